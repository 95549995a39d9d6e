"""Lifting a mesh made in the map to 3D: each 2D vertex by barycentric interpolation over
triangles of the map (:func:`lift`), the triangles that boundary detection kept (the Delaunay
triangulation of f(X) without the triangles that span gaps) or the map's whole Delaunay
triangulation (:func:`map_delaunay`).

Vertices outside every kept triangle
------------------------------------
The meshed region is the polygon of the kept loops; the kept triangles cover it except in the
gaps whose loops were dropped as too small (``BoundaryLoops.dropped``) and, up to rounding,
on the boundary edges themselves. A vertex found in no kept triangle takes the point of the
kept triangles' boundary edges nearest to it in the map and is lifted linearly along that
edge (barycentric interpolation on its triangle, with the opposite vertex's weight 0). It is
a projection onto the nearest covered point, so a gap is bridged by the surface around it,
never extrapolated.

Strays are never lifted
-----------------------
A map places every row of the cloud, strays too (points the outlier test flagged, which no
fan of the local mesh uses: :func:`pcgeom.neighbours.find_outliers`, run by the denoise step
and by the local mesh). A stray's map point lies among its surface neighbours' but its 3D
point floats off the surface, so a triangle with it for a corner lifts a spike into the
mesh (measured: face_3holes_small_choi with depth noise of half a spacing and 1% strays,
the farthest vertex 16.9% of the diagonal off the true surface). So the mesh is lifted over
the inliers only (:func:`inlier_rows`): the points of the local mesh the map was made on
(``ParamResult.mesh_faces``), or, for a map without it, the points the outlier test keeps.

The rim of a denoised cloud
---------------------------
A denoised cloud's points are fitted to the surface from their neighbours
(:mod:`pcgeom.denoise`); a rim point has neighbours on one side only, so its fit is the least
certain, and a point of the noise's tail (or a stray within it) on the rim stays off the
surface. The mesh's boundary vertices are the loops' points themselves, lifted as they are.
So for a denoised cloud the loops' points are first smoothed along their loops, one
``(p_prev + 2 p + p_next) / 4`` step (:func:`smooth_rim`; ``reconstruct_surface(...,
smooth_rim=True)``, as ``pcgeom reconstruct`` does for a denoised map). Measured on
face_3holes_small_choi with depth noise of half a spacing and 1% strays (seeds 0-4, box and
near strays, and the depth noise alone, side by side with the mesh lifted as it was): the
farthest point of the mesh 0.0075-0.0094 of the diagonal, from 0.0072-0.0108 (the 0.0108: a
near stray within the noise's tail on the rim, its fit 1.0 mean edge off); the mean within
1% (BENCHMARKS.md, ``bench_apps_strays``).
"""

from __future__ import annotations

import numpy as np

from ...errors import InputError
from ...mesh import face_keys
from ..planar import delaunay, distinct_points, validate_map


def inlier_rows(points, mesh_faces=None) -> np.ndarray:
    """The rows of the cloud a mesh may be lifted over: the vertices of the map's local mesh
    (``ParamResult.mesh_faces``: the strays and the bits outside its main part are in no
    triangle), else the points :func:`pcgeom.neighbours.find_outliers` keeps. (K,) int64,
    ascending."""
    if mesh_faces is not None and len(mesh_faces):
        return np.unique(np.asarray(mesh_faces, dtype=np.int64))
    from ...neighbours import find_outliers

    return np.flatnonzero(~find_outliers(np.asarray(points, dtype=np.float64)))


def smooth_rim(points, loops) -> np.ndarray:
    """``points`` with each loop's points moved to ``(p_prev + 2 p + p_next) / 4`` of their
    loop (module docstring: the rim of a denoised cloud). (N, 3) float64, a copy.

    Parameters
    ----------
    points : (N, 3) array_like
    loops : list of (K,) array_like of int
        Closed loops, rows of ``points`` in order (``BoundaryLoops.loops``).
    """
    P = np.asarray(points, dtype=np.float64)
    out = P.copy()
    for loop in loops:
        loop = np.asarray(loop, dtype=np.int64)
        if len(loop) >= 3:
            out[loop] = 0.25 * (P[np.roll(loop, 1)] + 2.0 * P[loop] + P[np.roll(loop, -1)])
    return out


def lift(points, U, triangles, Q) -> tuple[np.ndarray, np.ndarray]:
    """Lift map points ``Q`` to 3D by barycentric interpolation over ``triangles``.

    Parameters
    ----------
    points : (N, 3) array_like
        The cloud.
    U : (N, 2) array_like
        Its map.
    triangles : (M, 3) array_like of int
        Triangles of the map (rows of ``U``) that do not overlap, e.g.
        ``BoundaryLoops.triangles``.
    Q : (K, 2) array_like
        Points to lift.

    Returns
    -------
    V : (K, 3) float64
        The lifted points.
    outside : (K,) bool
        Points in no triangle, lifted from the nearest point of the triangles' boundary
        edges (module docstring).
    """
    from scipy.spatial import cKDTree

    P = np.asarray(points, dtype=np.float64)
    U = np.asarray(U, dtype=np.float64)
    T = np.asarray(triangles, dtype=np.int64)
    Q = np.asarray(Q, dtype=np.float64)
    if P.ndim != 2 or P.shape[1] != 3 or U.shape != (len(P), 2):
        raise InputError(f"points, U: expected shapes (N, 3) and (N, 2), got {P.shape} and "
                         f"{U.shape}")
    if Q.ndim != 2 or Q.shape[1] != 2:
        raise InputError(f"Q: expected shape (K, 2), got {Q.shape}")
    if len(T) == 0:
        raise InputError("triangles: none; the reconstruction would be empty")
    found = _locate(U, T, Q)  # -1: outside
    V = np.empty((len(Q), 3))
    inside = found >= 0
    t = T[found[inside]]  # (k, 3)
    ab, ac, aq = (U[t[:, 1]] - U[t[:, 0]], U[t[:, 2]] - U[t[:, 0]],
                  Q[inside] - U[t[:, 0]])  # (k, 2) each
    det = ab[:, 0] * ac[:, 1] - ab[:, 1] * ac[:, 0]  # twice the signed area
    wb = (aq[:, 0] * ac[:, 1] - aq[:, 1] * ac[:, 0]) / det
    wc = (ab[:, 0] * aq[:, 1] - ab[:, 1] * aq[:, 0]) / det
    wa = 1.0 - wb - wc
    V[inside] = wa[:, None] * P[t[:, 0]] + wb[:, None] * P[t[:, 1]] + wc[:, None] * P[t[:, 2]]

    outside = ~inside
    if outside.any():
        # Boundary edges of the triangles: directed edges whose reverse is not an edge.
        half = np.stack([T, np.roll(T, -1, axis=1)], axis=2).reshape(-1, 2)
        K = int(T.max()) + 1
        key = half[:, 0] * K + half[:, 1]
        E = half[~np.isin(half[:, 1] * K + half[:, 0], key)]  # (E, 2)
        A, B = U[E[:, 0]], U[E[:, 1]]
        # Candidates: the edges with the nearest midpoints; an edge is never longer than
        # the span of the candidates' midpoints in practice, and 32 leaves a wide margin.
        k = min(32, len(E))
        _, cand = cKDTree(0.5 * (A + B)).query(Q[outside], k=k)
        cand = np.asarray(cand).reshape(-1, k)  # (o, k)
        q = Q[outside][:, None, :]  # (o, 1, 2)
        d = B[cand] - A[cand]  # (o, k, 2)
        s = np.clip(np.sum((q - A[cand]) * d, axis=2)
                    / np.maximum(np.sum(d * d, axis=2), np.finfo(float).tiny), 0.0, 1.0)
        dist = np.linalg.norm(A[cand] + s[..., None] * d - q, axis=2)  # (o, k)
        best = np.argmin(dist, axis=1)
        e = cand[np.arange(len(cand)), best]
        s = s[np.arange(len(cand)), best][:, None]
        V[outside] = (1.0 - s) * P[E[e, 0]] + s * P[E[e, 1]]
    return V, outside


def _locate(U: np.ndarray, T: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """For each point of ``Q`` the row of ``T`` whose triangle in the map ``U`` holds it, -1
    for none. (K,) int64

    matplotlib's trapezoid map finds them; it refuses some valid triangulations (measured: a
    map with two points a thousand map widths away, 'Triangulation is invalid'). Then, when
    every triangle is one of the map's Delaunay triangles (those of :func:`map_delaunay` and
    of boundary detection are), scipy's Delaunay point location finds them."""
    import matplotlib.tri as mtri

    used, local = np.unique(T, return_inverse=True)
    try:
        tri = mtri.Triangulation(U[used, 0], U[used, 1], local.reshape(-1, 3))
        return np.asarray(tri.get_trifinder()(Q[:, 0], Q[:, 1]), dtype=np.int64)
    except RuntimeError:
        pass
    from scipy.spatial import Delaunay

    unique, row = distinct_points(U)
    located = Delaunay(unique)
    ours, theirs = face_keys(T, len(U)), face_keys(row[located.simplices], len(U))
    order = np.argsort(ours)
    at = np.searchsorted(ours[order], theirs)
    hit = (at < len(ours)) & (ours[order][np.minimum(at, len(ours) - 1)] == theirs)
    if hit.sum() < len(np.unique(ours)):
        raise InputError("triangles: the map's points cannot be located in them (they are "
                         "not all triangles of the map's Delaunay triangulation, and "
                         "matplotlib refused them)")
    of_simplex = np.where(hit, order[np.minimum(at, len(ours) - 1)], -1)
    simplex = located.find_simplex(Q)
    return np.where(simplex >= 0, of_simplex[simplex], -1).astype(np.int64)


def map_delaunay(U) -> np.ndarray:
    """The Delaunay triangles of a map ``U`` (N, 2), as its rows (a duplicated map point by
    its first row), counter-clockwise. (M, 3) int64"""
    unique, row = distinct_points(validate_map(U))
    return row[delaunay(unique)]
