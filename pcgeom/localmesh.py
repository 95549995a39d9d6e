"""The local-mesh map: a manifold mesh of same-sheet tangent fans, then LSCM (not in the paper).

The networks of the paper decide a cloud's global layout from positions alone. Where a scan's
surface doubles back closer than its point spacing, positions cannot tell the sheets apart and
the networks lay a flap of the surface folded onto the other sheet; local refinement steps
cannot unfold it (DESIGN.md, "What limits real scans"). Oriented normals can, and a global
linear solve uses them everywhere at once:

1. **Same-sheet neighbours.** Each point keeps those of its ``k`` nearest neighbours whose
   normal points to the same side as its own (``n_i . n_j > 0``).
2. **Tangent fans.** They are projected on the point's tangent plane and Delaunay-triangulated;
   the triangles at the point form its fan (its star in the local Delaunay triangulation).
3. **Manifold merge.** The fans' triangles are oriented by the normals and added greedily, the
   ones most fans agree on first, then the better-shaped: a triangle is kept only if each of its
   edges stays in at most two triangles, with opposite directions. The result is edge-manifold
   and consistently oriented. (LSCM over the plain union of the fans folds: DESIGN.md.)
4. **LSCM** (Levy et al. 2002) on that mesh: minimize the conformal energy, the Dirichlet energy
   (libigl's cotangent matrix) minus the signed area (libigl's ``vector_area_matrix``), with
   two far-apart points pinned. Points outside the mesh's largest connected part take the
   distance-weighted mean of the map at their nearest meshed points (they are counted).
5. **Conformal factor.** ``l_i``, the inverse-lambda of LEG, is set so that LEG's
   ``(l_i + l_j) |u_i - u_j|`` matches ``|x_i - x_j|`` at the point's nearest neighbours.

Measured on face_human_choi (17k points, the mesh's oriented normals, evaluated on its true
triangles): 0.0229 rad mean angle distortion and no flipped triangle with 24 neighbours,
0.0276 rad and 0.24% flipped with 16, 0.0403 rad and 0.57% with 12; libigl's LSCM on the true
mesh gives 0.0195. With PCA normals oriented by propagation (:mod:`pcgeom.normals`): 0.034 rad
and 3.5% flipped.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import InputError

__all__ = ["LocalMesh", "local_mesh", "lscm_free", "conformal_disk", "conformal_factor"]


@dataclass(frozen=True, eq=False)
class LocalMesh:
    """A manifold triangle mesh over a cloud, built from its points and oriented normals."""

    faces: np.ndarray
    """(M, 3) int64, consistently oriented (counter-clockwise seen from the normals' side)."""
    main: np.ndarray
    """(N,) bool: the point is a vertex of the mesh's largest connected part."""
    boundary_edges: int
    """Edges of the whole mesh that belong to one triangle only."""
    candidates: int
    """Distinct triangles the fans proposed."""

    @property
    def n_faces(self) -> int:
        return len(self.faces)

    @property
    def looks_closed(self) -> bool:
        """Fewer boundary edges than ``sqrt(N) / 2``: the cloud samples a closed surface.

        An open surface has a rim of about the square root of its point count or more
        (face_human_choi: 683 boundary edges for 17157 points, 5.2 sqrt(N); peaks_7holes_choi
        3.7 sqrt(N)); the closed david head gives none.
        """
        return self.boundary_edges < 0.5 * np.sqrt(len(self.main))


_MERGE_CHUNK = 100_000
"""Candidate triangles turned into Python lists at a time by the merge."""

_MIN_QUALITY = 1e-4
"""Triangles of worse shape quality (1: equilateral, 0: degenerate) are never kept."""


def _tangent_basis(n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors spanning the plane orthogonal to each unit ``n`` (N, 3)."""
    helper = np.where(np.abs(n[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    a = np.cross(n, helper)
    a /= np.linalg.norm(a, axis=1, keepdims=True)
    return a, np.cross(n, a)


def _fans(X: np.ndarray, normals: np.ndarray, neighbours: int, progress: bool,
          chunk: int = 50_000) -> np.ndarray:
    """Triangles of every point's Delaunay star among its same-sheet neighbours."""
    from scipy.spatial import cKDTree
    from tqdm.auto import tqdm

    k = min(neighbours, len(X) - 1)
    _, nb = cKDTree(X).query(X, k + 1)
    starts = range(0, len(X), chunk)
    blocks = [_stars(X, normals, nb[s:s + chunk], np.arange(s, min(s + chunk, len(X))))
              for s in tqdm(starts, desc="local mesh", unit="block", disable=not progress,
                            leave=False)]
    return np.concatenate(blocks).astype(np.int64)


def _circular_neighbours(alive: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For each slot of each row, the previous and the next alive slot in circular order
    (positions in the row doubled: ``< k`` is one lap back, ``>= k`` one lap on; ``-1`` and
    ``>= 2k`` where there is none)."""
    k = alive.shape[1]
    cols = np.arange(k)[None, :]
    before = np.concatenate([np.where(alive, cols, -1), np.where(alive, cols + k, -1)], axis=1)
    prev = np.maximum.accumulate(before, axis=1)[:, k - 1:2 * k - 1]
    after = np.concatenate([np.where(alive, cols, 3 * k), np.where(alive, cols + k, 3 * k)],
                           axis=1)
    nxt = np.minimum.accumulate(after[:, ::-1], axis=1)[:, ::-1][:, 1:k + 1]
    return prev, nxt


def _stars(X: np.ndarray, normals: np.ndarray, nb: np.ndarray, idx: np.ndarray) -> np.ndarray:
    """The Delaunay star of each point ``idx`` among its same-sheet neighbours ``nb[:, 1:]``,
    projected on its tangent plane, for all points at once.

    ``x_j`` is a Delaunay neighbour of the point (the origin) when some circle through both is
    empty. Inversion about the origin (``q = p / |p|^2``) turns those circles into lines, so
    the neighbours are the vertices of the convex hull of the ``q`` and the origin. Sorted by
    angle, a neighbour inside the triangle of the origin and its two hull neighbours (a
    right turn, within a wedge under pi) is never a hull vertex: such neighbours are dropped
    until none is left. The star's triangles join consecutive survivors less than pi apart.
    Equal, up to ties between cocircular points, to scipy's Delaunay of each neighbourhood.
    """
    k = nb.shape[1] - 1
    a, b = _tangent_basis(normals[idx])
    js = nb[:, 1:]
    same = np.einsum("nkd,nd->nk", normals[js], normals[idx]) > 0
    offsets = X[js] - X[idx][:, None, :]
    p = np.stack([np.einsum("nkd,nd->nk", offsets, a), np.einsum("nkd,nd->nk", offsets, b)],
                 axis=-1)
    angle = np.where(same, np.arctan2(p[..., 1], p[..., 0]), np.inf)
    order = np.argsort(angle, axis=1)
    js = np.take_along_axis(js, order, axis=1)
    p = np.take_along_axis(p, order[..., None], axis=1)
    angle = np.take_along_axis(angle, order, axis=1)
    alive = np.isfinite(angle)
    angle = np.where(alive, angle, 0.0)
    q = p / np.maximum((p ** 2).sum(axis=-1, keepdims=True), 1e-300)
    cols = np.arange(k)[None, :]
    for _ in range(k):
        prev, nxt = _circular_neighbours(alive)
        pi, ni = prev % k, nxt % k
        valid = alive & (prev >= 0) & (nxt < 2 * k) & (pi != ni) & (pi != cols)
        qa = np.take_along_axis(q, pi[..., None], axis=1)
        qb = np.take_along_axis(q, ni[..., None], axis=1)
        wedge = np.mod(np.take_along_axis(angle, ni, axis=1)
                       - np.take_along_axis(angle, pi, axis=1), 2 * np.pi)
        turn = ((q[..., 0] - qa[..., 0]) * (qb[..., 1] - q[..., 1])
                - (q[..., 1] - qa[..., 1]) * (qb[..., 0] - q[..., 0]))
        inside = valid & (wedge < np.pi) & (turn <= 0)
        if not inside.any():
            break
        alive &= ~inside
    _, nxt = _circular_neighbours(alive)
    ni = nxt % k
    gap = np.mod(np.take_along_axis(angle, ni, axis=1) - angle, 2 * np.pi)
    keep = alive & (nxt < 2 * k) & (ni != cols) & (gap < np.pi)
    r, c = np.nonzero(keep)
    return np.column_stack([idx[r], js[r, c], js[r, ni[r, c]]])


def _merge(X: np.ndarray, normals: np.ndarray, candidates: np.ndarray
           ) -> tuple[np.ndarray, int]:
    """Greedy edge-manifold, consistently oriented union of the fans' triangles, and the
    number of distinct candidates."""
    tris, votes = np.unique(np.sort(candidates, axis=1), axis=0, return_counts=True)
    if len(tris) == 0:
        return tris, 0
    cross = np.cross(X[tris[:, 1]] - X[tris[:, 0]], X[tris[:, 2]] - X[tris[:, 0]])
    flip = np.einsum("md,md->m", cross, normals[tris].sum(axis=1)) < 0
    tris[flip] = tris[flip][:, [0, 2, 1]]
    # Shape quality: 1 for an equilateral triangle, 0 for a degenerate one.
    sq = sum(((X[tris[:, (q + 1) % 3]] - X[tris[:, q]]) ** 2).sum(axis=1) for q in range(3))
    quality = 2.0 * np.sqrt(3.0) * np.linalg.norm(cross, axis=1) / np.maximum(sq, 1e-300)
    # Slivers (collinear points, as on a regular grid) make the cotangent weights blow up.
    order = np.lexsort((-quality, -votes))
    order = order[quality[order] > _MIN_QUALITY]
    # Edges as integer keys (a * n + b): a third of the memory of tuples at 1M points.
    n = int(tris.max()) + 1
    directed: set[int] = set()
    uses: dict[int, int] = {}
    keep = []
    for start in range(0, len(order), _MERGE_CHUNK):
        block = order[start:start + _MERGE_CHUNK]
        for t, (a, b, c) in zip(block.tolist(), tris[block].tolist()):
            edges = ((a, b), (b, c), (c, a))
            if any(x * n + y in directed or uses.get(min(x, y) * n + max(x, y), 0) >= 2
                   for x, y in edges):
                continue
            keep.append(t)
            for x, y in edges:
                directed.add(x * n + y)
                key = min(x, y) * n + max(x, y)
                uses[key] = uses.get(key, 0) + 1
    return tris[np.sort(np.asarray(keep, dtype=np.int64))], len(tris)


def _main_part(faces: np.ndarray, n: int) -> np.ndarray:
    """(n,) bool: the vertices of the largest connected part of ``faces`` (none if empty)."""
    import scipy.sparse as sp
    from scipy.sparse.csgraph import connected_components

    main = np.zeros(n, dtype=bool)
    if len(faces):
        ring = np.roll(faces, 1, axis=1)
        A = sp.coo_matrix((np.ones(faces.size), (faces.ravel(), ring.ravel())), shape=(n, n))
        _, label = connected_components(A, directed=False)
        used = np.zeros(n, dtype=bool)
        used[faces.ravel()] = True
        main = used & (label == np.bincount(label[used]).argmax())
    return main


def _submesh(X: np.ndarray, faces: np.ndarray, keep: np.ndarray
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The vertices ``keep`` (bool mask) of the mesh, renumbered: their indices, contiguous
    ``V`` and the faces among them (contiguous, as libigl wants them)."""
    index = np.flatnonzero(keep)
    remap = np.full(len(X), -1, dtype=np.int64)
    remap[index] = np.arange(len(index))
    F = remap[faces]
    return index, np.ascontiguousarray(X[index]), np.ascontiguousarray(F[(F >= 0).all(axis=1)])


def local_mesh(X: np.ndarray, normals: np.ndarray, neighbours: int = 24, *,
               exclude: np.ndarray | None = None, progress: bool = False) -> LocalMesh:
    """Build the manifold mesh of same-sheet tangent fans (steps 1-3 of the module).

    Parameters
    ----------
    X : (N, 3) float64
        Distinct points.
    normals : (N, 3) float64
        Unit normals, consistently oriented.
    neighbours : int
        Nearest neighbours each fan is built from.
    progress : bool
        A tqdm bar over the fans on stderr.

    Returns
    -------
    LocalMesh
    """

    n = len(X)
    kept = np.arange(n) if exclude is None else np.flatnonzero(~np.asarray(exclude, bool))
    candidates = kept[_fans(X[kept], normals[kept], neighbours, progress)]
    faces, n_candidates = _merge(X, normals, candidates)
    del candidates
    main = _main_part(faces, n)
    boundary = int(_edge_sides(faces)[1].sum())
    return LocalMesh(faces=faces, main=main, boundary_edges=boundary, candidates=n_candidates)


def _edge_sides(faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each triangle's three edges, ``(3M, 2)`` in the order 01, 12, 20 of every triangle
    (edge ``k`` belongs to triangle ``k % M``), and whether each is on one triangle only
    (a boundary edge), ``(3M,)``."""
    edges = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    if not len(edges):
        return edges, np.zeros(0, dtype=bool)
    _, inverse, counts = np.unique(np.sort(edges, axis=1), axis=0, return_inverse=True,
                                   return_counts=True)
    return edges, counts[inverse.ravel()] == 1


def lscm_free(X: np.ndarray, mesh: LocalMesh) -> np.ndarray:
    """Free-boundary LSCM of the mesh's main part; other points interpolated (step 4).

    Returns
    -------
    (N, 2) float64
        The map, centred on its mean and turned to its principal axes (the longer along u;
        a rotation, never a mirror), in the units of LSCM with the two pins one apart.
    """
    import igl
    import scipy.sparse as sp

    main, V, F = _submesh(X, mesh.faces, mesh.main)
    m = len(V)
    # Conformal energy 1/2 u^T (-L (+) -L) u - u^T A u, libigl's LSCM quadratic form.
    L = igl.cotmatrix(V, F)
    Q = sp.csr_matrix(-0.5 * sp.block_diag([L, L]) - igl.vector_area_matrix(F))
    # Pins: the point farthest from the centroid, and the point farthest from it.
    p0 = int(np.argmax(((V - V.mean(axis=0)) ** 2).sum(axis=1)))
    p1 = int(np.argmax(((V - V[p0]) ** 2).sum(axis=1)))
    fixed = np.array([p0, p1, m + p0, m + p1])
    values = np.array([0.0, 1.0, 0.0, 0.0])
    free = np.setdiff1d(np.arange(2 * m), fixed)
    rows = Q[free]
    del Q, L  # the sparse LU below is the peak of memory at a million points
    rhs = -(rows[:, fixed] @ values)
    Q_ff = rows[:, free].tocsc()
    del rows
    z = _spd_factor(Q_ff)(rhs)
    if not np.isfinite(z).all():
        raise InputError("the local mesh of the cloud is degenerate (LSCM has no unique "
                         "solution); try more neighbours or the 'networks' preset")
    flat = np.empty(2 * m)
    flat[fixed] = values
    flat[free] = z
    U = np.full((len(X), 2), np.nan)
    U[main] = np.column_stack([flat[:m], flat[m:]])
    return _principal_pose(_interpolate_rest(X, U, mesh.main))


def _spd_factor(A):
    """A sparse LU of the symmetric positive definite ``A`` (scipy's SuperLU), ordered for
    symmetry: minimum degree on ``A^T + A`` and no pivoting, which a positive definite matrix
    does not need. Returns the factor's ``solve``.

    SuperLU's default (COLAMD, partial pivoting) is made for unsymmetric matrices: on the LSCM
    system of a 100k-point height field it filled 37.1M entries and took 23 s; this ordering
    fills 14.7M in 8.7 s, with the same solution to 2e-8 (benchmarks, 2 cores).
    """
    import scipy.sparse as sp
    from scipy.sparse.linalg import splu

    return splu(sp.csc_matrix(A), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                options={"SymmetricMode": True}).solve


def _principal_pose(U: np.ndarray) -> np.ndarray:
    """``U`` centred and rotated so that its principal axes are u and v (deterministic signs)."""
    U = U - U.mean(axis=0)
    _, _, Vt = np.linalg.svd(U, full_matrices=False)
    R = Vt.T  # columns: principal directions
    # Signs: the largest component of the first axis positive, then no mirror (det +1).
    R[:, 0] *= np.sign(R[np.argmax(np.abs(R[:, 0])), 0]) or 1.0
    if np.linalg.det(R) < 0:
        R[:, 1] = -R[:, 1]
    return U @ R


def conformal_factor(X: np.ndarray, U: np.ndarray, neighbours: int = 8) -> np.ndarray:
    """``l_i = median_j |x_i - x_j| / (2 |u_i - u_j|)`` over the nearest neighbours (step 5).

    LEG compares ``|x_i - x_j|`` with ``(l_i + l_j) |u_i - u_j|``; with this ``l`` they agree
    where the map is locally a similarity.
    """
    from scipy.spatial import cKDTree

    k = min(neighbours, len(X) - 1)
    _, nb = cKDTree(X).query(X, k + 1)
    d3 = np.linalg.norm(X[nb[:, 1:]] - X[:, None, :], axis=-1)
    d2 = np.linalg.norm(U[nb[:, 1:]] - U[:, None, :], axis=-1)
    ratio = d3 / np.maximum(d2, 1e-12 * max(float(d3.max()), 1e-300))
    return 0.5 * np.median(ratio, axis=1)


def _vertex_manifold(faces: np.ndarray, rounds: int = 5) -> np.ndarray:
    """Drop triangles so that every vertex has one fan: where two fans meet at a vertex (a
    "bowtie", which the merge's edge test lets through), keep the fan with most triangles.

    Not used for the free map: on face_human_choi the dropped fans raise its distortion
    (0.0229 to 0.0239 rad with the mesh's normals). The disk map needs it: its boundary must
    be one simple loop.
    """
    for _ in range(rounds):
        directed = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
        present = set(map(tuple, directed.tolist()))
        outgoing = np.zeros(faces.max(initial=-1) + 1, dtype=np.int64)
        for a, b in directed.tolist():
            if (b, a) not in present:
                outgoing[a] += 1
        bad = set(np.flatnonzero(outgoing > 1).tolist())
        if not bad:
            break
        incident: dict[int, list[int]] = {}
        for t, tri in enumerate(faces.tolist()):
            for v in tri:
                if v in bad:
                    incident.setdefault(v, []).append(t)
        drop: set[int] = set()
        for v in sorted(bad):
            tris = [t for t in incident[v] if t not in drop]
            if not tris:
                continue
            parent = {t: t for t in tris}  # union-find of the triangles around v

            def root(t: int) -> int:
                while parent[t] != t:
                    parent[t] = parent[parent[t]]
                    t = parent[t]
                return t

            first: dict[int, int] = {}  # other vertex of an edge at v -> a triangle on it
            for t in tris:
                for w in faces[t].tolist():
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
            drop.update(t for fan in fans.values() if fan is not biggest for t in fan)
        faces = np.delete(faces, sorted(drop), axis=0)
    return faces


def _boundary_loops(faces: np.ndarray) -> list[list[int]]:
    """Boundary loops of a vertex-manifold, consistently oriented mesh, as vertex lists."""
    directed = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]).tolist()
    present = set(map(tuple, directed))
    following = {a: b for a, b in directed if (b, a) not in present}
    loops, seen = [], set()
    for start in following:
        if start in seen:
            continue
        loop, v = [], start
        while v not in seen and v in following:
            seen.add(v)
            loop.append(v)
            v = following[v]
        if len(loop) >= 3:
            loops.append(loop)
    return loops


def _signed_area(P: np.ndarray) -> float:
    """Shoelace area of the closed polygon ``P`` (k, 2): positive when counter-clockwise."""
    x, y = P[:, 0], P[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def _interpolate_rest(X: np.ndarray, U: np.ndarray, known: np.ndarray) -> np.ndarray:
    """Fill the rows of ``U`` not in ``known`` with the inverse-distance mean of the map at
    their 8 nearest known points."""
    from scipy.spatial import cKDTree

    rest = np.flatnonzero(~known)
    if len(rest):
        have = np.flatnonzero(known)
        k = min(8, len(have))
        dist, nb = cKDTree(X[have]).query(X[rest], k)
        dist, nb = np.atleast_2d(dist), np.atleast_2d(nb)
        w = 1.0 / np.maximum(dist, 1e-12)
        U[rest] = np.einsum("rk,rkd->rd", w, U[have][nb]) / w.sum(axis=1, keepdims=True)
    return U


def _planar_mesh(P: np.ndarray, loop: np.ndarray) -> np.ndarray:
    """The Delaunay triangles (scipy) of the planar points ``P`` inside the closed polygon
    ``P[loop]``, counter-clockwise, with one fan per vertex.

    The polygon is filled: holes of the map inside it are triangulated over. Where the loop
    crosses itself (a fold of the map at its rim), its largest simple part is used (shapely's
    ``make_valid``). A triangle is kept when it lies inside the polygon (to a tolerance of
    1e-9 of its size), so the mesh's rim follows the loop into its concave notches instead of
    cutting across them, and the loop's points stay on the rim the disk map puts on the
    circle. Keeping the triangles whose centroid is inside instead cut those notches: on
    face_human_choi the mapped true surface then missed the circle by 0.019 (0.013 with this
    test; with its normals 0.0195 -> 0.010), at the same angles. Then the flat rim triangles
    over points just inside the loop are peeled (:func:`_peel_rim`). Points on top of another
    (qhull leaves them out) or outside the polygon belong to no triangle.
    """
    import shapely
    from scipy.spatial import Delaunay

    region = shapely.make_valid(shapely.Polygon(P[loop]))
    parts = [g for g in getattr(region, "geoms", [region])
             if g.geom_type == "Polygon" and g.area > 0]
    if not parts or len(P) < 3:
        return np.empty((0, 3), dtype=np.int64)
    region = shapely.Polygon(max(parts, key=lambda g: g.area).exterior)
    region = region.buffer(1e-9 * np.sqrt(region.area))  # its own edges count as inside
    shapely.prepare(region)
    tri = Delaunay(P).simplices.astype(np.int64)
    tri = tri[shapely.contains(region, shapely.polygons(P[tri]))]
    a, b = P[tri[:, 1]] - P[tri[:, 0]], P[tri[:, 2]] - P[tri[:, 0]]
    clockwise = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0] < 0
    tri[clockwise] = tri[clockwise][:, [0, 2, 1]]
    return _vertex_manifold(_peel_rim(P, tri))


RIM_ANGLE = 2.0 * np.pi / 3.0
"""A rim triangle whose angle opposite its boundary edge is wider than this spans a notch of
the rim (:func:`_peel_rim`)."""


def _peel_rim(P: np.ndarray, T: np.ndarray, rounds: int = 20) -> np.ndarray:
    """Drop the rim triangles that bridge a notch of the rim: one boundary edge, the angle
    opposite it wider than :data:`RIM_ANGLE`, and the opposite vertex not on the rim yet
    (so that it joins the rim, and the mesh stays manifold). Repeated while any is left.

    The local mesh's fans cover a rim point that lies a little inside its neighbours on the
    rim (the stars are Delaunay in each tangent plane), so the disk map put such a point
    inside the disk and the true surface missed the circle there: on face_human_choi by 0.013
    (0.010 with its normals), on that face decimated to 6085 points (its 168 rim vertices
    kept) by 0.043. Peeled: 0.0007, 0.0007 and 0.0006, with angles a little lower (0.0397 ->
    0.0392 rad bare, 0.0257 -> 0.0253, 0.0458 -> 0.0448) and the same flips; the same from
    100 to 140 degrees.
    """
    limit = np.cos(RIM_ANGLE)
    for _ in range(rounds):
        edges, boundary = _edge_sides(T)  # (3M, 2), (3M,)
        opposite = np.concatenate([T[:, 2], T[:, 0], T[:, 1]])  # (3M,)
        on_rim = np.zeros(len(P), dtype=bool)
        on_rim[edges[boundary].ravel()] = True
        u, v = P[edges[:, 0]] - P[opposite], P[edges[:, 1]] - P[opposite]
        cos = (u * v).sum(axis=1) / np.maximum(
            np.linalg.norm(u, axis=1) * np.linalg.norm(v, axis=1), 1e-300)
        face = np.arange(len(edges)) % len(T)
        one_edge = np.bincount(face[boundary], minlength=len(T)) == 1  # (M,)
        drop = np.unique(face[boundary & (cos < limit) & ~on_rim[opposite]])
        drop = drop[one_edge[drop]]
        if not len(drop):
            break
        T = np.delete(T, drop, axis=0)
    return T


def _harmonic_measure_disk(V: np.ndarray, F: np.ndarray, outer: np.ndarray,
                           centre: int) -> np.ndarray:
    """The discrete Riemann map of the mesh ``(V, F)`` onto the unit disk, ``centre`` to 0.

    The Green's function ``g`` of the centre (cotangent Laplacian ``L``, ``L g = delta``,
    ``g = 0`` on the loop ``outer``) gives the harmonic measure of the boundary seen from it,
    the flux ``-(L g)_b``. A conformal map sending the centre to 0 spreads the boundary on the
    circle by harmonic measure: vertex ``b`` goes to the angle ``2 pi`` times the cumulative
    flux up to it. The interior is the harmonic extension of those values (cotangent weights;
    other boundary loops free), the conformal map when the boundary values are.
    """
    import igl

    n = len(V)
    interior = np.setdiff1d(np.arange(n), outer)
    L = -igl.cotmatrix(V, F)  # positive semi-definite
    solve = _spd_factor(L[interior][:, interior])  # one factor for the three solves
    g = np.zeros(n)
    g[interior] = solve((interior == centre).astype(np.float64))
    flux = np.maximum(-(L @ g)[outer], 0.0)
    if not np.isfinite(flux).all() or flux.sum() <= 0:
        raise InputError("the local mesh of the cloud is degenerate (no harmonic measure on "
                         "its boundary); try the 'networks' preset")
    theta = 2.0 * np.pi * (np.cumsum(flux) - 0.5 * flux) / flux.sum()
    circle = np.column_stack([np.cos(theta), np.sin(theta)])
    D = np.zeros((n, 2))
    D[outer] = circle
    D[interior] = solve(np.asarray(-(L[interior][:, outer] @ circle)))
    return D


def conformal_disk(X: np.ndarray, mesh: LocalMesh, free_uv: np.ndarray) -> np.ndarray:
    """A conformal map of the cloud onto the unit disk: its free map ``free_uv`` (LSCM),
    followed by the Riemann map of the planar region that map covers.

    1. The mesh is made vertex-manifold, so that its outer boundary is one simple loop: the
       loop of largest area in the free map.
    2. The free map's points inside that loop are triangulated in the plane (Delaunay,
       :func:`_planar_mesh`). The free map is already conformal, so a conformal map of this
       planar region onto the disk composes with it into a conformal map of the surface.
       Defects of the local mesh (flaps folded over where the estimated normals cross two
       sheets, slivers, handles) stay where LSCM put them instead of steering the disk map.
    3. That region's Riemann map (:func:`_harmonic_measure_disk`), centred at the point
       farthest from the loop. A Delaunay triangulation's cotangent weights are not negative
       inside, so the harmonic map onto the convex circle does not fold it.
    4. Points in no planar triangle (outside the mesh's main part, on top of another point or
       beyond the loop) are interpolated; a disk automorphism centres the points' mean
       (:func:`_balance`).

    Measured (angle distortion on the true triangles, flipped of them, Hausdorff distance to
    the disk of the mapped points and of the mapped true triangles): three peaks, estimated
    normals, 0.0167 rad, none, 0.025 and 0.0001; face_human_choi with its normals 0.0253 rad,
    28 of 34144, 0.066 and 0.0007, and without them 0.0392 rad, 1192 (the free map's own
    folds), 0.063 and 0.0007. The harmonic map of the local mesh itself, which this replaced:
    0.0228 rad with 12 flips, 0.0534 and 0.145 rad: the bare face's folded eyelid flaps bent
    the whole interior. libigl's harmonic map with the boundary spread by arc length, on the
    true meshes: 0.180 and 0.115 rad.

    Returns
    -------
    (N, 2) float64, inside the closed unit disk.
    """
    from scipy.spatial import cKDTree

    n_all = len(X)
    faces = _vertex_manifold(mesh.faces)
    main, _, F = _submesh(X, faces, _main_part(faces, n_all))
    P = np.ascontiguousarray(free_uv[main])
    loops = _boundary_loops(F)
    if not loops:
        raise InputError("the local mesh has no boundary loop; a disk map needs one")
    outer = np.array(max(loops, key=lambda loop: abs(_signed_area(P[loop]))))
    T = _planar_mesh(P, outer)
    placed, V2, T = _submesh(np.column_stack([P, np.zeros(len(P))]), T, _main_part(T, len(P)))
    plane = _boundary_loops(T) if len(T) else []
    rim = np.array(max(plane, key=lambda loop: abs(_signed_area(V2[loop, :2]))) if plane else [],
                   dtype=np.int64)
    inside = np.setdiff1d(np.arange(len(V2)), rim)
    if not len(rim) or not len(inside):
        raise InputError("the local mesh of the cloud is degenerate (its free map covers no "
                         "region with a point inside); try the 'networks' preset")
    centre = int(inside[np.argmax(cKDTree(V2[rim, :2]).query(V2[inside, :2])[0])])
    U = np.full((n_all, 2), np.nan)
    U[main[placed]] = _harmonic_measure_disk(V2, T, rim, centre)
    known = np.zeros(n_all, dtype=bool)
    known[main[placed]] = True
    return _balance(_interpolate_rest(X, U, known))


def _balance(U: np.ndarray, rounds: int = 50) -> np.ndarray:
    """Compose with disk automorphisms ``z -> (z - a) / (1 - conj(a) z)``, ``a`` the points'
    mean, until the mean is at the centre: the points sample the surface evenly, so this
    spreads the surface's area evenly around the disk (conformal, so no angle changes).
    Three peaks: Hausdorff distance to the disk 0.0312 -> 0.0293; face_human_choi 0.070 ->
    0.065."""
    z = U[:, 0] + 1j * U[:, 1]
    for _ in range(rounds):
        a = z.mean()
        if abs(a) < 1e-9:
            break
        z = (z - a) / (1.0 - np.conj(a) * z)
    return np.column_stack([z.real, z.imag])
