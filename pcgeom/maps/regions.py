"""False loops closed by re-triangulating their region in a layout of its points (not in the
paper; step 2d of :mod:`pcgeom.maps.topology`).

The fills before this step (:mod:`pcgeom.maps.topology`, :mod:`pcgeom.maps.fills`,
:mod:`pcgeom.maps.pinches`) take a loop as a polygon in the plane of its normals. The false
loops they leave run through pinched vertices or cross themselves in that plane (the mesh
round them overlaps itself, or the surface turns too much for one plane: the pleats' crests,
their corners' normals 85-110 degrees apart over four points). Here the region round such a
loop goes whole: the triangles at its points (:data:`REGION_RINGS`), grown until its outer
rim is one simple cycle of the mesh's interior edges, taking in every loop it meets (each
whole) and the triangles round the points where its rim meets itself. Its points are laid out
in the plane (:func:`_layouts`: the plane of their normals, else the classical MDS of their
geodesic distances along their nearest points, edges whose ends' normals face apart left
out), and the Delaunay triangles inside the outer rim's polygon, when they hold every point
and their rim is exactly the outer rim, replace the region: a disk, its holes and any pinch
inside gone. That is kept when it passes the fills' tests in space: no triangle facing away
from its corners' normals more than :data:`pcgeom.maps.fills.REFILL_TURN` (or than the
region's own triangles did: :data:`REGION_TURN_OLD`), none wider, nor leaving a wider empty
circle, than :data:`REGION_WIDTH` times the bound, and no edge of it an edge of the mesh
outside the region.

Which loops: those of the mesh's largest part (and of the flaps that meet one of them at a
vertex) no longer than :data:`REGION_LOOP` bound circles, but its longest, that run through a
pinched vertex or are no simple polygon in the plane of their normals; and only on a mesh with
no handles (:func:`pcgeom.maps.topology.repair`: on face_human_choi's bare meshes with
handles, early in a run, the re-triangulations turned the normal rounds' and the arc signs'
choices: genus 0 -> 4 and 702 -> 710 flipped at the end).

Tutte's embedding of the region (its rim on a circle, a virtual point in each hole) was tried
first for the layout: it follows the mesh's own combinatorics, folds included, and the
Delaunay triangles there turned 176-180 degrees from their corners' normals on face_human_choi
(its regions' own triangles up to 162): none kept. Without the MDS layout the pleats keep 20
of their 22 loops (7 with it, the repair's last mesh alone).

Measured side by side (``fast``, off / on, one run each, 2026-12-06, load 7-9; angle and
flips on the true triangles, loops of the mesh the run maps):

- loops: the pleats (``pleated_sheet(6000, folds=4, gap=1.5)``, bare) 22 / 6 (true 1);
  face_human_choi bare 33 / 29, with its mesh's normals 22 / 20 (true 1); the lips sheet
  (11k) with its normals 25 / 19, bare 44 / 44 (genus 12: not tried); peaks_7holes_choi 8 /
  8, face_3holes_small_choi 4 / 4, peaks_three_cgal 4 / 4 and 6 / 6 (bare, normals); 9 holed
  sheets (uniform, grid, scan; seeds 2-4) the same holes and loops.
- maps: the pleats free 0.0155 / 0.0153 rad, disk 0.0244 / 0.0241 (38 / 38 and 40 / 40
  flipped); face_human_choi with normals 0.0225 / 0.0218 rad, 30 / 24 flipped, bare free
  0.0310 / 0.0309, 702 / 703, disk 0.0324 / 0.0324, 714 / 714; the lips with normals 0.0273
  / 0.0273, 160 / 160; the other shared surfaces the same to 4 digits, none flipped.
- on main 13e5bc9 (the bare runs' mesh rebuilt with its bridges cut, d4e60d8), slits
  (:func:`fill_slits`) off / on: face_human_choi with its mesh's normals 20 / 18 loops,
  0.0218 / 0.0217 rad, 24 / 8 flipped; every other map and loop count of the shared open
  surfaces, the pleats and the lips the same, and the 9 holed sheets' holes and loops.
"""

from __future__ import annotations

import numpy as np

from ..mesh import cross3, fan_counts, half_edges as _directed, twins
from .topology_batch import CloudTree, Corners, isin, main_faces, setdiff

__all__ = ["retriangulate_regions", "fill_slits"]

REGION_RINGS = (1, 2)
"""Rings of triangles round the loop's points, tried in turn."""

REGION_GROW = 4
"""Times a region grows to take in the loops it meets or to make its rim one simple cycle."""

REGION_LOOP = 5.0
"""Loops no longer than a circle of this many times the bound's radius (in local spacings)
are tried."""

REGION_WIDTH = 0.6
"""A re-triangulation is kept when no triangle of it is wider, nor leaves a wider empty
circle, than this times the bound. At 0.75 (the re-mesh's
:data:`pcgeom.maps.fills.REFILL_WIDTH`) a scan holed sheet (``holed_sheet(6000,
sampling="scan", seed=4)``) lost its hole of radius 2 spacings (its loop 2.2 bound circles
long, through a pinched vertex, re-triangulated at 0.70 of the bound); the re-triangulations
kept at 0.6 are up to 0.57 of the bound on the pleats, 0.63 on face_human_choi."""

REGION_TURN_OLD = True
"""Whether a re-triangulation that turns more than :data:`pcgeom.maps.fills.REFILL_TURN`
from a corner's normal is kept when the region's own triangles turned as much or more (and
none of it faces away from a corner's normal). Estimated normals turn 85-110 degrees over the
pleats' crests: there no triangle, the true ones included, keeps to 45 degrees."""

SLITS = True
"""Whether :func:`fill_slits` follows the re-triangulation."""

REGION_ROUNDS = 2
"""Rounds (a round's regions are disjoint; a loop whose region met one re-triangulated in the
round is tried again in the next)."""


def retriangulate_regions(X: np.ndarray, normals: np.ndarray, faces: np.ndarray, h: np.ndarray,
                          bound: float, exclude: np.ndarray | None = None, *, cloud=None,
                          twins_of=twins, fans_of=fan_counts, parts_of=main_faces
                          ) -> tuple[np.ndarray, int]:
    """The open mesh ``faces`` with false loops closed by the re-triangulation of their
    region in a layout of its points (the plane of their normals, else the classical MDS of
    their geodesics; the module's rules), and how many loops that closed.

    Parameters
    ----------
    X, normals : (N, 3) float64
        The points and their oriented unit normals.
    faces : (M, 3) int64
        The mesh: edge-manifold, consistently oriented.
    h : (N,) float64
        Each point's local spacing.
    bound : float
        The widest empty circle the sampling leaves, with its margin (local spacings).
    exclude : (N,) bool, optional
        Points no fill may use (unused here: a region holds meshed points only).
    cloud : pcgeom.maps.topology_batch.CloudTree, optional
        The points not excluded and their k-d tree (the empty circles' test).
    twins_of : callable
        :func:`pcgeom.mesh.twins`, or a :class:`pcgeom.maps.topology_batch.KnownTwins`' ``of``.
    fans_of, parts_of : callable
        :func:`pcgeom.mesh.fan_counts` and :func:`pcgeom.maps.topology_batch.main_faces`, or
        the KnownTwins' ``fans`` and ``parts`` (found once per faces array).
    """
    from .fills import _cycle, _empty_radius, _pinches, _walk_medians
    from .topology import enclosing_radius, rim_walks

    n = len(X)
    cloud = CloudTree(X, exclude) if cloud is None else cloud
    closed = 0
    waiting = None  # the loops (their point sets) a region closed in the round before met
    for _ in range(REGION_ROUNDS):
        if not len(faces):
            break
        m = len(faces)
        twin = twins_of(faces)[0]
        rim, walks = rim_walks(faces, twin)
        if len(walks) < 2:
            break
        length = np.linalg.norm(X[rim[:, 1]] - X[rim[:, 0]], axis=1)
        perimeter = np.array([length[w].sum() for w in walks])
        circles = perimeter / (2.0 * np.pi * _walk_medians(h[rim[:, 0]], walks))
        boundary = np.flatnonzero(twin < 0)
        # The loops of the mesh's largest part (the one every map uses), its longest left out.
        kept = parts_of(faces, twin)[2]
        if kept is None:
            on_main = np.ones(len(walks), dtype=bool)
            longest = int(np.argmax(circles))
        else:  # and the loops of parts that meet one of its loops at a vertex (flaps)
            at_main = kept[boundary[[w[0] for w in walks]] % m]
            longest = int(np.argmax(np.where(at_main, circles, -1.0)))
            near = np.zeros(n, dtype=bool)
            for i in np.flatnonzero(at_main & (circles <= REGION_LOOP * bound)).tolist():
                if i != longest:
                    near[rim[walks[i], 0]] = True
            on_main = at_main | np.array([near[rim[w, 0]].any() for w in walks])
        tried = [i for i in np.argsort(circles).tolist()
                 if on_main[i] and i != longest and circles[i] <= REGION_LOOP * bound]
        # Only loops of a shape the plane fills cannot take: through a pinched vertex, or
        # crossing themselves in the plane of their normals (a round hole, simple in its
        # plane, is what those fills judged: wide, a hole of the surface).
        pinched = fans_of(faces, twin) > 1
        tried = [i for i in tried if pinched[rim[walks[i], 0]].any()
                 or not _simple_in_plane(X, normals, rim[walks[i], 0])]
        keys = [frozenset(rim[w, 0].tolist()) for w in walks]
        small = np.zeros(len(walks), dtype=bool)
        small[tried] = True
        if waiting is not None:  # (the others' regions are as they were: they fail again)
            tried = [i for i in tried if keys[i] in waiting]
        waiting = set()
        if not tried:
            break
        walk_of = np.full(3 * m, -1, dtype=np.int64)
        for i, w in enumerate(walks):
            walk_of[boundary[w]] = i
        corners = Corners(faces, n)
        busy = np.zeros(m, dtype=bool)
        done = np.zeros(len(walks), dtype=bool)
        fills = []
        failed: set = set()  # the regions tried this round (as their triangles)
        taken_edges: set = set()

        def region(i: int, rings: int):
            members = {i}
            T = corners.triangles(np.unique(rim[walks[i], 0]))
            for _ in range(rings - 1):
                T = corners.triangles(np.unique(faces[T]))
            for _ in range(REGION_GROW + 1):
                if busy[T].any():
                    waiting.add(keys[i])
                    return None
                half = (np.arange(3)[:, None] * m + T[None, :]).ravel()
                open_ = twin[half] < 0
                owners = walk_of[half[open_]]
                if done[owners].any():
                    waiting.add(keys[i])
                    return None
                if (~small[owners]).any():
                    return None  # the surface's rim, or a loop too long
                extra = set(owners.tolist()) - members
                # Each loop it meets joins whole (all its points' triangles).
                inT = np.zeros(3 * m, dtype=bool)
                inT[half] = True
                whole = [j for j in members | extra if not inT[boundary[walks[j]]].all()]
                if extra or whole:
                    members |= extra
                    T = np.union1d(T, corners.triangles(np.unique(np.concatenate(
                        [rim[walks[j], 0] for j in members]))))
                    continue
                D = _directed(faces[T])
                outer = D[~open_ & ~inT[np.where(open_, 0, twin[half])]]
                loop = _cycle(outer)
                if loop is not None:
                    return T, members, loop
                T = np.union1d(T, corners.triangles(_pinches(outer)))
            return None

        for i in tried:
            if done[i]:
                continue
            for rings in REGION_RINGS:
                got = region(i, rings)
                if got is None:
                    continue
                T, members, loop = got
                if T.tobytes() in failed:  # (the region of a loop met before, from another)
                    break
                failed.add(T.tobytes())
                F = _relaid(X, normals, faces[T], loop, members=members, rim=rim, walks=walks)
                if F is None:
                    break  # (a wider ring lays out no better: measured)
                if not _flat_enough(X, normals, F, faces[T]):
                    continue
                hF = np.maximum(h[F].mean(axis=1), 1e-300)
                width = np.maximum(enclosing_radius(X, F), _empty_radius(X, F, cloud.tree)) / hF
                if float(width.max()) > REGION_WIDTH * bound:
                    continue
                # No edge inside the patch may be an edge of the mesh outside the region.
                E = np.sort(_directed(F), axis=1)
                ek, ec = np.unique(E[:, 0] * n + E[:, 1], return_counts=True)
                inner = ek[ec == 2]
                lo, hi = inner // n, inner % n
                old = np.sort(_directed(faces[T]), axis=1)
                own = set((old[:, 0] * n + old[:, 1]).tolist())
                outside = (corners.has_half(lo, hi) | corners.has_half(hi, lo)) & ~isin(inner, own)
                if outside.any() or not taken_edges.isdisjoint(ek.tolist()):
                    continue
                busy[T] = True
                done[list(members)] = True
                fills.append(F)
                taken_edges.update(ek.tolist())
                closed += len(members)
                break
        if not fills:
            break
        faces = np.concatenate([faces[~busy], *fills])
    return faces, closed


def fill_slits(X: np.ndarray, normals: np.ndarray, faces: np.ndarray, h: np.ndarray,
               bound: float, exclude: np.ndarray | None = None, *, cloud=None
               ) -> tuple[np.ndarray, int]:
    """The open mesh ``faces`` with its slits filled: the loops longer than the fill pass tries
    (:data:`pcgeom.maps.topology.GROW_LOOP` bound circles: a rim or a hole of the surface, it
    takes them) but its longest, that have a flat fill (:func:`pcgeom.maps.topology.fill_loop`)
    no wider, nor leaving a wider empty circle, than the bound. A round hole that long has
    wider fills; a slit between two rows of points (face_human_choi's eyes: 19 points, 9.2
    circles of the local spacing round, fills 2.74 local spacings wide for a bound of 2.98)
    is a gap the sampling leaves. How many were filled, with the faces."""
    from .topology import GROW_LOOP, _fill_pass, simple_loops
    from .topology_batch import loop_figures

    if not SLITS or not len(faces):
        return faces, 0
    loops = simple_loops(faces)
    perimeter, median = loop_figures(X, h, loops)[:2]
    circles = perimeter / (2.0 * np.pi * median)
    long = [q for q in np.argsort(circles)[:-1].tolist() if circles[q] > GROW_LOOP * bound]
    if not long:
        return faces, 0
    faces, filled = _fill_pass(X, normals, faces, h, bound, exclude, grow=np.inf,
                               loops=[loops[q] for q in long], empty=1.0, cloud=cloud)[:2]
    return faces, filled


def _simple_in_plane(X: np.ndarray, normals: np.ndarray, loop: np.ndarray) -> bool:
    """Whether the walk ``loop`` is a simple polygon in the plane of its points' normals (a
    point met twice is not)."""
    import shapely

    from .topology import _plane

    if len(np.unique(loop)) != len(loop):
        return False
    frame = _plane(X, normals, loop)
    Q = (X[loop] - X[loop].mean(axis=0)) @ frame[:2].T
    return bool(shapely.Polygon(Q).is_valid)


def _layouts(X: np.ndarray, normals: np.ndarray, pts: np.ndarray):
    """Layouts (k, 2) of the region's points ``pts``, tried in turn: their projection on the
    plane of their mean normal, and the classical MDS of their geodesic distances along
    their 8 nearest points among themselves (edges whose ends' normals face apart left
    out: no path jumps across to a near sheet)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import dijkstra
    from scipy.spatial import cKDTree

    P = X[pts]
    nrm = normals[pts].sum(axis=0)
    if np.linalg.norm(nrm) > 0.5 * len(pts):
        nrm = nrm / np.linalg.norm(nrm)
        a = cross3(nrm, [1.0, 0.0, 0.0] if abs(nrm[0]) < 0.9 else [0.0, 1.0, 0.0])
        a /= np.linalg.norm(a)
        yield (P - P.mean(axis=0)) @ np.stack([a, cross3(nrm, a)]).T
    k = min(9, len(pts))
    dist, nb = cKDTree(P).query(P, k)
    rows = np.repeat(np.arange(len(pts)), k)
    cols, w = nb.ravel(), dist.ravel()
    ok = (cols != rows) & (np.einsum("kd,kd->k", normals[pts][rows], normals[pts][cols]) > 0)
    G = coo_matrix((w[ok], (rows[ok], cols[ok])), shape=(len(pts),) * 2).tocsr()
    D = dijkstra(G, directed=False)
    if not np.isfinite(D).all():
        return
    J = np.eye(len(pts)) - 1.0 / len(pts)
    B = -0.5 * J @ (D ** 2) @ J
    vals, vecs = np.linalg.eigh(B)
    yield vecs[:, -2:] * np.sqrt(np.maximum(vals[-2:], 0.0))


def _relaid(X: np.ndarray, normals: np.ndarray, T: np.ndarray, loop: np.ndarray, *,
            members: set, rim: np.ndarray, walks: list) -> np.ndarray | None:
    """The Delaunay triangles of the region ``T``'s points (its triangles, (K, 3)) inside its
    outer rim ``loop`` (its points in order, each rim edge ``loop[i] -> loop[i + 1]`` a
    half-edge of ``T``) in a layout of them (:func:`_layouts`), oriented as the mesh: the
    first layout whose triangles are a disk with exactly that rim and hold every point;
    None when none is."""
    import shapely
    from scipy.spatial import Delaunay, QhullError

    from .topology import _rim_is

    pts = np.unique(T)
    inner = setdiff(pts, loop)
    order = np.concatenate([loop, inner])
    k = len(loop)
    for Q in _layouts(X, normals, order):
        polygon = shapely.Polygon(Q[:k])
        if not polygon.is_valid or polygon.area <= 0:
            continue
        if not shapely.contains_xy(polygon, Q[k:, 0], Q[k:, 1]).all():
            continue
        try:
            S = Delaunay(Q).simplices.astype(np.int64)
        except QhullError:
            continue
        # The triangles inside the rim (a Delaunay triangle is inside or outside the rim's
        # polygon when its rim edges are Delaunay edges: its centre tells; checked after).
        centre = Q[S].mean(axis=1)
        S = S[shapely.contains_xy(polygon, centre[:, 0], centre[:, 1])]
        if len(np.unique(S)) != len(order) or not _rim_is(S, k):
            continue
        a, b = Q[S[:, 1]] - Q[S[:, 0]], Q[S[:, 2]] - Q[S[:, 0]]
        cross = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
        if (np.abs(cross) <= 1e-12 * polygon.area).any():
            continue
        S[cross < 0] = S[cross < 0][:, [0, 2, 1]]
        F = order[S]
        D = _directed(F)
        key = set((D[:, 0] * len(X) + D[:, 1]).tolist())
        if int(loop[1]) * len(X) + int(loop[0]) in key:
            F = F[:, [0, 2, 1]]
        return F
    return None


def _widest_turn(X: np.ndarray, normals: np.ndarray, F: np.ndarray) -> float:
    """The widest angle (degrees) between a triangle of ``F`` and one of its corners' normals."""
    face = cross3(X[F[:, 1]] - X[F[:, 0]], X[F[:, 2]] - X[F[:, 0]])
    face /= np.maximum(np.linalg.norm(face, axis=1, keepdims=True), 1e-300)
    cos = float(np.einsum("md,mcd->mc", face, normals[F]).min())
    return float(np.degrees(np.arccos(np.clip(cos, -1.0, 1.0))))


def _flat_enough(X: np.ndarray, normals: np.ndarray, F: np.ndarray, old: np.ndarray) -> bool:
    """Whether the re-triangulation ``F`` of the region whose triangles were ``old`` keeps to
    its corners' normals: each triangle within :data:`pcgeom.maps.fills.REFILL_TURN` of each
    corner's normal, or, where the region's own triangles turned more, no more than they did
    and none facing away (:data:`REGION_TURN_OLD`)."""
    from .fills import REFILL_TURN

    turn = _widest_turn(X, normals, F)
    return turn <= REFILL_TURN or (REGION_TURN_OLD and turn < 90.0
                                   and turn <= _widest_turn(X, normals, old))
