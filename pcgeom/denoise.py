"""Denoised geometry for the map: the noise level of a cloud, and its points moved onto a
surface fitted to them (not in the paper).

Range scanners add noise mostly along the line of sight. A map of the noisy points treats
every bump as geometry: with depth noise of half a mean edge length, the free map of
face_3holes_small_choi, judged on the clean mesh, is as bad as LSCM on the noisy mesh
(DESIGN.md, "What limits real scans"). Here the surface is fitted first and the map is made of
the fitted points; each input point keeps its row, so the map is still reported per input
point.

1. **Spacing and noise level** (:func:`estimate_noise`). The spacing ``h`` is the median over
   points of the distance to the nearest neighbour measured in the tangent plane (the
   neighbourhood's PCA frame), so noise across the surface does not inflate it. The noise
   level is the median over points of the residual RMS of the least-squares quadric
   ``z = a + b x + c y + d x^2 + e x y + f y^2`` fitted to each point's ``k`` nearest
   neighbours in their PCA frame, corrected for the six fitted coefficients
   (``sqrt(k / (k - 6))``). A quadric follows a smooth surface's curvature, so a clean scan
   reads a few hundredths of a spacing and Gaussian noise of standard deviation ``s``
   reads about ``s`` (measured: within 5% from 0.25 to 1 spacing).
2. **Heights** (:func:`fit_heights`). Each point is moved along the normal of a weighted
   least-squares quadric (a jet of order 2, as in moving least squares) fitted to its
   ``neighbours`` nearest points with Gaussian weights ``exp(-d^2 / (2 rho^2))``,
   ``rho = max(width * h, d_12 / 2)`` (``d_12``: the distance to the 12th neighbour, so
   that a sparse part of the cloud keeps enough points in its fit), onto the fitted
   quadric.
3. **Directions** (:func:`denoise_points`). The fitted heights are only half of it: the
   input point is moved onto the fitted surface along a direction, and any error in that
   direction shifts the point *along* the surface, which distorts the map's angles as much as
   the noise did (measured on face_3holes_small_choi with depth noise 0.5: heights fitted as
   above and the true normals 0.019 rad; the fit's own normals 0.063 rad). With the input's
   oriented normals (a scanner's) the point moves along its normal; without, along the PCA
   normal of the fitted points (16 neighbours), which measured best among the fit's gradient,
   PCA of the noisy points and larger neighbourhoods.

:func:`denoise_points` is the whole step as a run takes it (:class:`pcgeom.config.DenoiseConfig`
decides whether to apply it); it returns the moved points and a record of what it did.
"""

from __future__ import annotations

import time
from typing import NamedTuple

import numpy as np

from .cloud import local_pca
from .config import DenoiseConfig

__all__ = ["NoiseEstimate", "estimate_noise", "fit_heights", "denoise_points"]

_CHUNK = 4096
"""Points whose fits are solved at once (memory: chunk x neighbours x 36 floats)."""

_MIN_FIT = 12
"""The Gaussian width of a fit is at least half the distance to this neighbour."""


class NoiseEstimate(NamedTuple):
    """The noise level of a cloud, in its own units and in spacings."""

    std: float
    """Estimated standard deviation of the noise across the surface (the cloud's units)."""
    spacing: float
    """Median nearest-neighbour distance in the tangent plane (the cloud's units)."""

    @property
    def relative(self) -> float:
        """``std / spacing``: the noise in mean spacings."""
        return self.std / self.spacing if self.spacing > 0 else 0.0


def _quadric_basis(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """``[1, x, y, x^2, x y, y^2]`` along a new last axis."""
    return np.stack([np.ones_like(x), x, y, x * x, x * y, y * y], axis=-1)


def _neighbours(X: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """Distances and indices of each point's ``k`` nearest points, itself first."""
    from scipy.spatial import cKDTree

    return cKDTree(X).query(X, min(k, len(X)))


def estimate_noise(X, neighbours: int = 32) -> NoiseEstimate:
    """The spacing and the noise level of a cloud (step 1 of the module's description).

    Parameters
    ----------
    X : (N, 3) array_like
        Distinct points of one surface.
    neighbours : int
        Points of each quadric fit, the point itself included.

    Returns
    -------
    NoiseEstimate
        ``std`` and ``spacing`` in the cloud's units; ``relative`` is their ratio.
    """
    X = np.asarray(X, dtype=np.float64)
    _, nb = _neighbours(X, neighbours)
    k = nb.shape[1]
    rms = np.empty(len(X))
    gaps = np.empty(len(X))
    for s in range(0, len(X), _CHUNK):
        P = X[nb[s:s + _CHUNK]]  # (n, k, 3)
        Q = P - P.mean(axis=1, keepdims=True)
        _, frame = np.linalg.eigh(np.einsum("nki,nkj->nij", Q, Q))  # columns: normal, t1, t2
        local = np.einsum("nkd,nde->nke", Q, frame)  # (n, k, 3)
        # The nearest neighbour (slot 1) measured in the tangent plane.
        gaps[s:s + _CHUNK] = np.linalg.norm(local[:, 1, 1:] - local[:, 0, 1:], axis=1)
        A = _quadric_basis(local[..., 1], local[..., 2])  # (n, k, 6)
        AtA = np.einsum("nki,nkj->nij", A, A) + 1e-12 * np.eye(6)
        coef = np.linalg.solve(AtA, np.einsum("nki,nk->ni", A, local[..., 0])[..., None])[..., 0]
        res = local[..., 0] - np.einsum("nki,ni->nk", A, coef)
        rms[s:s + _CHUNK] = np.sqrt((res**2).sum(axis=1) / max(k - 6, 1))
    return NoiseEstimate(float(np.median(rms)), float(np.median(gaps)))


def fit_heights(X, width: float, spacing: float, neighbours: int = 96):
    """Each point moved along the normal of its weighted quadric fit onto that quadric
    (step 2 of the module's description).

    Parameters
    ----------
    X : (N, 3) array_like
        Distinct points.
    width : float
        Gaussian width of the fits' weights in spacings (``rho = max(width * spacing,
        d_12 / 2)``).
    spacing : float
        The cloud's spacing (:func:`estimate_noise`).
    neighbours : int
        Points each fit may use, the point itself included.

    Returns
    -------
    (N, 3) float64
        The points on their fitted quadrics.
    """
    X = np.asarray(X, dtype=np.float64)
    dist, nb = _neighbours(X, neighbours)
    rho = np.maximum(width * spacing, 0.5 * dist[:, min(_MIN_FIT, nb.shape[1] - 1)])
    out = np.empty_like(X)
    for s in range(0, len(X), _CHUNK):
        x0 = X[s:s + _CHUNK]
        P = X[nb[s:s + _CHUNK]]  # (n, k, 3)
        w = np.exp(-dist[s:s + _CHUNK] ** 2 / (2 * rho[s:s + _CHUNK, None] ** 2))  # (n, k)
        centre = np.einsum("nk,nkd->nd", w, P) / w.sum(axis=1, keepdims=True)
        Q = P - centre[:, None]
        _, frame = np.linalg.eigh(np.einsum("nk,nki,nkj->nij", w, Q, Q))
        local = np.einsum("nkd,nde->nke", Q, frame)
        own = np.einsum("nd,nde->ne", x0 - centre, frame)
        A = _quadric_basis(local[..., 1], local[..., 2])
        AtA = np.einsum("nk,nki,nkj->nij", w, A, A) + 1e-12 * np.eye(6)
        Atz = np.einsum("nk,nki,nk->ni", w, A, local[..., 0])
        coef = np.linalg.solve(AtA, Atz[..., None])[..., 0]
        height = np.einsum("ni,ni->n", _quadric_basis(own[:, 1], own[:, 2]), coef)
        out[s:s + _CHUNK] = x0 + (height - own[:, 0])[:, None] * frame[:, :, 0]
    return out


def denoise_points(X, config: DenoiseConfig = DenoiseConfig(mode="on"), normals=None,
                   *, estimate: NoiseEstimate | None = None) -> tuple[np.ndarray, dict]:
    """The cloud moved onto its fitted surface, when ``config`` says so.

    Parameters
    ----------
    X : (N, 3) array_like
        Distinct points of one surface.
    config : DenoiseConfig
        ``mode`` ``"off"``: nothing (no estimate either); ``"auto"``: denoise when the
        estimated noise exceeds ``threshold`` spacings; ``"on"``: always.
    normals : (N, 3) array_like, optional
        Oriented (or not) unit normals, one per row: the direction each point moves along.
        Without them, the PCA normals of the fitted points.
    estimate : NoiseEstimate, optional
        The cloud's noise estimate, if already made.

    Returns
    -------
    Y : (N, 3) float64
        The points on the fitted surface (``X`` itself when not applied).
    record : dict
        ``noise`` (estimated std in spacings; None when off), ``noise_std`` and ``spacing``
        (the cloud's units), ``applied``, ``mode``, ``width``, ``directions`` (``"input
        normals"`` or ``"fitted"``), ``moved`` (mean distance moved, in spacings), ``seconds``.
    """
    t0 = time.perf_counter()
    X = np.asarray(X, dtype=np.float64)
    record = {"stage": "denoise", "mode": config.mode, "applied": False, "noise": None,
              "noise_std": None, "spacing": None, "width": config.width, "directions": None,
              "moved": 0.0, "seconds": 0.0}
    if config.mode == "off":
        return X, record
    est = estimate if estimate is not None else estimate_noise(X, config.noise_neighbours)
    record.update(noise=est.relative, noise_std=est.std, spacing=est.spacing)
    if config.mode == "auto" and est.relative <= config.threshold:
        record["seconds"] = time.perf_counter() - t0
        return X, record
    fitted = fit_heights(X, config.width, est.spacing, config.neighbours)
    if normals is not None:
        d, record["directions"] = np.asarray(normals, dtype=np.float64), "input normals"
    else:
        d, record["directions"] = local_pca(fitted, 16)[1][:, :, 0], "fitted"
    Y = X + np.einsum("nd,nd->n", fitted - X, d)[:, None] * d
    record.update(applied=True, moved=float(np.linalg.norm(Y - X, axis=1).mean() / est.spacing),
                  seconds=time.perf_counter() - t0)
    return Y, record
