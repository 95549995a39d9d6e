"""Rows a map leaves off its triangles, moved with it: after a bend of a start map (the
landmarks' barrier map, their polish), the points off the local mesh's main part follow the
bend instead of being laid anew from the bent map.

A row whose start position lies in a triangle of the start map (counter-clockwise there) goes
where the bent map takes that point of the triangle, barycentrically:

    ``u_i = sum_q w_iq d_(t_q)``, ``s_i = sum_q w_iq s_(t_q)``, ``w_iq >= 0``,

the piecewise linear map from the start to the bent map (one-to-one where the bent map turns
no triangle over), so that two points on the same side of a line of the start stay on it. A
row outside every such triangle (beyond the rim, in a hole) takes its start plus the
inverse-distance mean of its nearest known rows' displacements ``d_j - s_j``
(:func:`pcgeom.maps.localmesh._interpolate_rest`). Interpolating the bent map itself (the
mean of the neighbours' positions) lays them anew: peaks_three_cgal, four landmarks 0.05 off
a disk automorphism's image (bench_landmarks' seed 0), put a true triangle's corner off the
main part across the triangle's opposite edge, 2 true triangles turned over; the mean
displacement alone did too (the corner's nearest rows include a landmark pulled 0.04).
"""

from __future__ import annotations

import numpy as np

from ..mesh import barycentric, signed_areas

__all__ = ["follow_rest", "CANDIDATES"]

CANDIDATES = 12
"""Triangles (of nearest centroids in the start map) searched for each row's start."""


def follow_rest(X: np.ndarray, U: np.ndarray, known: np.ndarray, start: np.ndarray,
                faces: np.ndarray) -> np.ndarray:
    """The rows of ``U`` not in ``known`` moved with the map from ``start`` (module doc).

    Parameters
    ----------
    X : (N, 3) float64
        The points (their nearest known rows place the rows in no triangle).
    U : (N, 2) float64
        The map; its ``known`` rows are read, the others written.
    known : (N,) bool
        Rows the map has.
    start : (N, 2) float64
        The map of every row before the move.
    faces : (m, 3) int64
        Triangles of known rows (rows of ``X``), the map's own; either orientation.

    Returns
    -------
    (N, 2) float64
        ``U`` with the other rows filled.
    """
    from scipy.spatial import cKDTree

    from .localmesh import _interpolate_rest

    U = np.array(U, dtype=np.float64, copy=True)
    rest = np.flatnonzero(~known)
    if not len(rest):
        return U
    move = np.where(known[:, None], U - start, np.nan)
    U[rest] = (start + _interpolate_rest(X, move, known))[rest]
    faces = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    if not len(faces):
        return U
    if signed_areas(start, faces).sum() < 0:
        faces = faces[:, ::-1]
    # Triangles counter-clockwise in both maps: the piecewise linear map between them.
    both = (signed_areas(start, faces) > 0) & (signed_areas(U, faces) > 0)
    faces = faces[both]
    if not len(faces):
        return U
    c = min(CANDIDATES, len(faces))
    _, T = cKDTree(start[faces].mean(axis=1)).query(start[rest], c)
    T = T.reshape(len(rest), c)
    W = barycentric(start, faces, start[rest], T)  # (r, c, 3)
    worst = W.min(axis=2)
    best = np.argmax(worst, axis=1)
    rows = np.arange(len(rest))
    inside = worst[rows, best] >= -1e-9
    w = np.clip(W[rows, best], 0.0, 1.0)[inside]
    t = faces[T[rows, best]][inside]  # (r', 3)
    U[rest[inside]] = np.einsum("rq,rqd->rd", w / w.sum(axis=1, keepdims=True), U[t])
    return U
