"""The energies of steps 3 and 4 per triangle, their gradients and projected Hessians in
``vec J`` (the barrier energies ``"mips"``, ``"root_mips"``, ``"symmetric_dirichlet"``; the
untangling energy of Garanzha et al.), and :func:`conformal_energy`."""

from __future__ import annotations

import math

import numpy as np

from ...config import ENERGIES
from .jacobians import _as_mesh, _det_cof, _jacobians, reference_triangles

__all__ = ["conformal_energy"]


_ROOT_DELTA = 0.05
"""``delta`` of ``"root_mips"``: smooth where the map is a similarity (``K = 2``)."""


def conformal_energy(V, F, U, energy: str = "mips", *, power: float = 0.5,
                     blend: float = 0.0) -> float:
    """A barrier energy of the map ``U`` per unit reference area, ``sum_t A_t e(J_t) /
    sum_t A_t`` (see the module).

    ``"mips"``: ``e = s1/s2 + s2/s1``, 2 exactly for a similarity (the minimum);
    ``"root_mips"``: ``e = (s1/s2 + s2/s1 - 2 + delta^2)^p + b (s1/s2 + s2/s1 - 2)``;
    ``"symmetric_dirichlet"``: ``e = s1^2 + s2^2 + s1^-2 + s2^-2``, 4 for an isometry.
    ``inf`` when a triangle is folded or flat.

    Parameters
    ----------
    V : (n, 3) or (n, 2) float64
        The mesh (the reference shapes).
    F : (m, 3) int64
    U : (n, 2) float64
        The map.
    energy : str
        One of :data:`ENERGIES`.
    power, blend : float
        ``p`` and ``b`` of ``"root_mips"``.

    Returns
    -------
    float
    """
    _check_energy(energy)
    V, F, U = _as_mesh(V, F, U)
    area, G = reference_triangles(V, F)
    value, _ = _barrier(_jacobians(U, F, G), area, energy, power, blend)
    return value / float(area.sum())


def _check_energy(energy: str) -> None:
    if energy not in ENERGIES:
        raise ValueError(f"energy: expected one of {', '.join(map(repr, ENERGIES))}, "
                         f"got {energy!r}")


def _barrier(J: np.ndarray, area: np.ndarray, energy: str, power: float = 0.5,
             blend: float = 0.0) -> tuple[float, np.ndarray]:
    """A barrier energy (see the module) and its gradient w.r.t. the Jacobians; ``inf``
    when a triangle has ``det J <= 0``."""
    det, cof = _det_cof(J)
    if (det <= 0).any():
        return math.inf, np.zeros_like(J)
    tr = (J ** 2).sum(axis=(1, 2))
    if energy in ("mips", "root_mips"):
        e = tr / det
        dJ = (2.0 / det)[:, None, None] * J - (tr / det ** 2)[:, None, None] * cof
        if energy == "root_mips":
            q = np.maximum(e - 2.0, 0.0) + _ROOT_DELTA ** 2
            e, dJ = (q ** power + blend * (e - 2.0),
                     (power * q ** (power - 1.0) + blend)[:, None, None] * dJ)
    else:  # symmetric Dirichlet: tr(J^T J) (1 + 1 / det^2), as tr(J^-T J^-1) = tr / det^2
        inv2 = 1.0 / det ** 2
        e = tr * (1.0 + inv2)
        dJ = (2.0 * (1.0 + inv2))[:, None, None] * J - (2.0 * tr * inv2 / det)[:, None, None] * cof
    return float(area @ e), area[:, None, None] * dJ


_K = np.array([[0.0, 0.0, 0.0, 1.0], [0.0, 0.0, -1.0, 0.0], [0.0, -1.0, 0.0, 0.0],
               [1.0, 0.0, 0.0, 0.0]])
"""The Hessian of ``det J`` in ``vec J = (J00, J01, J10, J11)``."""


def _project_psd(H: np.ndarray) -> np.ndarray:
    """Each symmetric ``H[t]`` with its negative eigenvalues set to zero (projected Newton,
    Teran et al. 2005)."""
    bad = ~np.isfinite(H).all(axis=(1, 2))
    if bad.any():  # overflow where a triangle is (nearly) flat: its curvature is unknown
        H = H.copy()
        H[bad] = 0.0
    w, Q = np.linalg.eigh(H)
    return (Q * np.maximum(w, 0.0)[:, None, :]) @ np.swapaxes(Q, 1, 2)


def _barrier_hessian(J: np.ndarray, area: np.ndarray, energy: str, power: float = 0.5,
                     blend: float = 0.0) -> np.ndarray:
    """The area-weighted, PSD-projected Hessian of the barrier energy in ``vec J``,
    (m, 4, 4); ``j = vec J``, ``c = vec cof J``, ``K`` the Hessian of ``det``:

    - MIPS ``tr / det``: ``2 I / det - 2 (j c^T + c j^T) / det^2 + 2 tr c c^T / det^3
      - tr K / det^2``;
    - symmetric Dirichlet ``tr (1 + det^-2)``: ``2 (1 + det^-2) I - 4 (j c^T + c j^T) /
      det^3 + 6 tr c c^T / det^4 - 2 tr K / det^3``.
    """
    det, cof = _det_cof(J)
    j = J.reshape(-1, 4)
    c = cof.reshape(-1, 4)
    tr = (j ** 2).sum(axis=1)
    jc = j[:, :, None] * c[:, None, :]
    sym = jc + np.swapaxes(jc, 1, 2)
    cc = c[:, :, None] * c[:, None, :]
    eye = np.eye(4)[None]
    if energy in ("mips", "root_mips"):
        H = ((2.0 / det)[:, None, None] * eye - (2.0 / det ** 2)[:, None, None] * sym
             + (2.0 * tr / det ** 3)[:, None, None] * cc - (tr / det ** 2)[:, None, None] * _K)
        if energy == "root_mips":
            g = (2.0 / det)[:, None] * j - (tr / det ** 2)[:, None] * c
            q = np.maximum(tr / det - 2.0, 0.0) + _ROOT_DELTA ** 2
            H = ((power * q ** (power - 1.0) + blend)[:, None, None] * H
                 + (power * (power - 1.0) * q ** (power - 2.0))[:, None, None]
                 * (g[:, :, None] * g[:, None, :]))
    else:
        H = ((2.0 * (1.0 + det ** -2))[:, None, None] * eye
             - (4.0 / det ** 3)[:, None, None] * sym
             + (6.0 * tr / det ** 4)[:, None, None] * cc
             - (2.0 * tr / det ** 3)[:, None, None] * _K)
    return area[:, None, None] * _project_psd(H)


def _chi(D: np.ndarray, eps: float) -> tuple[np.ndarray, np.ndarray]:
    """``chi(D, eps) = (D + sqrt(eps^2 + D^2)) / 2`` and its derivative in ``D``."""
    r = np.sqrt(eps * eps + D * D)
    return 0.5 * (D + r), 0.5 * (1.0 + D / r)


def _untangle_energy(J: np.ndarray, area: np.ndarray, eps: float, theta: float
                     ) -> tuple[float, np.ndarray]:
    """Garanzha et al.'s ``E_eps`` (see the module) and its gradient w.r.t. the Jacobians."""
    det, cof = _det_cof(J)
    tr = (J ** 2).sum(axis=(1, 2))
    chi, dchi = _chi(det, eps)
    if (chi <= 0).any():  # eps^2 / 4|D| underflows where D << -eps: a trial step too far
        return math.inf, np.zeros_like(J)
    num = (1.0 - theta) * tr + theta * (det * det + 1.0)
    e = num / chi
    # d e / dJ = [(1 - theta) 2 J + theta 2 det cof] / chi - num dchi cof / chi^2
    dJ = ((2.0 * (1.0 - theta)) / chi)[:, None, None] * J + (
        (2.0 * theta * det) / chi - num * dchi / chi ** 2)[:, None, None] * cof
    return float(area @ e), area[:, None, None] * dJ


def _untangle_hessian(J: np.ndarray, area: np.ndarray, eps: float, theta: float
                      ) -> np.ndarray:
    """The area-weighted, PSD-projected Hessian of Garanzha et al.'s ``E_eps`` in ``vec J``,
    (m, 4, 4): ``f = N / chi`` with ``N = (1 - theta) tr + theta (det^2 + 1)``,
    ``H = H_N / chi - (g_N g_chi^T + g_chi g_N^T) / chi^2 - N H_chi / chi^2
    + 2 N g_chi g_chi^T / chi^3``."""
    det, cof = _det_cof(J)
    j = J.reshape(-1, 4)
    c = cof.reshape(-1, 4)
    tr = (j ** 2).sum(axis=1)
    chi, dchi = _chi(det, eps)
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        # chi ~ eps^2 / 4|D| underflows for folded triangles when eps is small: their
        # Hessians overflow and are dropped by the projection.
        return area[:, None, None] * _project_psd(
            _untangle_hessian_raw(j, c, det, tr, chi=chi, dchi=dchi, eps=eps, theta=theta))


def _untangle_hessian_raw(j, c, det, tr, *, chi, dchi, eps, theta) -> np.ndarray:
    """:func:`_untangle_hessian` before the projection and the areas."""
    d2chi = 0.5 * eps * eps / (eps * eps + det * det) ** 1.5
    N = (1.0 - theta) * tr + theta * (det * det + 1.0)
    gN = 2.0 * (1.0 - theta) * j + (2.0 * theta * det)[:, None] * c
    cc = c[:, :, None] * c[:, None, :]
    HN = 2.0 * (1.0 - theta) * np.eye(4)[None] + 2.0 * theta * (
        cc + det[:, None, None] * _K)
    gchi = dchi[:, None] * c
    Hchi = d2chi[:, None, None] * cc + dchi[:, None, None] * _K
    cross = gN[:, :, None] * gchi[:, None, :]
    H = (HN / chi[:, None, None] - (cross + np.swapaxes(cross, 1, 2)) / (chi ** 2)[:, None, None]
         - (N / chi ** 2)[:, None, None] * Hchi
         + (2.0 * N / chi ** 3)[:, None, None] * gchi[:, :, None] * gchi[:, None, :])
    return H
