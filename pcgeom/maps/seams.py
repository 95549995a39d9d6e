"""Seams: a cut graph that opens a closed mesh of any genus into a topological disk, and the
mesh cut open along it.

**Cut graph** (:func:`cut_graph`). Tree-cotree (Eppstein 2003; with the weights of Erickson
and Whittlesey, "Greedy optimal homotopy and homology generators", SODA 2005):

1. ``T``: the shortest-path tree of the mesh's edge graph (edge lengths) from a root ``r``
   (the vertex nearest the centroid), ``d(v)`` the distance of ``v`` to ``r``.
2. ``C``: a maximum spanning tree of the dual graph (triangles joined across the edges not in
   ``T``), an edge ``uv`` weighted by the length of its loop ``d(u) + |uv| + d(v)``: the long
   loops go into ``C``, so that the edges left over are those of the shortest loops.
3. The ``2g`` edges in neither (``|E| - (|V| - 1) - (|F| - 1) = 2 - chi = 2g``): each closes
   one loop ``r -> u -> v -> r`` through ``T``. The cut graph is the union of these loops,
   pruned of its dangling branches (vertices of degree one, removed until none is left: the
   shared stem to the root). Cut along it, the surface is a disk (Eppstein, lemma 1).

For genus 0 there is no loop: the cut is the shortest path between two far vertices (the
vertex farthest from the centroid and the one farthest from it along the mesh), so that the
disk has a boundary.

A mesh with ``b`` boundary loops: the boundary is contracted to the root (the tree is the
shortest-path forest from all its vertices, the dual tree does not cross it), and the
``|E_inner| - (|V| - |V_rim|) - (|F| - 1) = 2g + b - 1`` edges left each close a path from
the boundary to the boundary; with the boundary they cut the surface into a disk (the
paths join the ``b`` loops and cut the ``g`` handles). Pruning keeps branches that end on the
boundary.

**Cutting** (:func:`cut_open`): the corners around each vertex are split into wedges at the
cut edges; each wedge is one vertex of the cut mesh (a seam vertex gets one per side; a
vertex where ``k`` cut edges meet, ``k`` of them), its 3D position that of the vertex it came
from.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components, dijkstra, minimum_spanning_tree

from ..mesh import euler_characteristic, half_edges, unique_edges

__all__ = ["cut_graph", "cut_open", "euler_characteristic"]


def _edge_index(E: np.ndarray, n: int) -> dict:
    return {int(k): i for i, k in enumerate(E[:, 0] * n + E[:, 1])}


def _tree_path(pred: np.ndarray, v: int) -> list[int]:
    """Vertices from ``v`` up to the root of the predecessor tree ``pred``."""
    path = [v]
    while pred[path[-1]] >= 0:
        path.append(int(pred[path[-1]]))
    return path


def _graph(V: np.ndarray, E: np.ndarray) -> sp.csr_matrix:
    n = len(V)
    w = np.linalg.norm(V[E[:, 0]] - V[E[:, 1]], axis=1)
    w = np.maximum(w, 1e-12 * max(float(w.max()), 1e-300))  # 0 means no edge to scipy
    return sp.coo_matrix((np.r_[w, w], (np.r_[E[:, 0], E[:, 1]], np.r_[E[:, 1], E[:, 0]])),
                         shape=(n, n)).tocsr()


def _prune(E: np.ndarray, cut: np.ndarray, n: int, anchored: np.ndarray | None = None
           ) -> np.ndarray:
    """``cut`` (E,) bool less its dangling branches: edges at a vertex of degree one go,
    until every cut vertex has degree two or more (``anchored`` (n,) bool: vertices on the
    mesh's boundary, which hold a branch that ends there)."""
    cut = cut.copy()
    extra = np.zeros(n, dtype=np.int64) if anchored is None else 2 * anchored.astype(np.int64)
    while True:
        deg = np.bincount(E[cut].ravel(), minlength=n) + extra
        dangling = cut & ((deg[E[:, 0]] == 1) | (deg[E[:, 1]] == 1))
        if not dangling.any():
            return cut
        cut &= ~dangling


def cut_graph(V: np.ndarray, F: np.ndarray, *, roots: int = 1
              ) -> tuple[np.ndarray, np.ndarray, dict]:
    """The seams that open the closed, connected, oriented mesh ``(V, F)`` into a disk.

    Parameters
    ----------
    V : (n, 3) float64
    F : (m, 3) int64
        Closed (every edge on two triangles), one connected part.
    roots : int
        Roots tried at genus >= 1 (the vertex nearest the centroid, then farthest-point
        samples of the mesh graph); the shortest pruned cut is kept.

    Returns
    -------
    E : (e, 2) int64
        The mesh's undirected edges (:func:`pcgeom.mesh.unique_edges`).
    cut : (e,) bool
        The seam edges.
    info : dict
        ``genus``, ``loops`` (the ``2g`` loops, or 1 path at genus 0), ``root``,
        ``length`` (the seams' total length, in the units of ``V``), ``roots`` (tried).
    """
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    n, m = len(V), len(F)
    E = unique_edges(F)
    chi = len(np.unique(F)) - len(E) + m  # over the vertices the triangles use
    genus = (2 - chi) // 2
    G = _graph(V, E)
    length = np.linalg.norm(V[E[:, 0]] - V[E[:, 1]], axis=1)
    cut = np.zeros(len(E), dtype=bool)
    index = _edge_index(E, n)

    def mark(path: list[int]) -> None:
        for a, b in zip(path[:-1], path[1:]):
            cut[index[min(a, b) * n + max(a, b)]] = True

    uses = np.bincount(np.searchsorted(E[:, 0] * n + E[:, 1],
                                       _keys(half_edges(F), n)), minlength=len(E))
    rim = uses == 1
    if rim.any():  # the boundary: one root for all its vertices (contracted)
        on_rim = np.zeros(n, dtype=bool)
        on_rim[E[rim].ravel()] = True
        from ..mesh import boundary_loops

        b = len(boundary_loops(F))
        cut, info = _tree_cotree(V, F, E, G, length, np.flatnonzero(on_rim),
                                 genus=(2 - chi - b) // 2, on_rim=on_rim, rim=rim)
        info["boundary_loops"] = b
    elif genus == 0:
        a = int(np.argmax(np.linalg.norm(V - V.mean(axis=0), axis=1)))
        dist, pred = dijkstra(G, indices=a, return_predecessors=True)
        b = int(np.argmax(np.where(np.isfinite(dist), dist, -1)))
        pred = np.where(pred < 0, -1, pred)
        mark(_tree_path(pred, b))
        info = {"genus": 0, "loops": 1, "root": a}
    else:
        start = int(np.argmin(np.linalg.norm(V - V.mean(axis=0), axis=1)))
        candidates, best = [start], None
        far = dijkstra(G, indices=start)
        for _ in range(max(int(roots), 1)):
            root = candidates[-1]
            E_cut, info = _tree_cotree(V, F, E, G, length, root, genus=genus)
            total = float(length[E_cut].sum())
            if best is None or total < best[0]:
                best = (total, E_cut, info)
            d = dijkstra(G, indices=root)
            far = np.minimum(far, d)
            candidates.append(int(np.argmax(np.where(np.isfinite(far), far, -1))))
        cut, info = best[1], best[2]
        info["roots"] = max(int(roots), 1)
    info["length"] = float(length[cut].sum())
    return E, cut, info


def _keys(he: np.ndarray, n: int) -> np.ndarray:
    return np.minimum(he[:, 0], he[:, 1]) * n + np.maximum(he[:, 0], he[:, 1])


def _tree_cotree(V, F, E, G, length, root, *, genus: int, on_rim=None, rim=None
                 ) -> tuple[np.ndarray, dict]:
    """The pruned tree-cotree cut graph from ``root`` (steps 1-3 of the module). On a mesh
    with a boundary, ``root`` is all its vertices (``on_rim``; ``rim``: its edges), contracted
    to one: the shortest-path forest grows from them, the dual tree does not cross the
    boundary, and the ``2g + b - 1`` edges left each close a path from the boundary to the
    boundary (joining its ``b`` loops and cutting the ``g`` handles)."""
    n, m = len(V), len(F)
    cut = np.zeros(len(E), dtype=bool)
    index = _edge_index(E, n)

    def mark(path: list[int]) -> None:
        for a, b in zip(path[:-1], path[1:]):
            cut[index[min(a, b) * n + max(a, b)]] = True

    dist, pred, _ = dijkstra(G, indices=root, return_predecessors=True, min_only=True)
    pred = np.where(pred < 0, -1, pred).astype(np.int64)
    child = np.flatnonzero(pred >= 0)
    in_tree = np.zeros(len(E), dtype=bool)
    tree_keys = np.minimum(child, pred[child]) * n + np.maximum(child, pred[child])
    in_tree[np.searchsorted(E[:, 0] * n + E[:, 1], tree_keys)] = True
    # The dual graph over the edges not in T: the two triangles of each edge.
    he = half_edges(F)
    keys = np.minimum(he[:, 0], he[:, 1]) * n + np.maximum(he[:, 0], he[:, 1])
    eid = np.searchsorted(E[:, 0] * n + E[:, 1], keys)
    tri = np.arange(len(he)) % m
    order = np.argsort(eid, kind="stable")
    if rim is None:
        pairs = tri[order].reshape(-1, 2)  # closed: every edge on exactly two triangles
    else:  # boundary edges: one triangle, no dual edge
        pairs = np.zeros((len(E), 2), dtype=np.int64)
        sorted_eid = eid[order]
        first = np.r_[True, sorted_eid[1:] != sorted_eid[:-1]]
        pairs[sorted_eid[first], 0] = tri[order][first]
        pairs[sorted_eid[~first], 1] = tri[order][~first]
        pairs[rim, 1] = pairs[rim, 0]
    loop_len = dist[E[:, 0]] + dist[E[:, 1]] + length
    free = ~in_tree if rim is None else ~in_tree & ~rim
    # Maximum spanning tree of loop lengths: a minimum one of (top - length), all > 0.
    w = (loop_len.max() * 1.01 + 1e-9) - loop_len[free]
    D = sp.coo_matrix((w, (pairs[free, 0], pairs[free, 1])), shape=(m, m)).tocsr()
    C = minimum_spanning_tree(D).tocoo()
    dual_keys = set(zip(np.minimum(C.row, C.col).tolist(), np.maximum(C.row, C.col).tolist()))
    lo, hi = np.minimum(pairs[:, 0], pairs[:, 1]), np.maximum(pairs[:, 0], pairs[:, 1])
    in_cotree = np.array([(int(a), int(b)) in dual_keys for a, b in zip(lo, hi)])
    left = np.flatnonzero(free & ~in_cotree)
    for e in left:
        u, v = int(E[e, 0]), int(E[e, 1])
        mark(_tree_path(pred, u))
        mark(_tree_path(pred, v))
        cut[e] = True
    info = {"genus": int(genus), "loops": int(len(left)),
            "root": int(root) if np.ndim(root) == 0 else "boundary"}
    return _prune(E, cut, n, on_rim), info


def cut_open(F: np.ndarray, E: np.ndarray, cut: np.ndarray, n: int
             ) -> tuple[np.ndarray, np.ndarray]:
    """The mesh ``F`` cut open along the edges ``E[cut]``.

    Two corners of one vertex are the same vertex of the cut mesh when they are joined
    through triangles across edges that are not cut (connected components of the corner
    graph).

    Returns
    -------
    Fc : (m, 3) int64
        The triangles, corner for corner, in the cut mesh's vertices.
    origin : (k,) int64
        The vertex of ``F`` each cut-mesh vertex came from (seam vertices: several).
    """
    F = np.asarray(F, dtype=np.int64)
    m = len(F)
    he = half_edges(F)  # row j: triangle j % m, edge (c, c+1) with c = j // m
    keys = np.minimum(he[:, 0], he[:, 1]) * n + np.maximum(he[:, 0], he[:, 1])
    ekeys = E[:, 0] * n + E[:, 1]
    eid = np.searchsorted(ekeys, keys)
    keep = ~cut[eid]
    # Corner id: c * m + t for corner c of triangle t. The half-edge (a, b) of triangle t
    # at position c has corner c at a and corner (c+1) % 3 at b.
    tri = np.arange(3 * m) % m
    pos = np.arange(3 * m) // m
    ca = pos * m + tri
    cb = ((pos + 1) % 3) * m + tri
    order = np.argsort(eid, kind="stable")
    sorted_eid = eid[order]
    first = np.r_[True, sorted_eid[1:] != sorted_eid[:-1]]
    starts = np.flatnonzero(first)
    # Pairs of half-edges of one inner edge (two per edge on a closed or open manifold).
    twin = starts[np.diff(np.r_[starts, len(order)]) == 2]
    h1, h2 = order[twin], order[twin + 1]
    ok = keep[h1]
    h1, h2 = h1[ok], h2[ok]
    # Opposite directions: a of h1 is b of h2.
    rows = np.r_[ca[h1], cb[h1]]
    cols = np.r_[cb[h2], ca[h2]]
    graph = sp.coo_matrix((np.ones(len(rows), dtype=np.int8), (rows, cols)),
                          shape=(3 * m, 3 * m))
    _, label = connected_components(graph, directed=False)
    corner_vertex = F.T.ravel()  # corner c * m + t is F[t, c]
    # Renumber labels densely; every label is one vertex wedge.
    labels, inverse = np.unique(label, return_inverse=True)
    origin = np.zeros(len(labels), dtype=np.int64)
    origin[inverse] = corner_vertex
    Fc = inverse.reshape(3, m).T.astype(np.int64)
    return Fc, origin
