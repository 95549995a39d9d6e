"""The feasible step: the largest step along a direction before a triangle's area reaches
zero (Smith and Schaefer 2015), and moving vertices where that folds nothing."""

from __future__ import annotations

import numpy as np

from ...mesh import signed_areas
from .jacobians import _not_positive

__all__ = ["max_feasible_step"]


def max_feasible_step(U, F, D) -> float:
    """The largest ``a`` such that no triangle's signed area reaches zero on ``U + s D``,
    ``0 <= s < a`` (Smith and Schaefer 2015, section 4).

    For a triangle, ``2 area(U + a D) = c + b a + q a^2`` with ``c = (u_1 - u_0) x (u_2 -
    u_0)``, ``b = (u_1 - u_0) x (d_2 - d_0) + (d_1 - d_0) x (u_2 - u_0)``, ``q = (d_1 - d_0) x
    (d_2 - d_0)``; the answer is the smallest positive root over all triangles (``inf`` if
    none). The triangles are assumed positive at ``a = 0``.

    Parameters
    ----------
    U : (n, 2) float64
        A map with every triangle positive.
    F : (m, 3) int64
    D : (n, 2) float64
        The direction.

    Returns
    -------
    float
    """
    U, D = np.asarray(U, dtype=np.float64), np.asarray(D, dtype=np.float64)
    u1, u2 = U[F[:, 1]] - U[F[:, 0]], U[F[:, 2]] - U[F[:, 0]]
    d1, d2 = D[F[:, 1]] - D[F[:, 0]], D[F[:, 2]] - D[F[:, 0]]

    def cross(a, b):
        return a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]

    c = cross(u1, u2)
    b = cross(u1, d2) + cross(d1, u2)
    q = cross(d1, d2)
    roots = np.full(len(F), np.inf)
    # Nearly linear: q a^2 negligible against b a over the scale of the root -c/b.
    small = np.abs(q) * c <= 1e-12 * b ** 2
    lin = small & (b < 0)
    roots[lin] = -c[lin] / b[lin]
    quad = ~small
    disc = b[quad] ** 2 - 4 * q[quad] * c[quad]
    ok = disc >= 0
    sq = np.sqrt(np.where(ok, disc, 0.0))
    # Stable roots: r1 = (-b - sign(b) sq) / 2q, r2 = c / (q r1) = 2c / (-b - sign(b) sq).
    s = np.where(b[quad] >= 0, 1.0, -1.0)
    t = -0.5 * (b[quad] + s * sq)
    with np.errstate(divide="ignore", invalid="ignore"):
        r1 = np.where(ok, t / q[quad], np.inf)
        r2 = np.where(ok & (t != 0), c[quad] / t, np.inf)
    r1 = np.where(r1 > 0, r1, np.inf)
    r2 = np.where(r2 > 0, r2, np.inf)
    roots[quad] = np.minimum(r1, r2)
    return float(roots.min())


def _snap(F: np.ndarray, U: np.ndarray, index: np.ndarray, targets: np.ndarray
          ) -> np.ndarray:
    """Move the vertices ``index`` onto ``targets`` where that folds nothing: all at once
    when the straight path is clear (:func:`max_feasible_step` > 1), else without the
    vertices of the triangles that would fold, until it is. Returns the mask of ``index``
    that moved (``U`` is updated)."""
    moved = np.ones(len(index), dtype=bool)
    for _ in range(len(index) + 1):
        D = np.zeros_like(U)
        D[index[moved]] = targets[moved] - U[index[moved]]
        after = U + D
        # Flat counts as folded: three loop vertices laid on a straight side of a ring make
        # a triangle of zero area up to rounding, which no barrier can start from.
        bad = np.flatnonzero(_not_positive(after, F))
        if not len(bad) and max_feasible_step(U, F, D) > 1.0 - 1e-6:
            U[index[moved]] = targets[moved]
            return moved
        if not len(bad):  # the path crosses zero and comes back: take the worst triangles
            mid = U + 0.5 * D
            bad = np.flatnonzero(signed_areas(mid, F) <= 0)
        stuck = np.isin(index, F[bad].ravel())
        if not (stuck & moved).any():
            break
        moved &= ~stuck
    return np.zeros(len(index), dtype=bool)
