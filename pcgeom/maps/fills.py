"""Small false loops of an open local mesh closed by re-meshing their neighbourhood flat (not
in the paper; step 2b of :mod:`pcgeom.maps.topology`).

The loop fills of :mod:`pcgeom.maps.topology` take a loop as it is: its points and the
unmeshed points inside it. Measured on the shared open surfaces and the holed sheets, most
false loops left after them are not wide (their perimeter is 0.7-3 circles of the local
spacing) but have no flat fill of the loop alone: the mesh round them overlaps itself (a
triangle over the hole's corner, so that every fill triangle faces away from its corners'
normals or needs a diagonal the mesh already has), or the loop runs through pinched vertices
(a walk that visits a point twice). A fill of the loop alone then folds, and folds cost the
maps. Here the loop's whole neighbourhood is re-meshed instead: the triangles at its points
(one ring, else two) go, and the hole they leave, with those points inside it, gets the
Delaunay triangles of the plane of its normals (:func:`pcgeom.maps.topology.fill_loop`).
The re-mesh is kept only when it is flat (each triangle within :data:`REFILL_TURN` of each
corner's normal, the region's rim is one simple loop of the mesh's own edges, no edge gains a
third triangle),
uses every point it freed, and no triangle of it is wider, nor leaves a wider empty circle,
than the widest the sampling leaves (:func:`pcgeom.maps.topology.widest_empty`): a hole of
the surface (wider than any empty circle of the sampling) stays open, and a patch that is
not flat in any plane (a fold of the surface) keeps its mesh. A flat re-mesh of a
neighbourhood is an embedding of it in its plane: it turns no triangle of a map over.

Where the neighbourhood is too curved for one plane (the shared peaks: its corners' normals
over 90 degrees apart over a ring), the loop is often held open by an ear: a triangle of the
mesh that holds two consecutive edges of the loop, its tip poking into the hole, round which
every fill folds. The ears go and the loop left gets the flat fill of the loop alone
(:func:`_ear_fill`), under the same width bound and, as the true holes of peaks_7holes_choi
show, an empty-circle test too: the local mesh's fans span most of those holes with long
triangles, leaving loops of 4-7 points (perimeter 1.1-2.5 circles of the local spacing, as
short as false loops), but the empty circle at the fill's centre is that of the whole hole.
Measured (bare / file normals): peaks_7holes_choi 11 / 11 loops after the re-mesh alone, 9 /
10 with the ears (its 7 holes and the rim kept; without the empty-circle test one hole was
filled, 8 / 7).
The ears' step is off by default (:data:`REFILL_EARS`): it costs maps elsewhere.

What keeps the false loops left open (measured 2026-12-05 on the mesh a bare ``fast`` run
maps; loops with no point on the true mesh's rim). face_human_choi (39 loops, 1 true): of the
small loops re-meshed and left, 76 reach a loop that is not small (the region's rim meets a
long walk through pinched vertices, or one of the 17-37 spacings round the eyes and the
mouth, where two sheets nearly touch), 10 get no fill (the Delaunay triangles of the region's
points do not keep its rim; with the rim's edges flipped in, Sloan's way, all 18 tried kept
it, but the re-meshes were refused after and no loop closed), 2 leave points inside unused,
2 turn.
peaks_three_cgal (4 loops, 1 true): each of its 5 false simple loops turns at one ring and at
two rings has no simple outline in the plane of its normals (a steep peak). A tangent-plane
gap test (the widest angle between a loop point's 24 nearest points in their own PCA plane)
tells face_human_choi's false loops (widest gap mostly under 120 degrees) from its rim (180),
but not peaks_7holes_choi's small true holes (86-189 degrees); taken as a licence to pass the
turn test it closed 2 more of face_human_choi's loops (39 -> 37 bare, 26 -> 24 with its mesh's
normals), the maps unchanged, at 5% more time: not kept.
A fill drawn in an embedding instead of the plane of the normals (measured 2026-12-05, not
kept): loops left no longer than 2.5 bound circles whose points' median widest gap (the
cloud's points within 2 local spacings, in the point's tangent plane) is under 120 degrees,
capped by a virtual point and, with one to three rings of triangles round them (each fan of a
pinched vertex its own point, other loops in the rings capped too), laid out by Tutte's
embedding (the outer rim on a circle); every triangulation of the loop inside its outline
there, none of whose diagonals the mesh has, was tried. It closed none: face_human_choi 11 of
19 short loops interior bare, 2 of 15 with its mesh's normals, peaks_three_cgal 3 of 3 and 3
of 6, and for each every such triangulation has a triangle facing away from its corners'
normals (the mesh round the loop overlaps itself: a loop's fill cannot mend that, its
neighbourhood's triangles must change); the test also called one of peaks_7holes_choi's true
holes interior (median gap 95 degrees).
"""

from __future__ import annotations

import numpy as np

from ..mesh import cross3, half_edges as _directed, successor_walks, twins
from .topology_batch import CloudTree, Corners, FillMemo, isin, setdiff, unmeshed

__all__ = ["refill_small_loops"]

REFILL_EARS = False
"""Whether a small loop no re-mesh closes loses its ears and gets the flat fill of the loop
alone (:func:`_ear_fill`). Off: measured side by side, the ears' fills cost maps that the
loop counts do not pay for: face_human_choi's bare disk map 813 -> 823 true triangles
flipped; a planar ring (12 rings of a 48-gon, r 0.4-1) onto annulus:auto 0.0082 -> 0.0318
from the domain, 3 -> 5 flipped, 0.0179 -> 0.0206 rad. On, peaks_7holes_choi reads 9 / 10
loops (bare / file normals) instead of 11 / 11 (true 8)."""

REFILL_ROUNDS = 2
"""Rounds of re-meshing (a round's regions are disjoint; one next to a region re-meshed in
the round waits for the next)."""

REFILL_LOOP = 0.8
"""A loop is re-meshed when it is no longer than a circle of this many times the bound's
radius (:data:`pcgeom.maps.topology.HOLE_MARGIN` times the widest empty circle, in local
spacings). Measured on 12 holed sheets (``holed_sheet``, uniform and scan samplings, seeds
2-7, holes of radius 1-5 spacings): at 1.0 the loops round holes of radius 2 spacings
(perimeter 2.2-2.4 circles of the local spacing) were re-meshed over in 5 of the 12; at 0.8
in 2 (both scan sheets, where such a hole is about 1.7 local spacings wide; one of them lost
already without the re-mesh)."""

REFILL_WIDTH = 0.75
"""... and kept when no triangle of it is wider, nor leaves an empty circle wider, than this
times the bound (0.75 of 1.35: the widest empty circle the sampling leaves, no margin). The
loops round holes of radius 2 spacings re-meshed leave empty circles of 1.7-2.3 local
spacings; the false loops' re-meshes 1.0-2.0. The 12 sheets kept 5 false loops and lost 5
holes of radius 2 with 1.0 (and :data:`REFILL_LOOP` 1.0); 11 and 2 with 0.75 (and 0.8);
without the re-mesh, 48 and 1."""

REFILL_SHORT = 1.5
"""... or no longer than a circle of this many local spacings, whatever the bound: on a
regular sampling the bound is tight (peaks_three_cgal: 1.52, so :data:`REFILL_LOOP` alone
takes loops up to 1.22) while its false loops run to 1.4. Measured: peaks_three_cgal 6 / 7
loops (bare / file normals) -> 5 / 6; 2.0 closes no more; the 18 holed sheets (uniform,
scan and grid, seeds 2-7), peaks_7holes_choi, face_human_choi and the pleats the same."""

REFILL_TURN = 45.0
"""A re-mesh or an ear's fill is kept when each of its triangles is within this angle
(degrees) of each corner's normal (a stricter flatness than facing their sum). Measured, free
maps, one run, side by side: on the lips sheet (``lips_sheet(11000, gap=0.75)``, bare; its
sheets 0.75 spacings apart) the re-meshes with the sum test bridged the sheets, 0.0870 rad,
5.03% flipped without re-meshes -> 0.0935, 5.13%; at 45 degrees 0.0862, 4.99% (at 60
0.1046). The pleats (``pleated_sheet(6000, folds=4, gap=1.5)``): 0.0261, 41 flipped without
-> 0.0282, 50 with the sum test -> 0.0259, 41 at 45 degrees. face_human_choi bare: 0.0333,
2.51% -> 0.0331, 2.49% (its mesh 50 loops for 58; 36 with the sum test, which the lips rule
out)."""

REFILL_GROW = 4
"""Times a region grows: to take in the small loops its triangles reach, or the triangles
round the points where its rim is no simple loop."""

REFILL_RINGS = (1, 2)
"""Rings of triangles round a loop's points that are re-meshed, tried in turn."""


def _cycle(edges: np.ndarray) -> np.ndarray | None:
    """The vertices of the directed edges ``edges`` (k, 2) in order round their one simple
    cycle; None when they do not form exactly one."""
    if len(edges) < 3:
        return None
    nxt = dict(zip(edges[:, 0].tolist(), edges[:, 1].tolist()))
    if len(nxt) != len(edges) or len(set(edges[:, 1].tolist())) != len(edges):
        return None
    start = int(edges[0, 0])
    out, v = [start], nxt[start]
    while v != start:
        if len(out) >= len(edges) or v not in nxt:
            return None
        out.append(v)
        v = nxt[v]
    if len(out) != len(edges):
        return None
    return np.asarray(out, dtype=np.int64)


def _empty_radius(X: np.ndarray, F: np.ndarray, cloud) -> np.ndarray:
    """(M,) the radius of the empty circle round each triangle's circumcentre: the distance
    from it to the nearest point of the cloud (``cloud``, a cKDTree of its points). For a
    Delaunay triangle inside a hole it is its circumradius; for a sliver at the rim of a
    fill, whose circumcentre lies out over the mesh, it is small."""
    A, B, C = X[F[:, 0]], X[F[:, 1]], X[F[:, 2]]
    a, b = A - C, B - C
    axb = cross3(a, b)
    num = cross3((a * a).sum(1)[:, None] * b - (b * b).sum(1)[:, None] * a, axb)
    centre = C + num / np.maximum(2.0 * (axb * axb).sum(1), 1e-300)[:, None]
    return cloud.query(centre)[0]


def _faces_normals(X: np.ndarray, normals: np.ndarray, F: np.ndarray) -> bool:
    """Whether each triangle of ``F`` is within :data:`REFILL_TURN` of each corner's normal."""
    return _flat(_least_cosine(X, normals, F))


def _least_cosine(X: np.ndarray, normals: np.ndarray, F: np.ndarray) -> float:
    """The least cosine between a triangle of ``F`` and one of its corners' normals."""
    face = cross3(X[F[:, 1]] - X[F[:, 0]], X[F[:, 2]] - X[F[:, 0]])
    face /= np.maximum(np.linalg.norm(face, axis=1, keepdims=True), 1e-300)
    turn = np.einsum("md,mcd->mc", face, normals[F])  # (M, 3) cosines
    return float(turn.min())


def _flat(least_cosine: float) -> bool:
    """Whether a fill whose :func:`_least_cosine` is ``least_cosine`` is within
    :data:`REFILL_TURN` of each corner's normal."""
    return bool(least_cosine > np.cos(np.radians(REFILL_TURN)))


def _pinches(edges: np.ndarray) -> np.ndarray:
    """The points where the directed edges ``edges`` (k, 2) are no one simple cycle: those
    with more than one edge leaving them, or, where each has one, the points of every cycle
    but the longest."""
    starts, count = np.unique(edges[:, 0], return_counts=True)
    if (count > 1).any():
        return starts[count > 1]
    cycles = successor_walks(dict(zip(edges[:, 0].tolist(), edges[:, 1].tolist())))
    cycles.sort(key=len)
    return np.asarray([v for c in cycles[:-1] for v in c], dtype=np.int64)


def refill_small_loops(X: np.ndarray, normals: np.ndarray, faces: np.ndarray, h: np.ndarray,
                       bound: float, exclude: np.ndarray | None = None, *, cloud=None,
                       twins_of=twins, memo: FillMemo | None = None) -> tuple[np.ndarray, int]:
    """The open mesh ``faces`` with its small boundary loops (no longer than a circle of
    :data:`REFILL_LOOP` times ``bound``, or :data:`REFILL_SHORT`, local spacings ``h``)
    closed by a flat re-mesh of their neighbourhood, or by a flat fill once their ears go
    (the module's rules), and how many loops that closed.

    Parameters
    ----------
    X, normals : (N, 3) float64
        The points and their oriented unit normals.
    faces : (M, 3) int64
        The mesh: edge-manifold, consistently oriented.
    h : (N,) float64
        Each point's local spacing.
    bound : float
        The widest triangle (enclosing radius in local spacings) a fill may have.
    exclude : (N,) bool, optional
        Points no fill may use.
    cloud : pcgeom.maps.topology_batch.CloudTree, optional
        The points not excluded (``X[~exclude]``) and their k-d tree, built when first needed
        and shared with the caller's other steps (the repair's own).
    twins_of : callable
        :func:`pcgeom.mesh.twins`, or one that knows those of faces it has seen
        (:class:`pcgeom.maps.topology_batch.KnownTwins`).
    memo : pcgeom.maps.topology_batch.FillMemo, optional
        The fills' figures that earlier repairs of the cloud found (bound to it); None: a
        memo of this call's own.
    """
    from scipy.spatial import cKDTree

    from .topology import enclosing_radius, fill_loop, rim_walks

    memo = FillMemo() if memo is None else memo

    n = len(X)
    closed = 0
    # Loops a round tried and could not close, by their points: where they reach (a ball
    # round the loop's centre holding every point the re-mesh looked at) and the loops not
    # small that stopped them. The next round skips such a loop when nothing it looked at
    # changed: no point in its ball re-meshed, and the loops that stopped it the same.
    failed: dict = {}
    touched = None
    cloud = CloudTree(X, exclude) if cloud is None else cloud  # its tree built when first needed

    def _flat_fill(loop: np.ndarray, inside: np.ndarray, inner: np.ndarray):
        """The fill of a region's rim ``loop`` over ``inner`` that uses every point
        ``inside``, flat and no wider than the sampling leaves; None when there is none (the
        module's tests that do not depend on the mesh round it). Its figures from ``memo``
        when a repair of the cloud found them (the same loop, points and normals)."""
        key = ("remesh", loop.tobytes(), inside.tobytes(), inner.tobytes(),
               normals[loop].tobytes(), normals[inner].tobytes())
        found = memo.get(key, lambda: _fill_figures(loop, inside, inner))
        F, least = found[0], found[1]
        if F is None or not _flat(least):
            return None
        if found[2] is None:  # (its widths found once it is flat)
            width = enclosing_radius(X, F) / np.maximum(h[F].mean(axis=1), 1e-300)
            empty = _empty_radius(X, F, cloud.tree) / np.maximum(h[F].mean(axis=1), 1e-300)
            found[2] = max(float(width.max()), float(empty.max()))
        if found[2] > REFILL_WIDTH * bound:
            return None
        return F

    def _fill_figures(loop: np.ndarray, inside: np.ndarray, inner: np.ndarray) -> list:
        """[the fill (None when it leaves a point inside out), its least cosine to a
        corner's normal, its widest triangle or empty circle (None: not yet found)]."""
        # (A fill of the loop alone leaves the points inside out: no re-mesh.)
        F = fill_loop(X, normals, loop, inner, loop_alone=not len(inside))
        if F is None or not isin(inside, F).all():
            return [None, None, None]
        return [F, _least_cosine(X, normals, F), None]

    for _ in range(REFILL_ROUNDS):
        if not len(faces):
            break
        m = len(faces)
        halves: dict = {}  # the half-edges' keys a * N + b sorted, and their order, when needed
        twin = twins_of(faces)[0]
        rim, walks = rim_walks(faces, twin)
        perimeter = np.linalg.norm(X[rim[:, 1]] - X[rim[:, 0]], axis=1)
        spacing = _walk_medians(h[rim[:, 0]], walks)
        walk_keys = [frozenset(rim[w, 0].tolist()) for w in walks]
        walk_id = np.full(len(rim), -1, dtype=np.int64)
        for i, w in enumerate(walks):
            walk_id[w] = i
        small = []
        present = set(walk_keys)
        for i, w in enumerate(walks):
            length = float(perimeter[w].sum())
            short = max(REFILL_LOOP * bound, REFILL_SHORT)
            if length <= 2.0 * np.pi * short * float(spacing[i]):
                if not _unchanged(failed.get(walk_keys[i]), touched, present):
                    small.append((length, w, walk_keys[i]))
        if not small:
            break
        small.sort(key=lambda s: s[0])
        looked: dict = {}  # small loop -> (triangles looked at, loops not small it met)
        walk_of = np.full(len(rim), -1, dtype=np.int64)
        for k, (_, w, _) in enumerate(small):
            walk_of[w] = k
        # The small loop and the walk of each half-edge on the boundary (rim_walks' rows are
        # the half-edges with no twin, in order), -1 elsewhere.
        boundary = np.flatnonzero(twin < 0)
        small_of = np.full(3 * m, -1, dtype=np.int64)
        small_of[boundary] = walk_of
        walk_of_half = np.full(3 * m, -1, dtype=np.int64)
        walk_of_half[boundary] = walk_id
        corners = Corners(faces, n)
        free, tree = unmeshed(X, faces, exclude)
        busy = np.zeros(m, dtype=bool)
        fills, added_edges = [], set()

        tris_at = corners.triangles

        def sorted_halves() -> tuple[np.ndarray, np.ndarray]:
            if not halves:
                H = _directed(faces)  # (3M, 2)
                hkey = H[:, 0] * n + H[:, 1]
                horder = np.argsort(hkey, kind="stable")  # (runs of the faces' order: fast)
                halves.update(sorted=hkey[horder], order=horder)
            return halves["sorted"], halves["order"]

        def has_half(keys: np.ndarray) -> np.ndarray:
            return corners.has_half(keys // n, keys % n)

        def region_fill(k: int, rings: int):
            """The re-mesh of small loop ``k``'s neighbourhood: (triangles gone, fill, loops
            closed, fill's edges); None when it fails, False when a wider ring fails too
            (the region reaches a loop that is not small, or one re-meshed this round)."""
            members = {k}
            L = np.unique(rim[small[k][1]])
            T = tris_at(L)
            for _ in range(rings - 1):
                T = tris_at(np.unique(faces[T]))
            for _ in range(REFILL_GROW):
                looked[k] = (T, looked.get(k, (None, frozenset()))[1])
                if busy[T].any():
                    looked[k] = (None, frozenset())  # waits for the next round
                    return False
                # T's half-edges, slot * m + T (the rows of _directed(faces[T])), and those
                # on the mesh's boundary (no twin; none of them has its twin in T).
                half = (np.arange(3)[:, None] * m + T[None, :]).ravel()
                open_ = twin[half] < 0
                owners = small_of[half[open_]]
                if (owners < 0).any():
                    stop = walk_of_half[half[open_][owners < 0]]
                    looked[k] = (T if (stop >= 0).all() else None,
                                 frozenset(walk_keys[i] for i in stop.tolist() if i >= 0))
                    return False  # a rim or a hole of the surface, or a wide loop
                extra = set(owners.tolist()) - members
                if extra:  # small loops next to it join it, with their ring
                    members |= extra
                    T = np.union1d(T, tris_at(np.unique(rim[np.concatenate(
                        [small[j][1] for j in extra])])))
                    continue
                D = _directed(faces[T])
                back = D[:, 1] * n + D[:, 0]
                own = np.sort(D[:, 0] * n + D[:, 1])  # (np.isin, by a search)
                inT = own[np.minimum(np.searchsorted(own, back), len(own) - 1)] == back
                outer = D[~open_ & ~inT]
                loop = _cycle(outer[:, ::-1])
                if loop is not None:
                    break
                # The region's rim is no simple loop: it meets itself at a vertex (the
                # triangles round it are taken in) or it holds a hole of its own (each
                # rim but the longest: the triangles at its vertices are taken in).
                at_pinch = _pinches(outer)
                T = np.union1d(T, tris_at(at_pinch))
            else:
                return None
            looked[k] = (T, looked[k][1])
            if (np.einsum("kd,kd->k", normals[loop], normals[np.roll(loop, -1)])
                    <= np.cos(np.radians(2.0 * REFILL_TURN))).any():
                # The fill's triangle at that loop edge turns more than REFILL_TURN from
                # one of its ends' normals: no fill passes the turn test (a cheap test first).
                return None
            region = np.unique(faces[T])
            inside = setdiff(region, loop)
            if exclude is not None:
                inside = inside[~np.asarray(exclude, dtype=bool)[inside]]
            inner = inside
            if tree is not None:
                centre = X[loop].mean(axis=0)
                reach = float(np.linalg.norm(X[loop] - centre, axis=1).max())
                near = free[np.asarray(tree.query_ball_point(centre, reach), dtype=np.int64)]
                inner = np.concatenate([inside, near])
            F = _flat_fill(loop, inside, inner)
            if F is None:
                return None
            # No edge of the fill inside the region may be an edge of the mesh outside it.
            E = np.sort(_directed(F), axis=1)
            ek, ec = np.unique(E[:, 0] * n + E[:, 1], return_counts=True)
            inner_edges = ek[ec == 2]
            Tk, Tc = np.unique(np.sort(D, axis=1) @ np.array([n, 1]), return_counts=True)
            # (Triangles of the mesh at each edge: one per direction, the mesh consistently
            # oriented.)
            lo, hi = inner_edges // n, inner_edges % n
            total = (has_half(lo * n + hi).astype(np.int64)
                     + has_half(hi * n + lo).astype(np.int64))
            at = np.minimum(np.searchsorted(Tk, inner_edges), len(Tk) - 1)
            total = total - np.where(Tk[at] == inner_edges, Tc[at], 0)
            if (total > 0).any() or not added_edges.isdisjoint(ek.tolist()):
                return None
            return T, F, members, ek

        done = set()
        for k in range(len(small)):
            if k in done:
                continue
            for rings in REFILL_RINGS:
                got = region_fill(k, rings)
                if got is False:
                    break
                if got is not None:
                    T, F, members, ek = got
                    busy[T] = True
                    fills.append(F)
                    added_edges.update(ek.tolist())
                    done |= members
                    closed += len(members)
                    break
        for k in range(len(small) if REFILL_EARS else 0):
            if k in done:
                continue
            hsorted, horder = sorted_halves()
            got = _ear_fill(X, normals, faces, rim[small[k][1]], hsorted=hsorted, horder=horder)
            if got is None or busy[got[0]].any():
                continue
            ear, F = got
            if not _faces_normals(X, normals, F):
                continue
            width = np.maximum(enclosing_radius(X, F), _empty_radius(X, F, cloud.tree)
                               ) / np.maximum(h[F].mean(axis=1), 1e-300)
            E = np.sort(_directed(F), axis=1)
            ek, ec = np.unique(E[:, 0] * n + E[:, 1], return_counts=True)
            inner_edges = ek[ec == 2]
            lo, hi = inner_edges // n, inner_edges % n
            if (float(width.max()) > REFILL_WIDTH * bound
                    or (has_half(lo * n + hi) | has_half(hi * n + lo)).any()
                    or not added_edges.isdisjoint(ek.tolist())):
                continue
            busy[ear] = True
            fills.append(F)
            added_edges.update(ek.tolist())
            closed += 1
        for k in set(range(len(small))) - done:
            T, stop = looked.get(k, (None, frozenset()))
            if T is None:
                continue
            P = X[np.unique(faces[T])]
            centre = X[rim[small[k][1], 0]].mean(axis=0)
            radius = 2.0 * float(np.linalg.norm(P - centre, axis=1).max())  # (free points)
            failed[small[k][2]] = (centre, radius, stop)
        if not fills:
            break
        changed = np.unique(np.concatenate([faces[busy].ravel(), *[F.ravel() for F in fills]]))
        touched = cKDTree(X[changed])
        faces = np.concatenate([faces[~busy], *fills])
    return faces, closed


def _walk_medians(values: np.ndarray, walks: list[np.ndarray]) -> np.ndarray:
    """``np.median(values[w])`` of each walk ``w`` (index arrays), all at once (the same
    numbers: the middle value, or the mean of the middle two)."""
    if not walks:
        return np.zeros(0)
    sizes = np.array([len(w) for w in walks], dtype=np.int64)
    seg = np.repeat(np.arange(len(walks)), sizes)
    v = values[np.concatenate(walks)]
    ordered = v[np.lexsort((v, seg))]
    mid = np.cumsum(sizes) - sizes + sizes // 2
    return np.where(sizes % 2 == 1, ordered[mid], (ordered[mid - 1] + ordered[mid]) / 2)


def _unchanged(seen: tuple | None, touched, present: set) -> bool:
    """Whether a loop an earlier round could not close (``seen``: the centre and radius of
    the ball of points it looked at, and the loops not small that stopped it) meets the same
    mesh now: no point in that ball re-meshed since (``touched``, a cKDTree of those points)
    and each loop that stopped it still there (``present``: the loops' point sets)."""
    if seen is None or touched is None:
        return False
    centre, radius, stop = seen
    return not touched.query_ball_point(centre, radius * (1.0 + 1e-9)) and stop <= present


def _ear_fill(X: np.ndarray, normals: np.ndarray, faces: np.ndarray, rim: np.ndarray, *,
              hsorted: np.ndarray, horder: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """A loop (its boundary half-edges ``rim`` (k, 2), in order) closed by a flat fill
    (:func:`pcgeom.maps.topology.fill_loop`) once its ears go: the mesh's triangles that hold
    two of its consecutive edges (a corner of the mesh poking into the hole, round which
    every fill folds). The ears (their indices into ``faces``) and the fill, or None.
    ``hsorted``, ``horder``: the faces' half-edges ``a * N + b`` sorted, and their order."""
    from .topology import fill_loop

    m, n = len(faces), len(X)
    key = rim[:, 0] * n + rim[:, 1]
    at = np.minimum(np.searchsorted(hsorted, key), len(hsorted) - 1)
    tri = horder[at] % m  # the triangle of each loop edge
    ear = np.flatnonzero(tri == np.roll(tri, -1))  # edges i and i + 1 in one triangle
    if not len(ear) or len(rim) - len(ear) < 3:
        return None
    tip = rim[(ear + 1) % len(rim), 0]
    if len(np.unique(tip)) != len(tip) or (rim[:, 0] == tip[:, None]).sum() != len(tip):
        return None  # a tip the loop visits twice: a pinch, not an ear
    loop = np.delete(rim[:, 0], (ear + 1) % len(rim))
    if len(np.unique(loop)) != len(loop):
        return None
    F = fill_loop(X, normals, loop, np.zeros(0, dtype=np.int64))
    if F is None:
        return None
    return tri[ear], F
