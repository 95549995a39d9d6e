"""A chart's scale-factor spread brought within a bound without a seam: a local/global map whose
triangles each aim at their own similarity with its scale clamped into a band.

A conformal map of a disk cut from a surface of high genus shrinks some parts far more than
others (a genus-4 pretzel cut along its shortest cut graph: LSCM's spread, the 95th over the
5th percentile of the per-triangle scale factor ``sqrt(uv area / 3D area)``, 20-30), although
the angles it keeps would allow an even texel density if a little of them were given up.
:func:`bound_scale` gives them up where that pays, by the local/global iteration of Liu et al.
("A local/global approach to mesh parameterization", SGP 2008) with a scale-clamped target:

1. **Local.** Each triangle's Jacobian ``J_t`` (from its 3D triangle laid flat to its image)
   has the nearest rotation ``R_t`` and the scale ``s_t = sqrt(det J_t)``; its target is
   ``L_t = clip(s_t, m / sqrt(T), m sqrt(T)) R_t``, ``m`` the geometric mean of the current 5th
   and 95th percentiles of ``s`` and ``T`` the band (:data:`BAND` times the bound). A triangle
   inside the band aims at its own similarity (no angle is lost); only the most shrunk and
   the most stretched are asked to change size.
2. **Global.** ``min_U sum_t A_t |J_t(U) - L_t|^2``: one Poisson system (the cotangent
   Laplacian, one vertex held), factored once (:func:`pcgeom.maps._sparse.spd_factor`), solved
   for the two coordinates every round.

The map may turn a few triangles over (where the chart's boundary pinches): they are unfolded
locally (:func:`pcgeom.maps.injective.untangle` on the triangles within :data:`RINGS` rings of
them, the rest held). The caller keeps the result only when it is within the bound and costs
little in angle (:data:`ANGLE_COST`): on a long limb, whose conformal factor falls
exponentially along it, a slit to its tip is the better answer.

Measured on the genus-4 pretzel (5k points, its one-chart cut along the short cut graph):
spread 26.3 -> 8.0 in 30 rounds (1 s), mean ``|log(s1/s2)|`` 0.0541 -> 0.0548.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ..mesh import signed_areas

__all__ = ["bound_scale", "conformal_distortion", "BAND", "ROUNDS", "RINGS", "ANGLE_COST"]

BAND = 0.8
"""The band of target scale factors spans this fraction of the bound (room for the
percentiles to settle a little outside it)."""

ROUNDS = 30
"""Local/global rounds (the spread settles within 2% of the band in about 20-30)."""

RINGS = 3
"""Rings of triangles around a folded one freed to unfold it."""

ANGLE_COST = 1.2
"""A bounded map is kept when its mean conformal distortion (:func:`conformal_distortion`) is
at most this many times the conformal map's (issue 38 allows 1.5x libigl's LSCM on the same
seams)."""


def _frames(P: np.ndarray, F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per triangle, the inverse of its edge matrix laid flat (2, 2), and its area."""
    e1 = P[F[:, 1]] - P[F[:, 0]]
    e2 = P[F[:, 2]] - P[F[:, 0]]
    nrm = np.cross(e1, e2)
    area = 0.5 * np.linalg.norm(nrm, axis=1)
    x = e1 / np.maximum(np.linalg.norm(e1, axis=1), 1e-300)[:, None]
    y = np.cross(nrm / np.maximum(2.0 * area, 1e-300)[:, None], x)
    D = np.stack([np.c_[(e1 * x).sum(1), (e1 * y).sum(1)],
                  np.c_[(e2 * x).sum(1), (e2 * y).sum(1)]], axis=2)
    return np.linalg.inv(D), area


def _jacobians(U: np.ndarray, F: np.ndarray, Dinv: np.ndarray) -> np.ndarray:
    Ds = np.stack([U[F[:, 1]] - U[F[:, 0]], U[F[:, 2]] - U[F[:, 0]]], axis=2)
    return Ds @ Dinv


def conformal_distortion(P: np.ndarray, U: np.ndarray, F: np.ndarray) -> float:
    """The area-weighted mean of ``|log(s1 / s2)|`` over the triangles of the map ``U`` of
    ``(P, F)`` (``s1 >= s2`` the singular values of each Jacobian): 0 for a conformal map."""
    Dinv, area = _frames(P, F)
    s = np.linalg.svd(_jacobians(U, F, Dinv), compute_uv=False)
    d = np.abs(np.log(np.maximum(s[:, 0], 1e-300) / np.maximum(s[:, 1], 1e-300)))
    return float((d * area).sum() / max(float(area.sum()), 1e-300))


def _gradient(F: np.ndarray, Dinv: np.ndarray, n: int) -> sp.csr_matrix:
    """(2m, n): row ``2t + k`` gives the ``k``-th component of the gradient of a function
    on triangle ``t`` (its 2D frame)."""
    m = len(F)
    rows, cols, vals = [], [], []
    for k in range(2):
        r = 2 * np.arange(m) + k
        c1, c2 = Dinv[:, 0, k], Dinv[:, 1, k]
        rows += [r, r, r]
        cols += [F[:, 0], F[:, 1], F[:, 2]]
        vals += [-(c1 + c2), c1, c2]
    return sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                         shape=(2 * m, n))


def _unfold(P: np.ndarray, F: np.ndarray, U: np.ndarray) -> np.ndarray:
    """``U`` with its folded triangles unfolded by :func:`untangle` on the triangles within
    :data:`RINGS` rings of them, the vertices around held."""
    from .injective import untangle

    bad = signed_areas(U, F) <= 0
    if not bad.any():
        return U
    free = np.zeros(len(P), dtype=bool)
    free[F[bad].ravel()] = True
    for _ in range(RINGS):
        free[F[free[F].any(axis=1)].ravel()] = True
    rows = np.flatnonzero(free[F].any(axis=1))
    used, Fs = np.unique(F[rows], return_inverse=True)
    Fs = Fs.reshape(-1, 3)
    held = np.flatnonzero(~free[used])
    W, _ = untangle(P[used], Fs, U[used], held)
    out = U.copy()
    out[used] = W
    return out


def bound_scale(P: np.ndarray, F: np.ndarray, U0: np.ndarray, bound: float, *,
                rounds: int = ROUNDS) -> np.ndarray:
    """The map ``U0`` of the disk ``(P, F)`` moved towards a scale-factor spread within
    ``BAND * bound`` (steps 1-2 of the module), folds unfolded locally; the caller checks the
    result (flips, spread, angle, boundary)."""
    from ._sparse import spd_factor

    Dinv, area = _frames(P, F)
    n = len(P)
    G = _gradient(F, Dinv, n)
    W = sp.diags(np.repeat(area, 2))
    GtW = (G.T @ W).tocsr()
    L = (GtW @ G).tocsc()
    solve = spd_factor(L[1:, 1:])
    link = L[1:, 0].toarray().ravel()
    half = np.sqrt(BAND * float(bound))
    U = np.asarray(U0, dtype=np.float64).copy()
    for _ in range(rounds):
        J = _jacobians(U, F, Dinv)
        A, S, Bt = np.linalg.svd(J)
        turn = np.linalg.det(A @ Bt) < 0
        A[turn, :, 1] *= -1.0  # the nearest rotation, never a mirror
        R = A @ Bt
        s = np.sqrt(S[:, 0] * S[:, 1])
        lo, hi = np.percentile(s, [5, 95])
        mid = np.sqrt(lo * hi)
        T = np.clip(s, mid / half, mid * half)[:, None, None] * R
        b = GtW @ np.column_stack([T[:, 0, :].ravel(), T[:, 1, :].ravel()])
        U[1:] = solve(b[1:] - np.outer(link, U[0]))
    return _unfold(P, F, U)
