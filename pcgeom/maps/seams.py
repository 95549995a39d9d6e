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

With ``roots > 1`` (what ``cut="auto"`` asks), a shorter cut graph is sought too
(:func:`_homology_cut`), and the shorter of the two kept (``info["method"]``):

4. Each edge gets its Z2 homology code from the tree-cotree above (:func:`_cocycles`: the
   ``2g`` left-over edges one bit each, the tree 0, the cotree edges what closes each
   triangle), so that the class of any closed walk is the XOR of its edges' codes.
5. From ``roots`` roots (farthest-point samples along the mesh), every edge closes a loop
   through the root's shortest-path tree; the shortest loop of each class per root is a
   candidate. The candidates in order of length, each kept when its class is independent of
   those kept, give a greedy shortest homology basis (Erickson and Whittlesey 2005: with
   every vertex a root, the shortest). Unlike the loops of step 3, they need not share a
   base point: the seams go round a handle where it is thin, not through a far root.
6. Their union is cut down to a cut graph (:func:`_reduce`): where loops cross they enclose
   pieces of surface; the longest chain of seam (between vertices where three seam edges or
   more meet) parting two different pieces is dropped, and so on until the complement is one
   piece; dangling branches are pruned and the parts left joined by shortest paths. The
   result is kept only when the mesh cut along it is a disk (Euler characteristic 1, one
   boundary loop).

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
        At genus >= 1 on a closed mesh: 1, the tree-cotree cut graph from the vertex nearest
        the centroid; more, also the cut graph from a greedy homology basis over that many
        roots (that vertex, then farthest-point samples along the mesh), the shorter kept.

    Returns
    -------
    E : (e, 2) int64
        The mesh's undirected edges (:func:`pcgeom.mesh.unique_edges`).
    cut : (e,) bool
        The seam edges.
    info : dict
        ``genus``, ``loops`` (the ``2g`` loops, or 1 path at genus 0), ``root``,
        ``length`` (the seams' total length, in the units of ``V``); at genus >= 1 on a
        closed mesh ``roots`` (asked) and ``method`` (``"tree-cotree"`` or
        ``"homology basis"``, whichever is shorter).
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
        cut, info = _tree_cotree(V, F, E, G, length, start, genus=genus)
        info.update(method="tree-cotree", roots=max(int(roots), 1))
        if roots > 1:
            short = _homology_cut(V, F, E, G, length, start, roots=int(roots))
            if short is not None and length[short].sum() < length[cut].sum():
                cut = short
                info.update(method="homology basis", root="several")
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


def _dual(F: np.ndarray, E: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """The two triangles of each edge of the closed mesh, ``(e, 2)``, and the three edges of
    each triangle, ``(m, 3)`` (rows of ``E``)."""
    m = len(F)
    he = half_edges(F)
    eid = np.searchsorted(E[:, 0] * n + E[:, 1], _keys(he, n))
    tri = np.arange(len(he)) % m
    return tri[np.argsort(eid, kind="stable")].reshape(-1, 2), eid.reshape(3, m).T


def _tree_edges(E: np.ndarray, pred: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """The vertices with a parent in the predecessor tree ``pred`` and the rows of ``E`` that
    join each to its parent."""
    child = np.flatnonzero(pred >= 0)
    keys = np.minimum(child, pred[child]) * n + np.maximum(child, pred[child])
    return child, np.searchsorted(E[:, 0] * n + E[:, 1], keys)


def _cocycles(F, E, G, pairs, tri_edges, root: int) -> tuple[np.ndarray, int] | None:
    """Each edge's Z2 homology code (bit ``i``: the value on it of the ``i``-th of ``2g``
    cocycles): the sum of the codes over a closed walk is its homology class over Z2 (0: it
    bounds). From a tree-cotree decomposition (the shortest-path tree from ``root``, any
    spanning tree of the dual over the other edges): the ``2g`` edges left over get one bit
    each, the tree's edges 0, and each cotree edge, from the dual tree's leaves in, the sum of
    its triangle's two other edges (every triangle's boundary sums to 0). None when two
    triangles share two edges (the dual tree is then ambiguous)."""
    from scipy.sparse.csgraph import breadth_first_order

    n, m = G.shape[0], len(F)
    pred = dijkstra(G, indices=root, return_predecessors=True)[1]
    in_tree = np.zeros(len(E), dtype=bool)
    in_tree[_tree_edges(E, pred, n)[1]] = True
    free = np.flatnonzero(~in_tree)
    lo, hi = pairs[free].min(axis=1), pairs[free].max(axis=1)
    between = sp.coo_matrix((free + 1.0, (lo, hi)), shape=(m, m)).tocsr()
    if between.nnz != len(free):
        return None
    order, parent = breadth_first_order(between + between.T, 0, directed=False,
                                        return_predecessors=True)
    if len(order) != m:
        return None
    up = np.full(m, -1, dtype=np.int64)  # each triangle's dual-tree edge to its parent
    rest = order[1:]
    up[rest] = np.asarray(between[np.minimum(rest, parent[rest]),
                                  np.maximum(rest, parent[rest])]).ravel().astype(np.int64) - 1
    left = np.setdiff1d(free, up[rest])
    code = np.zeros(len(E), dtype=np.int64)
    code[left] = 1 << np.arange(len(left), dtype=np.int64)
    for t in order[:0:-1].tolist():  # leaves first: the parent edge closes the triangle
        a, b, c = tri_edges[t]
        code[up[t]] = code[a] ^ code[b] ^ code[c] ^ code[up[t]]
    return code, len(left)


def _path_xor(pred: np.ndarray, step: np.ndarray) -> np.ndarray:
    """Per vertex, the XOR of ``step`` (each vertex's code of the edge to its parent; 0 at
    the root) along its path to the root of ``pred``, by pointer doubling."""
    p = np.where(pred < 0, np.arange(len(pred)), pred)
    acc = step.copy()
    while True:
        done = p == p[p]
        if done.all():
            return acc
        acc = np.where(done, acc, acc ^ acc[p])
        p = p[p]


def _homology_cut(V, F, E, G, length, start: int, *, roots: int) -> np.ndarray | None:
    """A short cut graph from a greedy shortest homology basis (Erickson and Whittlesey
    2005), or None when it does not open the mesh into a disk.

    1. Loops: from each of ``roots`` roots (``start``, then farthest-point samples along the
       mesh), the shortest-path tree; each edge ``uv`` outside it closes the loop
       ``r -> u -> v -> r`` of length ``d(u) + |uv| + d(v)`` and Z2 class
       ``h(u) + code(uv) + h(v)`` (:func:`_cocycles`); per root and class the shortest.
    2. Greedy: the loops in order of length, each kept when its class is independent of those
       kept (a XOR basis), until ``2g``; each loop without its stem (the tree paths' shared
       part, which cancels over Z2).
    3. The union of the loops, reduced to a cut graph (:func:`_reduce`).
    """
    n = len(V)
    pairs, tri_edges = _dual(F, E, n)
    coded = _cocycles(F, E, G, pairs, tri_edges, start)
    if coded is None:
        return None
    code, rank = coded
    candidates, trees, far, root = [], {}, None, start
    for _ in range(roots):
        d, pred = dijkstra(G, indices=root, return_predecessors=True)
        trees[root] = pred
        step = np.zeros(n, dtype=np.int64)
        child, rows = _tree_edges(E, pred, n)
        step[child] = code[rows]
        h = _path_xor(pred, step)
        cls = h[E[:, 0]] ^ h[E[:, 1]] ^ code
        loop = d[E[:, 0]] + d[E[:, 1]] + length
        some = np.flatnonzero(cls)
        some = some[np.argsort(loop[some], kind="stable")]
        best = some[np.unique(cls[some], return_index=True)[1]]
        candidates += [(float(loop[e]), int(cls[e]), root, int(e)) for e in best]
        far = d if far is None else np.minimum(far, d)
        root = int(np.argmax(np.where(np.isfinite(far), far, -1)))
    basis, cut = [], np.zeros(len(E), dtype=bool)
    keys = E[:, 0] * n + E[:, 1]
    for _, cls, root, e in sorted(candidates):
        x = cls
        for b in basis:  # kept in decreasing order: each lowers its leading bit
            x = min(x, x ^ b)
        if not x:
            continue
        basis = sorted(basis + [x], reverse=True)
        loop = np.zeros(len(E), dtype=bool)
        loop[e] = True
        for v in E[e].tolist():
            path = _tree_path(trees[root], v)
            a, b = np.asarray(path[:-1]), np.asarray(path[1:])
            np.logical_xor.at(loop, np.searchsorted(keys, np.minimum(a, b) * n
                                                    + np.maximum(a, b)), True)
        cut |= loop
        if len(basis) == rank:
            break
    cut = _reduce(E, cut, pairs, G, length)
    from .charts import _is_disk

    return cut if _is_disk(cut_open(F, E, cut, n)[0]) else None


def _reduce(E, cut, pairs, G, length) -> np.ndarray:
    """The union of loops ``cut`` reduced to a cut graph: where the loops cross they bound
    pieces of surface between them; the longest stretch of seam (a chain between vertices
    where three or more seam edges meet) that parts two different pieces is dropped, and so
    on (Kruskal over the pieces, longest first), until the pieces are one; then the dangling
    branches are pruned and the parts left joined by shortest paths (nearest first)."""
    n = G.shape[0]
    cut = cut.copy()
    keep = np.flatnonzero(~cut)
    m = int(pairs.max()) + 1
    _, face = connected_components(sp.coo_matrix(
        (np.ones(len(keep)), (pairs[keep, 0], pairs[keep, 1])), shape=(m, m)), directed=False)
    ce = np.flatnonzero(cut)
    chain, count = _chains(E, cut, n)
    chain_len = np.bincount(chain, length[ce], minlength=count)
    first = np.zeros(count, dtype=np.int64)
    first[chain[::-1]] = np.arange(len(ce))[::-1]
    sides = face[pairs[ce[first]]]
    group = np.arange(int(face.max()) + 1)

    def find(x: int) -> int:
        while group[x] != x:
            group[x] = group[group[x]]
            x = int(group[x])
        return x

    drop = np.zeros(count, dtype=bool)
    for c in np.argsort(-chain_len, kind="stable"):
        a, b = find(int(sides[c, 0])), find(int(sides[c, 1]))
        if a != b:
            group[a] = b
            drop[c] = True
    cut[ce[drop[chain]]] = False
    cut = _prune(E, cut, n)
    keys = E[:, 0] * n + E[:, 1]
    while True:
        ce = np.flatnonzero(cut)
        on = np.zeros(n, dtype=bool)
        on[E[ce].ravel()] = True
        label = connected_components(sp.coo_matrix(
            (np.ones(len(ce)), (E[ce, 0], E[ce, 1])), shape=(n, n)), directed=False)[1]
        parts = np.unique(label[on])
        if len(parts) <= 1:
            return cut
        d, pred, _ = dijkstra(G, indices=np.flatnonzero(on & (label == parts[0])),
                              return_predecessors=True, min_only=True)
        other = np.flatnonzero(on & (label != parts[0]))
        path = np.asarray(_tree_path(pred, int(other[np.argmin(d[other])])))
        a, b = path[:-1], path[1:]
        cut[np.searchsorted(keys, np.minimum(a, b) * n + np.maximum(a, b))] = True


def _chains(E: np.ndarray, cut: np.ndarray, n: int) -> tuple[np.ndarray, int]:
    """The chains of the seams ``E[cut]``: runs of seam edges joined at vertices where two
    seam edges meet (not three or more, not one). Returns each seam edge's chain (in the
    order of ``np.flatnonzero(cut)``) and the count."""
    ce = np.flatnonzero(cut)
    deg = np.bincount(E[ce].ravel(), minlength=n)
    ends = np.r_[E[ce, 0], E[ce, 1]]
    which = np.r_[np.arange(len(ce)), np.arange(len(ce))]
    two = deg[ends] == 2
    joined = which[two][np.argsort(ends[two], kind="stable")].reshape(-1, 2)
    count, chain = connected_components(sp.coo_matrix(
        (np.ones(len(joined)), (joined[:, 0], joined[:, 1])), shape=(len(ce), len(ce))),
        directed=False)
    return chain, count
