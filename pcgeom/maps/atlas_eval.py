"""A cut map (``cut="auto"``) measured on a reference mesh: the true triangles inside charts,
those a seam crosses, scale-factor spread, seam length, flips, overlap, atlas use.

A point on a seam has one atlas position per side (``ParamResult.corner_uv`` of
``mesh_faces``). Each true triangle takes, of its points' positions, the combination with the
smallest uv perimeter (:func:`triangle_uv`): inside a chart that is the side it lies on. A
triangle whose best perimeter, over its 3D perimeter, is still more than
:data:`CROSSED_RATIO` times the median such ratio spans a seam: it is counted and left out of
the angle figure.
"""

from __future__ import annotations

import itertools

import numpy as np

from ..mesh import signed_areas
from ..metrics import angle_distortion

__all__ = ["triangle_uv", "cut_map_report", "same_seams_lscm", "CROSSED_RATIO"]

CROSSED_RATIO = 3.0
"""A true triangle whose best uv perimeter over its 3D perimeter exceeds this many times the
median is crossed by a seam (inside a chart the ratio varies with the scale factor, whose
spread over a chart is a few times at most on the measured surfaces)."""


def _copies(n: int, mesh_faces: np.ndarray, corner_uv: np.ndarray) -> tuple[np.ndarray, list]:
    """Each point's atlas positions: the first (N, 2) (NaN for points on no triangle), and for
    points with several, the list of them (dict point -> (k, 2))."""
    rows = np.asarray(mesh_faces, dtype=np.int64).ravel()
    U = np.asarray(corner_uv, dtype=np.float64).reshape(-1, 2)
    keys = np.unique(np.column_stack([rows, U]), axis=0)
    pt = keys[:, 0].astype(np.int64)
    first = np.full((n, 2), np.nan)
    start = np.r_[True, pt[1:] != pt[:-1]]
    first[pt[start]] = keys[start, 1:]
    counts = np.bincount(pt, minlength=n)
    many = {}
    bounds = np.flatnonzero(start)
    for s, e in zip(bounds, np.r_[bounds[1:], len(pt)]):
        if e - s > 1:
            many[int(pt[s])] = keys[s:e, 1:]
    return first, many if counts.max() > 1 else {}


def triangle_uv(P, faces, mesh_faces, corner_uv) -> tuple[np.ndarray, np.ndarray]:
    """The atlas positions of the corners of each true triangle, and which a seam crosses.

    Parameters
    ----------
    P : (N, 3) float64
        The reference mesh's vertices (one per row of the map).
    faces : (M, 3) int
        Its triangles.
    mesh_faces, corner_uv : (K, 3) int, (K, 3, 2) float64
        The cut map's local mesh and per-corner atlas positions.

    Returns
    -------
    T : (M, 3, 2) float64
        Each triangle's corners in the atlas (NaN where a point is on no local-mesh triangle).
    crossed : (M,) bool
        Spans a seam (or has a point off the local mesh).
    """
    P = np.asarray(P, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64)
    first, many = _copies(len(P), mesh_faces, corner_uv)
    T = first[faces]
    if many:
        seam = np.zeros(len(P), dtype=bool)
        seam[list(many)] = True
        for t in np.flatnonzero(seam[faces].any(axis=1)):
            options = [many.get(int(v), first[v][None]) for v in faces[t]]
            best, length = None, np.inf
            for combo in itertools.product(*options):
                c = np.array(combo)
                per = float(np.linalg.norm(c - np.roll(c, 1, axis=0), axis=1).sum())
                if per < length:
                    best, length = c, per
            T[t] = best
    p3 = np.linalg.norm(P[faces] - np.roll(P[faces], 1, axis=1), axis=2).sum(axis=1)
    p2 = np.linalg.norm(T - np.roll(T, 1, axis=1), axis=2).sum(axis=1)
    ratio = p2 / np.maximum(p3, 1e-300)
    crossed = ~np.isfinite(ratio)
    crossed |= ratio > CROSSED_RATIO * np.median(ratio[~crossed])
    return T, crossed


def cut_map_report(P, faces, result, *, overlap: bool = True) -> dict:
    """The figures of a cut map ``result`` (a :class:`pcgeom.io.ParamResult` with
    ``corner_uv``) on the reference mesh ``(P, faces)``.

    Returns
    -------
    dict
        ``mean_abs_angle_rad``, ``median_abs_angle_rad``, ``p95_abs_angle_rad``,
        ``max_abs_angle_rad``, ``flipped``, ``flipped_percent``, ``flipped_where`` and
        ``n_faces`` over the true triangles inside charts; ``seam_crossed`` (count) and
        ``seam_crossed_percent`` (of all ``n_true_faces``); ``stretch`` (95th over 5th
        percentile of the per-triangle scale factor ``sqrt(uv area / 3D area)`` inside charts);
        ``seam_length`` (over the square root of the area, the map's record); ``charts``;
        ``atlas_use`` (chart area over the unit square); ``overlap`` (the atlas triangles'
        area covered twice, a fraction: :func:`pcgeom.maps.atlas.overlap_area`; None when
        not asked).
    """
    from .atlas import overlap_area

    P = np.asarray(P, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64)
    T, crossed = triangle_uv(P, faces, result.mesh_faces, result.corner_uv)
    inside = ~crossed
    V = P[faces[inside]].reshape(-1, 3)
    F = np.arange(len(V)).reshape(-1, 3)
    U = T[inside].reshape(-1, 2)
    rep = angle_distortion(V, F, U)
    a3 = 0.5 * np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]), axis=1)
    a2 = np.abs(signed_areas(U, F))
    good = a3 > 0
    p5, p95 = np.percentile(np.sqrt(a2[good] / a3[good]), [5, 95])
    record = next((r for r in result.history if r.get("cut") == "auto"), {})
    C = result.corner_uv.reshape(-1, 2)
    CF = np.arange(len(C)).reshape(-1, 3)
    return {
        "mean_abs_angle_rad": rep.mean_abs, "median_abs_angle_rad": rep.median_abs,
        "p95_abs_angle_rad": rep.p95_abs, "max_abs_angle_rad": rep.max_abs,
        "flipped": rep.flipped, "n_faces": rep.n_faces,
        "flipped_percent": 100.0 * rep.flipped / max(rep.n_faces, 1),
        # A soup of triangles has no rim: every one left is inside a chart.
        "flipped_where": {"rim": 0, "hole": 0, "inside": rep.flipped},
        "n_true_faces": int(len(faces)), "seam_crossed": int(crossed.sum()),
        "seam_crossed_percent": 100.0 * float(crossed.mean()),
        "stretch": float(p95 / p5), "seam_length": record.get("seam_length"),
        "charts": int(result.chart.max()) + 1 if result.chart is not None else None,
        "atlas_use": float(np.abs(signed_areas(C, CF)).sum()),
        "overlap": overlap_area(C, CF) if overlap else None,
    }


def same_seams_lscm(P, faces, result) -> dict:
    """libigl's LSCM on the reference mesh ``(P, faces)`` cut along the cut map's own seams:
    the baseline of the angle figure.

    The true triangles a seam crosses (:func:`triangle_uv`) are left out; two of the others
    share a vertex where they give a point the same atlas position (a seam point's sides
    differ) and are joined across an edge, so the mesh falls into the map's charts, slits
    open. Each part: ``igl.lscm``
    with two far boundary vertices pinned (the free-boundary minimizer up to a similarity).

    Returns
    -------
    dict
        ``mean_abs_angle_rad``, ``flipped``, ``n_faces``, ``parts``, ``skipped`` (triangles
        of parts libigl's solve fails on, left out).
    """
    import igl
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    from ..mesh import boundary_loops

    P = np.asarray(P, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64)
    T, crossed = triangle_uv(P, faces, result.mesh_faces, result.corner_uv)
    F = faces[~crossed]
    keys = np.column_stack([F.reshape(-1, 1).astype(np.float64), T[~crossed].reshape(-1, 2)])
    _, ids = np.unique(keys, axis=0, return_inverse=True)
    Fc = ids.reshape(-1, 3)
    origin = np.zeros(int(Fc.max()) + 1, dtype=np.int64)
    origin[Fc.ravel()] = F.ravel()
    # Points the left-out triangles pinch (two fans meeting at one point) split, as the map's
    # own charts are: libigl's solve fails on such a part.
    from ..mesh import unique_edges
    from .seams import cut_open

    E = unique_edges(Fc)
    Fc, o = cut_open(Fc, E, np.zeros(len(E), dtype=bool), len(origin))
    origin = origin[o]
    n = len(origin)
    A = coo_matrix((np.ones(2 * len(Fc)), (np.r_[Fc[:, 0], Fc[:, 1]], np.r_[Fc[:, 1], Fc[:, 2]])),
                   shape=(n, n))
    count, label = connected_components(A, directed=False)
    Vc = P[origin]
    U = np.zeros((n, 2))
    skipped = np.zeros(len(Fc), dtype=bool)
    for c in range(count):
        sub = np.flatnonzero(label[Fc[:, 0]] == c)
        used, Fs = np.unique(Fc[sub], return_inverse=True)
        Fs = Fs.reshape(-1, 3)
        loop = np.asarray(max(boundary_loops(Fs), key=len))
        V = Vc[used]
        a = loop[np.argmax(np.linalg.norm(V[loop] - V[loop[0]], axis=1))]
        b = loop[np.argmax(np.linalg.norm(V[loop] - V[a], axis=1))]
        d = float(np.linalg.norm(V[a] - V[b]))
        try:
            if a == b or d <= 0:
                raise RuntimeError("no two distinct pins")
            Us = igl.lscm(np.ascontiguousarray(V), np.ascontiguousarray(Fs),
                          np.array([a, b], dtype=np.int64), np.array([[0.0, 0.0], [d, 0.0]]))[0]
        except RuntimeError:  # a part libigl cannot solve (a sliver): left out, counted
            skipped[sub] = True
            continue
        Us = np.asarray(Us, dtype=np.float64)
        if signed_areas(Us, Fs).sum() < 0:
            Us[:, 1] *= -1.0
        U[used] = Us
    rep = angle_distortion(Vc, Fc[~skipped], U)
    return {"mean_abs_angle_rad": rep.mean_abs, "flipped": rep.flipped,
            "n_faces": rep.n_faces, "parts": int(count), "skipped": int(skipped.sum())}
