"""The smallest conformal bend of a disk map that moves its landmarks onto their targets: one
linear solve.

After the disk automorphism of :mod:`pcgeom.maps.moebius`, what the landmarks still ask for is
a deformation that no conformal map makes. This one is of least conformal energy (libigl's
LSCM form, ``E(u) = 1/2 u^T (-L (+) -L) u - u^T A u``: the squared anti-conformal part
``|d u / d conj(z)|^2`` integrated over the surface's triangles, zero exactly for a conformal
map oriented as the triangles) of the offset from the disk map, plus ``w`` times the squared
distances of the landmark points to their targets, with the rim sliding along the unit circle (to
first order: each rim vertex
moves along the circle's tangent, then back onto the circle along its radius). The map is
linear in the landmarks' offsets, so a small offset gives a small bend spread over the whole
surface, and no triangle turns over unless the offsets are large against the mesh's spacing;
:func:`pcgeom.maps.domain.landmarks_onto` checks that and hands a bend that folds to the
barrier map.
"""

from __future__ import annotations

import numpy as np

__all__ = ["conformal_bend", "spread_pairs", "BEND_WEIGHT", "SPREAD"]

BEND_WEIGHT = 1e3
"""Weight of the landmark term against the conformal energy, times the mean diagonal entry of
the energy's matrix (the cotangent weights are dimensionless, the distances in the disk's
units): the landmarks are met to about a thousandth of their offsets."""


SPREAD = 2.0
"""A landmark's offset ``d`` also pulls the points within ``SPREAD |d|`` of it (in the disk) by
the same offset, with weights ``(1 - (r / R)^2)^2``: a bend pinned at single points is
singular there (the energy of moving one point by ``d`` grows only as ``|d|^2 / log(R / h)``
as the spacing ``h`` shrinks, all of it next to the point) and folds its neighbours once
``|d|`` passes a few spacings; a neighbourhood moved as one is a translation, conformal, and
the bend is spread around it. face_3holes_small_choi, four landmarks 0.05 off their conformal
image: point pins 16 folds, spread 0."""


def spread_pairs(Z: np.ndarray, index: np.ndarray, targets: np.ndarray, *,
                 spread: float = SPREAD) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The landmark pairs ``index -> targets`` of the map ``Z`` (n, 2) widened as
    :data:`SPREAD` says: ``(index, targets, weights)`` of every point each pair pulls."""
    from scipy.spatial import cKDTree

    index = np.asarray(index, dtype=np.int64)
    offset = targets - Z[index]
    reach = spread * np.linalg.norm(offset, axis=1)
    tree = cKDTree(Z)
    out_i, out_t, out_w = [index], [targets], [np.ones(len(index))]
    for k in np.flatnonzero(reach > 0):
        near = np.asarray(tree.query_ball_point(Z[index[k]], reach[k]), dtype=np.int64)
        near = near[near != index[k]]
        if len(near):
            r2 = ((Z[near] - Z[index[k]]) ** 2).sum(axis=1) / reach[k] ** 2
            out_i.append(near)
            out_t.append(Z[near] + offset[k])
            out_w.append((1.0 - np.minimum(r2, 1.0)) ** 2)
    return np.concatenate(out_i), np.vstack(out_t), np.concatenate(out_w)


def conformal_bend(V: np.ndarray, F: np.ndarray, Z: np.ndarray, rim: np.ndarray,
                   index: np.ndarray, targets: np.ndarray, *,
                   weight: float = BEND_WEIGHT, pair_weights: np.ndarray | None = None,
                   rounds: int = 0, floor: float = 0.01) -> np.ndarray:
    """The map ``Z`` of the mesh ``(V, F)`` onto the unit disk, bent as the module says.

    Parameters
    ----------
    V : (n, 3) float64
    F : (m, 3) int64
    Z : (n, 2) float64
        The disk map; the ``rim`` vertices on the unit circle.
    rim : (k,) int
        Vertices that slide on the circle.
    index : (p,) int
        Landmark vertices (one may appear in several pairs).
    targets : (p, 2) float64
        Their targets in the disk.
    weight : float
        :data:`BEND_WEIGHT`.
    pair_weights : (p,) float64, optional
        Each pair's share of ``weight`` (1 each by default).

    Returns
    -------
    (n, 2) float64
        The bent map, the rim vertices on the circle.
    """
    import igl
    import scipy.sparse as sp

    from ..mesh import signed_areas
    from .free import _anticonformal, _weighted_form

    n = len(V)
    if float(signed_areas(Z, F).sum()) < 0:  # the energy wants the triangles counter-clockwise
        F = F[:, ::-1]
    F = np.ascontiguousarray(F, dtype=np.int64)
    V = np.ascontiguousarray(V, dtype=np.float64)
    U = Z
    for r in range(rounds + 1):
        if r == 0:
            L = igl.cotmatrix(V, F)
            Q = sp.csr_matrix(-0.5 * sp.block_diag([L, L]) - igl.vector_area_matrix(F))
            Q = 0.5 * (Q + Q.T)
        else:
            # Reweighted (an L1 norm of the distortion, not its square): the bend spreads
            # from where it gathered.
            a = _anticonformal(V, F, U[:, 0], U[:, 1])
            Q = _form_matrix(_weighted_form(V, F, 1.0 / (np.maximum(a, 0) + floor)), n)
        U = _solve(Q, Z, rim, index, targets, weight=weight, pair_weights=pair_weights)
    return U


def _form_matrix(form: tuple, n: int):
    """:func:`pcgeom.maps.free._weighted_form` as a sparse (2n, 2n) matrix (as
    :func:`pcgeom.maps.free._apply_form` applies it)."""
    import scipy.sparse as sp

    lo, hi, C, S, D = form
    rows = np.concatenate([np.arange(n), n + np.arange(n), lo, hi, n + lo, n + hi,
                           lo, n + hi, hi, n + lo])
    cols = np.concatenate([np.arange(n), n + np.arange(n), hi, lo, n + hi, n + lo,
                           n + hi, lo, n + lo, hi])
    vals = np.concatenate([D, D, -C, -C, -C, -C, -S, -S, S, S])
    return sp.csr_matrix((vals, (rows, cols)), shape=(2 * n, 2 * n))


def _solve(Q, Z, rim, index, targets, *, weight, pair_weights) -> np.ndarray:
    import scipy.sparse as sp

    from ._sparse import spd_factor
    from .polish import _rim_basis

    n = len(Z)
    # The offset d = c + P s: interior vertices keep both unknowns, a rim vertex one (along
    # the circle's tangent). Of the offset, not of the map: the disk map is conformal only
    # up to its discretization, and the least-energy map of this mesh differs from it (the
    # rim alone, left to slide, moves by 0.2); a zero offset bends nothing.
    rim = np.unique(np.asarray(rim, dtype=np.int64))
    P = _rim_basis(Z, rim)
    index = np.asarray(index, dtype=np.int64)
    w = weight * float(Q.diagonal().mean())
    pw = np.ones(len(index)) if pair_weights is None else np.asarray(pair_weights, float)
    root = np.sqrt(np.concatenate([pw, pw]))
    S = sp.csr_matrix((root, (np.arange(2 * len(index)), np.concatenate([index, n + index]))),
                      shape=(2 * len(index), 2 * n))
    d = targets - Z[index]
    t = root * np.concatenate([d[:, 0], d[:, 1]])
    A = Q + w * (S.T @ S)
    s = spd_factor((P.T @ A @ P).tocsc())(P.T @ (w * (S.T @ t)))
    u = P @ s
    U = Z + np.column_stack([u[:n], u[n:]])
    U[rim] /= np.linalg.norm(U[rim], axis=1, keepdims=True)
    return U
