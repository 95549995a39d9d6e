"""``cut="auto"``: a cloud of any genus cut open along seams into a disk, mapped without a fold,
and packed into the unit square (a texture atlas).

1. **The mesh.** The cloud's repaired local mesh (:func:`pcgeom.maps.free.mesh_for`,
   :mod:`pcgeom.maps.topology`), its main part with one fan per vertex and the gaps that
   leaves filled (as for the sphere map, :func:`pcgeom.maps.sphere.closed_mesh`, but of any
   genus).
2. **Seams** (:mod:`pcgeom.maps.seams`): on a closed mesh of genus ``g >= 1``, the
   shorter of the tree-cotree cut graph and the one reduced from a greedy shortest homology
   basis (when that one's charts need slits or splits, the tree-cotree atlas is made too and
   the one with the shorter seams kept, :func:`pcgeom.maps.charts.fit_charts`); at genus 0,
   the shortest path between two far points; an open mesh with handles or several boundary
   loops, the tree-cotree paths from its boundary to its boundary (``2g + b - 1`` of them).
   An open mesh with one boundary loop and no handle is a disk already: no seam.
3. **The charts** (:mod:`pcgeom.maps.charts`): the cut mesh's free LSCM map (``igl.lscm``,
   two boundary vertices far apart pinned), mirrored if it came out clockwise, untangled
   (:func:`pcgeom.maps.injective.untangle`) where it turns triangles over. A chart whose
   scale-factor spread (95th over 5th percentile) passes ``max_stretch`` gets slits (seams
   from its boundary to its most shrunk or stretched point); one that overlaps itself is
   split in two, each part opened into a disk and mapped again; Tutte's embedding onto a
   circle is the last resort of a part that still overlaps.
4. **Packing.** One chart: turned to its principal axes, scaled uniformly into
   ``[gutter, 1 - gutter]^2`` and centred (:func:`pack_one`). Several: each at a median scale
   factor of 1, placed by ``xatlas``'s packer (one similarity per chart read from its output,
   applied to the float64 map), then scaled into the same square.
5. **Checks.** Flips: triangles of a chart with signed area ``<= 0``. Overlap: with no
   flip, a chart's map is one-to-one exactly when its boundary polygon is simple (the
   degree of the map is then 1 inside it), tested with shapely (:func:`boundary_simple`);
   :func:`overlap_area` measures the overlap of the triangles directly (their areas' sum
   less the area of their union); between charts, the outlines' intersections
   (:func:`pcgeom.maps.charts.charts_overlap`).

Every point of the cloud gets the atlas position of one of its copies (its chart: the one
copy's), the corners of every triangle their own uv (``corner_uv``: a seam vertex has one
uv per side).
"""

from __future__ import annotations

import time

import numpy as np

from ..errors import InputError
from ..mesh import boundary_loops, euler_characteristic, signed_areas
from .charts import charts_overlap, fit_charts, pack_charts

__all__ = ["OVERLAPS", "atlas_map", "chart_map", "pack_one", "boundary_simple", "overlap_area",
           "CUTS", "GUTTER", "MAX_STRETCH", "check_cut"]

CUTS = ("none", "auto")
"""The values of ``cut``: ``"none"`` (no seams, the default) or ``"auto"``."""

GUTTER = 0.02
"""The empty margin kept around the charts in the unit square (a fraction of its side)."""

MAX_STRETCH = 10.0
"""The default bound on a chart's scale-factor spread (95th over 5th percentile) for
``--max-stretch``: a chart over it gets slits, then is split (:mod:`pcgeom.maps.charts`)."""

SEAM_ROOTS = 32
"""Roots of the greedy homology basis (:func:`pcgeom.maps.seams.cut_graph`; 1: the one-root
tree-cotree cut alone). Measured (cut graph over sqrt(area), the same local meshes; 1 / 4 /
16 / 32 / 64 roots): genus-2 pretzel 5k 3.39 / 2.86 / 2.52 / 2.52 / 2.52, genus-4 5k 6.00 /
4.73 / 4.63 / 4.52 / 4.51, torus 5k 1.66 / 1.66 / 1.65 / 1.65 / 1.65; 32 roots take 0.4 s at
5k."""

GAP = 5
"""Boundary loops of at most this many points are gaps, always filled: a hole about one
spacing wide, which the sampling leaves (the repaired local meshes of 2k-point clouds with
holes of 14-24 points keep loops of 3-4 points besides them)."""

def check_cut(cut: str, max_stretch, domain_name: str) -> float:
    """Validate ``cut`` and ``max_stretch`` (before any work); returns the bound as a float.

    Raises
    ------
    InputError
        ``cut`` not in :data:`CUTS`; ``"auto"`` with a domain other than ``free``; a bound
        that is not a number above 1.
    """
    if cut not in CUTS:
        raise InputError(f"cut must be one of {', '.join(CUTS)}, got {cut!r}")
    try:
        bound = float(max_stretch)
    except (TypeError, ValueError):
        raise InputError(f"max-stretch must be a number above 1, got {max_stretch!r}") from None
    if not (np.isfinite(bound) and bound > 1.0):
        raise InputError(f"max-stretch must be a number above 1, got {max_stretch!r}")
    if cut == "auto" and domain_name != "free":
        raise InputError(f"--cut auto maps onto the free domain only (an atlas in the unit "
                         f"square), got --domain {domain_name}")
    return bound


def _mesh_of(Xn: np.ndarray, mesh) -> tuple[np.ndarray, np.ndarray]:
    """The main part of the local mesh with one fan per vertex and its gaps filled (as
    :func:`pcgeom.maps.sphere.closed_mesh`, any genus): point indices (K,), faces (M, 3) in
    them. Of the boundary loops, the ``k`` longest stay open, ``k`` the repaired topology's
    count (:attr:`pcgeom.maps.topology.Topology.boundary_loops`: 0 on a closed cloud), unless
    they have at most :data:`GAP` points; the others, gaps the fans leave, are closed by
    fans."""
    from ..mesh import close_loops, compact, one_fan
    from .localmesh import _submesh

    index, _, F = _submesh(Xn, mesh.faces, mesh.main)
    F = one_fan(F, 5)[0]
    measured = getattr(mesh, "topology", None)
    keep = 0 if measured is None else int(measured.boundary_loops)
    loops = sorted(boundary_loops(F), key=len, reverse=True)
    gaps = loops[keep:] + [loop for loop in loops[:keep] if len(loop) <= GAP]
    used, F = compact(close_loops(F, gaps))
    return index[used], F


def _seam_length(V: np.ndarray, F: np.ndarray, Fc: np.ndarray, origin: np.ndarray) -> float:
    """The length of the seams: half the charts' boundary length less the mesh's own (each
    seam edge is on the boundary of the cut mesh twice)."""
    def rim(P, faces):
        loops = boundary_loops(faces)
        return sum(float(np.linalg.norm(P[np.asarray(lp)] - P[np.roll(np.asarray(lp), -1)],
                                        axis=1).sum()) for lp in loops)

    return 0.5 * (rim(V[origin], Fc) - rim(V, F))


def _far_pair(V: np.ndarray, loop: np.ndarray) -> tuple[int, int]:
    """Two vertices of ``loop`` far apart: the farthest from its first vertex's farthest."""
    a = loop[np.argmax(np.linalg.norm(V[loop] - V[loop[0]], axis=1))]
    b = loop[np.argmax(np.linalg.norm(V[loop] - V[a], axis=1))]
    return int(a), int(b)


def chart_map(V: np.ndarray, F: np.ndarray) -> tuple[np.ndarray, dict]:
    """A map of the disk ``(V, F)`` that turns no triangle over: LSCM, then untangling.

    Returns
    -------
    U : (n, 2) float64
        The map, its triangles counter-clockwise (positive area) when ``flips`` is 0.
    info : dict
        ``lscm_flips`` (LSCM's triangles with area ``<= 0``), ``flips`` (the map's),
        ``untangled`` (whether :func:`pcgeom.maps.injective.untangle` ran).
    """
    import igl

    loops = boundary_loops(F)
    if len(loops) != 1:
        raise InputError(f"the cut mesh is not a disk ({len(loops)} boundary loops)")
    a, b = _far_pair(V, np.asarray(max(loops, key=len)))
    pins = np.array([a, b], dtype=np.int64)
    d = float(np.linalg.norm(V[a] - V[b]))
    pinned = np.array([[0.0, 0.0], [d, 0.0]])
    U = igl.lscm(np.ascontiguousarray(V), np.ascontiguousarray(F), pins, pinned)[0]
    U = np.asarray(U, dtype=np.float64)
    if signed_areas(U, F).sum() < 0:  # mirrored: flip v and keep the pins
        U[:, 1] *= -1.0
    info = {"lscm_flips": int((signed_areas(U, F) <= 0).sum()), "untangled": False}
    if info["lscm_flips"]:
        from .injective import untangle

        U, stats = untangle(V, F, U, pins)
        info.update(untangled=True, untangle_seconds=stats["seconds"])
    info["flips"] = int((signed_areas(U, F) <= 0).sum())
    return U, info


def pack_one(U: np.ndarray, gutter: float = GUTTER) -> np.ndarray:
    """One chart ``U`` (n, 2) turned to its principal axes (a rotation) and scaled uniformly
    into ``[gutter, 1 - gutter]^2``, centred."""
    C = U - U.mean(axis=0)
    _, _, Vt = np.linalg.svd(C, full_matrices=False)
    R = Vt.T
    if np.linalg.det(R) < 0:
        R[:, 1] *= -1.0
    C = C @ R
    lo, hi = C.min(axis=0), C.max(axis=0)
    s = (1.0 - 2.0 * gutter) / float((hi - lo).max())
    return (C - (lo + hi) / 2.0) * s + 0.5


def boundary_simple(U: np.ndarray, F: np.ndarray) -> bool:
    """Whether every boundary loop of the chart ``(U, F)`` is a simple polygon in the plane
    (shapely): with no flipped triangle, the chart's map is then one-to-one."""
    from shapely.geometry import LinearRing

    return all(LinearRing(U[np.asarray(loop)]).is_simple for loop in boundary_loops(F))


def overlap_area(U: np.ndarray, F: np.ndarray) -> float:
    """The area covered twice or more by the triangles ``U[F]``: the sum of their areas less
    the area of their union (shapely), as a fraction of the sum (0 for a one-to-one map,
    to rounding: about 1e-12)."""
    import shapely

    tris = shapely.polygons(np.concatenate([U[F], U[F][:, :1]], axis=1))
    total = float(np.abs(signed_areas(U, F)).sum())
    union = float(shapely.unary_union(tris).area)
    return max(total - union, 0.0) / total


def _vertex_scale(V: np.ndarray, U: np.ndarray, F: np.ndarray, n: int) -> np.ndarray:
    """Per vertex, ``sqrt(sum 3D areas / sum uv areas)`` of its triangles: the inverse
    conformal factor, lengths on the surface per unit of uv."""
    a3 = 0.5 * np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]), axis=1)
    a2 = np.abs(signed_areas(U, F))
    s3 = np.bincount(F.ravel(), np.repeat(a3, 3), minlength=n)
    s2 = np.bincount(F.ravel(), np.repeat(a2, 3), minlength=n)
    return np.sqrt(s3 / np.maximum(s2, 1e-300))


OVERLAPS = ("--cut auto: the atlas of this cloud is not one-to-one ({flips} triangles turned over, "
            "{share:.2f}% of its area covered twice) when every chart's splits are spent: map it "
            "without --cut")
"""The one-line error of an atlas that folds or overlaps (seen on open clouds whose repaired
local mesh keeps false holes and handles, each of which gets a seam)."""


def atlas_map(Xn: np.ndarray, normals: np.ndarray | None, config, *, progress: bool,
              outlier: np.ndarray | None = None, max_stretch: float = MAX_STRETCH,
              gutter: float = GUTTER) -> dict:
    """The atlas of a run with ``cut="auto"`` (steps 1-5 of the module).

    Returns
    -------
    dict
        ``uv`` (N, 2) in ``[0, 1]^2``, ``lambda_inv`` (N,), ``chart`` (N,) int64,
        ``faces`` (M, 3) rows of ``Xn``, ``corner_uv`` (M, 3, 2), ``record`` (the history
        record: the local mesh's, with ``seams`` (genus, loops, length), ``charts``,
        ``cut_euler`` and ``cut_loops`` (1 and 1: a disk), ``lscm_flips``, ``flips``,
        ``overlap`` (False when every chart's boundary is simple), ``overlap_area`` (the
        share of the charts' area covered twice, :func:`overlap_area`), ``stretch`` (the
        scale-factor spread, 95th over 5th percentile, per triangle), ``seam_length``
        (over the square root of the area), ``atlas_use``, ``max_stretch``).

    Raises
    ------
    InputError
        As :func:`pcgeom.maps.localmesh.mesh_cloud` (not a surface).

        The chart turns a triangle over or overlaps itself (its boundary is not simple: the
        free boundary of LSCM crossing itself, seen on open clouds whose repaired local mesh
        keeps false holes): :data:`OVERLAPS`.
    """
    from scipy.spatial import cKDTree

    from ..progress import log
    from .free import mesh_for
    from .sphere import mesh_topology

    t0 = time.perf_counter()
    mesh, normals, record = mesh_for(Xn, normals, config, progress=progress, outlier=outlier,
                                     closed=True)
    index, F = _mesh_of(Xn, mesh)
    V = Xn[index]
    charts, tally = fit_charts(V, F, max_stretch, roots=SEAM_ROOTS)
    bad = [c for c in charts if not c.info["ok"]]
    if bad:
        # An atlas that overlaps or folds cannot be right: an error, never a result.
        share = max(c.info["overlap_area"] for c in bad)
        raise InputError(OVERLAPS.format(flips=sum(c.info["flips"] for c in bad),
                                         share=100 * share))
    Us, packer = pack_charts(V, charts, gutter)
    between = charts_overlap(Us, charts) if len(charts) > 1 else 0.0
    if between > 1e-9:
        raise InputError(OVERLAPS.format(flips=0, share=100 * between))
    # The charts side by side as one cut mesh, its triangles in the mesh's order.
    offsets = np.cumsum([0] + [len(c.origin) for c in charts])
    Fc = np.zeros((len(F), 3), dtype=np.int64)
    for c, o in zip(charts, offsets):
        Fc[c.faces] = c.F + o
    origin = np.concatenate([c.origin for c in charts])
    label = np.concatenate([np.full(len(c.origin), k) for k, c in enumerate(charts)])
    U = np.concatenate(Us)
    Vc = V[origin]
    seam = _seam_length(V, F, Fc, origin)
    topo = mesh_topology(F)
    seams = {"genus": int(topo["genus"]), "loops": tally["loops"], "length": seam,
             "boundary_loops": int(topo["boundary_loops"]), "slits": tally["slits"],
             "splits": tally["splits"], "tutte": tally["tutte"], "cut": tally["cut"]}
    log(f"atlas: {len(charts)} chart(s), seams of length {seam:.3g}, packed by {packer}",
        enabled=progress)
    a3 = 0.5 * np.linalg.norm(np.cross(Vc[Fc[:, 1]] - Vc[Fc[:, 0]],
                                       Vc[Fc[:, 2]] - Vc[Fc[:, 0]]), axis=1)
    a2 = np.abs(signed_areas(U, Fc))
    ratio = np.sqrt(a2 / np.maximum(a3, 1e-300))
    p5, p95 = np.percentile(ratio[a3 > 0], [5, 95])
    # Each point: one copy's uv (the first), and its chart.
    first = np.full(len(V), -1, dtype=np.int64)
    first[origin[::-1]] = np.arange(len(origin))[::-1]
    uv = np.full((len(Xn), 2), np.nan)
    uv[index] = U[first]
    scale_c = _vertex_scale(Vc, U, Fc, len(Vc))
    lam = np.full(len(Xn), np.nan)
    lam[index] = scale_c[first]
    chart = np.zeros(len(Xn), dtype=np.int64)
    chart[index] = label[first]
    known = np.zeros(len(Xn), dtype=bool)
    known[index] = True
    if not known.all():  # points off the mesh: their nearest meshed point's
        near = np.flatnonzero(known)[cKDTree(Xn[known]).query(Xn[~known])[1]]
        uv[~known], lam[~known], chart[~known] = uv[near], lam[near], chart[near]
    flips = int(sum(c.info["flips"] for c in charts))
    record.update(kind="localmesh", onto="free", cut="auto", seams=seams, charts=len(charts),
                  cut_euler=euler_characteristic(Fc), cut_loops=len(boundary_loops(Fc)),
                  lscm_flips=int(sum(c.info["lscm_flips"] for c in charts)),
                  untangled=any(c.info["untangled"] for c in charts),
                  flips={"count": flips, "faces": int(len(Fc)), "rim": 0, "hole": 0,
                         "inside": flips},
                  overlap=between > 0,
                  overlap_area=max([between] + [c.info["overlap_area"] for c in charts]),
                  stretch=float(p95 / p5),
                  chart_stretch=float(max(c.info["spread"] for c in charts)),
                  seam_length=float(seam / np.sqrt(a3.sum())), packer=packer,
                  atlas_use=float(a2.sum()), max_stretch=float(max_stretch),
                  gutter=float(gutter), seconds=time.perf_counter() - t0)
    return {"uv": uv, "lambda_inv": lam, "chart": chart, "faces": index[F],
            "corner_uv": U[Fc], "record": record}
