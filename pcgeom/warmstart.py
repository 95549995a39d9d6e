"""Meshless warm start for the networks: landmark Isomap of the cloud (not in the paper).

Training sine networks from a random initialization spends most of its
budget untangling a random map, and on a curved surface such as a face a short
budget leaves folds that no later step removes. An Isomap embedding (geodesic
distances on the k-nearest-neighbour graph, then classical MDS) of an open,
disk-like surface is an unfolded, roughly isometric map; the networks are
first regressed onto it and then trained on LEG as usual.
"""

from __future__ import annotations

import numpy as np

__all__ = ["isomap_embedding", "farthest_point_sample"]


def farthest_point_sample(D_first: np.ndarray, dist_fn, m: int) -> np.ndarray:
    """Greedy farthest-point sampling of ``m`` indices.

    ``D_first`` holds distances from the first chosen index to every point;
    ``dist_fn(k)`` returns the distances from index ``k`` to every point.
    """
    chosen = [int(np.argmax(D_first))]
    dmin = dist_fn(chosen[0])
    rows = [dmin]
    for _ in range(m - 1):
        k = int(np.argmax(dmin))
        chosen.append(k)
        row = dist_fn(k)
        rows.append(row)
        dmin = np.minimum(dmin, row)
    return np.array(chosen), np.vstack(rows)


def isomap_embedding(
    X: np.ndarray, n_neighbors: int = 10, n_landmarks: int = 256
) -> np.ndarray:
    """A 2D landmark-Isomap embedding of a point cloud.

    Geodesic distances are shortest paths on the symmetric k-nearest-neighbour
    graph, from ``n_landmarks`` landmarks chosen by farthest-point sampling;
    the landmarks are placed by classical MDS and every other point by
    distance-based triangulation (de Silva and Tenenbaum, 2004).

    Parameters
    ----------
    X : (N, 3) float
        Distinct points.
    n_neighbors : int
        Graph degree; raised automatically until the graph is connected.
    n_landmarks : int

    Returns
    -------
    (N, 2) float64, centred, in the units of ``X``.

    Raises
    ------
    ValueError
        When the neighbour graph stays disconnected (the cloud has pieces far
        apart), naming the number of components.
    """
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import connected_components, dijkstra
    from scipy.spatial import cKDTree

    X = np.asarray(X, dtype=np.float64)
    n = len(X)
    tree = cKDTree(X)
    k = min(n_neighbors, n - 1)
    while True:
        dist, nb = tree.query(X, k + 1)
        rows = np.repeat(np.arange(n), k)
        G = csr_matrix((dist[:, 1:].ravel(), (rows, nb[:, 1:].ravel())), shape=(n, n))
        G = G.maximum(G.T)
        n_comp, _ = connected_components(G, directed=False)
        if n_comp == 1:
            break
        if k >= min(4 * n_neighbors, n - 1):
            raise ValueError(
                f"the point cloud falls apart into {n_comp} pieces (no path between them through "
                f"{k} nearest neighbours); parametrize each piece separately"
            )
        k = min(2 * k, n - 1)

    m = min(n_landmarks, n)

    def geodesic_from(idx: int) -> np.ndarray:
        return dijkstra(G, directed=False, indices=idx)

    start = geodesic_from(0)
    landmarks, D = farthest_point_sample(start, geodesic_from, m)  # D: (m, N)
    D2 = D**2
    DL2 = D2[:, landmarks]  # (m, m)
    J = np.eye(m) - 1.0 / m
    Bm = -0.5 * J @ DL2 @ J
    w, v = np.linalg.eigh(Bm)
    top = np.argsort(w)[::-1][:2]
    w, v = np.clip(w[top], 1e-12, None), v[:, top]
    # Triangulation: y = -1/2 L# (delta - mean delta), L# rows = v_k / sqrt(w_k).
    pinv = (v / np.sqrt(w)).T  # (2, m)
    Y = -0.5 * pinv @ (D2 - DL2.mean(axis=1, keepdims=True))  # (2, N)
    Y = Y.T
    return Y - Y.mean(axis=0)
