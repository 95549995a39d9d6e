"""Disk automorphisms fitted to landmark pairs: the conformal maps a disk map can still become.

Every conformal map of a surface onto the unit disk is one of them composed with any other:
``z -> e^(i t) (z - c) / (1 - conj(c) z)`` with ``|c| < 1`` (and the mirror ``z -> conj(z)``
first, since estimated normals have no preferred side). So when landmark targets are where a
conformal map puts the landmark points, one of these maps takes the cloud's disk map there
exactly, with no distortion added; when they are not, the nearest one leaves the smallest
bend for the barrier map (:func:`pcgeom.maps.injective.injective_map`) to make.

:func:`fit_moebius` fits one to pairs ``z_k -> w_k`` by least squares (scipy's
``least_squares``, from several starts, both mirrors). :func:`fit_landmarks` pairs the
landmark points with their targets as the barrier map's landmark term does
(:mod:`pcgeom.maps.injective.landmarks`: curves by arc length, other point sets nearest-first
both ways, one point with its one target), fits, and pairs again from the fitted map until the
pairs stop changing (point sets of unequal size: iterated closest pairs).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["Moebius", "fit_moebius", "fit_landmarks", "RIDGE"]

RIDGE = 1e-4
"""Weight of ``|b|^2`` (``c = tanh|b| b / |b|``) beside the squared residuals, per pair: with
one or two landmark pairs the automorphism is not determined, and the one nearest the
balanced disk map (``c = 0``) is taken."""

_STARTS = (0j, 0.6, 0.6j, -0.6, -0.6j)
"""Starting values of ``b`` for each mirror (the best rotation for each)."""


@dataclass(frozen=True)
class Moebius:
    """``z -> e^(i theta) (z' - c) / (1 - conj(c) z')``, ``z' = conj(z)`` when ``mirror``."""

    theta: float = 0.0
    c: complex = 0j
    mirror: bool = False

    def __call__(self, z: np.ndarray) -> np.ndarray:
        z = np.conj(z) if self.mirror else np.asarray(z)
        return np.exp(1j * self.theta) * (z - self.c) / (1.0 - np.conj(self.c) * z)

    def to_dict(self) -> dict:
        return {"rotation_deg": round(math.degrees(self.theta), 3), "mirror": bool(self.mirror),
                "automorphism": [round(self.c.real, 6), round(self.c.imag, 6)]}


def _c_of(b: complex) -> complex:
    """``|c| = tanh|b| < 1``: any ``b`` is an automorphism."""
    r = abs(b)
    return b * (math.tanh(r) / r) if r > 1e-12 else b


def _b_of(c: complex) -> complex:
    r = min(abs(c), 1 - 1e-9)
    return c * (math.atanh(r) / r) if r > 1e-12 else c


def fit_moebius(z, w, *, start: Moebius | None = None, mirrors=(False, True),
                ridge: float = RIDGE) -> tuple[Moebius, float]:
    """The disk automorphism ``M`` of least ``sum_k |M(z_k) - w_k|^2 + ridge n |b|^2``.

    Parameters
    ----------
    z, w : (n,) complex
        Points in the unit disk and where they should go.
    start : Moebius, optional
        Tried first (with its mirror only, when ``mirrors`` is left as is), beside the
        :data:`_STARTS`.
    mirrors : tuple of bool
        The mirrors tried.

    Returns
    -------
    M : Moebius
    rms : float
        ``sqrt(mean |M(z_k) - w_k|^2)``.
    """
    from scipy.optimize import least_squares

    z = np.asarray(z, dtype=np.complex128).ravel()
    w = np.asarray(w, dtype=np.complex128).ravel()
    lam = math.sqrt(ridge * len(z))
    best = None
    for mirror in mirrors:
        zm = np.conj(z) if mirror else z

        def residual(x: np.ndarray, zm=zm) -> np.ndarray:
            c = _c_of(complex(x[1], x[2]))
            r = np.exp(1j * x[0]) * (zm - c) / (1.0 - np.conj(c) * zm) - w
            return np.concatenate([r.real, r.imag, [lam * x[1], lam * x[2]]])

        starts = []
        if start is not None and start.mirror == mirror:
            b = _b_of(start.c)
            starts.append((start.theta, b))
        for b in _STARTS:
            c = _c_of(complex(b))
            m = (zm - c) / (1.0 - np.conj(c) * zm)
            starts.append((float(np.angle(np.vdot(m, w))) if np.any(m) else 0.0, complex(b)))
        for theta, b in starts:
            found = least_squares(residual, np.array([theta, b.real, b.imag]), method="lm",
                                  xtol=1e-12, ftol=1e-12, max_nfev=400)
            cost = float(found.cost)
            if best is None or cost < best[0]:
                x = found.x
                best = (cost, Moebius(float(np.angle(np.exp(1j * x[0]))),
                                      _c_of(complex(x[1], x[2])), mirror))
    M = best[1]
    rms = float(np.sqrt(np.mean(np.abs(M(z) - w) ** 2))) if len(z) else 0.0
    return M, rms


def fit_landmarks(X: np.ndarray, z0: np.ndarray, marks, to_disk, from_disk, *,
                  start: Moebius = Moebius(), rounds: int = 10) -> tuple[Moebius, dict]:
    """The disk automorphism that takes the landmark points' disk images nearest their targets.

    Parameters
    ----------
    X : (N, 3) float64
        The points (their 3D spacing orders landmark points along target curves).
    z0 : (N,) complex
        The disk map.
    marks : sequence of ((n_k,) int, (m_k, 2) float64)
        Rows of each landmark set and its targets in the domain.
    to_disk : callable
        Domain points (m, 2) to the disk, (m,) complex (the domain's Riemann map).
    from_disk : callable
        Disk points (m,) complex to the domain, (m, 2) (its inverse).
    start : Moebius
        The first map, from which the first pairs are drawn (both mirrors are fitted).
    rounds : int
        At most this many rounds of pairing and fitting.

    Returns
    -------
    M : Moebius
    info : dict
        ``rounds`` run, ``rms`` of the last fit in the disk.
    """
    from .injective.landmarks import _landmark_pairs

    rows = np.unique(np.concatenate([np.asarray(i, dtype=np.int64) for i, _ in marks]))
    U = np.zeros((len(z0), 2))

    def pairs(M: Moebius):
        U[rows] = from_disk(M(z0[rows]))
        index, q, _ = _landmark_pairs(X, U, marks, 1.0)
        return index, q

    def cost(M: Moebius, index, q) -> float:
        return float(np.sum((from_disk(M(z0[index])) - q) ** 2))

    M, index, q = start, *pairs(start)
    best, rms, done = None, 0.0, 0
    for done in range(1, rounds + 1):
        M, rms = fit_moebius(z0[index], to_disk(q), start=M)
        new_index, new_q = pairs(M)
        # Judged on the new pairs, in the domain: a round that does not lower it ends.
        c = cost(M, new_index, new_q)
        if best is not None and c >= best[0] * (1 - 1e-9):
            break
        best = (c, M)
        if np.array_equal(new_index, index) and np.allclose(new_q, q, atol=1e-12):
            break
        index, q = new_index, new_q
    return best[1], {"rounds": done, "rms": round(rms, 8)}
