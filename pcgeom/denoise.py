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
   reads a few hundredths of a spacing (0.005-0.044 on the shared surfaces with 16
   neighbours; a coarse one more: three peaks on a 12 x 12 grid 0.155) and Gaussian noise of
   standard deviation ``s`` reads about ``s``. :func:`denoise_points` decides with 16
   neighbours and, when it fits, reports (and sizes the fits by) the estimate with 32, which
   under-reads strong noise less (measured 0.85-0.98 of the true std on a noisy plane and
   sphere cap, 0.82-1.00 on face_3holes_small_choi with depth noise of 0.25-1 mean edge
   lengths; 16 neighbours: 0.70-0.96). Strays (:func:`pcgeom.neighbours.find_outliers`) are left
   out, and each fit keeps its point's sheet: with oriented normals the neighbours whose
   normal agrees, without them those on the point's side of a jump in their offsets
   (:func:`pcgeom.neighbours.own_sheet`; a groove's facing wall read as noise before).
2. **Heights** (:func:`fit_heights`). Each point is moved along the normal of a weighted
   least-squares quadric (a jet of order 2, as in moving least squares) fitted to its
   ``neighbours`` nearest points with Gaussian weights ``exp(-d^2 / (2 rho^2))``,
   ``rho = max(width * h, d_12 / 2)`` (``d_12``: the distance to the 12th neighbour, so
   that a sparse part of the cloud keeps enough points in its fit), onto the fitted
   quadric. ``width`` grows with the noise (:class:`pcgeom.config.DenoiseConfig`). With
   oriented normals, each fit keeps the neighbours on its point's sheet.
3. **Directions** (:func:`denoise_points`). The input point is then moved onto the fitted
   surface along the PCA normal of the fitted points (16 neighbours). Any error in that
   direction shifts the point *along* the surface, which the map's angles feel as much as
   the noise: on face_3holes_small_choi with depth noise 0.5 (LSCM on the true connectivity
   of the moved points), the true normals would give 0.019 rad; the fitted points' PCA
   normals give 0.063, the fit's own gradient 0.063-0.070, the noisy points' PCA 0.065-0.078,
   larger neighbourhoods more, the noisy mesh's normals 0.142. This, not the fitted heights,
   is what limits a bare cloud. Even perfect landings (each noisy point moved exactly onto
   the true tangent plane) along the PCA normals of the 16 nearest *clean* points map at
   0.023 rad there and 0.093 on face_human_choi, whose uneven rows tilt PCA normals by 12
   degrees at their 90th percentile (the local mesh's vertex normals of the clean points:
   0.076); from the noisy points, directions plateau at 3.6-4.4 degrees median error (quadric
   and cubic fits 1.5-4 spacings wide, fitted or noisy points, averaged fields: 0.058-0.082
   rad on face_3holes_small_choi).

Measured and not kept (face_3holes_small_choi, depth noise 0.5, seeds 0 / 1 / 2; distance of
the denoised points to the clean mesh in noise std; today's fits: largest 1.11 / 1.46 / 1.33,
mean 0.229 / 0.231 / 0.228, on the rim 1.08 / 1.31 / 1.33). The largest errors inside sit where
the face curves most (curvature times spacing 0.80-0.86, its 99.9th percentile: the quadric's
bias), those on the rim are one-sided fits.

- Fixed widths 2 / 4 / 5 spacings: largest 1.73-2.15 / 1.18-1.49 / 1.22-1.53.
- A width per point (1-5 spacings, the widest whose height's confidence interval still meets
  the narrower ones', kappa 0.5-2): largest 1.16-2.19; it takes the widest at 81-99% of the
  points, since a fit 1-2 spacings wide is too noisy to show the wider one's bias.
- Each point projected on its 16 nearest neighbours' fits and blended (a partition of unity,
  weights Gaussian in distance times ``exp(-2 o^2)``, ``o`` a fit's centroid offset over its
  width): mean 0.214 / 0.216 / 0.213, rim 0.99 / 1.27 / 1.30, largest 1.08 / 1.47 / 1.30; the
  maps (judged on the clean mesh, seed 0) face_3holes_small_choi 0.0635 -> 0.0611 rad at depth
  0.5 and 0.0267 -> 0.0269 at 0.25, face_human_choi 0.2350 -> 0.2311 and 0.1183 -> 0.1022;
  with 32 neighbours' fits 0.0614, 0.0273, 0.2339, 0.1178: no consistent gain.
- Twicing (the fit applied again to the fitted points and its change taken back, ``2 S(X) -
  S(S(X))``, which cancels most of a fit's bias): largest 1.34 / 1.48 / 1.51 at width 3 (mean
  0.269), 1.29-1.56 at widths 4-6: the bias it removes comes back as noise.
- Wider fits that keep all their points (widths 3 / 4 / 5 over 200 / 300 / 400 neighbours
  instead of 96): largest 1.46-1.66 / 1.74-2.15 / 2.63-2.91, mean 0.23 / 0.26 / 0.34: the
  face's curvature. The fit's bias alone (today's fits applied to the clean points) reaches
  0.71 std at the sharpest points (99th percentile 0.38).
- A noisy plane sampled like it (a jittered grid of 5041 points, noise 0.5 spacings), so no
  curvature at all: largest 1.09 / 1.38 / 0.97 at width 3, every one on the rim (inside 0.78 /
  0.65 / 0.68), 0.93 / 0.99 / 0.71 at width 5. The rim's one-sided fits alone reach the
  noise's standard deviation: a largest distance below it (BENCHMARKS.md's reconstruction
  target) is out of reach of fits of this kind on a 5000-point scan.

pymeshlab's MLS projections (``compute_mls_projection_apss`` and ``_rimls``, pymeshlab
2025.7.post1) were to be measured against this: both crash the interpreter (segmentation
fault) on these clouds, with or without faces, with or without torch imported.

:func:`denoise_points` is the whole step as a run takes it (:class:`pcgeom.config.DenoiseConfig`
decides whether to apply it); it returns the moved points and a record of what it did.
"""

from __future__ import annotations

import time
from typing import NamedTuple

import numpy as np

from .config import DenoiseConfig
from .neighbours import (Neighbours, find_outliers, local_pca, own_sheet, quadric_basis,
                         surface_variation)

__all__ = ["NoiseEstimate", "estimate_noise", "fit_heights", "denoise_points"]

_CHUNK = 4096
"""Points whose fits are solved at once (memory: chunk x neighbours x 36 floats)."""

_MIN_FIT = 12
"""The Gaussian width of a fit is at least half the distance to this neighbour."""

FITTED_MAX_VARIATION = 0.05
"""Largest median surface variation (:func:`pcgeom.neighbours.surface_variation`, 16 neighbours)
of fitted points that sample one surface. Measured: noisy faces (depth noise 0.5 and 1 mean
edge lengths: 0.10-0.15 before the fit, above the local mesh's 0.15 for face_human_choi at
1) read 0.003-0.010 after it; a cube of uniform random points 0.18 before and 0.13 after."""


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


def estimate_noise(X, neighbours: int = 16, normals=None, *, knn: Neighbours | None = None
                   ) -> NoiseEstimate:
    """The spacing and the noise level of a cloud (step 1 of the module's description).

    Parameters
    ----------
    X : (N, 3) array_like
        Distinct points of one surface (strays removed: :func:`pcgeom.neighbours.find_outliers`).
    neighbours : int
        Points of each quadric fit, the point itself included.
    normals : (N, 3) array_like, optional
        Oriented normals: each fit keeps the neighbours whose normal agrees with its point's
        (``n_i . n_j > 0``), so that the other sheet of a fold does not read as noise.
        Without them, those on the point's side of a jump in the offsets along its normal
        (:func:`pcgeom.neighbours.own_sheet`).
    knn : Neighbours, optional
        The points' nearest points, when already found (at least ``neighbours - 1`` each).

    Returns
    -------
    NoiseEstimate
        ``std`` and ``spacing`` in the cloud's units; ``relative`` is their ratio.
    """
    X = np.asarray(X, dtype=np.float64)
    nb = (knn if knn is not None else Neighbours.of(X, neighbours - 1)).first(neighbours - 1)[1]
    rms = np.empty(len(X))
    gaps = np.empty(len(X))
    for s in range(0, len(X), _CHUNK):
        rows = nb[s:s + _CHUNK]
        P = X[rows]  # (n, k, 3)
        if normals is not None:
            w = (np.einsum("nd,nkd->nk", normals[s:s + _CHUNK], normals[rows]) > 0).astype(float)
        else:
            w = own_sheet(P).astype(float)
        centre = np.einsum("nk,nkd->nd", w, P) / w.sum(axis=1, keepdims=True)
        Q = P - centre[:, None]
        _, frame = np.linalg.eigh(np.einsum("nk,nki,nkj->nij", w, Q, Q))  # columns: n, t1, t2
        local = np.einsum("nkd,nde->nke", Q, frame)  # (n, k, 3)
        # The nearest neighbour (slot 1) measured in the tangent plane.
        gaps[s:s + _CHUNK] = np.linalg.norm(local[:, 1, 1:] - local[:, 0, 1:], axis=1)
        A = quadric_basis(local[..., 1], local[..., 2])  # (n, k, 6)
        AtA = np.einsum("nk,nki,nkj->nij", w, A, A) + 1e-12 * np.eye(6)
        Atz = np.einsum("nk,nki,nk->ni", w, A, local[..., 0])
        coef = np.linalg.solve(AtA, Atz[..., None])[..., 0]
        res = local[..., 0] - np.einsum("nki,ni->nk", A, coef)
        rms[s:s + _CHUNK] = np.sqrt((w * res**2).sum(axis=1)
                                    / np.maximum(w.sum(axis=1) - 6, 1))
    if normals is not None:
        ok = np.isfinite(rms)
        rms, gaps = rms[ok], gaps[ok]
    return NoiseEstimate(float(np.median(rms)), float(np.median(gaps)))


def fit_heights(X, width: float, spacing: float, neighbours: int = 96,
                normals=None, exclude=None) -> np.ndarray:
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
    normals : (N, 3) array_like, optional
        Oriented normals: a neighbour whose normal points the other way (``n_i . n_j <= 0``,
        the other sheet of a fold) gets weight 0 in the point's fit.
    exclude : (N,) bool, optional
        Points that no fit uses (strays); they still get their own fit from the others.

    Returns
    -------
    (N, 3) float64
        The points on their fitted quadrics.
    """
    from scipy.spatial import cKDTree

    X = np.asarray(X, dtype=np.float64)
    tree = cKDTree(X)
    k = min(neighbours, len(X))
    out = np.empty_like(X)
    for s in range(0, len(X), _CHUNK):
        x0 = X[s:s + _CHUNK]
        # Each block's neighbours queried with it: all of a million points' 96 at once held
        # 1.5 GB.
        dist, nb = tree.query(x0, k)
        dist, nb = dist.reshape(len(x0), k), nb.reshape(len(x0), k)
        rho = np.maximum(width * spacing, 0.5 * dist[:, min(_MIN_FIT, k - 1)])
        P = X[nb]  # (n, k, 3)
        w = np.exp(-dist ** 2 / (2 * rho[:, None] ** 2))  # (n, k)
        if exclude is not None:
            w = np.where(exclude[nb], 0.0, w)
        if normals is not None:
            same = np.einsum("nd,nkd->nk", normals[s:s + _CHUNK], normals[nb])
            # A point whose normal few neighbours share (a stray) is fitted from them all.
            alone = (np.where(same > 0, w, 0.0).sum(axis=1) < 3.0)[:, None]
            w = np.where((same > 0) | alone, w, 0.0)
        centre = np.einsum("nk,nkd->nd", w, P) / w.sum(axis=1, keepdims=True)
        Q = P - centre[:, None]
        _, frame = np.linalg.eigh(np.einsum("nk,nki,nkj->nij", w, Q, Q))  # columns: n, t1, t2
        local = np.einsum("nkd,nde->nke", Q, frame)  # (n, k, 3)
        own = np.einsum("nd,nde->ne", x0 - centre, frame)
        A = quadric_basis(local[..., 1], local[..., 2])  # (n, k, 6)
        AtA = np.einsum("nk,nki,nkj->nij", w, A, A) + 1e-12 * np.eye(A.shape[-1])
        Atz = np.einsum("nk,nki,nk->ni", w, A, local[..., 0])
        coef = np.linalg.solve(AtA, Atz[..., None])[..., 0]
        height = np.einsum("ni,ni->n", quadric_basis(own[:, 1], own[:, 2]), coef)
        out[s:s + _CHUNK] = x0 + (height - own[:, 0])[:, None] * frame[:, :, 0]
    return out


def denoise_points(X, config: DenoiseConfig = DenoiseConfig(mode="on"), normals=None,
                   *, estimate: NoiseEstimate | None = None, outlier: np.ndarray | None = None,
                   knn: Neighbours | None = None) -> tuple[np.ndarray, dict]:
    """The cloud moved onto its fitted surface, when ``config`` says so.

    Parameters
    ----------
    X : (N, 3) array_like
        Distinct points of one surface.
    config : DenoiseConfig
        ``mode`` ``"off"``: nothing (no estimate either); ``"auto"``: denoise when the
        estimated noise exceeds ``threshold`` spacings; ``"on"``: always.
    normals : (N, 3) array_like, optional
        Oriented unit normals, one per row: each fit keeps the neighbours on its point's
        sheet (:func:`fit_heights`). The points still move along the fitted points' normals:
        a scanner's normals are estimated from its noisy points (on face_3holes_small_choi
        with depth noise 0.5, moving along the noisy mesh's normals maps at 0.142 rad, along
        the fitted points' at 0.063).
    estimate : NoiseEstimate, optional
        The cloud's noise estimate, if already made.
    outlier : (N,) bool, optional
        The cloud's strays (:func:`pcgeom.neighbours.find_outliers`), if already found.
    knn : Neighbours, optional
        The points' nearest points (at least 16 each), if already found: the strays and the
        noise estimate read them.

    Returns
    -------
    Y : (N, 3) float64
        The points on the fitted surface (``X`` itself when not applied).
    record : dict
        ``stage`` ("denoise"), ``mode``, ``noise`` (the estimated std in spacings; None when
        off or not a surface), ``noise_std`` and ``spacing`` (the cloud's units),
        ``applied``, ``skipped`` (why not: ``"below the threshold"``, ``"not a surface"``),
        ``width`` (of the fits, in spacings), ``same_sheet`` (normals kept the fits on one
        sheet), ``strays`` (flagged by :func:`pcgeom.neighbours.find_outliers`, more than 5
        noise std off the fitted surface, left where they are), ``moved`` (mean distance moved,
        in spacings), ``seconds``.
    """
    t0 = time.perf_counter()
    X = np.asarray(X, dtype=np.float64)
    record = {"stage": "denoise", "mode": config.mode, "applied": False, "noise": None,
              "noise_std": None, "spacing": None, "width": config.width,
              "same_sheet": normals is not None, "strays": 0, "skipped": None, "moved": 0.0,
              "seconds": 0.0}
    if config.mode == "off":
        return X, record
    if normals is not None:
        normals = np.asarray(normals, dtype=np.float64)
    # Strays are neither fitted nor used in the fits: the map's own outlier test must still
    # find them where they are.
    outlier = find_outliers(X, knn=knn) if outlier is None else np.asarray(outlier, bool)
    inliers = np.flatnonzero(~outlier)
    Xi, Ni = X[inliers], None if normals is None else normals[inliers]
    if estimate is None:
        sub = knn.among(~outlier, X) if knn is not None else None
        estimate = estimate_noise(Xi, config.noise_neighbours, Ni, knn=sub)
        del sub
        again = True  # made here: a second look with larger fits when it is applied
    else:
        again = False
    est = estimate
    record.update(noise=est.relative, noise_std=est.std, spacing=est.spacing)
    if config.mode == "auto" and est.relative <= config.threshold:
        record.update(skipped="below the threshold", seconds=time.perf_counter() - t0)
        return X, record
    if again:
        # Small fits tell a coarsely sampled clean surface from a noisy one; fits twice as
        # large under-read strong noise less (the level reported and the fits' width).
        est = estimate_noise(Xi, 2 * config.noise_neighbours, Ni)
        record.update(noise=est.relative, noise_std=est.std, spacing=est.spacing)
    width = max(config.width, config.width_per_noise * est.relative)
    fitted = fit_heights(X, width, est.spacing, config.neighbours, normals, exclude=outlier)
    # The input's normals are as noisy as its points (a scanner estimates them from its own
    # mesh): the fitted points' normals are the better direction.
    values, vectors = local_pca(fitted[inliers], 16)
    if np.median(surface_variation(values)) > FITTED_MAX_VARIATION:
        # The fits do not agree on one surface: a volume of points, not a noisy surface.
        # The map's own surface test refuses the cloud as it is.
        record.update(skipped="not a surface", seconds=time.perf_counter() - t0)
        return X, record
    d = np.zeros_like(X)
    d[inliers] = vectors[:, :, 0]
    if len(inliers) < len(X):
        from scipy.spatial import cKDTree

        d[outlier] = d[inliers][cKDTree(fitted[inliers]).query(fitted[outlier])[1]]
    step = np.einsum("nd,nd->n", fitted - X, d)
    # A point the outlier test flagged is a tail of the noise if it lands within 5 std of
    # where it was (strays stay where they are, for the map's own outlier test).
    keep = outlier & (np.abs(step) > 5 * est.std)
    Y = X + np.where(keep, 0.0, step)[:, None] * d
    record["strays"] = int(keep.sum())
    moved = float(np.linalg.norm(Y - X, axis=1).mean() / est.spacing)
    record.update(applied=True, width=width, moved=moved, seconds=time.perf_counter() - t0)
    return Y, record
