"""A cortex-like cap: a gently curved sheet with deep, narrow sulci whose centre lines meander,
whose depth and wall gap change along their course, sampled unevenly, with its true mesh
(issue 39's unseen cortical surface had sulci like these; :mod:`pcgeom.synthetic_folds`'s
grooves are straight, parallel and extruded).

The parameter domain is a disk, in polar coordinates (rho, theta), in units of the mean point
spacing. Sulcus k occupies the band ``|rho - c_k(theta)| < L_k(theta) / 2`` around a
meandering closed centre line ``c_k`` (two sine terms in theta); across the band the radius
is arc length along the groove's cross-section (as in :func:`pcgeom.synthetic_folds.deep_folds`:
a lip turning down, a wall ``D_k(theta)`` deep, a half circle of diameter ``g_k(theta)`` at
the bottom, the facing wall and lip back up), so the surface is isometric across the sulci;
beyond the band the flats are moved inward by what the sulcus took up (``L - W``), which
only shortens them along theta. The plane (horizontal radius, theta, depth) is then bent onto
a sphere (azimuthal equidistant, depth along the sphere's normal). The map is not isometric,
so the reference is LSCM on the true mesh, not the parameters.

Points are sampled in the disk with a density proportional to the surface's area element
(uniform on the surface: ``"uniform"``), or that times a density falling 4x across the cap
(``"scan"``); the true mesh is their Delaunay triangulation in the disk, less the rim's
slivers, flipped until it is Delaunay on the surface (as the lips sheet's).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .mesh import mean_edge, peel_rim, signed_areas
from .synthetic_folds import _advance
from .synthetic_sheets import _surface_delaunay

__all__ = ["Cortex", "cortex_cap", "SAMPLINGS", "PIECES"]

SAMPLINGS = ("uniform", "scan")
"""How :func:`cortex_cap` samples: uniform on the surface, or with a density falling 4x
across the cap (uneven as a scan)."""

PIECES = ("flat", "lip", "wall", "bottom")
"""The names of :attr:`Cortex.piece`'s values 0-3."""

POISSON_EDGE = 1.132
"""Mean Delaunay edge of a Poisson point process of unit density (``32 / (9 pi)``): the area
per point that makes the mean edge one spacing is ``1 / POISSON_EDGE**2``."""


@dataclasses.dataclass(frozen=True)
class Cortex:
    """What :func:`cortex_cap` returns."""

    points: np.ndarray
    """(N, 3) float64 points on the surface (no noise), in spacings of the design."""
    normals: np.ndarray
    """(N, 3) float64 unit normals, up on the flats (so a sulcus's walls face each other)."""
    faces: np.ndarray
    """(M, 3) int64 true triangles, counter-clockwise seen from the normals; used to
    evaluate a map, never to make one."""
    params: np.ndarray
    """(N, 2) float64 the points' parameters in the disk (not an isometric map)."""
    spacing: float
    """Mean edge length of ``faces``."""
    sulcus: np.ndarray
    """(N,) int64 the sulcus (0, 1, ... from the centre out) a point lies in; -1 on a flat."""
    piece: np.ndarray
    """(N,) int64 where on its cross-section a point lies: 0 flat, 1 lip, 2 wall, 3 bottom
    (:data:`PIECES`)."""
    gap: np.ndarray
    """(N,) float64 the wall gap of the point's sulcus at its theta, in design spacings,
    measured along the radius; across the walls it is narrower where they run slantwise to
    the radius (the centre line, the depth and the gap change along theta) and deep down
    (the sphere): the nearest point of the facing wall down to 0.63 of it at 4000 points.
    NaN on a flat."""
    depth: np.ndarray
    """(N,) float64 how far below the flats a point lies, in design spacings."""


@dataclasses.dataclass(frozen=True)
class _Sulcus:
    """One sulcus: its centre line ``c(theta) = base + sum a sin(m theta + phase)``, its
    depth ``D`` and gap ``g`` along theta (each ``lo + (hi - lo) (1 + sin(m theta + p)) / 2``),
    and its lips' radius."""

    base: float
    meander: tuple[tuple[float, int, float], ...]
    depth: tuple[float, float, int, float]
    gap: tuple[float, float, int, float]
    lip: float

    def centre(self, theta):
        return self.base + sum(a * np.sin(m * theta + p) for a, m, p in self.meander)

    @staticmethod
    def _wave(spec, theta):
        lo, hi, m, p = spec
        return lo + (hi - lo) * 0.5 * (1.0 + np.sin(m * theta + p))

    def D(self, theta):
        return self._wave(self.depth, theta)

    def g(self, theta):
        return self._wave(self.gap, theta)

    def reach(self) -> float:
        """Largest ``|rho - base|`` the band reaches."""
        return (sum(abs(a) for a, _, _ in self.meander)
                + (np.pi * self.lip + 2 * self.depth[1] + np.pi * self.gap[1] / 2) / 2)


def _profile(s, lip, D, g):
    """Horizontal offset, depth (negative) and piece (1 lip, 2 wall, 3 bottom) of the groove's
    cross-section at arc length ``s`` from its start: lip down, wall, half circle, wall, lip
    up (each piece a line or an arc, as :func:`pcgeom.synthetic_folds._curve`)."""
    zero = np.zeros_like(s)
    lengths = (np.pi * lip / 2, D, np.pi * g / 2, D, np.pi * lip / 2)
    kappas = (-1.0 / lip, zero, 2.0 / g, zero, -1.0 / lip)
    x, z, h, start = zero, zero, zero, zero
    out_x, out_z, piece = zero.copy(), zero.copy(), np.zeros(len(s), dtype=np.int64)
    for j, (length, kappa) in enumerate(zip(lengths, kappas)):
        t = s - start
        here = (t >= 0) & ((t < length) | (j == 4))
        xj, zj, _ = _advance(x, z, h, np.clip(t, 0, length), kappa)
        out_x[here], out_z[here], piece[here] = xj[here], zj[here], (1, 2, 3, 2, 1)[j]
        x, z, h = _advance(x, z, h, length, kappa)
        start = start + length
    return out_x, out_z, piece


def _embed(uv, sulci, sphere):
    """The surface point of each parameter point, with its sulcus, piece, gap and depth."""
    rho = np.hypot(uv[:, 0], uv[:, 1])
    theta = np.arctan2(uv[:, 1], uv[:, 0])
    n = len(uv)
    r3, z, shift = rho.copy(), np.zeros(n), np.zeros(n)
    sulcus, piece = np.full(n, -1, dtype=np.int64), np.zeros(n, dtype=np.int64)
    gap = np.full(n, np.nan)
    for i, sc in enumerate(sulci):
        D, g = sc.D(theta), sc.g(theta)
        L = np.pi * sc.lip + 2.0 * D + np.pi * g / 2.0
        start = sc.centre(theta) - L / 2
        inside = (rho >= start) & (rho < start + L)
        x, zz, pc = _profile(rho[inside] - start[inside], np.full(inside.sum(), sc.lip),
                             D[inside], g[inside])
        r3[inside] = start[inside] - shift[inside] + x
        z[inside] = zz
        sulcus[inside], piece[inside], gap[inside] = i, pc, g[inside]
        shift += np.where(rho >= start + L, L - (2 * sc.lip + g), 0.0)
    flat = sulcus < 0
    r3[flat] = rho[flat] - shift[flat]
    phi = r3 / sphere
    radial = sphere + z
    X = np.column_stack([radial * np.sin(phi) * np.cos(theta), radial * np.sin(phi)
                         * np.sin(theta), radial * np.cos(phi) - sphere])
    return X, sulcus, piece, gap, -z


def _frame(uv, sulci, sphere, eps=1e-5):
    """Points, their unit normals ``P_u x P_v`` and area elements ``|P_u x P_v|`` (forward
    differences in the parameters), and the labels of :func:`_embed`."""
    X, sulcus, piece, gap, depth = _embed(uv, sulci, sphere)
    du = _embed(uv + [eps, 0], sulci, sphere)[0] - X
    dv = _embed(uv + [0, eps], sulci, sphere)[0] - X
    cross = np.cross(du, dv) / (eps * eps)
    area = np.linalg.norm(cross, axis=1)
    return X, cross / area[:, None], area, sulcus, piece, gap, depth


def _layout(n: int, sulci: int, depth, gap, lip: float, meander: float, *, rng):
    """The sulci (centre lines out from a flat of 8 spacings, flats of at least 4 between)
    and the disk's radius that makes the surface's area ``n / POISSON_EDGE**2``."""
    out, edge = [], 8.0
    for _ in range(sulci):
        m1, m2 = int(rng.integers(3, 8)), int(rng.integers(8, 14))
        a2 = 0.25 * meander
        spec = _Sulcus(base=0.0, meander=(), lip=lip,
                       depth=(depth[0], depth[1], int(rng.integers(1, 4)),
                              float(rng.uniform(0, 2 * np.pi))),
                       gap=(gap[0], gap[1], int(rng.integers(2, 6)),
                            float(rng.uniform(0, 2 * np.pi))))
        half = spec.reach() + meander + a2
        base = edge + half
        # Keep the centre line's slope (a m / base) under about 0.6: a bend no tighter than
        # the lips' reach.
        a1 = min(meander, 0.6 * base / m1)
        a2 = min(a2, 0.15 * base / m2)
        out.append(dataclasses.replace(spec, base=base, meander=(
            (a1, m1, float(rng.uniform(0, 2 * np.pi))),
            (a2, m2, float(rng.uniform(0, 2 * np.pi))))))
        edge = base + half + 4.0
    target = n / POISSON_EDGE ** 2
    theta = np.linspace(-np.pi, np.pi, 181)[:-1] + np.pi / 180
    rho = np.arange(0.125, edge + 4 * np.sqrt(target), 0.25)
    total, radius = 0.0, None
    for r in np.array_split(rho, max(1, len(rho) // 40)):
        R, T = np.meshgrid(r, theta, indexing="ij")
        uv = np.column_stack([(R * np.cos(T)).ravel(), (R * np.sin(T)).ravel()])
        area = _frame(uv, out, 1e9)[2].reshape(R.shape) * R * 0.25 * (2 * np.pi / 180)
        cum = total + np.cumsum(area.sum(axis=1))
        if cum[-1] >= target:
            radius = float(r[np.searchsorted(cum, target)])
            break
        total = cum[-1]
    if radius is None or radius < edge:
        raise ValueError(f"n: {n} points leave no outer flat around {sulci} "
                         f"{'sulcus' if sulci == 1 else 'sulci'} (the "
                         f"disk needs a radius of at least {edge:.0f} spacings); ask for more "
                         "points or fewer, shallower sulci")
    return out, radius


def cortex_cap(n: int = 48000, *, sulci: int = 2, depth=(3.0, 12.0), gap=(0.5, 3.0),
               lip: float = 1.0, meander: float = 5.0, sampling: str = "uniform",
               seed: int = 0, shape: int = 0) -> Cortex:
    """A gently curved cap with ``sulci`` closed, meandering sulci whose depth and wall gap
    vary along their course.

    Parameters
    ----------
    n : int
        How many points, at least 1000.
    sulci : int
        How many sulci, nested from the centre out, >= 1.
    depth : (float, float)
        The walls' least and greatest length along each sulcus, in spacings (>= 0).
    gap : (float, float)
        The walls' least and greatest distance along each sulcus, in spacings (> 0).
    lip : float
        The lips' radius in spacings, > 0.
    meander : float
        The centre lines' main swing, in spacings (smaller where the sulcus is near the
        centre, so that no bend is tighter than a slope of 0.6), >= 0.
    sampling : {"uniform", "scan"}
    seed : int
        Seeds the sampling.
    shape : int
        Seeds the sulci's course (their swings' periods and phases).

    Raises
    ------
    ValueError
        A bad argument, or too few points for the sulci.
    """
    from scipy.spatial import Delaunay

    n = int(n)
    depth, gap = tuple(float(d) for d in depth), tuple(float(g) for g in gap)
    if n < 1000 or int(sulci) < 1:
        raise ValueError(f"n, sulci: expected at least 1000 points and 1 sulcus, got {n}, "
                         f"{sulci!r}")
    if not (0 <= depth[0] <= depth[1] and 0 < gap[0] <= gap[1] and lip > 0 and meander >= 0):
        raise ValueError(f"depth, gap, lip, meander: expected 0 <= lo <= hi, 0 < lo <= hi, "
                         f"> 0, >= 0, got {depth!r}, {gap!r}, {lip!r}, {meander!r}")
    if sampling not in SAMPLINGS:
        raise ValueError(f"sampling: expected one of {', '.join(SAMPLINGS)}, got {sampling!r}")
    sulci_, radius = _layout(n, int(sulci), depth, gap, float(lip), float(meander),
                             rng=np.random.default_rng(shape))
    sphere = 2.0 * radius
    rng = np.random.default_rng(seed)
    uv = np.empty((0, 2))
    labels, bound = None, None
    while len(uv) < n:  # rejection: density proportional to the area element (times the scan's)
        m = 3 * n
        r = radius * np.sqrt(rng.uniform(0, 1, m))
        t = rng.uniform(-np.pi, np.pi, m)
        cand = np.column_stack([r * np.cos(t), r * np.sin(t)])
        frame = _frame(cand, sulci_, sphere)
        if bound is None:  # the area element reaches about 1.8 where the lips shear
            bound = max(2.0, 1.1 * float(frame[2].max()))
        weight = frame[2] / bound
        if sampling == "scan":
            weight = weight * (0.25 + 0.75 * (cand[:, 0] + radius) / (2 * radius))
        keep = rng.uniform(0, 1, m) < weight
        uv = np.vstack([uv, cand[keep]])
        part = [f[keep] for f in frame]
        labels = part if labels is None else [np.concatenate([a, b]) for a, b in
                                              zip(labels, part)]
    uv = uv[:n]
    X, N, _, sulcus, piece, gap_, depth_ = (a[:n] for a in labels)
    F = Delaunay(uv).simplices.astype(np.int64)
    area2 = 2.0 * signed_areas(uv, F)
    F, area2 = F[np.abs(area2) > 1e-12], area2[np.abs(area2) > 1e-12]
    F[area2 < 0] = F[area2 < 0][:, ::-1]  # counter-clockwise in the disk: facing up
    F = peel_rim(np.column_stack([uv, np.zeros(n)]), F)[0]
    F = _surface_delaunay(X, uv, F)
    return Cortex(points=X, normals=N, faces=F, params=uv, spacing=mean_edge(X, F),
                  sulcus=sulcus, piece=piece, gap=gap_, depth=depth_)
