"""Analytic surfaces for seams and atlases (``cut="auto"``): a body with a long thin
protrusion (an open surface whose one conformal chart shrinks the protrusion to nothing), and
closed surfaces of any genus (pretzels).

- :func:`finger`: a disk of radius ``R`` in the plane ``z = 0`` with a tube of radius ``r``
  and length ``L`` standing on its centre, joined by a concave quarter-circle fillet of radius
  ``f`` and closed by a hemispherical cap: a surface of revolution, a topological disk. Its
  conformal map onto a planar region shrinks the tube by about ``exp(-L / r)`` (a cylinder of
  radius ``r`` and length ``L`` is conformally an annulus of modulus ``L / r``), so the scale
  factor's spread over the points is far above 10. Sampled on rings of constant arc length
  from the tip, about one spacing apart, each ring with about ``2 pi rho / h`` points,
  jittered; its true triangles stitch consecutive rings (counter-clockwise seen from the
  outside: from above on the disk, from outside on the tube).
- :func:`pretzel`: the implicit surface ``(p(x) + y^2)^2 + z^2 = eps``, with a hole over
  each of the ``g`` intervals between the roots of ``p`` where ``p < 0``: genus ``g``. For
  ``g <= 2``, ``p(x) = x (x - 1)^2 (x - 2)`` (or ``x (x - 1)``); for ``g >= 3``, ``p(x) =
  -sin^2(pi x) / (tanh(2 x) tanh(2 (g - x)))`` on ``[0, g]`` (wells of nearly one depth) and
  ``-(pi^2 / 2) u (1 - 2 u)`` beyond, ``u = x`` or ``g - x``, scaled so that its shallowest
  well is 0.3 deep (the tube is ``|p + y^2| < sqrt(eps)`` wide: holes of about 0.7 across).
  Random points of its box projected onto it (Newton steps along the
  gradient), thinned to a minimum distance. No true triangles.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .errors import InputError

__all__ = ["OpenSurface", "finger", "pretzel", "FINGER"]

FINGER = {"R": 1.0, "r": 0.12, "L": 1.0, "f": 0.1}
"""The default finger: disk radius ``R``, tube radius ``r`` and length ``L``, fillet ``f``."""


@dataclasses.dataclass(frozen=True)
class OpenSurface:
    """What :func:`finger` returns."""

    points: np.ndarray
    """(N, 3) float64."""
    normals: np.ndarray
    """(N, 3) float64 unit normals, up on the disk and outward on the tube."""
    faces: np.ndarray
    """(M, 3) int64 true triangles, counter-clockwise seen from the normals' side; a
    topological disk (Euler characteristic 1, one boundary loop: the rim)."""
    spacing: float
    """The ring spacing ``h``."""


def _profile(R: float, r: float, L: float, f: float, samples: int = 20001):
    """The profile from the tip: arc length ``t`` (samples,), radius ``rho``, height ``z``."""
    cap = np.linspace(0.0, np.pi / 2, samples)
    top = f + L
    parts = [
        (r * cap, r * np.sin(cap), top + r * np.cos(cap)),
        (r * np.pi / 2 + np.linspace(0, L, samples), np.full(samples, r),
         np.linspace(top, f, samples)),
        (r * np.pi / 2 + L + f * cap, r + f - f * np.cos(cap), f - f * np.sin(cap)),
        (r * np.pi / 2 + L + f * np.pi / 2 + np.linspace(0, R - r - f, samples),
         np.linspace(r + f, R, samples), np.zeros(samples)),
    ]
    t = np.concatenate([p[0] for p in parts])
    rho = np.concatenate([p[1] for p in parts])
    z = np.concatenate([p[2] for p in parts])
    t, keep = np.unique(t, return_index=True)
    return t, rho[keep], z[keep]


def _stitch(a: np.ndarray, ta: np.ndarray, b: np.ndarray, tb: np.ndarray) -> list:
    """Triangles between the ring ``a`` (angles ``ta``, ascending) and the next ring out ``b``
    (``tb``, ascending), both closed: from ``a[0]`` and the point of ``b`` nearest it in
    angle, walk both rings once round, advancing the one whose next angle comes first."""
    na, nb = len(a), len(b)
    j0 = int(np.argmin(np.abs(np.angle(np.exp(1j * (tb - ta[0]))))))
    ua = np.r_[ta - ta[0], 2 * np.pi]
    ub = np.angle(np.exp(1j * (tb[(j0 + np.arange(nb)) % nb] - ta[0])))
    ub = ub[0] + np.r_[np.mod(ub - ub[0], 2 * np.pi), 2 * np.pi]
    ub[1:-1][ub[1:-1] <= ub[0]] += 2 * np.pi
    bb = b[(j0 + np.arange(nb + 1)) % nb]
    aa = a[np.arange(na + 1) % na]
    tris = []
    i = j = 0
    while i < na or j < nb:
        if j < nb and (i == na or ub[j + 1] <= ua[i + 1]):
            tris.append((aa[i], bb[j], bb[j + 1]))
            j += 1
        else:
            tris.append((aa[i], bb[j], aa[i + 1]))
            i += 1
    return tris


def finger(n: int = 5000, *, seed: int = 0, R: float = FINGER["R"], r: float = FINGER["r"],
           L: float = FINGER["L"], f: float = FINGER["f"], jitter: float = 0.2) -> OpenSurface:
    """About ``n`` points on a disk with a finger (the module's first surface).

    Raises
    ------
    InputError
        ``n`` under 200, or sizes that do not fit (``r + f < R``, all positive).
    """
    if n < 200:
        raise InputError(f"finger: n must be at least 200, got {n}")
    if min(R, r, L, f) <= 0 or r + f >= R:
        raise InputError(f"finger: need positive sizes with r + f < R, got R={R}, r={r}, "
                         f"L={L}, f={f}")
    rng = np.random.default_rng(seed)
    t, rho, z = _profile(R, r, L, f)
    area = float(np.trapezoid(2 * np.pi * rho, t))
    h = 0.94 * float(np.sqrt(2.0 * area / (np.sqrt(3.0) * n)))  # 0.94: n points, measured
    S = float(t[-1])
    count = max(int(round(S / h)), 2)
    levels = np.linspace(0.0, S, count + 1)
    levels[1:-1] += rng.uniform(-jitter, jitter, count - 1) * (S / count)
    drho, dz = np.gradient(rho, t), np.gradient(z, t)
    points, normals, rings, angles = [], [], [], []
    start = 0
    for k, s in enumerate(levels):
        rr, zz = np.interp(s, t, rho), np.interp(s, t, z)
        m = 1 if k == 0 else max(int(round(2 * np.pi * rr / (S / count))), 3)
        th = 2 * np.pi * (np.arange(m) + rng.uniform() +
                          (rng.uniform(-jitter, jitter, m) if m > 3 else 0.0)) / m
        th = np.sort(np.mod(th, 2 * np.pi))
        tr, tz = np.interp(s, t, drho), np.interp(s, t, dz)
        nr, nz = -tz, tr
        norm = np.hypot(nr, nz)
        points.append(np.column_stack([rr * np.cos(th), rr * np.sin(th), np.full(m, zz)]))
        normals.append(np.column_stack([nr / norm * np.cos(th), nr / norm * np.sin(th),
                                        np.full(m, nz / norm)]))
        rings.append(np.arange(start, start + m))
        angles.append(th)
        start += m
    faces = [(0, b, c) for b, c in zip(rings[1], np.roll(rings[1], -1))]
    for k in range(1, len(rings) - 1):
        faces += _stitch(rings[k], angles[k], rings[k + 1], angles[k + 1])
    P = np.vstack(points)
    F = np.asarray(faces, dtype=np.int64)
    N = np.vstack(normals)
    N[0] = [0.0, 0.0, 1.0]
    cross = np.cross(P[F[:, 1]] - P[F[:, 0]], P[F[:, 2]] - P[F[:, 0]])
    if (cross * N[F].mean(axis=1)).sum() < 0:
        F = F[:, ::-1].copy()
    return OpenSurface(P, N, F, h)


def pretzel(genus: int, n: int, *, seed: int = 0, eps: float = 0.03) -> np.ndarray:
    """About ``n`` points on the genus-``genus`` implicit surface of the module (no true
    triangles). ``genus`` 2 with ``eps = 0.03`` is the classic double torus
    ``(x (x - 1)^2 (x - 2) + y^2)^2 + z^2 = 0.03``."""
    from scipy.spatial import cKDTree

    if genus < 1:
        raise InputError(f"pretzel: genus must be at least 1, got {genus}")

    def raw(x):
        if genus <= 2:  # x (x - 1)^2 (x - 2): its wells equal by symmetry
            out = x * (x - genus)
            for k in range(1, genus):
                out = out * (x - k) ** 2
            return out
        # sin^2(pi x) over a smooth ramp: double zeros inside, simple ones at 0 and g, wells
        # of nearly one depth (a polynomial's middle wells are several times shallower, so
        # thin that their holes close).
        # Outside [0, g], -(pi^2 / 2) u (1 - 2 u) with u = x or g - x (< 0): positive,
        # growing, its slope at the end that of the inside (tanh(2 g) = 1 to 1e-5).
        u = np.minimum(x, genus - x)
        ramp = np.tanh(2 * x) * np.tanh(2 * (genus - x))
        with np.errstate(divide="ignore", invalid="ignore"):
            inside = -np.sin(np.pi * x) ** 2 / ramp
        inside = np.where(np.abs(ramp) < 1e-12, 0.0, inside)
        return np.where(u < 0, -(np.pi ** 2 / 2) * u * (1 - 2 * u), inside)

    # p scaled: at genus 1-2 to its classic depth (-0.1875 at x = 0.5 and 1.5: holes of
    # about 0.12 across, since the tube is |p + y^2| < sqrt(eps) = 0.173 wide); beyond, so
    # that its shallowest well is 0.3 deep (holes of about 0.7 across).
    if genus <= 2:
        scale = 1.0
    else:
        depth = [-float(raw(np.linspace(k, k + 1, 401)).min()) for k in range(genus)]
        scale = 0.3 / min(depth)

    def fun(P):
        x, y, zz = P.T
        return (scale * raw(x) + y ** 2) ** 2 + zz ** 2 - eps

    def grad(P, h=1e-6):
        return np.column_stack([(fun(P + d) - fun(P - d)) / (2 * h) for d in np.eye(3) * h])

    rng = np.random.default_rng(seed)
    P = rng.uniform([-0.35, -1.1, -0.45], [genus + 0.35, 1.1, 0.45], size=(40 * n, 3))
    for _ in range(30):
        g = grad(P)
        P = P - (fun(P) / np.maximum((g * g).sum(1), 1e-12))[:, None] * g
    P = P[np.abs(fun(P)) < 1e-9]
    P = P[rng.permutation(len(P))]
    tree = cKDTree(P)

    def thin(radius):
        keep = np.ones(len(P), dtype=bool)
        for i in range(len(P)):
            if keep[i]:
                keep[tree.query_ball_point(P[i], radius)] = False
                keep[i] = True
        return keep

    # A first radius from the genus-2 surface's area, then one correction to about n points.
    radius = 0.75 * np.sqrt(6.0 / n) * np.sqrt(genus / 2.0)
    keep = thin(radius)
    keep = thin(radius * np.sqrt(keep.sum() / n))
    return P[keep]
