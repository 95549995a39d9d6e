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

__all__ = ["estimate_normals", "orient_normals"]

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
