"""Normals of a cloud that has none: PCA estimates, consistently oriented by propagation.

Scanners write oriented normals, and where a surface doubles back (closed eyelids and lips,
nostrils) they are what tells its two sheets apart: the other sheet can lie closer than the
point spacing, but its normals point the other way (DESIGN.md, "What limits real scans").
A bare cloud has to estimate them:

1. **PCA** (Hoppe et al., 1992): the normal at ``x_i`` is the direction of least variance of its
   ``k`` nearest neighbours. It has no sign. :func:`pcgeom.maps.localmesh.mesh_cloud` takes each
   point's ``k`` from a ladder (6 to 24), the largest at which its neighbours lie nearly as flat as
   at the
   flattest (:func:`pcgeom.neighbours.adaptive_pca`): noise asks for many neighbours, a fold whose
   facing sheet lies a couple of spacings away for few.
2. **Orientation by propagation** (Hoppe et al.; the same idea as Open3D's
   ``orient_normals_consistent_tangent_plane``): on the k-nearest-neighbour graph, take a
   minimum spanning tree and flip each normal to agree with its parent's, from a seed.

   The edge cost is ``(1 - |n_i . n_j|) + |n_i . e_ij| + |n_j . e_ij|`` with ``e_ij`` the unit
   direction from ``x_i`` to ``x_j``. The first term is Hoppe's (prefer parallel normals). The
   last two, added here, price an edge that leaves the tangent planes: a neighbour on the
   other sheet of a fold sits along the normal, not beside the point. On face_human_choi they
   raise the share of correctly oriented normals from 93.2% to 96.7%. The propagation still
   crosses where the sheets touch over a long stretch. This is why a cloud without normals
   may fold there.

   It crosses even from exact lines: the lips sheet's true normals with random signs
   (:func:`pcgeom.synthetic_sheets.lips_sheet`, walls 0.75 spacings apart, 11k points, seeds
   0-2) come out 468 / 34 / 103 points the wrong way, from its PCA normals 443 / 259 / 451
   (benchmarks/bench_bridges.py). Costs measured and not kept (bare, ``fast``, on the true
   triangles, side by side in one run, 2026-12-05): the heights in local spacings instead of
   the unit direction, ``(1 - |n_i . n_j|) + (|n_i . d_ij| + |n_j . d_ij|) / h_i`` (``d_ij``
   the offset, ``h_i`` the mean distance to the 6 nearest), on 8 neighbours: exact lines 33 /
   41 / 53 wrong (16 neighbours), PCA lines 294 / 176 / 132; the lips sheet's free map
   4.88 / 3.07 / 5.34% -> 3.11 / 2.45 / 2.28% flipped but 0.0763 / 0.1103 / 0.0788 ->
   0.0928 / 0.0990 / 0.0983 rad (its local mesh keeps genus 13-14, for 16: the handles spread
   the error over the whole sheet), the pleat 1.5 spacings wide free 0.0251 -> 0.0266 rad
   (0.33 -> 0.14%), face_human_choi free 0.0325 -> 0.0328 rad (2.46 -> 2.28%). With the bridges
   cut on the bare cloud as well (:mod:`pcgeom.maps.bridges`) the lips sheet's seeds 0 / 2
   map at 0.0511 / 0.0599 rad, 2.91 / 2.03% (genus 1 / 5), but the pleat at 0.0447. The same
   pair cost with ``|(n_i + s n_j) . d_ij| / h_i`` for the heights (``s`` the sign of
   ``n_i . n_j``: zero along any arc of one sheet; but two facing walls look like the two
   ends of an arc as wide as their gap) mapped worse (lips 0.0848 / 0.1081 / 0.1023 rad, the
   pleat 0.0357), a spectral orientation (the leading eigenvector of the signed neighbour
   graph) oriented face_human_choi worse (572 points wrong against 462).
"""

from __future__ import annotations

import numpy as np

from ..neighbours import Neighbours, local_pca

__all__ = ["arc_relation", "arc_signs", "estimate_normals", "orient_normals", "ARC"]

_CHUNK = 100_000
"""Points per block of the orientation graph's costs."""


def estimate_normals(X: np.ndarray, neighbours: int = 16) -> np.ndarray:
    """Unoriented PCA normals: the least-variance direction of each point's neighbourhood.

    Parameters
    ----------
    X : (N, 3) float64
        Distinct points.
    neighbours : int
        Neighbours per point, the point itself excluded.

    Returns
    -------
    (N, 3) float64
        Unit normals, sign arbitrary.
    """
    _, vectors = local_pca(X, neighbours)
    return np.ascontiguousarray(vectors[:, :, 0])


def orient_normals(X: np.ndarray, normals: np.ndarray, neighbours: int = 16, *,
                   knn: Neighbours | None = None) -> np.ndarray:
    """Flip normals to one consistent side by propagation over a minimum spanning tree.

    The largest connected part of the neighbour graph is oriented from its point of largest z,
    whose normal is made to point up (+z): for a scan seen from above, normals towards the
    scanner. Each smaller part (an island cut off by holes) then starts from its point
    nearest to the parts already oriented, made to agree with that neighbour.

    Parameters
    ----------
    X : (N, 3) float64
    normals : (N, 3) float64
        Unit normals of any sign.
    neighbours : int
        Neighbours per point in the graph.
    knn : Neighbours, optional
        The points' nearest points, when already found (at least ``neighbours`` each).

    Returns
    -------
    (N, 3) float64
        The same lines, with consistent signs.
    """
    import scipy.sparse as sp
    from scipy.sparse.csgraph import breadth_first_order, connected_components
    from scipy.sparse.csgraph import minimum_spanning_tree
    from scipy.spatial import cKDTree

    n = len(X)
    N = np.array(normals, dtype=np.float64)
    nb = (knn if knn is not None else Neighbours.of(X, neighbours)).first(neighbours)[1]
    k = nb.shape[1] - 1
    cost = np.empty((n, k))
    for s in range(0, n, _CHUNK):  # in blocks: (N, k, 3) temporaries are 0.4 GB each at 1M
        rows, js = np.arange(s, min(s + _CHUNK, n)), nb[s:s + _CHUNK, 1:]
        e = X[js] - X[rows, None]
        e /= np.linalg.norm(e, axis=-1, keepdims=True)
        ni, nj = N[rows, None], N[js]
        cost[rows] = (1.0 - np.abs((ni * nj).sum(axis=-1)) + np.abs((ni * e).sum(axis=-1))
                      + np.abs((nj * e).sum(axis=-1)))
    # Zero-cost edges would vanish from the sparse graph: shift every cost up a little. Each
    # stored entry is an undirected edge to the spanning tree (Kruskal's): no symmetrizing.
    G = sp.csr_matrix(((cost + 1e-9).ravel(), nb[:, 1:].ravel(), np.arange(0, n * k + 1, k)),
                      shape=(n, n))
    del cost
    tree = minimum_spanning_tree(G)
    del G
    tree = tree + tree.T
    n_parts, label = connected_components(tree, directed=False)
    oriented = np.zeros(n, dtype=bool)
    for part in np.argsort(-np.bincount(label)):  # the largest part first
        members = np.flatnonzero(label == part)
        if oriented.any():
            # A smaller part (an island cut off by a hole) agrees with the nearest oriented
            # point: each part's own top point would orient it at random relative to the rest.
            done = np.flatnonzero(oriented)
            dist, near = cKDTree(X[done]).query(X[members])
            seed = members[np.argmin(dist)]
            if N[seed] @ N[done[near[np.argmin(dist)]]] < 0:
                N[seed] = -N[seed]
        else:
            seed = members[np.argmax(X[members, 2])]
            if N[seed, 2] < 0:
                N[seed] = -N[seed]
        order, parent = breadth_first_order(tree, seed, directed=False)
        oriented[order] = True
        # In BFS order each parent is final before its children are visited.
        for v in order[1:]:
            if N[v] @ N[parent[v]] < 0:
                N[v] = -N[v]
    return N


ARC = 3.0
"""The weight of the chord's term in :func:`arc_relation`. Measured on the bare clouds' PCA
normals, oriented by :func:`orient_normals` and then re-signed by :func:`arc_signs` (points
the wrong way against the true normals): lips sheet 11k seeds 0-2 443 / 259 / 451 -> 261 /
248 / 322, face_human_choi 462 -> 383, the pleat 1.5 spacings wide 77 -> 35, the other
shared open surfaces 0 -> 0; at 2.5: 338 / 374 / 502, 374, 33; at 4: 234 / 225 / 199, 450,
34; at 6: 218 / 200 / 137, 728. Single-point majority flips after the eigenvector (5 rounds)
took face_human_choi from 383 to 465 (at 6: 728 -> 747)."""


def arc_relation(X: np.ndarray, N: np.ndarray, nb: np.ndarray, arc: float = ARC
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """How strongly each neighbour pair's normals agree as they are signed, on an arc of
    one sheet or across a thin gap:

    ``d_ij = n_i . n_j - arc * sign(a b) * min(|a|, |b|)``, ``a = n_i . e_ij``,
    ``b = n_j . e_ij``, clipped to [-1, 1] (``e_ij`` the unit chord).

    On an arc of one smooth sheet, consistently oriented normals lean to opposite sides of
    the chord (``a b < 0``; on a circle ``a = -b``), and across the gap between two sheets
    that nearly touch (the walls of a fold, facing or back to back) as well, while their
    dot product is -1: Hoppe's relation (``n_i . n_j``) orients the far wall the wrong way,
    this one the right way when ``arc > 1``. Points on one plane: ``a = b = 0``, Hoppe's.
    On the lips sheet's true normals (11k, 16 neighbours) 12691 of 177168 pairs read
    ``d < 0`` at ``arc`` 0 (Hoppe's), 2876 at 3.

    Parameters
    ----------
    X : (N, 3) float64
    N : (N, 3) float64
        Unit normals (their signs as they are).
    nb : (N, k + 1) int64
        Each point's nearest points, itself first.
    arc : float

    Returns
    -------
    i, j : (N k,) int64
        The pairs.
    d : (N k,) float64
    """
    n, k = nb.shape[0], nb.shape[1] - 1
    i, j = np.repeat(np.arange(n), k), nb[:, 1:].ravel()
    e = X[j] - X[i]
    e /= np.maximum(np.linalg.norm(e, axis=1, keepdims=True), 1e-300)
    a, b = np.einsum("md,md->m", N[i], e), np.einsum("md,md->m", N[j], e)
    d = np.einsum("md,md->m", N[i], N[j]) - arc * np.sign(a * b) * np.minimum(np.abs(a),
                                                                              np.abs(b))
    return i, j, np.clip(d, -1.0, 1.0)


def arc_signs(X: np.ndarray, N: np.ndarray, nb: np.ndarray, arc: float = ARC) -> np.ndarray:
    """Signs (+1 keep, -1 turn) that orient the normals ``N`` consistently by
    :func:`arc_relation` as a whole, not along a tree: the eigenvector of the smallest
    eigenvalue of the signed graph's Laplacian ``L = D - W`` (``W`` the pairs' ``d_ij``,
    symmetrized; ``D`` the sums of ``|W|``), the relaxation of maximizing
    ``sum_ij d_ij s_i s_j`` over ``s`` in {-1, 1}^N, started from ``N``'s own signs (LOBPCG,
    at most 500 iterations); the sign of most points kept.

    A spanning tree orients a patch from the one pair it hangs by, across a gap where that
    pair happens to be cheapest; the eigenvector weighs every pair round the patch.

    Parameters
    ----------
    X : (N, 3) float64
    N : (N, 3) float64
        Unit normals, oriented (:func:`orient_normals`).
    nb : (N, k + 1) int64
        Each point's nearest points, itself first.
    arc : float

    Returns
    -------
    (N,) float64
    """
    import warnings

    import scipy.sparse as sp
    from scipy.sparse.linalg import lobpcg

    n = len(X)
    if n < 8:
        return np.ones(n)
    i, j, d = arc_relation(X, N, nb, arc)
    W = sp.coo_matrix((d, (i, j)), shape=(n, n)).tocsr()
    W = (W + W.T) * 0.5
    L = sp.diags(np.asarray(abs(W).sum(axis=1)).ravel()) - W
    start = np.ones((n, 1)) + 0.01 * np.random.default_rng(0).standard_normal((n, 1))
    with warnings.catch_warnings():  # not converging to the tolerance is no error here
        warnings.simplefilter("ignore")
        v = lobpcg(L, start, largest=False, tol=1e-6, maxiter=500)[1][:, 0]
    sign = np.where(v < 0, -1.0, 1.0)
    return -sign if sign.sum() < 0 else sign
