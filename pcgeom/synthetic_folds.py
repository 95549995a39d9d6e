"""A sheet with deep, narrow grooves (sulci), isometric to a rectangle: the test surface of the
normal estimate where two sheets face each other a spacing or two apart (issue 39).

The cross-section is a curve in the xz-plane parametrised by arc length, extruded along y: flat
stretches, and between them grooves, each a rounded lip turning down, a straight wall, a half
circle at the bottom and the facing wall back up, ``gap`` spacings from the first. The surface
is developable, so its parameters (arc length, y) are an exact map of it, and its true
triangles are their Delaunay triangles (less the slivers along the sides).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .mesh import mean_edge, peel_rim, signed_areas

__all__ = ["DeepFolds", "deep_folds"]

SAMPLINGS = ("even", "uniform")
"""How :func:`deep_folds` samples its rectangle: a jittered R2 sequence, or uniform random."""


@dataclasses.dataclass(frozen=True)
class DeepFolds:
    """What :func:`deep_folds` returns."""

    points: np.ndarray
    """(N, 3) float64 points on the surface (no noise)."""
    normals: np.ndarray
    """(N, 3) float64 unit normals, +z on the flats (so on a groove's walls they face each
    other)."""
    faces: np.ndarray
    """(M, 3) int64 true triangles: the Delaunay triangles of ``uv_true``, counter-clockwise
    there, less the slivers along the rectangle's sides (an angle over
    :data:`pcgeom.mesh.RIM_ANGLE_DEG` opposite a side, peeled as :func:`pcgeom.mesh.peel_rim`
    does). Uniformly random points leave the convex hull's slivers there, up to the whole
    side long: 6000 points, 267 of 11979 triangles, whose chords cross the grooves' mouths,
    so that the exact map itself read 0.0101 rad on them (0.0066 without; walls 1.5
    spacings apart) and a map turned over 0.93% of them where it turns over 0.44% of the
    rest. Evenly sampled sides leave 4-9. Used to evaluate a map, never to make one."""
    uv_true: np.ndarray
    """(N, 2) float64 arc length across the grooves and y: an exact (isometric) map."""
    spacing: float
    """Mean edge length of the Delaunay triangles of ``uv_true`` (the rim's slivers
    included): the unit of ``gap``, ``depths`` and ``lip``."""
    gap: float
    """Distance between a groove's walls, in spacings."""
    groove: np.ndarray
    """(N,) int64: the groove (0, 1, ...) a point lies in, below the flats; -1 on a flat."""


def _pieces(gap: float, depths, lip: float, flat: float) -> list[tuple[float, float]]:
    """(length, curvature) of the curve's pieces, in spacings: flat, then for each groove a lip
    (a quarter turn down), a wall, the bottom (a half turn), the wall up, a lip, a flat."""
    out = [(flat, 0.0)]
    for depth in depths:
        out += [(np.pi * lip / 2, -1.0 / lip), (depth, 0.0), (np.pi * gap / 2, 2.0 / gap),
                (depth, 0.0), (np.pi * lip / 2, -1.0 / lip), (flat, 0.0)]
    return out


def _curve(s: np.ndarray, pieces) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points (x, z), unit normals and piece index of the curve at arc lengths ``s``: each
    piece a line or a circular arc (constant curvature), starting at the origin along +x."""
    starts = np.concatenate([[0.0], np.cumsum([p[0] for p in pieces])])
    piece = np.clip(np.searchsorted(starts, s, side="right") - 1, 0, len(pieces) - 1)
    x0, z0, h0 = [0.0], [0.0], [0.0]
    for length, kappa in pieces:  # each piece's start point and heading
        x, z, h = _advance(x0[-1], z0[-1], h0[-1], length, kappa)
        x0.append(x)
        z0.append(z)
        h0.append(h)
    x0, z0, h0 = np.array(x0), np.array(z0), np.array(h0)
    kappa = np.array([p[1] for p in pieces])[piece]
    x, z, h = _advance(x0[piece], z0[piece], h0[piece], s - starts[piece], kappa)
    normal = np.column_stack([-np.sin(h), np.cos(h)])  # the tangent turned a quarter left
    return np.column_stack([x, z]), normal, piece


def _advance(x, z, h, t, kappa):
    """Where a curve of constant curvature ``kappa`` from ``(x, z)`` at heading ``h`` is after
    arc length ``t``: ``(x, z, heading)``."""
    x, z, h, t, kappa = np.broadcast_arrays(*(np.asarray(a, dtype=np.float64)
                                              for a in (x, z, h, t, kappa)))
    straight = np.abs(kappa) < 1e-12
    k = np.where(straight, 1.0, kappa)
    h1 = h + kappa * t
    dx = np.where(straight, t * np.cos(h), (np.sin(h1) - np.sin(h)) / k)
    dz = np.where(straight, t * np.sin(h), (np.cos(h) - np.cos(h1)) / k)
    return x + dx, z + dz, h1


def deep_folds(n: int = 6000, *, gap: float = 1.5, depths=(3.0, 6.0, 10.0), lip: float = 1.0,
               width: float = 0.5, sampling: str = "even", seed: int = 0) -> DeepFolds:
    """A sheet with grooves whose walls lie ``gap`` spacings apart, ``depths`` spacings deep.

    Each groove: a lip (a quarter circle of radius ``lip`` spacings) turning down, a straight
    wall of ``depth`` spacings, a half circle of diameter ``gap`` at the bottom, the facing
    wall and lip back up; equal flats before, between and after. The rectangle of arc length
    ``[0, 1]`` by ``[0, width]`` is sampled (``"even"``: a jittered R2 sequence, its sides
    evenly; ``"uniform"``: uniform random, as uneven as a scan gets) and triangulated there.

    Parameters
    ----------
    n : int
        About how many points, at least 500.
    gap : float
        The walls' distance in spacings (the true triangles' mean edge), > 0.
    depths : sequence of float
        Each groove's wall length in spacings, >= 0; one groove each.
    lip : float
        The lips' radius in spacings, > 0.
    width : float
        The extent along the grooves (the arc length across them is 1), > 0.
    sampling : {"even", "uniform"}
    seed : int

    Raises
    ------
    ValueError
        A bad argument, or grooves that leave flats shorter than 3 spacings (ask for more
        points or fewer, shallower grooves).
    """
    from scipy.spatial import Delaunay

    from .synthetic import even_rectangle

    n = int(n)
    depths = tuple(float(d) for d in depths)
    if n < 500:
        raise ValueError(f"n: expected at least 500 points, got {n}")
    if not (gap > 0 and lip > 0 and width > 0):
        raise ValueError(f"gap, lip, width: expected numbers > 0, got {gap!r}, {lip!r}, "
                         f"{width!r}")
    if not depths or min(depths) < 0:
        raise ValueError(f"depths: expected one or more numbers >= 0, got {depths!r}")
    if sampling not in SAMPLINGS:
        raise ValueError(f"sampling: expected one of {', '.join(SAMPLINGS)}, got {sampling!r}")
    rng = np.random.default_rng(seed)
    if sampling == "even":
        rim, inside = even_rectangle(n, width, rng)
        uv = np.vstack([inside, rim])
    else:
        uv = rng.uniform([0.0, 0.0], [1.0, width], (n, 2))
    F = Delaunay(uv).simplices.astype(np.int64)
    area2 = 2.0 * signed_areas(uv, F)
    keep = np.abs(area2) > 1e-12 * width
    F, area2 = F[keep], area2[keep]
    F[area2 < 0] = F[area2 < 0][:, ::-1]
    spacing = mean_edge(np.column_stack([uv, np.zeros(len(uv))]), F)
    # The convex hull's slivers along the rectangle's sides are no triangles of the surface.
    F = peel_rim(np.column_stack([uv, np.zeros(len(uv))]), F)[0]
    grooves = sum(np.pi * lip + 2 * d + np.pi * gap / 2 for d in depths)
    flat = (1.0 / spacing - grooves) / (len(depths) + 1)
    if flat < 3.0:
        raise ValueError(f"depths: grooves of {grooves:.0f} spacings leave flats of "
                         f"{flat:.1f} (< 3) in a sheet {1.0 / spacing:.0f} spacings across; "
                         f"ask for more points or fewer, shallower grooves")
    pieces = _pieces(gap, depths, lip, flat)
    xz, nxz, piece = _curve(uv[:, 0] / spacing, pieces)
    points = np.column_stack([xz[:, 0] * spacing, uv[:, 1], xz[:, 1] * spacing])
    normals = np.column_stack([nxz[:, 0], np.zeros(len(uv)), nxz[:, 1]])
    groove = np.where(piece % 6 == 0, -1, (piece - 1) // 6)
    return DeepFolds(points=points, normals=normals, faces=F, uv_true=uv, spacing=spacing,
                     gap=float(gap), groove=groove.astype(np.int64))
