"""The charts of a cut map: pieces of the mesh opened into disks, each mapped without a fold
or an overlap within the scale-factor bound, packed into the unit square.

A **piece** is a connected part of the mesh cut open (:class:`Piece`: its triangles' rows in
the mesh, its own triangles and the mesh vertex of each of its vertices). :func:`fit_charts`
takes the whole mesh as one piece and, recursively:

1. **Opens it into a disk** when it is not one (:func:`pcgeom.maps.seams.cut_graph`: the
   tree-cotree seams of a closed piece, the paths from boundary to boundary of an open one).
2. **Maps it** (:func:`pcgeom.maps.atlas.chart_map`: LSCM, untangled where it flips) and
   measures its **spread**, the 95th over the 5th percentile of the per-triangle scale factor
   ``sqrt(uv area / 3D area)``.
3. A chart with no flip, a simple boundary and a spread within the bound (``max_stretch``) is
   kept. One over the bound is first mapped again with its scale bounded
   (:func:`pcgeom.maps.chart_scale.bound_scale`, kept by :func:`_bounded` when it is within the
   bound, with no flip, at little cost in angle: no seam added). A chart whose boundary
   crosses itself in small lobes (at most :data:`PINCH` of its area) is made one-to-one onto
   the outline of what it covers (:func:`pcgeom.maps.chart_scale.onto_outline`, the barrier
   map), kept when that is within the bound at little cost in angle; one whose lobes cover
   more (at most :data:`LOBES`), or that the outline leaves crossing, is made one-to-one on
   a patch around its lobes only (:func:`_lobes`, :mod:`pcgeom.maps.chart_lobes`). One
   still over the bound gets a **slit** (up to :data:`SLITS` per chart): a seam along the
   shortest path from its boundary to the vertex whose scale factor is farthest from the
   median (in log: the tip of a finger the conformal map shrinks), then is mapped again (the
   cone-and-cut idea of OptCuts and Boundary First Flattening, with the cut ending at the
   worst point), kept when it divides the spread by :data:`SLIT_GAIN`. A chart that folds or
   overlaps itself, or whose slits are spent or do not pay, is **split**
   in two (up to :data:`DEPTH` times): triangles nearer one of two far vertices (distance
   along the mesh) than the other, each part's connected pieces mapped from step 1.

:func:`pack_charts` places the charts in ``[0, 1]^2``: each scaled to a median scale factor
of 1 (even texel density), then ``xatlas``'s packer (bitmaps of the charts, tried at many
places and turns: tight and free of overlap by construction, with a gutter of
:data:`PADDING` texels); its float32 output is only read back as one similarity per chart,
fitted to the chart's float64 map and applied to it, so each chart keeps its exact shape. One
chart is placed by :func:`pcgeom.maps.atlas.pack_one` (no packer needed).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components, dijkstra

from ..errors import InputError
from ..mesh import boundary_loops, euler_characteristic, signed_areas, unique_edges
from .seams import cut_graph, cut_open

__all__ = ["Piece", "Chart", "fit_charts", "pack_charts", "spread", "charts_overlap",
           "SLITS", "DEPTH", "TOUCH", "PADDING", "RESOLUTION", "PINCH",
           "OUTLINE_TRIES", "LOBES", "LOBE_COST"]

SLITS = 6
"""Slits a chart over the bound gets before it is split instead."""

SMOOTH = 3
"""Rounds of majority smoothing of a split's two sides."""

SLIT_GAIN = 1.25
"""A slit is kept when it divides the chart's spread by at least this much (or leaves a chart
that overlaps, which is then split); otherwise the chart before it is split instead (a slit to the
shrunk tip of a finger divides it by
hundreds; on a long chart with no tip, slits hardly change it)."""

DEPTH = 6
"""Times a chart is split in two at most (up to 64 charts)."""

PADDING = 4
"""xatlas's gutter between charts, in texels of a :data:`RESOLUTION`-texel atlas."""

TOUCH = 1e-9
"""A chart whose triangles cover at most this share of its area twice (the two sides of a
seam crossing by rounding) is one-to-one; more is an overlap."""

PINCH = 1e-3
"""A chart whose boundary crosses itself over at most this share of its area (the lobes a
conformal map pinches where it shrinks most: 1.7e-4 to 8.8e-4 on the pretzels of genus 3-4)
is made one-to-one without a seam (:func:`_outline`); more (the finger's 4e-3 and 1.7e-2)
is split."""

LOBES = 3e-3
"""A chart whose boundary crosses itself over at most this share of its area, and that
:func:`_outline` leaves crossing (or does not try: over :data:`PINCH`), is made one-to-one
around its lobes only (:func:`_lobes`): the genus-4 pretzel's one chart at 50k points,
1.7e-3. More is split."""

LOBE_COST = 1.35
""":func:`_lobes`'s result is kept when its mean conformal distortion is at most this many
times LSCM's (issue 38 allows 1.5x libigl's LSCM on the same seams). Squeezing a lobe into
the outline costs angle where the chart shrinks most: genus-4 pretzel 50k, its one chart,
1.08x (the bounded map) -> 1.33x; the split it saves added 0.57 sqrt(A) of seam."""

OUTLINE_TRIES = 3
"""Charts of one atlas that :func:`_outline` tries (a barrier map each, 1-9 s at 5k-20k
points); the later ones are split as before. The pretzels need one; face_human_choi, whose
repaired local mesh keeps false holes and handles, tried 21 (none kept) in 49 of its 69 s.
:func:`_lobes` has as many tries of its own."""

RESOLUTION = 1024
"""The side, in texels, of the atlas xatlas packs."""


@dataclasses.dataclass
class Piece:
    """A connected part of the mesh, cut open."""

    faces: np.ndarray
    """(m,) int64 rows of the mesh's triangles."""
    F: np.ndarray
    """(m, 3) int64 its triangles in its own vertices."""
    origin: np.ndarray
    """(k,) int64 the mesh vertex of each of its vertices."""


@dataclasses.dataclass
class Chart(Piece):
    """A piece mapped: ``U`` (k, 2), and ``info`` (``flips``, ``simple``, ``spread``,
    ``slits``, ``lscm_flips``, ``untangled``)."""

    U: np.ndarray = None
    info: dict = None


def _areas3(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    return 0.5 * np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]),
                                axis=1)


def spread(V: np.ndarray, U: np.ndarray, F: np.ndarray) -> float:
    """The 95th over the 5th percentile of the per-triangle scale factor
    ``sqrt(|uv area| / 3D area)`` of the map ``U`` of ``(V, F)``."""
    a3 = _areas3(V, F)
    good = a3 > 0
    r = np.sqrt(np.abs(signed_areas(U, F))[good] / a3[good])
    p5, p95 = np.percentile(r, [5, 95])
    return float(p95 / max(p5, 1e-300))


def _is_disk(F: np.ndarray) -> bool:
    return euler_characteristic(F) == 1 and len(boundary_loops(F)) == 1


def _parts(piece: Piece, cut: np.ndarray | None = None, E: np.ndarray | None = None
           ) -> list[Piece]:
    """``piece`` cut open along ``E[cut]`` (none: only its pinched vertices split), as its
    connected parts."""
    n = len(piece.origin)
    if E is None:
        E = unique_edges(piece.F)
        cut = np.zeros(len(E), dtype=bool)
    Fc, o = cut_open(piece.F, E, cut, n)
    k = int(Fc.max()) + 1
    rows = np.r_[Fc[:, 0], Fc[:, 1]]
    cols = np.r_[Fc[:, 1], Fc[:, 2]]
    graph = sp.coo_matrix((np.ones(len(rows), dtype=np.int8), (rows, cols)), shape=(k, k))
    count, label = connected_components(graph, directed=False)
    face_label = label[Fc[:, 0]]
    out = []
    for c in range(count):
        rows_c = np.flatnonzero(face_label == c)
        used = np.unique(Fc[rows_c])
        renumber = np.full(k, -1, dtype=np.int64)
        renumber[used] = np.arange(len(used))
        out.append(Piece(piece.faces[rows_c], renumber[Fc[rows_c]], piece.origin[o[used]]))
    return out


def _disk(V: np.ndarray, piece: Piece, roots: int, tally: dict) -> Piece:
    """``piece`` opened into a disk by :func:`pcgeom.maps.seams.cut_graph` (itself if it is
    one); its loops or paths counted in ``tally["loops"]``."""
    if _is_disk(piece.F):
        return piece
    E, cut, info = cut_graph(V[piece.origin], piece.F, roots=roots)
    tally["loops"] += int(info["loops"])
    tally["short"] = tally.get("short", 0) + (info.get("method") == "homology basis")
    parts = _parts(piece, cut, E)
    if len(parts) != 1 or not _is_disk(parts[0].F):
        raise InputError("--cut auto: the seams do not open this cloud's local mesh into "
                         f"disks ({len(parts)} part(s), Euler characteristic "
                         f"{euler_characteristic(parts[0].F)})")
    return parts[0]


def _graph(P: np.ndarray, F: np.ndarray) -> tuple[np.ndarray, sp.csr_matrix]:
    E = unique_edges(F)
    w = np.maximum(np.linalg.norm(P[E[:, 0]] - P[E[:, 1]], axis=1), 1e-12)
    n = len(P)
    G = sp.coo_matrix((np.r_[w, w], (np.r_[E[:, 0], E[:, 1]], np.r_[E[:, 1], E[:, 0]])),
                      shape=(n, n)).tocsr()
    return E, G


def _vertex_log_scale(P, U, F) -> np.ndarray:
    a3 = np.bincount(F.ravel(), np.repeat(_areas3(P, F), 3), minlength=len(P))
    a2 = np.bincount(F.ravel(), np.repeat(np.abs(signed_areas(U, F)), 3), minlength=len(P))
    return 0.5 * np.log(np.maximum(a2, 1e-300) / np.maximum(a3, 1e-300))


def _slit(V: np.ndarray, chart: Chart) -> Piece | None:
    """``chart`` with a seam along the shortest path from its boundary to its inner vertex
    whose log scale factor is farthest from the median; None when every vertex is on the
    boundary."""
    P, F = V[chart.origin], chart.F
    on_rim = np.zeros(len(P), dtype=bool)
    on_rim[np.concatenate([np.asarray(loop) for loop in boundary_loops(F)])] = True
    if on_rim.all():
        return None
    s = _vertex_log_scale(P, chart.U, F)
    far = np.abs(s - np.median(s))
    far[on_rim] = -1.0
    target = int(np.argmax(far))
    E, G = _graph(P, F)
    _, pred, _ = dijkstra(G, indices=np.flatnonzero(on_rim), min_only=True,
                          return_predecessors=True)
    n = len(P)
    keys = E[:, 0] * n + E[:, 1]
    cut = np.zeros(len(E), dtype=bool)
    v = target
    while pred[v] >= 0:
        a, b = min(v, int(pred[v])), max(v, int(pred[v]))
        cut[np.searchsorted(keys, a * n + b)] = True
        v = int(pred[v])
    parts = _parts(chart, cut, E)
    return parts[0] if len(parts) == 1 and _is_disk(parts[0].F) else None


def _glue(V: np.ndarray, piece: Piece) -> Piece:
    """``piece`` with the seams inside it glued back where it stays a disk without them: a
    split leaves in each part seams that both of their sides now lie in, some of which the
    part no longer needs (a path that joined the cut graph to a handle the split has cut);
    each glued seam is shorter seams and one crack fewer for the map to open. Chains of seam
    (between vertices where three or more seam edges meet, or one) are tried longest first,
    each kept glued when the part stays one disk."""
    from ..mesh import half_edges, twin_pairs
    from .seams import _chains

    n, m = len(V), len(piece.F)
    G = piece.origin[piece.F]  # the part's triangles in the mesh's vertices
    E = unique_edges(G)
    he_mesh, he_own = half_edges(G), half_edges(piece.F)
    keys = np.minimum(he_mesh[:, 0], he_mesh[:, 1]) * n + np.maximum(he_mesh[:, 0],
                                                                      he_mesh[:, 1])
    eid = np.searchsorted(E[:, 0] * n + E[:, 1], keys)
    h1, h2 = twin_pairs(G)
    # An edge inside the part is a seam when its two triangles do not share its ends there.
    seam = np.zeros(len(E), dtype=bool)
    seam[eid[h1]] = (he_own[h1, 0] != he_own[h2, 1]) | (he_own[h1, 1] != he_own[h2, 0])
    if not seam.any():
        return piece
    length = np.linalg.norm(V[E[:, 0]] - V[E[:, 1]], axis=1)
    best = None
    changed = True
    while changed and seam.any():
        changed = False
        chain, count = _chains(E, seam, n)
        rows = np.flatnonzero(seam)
        for c in np.argsort(-np.bincount(chain, length[rows], minlength=count), kind="stable"):
            trial = seam.copy()
            trial[rows[chain == c]] = False
            Fc, o = cut_open(G, E, trial, n)
            if _is_disk(Fc) and connected_components(sp.coo_matrix(
                    (np.ones(2 * m), (np.r_[Fc[:, 0], Fc[:, 1]], np.r_[Fc[:, 1], Fc[:, 2]])),
                    shape=(len(o), len(o))), directed=False)[0] == 1:
                seam, best, changed = trial, (Fc, o), True
                break
    if best is None:
        return piece
    return Piece(piece.faces, best[0], best[1])


def _split(V: np.ndarray, piece: Piece) -> list[Piece]:
    """``piece`` in two, across its shortest cut among level sets of ``d_a - d_b`` (``d``:
    distance along the mesh from two far vertices ``a`` and ``b``; levels at the 25th to
    75th percentiles over the triangles), its triangles' sides then smoothed (each takes the
    side of most of itself and its neighbours, :data:`SMOOTH` rounds: a cut along triangle
    sides zigzags); the connected parts of each side."""
    from ..mesh import half_edges, twin_pairs

    P, F = V[piece.origin], piece.F
    E, G = _graph(P, F)
    a = int(np.argmax(dijkstra(G, indices=0)))
    da = dijkstra(G, indices=a)
    b = int(np.argmax(da))
    db = dijkstra(G, indices=b)
    level = (da - db)[F].mean(axis=1)
    n, m = len(P), len(F)
    he = half_edges(F)
    k = np.minimum(he[:, 0], he[:, 1]) * n + np.maximum(he[:, 0], he[:, 1])
    eid = np.searchsorted(E[:, 0] * n + E[:, 1], k)
    h1, h2 = twin_pairs(F)
    f1, f2, inner = h1 % m, h2 % m, eid[h1]
    length = np.linalg.norm(P[E[:, 0]] - P[E[:, 1]], axis=1)
    A = sp.coo_matrix((np.ones(2 * len(f1)), (np.r_[f1, f2], np.r_[f2, f1])), shape=(m, m)
                      ).tocsr() + sp.identity(m, format="csr")
    best = None
    for q in np.quantile(level, np.linspace(0.25, 0.75, 11)):
        side = level < q
        for _ in range(SMOOTH):
            side = (A @ side.astype(np.float64)) * 2 > A.sum(axis=1).A1
        if side.all() or not side.any():
            continue
        crossed = np.zeros(len(E), dtype=bool)
        crossed[inner[side[f1] != side[f2]]] = True
        cost = float(length[crossed].sum())
        if best is None or cost < best[0]:
            best = (cost, side)
    side = best[1] if best is not None else np.arange(m) < m // 2
    cut = np.zeros(len(E), dtype=bool)
    cut[inner[side[f1] != side[f2]]] = True
    return _parts(piece, cut, E)


def _map(V: np.ndarray, piece: Piece, slits: int, bound: float = np.inf, *,
         outline: bool = False, lobes: bool = False) -> Chart:
    from .atlas import boundary_simple, chart_map, overlap_area

    P, F = V[piece.origin], piece.F
    U, info = chart_map(P, F)
    U, info = _bounded(P, F, U, dict(info, bounded=False, outline=False, lobes=False), bound)
    simple = bool(boundary_simple(U, F))
    info["outline_tried"] = info["lobes_tried"] = False
    crossed = None  # the share covered twice, measured once where it is needed
    if (outline or lobes) and not simple and not info["flips"]:
        crossed = overlap_area(U, F)
        if outline and crossed <= PINCH:
            U, info, simple = _outline(P, F, U, info, bound)
        if lobes and not simple and crossed <= LOBES:
            U, info, simple = _lobes(P, F, U, info, bound)
    # A seam whose two sides the map keeps together (a slit across a smooth part, a path to
    # a small hole) touches itself: its sides may cross by rounding, no more.
    if simple:
        covered = 0.0
    elif crossed is not None and not info["outline"] and not info["lobes"]:
        covered = crossed  # the map it was measured on
    else:
        covered = overlap_area(U, F)
    info = dict(info, simple=simple, overlap_area=covered, slits=slits, spread=spread(P, U, F))
    info["ok"] = info["flips"] == 0 and covered < TOUCH
    return Chart(piece.faces, piece.F, piece.origin, U, info)


def _bounded(P: np.ndarray, F: np.ndarray, U: np.ndarray, info: dict, bound: float
             ) -> tuple[np.ndarray, dict]:
    """``U`` (LSCM), or when its spread passes ``bound`` the scale-bounded map
    (:func:`pcgeom.maps.chart_scale.bound_scale`) if that one has no flip, a spread within the
    bound and a conformal distortion at most :data:`pcgeom.maps.chart_scale.ANGLE_COST` times
    ``U``'s (``info["bounded"]`` says which; ``info["conformal"]``: ``U``'s).

    The map returned is the start of :func:`_outline` and :func:`_lobes` too. A bounded map
    dropped on angle is no start for them: they add angle, and keep nothing over
    ``ANGLE_COST`` (:func:`_outline`) or :data:`LOBE_COST` times LSCM's (pretzel g4 20k,
    before the accelerated rounds: its bounded start 1.26x, onto the outline 1.22x; at 50k
    a bounded start of 1.45x, whose barrier map took 48 s to fail). Measured on
    face_human_choi (``--cut auto``): the bounded maps of 7 of its 59 maps were dropped on
    angle, six at 1.49-2.31x LSCM's and one at 1.34x, each crossing itself over 0.6-12% of
    its area (more than :data:`LOBES`, which :func:`_lobes` is not tried on)."""
    from .chart_scale import ANGLE_COST, FOLDS, bound_scale, conformal_distortion, unfold_locally

    info = dict(info, conformal=conformal_distortion(P, U, F))
    if info["flips"] or not np.isfinite(bound) or spread(P, U, F) <= bound:
        return U, info
    W = bound_scale(P, F, U, bound, unfold=False)
    # Judged before its folds are unfolded (the costly part), and again after.
    folds = int((signed_areas(W, F) <= 0).sum())
    if folds > FOLDS * len(F) or spread(P, W, F) > bound:
        return U, info
    if folds:
        W = unfold_locally(P, F, W)
        if (signed_areas(W, F) <= 0).any() or spread(P, W, F) > bound:
            return U, info
    if conformal_distortion(P, W, F) > ANGLE_COST * info["conformal"]:
        return U, info
    return W, dict(info, bounded=True)


def _outline(P: np.ndarray, F: np.ndarray, U: np.ndarray, info: dict, bound: float
             ) -> tuple[np.ndarray, dict, bool]:
    """A chart whose boundary crosses itself made one-to-one without a seam
    (:func:`pcgeom.maps.chart_scale.onto_outline` from ``U``, the map :func:`_bounded` kept),
    kept when it has no flip, a simple boundary, a conformal distortion at most
    ``ANGLE_COST`` times LSCM's and a spread within ``bound`` (a chart that needs no more
    seams: one still over the bound is slit or split as before, which leaves the finger as it
    was); else ``U`` as it was. Returns the map, its info (``outline``: kept) and whether its
    boundary is simple."""
    from .atlas import boundary_simple
    from .chart_scale import ANGLE_COST, conformal_distortion, onto_outline

    if spread(P, U, F) > bound:  # the outline keeps its shape: it would stay over
        return U, info, False
    info = dict(info, outline_tried=True)
    X = onto_outline(P, F, U)
    if X is None or not boundary_simple(X, F):
        return U, info, False
    if conformal_distortion(P, X, F) > ANGLE_COST * info["conformal"] or \
            spread(P, X, F) > bound:
        return U, info, False
    return X, dict(info, outline=True), True


def _lobes(P: np.ndarray, F: np.ndarray, U: np.ndarray, info: dict, bound: float
           ) -> tuple[np.ndarray, dict, bool]:
    """A chart whose boundary crosses itself made one-to-one around its lobes only
    (:func:`pcgeom.maps.chart_lobes.unfold_lobes`: the barrier map onto the outline on a
    patch around them, of each size of :data:`pcgeom.maps.chart_lobes.LOBE_RINGS` in turn
    while the last was one-to-one), the first kept when it has no flip, a simple boundary, a
    spread within ``bound`` and a conformal distortion at most :data:`LOBE_COST` times
    LSCM's; else ``U`` as it was. Returns the map, its info (``lobes``: kept) and whether
    its boundary is simple."""
    from .atlas import boundary_simple
    from .chart_lobes import LOBE_RINGS, unfold_lobes
    from .chart_scale import conformal_distortion

    if spread(P, U, F) > bound:  # the patch keeps the chart's scale: it would stay over
        return U, info, False
    info = dict(info, lobes_tried=True)
    for rings in LOBE_RINGS:
        X = unfold_lobes(P, F, U, rings=rings)
        if X is None or (signed_areas(X, F) <= 0).any() or not boundary_simple(X, F):
            # A larger patch is tried only for a lower angle cost (face_human_choi: three
            # charts of 9 small crossings each, no patch one-to-one; 13 s for both sizes).
            break
        if conformal_distortion(P, X, F) <= LOBE_COST * info["conformal"] and \
                spread(P, X, F) <= bound:
            return X, dict(info, lobes=True), True
    return U, info, False


def _tutte(V: np.ndarray, chart: Chart) -> Chart:
    """``chart`` mapped by Tutte's embedding, its boundary on a circle by arc length
    (:func:`pcgeom.maps.injective.tutte.tutte_fill`, mean-value weights: one-to-one, the
    last resort of a chart that still folds or overlaps when its splits are spent).

    face_human_choi (measured, not kept): its 8 Tutte charts turn 362 true triangles over,
    its uncut free map 289 of the same (in one chart 136 against 135, in another 67 against
    34). The uncut map cannot stand in for them: on 7 of the 8 pieces it turns 2-22 of their
    own triangles over or its boundary crosses itself. The barrier map from this one onto
    its circle (boundary sliding): 362 -> 348, spreads up to 311. Nor is it a cloud that
    needs no seam: its free map's spread over the true triangles is 12.8 (libigl's LSCM on
    its true mesh 15.2), the shrunk 5% in three mirrored pairs of clusters (by their places
    nostrils, mouth and eye corners) 5-40 spacings from the local mesh's false holes."""
    from .injective.tutte import tutte_fill

    P, F = V[chart.origin], chart.F
    loop = np.asarray(boundary_loops(F)[0])
    step = np.linalg.norm(P[np.roll(loop, -1)] - P[loop], axis=1)
    t = 2 * np.pi * np.r_[0.0, np.cumsum(step)[:-1]] / max(float(step.sum()), 1e-300)
    r = float(step.sum()) / (2 * np.pi)
    for sign in (1.0, -1.0):
        U = tutte_fill(P, F, loop, r * np.column_stack([np.cos(t), sign * np.sin(t)]))
        if signed_areas(U, F).sum() > 0:
            break
    flips = int((signed_areas(U, F) <= 0).sum())
    info = dict(chart.info, flips=flips, simple=True, overlap_area=0.0, tutte=True,
                spread=spread(P, U, F), ok=flips == 0)
    return Chart(chart.faces, F, chart.origin, U, info)


def fit_charts(V: np.ndarray, F: np.ndarray, max_stretch: float, *, roots: int = 1,
               slits: int = SLITS, depth: int = DEPTH) -> tuple[list[Chart], dict]:
    """The charts of the mesh ``(V, F)`` (steps 1-3 of the module), and a tally: ``loops``
    (the tree-cotree loops or paths that opened pieces into disks), ``slits``, ``splits``,
    ``tutte`` (charts mapped by :func:`_tutte`), ``short`` (pieces opened by the short
    cut graph), ``seam_length`` (the seams' length, in the
    units of ``V``), ``cut`` (the cut graph that gave them: ``"short"`` or
    ``"tree-cotree"``).

    The pieces are opened by the shortest cut graph :func:`pcgeom.maps.seams.cut_graph`
    finds from ``roots`` roots; when its charts need slits or splits (a short cut leaves more
    area distortion), the charts from the one-root tree-cotree cut are made too and the
    atlas with the shorter seams (slits and splits counted) is kept; not made when the
    tree-cotree cut graph alone is already as long as the short atlas's seams (the pretzels
    of genus 3 and 4: their short atlases need splits, yet stay shorter than that cut).

    Each chart's ``info["ok"]`` says it has no flip and a simple boundary; its spread may stay
    over ``max_stretch`` when its slits and splits are spent (``info["spread"]``).
    """
    whole = Piece(np.arange(len(F)), np.asarray(F, dtype=np.int64),
                  np.arange(len(V), dtype=np.int64))
    pieces = _parts(whole)
    own = _rim_length(V, whole)
    best = None
    for r in dict.fromkeys([max(int(roots), 1), 1]):
        if best is not None and best[1]["seam_length"] <= _tree_cotree_length(V, pieces):
            break  # the tree-cotree cut alone is as long as the short atlas's seams
        out, tally = _fit(V, pieces, max_stretch, roots=r, slits=slits, depth=depth)
        tally["seam_length"] = sum(_rim_length(V, c) for c in out) / 2 - own / 2
        tally["cut"] = "short" if tally["short"] else "tree-cotree"
        if best is None or tally["seam_length"] < best[1]["seam_length"]:
            best = (out, tally)
        if not tally["short"] or not (tally["slits"] or tally["splits"] or tally["tutte"]):
            break
    return best


def _tree_cotree_length(V: np.ndarray, pieces: list[Piece]) -> float:
    """The length of the one-root tree-cotree cut graphs of the pieces that are not disks:
    what the tree-cotree atlas's seams start from (its slits and splits add to it)."""
    return sum(cut_graph(V[p.origin], p.F)[2]["length"] for p in pieces if not _is_disk(p.F))


def _rim_length(V: np.ndarray, piece: Piece) -> float:
    """The length of the boundary loops of ``piece``."""
    P = V[piece.origin]
    return sum(float(np.linalg.norm(P[np.asarray(lp)] - P[np.roll(np.asarray(lp), -1)],
                                    axis=1).sum()) for lp in boundary_loops(piece.F))


def _fit(V: np.ndarray, pieces: list[Piece], max_stretch: float, *, roots: int, slits: int,
         depth: int) -> tuple[list[Chart], dict]:
    """:func:`fit_charts` with the pieces opened by the cut graph from ``roots`` roots."""
    tally = {"loops": 0, "slits": 0, "splits": 0, "tutte": 0, "short": 0, "bounded": 0,
             "outlines": 0, "outline_tries": 0, "lobes": 0, "lobe_tries": 0}
    out: list[Chart] = []
    # (piece, splits above it, slits in it, the chart before its last slit)
    work = [(p, 0, 0, None) for p in pieces]
    while work:
        piece, level, cuts, before = work.pop()
        chart = _map(V, _disk(V, piece, roots, tally), cuts, max_stretch,
                     outline=tally["outline_tries"] < OUTLINE_TRIES,
                     lobes=tally["lobe_tries"] < OUTLINE_TRIES)
        tally["outline_tries"] += chart.info["outline_tried"]
        tally["lobe_tries"] += chart.info["lobes_tried"]
        tally["bounded"] += chart.info["bounded"]
        tally["outlines"] += chart.info["outline"]
        tally["lobes"] += chart.info["lobes"]
        ok = chart.info["ok"]
        if before is not None and ok and chart.info["spread"] * SLIT_GAIN \
                > before.info["spread"]:
            # The slit did not pay: the chart before it is split instead.
            tally["slits"] -= 1
            chart, ok, cuts = before, True, slits
        if ok and chart.info["spread"] <= max_stretch:
            out.append(chart)
            continue
        if ok and cuts < slits:
            slit = _slit(V, chart)
            if slit is not None:
                work.append((slit, level, cuts + 1, chart))
                tally["slits"] += 1
                continue
        if level < depth and len(chart.F) > 1:
            work.extend((_glue(V, p), level + 1, 0, None) for p in _split(V, chart))
            tally["splits"] += 1
            continue
        if not ok:
            chart = _tutte(V, chart)
            tally["tutte"] += 1
        out.append(chart)
    return out, tally


def _similarity(z: np.ndarray, w: np.ndarray) -> tuple[complex, complex, float]:
    """The map ``w ~ a z + b`` (complex: a turn and a scale, then a shift) nearest ``w`` in
    least squares, and its largest residual."""
    zc, wc = z - z.mean(), w - w.mean()
    a = complex((wc * np.conj(zc)).sum() / max(float((np.abs(zc) ** 2).sum()), 1e-300))
    b = complex(w.mean() - a * z.mean())
    return a, b, float(np.abs(a * z + b - w).max())


def _hull(U: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The convex hull of ``U`` as a fan of triangles: its corners (rows of ``U``) and the
    fan in them."""
    from scipy.spatial import ConvexHull

    corners = ConvexHull(U).vertices  # counter-clockwise
    k = len(corners)
    return corners, np.column_stack([np.zeros(k - 2, dtype=np.int64), np.arange(1, k - 1),
                                     np.arange(2, k)])


def _xatlas(charts: list[np.ndarray], Fs: list[np.ndarray]) -> list[np.ndarray] | None:
    """The charts moved by xatlas's packer: one similarity each, fitted to its float32
    output. A chart xatlas does not move by a similarity (it re-flattens charts whose
    triangles touch, as the two sides of a slit do) is given to it again as its convex hull.
    None when that fails too, or the charts take several atlases."""
    import xatlas

    from ..progress import log

    rows_of = [np.arange(len(U)) for U in charts]
    proxies = [(U, F) for U, F in zip(charts, Fs)]
    for _ in range(2):
        offsets = np.cumsum([0] + [len(P) for P, _ in proxies])
        atlas = xatlas.Atlas()
        atlas.add_uv_mesh(np.concatenate([P for P, _ in proxies]).astype(np.float32),
                          np.concatenate([F + o for (_, F), o in zip(proxies, offsets)]
                                         ).astype(np.uint32))
        pack = xatlas.PackOptions()
        pack.padding = PADDING
        pack.resolution = RESOLUTION
        pack.bruteForce = False  # brute force: 0.6 s -> 100 s on three charts of 2k triangles
        # Its turns by 90 degrees swap u and v: a mirror, which would turn every triangle over.
        pack.rotate_charts = False
        atlas.generate(pack_options=pack)
        if atlas.atlas_count != 1 or atlas.chart_count != len(charts):
            log(f"xatlas: {atlas.atlas_count} atlases, {atlas.chart_count} charts for "
                f"{len(charts)}: packed on shelves instead")
            return None
        vmap, _, out = atlas[0]
        px = out.astype(np.float64) * np.array([atlas.width, atlas.height])
        wz = px[:, 0] + 1j * px[:, 1]
        moved, failed = [], []
        for k, U in enumerate(charts):
            rows = np.flatnonzero((vmap >= offsets[k]) & (vmap < offsets[k + 1]))
            z = U[rows_of[k][vmap[rows] - offsets[k]]]
            z = z[:, 0] + 1j * z[:, 1]
            a, b, residual = _similarity(z, wz[rows])
            # Within a quarter of the gutter of where xatlas put it: still apart from the
            # others (float32 output: 0.1-0.4 texels seen).
            if residual > PADDING / 4:
                failed.append(k)
            full = a * (U[:, 0] + 1j * U[:, 1]) + b
            moved.append(np.column_stack([full.real, full.imag]))
        if not failed:
            return moved
        for k in failed:
            rows_of[k], hull_faces = _hull(charts[k])
            proxies[k] = (charts[k][rows_of[k]], hull_faces)
    log(f"xatlas: charts {failed} moved by no similarity: packed on shelves instead")
    return None


def _shelves(charts: list[np.ndarray], pad: float) -> list[np.ndarray]:
    """Boxes on shelves, tallest first: the fallback when xatlas's output is not one similarity
    per chart (charts turned to their principal axes, each box ``pad`` apart)."""
    from .atlas import pack_one

    boxed = []
    for U in charts:
        C = pack_one(U, 0.0) - 0.5  # principal axes, longest side 1: scale back below
        s = float(np.ptp(U, axis=0).max()) / max(float(np.ptp(C, axis=0).max()), 1e-300)
        boxed.append(C * s)
    sizes = np.array([np.ptp(C, axis=0) for C in boxed])
    width = max(float(np.sqrt(((sizes + pad) ** 2).sum()) * 1.2), float(sizes[:, 0].max()))
    x = y = shelf = 0.0
    moved = [None] * len(charts)
    for k in np.argsort(-sizes[:, 1]):
        w, h = sizes[k]
        if x > 0 and x + w > width:
            x, y, shelf = 0.0, y + shelf + pad, 0.0
        moved[k] = boxed[k] - boxed[k].min(axis=0) + [x, y]
        x, shelf = x + w + pad, max(shelf, h)
    return moved


def pack_charts(V: np.ndarray, charts: list[Chart], gutter: float) -> tuple[list[np.ndarray], str]:
    """Each chart's map placed in ``[gutter, 1 - gutter]^2`` (the module's packing), and the
    packer's name (``"one chart"``, ``"xatlas"`` or ``"shelves"``)."""
    from .atlas import pack_one

    if len(charts) == 1:
        return [pack_one(charts[0].U, gutter)], "one chart"
    scaled = []
    for c in charts:
        P = V[c.origin]
        a3 = _areas3(P, c.F)
        good = a3 > 0
        r = np.sqrt(np.abs(signed_areas(c.U, c.F))[good] / a3[good]) if good.any() else [1.0]
        U = c.U / max(float(np.median(r)), 1e-300)
        scaled.append(U - U.mean(axis=0))
    moved, packer = _xatlas(scaled, [c.F for c in charts]), "xatlas"
    if moved is None:
        total = np.sqrt(sum(float(np.prod(np.ptp(U, axis=0))) for U in scaled))
        moved, packer = _shelves(scaled, PADDING / RESOLUTION * total), "shelves"
    allU = np.concatenate(moved)
    lo, hi = allU.min(axis=0), allU.max(axis=0)
    s = (1.0 - 2.0 * gutter) / float((hi - lo).max())
    centre = (lo + hi) / 2.0
    return [(U - centre) * s + 0.5 for U in moved], packer


def charts_overlap(Us: list[np.ndarray], charts: list[Chart]) -> float:
    """The area two charts' outlines share, as a fraction of the charts' area (shapely; 0
    when the packing kept them apart)."""
    import shapely
    from shapely.strtree import STRtree

    polys = [shapely.Polygon(U[np.asarray(max(boundary_loops(c.F), key=len))]).buffer(0)
             for U, c in zip(Us, charts)]
    tree = STRtree(polys)
    shared = 0.0
    for i, p in enumerate(polys):
        for j in tree.query(p):
            if j > i:
                shared += float(p.intersection(polys[j]).area)
    return shared / max(sum(p.area for p in polys), 1e-300)
