"""Where a denoised cloud's points go on the sphere: each at the map's image of its input
point's place along the fitted surface (:func:`place_input`).

The denoiser (:mod:`pcgeom.denoise`) moves every point onto its fitted surface along the
normal of its 16 nearest fitted points, estimated to a few degrees. A point moved by ``h``
along a direction ``a`` degrees off the surface's normal also slides ``h sin a`` along the
surface, and two close points that slide differently pass each other: a thin triangle of
the true surface is turned over before any map is made (on a bumpy sphere of 5000 points
with noise of 0.25 spacings along the normals, 10 of the 11 true triangles the map turned
over were turned over by the fitted points in 3D already).

The sphere map is made of the fitted points as before (their local mesh, its cotangent
weights, the flow); then each mapped point ``i`` is moved on the sphere by the map's
differential at ``i`` applied to ``t_i``, the part of ``x_i - y_i`` (input point minus fitted
point) along the surface, the surface's normal taken from a quadric fit of the
:data:`NEIGHBOURS` fitted points nearest ``i`` (wide, and bent with the surface): the map's
image of the input point's foot on the surface, to first order. The heights the denoiser
removed stay removed; only the slide along the surface is undone.

A wide normal is right where the surface is smooth at its scale and wrong where it has
detail at the scale of a few points (on the noisy closed david head the 16 nearest points'
normal is the better one: moving along the wide one there costs 0.0520 -> 0.0555-0.0742 rad,
even only where the two agree within 3 degrees, 0.0523). The step is therefore made only
when the two agree over the cloud: the median angle between them under :data:`AGREE_DEG`
(smooth analytic shapes 2.1-2.3 degrees, the noisy david head 5.6).

The step never turns over a triangle of the map's own mesh that the map had not turned
over: where one does, its corners' steps are halved (:data:`HALVINGS` times, then dropped).

Where the normals disagree the slide cannot be undone, and it costs more than the noise the
denoiser removed at low noise: the map is then made of points moved only a part of the way
from the input points to the fitted ones (:func:`mapped_points`), the noise level in spacings
(:data:`FULL_STEP`: the whole way from one spacing on). Half the noise left along the
normals costs less than half the slide, since a point moved along the surface changes its
triangles' angles to first order and one moved off it to second. The noisy david head (depth
noise 0.25 / 0.5 / 1 mean edges, estimated 0.31 / 0.55 / 0.91 spacings): 0.0520 / 0.1021 /
0.2525 rad -> 0.0402 / 0.0874 / 0.2490 (seed 0; its anchor on the noisy true mesh 0.0516 at
0.25; flips 0 / 49 / 573 -> 0 / 31 / 571). A fixed part is worse at one end or the other:
half the way 0.0409 / 0.0881 / 0.2752, three quarters 0.0470 / 0.0918 / 0.2349; on a smooth
shape whose normals disagree only under strong noise (a peanut sampled as a scan, noise 1
spacing, estimated 1.29, agreement 3.7 degrees) the whole way is the better, 0.1613 rad
against 0.2623 half way and 0.1844 three quarters. Smooth shapes with the placement made are
unchanged: there a part of the way is much the worse (the uniform sphere, noise 0.25 spacings,
estimated 0.55: 0.0053 placed, 0.0172 the whole way unplaced, 0.0425 half way).
"""

from __future__ import annotations

import itertools

import numpy as np

__all__ = ["place_input", "mapped_points", "normals_agree", "quadric_normals", "NEIGHBOURS",
           "AGREE_DEG", "HALVINGS", "FULL_STEP"]

NEIGHBOURS = 96
"""Fitted points of each quadric fit that gives the surface's normal (the denoiser's own fits
use 96). On 5k noisy uniform clouds of the bumpy sphere (seeds 0-4), the true triangles
turned over / mean angle error, before the step: 11, 0, 4, 3, 2 / 0.019-0.020 rad; along the
normal of a quadric of 24 points 10, 0, 3, 2, 3 / 0.016; of 48: 6, 0, 1, 2, 1 / 0.011; of 96:
4, 0, 1, 1, 0 / 0.008-0.009 (PCA of 32 or 48 points: 7, 0, 1, 1, 1 / 0.014 and 5, 0, 1, 1, 1
/ 0.011-0.012)."""

AGREE_DEG = 3.5
"""The step is made when the median angle, over the mapped points, between the normal of
the 16 nearest fitted points and the wide quadric's is under this (degrees)."""

FULL_STEP = 1.0
"""Where the normals disagree, the map is made of points moved ``min(1, noise / FULL_STEP)``
of the way from the input points to the fitted ones (``noise``: the denoiser's estimate, in
spacings); the module's description has the measurements."""

HALVINGS = 6
"""Times a step that turns a triangle of the map's own mesh over is halved before it is
dropped."""

_CHUNK = 32_768
"""Points per block of the quadric fits (96 neighbours each)."""


def quadric_normals(Y: np.ndarray, neighbours: int = NEIGHBOURS) -> np.ndarray:
    """(N, 3) unit normals (unoriented) of ``Y`` (N, 3): at each point the gradient normal of
    the quadric ``z = q(x, y)`` fitted, unweighted, to its ``neighbours`` nearest points in
    their PCA frame, evaluated at the point itself."""
    from scipy.spatial import cKDTree

    from ..neighbours import quadric_basis

    tree = cKDTree(Y)
    k = min(neighbours, len(Y))
    out = np.empty_like(Y)
    for s in range(0, len(Y), _CHUNK):
        y0 = Y[s:s + _CHUNK]
        nb = tree.query(y0, k)[1].reshape(len(y0), k)
        P = Y[nb] - y0[:, None]  # the point at the origin
        Q = P - P.mean(axis=1, keepdims=True)
        frame = np.linalg.eigh(np.einsum("nki,nkj->nij", Q, Q))[1]  # columns: n, t1, t2
        local = np.einsum("nkd,nde->nke", P, frame)
        A = quadric_basis(local[..., 1], local[..., 2])
        AtA = np.einsum("nki,nkj->nij", A, A) + 1e-12 * np.eye(A.shape[-1])
        coef = np.linalg.solve(AtA, np.einsum("nki,nk->ni", A, local[..., 0])[..., None])
        g = np.column_stack([np.ones(len(y0)), -coef[:, 1, 0], -coef[:, 2, 0]])
        g /= np.linalg.norm(g, axis=1, keepdims=True)
        out[s:s + _CHUNK] = np.einsum("nde,ne->nd", frame, g)
    return out


def normals_agree(Y: np.ndarray) -> tuple[float, np.ndarray]:
    """The median angle (degrees) between the normals of the 16 nearest points (PCA) and the
    wide quadric's (:func:`quadric_normals`) over the points ``Y`` (N, 3), and the latter
    (N, 3)."""
    from ..neighbours import local_pca

    wide = quadric_normals(Y)
    narrow = local_pca(Y, 16)[1][:, :, 0]
    agree = float(np.degrees(np.median(np.arccos(np.clip(
        np.abs(np.einsum("nd,nd->n", wide, narrow)), 0.0, 1.0)))))
    return agree, wide


def mapped_points(Y: np.ndarray, X: np.ndarray, noise: float | None
                  ) -> tuple[np.ndarray, tuple[float, np.ndarray], float]:
    """The points a denoised cloud's sphere map is made of: the fitted points ``Y`` (N, 3)
    when the normals agree (:data:`AGREE_DEG`; :func:`place_input` then undoes the slide),
    else the points moved ``step = min(1, noise / FULL_STEP)`` of the way from the input
    points ``X`` (N, 3) to them (``noise``: the denoiser's estimate in spacings; None: the
    whole way).

    Returns the points, the agreement (degrees) with the wide normals (for
    :func:`place_input`), and ``step``."""
    gate = normals_agree(Y)
    if gate[0] < AGREE_DEG or noise is None:
        return Y, gate, 1.0
    step = float(min(1.0, noise / FULL_STEP))
    return X + step * (Y - X), gate, step


def _differentials(S: np.ndarray, Y: np.ndarray, F: np.ndarray, normal: np.ndarray
                   ) -> np.ndarray:
    """(N, 3, 3) per vertex the least-squares linear map ``J`` with ``(y_j - y_i) J ~
    s_j - s_i`` over its mesh neighbours ``j``, of the edges projected onto the plane normal
    to ``normal[i]`` (zero along it)."""
    n = len(Y)
    E = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    E = np.unique(np.sort(E, axis=1), axis=0)
    E = np.concatenate([E, E[:, ::-1]])
    i, j = E[:, 0], E[:, 1]
    d = Y[j] - Y[i]
    d -= np.einsum("md,md->m", d, normal[i])[:, None] * normal[i]
    M = np.zeros((n, 3, 3))
    np.add.at(M, i, np.einsum("ma,mb->mab", d, d))
    R = np.zeros((n, 3, 3))
    np.add.at(R, i, np.einsum("ma,mb->mab", d, S[j] - S[i]))
    # The normal direction, where M is zero, gets a unit weight and no image.
    M += np.einsum("na,nb->nab", normal, normal)
    return np.linalg.solve(M, R)


def place_input(S: np.ndarray, Y: np.ndarray, X: np.ndarray, F: np.ndarray, *,
                gate: tuple[float, np.ndarray] | None = None) -> tuple[np.ndarray, dict]:
    """The sphere map ``S`` (N, 3) of the fitted points ``Y`` (N, 3) on the closed mesh ``F``
    (outward), each point moved to the image of its input point's place ``X`` along the
    surface (the module's description). ``gate``: :func:`normals_agree` of ``Y`` when
    already made.

    Returns the unit vectors (N, 3) and a record: ``applied``, ``agree_deg`` (the median
    angle between the narrow and the wide normals), ``moved`` (points whose step was kept,
    whole or halved), ``halved`` (points whose step was halved or dropped), ``shift`` (the
    mean step along the surface, relative to the mean edge)."""
    from .sphere import sphere_flips

    record = {"applied": False, "agree_deg": None, "moved": 0, "halved": 0, "shift": 0.0}
    step3 = X - Y
    if not np.any(step3):
        return S, record
    agree, wide = normals_agree(Y) if gate is None else gate
    record["agree_deg"] = agree
    if agree >= AGREE_DEG:
        return S, record
    t = step3 - np.einsum("nd,nd->n", step3, wide)[:, None] * wide
    J = _differentials(S, Y, F, wide)
    move = np.einsum("nd,nde->ne", t, J)
    before = sphere_flips(S, F)
    scale = np.ones(len(S))
    halved = np.zeros(len(S), dtype=bool)
    for k in itertools.count():  # ends: each round drops a step or halves one
        out = S + scale[:, None] * move
        out /= np.linalg.norm(out, axis=1, keepdims=True)
        worse = sphere_flips(out, F) & ~before
        if not worse.any():
            break
        corners = np.unique(F[worse])
        halved[corners] = True
        # A triangle whose corners all keep their place is as the map made it.
        scale[corners] = 0.0 if k >= HALVINGS - 1 else 0.5 * scale[corners]
    edges = np.linalg.norm(Y[F] - Y[np.roll(F, 1, axis=1)], axis=2).mean()
    record.update(applied=True, moved=int((scale > 0).sum()), halved=int(halved.sum()),
                  shift=float(np.linalg.norm(t, axis=1).mean() / edges))
    return out, record
