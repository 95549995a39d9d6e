"""The repair's per-loop figures for all loops at once (not in the paper): the fill pass of
:mod:`pcgeom.maps.topology` looks at every boundary loop of the local mesh, a hundred or
more on a scan (face_human_choi: 120 per repair, most of 3-8 points), and their figures
one loop at a time cost more than the fills they lead to.

- :func:`loop_figures`: each loop's perimeter, median local spacing, centre and reach (the
  same numbers as one loop at a time: the same operations in the same order).
- :func:`least_area_folds`: which short loops have no least-area fill that keeps to its
  corners' normals and the mesh's edges (:func:`pcgeom.maps.topology._least_area_fill`
  returns None), for all loops of one length in one array: every fill of such a loop folds
  or needs an edge the mesh has, and the fill pass skips it
  (:func:`pcgeom.maps.topology.fill_loop` would return None at once).

And the mesh's figures from its twins (:func:`pcgeom.mesh.twins`, one sort), found once per
measure: :func:`main_faces` (the largest part, from the half-edges' pairs rather than
libigl's ``facet_components``), :func:`sub_twins` (its twins, renumbered) and
:func:`edge_keys` (the sorted edge keys the fills test against). Each gives what it gave
before, to the bit (the repaired faces of 58 local meshes of the shared surfaces, the
pleats and the lips identical, 2026-12-05).

And the lookups the fills share instead of sorting every half-edge or building a k-d tree
again: :class:`Corners` (each vertex's corners by a radix sort, :func:`stable_order`: the
triangles at a vertex, and whether the mesh has a half-edge ``a -> b``), :class:`CloudTree`
(the tree of the points not excluded: the local mesh's neighbour query's own,
:attr:`pcgeom.neighbours.Neighbours.tree`, when given) and :func:`add_fills`.

And :class:`FillMemo` (:data:`FILLS`): the fills the re-meshes and the pinches' mends
tried, kept from one repair of a cloud to the next, by all they were found from;
:func:`cut_at_repeats` (a walk's simple loops).
"""

from __future__ import annotations

import numpy as np

from ..mesh import cross3, face_parts, fan_counts, half_edges, twins

__all__ = ["loop_figures", "least_area_folds", "triage", "main_faces", "sub_twins", "edge_keys",
           "stable_order", "Corners", "CloudTree", "add_fills", "KnownTwins", "cut_at_repeats",
           "FillMemo", "FILLS"]


def loop_figures(X: np.ndarray, h: np.ndarray, loops: list[np.ndarray]
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Each loop's perimeter (the sum of its edges' lengths, last point joined to the first),
    the median of its points' local spacings ``h``, its centre (the mean of its points) and
    its reach (its farthest point from the centre): (L,), (L,), (L, 3), (L,)."""
    sizes = np.array([len(loop) for loop in loops], dtype=np.int64)
    if not len(loops):
        return np.zeros(0), np.zeros(0), np.zeros((0, 3)), np.zeros(0)
    cat = np.concatenate(loops)
    starts = np.concatenate([[0], np.cumsum(sizes)[:-1]])
    ends = starts + sizes
    pos = np.arange(len(cat))
    seg = np.repeat(np.arange(len(loops)), sizes)
    after = np.where(pos + 1 == ends[seg], starts[seg], pos + 1)  # np.roll(loop, -1)
    edge = np.linalg.norm(X[cat[after]] - X[cat], axis=1)
    # (Each loop's sum alone: the pairwise sum of its own edges, as one loop at a time.)
    perimeter = np.array([edge[a:b].sum() for a, b in zip(starts.tolist(), ends.tolist())])
    hs = h[cat]
    ordered = hs[np.lexsort((hs, seg))]
    mid = starts + sizes // 2
    odd = sizes % 2 == 1
    median = np.where(odd, ordered[mid], (ordered[mid - 1] + ordered[mid]) / 2)
    # (Each loop's mean alone: numpy's sum down a column is pairwise, not in order.)
    centre = np.array([X[loop].mean(axis=0) for loop in loops])
    reach = np.maximum.reduceat(np.linalg.norm(X[cat] - centre[seg], axis=1), starts)
    return perimeter, median, centre, reach


def triage(X: np.ndarray, normals: np.ndarray, h: np.ndarray, loops: list[np.ndarray], *,
           radius: float, longest: float, tree, edges: np.ndarray | None) -> tuple:
    """The fill pass's look at its loops (:func:`pcgeom.maps.topology._fill_pass`), all at
    once: each loop's perimeter and the circle of ``radius`` times its median local spacing
    ``h`` (their lengths), which loops are tried (no longer than ``longest`` such circles),
    the points of ``tree`` (a cKDTree, or None) within each tried loop's reach of its centre
    (lists of indices, in the order a query of that loop alone gives), and which tried loops
    of 4-8 points with none of those points fold (:func:`least_area_folds` against the
    mesh's ``edges``; None: no such test, as for fills that may fold)."""
    perimeters, medians, centres, reaches = loop_figures(X, h, loops)
    circles = 2.0 * np.pi * radius * medians
    tried = ~(perimeters > longest * circles)
    near = [[] for _ in loops]
    if tree is not None and tried.any():
        near = np.empty(len(loops), dtype=object)
        near[tried] = tree.query_ball_point(centres[tried], reaches[tried], return_sorted=False)
    folded = np.zeros(len(loops), dtype=bool)
    if edges is not None:
        short = [q for q in np.flatnonzero(tried).tolist()
                 if 4 <= len(loops[q]) <= 8 and not len(near[q])]
        folded[short] = least_area_folds(X, normals, [loops[q] for q in short], edges)
    return perimeters, circles, tried, near, folded


def least_area_folds(X: np.ndarray, normals: np.ndarray, loops: list[np.ndarray],
                     edges: np.ndarray) -> np.ndarray:
    """(L,) bool: the loops (each of 4 to 8 points or so; all of one length or not) whose
    least-area triangulation in space prices a triangle facing away from its corners'
    normals or needs a diagonal that is an edge of ``edges`` (the mesh's, sorted ``a * N +
    b``, ``a < b``): :func:`pcgeom.maps.topology._least_area_fill` (``folds`` False) is None
    for them. The same arrays, costs and dynamic programme, with the loops of one length
    stacked."""
    out = np.zeros(len(loops), dtype=bool)
    sizes = np.array([len(loop) for loop in loops], dtype=np.int64)
    for k in np.unique(sizes).tolist():
        which = np.flatnonzero(sizes == k)
        L = np.stack([loops[w] for w in which.tolist()])  # (B, k)
        out[which] = _folds_of_length(X, normals, L, edges)
    return out


def _folds_of_length(X: np.ndarray, normals: np.ndarray, L: np.ndarray, edges: np.ndarray
                     ) -> np.ndarray:
    """:func:`least_area_folds` of the loops ``L`` (B, k), all of ``k`` points."""
    B, k = L.shape
    P, Nv = X[L], normals[L]  # (B, k, 3)
    i, m, j = np.meshgrid(np.arange(k), np.arange(k), np.arange(k), indexing="ij")
    face = cross3(P[:, j] - P[:, i], P[:, m] - P[:, i])  # (B, k, k, k, 3)
    area = 0.5 * np.linalg.norm(face, axis=-1)
    away = np.einsum("bijmd,bijmd->bijm", face, Nv[:, i] + Nv[:, j] + Nv[:, m]) <= 0
    total_area = np.array([a.sum() for a in area])  # each loop's own pairwise sum
    far = 10.0 * (total_area / max(k, 1) ** 2 + 1e-300) * k
    cost = area + away * far[:, None, None, None]
    if edges is not None and len(edges):
        lo = np.minimum(L[:, :, None], L[:, None, :])
        hi = np.maximum(L[:, :, None], L[:, None, :])
        key = lo * len(X) + hi
        at = np.minimum(np.searchsorted(edges, key), len(edges) - 1)
        blocked = edges[at] == key
        ring = np.abs(np.subtract.outer(np.arange(k), np.arange(k)))
        blocked &= ((ring != 1) & (ring != k - 1))[None]
        cost = np.where(blocked[:, i, j] | blocked[:, j, m] | blocked[:, m, i], np.inf, cost)
    best = np.zeros((B, k, k))
    for gap in range(2, k):
        a = np.arange(0, k - gap)[:, None]
        b = a + gap
        mids = a + np.arange(1, gap)[None, :]
        total = best[:, a, mids] + best[:, mids, b] + cost[:, a, mids, b]
        best[:, a[:, 0], b[:, 0]] = total.min(axis=2)
    last = best[:, 0, k - 1]
    return ~np.isfinite(last) | (last >= far)


def main_faces(faces: np.ndarray, twin: np.ndarray | None = None
                ) -> tuple[np.ndarray, int, np.ndarray | None]:
    """The faces of the largest part of ``faces`` joined through edges, how many parts, and
    which rows of ``faces`` it holds (None: all). ``twin``: :func:`pcgeom.mesh.twins`' first
    of ``faces`` where its second is True (the parts then from the half-edges' pairs, not
    libigl's ``facet_components``: the same)."""
    if len(faces) == 0:
        return faces, 0, None
    if twin is not None:
        count, label = face_parts(faces, twin)
    else:
        import igl

        count, label = igl.facet_components(np.ascontiguousarray(faces, dtype=np.int64))
    if count == 1:
        return faces, 1, None
    kept = label == np.bincount(label).argmax()
    return faces[kept], int(count), kept


def sub_twins(kept: np.ndarray, twin: np.ndarray) -> np.ndarray:
    """:func:`pcgeom.mesh.twins`' first of the rows ``kept`` (bool) of a mesh that make whole
    parts of it (joined through edges), from ``twin``, the mesh's: the same halves,
    renumbered."""
    m, k = len(kept), int(kept.sum())
    new = np.cumsum(kept) - 1
    h = np.flatnonzero(np.tile(kept, 3))
    t = twin[h]
    out = np.full(3 * k, -1, dtype=np.int64)
    out[(h // m) * k + new[h % m]] = np.where(t >= 0, (t // m) * k + new[t % m], -1)
    return out


def edge_keys(faces: np.ndarray, n: int, found: dict | None) -> np.ndarray:
    """The edges of ``faces``, ``a * n + b`` with ``a < b``, sorted, each once (``found``:
    :func:`pcgeom.maps.topology._measure`'s, its twins pick one half of each edge)."""
    H = half_edges(faces)
    if found is not None and found["consistent"]:
        twin = found["twin"]
        H = H[(twin < 0) | (twin > np.arange(len(twin)))]
        return np.sort(np.minimum(H[:, 0], H[:, 1]) * n + np.maximum(H[:, 0], H[:, 1]))
    U = np.sort(H, axis=1)
    return np.unique(U[:, 0] * n + U[:, 1])


def stable_order(values: np.ndarray, n: int) -> np.ndarray:
    """``np.argsort(values, kind="stable")`` of integers in ``0 .. n - 1``, by numpy's radix
    sort of 16-bit keys (one pass, or two for larger ``n``): several times faster."""
    if n <= 1 << 16:
        return np.argsort(values.astype(np.uint16), kind="stable")
    if n <= 1 << 32:
        return np.lexsort(((values & 0xFFFF).astype(np.uint16),
                           (values >> 16).astype(np.uint16)))
    return np.argsort(values, kind="stable")


SMALL_SET = 256
"""Integer arrays of at most this many values go through Python sets in :func:`setdiff` and
:func:`isin` (numpy's sorts cost more below it: 2-15x at the repair's few to few dozen)."""


def setdiff(a: np.ndarray, b) -> np.ndarray:
    """``np.setdiff1d(a, b)`` of integer arrays: the values of ``a`` not in ``b``, sorted,
    each once, ``a``'s dtype; by Python sets when both are small (:data:`SMALL_SET`)."""
    a, b = np.asarray(a), np.asarray(b)
    if a.size > SMALL_SET or b.size > SMALL_SET:
        return np.setdiff1d(a, b)
    return np.array(sorted(set(a.ravel().tolist()).difference(b.ravel().tolist())),
                    dtype=a.dtype)


def isin(a: np.ndarray, b) -> np.ndarray:
    """``np.isin(a, b)`` of integer arrays (``b`` an array or a set of ints): a bool array
    of ``a``'s shape, whether each value is in ``b``; by a Python set when ``a`` is small
    (:data:`SMALL_SET`)."""
    a = np.asarray(a)
    if a.size > SMALL_SET:
        if isinstance(b, (set, frozenset)):
            b = np.fromiter(b, dtype=np.int64, count=len(b))
        return np.isin(a, b)
    s = b if isinstance(b, (set, frozenset)) else set(np.asarray(b).ravel().tolist())
    return np.fromiter(map(s.__contains__, a.ravel().tolist()), dtype=bool,
                       count=a.size).reshape(a.shape)


class Corners:
    """The corners of the faces ``F`` (M, 3) by vertex (``n`` vertices): corner ``slot * M +
    tri`` is ``F[tri, slot]``; ``order`` the corners sorted by vertex (stable), ``start`` where
    each vertex's run begins (n + 1,), ``after`` the vertex that follows each sorted corner in
    its triangle (its half-edge's end)."""

    def __init__(self, F: np.ndarray, n: int):
        self.m = len(F)
        vertex = F.T.ravel()
        self.order = stable_order(vertex, n)
        self.start = np.searchsorted(vertex[self.order], np.arange(n + 1))
        self.after = F[:, [1, 2, 0]].T.ravel()[self.order]

    def triangles(self, vertices: np.ndarray) -> np.ndarray:
        """The triangles at ``vertices``, sorted, each once (the corners' runs gathered at
        once: no slice per vertex)."""
        vertices = np.asarray(vertices)
        if not len(vertices):
            return np.zeros(0, np.int64)
        lo = self.start[vertices]
        count = self.start[vertices + 1] - lo
        at = np.repeat(lo - np.cumsum(count) + count, count) + np.arange(int(count.sum()))
        return np.unique(self.order[at] % self.m)

    def has_half(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """(K,) bool: whether the faces have the directed edge ``a[k] -> b[k]``."""
        lo, hi = self.start[a], self.start[a + 1]
        count = hi - lo
        if not count.sum():
            return np.zeros(len(a), dtype=bool)
        at = np.repeat(lo - np.cumsum(count) + count, count) + np.arange(int(count.sum()))
        hit = self.after[at] == np.repeat(b, count)
        out = np.zeros(len(a), dtype=bool)
        owner = np.repeat(np.arange(len(a)), count)
        out[owner[hit]] = True
        return out


class CloudTree:
    """The k-d tree of the points not excluded (``X[~exclude]``), built when first asked for
    unless given (:attr:`pcgeom.neighbours.Neighbours.tree`: the same points, in order), and
    the ball queries of the meshed points through it."""

    def __init__(self, X: np.ndarray, exclude: np.ndarray | None, tree=None):
        self.X = X
        self.rows = (np.arange(len(X)) if exclude is None
                     else np.flatnonzero(~np.asarray(exclude, dtype=bool)))
        if tree is not None and not (tree.n == len(self.rows)
                                     and np.array_equal(tree.data, X[self.rows])):
            tree = None  # not these points' tree
        self._tree = tree

    @property
    def built(self):
        """The tree, or None while it is not built."""
        return self._tree

    @property
    def tree(self):
        from scipy.spatial import cKDTree

        if self._tree is None:
            self._tree = cKDTree(self.X[self.rows])
        return self._tree

    def meshed_near(self, centres: np.ndarray, radius: np.ndarray, meshed: np.ndarray
                    ) -> set | None:
        """The points with ``meshed`` (bool (N,)) within ``radius`` of any of ``centres``, as
        a set of their indices; None when a meshed point is excluded (not in the tree)."""
        if len(self.rows) < len(self.X) and meshed.sum() > meshed[self.rows].sum():
            return None
        near = self.tree.query_ball_point(centres, radius)
        found = self.rows[np.concatenate([np.asarray(k, dtype=np.int64) for k in near])]
        return set(found[meshed[found]].tolist())


def unmeshed(X: np.ndarray, faces: np.ndarray, exclude: np.ndarray | None = None):
    """The points that no triangle of ``faces`` uses and ``exclude`` does not name, (k,)
    int64, and their k-d tree (None when there are none): the points a fill may take in
    round a loop."""
    from scipy.spatial import cKDTree

    used = np.zeros(len(X), dtype=bool)
    used[faces.ravel()] = True
    if exclude is not None:
        used |= np.asarray(exclude, dtype=bool)
    free = np.flatnonzero(~used)
    return free, (cKDTree(X[free]) if len(free) else None)


def add_fills(faces: np.ndarray, fills: list[np.ndarray]) -> tuple[np.ndarray, int]:
    """``faces`` with the fills whose directed edges are taken by no triangle before them
    (the mesh's, then the earlier fills'); how many fills were added."""
    n = int(max(faces.max(), max(F.max() for F in fills))) + 1
    corners = Corners(faces, n)  # (the mesh's half-edges round each vertex: no sort of all)
    taken: set = set()  # the earlier fills'
    kept = []
    for F in fills:
        D = half_edges(F)
        if corners.has_half(D[:, 0], D[:, 1]).any():
            continue
        keys = (D[:, 0] * n + D[:, 1]).tolist()
        if taken.isdisjoint(keys) and len(set(keys)) == len(keys):
            taken.update(keys)
            kept.append(F)
    if not kept:
        return faces, 0
    return np.concatenate([faces, *kept]), len(kept)


class KnownTwins:
    """:func:`pcgeom.mesh.twins` of the faces array last asked about, kept while the same
    array (the same object: the repair's steps return their input when they change nothing)
    is asked about again; and so its :func:`pcgeom.mesh.fan_counts` and :func:`main_faces`
    with those twins (:meth:`fans`, :meth:`parts`; read-only results)."""

    def __init__(self):
        self._faces = None
        self._found = None
        self._fans = None
        self._parts = None

    def of(self, faces: np.ndarray) -> tuple[np.ndarray, bool]:
        if faces is not self._faces:
            self._faces, self._found = faces, twins(faces)
            self._fans = self._parts = None
        return self._found

    def _known(self, faces: np.ndarray, twin: np.ndarray | None) -> bool:
        return faces is self._faces and twin is not None and twin is self._found[0]

    def fans(self, faces: np.ndarray, twin: np.ndarray) -> np.ndarray:
        """:func:`pcgeom.mesh.fan_counts` ``(faces, twin)``, found once for the faces and
        twins :meth:`of` last gave."""
        if not self._known(faces, twin):
            return fan_counts(faces, twin)
        if self._fans is None:
            self._fans = fan_counts(faces, twin)
        return self._fans

    def parts(self, faces: np.ndarray, twin: np.ndarray | None = None
              ) -> tuple[np.ndarray, int, np.ndarray | None]:
        """:func:`main_faces` ``(faces, twin)``, found once for the faces and twins
        :meth:`of` last gave."""
        if not self._known(faces, twin):
            return main_faces(faces, twin)
        if self._parts is None:
            self._parts = main_faces(faces, twin)
        return self._parts


def cut_at_repeats(loop: np.ndarray) -> list[np.ndarray]:
    """A closed walk cut into simple cycles: each time a vertex comes back, the cycle since
    its last visit is cut off (cycles of fewer than 3 vertices are dropped)."""
    stack: list[int] = []
    where: dict[int, int] = {}
    cycles = []
    for v in loop.tolist() + [int(loop[0])]:
        if v in where:
            start = where[v]
            cycle = stack[start:]
            if len(cycle) >= 3:
                cycles.append(np.asarray(cycle, dtype=np.int64))
            for w in cycle[1:]:
                del where[w]
            del stack[start + 1:]
        else:
            where[v] = len(stack)
            stack.append(v)
    return cycles


class FillMemo:
    """The fills that repairs of one cloud tried and their figures (the re-meshes',
    :func:`pcgeom.maps.fills.refill_small_loops`; the pinches' mends',
    :func:`pcgeom.maps.pinches.mend_pinches`), by everything a fill and its figures are
    found from: the loop, the points inside and round it, the mesh's edges it must keep
    clear of, and those points' normals (the cloud's points, strays and spacings by a
    digest: :meth:`bind`). A run repairs one cloud's local mesh again in each round that
    builds the mesh again (robust, normal and vote rounds, the bridges' cut): 2-20 repairs,
    whose loops come back with the same points and normals where the mesh and the normals
    did not change (the normal rounds change 3-32% of the normals, measured on the pleats):
    measured, 41% of the fills a run of the pleats tries were tried before in the run, 57%
    for the lips sheet with its normals. (The fill pass's fills, by their loop, points,
    normals and the mesh's edges among the points, came back less often, 12% on the pleats,
    and their lookups cost what they saved.) The callers keep the figures before their
    thresholds (the least cosine between a triangle and a corner's normal, the widest
    triangle or empty circle) and apply those to them, so that an answer looked up is the
    answer found (the same repaired faces, to the bit)."""

    LIMIT = 20_000
    """Entries kept at most (all are dropped when there are more; a run of the pleats or the
    lips sheet, 6k-11k points, makes about 1,300)."""

    def __init__(self):
        self.clear()

    def clear(self) -> None:
        """No entries (:func:`pcgeom.maps.localmesh.mesh_cloud` clears it as a run starts:
        a run's repairs share their fills, and its memory goes with the next run)."""
        self._cloud = None
        self._entries: dict = {}
        self.hits = 0
        self.misses = 0

    def bind(self, X: np.ndarray, exclude: np.ndarray | None, h: np.ndarray) -> "FillMemo":
        """The memo for the points ``X``, strays ``exclude`` and spacings ``h``: its entries
        when they are of the same cloud, none otherwise."""
        import hashlib

        digest = hashlib.blake2b(digest_size=16)
        for a in (X, h) if exclude is None else (X, h, exclude):
            a = np.ascontiguousarray(a)
            digest.update(repr((a.dtype.str, a.shape)).encode())
            digest.update(a)
        cloud = digest.digest()
        if cloud != self._cloud:
            self._cloud, self._entries = cloud, {}
        return self

    def get(self, key: tuple, find):
        """The entry of ``key`` (a tuple of bytes and numbers), found by ``find()`` when
        there is none."""
        try:
            value = self._entries[key]
            self.hits += 1
            return value
        except KeyError:
            self.misses += 1
        value = find()
        if len(self._entries) >= self.LIMIT:
            self._entries = {}
        self._entries[key] = value
        return value


FILLS = FillMemo()
""":func:`pcgeom.maps.topology.repair`'s memo of fills (of the last cloud repaired)."""
