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
"""

from __future__ import annotations

import itertools

import numpy as np

__all__ = ["place_input", "quadric_normals", "NEIGHBOURS", "AGREE_DEG", "HALVINGS"]

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


def place_input(S: np.ndarray, Y: np.ndarray, X: np.ndarray, F: np.ndarray
                ) -> tuple[np.ndarray, dict]:
    """The sphere map ``S`` (N, 3) of the fitted points ``Y`` (N, 3) on the closed mesh ``F``
    (outward), each point moved to the image of its input point's place ``X`` along the
    surface (the module's description).

    Returns the unit vectors (N, 3) and a record: ``applied``, ``agree_deg`` (the median
    angle between the narrow and the wide normals), ``moved`` (points whose step was kept,
    whole or halved), ``halved`` (points whose step was halved or dropped), ``shift`` (the
    mean step along the surface, relative to the mean edge)."""
    from ..neighbours import local_pca
    from .sphere import sphere_flips

    record = {"applied": False, "agree_deg": None, "moved": 0, "halved": 0, "shift": 0.0}
    step3 = X - Y
    if not np.any(step3):
        return S, record
    wide = quadric_normals(Y)
    narrow = local_pca(Y, 16)[1][:, :, 0]
    agree = float(np.degrees(np.median(np.arccos(np.clip(
        np.abs(np.einsum("nd,nd->n", wide, narrow)), 0.0, 1.0)))))
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
