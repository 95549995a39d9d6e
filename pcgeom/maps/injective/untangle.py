"""Step 3: untangling (Garanzha, Kaporin, Kudryavtseva, Protais, Ray, Sokolov, "Foldover-free
maps in 50 lines of code", SIGGRAPH 2021)."""

from __future__ import annotations

import math
import time

import numpy as np

from ...config import UntangleConfig
from .energies import _chi, _untangle_energy, _untangle_hessian
from .jacobians import (_as_mesh, _det_cof, _jacobian_matrices, _jacobians, _scaled_reference,
                        _scatter, flipped, reference_triangles)
from .newton import _Assembly, _newton_minimize
from .rings import _Layout

__all__ = ["untangle"]


def _untangle(V: np.ndarray, F: np.ndarray, layout: _Layout, config: UntangleConfig,
              weights: np.ndarray | None = None) -> tuple[np.ndarray, dict]:
    """Step 3 on the variables of ``layout``."""
    from scipy.optimize import minimize

    t0 = time.perf_counter()
    n = len(V)
    W, _ = layout.unpack(layout.z0)
    area, G = _scaled_reference(V, F, W, weights)
    total = float(area.sum())
    start_flips = flipped(W, F)

    def fun(z, eps):
        W, frames = layout.unpack(z)
        value, dJ = _untangle_energy(_jacobians(W, F, G), area, eps, config.theta)
        return value / total, layout.pull(_scatter(dJ, F, G, n), frames) / total

    def min_det(z):
        return float(_det_cof(_jacobians(layout.unpack(z)[0], F, G))[0].min())

    assemble, B = _Assembly(F, n), _jacobian_matrices(G)

    def hessian(z, eps):
        W, frames = layout.unpack(z)
        H4 = _untangle_hessian(_jacobians(W, F, G), area, eps, config.theta) / total
        P = layout.matrix(frames)
        return (P.T @ assemble(H4, B) @ P).tocsr()

    z = layout.z0.copy()
    det_min = min_det(z)
    eps = math.sqrt(1e-12 + 0.04 * min(det_min, 0.0) ** 2)  # the paper's first eps
    energy = fun(z, eps)[0]
    iterations = evaluations = rounds = 0
    for rounds in range(1, config.rounds + 1):
        if not len(z):
            break
        if config.method == "newton":
            z, value, nit, nfev = _newton_minimize(fun, hessian, z, eps, config.newton_steps)
        else:
            res = minimize(fun, z, args=(eps,), jac=True, method="L-BFGS-B",
                           options={"maxiter": config.inner, "gtol": 1e-12, "ftol": 1e-13})
            z, value, nit, nfev = res.x, float(res.fun), int(res.nit), int(res.nfev)
        iterations += nit
        evaluations += nfev
        previous, energy = energy, value
        det_min = min_det(z)
        change = abs(previous - energy) / max(abs(energy), 1e-300)
        if det_min > 0 and (change < config.tolerance or config.stop_when_unfolded):
            break
        # The paper's schedule: chi(min det, eps_new) = (1 - sigma) chi(min det, eps).
        least = config.decrease
        sigma = max(1.0 - energy / previous, least) if previous > 0 else least
        mu = (1.0 - sigma) * float(_chi(np.array(det_min), eps)[0])
        eps = 2.0 * math.sqrt(mu * (mu - det_min)) if det_min < mu else 1e-10
    W, _ = layout.unpack(z)
    info = {"rounds": rounds, "iterations": iterations, "evaluations": evaluations,
            "eps": eps, "energy": energy, "min_det": det_min, "flipped": flipped(W, F),
            "flipped_start": start_flips, "seconds": time.perf_counter() - t0}
    return W, info


def untangle(V, F, U0, fixed, fixed_uv=None, *, weights=None,
             config: UntangleConfig = UntangleConfig()) -> tuple[np.ndarray, dict]:
    """Unfold a map with some vertices held (Garanzha et al. 2021; step 3 of the module).

    Minimizes ``E_eps(U) = sum_t w_t A_t [(1 - theta) tr(J_t^T J_t) + theta (det(J_t)^2 +
    1)] / chi(det J_t, eps)``, ``chi(D, eps) = (D + sqrt(eps^2 + D^2)) / 2``, over the
    vertices not held, for decreasing eps, until no triangle has ``det J <= 0``.

    Parameters
    ----------
    V : (n, 3) or (n, 2) float64
        The mesh; its triangles, laid flat, are the reference shapes.
    F : (m, 3) int64
        Triangles, counter-clockwise in the map sought.
    U0 : (n, 2) float64
        The start; may fold.
    fixed : (k,) int
        Vertices that do not move (the loops paired with a ring).
    fixed_uv : (k, 2) float64, optional
        Where they are held, in the order of ``fixed``; default ``U0[fixed]``.
    weights : (m,) float64, optional
        ``w_t``; default 1.
    config : UntangleConfig

    Returns
    -------
    U : (n, 2) float64
    info : dict
        ``rounds`` (values of eps), ``iterations`` (Newton steps or L-BFGS iterations, all
        rounds), ``evaluations``, ``eps`` (the last), ``energy`` (``E_eps`` per reference
        area, the last), ``min_det`` (smallest ``det J``, references scaled to the map's
        area), ``flipped`` (:func:`flipped` of ``U``: 0 on success), ``flipped_start``,
        ``seconds``.

    Raises
    ------
    ValueError
        Wrong shapes, indices out of range, a degenerate reference triangle, faces that run
        clockwise in the start.
    """
    V, F, U0 = _as_mesh(V, F, U0)
    n = len(V)
    reference_triangles(V, F)  # raises on a flat reference triangle
    fixed = np.asarray(fixed, dtype=np.int64).ravel()
    if len(fixed) and (fixed.min() < 0 or fixed.max() >= n):
        raise ValueError(f"fixed: indices must lie in [0, {n}), got [{fixed.min()}, "
                         f"{fixed.max()}]")
    U = U0.copy()
    if fixed_uv is not None:
        fixed_uv = np.asarray(fixed_uv, dtype=np.float64)
        if fixed_uv.shape != (len(fixed), 2):
            raise ValueError(f"fixed_uv: expected shape ({len(fixed)}, 2) (one row per "
                             f"fixed vertex), got {fixed_uv.shape}")
        U[fixed] = fixed_uv
    if weights is not None:
        weights = np.asarray(weights, dtype=np.float64)
        if weights.shape != (len(F),) or not (weights > 0).all():
            raise ValueError(f"weights: expected ({len(F)},) positive values, got shape "
                             f"{weights.shape}")
    used = np.zeros(n, dtype=bool)
    used[F.ravel()] = True
    used[fixed] = False
    return _untangle(V, F, _Layout(U, np.flatnonzero(used), None), config, weights)
