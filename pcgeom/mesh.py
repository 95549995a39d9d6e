"""Triangle-mesh primitives the maps, the apps and the metrics share: one implementation each.

A mesh here is a face array ``F`` (M, 3) of vertex indices; points are ``V`` (N, 2) or
(N, 3). Nothing in this module knows about clouds, maps or domains: it is NumPy and SciPy on
index arrays.

=========================  =================================================================
what                       function
=========================  =================================================================
signed triangle areas      :func:`signed_areas` ``a_t = ((u_1 - u_0) x (u_2 - u_0)) / 2``
polygon area (shoelace)    :func:`shoelace`
the three edges of faces   :func:`half_edges` (3M, 2), :func:`opposite_corners` (3M,)
undirected edges           :func:`edge_ids`, :func:`unique_edges`, :func:`edge_sides`,
                           :func:`mean_edge`
boundary                   :func:`unpaired`, :func:`boundary_loops`
the main part              :func:`main_part` (joined through edges), :func:`main_faces`
a triangle as one integer  :func:`face_keys`
one fan per vertex         :func:`smaller_fans`, :func:`one_fan`
rim slivers                :func:`peel_rim`, :data:`RIM_ANGLE`
=========================  =================================================================
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["signed_areas", "shoelace", "barycentric", "half_edges", "opposite_corners",
           "edge_ids", "unique_edges", "euler_characteristic", "close_loops", "compact",
           "mean_edge", "edge_sides", "unpaired", "boundary_loops", "main_part", "main_faces",
           "face_keys", "smaller_fans", "one_fan", "successor_walks", "peel_rim",
           "RIM_ANGLE_DEG", "RIM_ANGLE", "cross3", "twins", "corner_fans", "fan_counts",
           "face_parts", "drop_smaller_fans", "shape_quality"]

RIM_ANGLE_DEG = 120.0
"""A rim triangle whose angle opposite its boundary edge is wider than this (degrees) is a
sliver that bridges a notch of the rim: the disk map peels it in the plane, the barrier map
in 3D (:func:`peel_rim`, ``InjectiveConfig.rim_angle``), and the flip count leaves it out
(:func:`pcgeom.maps.localmesh.mesh_flips`)."""

RIM_ANGLE = math.radians(RIM_ANGLE_DEG)
""":data:`RIM_ANGLE_DEG` in radians (``2 pi / 3``)."""


def signed_areas(U, F) -> np.ndarray:
    """Signed areas of the triangles ``F`` (M, 3) of the plane points ``U`` (N, 2), ``(M,)``:
    positive when ``U[F]`` is counter-clockwise.

    ``a_t = ((u_1 - u_0) x (u_2 - u_0)) / 2`` (the 2D cross product).
    """
    U = np.asarray(U, dtype=np.float64)
    F = np.asarray(F)
    e1 = U[F[:, 1]] - U[F[:, 0]]
    e2 = U[F[:, 2]] - U[F[:, 0]]
    return 0.5 * (e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])


def cross3(a, b) -> np.ndarray:
    """``np.cross(a, b)`` of 3-vectors along the last axis (broadcast), the same products in
    the same order, without its axis bookkeeping (several times faster on small arrays)."""
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


def shape_quality(P: np.ndarray, F: np.ndarray, cross: np.ndarray) -> np.ndarray:
    """(M,) shape quality of the triangles ``F`` of ``P`` (N, 3), whose edge cross products
    ``(p_1 - p_0) x (p_2 - p_0)`` are ``cross`` (M, 3): ``2 sqrt(3) |cross| / sum of the
    squared edge lengths``, 1 for an equilateral triangle, 0 for a degenerate one."""
    sq = sum(((P[F[:, (q + 1) % 3]] - P[F[:, q]]) ** 2).sum(axis=1) for q in range(3))
    return 2.0 * np.sqrt(3.0) * np.linalg.norm(cross, axis=1) / np.maximum(sq, 1e-300)


def shoelace(P: np.ndarray) -> float:
    """Shoelace area of the closed polygon ``P`` (k, 2) (last vertex joined to the first):
    positive when counter-clockwise, ``A = sum_i (x_i y_{i+1} - x_{i+1} y_i) / 2``."""
    x, y = P[:, 0], P[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def barycentric(S: np.ndarray, F: np.ndarray, Z: np.ndarray, T: np.ndarray) -> np.ndarray:
    """Barycentric coordinates (k, c, 3) of the points ``Z`` (k, 2) in the triangles
    ``F[T]`` (k, c) of the points ``S`` (n, 2); a triangle not counter-clockwise (or flat)
    gets -inf."""
    A, B, C = (S[F[T, q]] for q in range(3))  # (k, c, 2)
    z = Z[:, None, :]
    det = ((B[..., 0] - A[..., 0]) * (C[..., 1] - A[..., 1])
           - (B[..., 1] - A[..., 1]) * (C[..., 0] - A[..., 0]))
    wb = ((z[..., 0] - A[..., 0]) * (C[..., 1] - A[..., 1])
          - (z[..., 1] - A[..., 1]) * (C[..., 0] - A[..., 0]))
    wc = ((B[..., 0] - A[..., 0]) * (z[..., 1] - A[..., 1])
          - (B[..., 1] - A[..., 1]) * (z[..., 0] - A[..., 0]))
    ok = det > 0
    det = np.where(ok, det, 1.0)
    W = np.stack([det - wb - wc, wb, wc], axis=-1) / det[..., None]
    return np.where(ok[..., None], W, -np.inf)


def half_edges(F: np.ndarray) -> np.ndarray:
    """Each triangle's three directed edges, ``(3M, 2)``, in the order 01, 12, 20 of every
    triangle: row ``k`` belongs to triangle ``k % M``."""
    return np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])


def opposite_corners(F: np.ndarray) -> np.ndarray:
    """The corner opposite each row of :func:`half_edges` ``(F)``, ``(3M,)``."""
    return np.concatenate([F[:, 2], F[:, 0], F[:, 1]])


def edge_ids(edges: np.ndarray) -> np.ndarray:
    """(E,) int64: the same number for the rows of ``edges`` (E, 2) that join the same two
    vertices, in either direction, numbered ``0 ..`` in order of the pair. Each pair is one
    integer, ``a * n + b`` with ``a < b``: a 1D sort, not a row sort."""
    if not len(edges):
        return np.zeros(0, dtype=np.int64)
    a, b = edges[:, 0].astype(np.int64), edges[:, 1].astype(np.int64)
    n = int(max(a.max(), b.max())) + 1
    return np.unique(np.minimum(a, b) * n + np.maximum(a, b), return_inverse=True)[1].ravel()


def unique_edges(F: np.ndarray, return_counts: bool = False):
    """The undirected edges of ``F``, each once, ``(E, 2)`` with the smaller index first, in
    lexicographic order; with ``return_counts`` also how many triangles hold each, ``(E,)``
    (1 on the boundary, 2 inside a manifold)."""
    return np.unique(np.sort(half_edges(F), axis=1), axis=0, return_counts=return_counts)


def euler_characteristic(F: np.ndarray) -> int:
    """``V - E + F`` of the triangles ``F`` (M, 3) over the vertices they use."""
    F = np.asarray(F, dtype=np.int64)
    return int(len(np.unique(F)) - len(unique_edges(F)) + len(F))


def close_loops(F: np.ndarray, loops) -> np.ndarray:
    """``F`` (M, 3) with each of ``loops`` (boundary loops of ``F``, as
    :func:`boundary_loops` orders them) closed by a fan of triangles from its first point,
    oriented as the mesh (a boundary edge ``a -> b`` of a triangle gets ``b -> a``)."""
    fans = [np.array([[loop[0], loop[k + 1], loop[k]] for k in range(1, len(loop) - 1)],
                     dtype=np.int64).reshape(-1, 3) for loop in loops]
    return np.concatenate([F, *fans]) if fans else F


def compact(F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The vertices the triangles ``F`` use, ``(K,)`` ascending, and ``F`` renumbered onto
    them (``0 .. K - 1``)."""
    used = np.unique(F)
    renumber = np.full(int(used[-1]) + 1 if len(used) else 0, -1, dtype=np.int64)
    renumber[used] = np.arange(len(used))
    return used, renumber[F]


def mean_edge(P: np.ndarray, F: np.ndarray) -> float:
    """Mean length of the undirected edges of ``F`` (each once) over the points ``P``."""
    E = unique_edges(F)
    return float(np.linalg.norm(P[E[:, 0]] - P[E[:, 1]], axis=1).mean())


def edge_sides(F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each triangle's three edges, ``(3M, 2)`` (:func:`half_edges`), and whether each is on
    one triangle only (a boundary edge), ``(3M,)``."""
    edges = half_edges(F)
    if not len(edges):
        return edges, np.zeros(0, dtype=bool)
    ids = edge_ids(edges)
    return edges, np.bincount(ids)[ids] == 1


def unpaired(directed: np.ndarray) -> np.ndarray:
    """(E,) bool: the directed edges ``(a, b)`` whose reverse ``(b, a)`` is not among them
    (boundary edges of a consistently oriented mesh)."""
    if not len(directed):
        return np.zeros(0, dtype=bool)
    forward = directed[:, 0] < directed[:, 1]
    # Grouped by undirected edge: unpaired when its group has no edge the other way.
    group = edge_ids(directed)
    ahead = np.bincount(group, weights=forward)
    back = np.bincount(group, weights=~forward)
    return np.where(forward, back[group], ahead[group]) == 0


def boundary_loops(F: np.ndarray) -> list[list[int]]:
    """Boundary loops of a vertex-manifold, consistently oriented mesh, as vertex lists (each
    in the faces' direction: the outer loop counter-clockwise when the faces are)."""
    directed = half_edges(F)
    rim = directed[unpaired(directed)]
    # A vertex with two rim edges out (a pinch) keeps the last one.
    following = dict(zip(rim[:, 0].tolist(), rim[:, 1].tolist()))
    return [loop for loop in successor_walks(following) if len(loop) >= 3]


def successor_walks(following: dict) -> list[list[int]]:
    """The walks of the map ``following`` (vertex -> next vertex), each from the first vertex
    not yet seen (in the map's order) until a vertex comes back or has no successor: on the
    edges of disjoint cycles, the cycles."""
    walks, seen = [], set()
    for start in following:
        if start in seen:
            continue
        walk, v = [], start
        while v not in seen and v in following:
            seen.add(v)
            walk.append(v)
            v = following[v]
        walks.append(walk)
    return walks


def main_part(F: np.ndarray, n: int) -> np.ndarray:
    """(n,) bool: the vertices of the largest part of ``F`` whose triangles are joined
    through shared edges (none if empty). A triangle that touches the rest at a corner only
    is not part of it: LSCM could turn and scale it freely about that corner (such a
    triangle of a normal round's mesh of face_human_choi sent two points 1000 map widths
    away)."""
    import scipy.sparse as sp
    from scipy.sparse.csgraph import connected_components

    main = np.zeros(n, dtype=bool)
    m = len(F)
    if m:
        # A graph of the triangles and their edges: triangle t is node t, edge e node m + e.
        ids = edge_ids(half_edges(F))
        size = m + int(ids.max()) + 1
        graph = sp.coo_matrix((np.ones(3 * m, dtype=np.int8), (np.tile(np.arange(m), 3),
                                                              m + ids)), shape=(size, size))
        del ids
        _, label = connected_components(graph, directed=False)
        del graph
        label = label[:m]
        main[F[label == np.bincount(label).argmax()].ravel()] = True
    return main


def main_faces(F: np.ndarray) -> np.ndarray:
    """The faces of the largest part of ``F`` (:func:`main_part`)."""
    main = main_part(F, int(F.max()) + 1)
    return F[main[F].all(axis=1)]


def face_keys(F: np.ndarray, n: int) -> np.ndarray:
    """One integer per triangle of ``F`` (indices below ``n``), whatever its corners' order:
    ``a n^2 + b n + c`` with ``a < b < c``."""
    return np.sort(np.asarray(F, dtype=np.int64), axis=1) @ np.array([n * n, n, 1])


def smaller_fans(F: np.ndarray, v: int, tris: list[int]) -> list[int]:
    """The triangles ``tris`` around vertex ``v`` that are not in its largest fan (a fan:
    triangles joined through edges at ``v``); none when they make one fan."""
    parent = {t: t for t in tris}  # union-find of the triangles around v

    def root(t: int) -> int:
        while parent[t] != t:
            parent[t] = parent[parent[t]]
            t = parent[t]
        return t

    first: dict[int, int] = {}  # other vertex of an edge at v -> a triangle on it
    for t in tris:
        for w in F[t].tolist():
            if w == v:
                continue
            if w in first:
                parent[root(t)] = root(first[w])
            else:
                first[w] = t
    fans: dict[int, list[int]] = {}
    for t in tris:
        fans.setdefault(root(t), []).append(t)
    biggest = max(fans.values(), key=len)
    return [t for fan in fans.values() if fan is not biggest for t in fan]


def one_fan(F: np.ndarray, rounds: int = 10, *, bowties_only: bool = False
            ) -> tuple[np.ndarray, int]:
    """Drop triangles until every vertex has one fan (its triangles joined through shared
    edges at it): where fans meet at a vertex, all but the largest go. Repeated up to
    ``rounds`` times (a drop can split another vertex's fan).

    Two fans at a vertex need twice 360 degrees around it in the plane: no flip-free map
    exists, and a disk map's boundary is not one simple loop.

    Parameters
    ----------
    F : (M, 3) int
        A consistently oriented mesh.
    rounds : int
    bowties_only : bool
        Look only at the vertices that two boundary edges leave (the "bowties" the local
        mesh's edge test lets through), each vertex's triangles less those dropped at a
        vertex before it; else every vertex, each on all its triangles (a rim vertex can
        also hold its closed star and a fan of slivers from its neighbours' stars).

    Returns
    -------
    F : (M', 3)
        The faces kept, in their order.
    dropped : int
    """
    dropped = 0
    for _ in range(rounds):
        drop: set[int] = set()
        if bowties_only:
            directed = half_edges(F)
            outgoing = np.bincount(directed[unpaired(directed), 0],
                                   minlength=F.max(initial=-1) + 1)
            bad = np.flatnonzero(outgoing > 1)
            if not len(bad):
                break
            # The triangles at each bad vertex, in triangle order.
            rows, cols = np.nonzero(np.isin(F, bad))
            at = F[rows, cols]
            order = np.argsort(at, kind="stable")
            rows, at = rows[order], at[order]
            starts = np.searchsorted(at, bad)
            ends = np.searchsorted(at, bad, side="right")
            for v, a, b in zip(bad.tolist(), starts.tolist(), ends.tolist()):
                tris = [t for t in rows[a:b].tolist() if t not in drop]
                if tris:
                    drop.update(smaller_fans(F, v, tris))
        else:
            incident: dict[int, list[int]] = {}
            for t, tri in enumerate(F.tolist()):
                for v in tri:
                    incident.setdefault(v, []).append(t)
            for v, tris in incident.items():
                drop.update(smaller_fans(F, v, tris))
            if not drop:
                break
        F = np.delete(F, sorted(drop), axis=0)
        dropped += len(drop)
    return F, dropped


def peel_rim(P: np.ndarray, F: np.ndarray, angle: float = RIM_ANGLE, *, rounds: int = 100,
             one_per_vertex: bool = True) -> tuple[np.ndarray, int]:
    """Drop the rim slivers: a triangle with one boundary edge, the angle opposite it wider
    than ``angle`` (radians), whose opposite vertex is on no boundary yet (it joins the rim,
    and the mesh stays manifold). Repeated while any is left, up to ``rounds`` times.

    The local mesh's tangent fans cover a rim point a little inside its neighbours on the rim
    with such slivers (the stars are Delaunay in each tangent plane): the disk map would put
    the point inside the disk, and laid on a curved ring they fold.

    Parameters
    ----------
    P : (N, 2) or (N, 3) float64
        The points (the angle is measured in their space).
    F : (M, 3) int
    angle : float
        Radians; :data:`RIM_ANGLE` by default.
    rounds : int
    one_per_vertex : bool
        One triangle per joining vertex a round (the first in the order of ``F``), so the rim
        stays one loop through it; else every sliver found in the round.

    Returns
    -------
    F : (M', 3)
        The faces kept, in their order.
    dropped : int
    """
    limit = math.cos(angle)
    m = len(F)
    edges = half_edges(F)  # (3M, 2)
    opposite = opposite_corners(F)  # (3M,)
    face = np.arange(len(edges)) % max(m, 1)
    # Each edge's undirected id and how many kept triangles have it, updated as they go.
    eid = edge_ids(edges)
    uses = np.bincount(eid)
    kept = np.ones(m, dtype=bool)
    for _ in range(rounds):
        rim = np.flatnonzero((uses[eid] == 1) & kept[face])  # boundary edges
        on_rim = np.zeros(len(P), dtype=bool)
        on_rim[edges[rim].ravel()] = True
        u = P[edges[rim, 0]] - P[opposite[rim]]
        w = P[edges[rim, 1]] - P[opposite[rim]]
        cos = (u * w).sum(axis=1) / np.maximum(
            np.linalg.norm(u, axis=1) * np.linalg.norm(w, axis=1), 1e-300)
        faces, count = np.unique(face[rim], return_counts=True)
        one_edge = np.zeros(m, dtype=bool)
        one_edge[faces[count == 1]] = True
        pick = rim[(cos < limit) & ~on_rim[opposite[rim]] & one_edge[face[rim]]]
        if one_per_vertex:
            _, first = np.unique(opposite[pick], return_index=True)
            pick = pick[first]
        drop = np.unique(face[pick])
        if not len(drop):
            break
        kept[drop] = False
        np.subtract.at(uses, eid[np.concatenate([drop, drop + m, drop + 2 * m])], 1)
    return F[kept], int(m - kept.sum())


def twins(F: np.ndarray) -> tuple[np.ndarray, bool]:
    """(3M,) the twin of each half-edge of ``F`` (:func:`half_edges`' rows; -1 where none:
    a boundary half-edge), and whether no directed edge comes twice (the mesh consistently
    oriented and edge-manifold)."""
    n = int(F.max()) + 1
    H = half_edges(F)
    # The half-edges sorted by their undirected edge: each edge's two halves side by side
    # (one sort, no search), when no edge has more than two and those two run opposite.
    ukey = np.minimum(H[:, 0], H[:, 1]) * n + np.maximum(H[:, 0], H[:, 1])
    # (A stable sort: the halves come in runs of the faces' order, which it takes as they
    # are, several times faster than numpy's default; any order pairs the same halves.)
    order = np.argsort(ukey, kind="stable")
    pair = np.flatnonzero(ukey[order[1:]] == ukey[order[:-1]])
    first, second = order[pair], order[pair + 1]
    if not ((pair[1:] == pair[:-1] + 1).any() or (H[first, 0] == H[second, 0]).any()):
        twin = np.full(len(H), -1, dtype=np.int64)
        twin[first], twin[second] = second, first
        return twin, True
    key = H[:, 0] * n + H[:, 1]
    order = np.argsort(key)
    ordered = key[order]
    twin_key = H[:, 1] * n + H[:, 0]
    at = np.minimum(np.searchsorted(ordered, twin_key), len(key) - 1)
    return (np.where(ordered[at] == twin_key, order[at], -1),
            not bool((ordered[1:] == ordered[:-1]).any()))


def twin_pairs(F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(p,) and (p,): the two half-edges of each edge that two triangles of ``F`` share
    (rows of :func:`half_edges`; the first the lower), from :func:`twins`: ``h % M`` is the
    triangle of half-edge ``h``."""
    twin = twins(F)[0]
    first = np.flatnonzero(twin > np.arange(len(twin)))
    return first, twin[first]


def corner_fans(F: np.ndarray, twin: np.ndarray | None = None) -> np.ndarray:
    """(3M,) the fan of each corner (node ``slot * M + tri``, at ``F[tri, slot]``): the
    components of the triangles' corners, a corner joined to the corner at the same vertex
    across each shared edge. ``twin``: :func:`twins`' first, when already found."""
    import scipy.sparse as sp
    from scipy.sparse.csgraph import connected_components

    m = len(F)
    if twin is None:
        twin = twins(F)[0]
    inner = np.flatnonzero(twin >= 0)
    # Corner of half-edge k's start: (slot k // m, triangle k % m) -> node slot * m + tri.
    # Half-edge a -> b in slot q starts at corner q and ends at corner q + 1; its twin
    # b -> a in slot r starts at corner r (b) and ends at r + 1 (a).
    q, t = inner // m, inner % m
    r, u = twin[inner] // m, twin[inner] % m
    rows = np.concatenate([q * m + t, ((q + 1) % 3) * m + t])
    cols = np.concatenate([((r + 1) % 3) * m + u, r * m + u])
    graph = sp.coo_matrix((np.ones(len(rows), dtype=np.int8), (rows, cols)),
                          shape=(3 * m, 3 * m))
    return connected_components(graph, directed=False)[1]


def fan_counts(F: np.ndarray, twin: np.ndarray) -> np.ndarray:
    """(n,) how many fans each vertex of ``F`` has (``n = F.max() + 1``; 0 where unused): the
    counts of :func:`corner_fans`' components per vertex, found by walking the fans instead of
    a graph's components. ``twin``: :func:`twins`' first where its second is True (every
    edge's halves paired, so each vertex's corners form paths and cycles).

    A corner ``c = slot * M + tri`` leaves its vertex by half-edge ``c``; the next corner
    round the vertex is the one its twin enters. A fan that is a path starts at a corner whose
    entering half-edge has no twin (one per open fan); the corners no such walk reaches form
    the closed fans, one per cycle of that step."""
    m = len(F)
    n = int(F.max()) + 1
    vertex = F.T.ravel()
    counts = np.zeros(n, dtype=np.int64)
    seen = np.zeros(3 * m, dtype=bool)

    def step(c: np.ndarray) -> np.ndarray:  # -1 where the corner's leaving edge is open
        t = twin[c]
        return np.where(t >= 0, ((t // m + 1) % 3) * m + t % m, -1)

    corner = np.arange(3 * m)
    entering = ((corner // m + 2) % 3) * m + corner % m
    cur = corner[twin[entering] < 0]
    np.add.at(counts, vertex[cur], 1)
    for _ in range(3 * m + 1):
        seen[cur] = True
        cur = step(cur)
        cur = cur[cur >= 0]
        if not len(cur):
            break
    rest = np.flatnonzero(~seen)  # the closed fans' corners: cycles of ``step``
    if len(rest):
        where = np.full(3 * m, -1, dtype=np.int64)
        where[rest] = np.arange(len(rest))
        p = where[step(rest)]
        # Each corner's least index round its cycle (pointer doubling): one per cycle is its
        # own least.
        least = np.arange(len(rest))
        longest, covered = int(np.bincount(vertex[rest]).max()), 1
        while covered < longest:
            least = np.minimum(least, least[p])
            p = p[p]
            covered *= 2
        counts += np.bincount(vertex[rest[least == np.arange(len(rest))]], minlength=n)
    return counts


def face_parts(F: np.ndarray, twin: np.ndarray) -> tuple[int, np.ndarray]:
    """How many parts the faces ``F`` form joined through edges, and each face's part
    (numbered in order of their first face, as libigl's ``facet_components``). ``twin``:
    :func:`twins`' first where its second is True (each edge's triangles are its halves')."""
    import scipy.sparse as sp
    from scipy.sparse.csgraph import connected_components

    m = len(F)
    k = np.flatnonzero(twin > np.arange(len(twin)))
    graph = sp.csr_matrix((np.ones(len(k), dtype=np.int8), (k % m, twin[k] % m)), shape=(m, m))
    return connected_components(graph, directed=False)


def drop_smaller_fans(F: np.ndarray, rounds: int = 3) -> np.ndarray:
    """The faces ``F`` (edge-manifold, consistently oriented) less, at each pinched vertex,
    the triangles of every fan but the largest (most triangles; ties: the first), so that
    the vertex has one fan; repeated while that pinches another (at most ``rounds`` times)."""
    F = np.asarray(F, dtype=np.int64)
    for _ in range(rounds):
        if not len(F):
            break
        m = len(F)
        label = corner_fans(F)
        vertex = F.T.ravel()
        size = np.bincount(label)
        # The largest fan at each vertex: corners sorted by vertex, then by their fan's size.
        order = np.lexsort((-size[label], vertex))
        lead = np.full(int(F.max()) + 1, -1, dtype=np.int64)
        v_sorted = vertex[order]
        start = np.flatnonzero(np.r_[True, v_sorted[1:] != v_sorted[:-1]])
        lead[v_sorted[start]] = label[order[start]]
        off = label != lead[vertex]
        if not off.any():
            break
        gone = np.zeros(m, dtype=bool)
        gone[np.flatnonzero(off) % m] = True
        F = F[~gone]
    return F
