"""The topology of the local mesh: measured, repaired, and the refusal of closed clouds on
planar domains (not in the paper).

The local mesh (:mod:`pcgeom.maps.localmesh`) is edge-manifold and consistently oriented, but
its topology need not be the surface's: where fans disagree it leaves small holes, two fans
can meet at one vertex (a pinch), and where two sheets nearly touch its triangles can bridge
them (a handle). A closed cloud then shows boundary loops and slips past a test on its
boundary into a folded planar map. This module measures the mesh's topology and repairs it:

1. **Widths.** Each triangle's width is the radius of its smallest enclosing circle in the
   local spacing (each point's mean distance to its 6 nearest points). The mesh's triangles
   are the empty circles the point density leaves on the surface; the widest one the
   sampling leaves (:func:`widest_empty`) is extrapolated from the bulk of their widths (the
   median and the 90th percentile, a Gaussian tail in the radius, to one in ``M``), so that
   the few triangles that span a hole of the surface do not set it. Times
   :data:`HOLE_MARGIN`, it is the bound of everything below: a rule of the sampling's own,
   the same on a jittered grid (tight) and on random points (a long tail).
2. **Open or closed.** A boundary loop longer than a circle :data:`GROW_LOOP` times that
   wide is a rim or a hole of the surface: the cloud is open. Then each loop (libigl's loops of the
   mesh with its pinched vertices split, each cut at its repeated vertices into simple loops) is
   filled where a fill no wider than the bound exists that lies flat: the Delaunay
   triangles, in the plane of the loop's normals, of its points and the unmeshed points
   inside it, or else its least-area triangulation in space (:func:`_least_area_fill`);
   none of whose triangles faces away from its corners' normals or gives an edge a third
   triangle. Folds are not filled: measured on the shared open surfaces, a fill that folds
   costs their maps (peaks_7holes_choi 0.030 to 0.046 rad, 9 flips). The loops left that are
   small (most false loops: no flat fill of the loop alone, as the mesh round it overlaps
   itself or the loop runs through pinched vertices) have their neighbourhood re-meshed
   flat instead (:func:`pcgeom.maps.fills.refill_small_loops`, its measured rule there);
   those left at a pinched vertex lose the vertex's smaller fan where the loops that leaves
   get flat fills (:func:`pcgeom.maps.pinches.mend_pinches`, :data:`PINCH_MEND`); on a mesh
   with no handles, those through a pinched vertex or crossing themselves in their plane
   have their region re-triangulated (:func:`pcgeom.maps.regions.retriangulate_regions`).
3. **Closed.** Without a long loop, the same fills; then the loops that no flat fill closes
   (the mesh overlaps itself there: noise, uneven density), or whose fill is wider than the
   bound, are opened further (their points' triangles go) and filled again, folds allowed,
   fills as wide as the loops that made the cloud closed (:data:`GROW_LOOP` times the
   bound), up to :data:`TRIAL_ROUNDS` times; kept when that closes the mesh and it keeps
   :data:`TRIAL_KEEP` of its points. A closed cloud gets no planar map, and the sphere map
   wants a closed mesh.
4. **Pinches** (libigl's ``is_vertex_manifold``) that a fill joined are repaired; the rest
   are split for the count (libigl's ``split_nonmanifold``) and kept in the mesh (LSCM maps
   both fans; the disk and domain maps drop the smaller; dropping them before the fills,
   :data:`PINCH_FANS`, is off: measured there). Bridges between sheets (handles)
   are counted in the genus, not cut: cutting the handles of face_human_choi's bare mesh
   (Tutte's embedding folds where they are, :func:`pcgeom.maps.injective._cut_handles`)
   made its free map worse, 0.033 to 0.074 rad.

The report, :class:`Topology`, is of the repaired mesh's largest part (the one every map
uses): Euler characteristic ``chi = V - E + F`` (pinches split), boundary loops ``b``, genus
``(2 - chi - b) / 2``, and the counts of the repairs. :func:`require_open` refuses a closed
one on a planar domain.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from ..errors import InputError
from ..mesh import (corner_fans, cross3, drop_smaller_fans, face_keys, fan_counts,
                    half_edges as _directed, twins)
from .fills import refill_small_loops
from .pinches import mend_pinches
from .regions import fill_slits, retriangulate_regions
from .topology_batch import (FILLS, CloudTree, KnownTwins, add_fills, cut_at_repeats,
                             edge_keys, main_faces, sub_twins, triage, unmeshed)

__all__ = ["Topology", "measure", "repair", "require_open", "closed_message"]

HOLE_MARGIN = 1.35
"""A hole is filled, and a triangle kept, when its width is at most this times the widest
empty circle the sampling leaves (:func:`widest_empty`)."""

TRIAL_ROUNDS = 3
"""Rounds of the trial that closes a mesh whose short loops no flat fill closes."""

TRIAL_KEEP = 0.9
"""... and kept when its mesh still holds this share of the points."""

GROW_LOOP = 2.5
"""A loop longer than a circle this many times the widest empty radius is a rim or a hole of
the surface: the cloud is open. At 3.0 an ellipsoid band of 1.5k uniform points (its two
holes 6.6 and 7.0 spacings in radius, the bound 7.1) was closed by the closing trial; at 2.5
it keeps both holes, while 32 closed clouds (4 shapes, uniform and scan, noise 0 and 0.25, 2k
and 20k points), two 50k ones, the closed head and the shared open surfaces read the same
topology at 2.5 as at 3.0."""

PINCH_FANS = False
"""Whether an open mesh loses, at each pinched vertex, every fan but the largest before its
fills (:func:`drop_smaller_fans`; the loops through the vertex become one simple loop, which
the fills may close), the fill pass then under the empty-circle rule (:data:`PINCH_EMPTY`:
without it peaks_7holes_choi's true holes, spanned by the fans' long triangles, lose their
last loops: 13 -> 4 loops for 8 true). Off: measured side by side (``fast``, one run,
2026-12-05; today / off / on), the loops and the maps of the surfaces with near-touching
sheets gain, but the pleats' and face_human_choi's angle lose:

- loops (bare): peaks_7holes_choi 13 / 11 / 10 (its 8 true loops kept), peaks_three_cgal
  6 / 6 / 4, face_3holes_small_choi 4 / 4 / 4, face_human_choi 49 / 46 / 29; pinched
  vertices left 0;
- free maps, bare: lips_sheet(11000, gap=0.75) 0.0844 / 0.0871 / 0.0496 rad, 5.10 / 5.03 /
  4.42% flipped; face_human_choi 0.0331 / 0.0333 / 0.0342 rad, 856 / 851 / 750 flipped;
  pleated_sheet(6000, folds=4, gap=1.5) 0.0525 / 0.0261 / 0.0357 rad, 33 / 41 / 112
  flipped (disk 0.0308 -> 0.0446 rad); peaks_three_cgal 0.0413 -> 0.0398 rad, 8 -> 5
  flipped; face_3holes_small_choi 0.0103 -> 0.0096;
- with the mesh's normals: lips 0.0446 -> 0.0285 rad, 1.08 -> 0.82% flipped;
  face_human_choi 0.0234 -> 0.0220 rad but 20 -> 33 flipped.

(The normal rounds count the dropped fans' flips, :attr:`pcgeom.maps.localmesh.LocalMesh.
pinch_fans`: without them the bare maps' own flips fell under the rounds' threshold where
the fans were dropped, and the pleats lost their rounds, 0.0261 -> 0.0515 rad.)"""

PINCH_EMPTY = 0.75
"""With :data:`PINCH_FANS`, the fill pass's fills leave no empty circle wider than this times
the bound (peaks_7holes_choi: 1.0 kept 4 of its 7 holes, 0.75 all 7)."""

PINCH_MEND = True
"""Whether :func:`pcgeom.maps.pinches.mend_pinches` follows the re-meshes (measured there)."""

REGIONS = True
"""Whether :mod:`pcgeom.maps.regions`' re-triangulation follows the mend (measured there)."""

SPACING_NEIGHBOURS = 6
"""Nearest points whose mean distance is a point's local spacing."""


@dataclass(frozen=True)
class Topology:
    """The topology of a local mesh's largest part, after its repair, and the repairs."""

    closed: bool
    """No boundary loop: the cloud samples a closed surface."""
    genus: int
    """Handles: ``(2 - euler - boundary_loops) / 2``."""
    boundary_loops: int
    """Boundary loops (pinched vertices split)."""
    euler: int
    """Euler characteristic ``V - E + F`` (pinched vertices split)."""
    components: int
    """Parts of the whole mesh joined through edges (the largest is the one measured)."""
    vertices: int
    faces: int
    pinched: int
    """Pinched vertices left (two or more fans at one vertex, libigl's
    ``is_vertex_manifold``); each counts as split."""
    pinches_split: int
    """Pinched vertices of the mesh before its repair that are still pinched (split for the
    count)."""
    pinches_repaired: int
    """Pinched vertices of the mesh before its repair that a fill made manifold."""
    holes_filled: int
    spans_cut: int
    """Triangles cut as wider than the sampling leaves (spanning a hole of the surface; none
    yet: cutting them made the holes of tests/test_maps_domain.py's sheets 20-45% too
    large)."""
    bridges_cut: int
    """Triangles cut as bridges between sheets before the repair (:mod:`pcgeom.maps.bridges`;
    the ``_before`` figures are of the mesh after that cut)."""
    euler_before: int
    boundary_loops_before: int
    genus_before: int

    def to_dict(self) -> dict:
        return asdict(self)


# --------------------------------------------------------------------------- measure


def measure(faces: np.ndarray) -> dict:
    """:func:`_measure`'s figures of the mesh ``faces``' largest part."""
    return _measure(faces)[0]


def _measure(faces: np.ndarray, found: dict | None = None, twins_of=twins, *,
             fans_of=fan_counts, parts_of=main_faces) -> tuple[dict, np.ndarray]:
    """Euler characteristic, boundary loops, genus, parts and pinched vertices of the largest
    part of the mesh ``faces`` (M, 3) (edge-manifold, consistently oriented), its pinched
    vertices split (each open fan its own vertex, as libigl's ``split_nonmanifold``).

    Returns
    -------
    dict
        ``euler``, ``boundary_loops``, ``genus``, ``components``, ``vertices``, ``faces``,
        ``pinched``; and (n,) bool, the pinched vertices. ``found`` (a dict), when given,
        receives ``twin`` and ``consistent``: :func:`pcgeom.mesh.twins` of ``faces``.
        ``twins_of``, ``fans_of``, ``parts_of``: :func:`pcgeom.mesh.twins`,
        :func:`pcgeom.mesh.fan_counts` and :func:`main_faces`, or a
        :class:`KnownTwins`' ``of``, ``fans`` and ``parts`` (found once per faces array).
    """
    faces = np.asarray(faces, dtype=np.int64)
    if len(faces) == 0:
        return {"euler": 0, "boundary_loops": 0, "genus": 0, "components": 0, "vertices": 0,
                "faces": 0, "pinched": 0}, np.zeros(0, dtype=bool)
    twin, consistent = twins_of(faces)  # (twins_of: twins, or a KnownTwins' of)
    if found is not None:
        found.update(twin=twin, consistent=consistent)
    main, parts, kept = parts_of(faces, twin if consistent else None)
    if parts > 1 and consistent:
        twin = sub_twins(kept, twin)
    elif parts > 1:
        twin, consistent = twins(main)
    _, following = _rim_next(main, twin)
    fans = fans_of(main, twin) if consistent else _fans(main, twin)
    used = fans > 0
    vertices = int(fans.sum())  # each fan its own vertex
    if consistent:  # each edge two half-edges, or one on the boundary
        edges = (len(twin) + int((twin < 0).sum())) // 2
    else:
        n = int(main.max()) + 1
        D = np.sort(_directed(main), axis=1)
        edges = len(np.unique(D[:, 0] * n + D[:, 1]))
    euler = vertices - edges + len(main)
    loops = _cycles(following)
    return {"euler": euler, "boundary_loops": loops, "genus": (2 - euler - loops) // 2,
            "components": parts, "vertices": int(used.sum()), "faces": len(main),
            "pinched": int((fans > 1).sum())}, fans > 1


def _rim_next(F: np.ndarray, twin: np.ndarray | None = None
              ) -> tuple[np.ndarray, np.ndarray]:
    """The boundary half-edges of the edge-manifold, consistently oriented mesh ``F``,
    ``(B, 2)``, and for each the one that follows it in its fan's rim (B,): from ``u -> v``
    round ``v`` through the triangles that share its edges, to the fan's other boundary
    half-edge leaving ``v`` (so that at a pinched vertex each fan keeps its own rim).
    ``twin``: :func:`pcgeom.mesh.twins`' first, when already found."""
    m = len(F)
    H = _directed(F)
    if twin is None:
        twin = twins(F)[0]
    boundary = np.flatnonzero(twin < 0)
    slot, tri = boundary // m, boundary % m
    e = ((slot + 1) % 3) * m + tri  # the triangle's half-edge leaving v
    found = np.full(len(boundary), -1, dtype=np.int64)
    todo = np.arange(len(boundary))
    for _ in range(len(F) + 1):
        if not len(todo):
            break
        t = twin[e[todo]]
        done = t < 0
        found[todo[done]] = e[todo[done]]
        todo, t = todo[~done], t[~done]
        e[todo] = ((t // m + 1) % 3) * m + t % m
    index = np.full(len(H), -1, dtype=np.int64)
    index[boundary] = np.arange(len(boundary))
    return H[boundary], index[found]


def _fans(F: np.ndarray, twin: np.ndarray | None = None) -> np.ndarray:
    """(n,) how many fans each vertex has (its triangles joined through the edges at it)."""
    label = corner_fans(F, twin)
    fan_vertex = np.empty(int(label.max()) + 1, dtype=np.int64)
    fan_vertex[label] = F.T.ravel()  # node slot * m + tri is F[tri, slot]
    return np.bincount(fan_vertex, minlength=int(F.max()) + 1)


def _cycles(following: np.ndarray) -> int:
    """How many cycles the permutation ``following`` (B,) has."""
    if not len(following):
        return 0
    import scipy.sparse as sp
    from scipy.sparse.csgraph import connected_components

    k = len(following)
    graph = sp.coo_matrix((np.ones(k, dtype=np.int8), (np.arange(k), following)), shape=(k, k))
    return int(connected_components(graph, directed=True, connection="weak")[0])


# --------------------------------------------------------------------------- loops


def rim_walks(F: np.ndarray, twin: np.ndarray | None = None
              ) -> tuple[np.ndarray, list[np.ndarray]]:
    """The boundary half-edges of ``F`` (B, 2) and its boundary loops as walks (each a list of
    indices into them, in order; a pinched vertex may come twice). ``twin``:
    :func:`pcgeom.mesh.twins`' first, when already found."""
    rim, following = _rim_next(F, twin)
    seen = [False] * len(rim)  # (a list: a numpy bool per step costs more)
    nxt = following.tolist()
    walks = []
    for first in range(len(rim)):
        if seen[first]:
            continue
        walk, e = [], first
        while not seen[e]:
            seen[e] = True
            walk.append(e)
            e = nxt[e]
        walks.append(np.asarray(walk, dtype=np.int64))
    return rim, walks


def simple_loops(faces: np.ndarray, twin: np.ndarray | None = None) -> list[np.ndarray]:
    """The boundary loops of the edge-manifold, consistently oriented mesh ``faces`` (each
    fan of a pinched vertex keeps its own rim, :func:`_rim_next`), each cut at its repeated
    vertices into simple loops, in the direction of the faces' boundary edges (each loop
    edge ``a -> b`` is an edge of a triangle as it turns). ``twin``:
    :func:`pcgeom.mesh.twins`' first, when already found."""
    F = np.asarray(faces, dtype=np.int64)
    if len(F) == 0:
        return []
    rim, walks = rim_walks(F, twin)
    out = []
    for walk in walks:
        if len(walk) >= 3:
            out.extend(cut_at_repeats(rim[walk, 0]))
    return out


# --------------------------------------------------------------------------- widths


def enclosing_radius(X: np.ndarray, F: np.ndarray) -> np.ndarray:
    """(M,) radius of each triangle's smallest enclosing circle: its circumradius when it is
    acute, half its longest edge otherwise (an obtuse sliver's circumcircle is no empty circle
    of the surface)."""
    P = X[F]  # (M, 3, 3): one gather
    e = np.stack([((P[:, (q + 1) % 3] - P[:, (q + 2) % 3]) ** 2).sum(axis=1)
                  for q in range(3)], axis=1)
    longest = e.max(axis=1)
    area2 = np.linalg.norm(cross3(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]), axis=1)
    circum = np.sqrt(e.prod(axis=1)) / np.maximum(2.0 * area2, 1e-300)
    obtuse = 2.0 * longest >= e.sum(axis=1)
    return np.where(obtuse, 0.5 * np.sqrt(longest), circum)


# --------------------------------------------------------------------------- fill


def _plane(X: np.ndarray, normals: np.ndarray, loop: np.ndarray) -> np.ndarray:
    """An orthonormal frame ``(a, b, n)`` (3, 3) of the loop's plane: ``n`` the mean of its
    points' normals, or the least-variance direction of its points where they disagree."""
    n = normals[loop].sum(axis=0)
    if np.linalg.norm(n) < 0.5 * len(loop):
        P = X[loop] - X[loop].mean(axis=0)
        n = np.linalg.svd(P, full_matrices=False)[2][2]
        if n @ normals[loop].sum(axis=0) < 0:
            n = -n
    n = n / np.linalg.norm(n)
    a = cross3(n, [1.0, 0.0, 0.0] if abs(n[0]) < 0.9 else [0.0, 1.0, 0.0])
    a /= np.linalg.norm(a)
    return np.stack([a, cross3(n, a), n])


def fill_loop(X: np.ndarray, normals: np.ndarray, loop: np.ndarray, inner: np.ndarray,
              edges: np.ndarray | None = None, folds: bool = False, *,
              loop_alone: bool = True) -> np.ndarray | None:
    """Triangles (k, 3) that fill the simple boundary loop ``loop`` (in the faces' boundary
    direction), over it and the candidate points ``inner`` that lie inside it, oriented as
    the mesh; None when the loop has no simple shape in its plane, or its fill's rim is not
    the loop, or a fill triangle faces away from its corners' normals. ``edges``: the mesh's
    edges (``a * N + b``, ``a < b``), which no fill triangle may hold but the loop's own.
    ``loop_alone``: False where a fill of the loop's points alone is of no use (a re-mesh
    that must use the points inside): None instead of one.

    The loop and the points are projected on the plane of the loop's normals
    (:func:`_plane`); the Delaunay triangles inside the loop are the fill. Where the loop's
    edges are not all Delaunay edges, the constrained Delaunay triangulation of the loop
    alone (shapely) is."""
    import shapely
    from scipy.spatial import Delaunay, QhullError

    if len(loop) == 3 and not len(inner):  # one triangle, each loop edge the other way
        F = loop[None, [0, 2, 1]]
        face = cross3(X[F[0, 1]] - X[F[0, 0]], X[F[0, 2]] - X[F[0, 0]])
        return F if folds or face @ normals[loop].sum(axis=0) > 0 else None
    if not len(inner) and loop_alone and not folds and len(loop) <= 8:  # a short loop alone:
        if _least_area_fill(X, normals, loop, edges) is None:  # its least-area fill folds or
            return None  # needs an edge the mesh has, so does every fill (the planar one too)
    frame = _plane(X, normals, loop)
    centre = X[loop].mean(axis=0)
    Q = (X[loop] - centre) @ frame[:2].T
    polygon = shapely.Polygon(Q)
    if not polygon.is_valid or polygon.area <= 0:
        return _least_area_fill(X, normals, loop, edges, folds) if loop_alone else None
    region = polygon.buffer(1e-9 * np.sqrt(polygon.area))
    shapely.prepare(region)
    if len(inner):
        # Points on the loop's side of the surface, inside the loop's outline.
        R = (X[inner] - centre) @ frame.T
        reach = np.linalg.norm(Q, axis=1).max()
        near = (np.abs(R[:, 2]) < reach) & (normals[inner] @ frame[2] > 0)
        inner, R = inner[near], R[near]
        inside = shapely.contains_xy(polygon, R[:, 0], R[:, 1]) if len(inner) else []
        inner, R = inner[inside], R[inside] if len(inner) else R
    pts = np.concatenate([loop, inner]).astype(np.int64)
    P = np.concatenate([Q, R[:, :2]]) if len(inner) else Q
    T = None
    if len(pts) > 3:
        try:
            T = Delaunay(P).simplices.astype(np.int64)
        except QhullError:
            T = None
    else:
        T = np.array([[0, 1, 2]])
    if T is not None:
        T = T[shapely.contains(region, shapely.polygons(P[T]))]
        if not _rim_is(T, len(loop)):
            T = None
    if T is None:  # the loop alone, its edges kept
        if not loop_alone:
            return None
        pts, P = loop, Q
        tri = shapely.constrained_delaunay_triangles(polygon)
        corners = np.array([np.asarray(t.exterior.coords)[:3] for t in tri.geoms])
        lookup = {tuple(p): i for i, p in enumerate(np.round(Q, 12).tolist())}
        try:
            T = np.array([[lookup[tuple(p)] for p in np.round(c, 12).tolist()] for c in corners])
        except KeyError:
            return None
        if len(T) == 0 or not _rim_is(T, len(loop)):
            return None
    # Counter-clockwise in the plane (seen from the normals' side), then as the mesh: the
    # fill holds each loop edge the other way round.
    a, b = P[T[:, 1]] - P[T[:, 0]], P[T[:, 2]] - P[T[:, 0]]
    cross = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    if (np.abs(cross) <= 1e-12 * polygon.area).any():
        return None
    T[cross < 0] = T[cross < 0][:, [0, 2, 1]]
    F = pts[T]
    if _has_directed(F, int(loop[0]), int(loop[1])):
        F = F[:, [0, 2, 1]]
    # Each triangle faces the side of its corners' normals.
    face = cross3(X[F[:, 1]] - X[F[:, 0]], X[F[:, 2]] - X[F[:, 0]])
    if (np.einsum("md,md->m", face, normals[F].sum(axis=1)) <= 0).any() or (
            edges is not None and _holds(F, edges, len(X))):
        return _least_area_fill(X, normals, loop, edges, folds) if loop_alone else None
    return F


def _holds(F: np.ndarray, edges: np.ndarray, n: int) -> bool:
    """Whether a triangle of ``F`` has an edge of ``edges`` (sorted ``a * n + b``, ``a < b``)
    that is not on the loop (an edge of one triangle of ``F``)."""
    D = np.sort(_directed(F), axis=1)
    key = D[:, 0] * n + D[:, 1]
    keys, count = np.unique(key, return_counts=True)
    inner = keys[count == 2]
    at = np.minimum(np.searchsorted(edges, inner), len(edges) - 1)
    return bool((edges[at] == inner).any())


LEAST_AREA_LOOP = 60
"""Loops of at most this many points whose outline crosses itself in their plane are filled
by their least-area triangulation in space (:func:`_least_area_fill`)."""


def _least_area_fill(X: np.ndarray, normals: np.ndarray, loop: np.ndarray,
                     edges: np.ndarray | None = None, folds: bool = False
                     ) -> np.ndarray | None:
    """The triangulation of the loop's polygon in space (no new point) of least total area,
    triangles facing away from their corners' normals priced out (dynamic programming over the
    polygon's diagonals, O(k^3); Barequet and Sharir's, as in Liepa's hole filling), oriented as the
    mesh (each loop edge the other way
    round); no diagonal may be an edge of ``edges`` (the mesh's: ``a * N + b``, ``a < b``).
    None for loops of more than :data:`LEAST_AREA_LOOP` points (twice that with ``folds``),
    or when every triangulation
    needs such a diagonal or (unless ``folds``) a triangle facing away (a fold: no fill of
    it maps flat)."""
    k = len(loop)
    if k > (LEAST_AREA_LOOP if not folds else 2 * LEAST_AREA_LOOP):
        return None
    P, Nv = X[loop], normals[loop]
    i, m, j = np.meshgrid(np.arange(k), np.arange(k), np.arange(k), indexing="ij")
    face = cross3(P[j] - P[i], P[m] - P[i])  # (i, j, m): each loop edge reversed
    area = 0.5 * np.linalg.norm(face, axis=-1)
    away = np.einsum("ijmd,ijmd->ijm", face, Nv[i] + Nv[j] + Nv[m]) <= 0
    far = 10.0 * (area.sum() / max(k, 1) ** 2 + 1e-300) * k
    cost = area + away * far
    if edges is not None:
        lo, hi = np.minimum.outer(loop, loop), np.maximum.outer(loop, loop)
        key = lo * len(X) + hi
        at = np.minimum(np.searchsorted(edges, key), len(edges) - 1)
        blocked = edges[at] == key
        ring = np.abs(np.subtract.outer(np.arange(k), np.arange(k)))
        blocked &= (ring != 1) & (ring != k - 1)  # the loop's own edges are the mesh's
        cost = np.where(blocked[i, j] | blocked[j, m] | blocked[m, i], np.inf, cost)
    best = np.zeros((k, k))
    split = np.zeros((k, k), dtype=np.int64)
    for gap in range(2, k):  # every polygon a .. a + gap at once
        a = np.arange(0, k - gap)[:, None]
        b = a + gap
        mids = a + np.arange(1, gap)[None, :]
        total = best[a, mids] + best[mids, b] + cost[a, mids, b]
        pick = np.argmin(total, axis=1)
        rows = np.arange(len(a))
        best[a[:, 0], b[:, 0]] = total[rows, pick]
        split[a[:, 0], b[:, 0]] = mids[rows, pick]
    if not np.isfinite(best[0, k - 1]) or (best[0, k - 1] >= far and not folds):
        return None
    tris, stack = [], [(0, k - 1)]
    while stack:
        a, b = stack.pop()
        if b - a < 2:
            continue
        c = split[a, b]
        tris.append((a, b, c))
        stack += [(a, c), (c, b)]
    F = loop[np.asarray(tris, dtype=np.int64)]
    if _has_directed(F, int(loop[0]), int(loop[1])):
        F = F[:, [0, 2, 1]]
    return F


def _rim_is(T: np.ndarray, k: int) -> bool:
    """Whether the triangles ``T`` (over points ``0 .. k - 1`` of a loop and others) have
    exactly the loop's edges ``(i, i + 1)`` as their rim, and hold every loop point."""
    if len(T) == 0:
        return False
    E = np.sort(_directed(T), axis=1)
    keys, count = np.unique(E[:, 0] * (T.max() + 1) + E[:, 1], return_counts=True)
    rim = keys[count == 1]
    i = np.arange(k)
    j = (i + 1) % k
    loop = np.sort(np.minimum(i, j) * (T.max() + 1) + np.maximum(i, j))
    return len(rim) == k and np.array_equal(np.sort(rim), loop) and (count <= 2).all()


def _has_directed(F: np.ndarray, a: int, b: int) -> bool:
    D = _directed(F)
    return bool(((D[:, 0] == a) & (D[:, 1] == b)).any())


# --------------------------------------------------------------------------- repair


def knn_spacing(X: np.ndarray, k: int = SPACING_NEIGHBOURS) -> np.ndarray:
    """(N,) each point's local spacing: the mean distance to its ``k`` nearest points."""
    from scipy.spatial import cKDTree

    dist = cKDTree(X).query(X, k + 1)[0]
    return dist[:, 1:].mean(axis=1)


def widest_empty(widths: np.ndarray) -> float:
    """The widest empty circle the sampling leaves among ``M = len(widths)`` triangles, from
    the bulk of their widths: the survival ``S(t) = P(w > t)`` taken as ``exp(a - c t^2)``
    (empty circles of a random sample: a Gaussian tail in the radius) through the median and
    the 90th percentile, solved for ``S = 1 / M``. The bulk, not the tail: the triangles that
    span the surface's holes (a few percent) leave it alone."""
    if len(widths) < 10:
        return float(np.max(widths, initial=0.0))
    q50, q90 = np.quantile(widths, [0.5, 0.9])
    if q90 <= q50:
        return float(q90)
    c = np.log(5.0) / (q90 ** 2 - q50 ** 2)
    a = np.log(0.5) + c * q50 ** 2
    return float(np.sqrt((a + np.log(len(widths))) / c))


def repair(X: np.ndarray, normals: np.ndarray, faces: np.ndarray, *,
           exclude: np.ndarray | None = None, spacing: np.ndarray | None = None,
           dropped: list | None = None, cloud=None) -> tuple[np.ndarray, Topology]:
    """The local mesh with the surface's holes opened and the holes its sampling can leave
    filled (steps 1-2 of the module), and the topology of the result.

    Parameters
    ----------
    X : (N, 3) float64
        The points.
    normals : (N, 3) float64
        Their oriented unit normals (rows of excluded points unused).
    faces : (M, 3) int64
        The local mesh: edge-manifold, consistently oriented.
    exclude : (N,) bool, optional
        Points no fill may use (strays).
    spacing : (N,) float64, optional
        Each point's local spacing (:func:`knn_spacing`), when already known.
    cloud : scipy.spatial.cKDTree, optional
        The k-d tree of the points not excluded (``X[~exclude]``, in order), when already
        built (:attr:`pcgeom.neighbours.Neighbours.tree`); the fills' tests query it.

    Returns
    -------
    faces : (M', 3) int64
        The faces less those wider than the sampling leaves, with the fills (edge-manifold,
        consistently oriented).
    Topology
    """
    faces = np.asarray(faces, dtype=np.int64)
    n = len(X)
    found: dict = {}
    known = KnownTwins()  # (each step's twins found once)
    before, pinched_before = _measure(faces, found, known.of, fans_of=known.fans,
                                        parts_of=known.parts)
    trees = CloudTree(X, exclude, cloud)
    filled = 0
    if len(faces):
        h = knn_spacing(X) if spacing is None else np.asarray(spacing, dtype=np.float64)
        width = enclosing_radius(X, faces) / np.maximum(h[faces].mean(axis=1), 1e-300)
        bound = HOLE_MARGIN * widest_empty(width)
        loops = simple_loops(faces, found.get("twin"))
        if _has_long_loop(X, loops, h, GROW_LOOP * bound):
            # A loop longer than any hole the sampling leaves: an open surface. The holes
            # the sampling leaves are filled where a flat fill closes them (a fold costs its
            # map).
            if PINCH_FANS:
                kept = drop_smaller_fans(faces)
                if len(kept) < len(faces):
                    if dropped is not None:
                        gone = ~np.isin(face_keys(faces, n), face_keys(kept, n))
                        dropped.append(faces[gone])
                    faces, loops = kept, simple_loops(kept)
            faces, filled, _, _ = _fill_pass(X, normals, faces, h, bound, exclude, loops=loops,
                                             empty=PINCH_EMPTY if PINCH_FANS else None,
                                             found=None if PINCH_FANS else found, cloud=trees)
            memo = FILLS.bind(X, exclude, h)  # (the fills earlier repairs of X tried)
            faces, refilled = refill_small_loops(X, normals, faces, h, bound, exclude,
                                                 cloud=trees, twins_of=known.of, memo=memo)
            filled += refilled
            if PINCH_MEND:
                faces, mended = mend_pinches(X, normals, faces, h, bound, exclude,
                                             cloud=trees, twins_of=known.of, memo=memo,
                                             fans_of=known.fans)
                filled += mended
            after = _measure(faces, None, known.of, fans_of=known.fans, parts_of=known.parts)
            if REGIONS and after[0]["genus"] == 0 and after[0]["boundary_loops"] > 1:
                relaid_faces, relaid = retriangulate_regions(X, normals, faces, h, bound, exclude,
                                                             cloud=trees, twins_of=known.of,
                                                             fans_of=known.fans,
                                                             parts_of=known.parts)
                relaid_faces, slits = fill_slits(X, normals, relaid_faces, h, bound, exclude,
                                                 cloud=trees)
                if relaid or slits:
                    faces, filled = relaid_faces, filled + relaid + slits
                    after = _measure(faces, None, known.of, fans_of=known.fans,
                                     parts_of=known.parts)
            return faces, _topology(before, pinched_before, *after, filled, 0)
        faces, filled, stuck, long = _fill_pass(X, normals, faces, h, bound, exclude,
                                                loops=loops, found=found, cloud=trees)
        if len(stuck) or long:
            # Loops left that no flat fill closes: the mesh overlaps itself there (noise,
            # uneven sampling), on what may be a closed surface. Their points' triangles go
            # and the larger holes are filled, folds allowed, a few times; kept only if that
            # closes the mesh (a fold costs a planar map, and a closed cloud gets none).
            trial, added = faces, 0
            for _ in range(TRIAL_ROUNDS):
                near = np.zeros(n, dtype=bool)
                near[stuck] = True
                trial = trial[~near[trial].any(axis=1)]
                trial, more, stuck, long = _fill_pass(X, normals, trial, h, GROW_LOOP * bound,
                                                      exclude, folds=True, grow=np.inf,
                                                      cloud=trees)
                added += more
                if not (more or len(stuck)):  # (two fills of one pass may share an edge)
                    break
            if (len(trial) and measure(trial)["boundary_loops"] == 0
                    and len(np.unique(trial)) >= TRIAL_KEEP * len(np.unique(faces))):
                faces, filled = trial, filled + added
    return faces, _topology(before, pinched_before, *_measure(faces), filled, 0)


def _topology(before: dict, pinched_before: np.ndarray, after: dict,
              pinched_after: np.ndarray, filled: int, carved: int) -> Topology:
    k = max(len(pinched_before), len(pinched_after))
    pinched_before = np.pad(pinched_before, (0, k - len(pinched_before)))
    pinched_after = np.pad(pinched_after, (0, k - len(pinched_after)))
    return Topology(
        closed=after["boundary_loops"] == 0 and after["faces"] > 0, genus=after["genus"],
        boundary_loops=after["boundary_loops"], euler=after["euler"],
        components=after["components"], vertices=after["vertices"], faces=after["faces"],
        pinched=int(pinched_after.sum()),
        pinches_split=int((pinched_before & pinched_after).sum()),
        pinches_repaired=int((pinched_before & ~pinched_after).sum()),
        holes_filled=filled, spans_cut=carved, bridges_cut=0, euler_before=before["euler"],
        boundary_loops_before=before["boundary_loops"], genus_before=before["genus"])


def _has_long_loop(X: np.ndarray, loops: list[np.ndarray], h: np.ndarray, radius: float
                   ) -> bool:
    """Whether a boundary loop of ``loops`` (:func:`simple_loops`) is longer than a circle of
    ``radius`` local spacings (the median of its points')."""
    for loop in loops:
        perimeter = np.linalg.norm(X[np.roll(loop, -1)] - X[loop], axis=1).sum()
        if perimeter > 2.0 * np.pi * radius * float(np.median(h[loop])):
            return True
    return False


def _fill_pass(X: np.ndarray, normals: np.ndarray, faces: np.ndarray, h: np.ndarray,
               bound: float, exclude: np.ndarray | None, *, folds: bool = False,
               grow: float = 1.0, loops: list[np.ndarray] | None = None,
               empty: float | None = None, found: dict | None = None,
               cloud: CloudTree | None = None) -> tuple[np.ndarray, int, np.ndarray, int]:
    """One pass of step 1's fills over the loops of ``faces``: the faces with the fills, how
    many, and the points of the loops that the sampling can leave (no longer than a circle
    of radius ``grow * bound`` spacings) but that no fill closes (every fill folds, unless
    ``folds``, or needs an edge the mesh has), and how many loops are left that are longer.
    ``loops``: ``simple_loops(faces)``, when already found. ``empty``: a fill is kept only
    when no triangle of it leaves an empty circle round its circumcentre wider than this
    times ``bound`` (as the re-mesh's rule, :data:`pcgeom.maps.fills.REFILL_WIDTH`).
    ``found``: :func:`_measure`'s of ``faces``, when measured. ``cloud``: the tree of the
    points not excluded, when at hand."""
    from scipy.spatial import cKDTree

    n = len(X)
    free, tree = unmeshed(X, faces, exclude)
    edges = edge_keys(faces, n, found)

    is_meshed = np.bincount(faces.ravel(), minlength=n) > 0
    meshed = np.flatnonzero(is_meshed)
    trees: dict = {}  # built when first needed
    cloud = CloudTree(X, exclude) if cloud is None else cloud

    def narrow(F: np.ndarray) -> bool:
        radius = enclosing_radius(X, F)
        if float((radius / np.maximum(h[F].mean(axis=1), 1e-300)).max()) > bound:
            return False
        if empty is not None:
            from .fills import _empty_radius

            gap = _empty_radius(X, F, cloud.tree) / np.maximum(h[F].mean(axis=1), 1e-300)
            if float(gap.max()) > empty * bound:
                return False
        # A fill over meshed points is a second sheet over the surface (a cap over a small
        # patch's rim), not a hole's: a few meshed points near its triangles at most (where
        # the mesh overlaps itself round a small hole), not a patch of them.
        # (The meshed points through the cloud's tree, when it holds them all.)
        under = cloud.meshed_near(X[F].mean(axis=1), 0.5 * radius, is_meshed)
        if under is None:
            if "mesh" not in trees:
                trees["mesh"] = cKDTree(X[meshed])
            near = trees["mesh"].query_ball_point(X[F].mean(axis=1), 0.5 * radius)
            under = set().union(*(meshed[k].tolist() for k in near))
        under -= set(F.ravel().tolist())
        return len(under) <= max(2, len(np.unique(F)) // 4)

    fills, stuck, long = [], [], 0
    loops = simple_loops(faces) if loops is None else loops
    perimeters, circles, tried, near, folded = triage(
        X, normals, h, loops, radius=bound, longest=GROW_LOOP if np.isfinite(grow) else np.inf,
        tree=tree, edges=None if folds else edges)
    for q, loop in enumerate(loops):
        perimeter, circle = perimeters[q], circles[q]
        if not tried[q]:
            long += 1  # a rim or a hole of the surface (or a slit as long): not tried
            continue
        inner = free[np.asarray(near[q], dtype=np.int64)] if len(near[q]) else np.zeros(
            0, dtype=np.int64)
        F = None if folded[q] else fill_loop(X, normals, loop, inner, edges, folds)
        if F is None:
            # No fill without a fold or a third triangle on an edge: the mesh overlaps
            # itself there. A loop no longer than a circle the sampling leaves is stuck.
            if perimeter <= grow * circle:
                stuck.append(loop)
            else:
                long += 1
            continue
        if narrow(F):
            fills.append(F)
        elif perimeter <= grow * circle:  # its fill covers meshed points or is too wide
            stuck.append(loop)
        else:  # a hole of the surface
            long += 1
    added = 0
    if fills:
        faces, added = add_fills(faces, fills)
    return (faces, added, np.concatenate(stuck) if stuck else np.zeros(0, dtype=np.int64),
            long)


# --------------------------------------------------------------------------- refusal


PLANAR_CLOSED = ("the cloud is a closed surface (genus 0): a planar domain ({domain}) has no "
                 "map of it without a cut; map it with --domain sphere, or cut it open first")
"""The message for a closed genus-0 cloud on a planar domain."""

PLANAR_HANDLES = ("the cloud is a closed surface of genus {genus}: a planar domain ({domain}) "
                  "has no map of it without cuts; cut it open first (remove a strip of points "
                  "across each handle, and a cap)")
"""The message for a closed cloud of higher genus on a planar domain."""


def closed_message(topology: Topology, domain: str) -> str:
    """The one-line refusal of a closed cloud on the planar domain named ``domain``."""
    if topology.genus == 0:
        return PLANAR_CLOSED.format(domain=domain)
    return PLANAR_HANDLES.format(genus=topology.genus, domain=domain)


def require_open(topology: Topology | None, domain: str) -> None:
    """Refuse (:class:`InputError`, one line) a closed cloud on a planar domain: called where
    the map is chosen, before any map is made.

    Parameters
    ----------
    topology : Topology or None
        The repaired local mesh's (None: not measured, nothing to refuse).
    domain : str
        The planar domain's name, as the message shows it (``free``, ``disk``, ...).
    """
    if topology is not None and topology.closed:
        raise InputError(closed_message(topology, domain))
