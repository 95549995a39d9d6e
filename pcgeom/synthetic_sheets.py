"""Open test surfaces for the local mesh's topology (:mod:`pcgeom.maps.topology`), with their
true triangulations: a sheet with lips and nostrils whose walls nearly touch, and a sheet
with round holes of a few spacings.

Both are images of a planar parameter domain, sampled there (uniform random points or a
jittered grid, near-isometric maps so that the 3D density is nearly uniform) and
triangulated there (Delaunay): the true mesh over the points, used only to evaluate.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy.spatial import Delaunay

from .errors import InputError

__all__ = ["Sheet", "lips_sheet", "holed_sheet"]


@dataclasses.dataclass(frozen=True)
class Sheet:
    """What :func:`lips_sheet` and :func:`holed_sheet` return."""

    points: np.ndarray
    """(N, 3) float64."""
    normals: np.ndarray
    """(N, 3) float64 unit normals, consistently oriented."""
    faces: np.ndarray
    """(M, 3) int64 true triangles over the points, counter-clockwise seen from the normals."""
    params: np.ndarray
    """(N, 2) the points' parameters (an isometric map for the holed sheet)."""
    boundary_loops: int
    """Boundary loops of the surface (the rim and the holes)."""
    spacing: float
    """Mean edge length of ``faces``."""


def _fold(t: np.ndarray, s: np.ndarray, depth: float, gap: float, bulb: float
          ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A fold into the sheet at arc length ``t`` along it, scaled by ``s`` (0: none): down a
    wall of length ``depth s``, round a bulb (a circle of radius ``bulb s`` through both
    walls' ends, the long way), up the other wall ``gap s`` away. Returns x, z offsets from
    the fold's start and the unit tangent (tx, tz)."""
    g, D, R = gap * s, depth * s, bulb * s
    half = np.arcsin(np.clip(g / (2 * np.maximum(R, 1e-300)), 0, 1))
    sweep = 2 * np.pi - 2 * half  # from wall 1's end the long way round to wall 2's
    arc = R * sweep
    x, z = np.zeros_like(t), np.zeros_like(t)
    tx, tz = np.zeros_like(t), -np.ones_like(t)
    down = t <= D
    z[down] = -t[down]
    bend = (t > D) & (t <= D + arc)
    # Circle centre below the walls' ends; wall 1's end at angle pi/2 + half from it.
    cz = -D - R * np.cos(half)
    a0 = np.pi / 2 + half
    phi = a0 + (t - D) / np.maximum(R, 1e-300)
    x[bend] = (g / 2 + R * np.cos(phi))[bend]
    z[bend] = (cz + R * np.sin(phi))[bend]
    tx[bend], tz[bend] = -np.sin(phi)[bend], np.cos(phi)[bend]
    up = t > D + arc
    x[up] = g[up] if np.ndim(g) else g
    z[up] = (-D + (t - D - arc))[up]
    tx[up], tz[up] = 0.0, 1.0
    return x, z, tx, tz


def _fold_length(s: np.ndarray, depth: float, gap: float, bulb: float) -> np.ndarray:
    half = np.arcsin(np.clip(gap / (2 * bulb), 0, 1))
    return s * (2 * depth + bulb * (2 * np.pi - 2 * half))


def _smooth_step(x: np.ndarray) -> np.ndarray:
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3 - 2 * x)


def lips_sheet(n: int = 11000, *, gap: float = 0.75, sampling: str = "uniform",
               seed: int = 0) -> Sheet:
    """A sheet (an open surface, one boundary loop) with a mouth and two nostrils: folds into
    it whose walls are ``gap`` spacings apart (the lips' and nostrils' sheets that nearly
    touch, with opposite normals), closing smoothly at their ends.

    The sheet is a curve in the xz-plane (arc length ``u``) extruded along y, folded at
    two places along u: the nostrils (depth 3, bulb radius 1.5 spacings) over two stretches
    of y, the mouth (depth 6, bulb 2) over a longer one; each fold scaled by a smooth step
    in y over 12 (20) spacings, so that it opens from nothing. The parameters ``(u, y)`` are nearly
    isometric; the true triangles are their Delaunay triangles.

    Parameters
    ----------
    n : about how many points.
    gap : the walls' distance in spacings (the mean true edge length, about 1).
    sampling : "uniform" (random) or "grid" (jittered).
    seed : seeds the sampling.
    """
    if sampling not in ("uniform", "grid"):
        raise InputError(f"lips_sheet: unknown sampling {sampling!r}; expected uniform or grid")
    if not (np.isfinite(gap) and gap > 0):
        raise InputError(f"lips_sheet: gap must be a number > 0, got {gap!r}")
    rng = np.random.default_rng(seed)
    h = 1.0  # the spacing the sizes are given in
    width = 80.0 * h
    nose = dict(depth=3.0, gap=gap, bulb=1.5)
    mouth = dict(depth=6.0, gap=gap, bulb=2.0)
    u_nose, u_mouth, flat = 25.0, 50.0, 75.0  # fold starts along the flat length

    def scales(y):
        s_nose = np.maximum(_smooth_step((y - 8) / 12) * _smooth_step((36 - y) / 12),
                            _smooth_step((y - 44) / 12) * _smooth_step((72 - y) / 12))
        s_mouth = _smooth_step((y - 8) / 20) * _smooth_step((72 - y) / 20)
        return s_nose, s_mouth

    def length(y):
        s_n, s_m = scales(y)
        return flat + _fold_length(s_n, **nose) + _fold_length(s_m, **mouth)

    area = (flat + float(np.mean(length(np.linspace(0, width, 400)) - flat))) * width
    density = n / area
    # Parameters (u, y) in the domain 0 <= u <= length(y), 0 <= y <= width.
    if sampling == "grid":
        step = 1.0 / np.sqrt(density)
        u, y = np.meshgrid(np.arange(0, flat + 40, step), np.arange(0, width, step),
                           indexing="ij")
        P = np.column_stack([u.ravel(), y.ravel()])
        P = P + rng.uniform(-0.25 * step, 0.25 * step, P.shape)
    else:
        P = rng.uniform([0, 0], [flat + 40, width], (int(density * (flat + 40) * width), 2))
    P = P[(P[:, 0] >= 0) & (P[:, 0] <= length(P[:, 1])) & (P[:, 1] >= 0) & (P[:, 1] <= width)]
    X, N = _lips_point(P, scales, nose, mouth, u_nose, u_mouth)
    F = _domain_delaunay(P, lambda Q: Q[:, 0] <= length(Q[:, 1]))
    F = _orient(X, N, F)
    return Sheet(points=X, normals=N, faces=F, params=P, boundary_loops=1,
                 spacing=_mean_edge(X, F))


def _lips_point(P, scales, nose, mouth, u_nose, u_mouth):
    """3D points and normals of the lips sheet at parameters ``P`` (u, y)."""
    u, y = P[:, 0], P[:, 1]
    s_n, s_m = scales(y)
    L_n, L_m = _fold_length(s_n, **nose), _fold_length(s_m, **mouth)
    x = np.empty(len(u))
    z = np.zeros(len(u))
    tx, tz = np.ones(len(u)), np.zeros(len(u))
    # Flat, nose fold, flat, mouth fold, flat.
    a = u < u_nose
    x[a] = u[a]
    b = (u >= u_nose) & (u < u_nose + L_n)
    fx, fz, ftx, ftz = _fold(u[b] - u_nose, s_n[b], **nose)
    x[b], z[b], tx[b], tz[b] = u_nose + fx, fz, ftx, ftz
    shift_n = nose["gap"] * s_n - L_n  # x of the flat after the nose fold, less its u
    c = (u >= u_nose + L_n) & (u < u_mouth + L_n)
    x[c] = u[c] + shift_n[c]
    d = (u >= u_mouth + L_n) & (u < u_mouth + L_n + L_m)
    fx, fz, ftx, ftz = _fold(u[d] - u_mouth - L_n[d], s_m[d], **mouth)
    x[d], z[d], tx[d], tz[d] = u_mouth + shift_n[d] + L_n[d] + fx, fz, ftx, ftz
    e = u >= u_mouth + L_n + L_m
    x[e] = u[e] + shift_n[e] + mouth["gap"] * s_m[e] - L_m[e]
    X = np.column_stack([x, y, z])
    N = np.column_stack([-tz, np.zeros(len(u)), tx])
    return X, N


def holed_sheet(n: int = 6000, *, radii: tuple[float, ...] = (1.0, 2.0, 3.0, 4.0, 5.0),
                sampling: str = "uniform", seed: int = 0) -> Sheet:
    """A smooth height field over a square with round holes of the given radii (in spacings,
    the mean true edge length), far from each other and from the rim: a surface with
    ``1 + len(radii)`` boundary loops.

    Parameters
    ----------
    n : about how many points (before the holes).
    radii : the holes' radii in spacings.
    sampling : "uniform" (random), "grid" (jittered) or "scan" (density falling 4x across).
    seed : seeds the sampling.
    """
    if sampling not in ("uniform", "grid", "scan"):
        raise InputError(f"holed_sheet: unknown sampling {sampling!r}; expected uniform, grid "
                         "or scan")
    rng = np.random.default_rng(seed)
    side = np.sqrt(n)  # about one point per unit area: spacing about 1
    if sampling == "grid":
        g = np.arange(0, side, 1.0)
        P = np.stack(np.meshgrid(g, g, indexing="ij"), -1).reshape(-1, 2)
        P = P + rng.uniform(-0.25, 0.25, P.shape)
    elif sampling == "scan":
        P = rng.uniform(0, side, (4 * n, 2))
        keep = rng.uniform(0, 1, len(P)) < (0.25 + 0.75 * P[:, 0] / side) / 1.0
        P = P[keep][: int(n * 1.6)]
    else:
        P = rng.uniform(0, side, (n, 2))
    # A first mesh for the spacing the radii are in.
    spacing = _mean_edge(np.column_stack([P, np.zeros(len(P))]), Delaunay(P).simplices)
    k = len(radii)
    centres = np.column_stack([side * (0.2 + 0.6 * (np.arange(k) % 3) / 2.0),
                               side * (0.25 + 0.5 * (np.arange(k) // 3))])
    inside = np.zeros(len(P), dtype=bool)
    for c, r in zip(centres, radii):
        inside |= np.linalg.norm(P - c, axis=1) < r * spacing
    P = P[~inside]

    def outside_holes(Q):
        ok = np.ones(len(Q), dtype=bool)
        for c, r in zip(centres, radii):
            ok &= np.linalg.norm(Q - c, axis=1) >= r * spacing
        return ok

    F = _domain_delaunay(P, outside_holes)
    z = 0.15 * side * np.sin(P[:, 0] / side * 3.0) * np.cos(P[:, 1] / side * 2.0)
    X = np.column_stack([P, z])
    grad = np.column_stack([0.15 * 3.0 * np.cos(P[:, 0] / side * 3.0) * np.cos(P[:, 1] / side * 2.0),
                            -0.15 * 2.0 * np.sin(P[:, 0] / side * 3.0) * np.sin(P[:, 1] / side * 2.0)])
    N = np.column_stack([-grad, np.ones(len(P))])
    N /= np.linalg.norm(N, axis=1, keepdims=True)
    F = _orient(X, N, F)
    return Sheet(points=X, normals=N, faces=F, params=P, boundary_loops=1 + k,
                 spacing=_mean_edge(X, F))


def _domain_delaunay(P: np.ndarray, inside) -> np.ndarray:
    """Delaunay triangles of ``P`` whose edges' midpoints and centroid are in the domain
    (``inside(Q)``: bool per row), counter-clockwise in the parameters."""
    T = Delaunay(P).simplices.astype(np.int64)
    ok = inside(P[T].mean(axis=1))
    for q in range(3):
        ok &= inside(0.5 * (P[T[:, q]] + P[T[:, (q + 1) % 3]]))
    T = T[ok]
    a, b = P[T[:, 1]] - P[T[:, 0]], P[T[:, 2]] - P[T[:, 0]]
    cw = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0] < 0
    T[cw] = T[cw][:, [0, 2, 1]]  # counter-clockwise in the parameters
    return T


def _orient(X: np.ndarray, N: np.ndarray, F: np.ndarray) -> np.ndarray:
    """``F`` (consistently oriented in the parameters) turned as a whole to face the side of
    most of its triangles' normals."""
    cross = np.cross(X[F[:, 1]] - X[F[:, 0]], X[F[:, 2]] - X[F[:, 0]])
    agree = np.einsum("md,md->m", cross, N[F].sum(axis=1)) > 0
    return F if agree.mean() >= 0.5 else F[:, [0, 2, 1]]


def _mean_edge(X: np.ndarray, F: np.ndarray) -> float:
    E = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    return float(np.linalg.norm(X[E[:, 0]] - X[E[:, 1]], axis=1).mean())
