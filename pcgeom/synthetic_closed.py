"""Analytic closed surfaces with ground truth: genus-0 star-shaped shapes and a torus, sampled
the ways scanners sample (area-uniform, a jittered parameter grid, an uneven scan-like density),
with optional noise along the normals.

Each sample comes with its true triangulation (over the clean points, outward oriented) and
outward unit normals. The triangulation is used only to *evaluate* a map or a reconstruction,
never to make one. Genus-0 shapes are star-shaped about the origin, ``p = r(w) w`` for unit
directions ``w``, so the convex hull of the directions is a triangulation of the surface; the
torus is triangulated by a periodic Delaunay triangulation of its parameters, scaled by its
radii so that the triangles are nearly isotropic on the surface.

Noise is given in spacings: the mean edge length of the true triangles on the clean sample.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy.spatial import ConvexHull, Delaunay

from .errors import InputError
from .mesh import mean_edge, signed_areas

__all__ = ["ClosedSurface", "closed_surface", "SHAPES", "SAMPLINGS"]

SHAPES = ("sphere", "ellipsoid", "bumpy", "peanut", "torus")
"""Shape names: four genus-0 shapes (the unit sphere; an ellipsoid of semi-axes 1, 0.75, 0.5;
a sphere with six Gaussian bumps and dents of 10-20% of its radius; a peanut ``r = 0.6 + 0.5
x^2`` with a concave waist) and a torus of radii 1 and 0.4 (genus 1)."""

SAMPLINGS = ("uniform", "grid", "scan")
"""``uniform``: independent points, uniform by area. ``grid``: a jittered lattice on the
parameter domain (a Fibonacci lattice of directions for genus 0, a (u, v) grid for the torus),
so uniform in the parameter, not on the surface. ``scan``: uniform by area times a density that
falls from top to bottom by 6.7x, as a scanner looking down samples a statue."""

ELLIPSOID_AXES = (1.0, 0.75, 0.5)
TORUS_RADII = (1.0, 0.4)
# (amplitude, centre direction, width) of the bumpy sphere's Gaussian bumps and dents.
_BUMPS = (
    (0.20, (0.0, 0.0, 1.0), 0.45),
    (-0.12, (1.0, 0.0, 0.0), 0.40),
    (0.15, (0.0, 1.0, 0.2), 0.35),
    (0.12, (-0.6, -0.6, -0.5), 0.40),
    (-0.10, (0.3, -0.8, 0.5), 0.35),
    (0.18, (-0.2, 0.4, -0.9), 0.40),
)
# Finite-difference step of the normals of genus-0 shapes (relative to a unit radius).
_FD_STEP = 1e-6
# Lowest relative density of the "scan" sampling (at the bottom; 1 at the top).
_SCAN_FLOOR = 0.15
# Jitter of the "grid" sampling, in lattice spacings.
_GRID_JITTER = 0.25
# Candidates drawn per point still needed, per round of rejection sampling.
_OVERSAMPLE = 4


@dataclasses.dataclass(frozen=True)
class ClosedSurface:
    """What :func:`closed_surface` returns."""

    points: np.ndarray
    """(N, 3) float64: the sample, with noise when asked."""
    clean_points: np.ndarray
    """(N, 3) float64: the same points on the analytic surface, before noise."""
    normals: np.ndarray
    """(N, 3) float64 outward unit normals of the analytic surface at the clean points."""
    faces: np.ndarray
    """(M, 3) int64 true triangles over the points, counter-clockwise seen from outside; a
    closed, edge-manifold mesh of Euler characteristic ``2 - 2 genus``."""
    genus: int
    """0 for the star-shaped shapes, 1 for the torus."""
    spacing: float
    """Mean edge length of ``faces`` on the clean points: the unit of ``noise``."""
    name: str
    sampling: str


def _unit_rows(A: np.ndarray) -> np.ndarray:
    return A / np.linalg.norm(A, axis=1, keepdims=True)


def _radius(name: str, w: np.ndarray) -> np.ndarray:
    """``r(w)`` of a star-shaped genus-0 shape at unit directions ``w (n, 3)``."""
    if name == "sphere":
        return np.ones(len(w))
    if name == "ellipsoid":
        return 1.0 / np.sqrt(((w / np.array(ELLIPSOID_AXES)) ** 2).sum(axis=1))
    if name == "bumpy":
        r = np.ones(len(w))
        for a, c, width in _BUMPS:
            c = np.asarray(c) / np.linalg.norm(c)
            r += a * np.exp((w @ c - 1.0) / width**2)
        return r
    if name == "peanut":
        return 0.6 + 0.5 * w[:, 0] ** 2
    raise AssertionError(name)


def _star_normals(name: str, P: np.ndarray) -> np.ndarray:
    """Outward unit normals of ``|p| - r(p / |p|) = 0`` by central differences."""
    def implicit(Q):
        d = np.linalg.norm(Q, axis=1)
        return d - _radius(name, Q / d[:, None])

    grad = np.empty_like(P)
    for k in range(3):
        step = np.zeros(3)
        step[k] = _FD_STEP
        grad[:, k] = (implicit(P + step) - implicit(P - step)) / (2.0 * _FD_STEP)
    return _unit_rows(grad)


def _star_density(name: str, w: np.ndarray) -> np.ndarray:
    """Area per solid angle of ``p = r(w) w``: ``r^2 / (n . w)``."""
    P = _radius(name, w)[:, None] * w
    n = _star_normals(name, P)
    return _radius(name, w) ** 2 / np.einsum("ij,ij->i", n, w)


def _torus_point(u: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    R, r = TORUS_RADII
    ring = R + r * np.cos(v)
    P = np.column_stack([ring * np.cos(u), ring * np.sin(u), r * np.sin(v)])
    n = np.column_stack([np.cos(v) * np.cos(u), np.cos(v) * np.sin(u), np.sin(v)])
    return P, n


def _scan_factor(z: np.ndarray, top: float) -> np.ndarray:
    """The scan's relative density at height ``z`` of a shape reaching ``+-top``: 1 at the top,
    :data:`_SCAN_FLOOR` at the bottom."""
    t = np.clip((z / top + 1.0) / 2.0, 0.0, 1.0)
    return _SCAN_FLOOR + (1.0 - _SCAN_FLOOR) * t**2


def _rejection(n: int, draw, weight, rng: np.random.Generator) -> np.ndarray:
    """``n`` candidates of ``draw(m)`` kept with probability ``weight / max weight`` (the
    maximum over a large first batch, with a margin)."""
    probe = draw(max(20000, 4 * n))
    w_max = 1.05 * weight(probe).max()
    kept = []
    count = 0
    while count < n:
        cand = draw(_OVERSAMPLE * (n - count) + 64)
        ok = rng.uniform(size=len(cand)) * w_max < weight(cand)
        kept.append(cand[ok])
        count += int(ok.sum())
    return np.concatenate(kept)[:n]


def _sphere_directions(n: int, sampling: str, name: str, rng) -> np.ndarray:
    """(n, 3) unit directions whose images ``r(w) w`` have the asked density."""
    if sampling == "grid":
        k = np.arange(n) + 0.5
        z = 1.0 - 2.0 * k / n
        phi = np.pi * (1.0 + 5**0.5) * k
        s = np.sqrt(1.0 - z**2)
        w = np.column_stack([s * np.cos(phi), s * np.sin(phi), z])
        # Jitter in the tangent plane by a fraction of the lattice spacing.
        h = np.sqrt(4.0 * np.pi / n)
        return _unit_rows(w + rng.normal(scale=_GRID_JITTER * h / 2.0, size=w.shape))

    def draw(m):
        return _unit_rows(rng.normal(size=(m, 3)))

    top = _radius(name, np.array([[0.0, 0.0, 1.0]]))[0]

    def weight(w):
        dens = _star_density(name, w)
        if sampling == "scan":
            dens = dens * _scan_factor(_radius(name, w) * w[:, 2], top)
        return dens

    return _rejection(n, draw, weight, rng)


def _hull_faces(w: np.ndarray) -> np.ndarray:
    """The convex hull of unit directions, oriented outward: a triangulation of the sphere
    with every direction a vertex."""
    F = ConvexHull(w).simplices.astype(np.int64)
    A, B, C = w[F[:, 0]], w[F[:, 1]], w[F[:, 2]]
    inward = np.einsum("ij,ij->i", np.cross(B - A, C - A), A + B + C) < 0
    F[inward] = F[inward][:, [0, 2, 1]]
    return F


def _torus_params(n: int, sampling: str, rng) -> np.ndarray:
    """(n, 2) torus parameters (u, v) in [0, 2 pi)^2 with the asked density."""
    R, r = TORUS_RADII
    if sampling == "grid":
        rows = max(3, int(round(np.sqrt(n * r / R))))
        cols = int(np.ceil(n / rows))
        uu, vv = np.meshgrid((np.arange(cols) + 0.5) / cols, (np.arange(rows) + 0.5) / rows)
        uv = np.column_stack([uu.ravel(), vv.ravel()])[:n]
        uv = uv + rng.normal(scale=_GRID_JITTER / 2.0, size=uv.shape) / [cols, rows]
        return (uv % 1.0) * 2.0 * np.pi

    def draw(m):
        return rng.uniform(0.0, 2.0 * np.pi, size=(m, 2))

    def weight(uv):
        dens = R + r * np.cos(uv[:, 1])
        if sampling == "scan":
            dens = dens * _scan_factor(r * np.sin(uv[:, 1]), r)
        return dens

    return _rejection(n, draw, weight, rng)


def _torus_faces(uv: np.ndarray) -> np.ndarray:
    """Periodic Delaunay triangulation of torus parameters scaled by the radii: the plane
    tiled 3 x 3, and each triangle kept once, from the tile holding its centroid."""
    R, r = TORUS_RADII
    period = np.array([2.0 * np.pi * R, 2.0 * np.pi * r])
    Q = uv * np.array([R, r])
    n = len(Q)
    shifts = np.array([(i, j) for i in (-1, 0, 1) for j in (-1, 0, 1)], dtype=float)
    tiled = (Q[None, :, :] + shifts[:, None, :] * period).reshape(-1, 2)
    T = Delaunay(tiled).simplices
    centroid = tiled[T].mean(axis=1)
    inside = ((centroid >= 0.0) & (centroid < period)).all(axis=1)
    T = T[inside]
    ccw = signed_areas(tiled, T) > 0
    T[~ccw] = T[~ccw][:, [0, 2, 1]]
    return (T % n).astype(np.int64)


def closed_surface(name: str = "ellipsoid", n: int = 5000, *, sampling: str = "uniform",
                   noise: float = 0.0, seed: int = 0) -> ClosedSurface:
    """A sample of an analytic closed surface with its true triangulation.

    Parameters
    ----------
    name : one of :data:`SHAPES`.
    n : number of points (at least 100).
    sampling : one of :data:`SAMPLINGS`.
    noise : standard deviation of Gaussian noise along the true normals, in spacings (the
        mean true edge length), ``>= 0``.
    seed : seeds the sampling and the noise; the same arguments give the same surface.

    Returns
    -------
    ClosedSurface
        points, clean points, outward normals, true faces (Euler characteristic ``2 - 2
        genus``), genus, spacing.
    """
    if name not in SHAPES:
        raise InputError(f"closed_surface: unknown shape {name!r}; expected one of "
                         f"{', '.join(SHAPES)}")
    if sampling not in SAMPLINGS:
        raise InputError(f"closed_surface: unknown sampling {sampling!r}; expected one of "
                         f"{', '.join(SAMPLINGS)}")
    if int(n) != n or n < 100:
        raise InputError(f"closed_surface: n must be an integer >= 100, got {n!r}")
    if not (np.isfinite(noise) and noise >= 0.0):
        raise InputError(f"closed_surface: noise must be a number >= 0, got {noise!r}")
    n = int(n)
    rng = np.random.default_rng(seed)
    if name == "torus":
        uv = _torus_params(n, sampling, rng)
        clean, normals = _torus_point(uv[:, 0], uv[:, 1])
        faces = _torus_faces(uv)
        genus = 1
    else:
        w = _sphere_directions(n, sampling, name, rng)
        clean = _radius(name, w)[:, None] * w
        normals = _star_normals(name, clean)
        faces = _hull_faces(w)
        genus = 0
    spacing = mean_edge(clean, faces)
    points = clean + rng.normal(scale=noise * spacing, size=n)[:, None] * normals
    return ClosedSurface(points=points, clean_points=clean, normals=normals, faces=faces,
                         genus=genus, spacing=spacing, name=name, sampling=sampling)
