"""Open test surfaces for the local mesh's topology (:mod:`pcgeom.maps.topology`), with their
true triangulations: a sheet with lips and nostrils whose walls nearly touch, and a sheet
with round holes of a few spacings.

Both are images of a planar parameter domain, sampled there (uniform random points or a
jittered grid, near-isometric maps so that the 3D density is nearly uniform) and
triangulated there (Delaunay; the lips sheet's then flipped to be Delaunay on the surface,
where its parameters shear): the true mesh over the points, used only to evaluate.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy.spatial import Delaunay

from .errors import InputError

__all__ = ["Sheet", "lips_sheet", "lips_fold_scale", "holed_sheet", "CREASE_RADIUS"]


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


def _fold_segments(depth: float, gap: float, bulb: float, crease: float
                   ) -> list[tuple[float, float]]:
    """The profile of a fold at scale 1, as pieces of constant curvature: (arc length, turn
    in radians; negative: clockwise). From the flat (heading +x) a fillet of radius
    ``crease`` turns down, a wall of length ``depth`` goes down, a fillet turns out, a bulb
    of radius ``bulb`` turns back up the long way, a fillet turns in, the other wall (``gap``
    from the first) goes up and a fillet turns onto the flat again. Every piece meets the
    next with the same tangent (no crease) unless ``crease`` is 0: then the walls meet the
    flat at right angles and the bulb at the circle through both walls' ends."""
    if gap >= 2 * bulb:
        raise InputError(f"lips_sheet: gap must be under the bulbs' diameter {2 * bulb}, "
                         f"got {gap!r}")
    # The bulb's fillets turn out by beta, the bulb back by pi + 2 beta, centred between
    # the walls: (bulb + crease) cos(beta) = gap / 2 + crease.
    beta = float(np.arccos((gap / 2 + crease) / (bulb + crease)))
    quarter = np.pi / 2
    return [(crease * quarter, -quarter), (depth, 0.0), (crease * beta, -beta),
            (bulb * (np.pi + 2 * beta), np.pi + 2 * beta), (crease * beta, -beta),
            (depth, 0.0), (crease * quarter, -quarter)]


def _fold(t: np.ndarray, s: np.ndarray, segments: list[tuple[float, float]]
          ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The fold of :func:`_fold_segments` scaled by ``s`` (0: none) at arc length ``t``
    along it: x, z offsets from the fold's start and the unit tangent (tx, tz), by arc
    length (the sheet stays isometric to its parameters along u)."""
    t = np.asarray(t, dtype=np.float64)
    s = np.maximum(np.broadcast_to(np.asarray(s, dtype=np.float64), t.shape), 1e-300)
    x, z, theta = np.zeros_like(t), np.zeros_like(t), np.zeros_like(t)
    start = np.zeros_like(t)
    for length, turn in segments:
        ell = length * s
        if length == 0.0:  # a crease: the tangent turns at once
            theta = theta + np.where(t >= start, turn, 0.0)
            continue
        dt = np.clip(t - start, 0.0, ell)
        after = theta + turn * dt / ell
        if turn == 0.0:
            x, z = x + dt * np.cos(theta), z + dt * np.sin(theta)
        else:
            radius = ell / turn
            x = x + radius * (np.sin(after) - np.sin(theta))
            z = z - radius * (np.cos(after) - np.cos(theta))
        theta, start = after, start + ell
    return x, z, np.cos(theta), np.sin(theta)


def _fold_length(s: np.ndarray, segments: list[tuple[float, float]]) -> np.ndarray:
    return s * sum(length for length, _ in segments)


def _fold_width(segments: list[tuple[float, float]]) -> float:
    """How far along x the flat after the fold (at scale 1) is from its start."""
    total = _fold_length(np.ones(1), segments)
    return float(_fold(total, np.ones(1), segments)[0][0])


def _smooth_step(x: np.ndarray) -> np.ndarray:
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3 - 2 * x)


CREASE_RADIUS = 2.5
"""The default radius of the lips' and nostrils' rounded edges (:func:`lips_sheet`), in
the sheet's units (about a spacing at 11k points): real lips and nostrils are rounded over
a few spacings of a scan."""


def lips_sheet(n: int = 11000, *, gap: float = 0.75, crease_radius: float = CREASE_RADIUS,
               sampling: str = "uniform", seed: int = 0) -> Sheet:
    """A sheet (an open surface, one boundary loop) with a mouth and two nostrils: folds into
    it whose walls are ``gap`` apart (the lips' and nostrils' sheets that nearly touch, with
    opposite normals), closing smoothly at their ends.

    The sheet is a curve in the xz-plane (arc length ``u``) extruded along y, folded at
    two places along u: the nostrils (walls 3 deep, bulb radius 1.5) over two stretches of
    y, the mouth (walls 6 deep, bulb 2) over a longer one. A fold goes down from the flat
    round a fillet of radius ``crease_radius`` (the lips' rounded edge), down its wall, out
    round a fillet, round the bulb, in round a fillet and up the other wall ``gap`` away,
    round a fillet onto the flat: a smooth curve (``crease_radius=0``: right-angle creases
    at the flat, and the bulb a circle through the walls' ends). Each fold is scaled by a
    smooth step in y over 12 (20) units, so that it opens from nothing. The parameters
    ``(u, y)`` are arc lengths: isometric where the fold's scale is constant, nearly so
    elsewhere; the true triangles are their Delaunay triangles.

    Sizes are in the sheet's units: the mean true edge length is 1.1 at 11000 points
    (``spacing``), 2.1 at 3000.

    Parameters
    ----------
    n : about how many points.
    gap : the walls' distance (under 3, the nostrils' bulb diameter).
    crease_radius : the radius of the folds' rounded edges (0: sharp creases).
    sampling : "uniform" (random) or "grid" (jittered).
    seed : seeds the sampling.
    """
    if sampling not in ("uniform", "grid"):
        raise InputError(f"lips_sheet: unknown sampling {sampling!r}; expected uniform or grid")
    if not (np.isfinite(gap) and gap > 0):
        raise InputError(f"lips_sheet: gap must be a number > 0, got {gap!r}")
    if not (np.isfinite(crease_radius) and crease_radius >= 0):
        raise InputError(f"lips_sheet: crease_radius must be a number >= 0, got "
                         f"{crease_radius!r}")
    rng = np.random.default_rng(seed)
    width, flat = _LIPS_WIDTH, _LIPS_FLAT
    nose, mouth = _lips_folds(gap, crease_radius)
    scales = _lips_scales

    def length(y):
        s_n, s_m = scales(y)
        return flat + _fold_length(s_n, nose) + _fold_length(s_m, mouth)

    longest = float(np.max(length(np.linspace(0, width, 801))))
    area = (flat + float(np.mean(length(np.linspace(0, width, 400)) - flat))) * width
    density = n / area
    # Parameters (u, y) in the domain 0 <= u <= length(y), 0 <= y <= width.
    if sampling == "grid":
        step = 1.0 / np.sqrt(density)
        u, y = np.meshgrid(np.arange(0, longest + step, step), np.arange(0, width, step),
                           indexing="ij")
        P = np.column_stack([u.ravel(), y.ravel()])
        P = P + rng.uniform(-0.25 * step, 0.25 * step, P.shape)
    else:
        P = rng.uniform([0, 0], [longest, width], (int(density * longest * width), 2))
    P = P[(P[:, 0] >= 0) & (P[:, 0] <= length(P[:, 1])) & (P[:, 1] >= 0) & (P[:, 1] <= width)]
    X, N = _lips_point(P, scales, nose, mouth, _U_NOSE, _U_MOUTH)
    F = _domain_delaunay(P, lambda Q: Q[:, 0] <= length(Q[:, 1]))
    F = _orient(X, N, _surface_delaunay(X, P, F))
    return Sheet(points=X, normals=N, faces=F, params=P, boundary_loops=1,
                 spacing=_mean_edge(X, F))


_LIPS_WIDTH, _LIPS_FLAT = 80.0, 75.0
"""The lips sheet's extent along y, and its flat length along u (without the folds)."""
_U_NOSE, _U_MOUTH = 25.0, 50.0
"""Where along the flat length the nostrils' and the mouth's folds start."""


def _lips_folds(gap: float, crease: float):
    """The nostrils' fold (walls 3 deep, bulb radius 1.5) and the mouth's (6, 2)."""
    return (_fold_segments(depth=3.0, gap=gap, bulb=1.5, crease=crease),
            _fold_segments(depth=6.0, gap=gap, bulb=2.0, crease=crease))


def _lips_scales(y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The nostrils' and the mouth's fold scales along y (0: no fold, 1: full size)."""
    s_nose = np.maximum(_smooth_step((y - 8) / 12) * _smooth_step((36 - y) / 12),
                        _smooth_step((y - 44) / 12) * _smooth_step((72 - y) / 12))
    s_mouth = _smooth_step((y - 8) / 20) * _smooth_step((72 - y) / 20)
    return s_nose, s_mouth


def lips_fold_scale(params: np.ndarray, *, gap: float = 0.75,
                    crease_radius: float = CREASE_RADIUS, margin: float = 2.0) -> np.ndarray:
    """The scale (0 to 1) of the fold that each point of :func:`lips_sheet` (its ``params``,
    same ``gap`` and ``crease_radius``) lies on or beside (within ``margin`` along u); 1
    elsewhere. Where it is small, the fold tapers off: narrower than the sampling.

    Returns
    -------
    (N,) float64
    """
    P = np.asarray(params, dtype=np.float64)
    u, y = P[:, 0], P[:, 1]
    nose, mouth = _lips_folds(gap, crease_radius)
    s_n, s_m = _lips_scales(y)
    L_n, L_m = _fold_length(s_n, nose), _fold_length(s_m, mouth)
    out = np.ones(len(P))
    at_nose = (u >= _U_NOSE - margin) & (u <= _U_NOSE + L_n + margin)
    at_mouth = (u >= _U_MOUTH + L_n - margin) & (u <= _U_MOUTH + L_n + L_m + margin)
    out[at_nose] = s_n[at_nose]
    out[at_mouth] = s_m[at_mouth]
    return out


def _lips_point(P, scales, nose, mouth, u_nose, u_mouth):
    """3D points and normals of the lips sheet at parameters ``P`` (u, y).

    The normal is ``dX/du x dX/dy``: where the nostrils' scale changes along y, the flat
    and the mouth after them shift along x with y (the mouth's walls lean by up to 60
    degrees off the xz-plane), so the profile's own normal ``(-tz, 0, tx)`` is not the
    surface's there (it was, before 2026-12-05: up to 60 degrees off on the mouth's
    walls)."""
    X, tx, tz = _lips_xz(P, scales, nose, mouth, u_nose, u_mouth)
    h = 1e-5
    dy = (_lips_xz(P + [0.0, h], scales, nose, mouth, u_nose, u_mouth)[0]
          - _lips_xz(P - [0.0, h], scales, nose, mouth, u_nose, u_mouth)[0]) / (2 * h)
    # (tx, 0, tz) x (a, 1, c) with (a, 1, c) = dX/dy.
    N = np.column_stack([-tz, tz * dy[:, 0] - tx * dy[:, 2], tx])
    return X, N / np.linalg.norm(N, axis=1, keepdims=True)


def _lips_xz(P, scales, nose, mouth, u_nose, u_mouth):
    """3D points of the lips sheet at parameters ``P`` (u, y) and their profile's unit
    tangent (tx, tz) along u."""
    u, y = P[:, 0], P[:, 1]
    s_n, s_m = scales(y)
    L_n, L_m = _fold_length(s_n, nose), _fold_length(s_m, mouth)
    W_n, W_m = _fold_width(nose) * s_n, _fold_width(mouth) * s_m
    x = np.empty(len(u))
    z = np.zeros(len(u))
    tx, tz = np.ones(len(u)), np.zeros(len(u))
    # Flat, nose fold, flat, mouth fold, flat.
    a = u < u_nose
    x[a] = u[a]
    b = (u >= u_nose) & (u < u_nose + L_n)
    fx, fz, ftx, ftz = _fold(u[b] - u_nose, s_n[b], nose)
    x[b], z[b], tx[b], tz[b] = u_nose + fx, fz, ftx, ftz
    shift_n = W_n - L_n  # x of the flat after the nose fold, less its u
    c = (u >= u_nose + L_n) & (u < u_mouth + L_n)
    x[c] = u[c] + shift_n[c]
    d = (u >= u_mouth + L_n) & (u < u_mouth + L_n + L_m)
    fx, fz, ftx, ftz = _fold(u[d] - u_mouth - L_n[d], s_m[d], mouth)
    x[d], z[d], tx[d], tz[d] = u_mouth + shift_n[d] + L_n[d] + fx, fz, ftx, ftz
    e = u >= u_mouth + L_n + L_m
    x[e] = u[e] + shift_n[e] + W_m[e] - L_m[e]
    return np.column_stack([x, y, z]), tx, tz


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
    a, b = P[:, 0] / side * 3.0, P[:, 1] / side * 2.0
    grad = np.column_stack([0.15 * 3.0 * np.cos(a) * np.cos(b),
                            -0.15 * 2.0 * np.sin(a) * np.sin(b)])
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


def _surface_delaunay(X: np.ndarray, P: np.ndarray, T: np.ndarray, rounds: int = 200
                      ) -> np.ndarray:
    """The triangles ``T`` (counter-clockwise in the parameters ``P``) with their edges flipped
    until the mesh is Delaunay on the surface ``X`` (the two angles facing each inner edge sum
    to at most pi in 3D), as far as a flip keeps both triangles counter-clockwise in ``P``:
    where the parameters shear (the flats beside a fold whose size changes along y), their
    own Delaunay triangles are slivers on the surface. Lawson's flips, in rounds of flips
    that share no triangle."""
    T = np.array(T, dtype=np.int64)
    n = len(X)

    def angle(at, b, c):
        u, v = X[b] - X[at], X[c] - X[at]
        return np.arctan2(np.linalg.norm(np.cross(u, v), axis=1), np.einsum("kd,kd->k", u, v))

    def ccw(a, b, c):
        u, v = P[b] - P[a], P[c] - P[a]
        return u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0] > 0

    for _ in range(rounds):
        a, b, c = (T[:, q] for q in range(3))
        # Half-edge (a, b) of triangle t, corner c opposite; its twin (b, a) in another one.
        head = np.concatenate([a, b, c])
        tail = np.concatenate([b, c, a])
        opp = np.concatenate([c, a, b])
        tri = np.tile(np.arange(len(T)), 3)
        key = head * n + tail
        order = np.argsort(key)
        twin = np.searchsorted(key[order], tail * n + head)
        twin = np.minimum(twin, len(key) - 1)
        has = key[order][twin] == tail * n + head
        one = np.flatnonzero(has & (head < tail))  # each inner edge once
        other = order[twin[one]]
        h, t, c1, c2 = head[one], tail[one], opp[one], opp[other]
        excess = angle(c1, h, t) + angle(c2, t, h) - np.pi
        # The flipped pair (h, c2, c1), (c2, t, c1) must stay counter-clockwise in P.
        ok = (excess > 1e-9) & ccw(h, c2, c1) & ccw(c2, t, c1)
        if not ok.any():
            break
        cand = np.flatnonzero(ok)[np.argsort(-excess[ok])]
        t1, t2 = tri[one][cand], tri[other][cand]
        # Flips that share no triangle: each triangle goes to its first (largest) flip.
        first = np.full(len(T), len(cand))
        np.minimum.at(first, np.concatenate([t1, t2]), np.tile(np.arange(len(cand)), 2))
        win = cand[(first[t1] == np.arange(len(cand))) & (first[t2] == np.arange(len(cand)))]
        T[tri[one][win]] = np.column_stack([h[win], c2[win], c1[win]])
        T[tri[other][win]] = np.column_stack([c2[win], t[win], c1[win]])
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
