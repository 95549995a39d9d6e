"""The solvers' linear algebra: the sparse Hessian's assembly, projected Newton steps and
L-BFGS directions."""

from __future__ import annotations

import math

import numpy as np



class _Assembly:
    """Sums the triangles' ``6 x 6`` Hessians into the sparse ``(2n, 2n)`` Hessian in the
    vertex coordinates ``(u_0x, u_0y, u_1x, ...)``; the sparsity pattern is built once."""

    def __init__(self, F: np.ndarray, n: int):
        idx = (2 * F[:, :, None] + np.arange(2)[None, None, :]).reshape(-1, 6)  # (m, 6)
        rows = np.broadcast_to(idx[:, :, None], (len(F), 6, 6)).ravel()
        cols = np.broadcast_to(idx[:, None, :], (len(F), 6, 6)).ravel()
        unique, self.slot = np.unique(rows * (2 * n) + cols, return_inverse=True)
        self.slot = self.slot.ravel()
        self.rows, self.cols = unique // (2 * n), unique % (2 * n)
        self.shape = (2 * n, 2 * n)

    def __call__(self, H4: np.ndarray, B: np.ndarray):
        """``sum_t B_t^T H_t B_t`` for the Hessians ``H4`` in ``vec J`` (m, 4, 4) and
        ``B_t = d vec J_t / du`` (:func:`_jacobian_matrices`)."""
        import scipy.sparse as sp

        H6 = np.swapaxes(B, 1, 2) @ H4 @ B  # (m, 6, 6)
        data = np.bincount(self.slot, H6.ravel(), minlength=len(self.rows))
        return sp.csr_matrix((data, (self.rows, self.cols)), shape=self.shape)


def _newton_factor(H, cache=None):
    """The solve of the sparse PSD ``H`` (the variables' Hessian), shifted by a tiny multiple
    of its mean diagonal where the projection left it singular. ``cache``: a
    :class:`pcgeom.maps._sparse.SymbolicCache` reused across steps (the Hessians of one
    optimization share their pattern); the solve is then valid until its next use."""
    import scipy.sparse as sp

    from .._sparse import spd_factor

    shift = 1e-9 * max(float(H.diagonal().mean()), 1e-300)
    return spd_factor((H + shift * sp.identity(H.shape[0], format="csr")).tocsc(), cache=cache)


def _newton_step(H, g: np.ndarray, cache=None) -> np.ndarray:
    """``-H^-1 g`` (:func:`_newton_factor`)."""
    return -_newton_factor(H, cache)(g)


def _newton_minimize(fun, hessian, z: np.ndarray, eps: float, steps: int
                     ) -> tuple[np.ndarray, float, int, int]:
    """Projected Newton on the smooth ``fun(z, eps)`` (value, gradient), Armijo
    backtracking; stops when a step lowers the value by less than 1e-9 of it. Returns ``z``,
    the value, the steps and the evaluations."""
    from .._sparse import SymbolicCache

    E, g = fun(z, eps)
    evaluations, it = 1, 0
    cache = SymbolicCache()
    for it in range(1, steps + 1):
        d = _newton_step(hessian(z, eps), g, cache)
        slope = float(g @ d)
        if slope >= 0:
            d, slope = -g, -float(g @ g)
        a = 1.0
        for _ in range(40):
            E_new, g_new = fun(z + a * d, eps)
            evaluations += 1
            if math.isfinite(E_new) and E_new <= E + 1e-4 * a * slope:
                break
            a *= 0.5
        else:
            break
        z, drop = z + a * d, E - E_new
        E, g = E_new, g_new
        if drop < 1e-9 * abs(E):
            break
    return z, E, it, evaluations


def _lbfgs_direction(g: np.ndarray, S: list, Y: list) -> np.ndarray:
    """``-H g`` by the L-BFGS two-loop recursion (Nocedal and Wright, Algorithm 7.4)."""
    q = g.copy()
    alphas = []
    for s, y in reversed(list(zip(S, Y))):
        rho = 1.0 / (y @ s)
        a = rho * (s @ q)
        alphas.append((rho, a))
        q -= a * y
    if S:
        q *= (S[-1] @ Y[-1]) / (Y[-1] @ Y[-1])
    for (s, y), (rho, a) in zip(zip(S, Y), reversed(alphas)):
        q += s * (a - rho * (y @ q))
    return -q
