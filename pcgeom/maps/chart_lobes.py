"""A chart whose free boundary crosses itself in a lobe, made one-to-one where it crosses: the
barrier map onto the outline, on the triangles around the lobe only.

Where a chart shrinks most (between corners of the cut graph), its free boundary may curl
and cross itself: a lobe of boundary laid over the chart's own triangles, no triangle turned
over (the genus-4 pretzel at 50k points: one crossing, the lobe's 55 boundary vertices, the
triangles over it 1.7e-3 of the chart's area). Cutting the lobe off does not help (measured:
a cut of 0.24 sqrt(A) across its mouth, or round the triangles over it, 0.41 sqrt(A): the
chart left crosses itself again beside the cut, 9e-4 and 7e-4 of its area); the barrier map of
the whole chart onto its outline (:func:`pcgeom.maps.chart_scale.onto_outline`) does, but
takes 48-122 s at 50k points. :func:`unfold_lobes` solves the same problem on a patch:

1. **The crossings**: the boundary segments that cross (shapely's tree of segments); each
   crossing's lobe is the shorter run of boundary between the two segments.
2. **The patch**: the triangles that touch a lobe's vertices or cover the region a lobe
   bounds (both sheets), grown by ``rings`` rings (:data:`LOBE_RINGS`); the triangles it
   encloses added; it must be a disk.
3. **The outline**: the outer ring of the union of the patch's triangles (a simple polygon:
   :func:`pcgeom.maps.chart_scale.covered_outline`, as for the whole chart's).
   The patch's boundary edges inside the chart lie on it and are held; the vertices of its
   boundary on the chart's free boundary slide along it (:func:`_place_runs`: those on it
   stay, the lobe's are spread over the stretch that cuts the lobe off).
4. **The map**: untangled with the whole patch boundary held
   (:func:`pcgeom.maps.injective.untangle`, first near the folds only), then the barrier descent
   (:func:`pcgeom.maps.injective.barrier._descend`, :data:`LOBE_STEPS` steps), the free
   vertices sliding, the patch's edge inside the chart held: no triangle turns over and the
   boundary stays on the outline, so the chart's boundary is simple.

The caller judges the result (flips, a simple boundary, spread, angle cost).
"""

from __future__ import annotations

import numpy as np

from ..mesh import boundary_loops, half_edges, shoelace, signed_areas, twin_pairs

__all__ = ["unfold_lobes", "crossings", "LOBE_RINGS", "LOBE_STEPS"]

LOBE_RINGS = (12, 20)
"""Rings of triangles around a lobe's triangles that the patch adds, tried in turn by the
caller (:func:`pcgeom.maps.charts._lobes`) while the last one is one-to-one but costs too
much angle. The barrier ends in a different local minimum
for each: genus-4 pretzel 50k, 8 / 12 / 16 / 20 / 24 rings: 1.41 / 1.32 / 1.43 / 1.29 /
1.39 times LSCM's conformal distortion (the bounded map before it: 1.08), 6-10 s each;
every one no flip and a simple boundary."""

LOBE_STEPS = 100
"""Steps of the barrier descent on the patch at most (genus-4 pretzel 50k: 30 steps leave
1.45x LSCM's conformal distortion, 100 and 200 1.33x, stopped by the barrier's tolerance)."""

UNTANGLE_RINGS = 4
"""Rings of vertices around the triangles the outline folds that untangling frees first."""


def crossings(U: np.ndarray, loop: np.ndarray) -> list[np.ndarray]:
    """The lobes of the closed boundary ``loop`` in the map ``U``: for each pair of its
    segments that cross (not neighbours), the positions in ``loop`` of the shorter run of
    vertices between them."""
    import shapely
    from shapely.strtree import STRtree

    k = len(loop)
    segs = shapely.linestrings(np.stack([U[loop], U[np.roll(loop, -1)]], axis=1))
    a, b = STRtree(segs).query(segs, predicate="intersects")
    keep = (b > a + 1) & ~((a == 0) & (b == k - 1))
    out = []
    for i, j in zip(a[keep].tolist(), b[keep].tolist()):
        if j - i <= k - (j - i):
            out.append(np.arange(i + 1, j + 1))
        else:
            out.append(np.arange(j + 1, i + k + 1) % k)
    return out


def _grow(F: np.ndarray, side: np.ndarray, rings: int, n: int) -> np.ndarray:
    for _ in range(rings):
        v = np.zeros(n, dtype=bool)
        v[F[side].ravel()] = True
        side = v[F].any(axis=1)
    return side


def _enclosed(F: np.ndarray, side: np.ndarray, rim_edges: set, n: int) -> np.ndarray:
    """``side`` with the triangles it encloses (connected parts of the others that touch no
    edge of the chart's boundary)."""
    import scipy.sparse as sp
    from scipy.sparse.csgraph import connected_components

    m = len(F)
    he = half_edges(F)
    key = np.minimum(he[:, 0], he[:, 1]) * n + np.maximum(he[:, 0], he[:, 1])
    tri = np.arange(3 * m) % m
    h1, h2 = twin_pairs(F)
    f1, f2 = h1 % m, h2 % m
    out = ~side
    both = out[f1] & out[f2]
    graph = sp.coo_matrix((np.ones(int(both.sum())), (f1[both], f2[both])), shape=(m, m))
    count, label = connected_components(graph, directed=False)
    on_rim = np.zeros(count, dtype=bool)
    rim_tri = np.flatnonzero(np.isin(key, np.fromiter(rim_edges, dtype=np.int64)))
    on_rim[label[tri[rim_tri]][out[tri[rim_tri]]]] = True
    inside = out & ~on_rim[label]
    return side | inside


def _increasing_spread(u: np.ndarray, span: float) -> np.ndarray:
    """The non-decreasing ``u`` in ``[0, span)`` made increasing within ``(0, span)``: each
    run of values not above the one before it spread evenly up to the next value above."""
    w = np.r_[0.0, u, span]
    q = 1
    while q < len(w) - 1:
        if w[q] > w[q - 1]:
            q += 1
            continue
        r = q
        while w[r] <= w[q - 1]:
            r += 1
        w[q:r] = w[q - 1] + (w[r] - w[q - 1]) * np.arange(1, r - q + 1) / (r - q + 1)
        q = r
    return w[1:-1]


def _place_runs(U: np.ndarray, loop: np.ndarray, slides: np.ndarray, outline: np.ndarray
                ) -> tuple[list | None, list, np.ndarray]:
    """The runs of sliding vertices of the patch's boundary ``loop`` (``slides``: a mask
    along it), each between two held vertices on the closed polyline ``outline``, placed on
    it in order: a vertex on the outline where it is (the outline follows the chart's
    boundary but where it crosses), those off it (a lobe's) spread evenly, by their place in
    the run, between the ones on it before and after them; then made increasing. Returns the
    runs (vertex arrays), their unwrapped arc lengths, and ``U`` with them placed; None for
    the runs when a run's ends coincide."""
    import shapely

    line = shapely.LineString(outline)
    L = float(line.length)
    k = len(loop)
    first = int(np.flatnonzero(~slides)[0])
    order = np.roll(np.arange(k), -first)  # starts at a held vertex
    s = np.asarray(shapely.line_locate_point(line, shapely.points(U[loop[order]])),
                   dtype=np.float64)
    dist = shapely.distance(line, shapely.points(U[loop[order]]))
    out = U.copy()
    runs, ts = [], []
    i = 0
    while i < k:
        if slides[order[i]]:
            j = i
            while j < k and slides[order[j]]:
                j += 1
            ta, tb = s[i - 1], s[j % k]
            span = (tb - ta) % L
            if span <= 0:
                return None, [], U
            u = (s[i:j] - ta) % L
            # Past the stretch: to its nearer end (behind its start: at the start).
            out_of = u > span
            u[out_of] = np.where(u[out_of] - span < L - u[out_of], span, 0.0)
            # The vertices off the outline (a lobe's) evenly by their place in the run
            # between those on it around them.
            on = dist[i:j] <= 1e-9 * L
            at = np.r_[-1, np.flatnonzero(on), j - i]
            u = np.interp(np.arange(j - i), at, np.r_[0.0, u[on], span])
            u = np.minimum(u, (1.0 - 1e-9) * span)
            u = _increasing_spread(np.maximum.accumulate(u), span)
            t = ta + u
            run = loop[order[i:j]]
            out[run] = shapely.get_coordinates(shapely.line_interpolate_point(line, t % L))
            runs.append(run)
            ts.append(t)
            i = j
        else:
            i += 1
    return runs, ts, out


def _untangle_near(P: np.ndarray, F: np.ndarray, U: np.ndarray, held: np.ndarray
                   ) -> np.ndarray | None:
    """``U`` with its folds untangled (:func:`pcgeom.maps.injective.untangle`), ``held``
    held: first only the vertices within :data:`UNTANGLE_RINGS` rings of a folded triangle
    (the rest keeps the chart's map), then, if folds are left, all of them; None when some
    are left still."""
    from .injective import untangle

    n = len(P)
    bad = signed_areas(U, F) <= 0
    if not bad.any():
        return U
    free = np.zeros(n, dtype=bool)
    free[F[bad].ravel()] = True
    for _ in range(UNTANGLE_RINGS):
        free[F[free[F].any(axis=1)].ravel()] = True
    free[held] = False
    W, info = untangle(P, F, U, np.flatnonzero(~free))
    if info["flipped"]:
        W, info = untangle(P, F, U, held)
    return None if info["flipped"] else W


def unfold_lobes(P: np.ndarray, F: np.ndarray, U: np.ndarray, *,
                 rings: int = LOBE_RINGS[0], steps: int = LOBE_STEPS) -> np.ndarray | None:
    """The map ``U`` of the disk ``(P, F)`` (no triangle turned over, its boundary crossing
    itself) made one-to-one around its lobes (steps 1-4 of the module); None when its
    boundary does not cross, the patch is not a disk, or a step fails."""
    import shapely

    from ..config import BarrierConfig
    from .chart_scale import covered_outline
    from .injective.barrier import _descend
    from .injective.jacobians import _scaled_reference
    from .injective.rings import _Layout, _Rings

    n = len(P)
    loop = np.asarray(boundary_loops(F)[0])
    lobes = crossings(U, loop)
    if not lobes:
        return None
    rim_set = set((np.minimum(loop, np.roll(loop, -1)) * n
                   + np.maximum(loop, np.roll(loop, -1))).tolist())
    seed_v = np.zeros(n, dtype=bool)
    seed_v[loop[np.concatenate(lobes)]] = True
    side = seed_v[F].any(axis=1)
    tris = shapely.polygons(np.concatenate([U[F], U[F][:, :1]], axis=1))
    for lobe in lobes:
        ring = U[loop[lobe]]
        if len(ring) >= 3:
            region = shapely.Polygon(ring).buffer(0)
            side |= shapely.intersects(tris, region)
    side = _enclosed(F, _grow(F, side, rings, n), rim_set, n)
    rows = np.flatnonzero(side)
    used, Fs = np.unique(F[rows], return_inverse=True)
    Fs = Fs.reshape(-1, 3)
    from .charts import _is_disk

    if not _is_disk(Fs):
        return None
    Ps, Us = P[used], U[used].copy()
    ls = np.asarray(boundary_loops(Fs)[0])
    if shoelace(Us[ls]) < 0:
        return None
    # The patch's boundary edges on the chart's boundary: their vertices slide.
    a, b = used[ls], used[np.roll(ls, -1)]
    on_rim = np.isin(np.minimum(a, b) * n + np.maximum(a, b),
                     np.fromiter(rim_set, dtype=np.int64))
    slides = on_rim & np.roll(on_rim, 1)  # both edges at the vertex on the chart's boundary
    if not slides.any() or slides.all():
        return None
    outline = covered_outline(U, F[rows])
    if outline is None:
        return None
    runs, ts, placed = _place_runs(Us, ls, slides, outline)
    if runs is None:
        return None
    start = _untangle_near(Ps, Fs, placed, ls)
    if start is None:
        return None
    inner = np.ones(len(Ps), dtype=bool)
    inner[ls] = False
    try:
        slide = _Rings(runs, [outline] * len(runs), start, t=ts)
        layout = _Layout(start, np.flatnonzero(inner), slide)
        W, out = _descend(Ps, Fs, layout, BarrierConfig(iterations=steps),
                          _scaled_reference(Ps, Fs, start))
    except ValueError:
        return None
    if out["flipped"] or (signed_areas(W, Fs) <= 0).any():
        return None
    result = U.copy()
    result[used] = W
    return result
