"""Domains whose region is a shapely polygon: generic sampling, boundary, containment, distance.

A subclass is a frozen dataclass holding its parameters; it builds its shapely ``Polygon`` or
``MultiPolygon`` once, in :meth:`ShapelyDomain._build_geometry`, and inherits every query from
shapely (containment, distance, area, centroid): no polygon arithmetic is written here.
"""

from __future__ import annotations

import abc
import functools
import math

import numpy as np
import shapely
from shapely.geometry.polygon import orient

from .base import Domain, as_points2d, check_count

__all__ = ["ShapelyDomain", "quasi_uniform_sample", "arc", "ARC_STEP"]

ARC_STEP = 2 * np.pi / 512
"""Largest angle (radians) between consecutive vertices of a circular arc made by :func:`arc`:
512 segments per full turn, a chord error of at most 1.9e-5 x radius."""

_PLASTIC = 1.32471795724474602596  # the real root of x^3 = x + 1
_R2_STEP = np.array([1.0 / _PLASTIC, 1.0 / _PLASTIC**2])  # (2,)


def arc(center, radius: float, start: float, stop: float) -> np.ndarray:
    """Vertices of a circular arc from angle ``start`` to ``stop`` (radians), both included.

    The direction follows the sign of ``stop - start`` (positive: counter-clockwise); the
    angular step is at most :data:`ARC_STEP`, and the number of segments is even, so the arc's
    midpoint (e.g. the tip of a bumper) is a vertex.

    Returns
    -------
    (k, 2) float64
    """
    segments = 2 * max(1, math.ceil(abs(stop - start) / (2 * ARC_STEP) - 1e-9))
    theta = np.linspace(start, stop, segments + 1)
    return np.asarray(center, dtype=np.float64) + radius * np.column_stack(
        [np.cos(theta), np.sin(theta)])


def quasi_uniform_sample(inside, bounds, area: float, n: int, seed: int = 0) -> np.ndarray:
    """The first ``n`` points of a shifted R2 sequence around ``bounds`` that ``inside`` keeps.

    The R2 sequence (Roberts 2018) is the additive recurrence
    ``x_k = frac(s + k (1/g, 1/g^2))`` with ``g`` the plastic number (``g^3 = g + 1``). Like
    Halton's, its prefixes have low discrepancy, so the kept points are area-uniform; unlike
    Halton's, neighbours stay apart: the nearest-neighbour distance measured on every built-in
    shape (n = 300 to 8192, seeds 0-3) is at least 0.55 x ``sqrt(area / n)`` (scrambled
    Halton: 0.1-0.2x; i.i.d. uniform: about 0.02x at n = 2000). The sequence covers the
    square around ``bounds``; ``s`` is drawn from ``seed``. Candidates are generated in
    growing chunks until ``n`` are kept; the result is the same prefix whatever the chunks,
    so a larger sample extends a smaller one.

    Parameters
    ----------
    inside : callable
        ``inside(P) -> (K,) bool`` for candidates ``P (K, 2)``: True strictly inside.
    bounds : (4,) float
        ``(xmin, ymin, xmax, ymax)`` of the region.
    area : float
        Area of the region (sizes the first chunk).
    n : int
        Number of points.
    seed : int
        Selects the shift ``s``.

    Returns
    -------
    (n, 2) float64
    """
    n = check_count(n)
    xmin, ymin, xmax, ymax = (float(b) for b in bounds)
    # The sequence fills the square around the bounding box: stretched to a long box, its
    # lattice-like structure would bring neighbours closer along the short side.
    side = max(xmax - xmin, ymax - ymin)
    low = np.array([xmin + xmax - side, ymin + ymax - side]) / 2
    shift = np.random.default_rng(seed).random(2)
    fraction = min(1.0, area / side**2)
    chunk = int(1.05 * n / fraction) + 64
    kept, count, start = [], 0, 0
    while count < n:
        k = np.arange(start, start + chunk, dtype=np.float64)[:, None]  # (chunk, 1)
        candidates = low + side * ((shift + k * _R2_STEP) % 1.0)  # (chunk, 2)
        keep = candidates[inside(candidates)]
        kept.append(keep)
        count += len(keep)
        start += chunk
        chunk *= 2
    return np.vstack(kept)[:n]


class ShapelyDomain(Domain):
    """A bounded domain whose region is a shapely (Multi)Polygon built from its parameters.

    Subclasses are frozen dataclasses; they validate their parameters in ``__post_init__``
    (``ValueError`` naming the parameter) and implement :meth:`_build_geometry`. The geometry
    is built once per instance, on first use, and cached in the instance's ``__dict__`` (a
    ``functools.cached_property``: it bypasses the frozen ``__setattr__`` and is not a
    dataclass field, so equality, hashing and :meth:`to_dict` see the parameters only).

    Containment and distances are those of the polygon; curved boundaries are polygons with
    vertices at most :data:`ARC_STEP` apart along each arc, unless a subclass overrides a
    query with an exact formula (as :class:`pcgeom.domains.Annulus` does).
    """

    @abc.abstractmethod
    def _build_geometry(self):
        """The region as a valid shapely ``Polygon`` or ``MultiPolygon`` of positive area."""

    @functools.cached_property
    def geometry(self):
        """The region: a shapely ``Polygon`` or ``MultiPolygon``, outer rings counter-clockwise
        and holes clockwise, prepared for fast repeated queries."""
        geom = self._build_geometry()
        if isinstance(geom, shapely.MultiPolygon):
            geom = shapely.MultiPolygon([orient(p, sign=1.0) for p in geom.geoms])
        else:
            geom = orient(geom, sign=1.0)
        shapely.prepare(geom)
        return geom

    @functools.cached_property
    def _outline(self):
        """The boundary as a prepared shapely (Multi)LineString, for distances."""
        outline = self.geometry.boundary
        shapely.prepare(outline)
        return outline

    @property
    def _tolerance(self) -> float:
        """Distance within which a point counts as on the boundary: 1e-12 x the region's size."""
        xmin, ymin, xmax, ymax = self.geometry.bounds
        return 1e-12 * max(xmax - xmin, ymax - ymin)

    def _interior(self, P: np.ndarray) -> np.ndarray:
        """(K,) bool: strictly inside (boundary points excluded); what :meth:`sample` keeps."""
        return shapely.contains_xy(self.geometry, P[:, 0], P[:, 1])

    def sample(self, n: int, seed: int = 0) -> np.ndarray:
        """Area-uniform points strictly inside the region, with no clumps.

        The first ``n`` points of a shifted R2 low-discrepancy sequence over the bounding box
        that fall strictly inside (:func:`quasi_uniform_sample`); ``seed`` selects the shift.

        Returns
        -------
        (n, 2) float64
        """
        return quasi_uniform_sample(self._interior, self.geometry.bounds, self.area, n, seed)

    def boundary_loops(self) -> list[np.ndarray]:
        """The polygon's rings: outer rings first (counter-clockwise), then holes (clockwise).

        Returns
        -------
        list of (k, 2) float64
            Each ring's last row repeats its first.
        """
        polygons = getattr(self.geometry, "geoms", [self.geometry])
        outer = [np.asarray(p.exterior.coords, dtype=np.float64) for p in polygons]
        holes = [np.asarray(r.coords, dtype=np.float64) for p in polygons for r in p.interiors]
        return outer + holes

    def boundary(self, n: int) -> np.ndarray:
        """``n`` points shared among the loops in proportion to their lengths, evenly spaced
        by arc length along each loop from its first vertex.

        Each loop gets ``n x length / total`` points rounded by largest remainder (so a short
        loop may get none when ``n`` is small); the loops are listed as in
        :meth:`boundary_loops`.

        Returns
        -------
        (n, 2) float64
        """
        n = check_count(n)
        lines = [shapely.LineString(loop) for loop in self.boundary_loops()]
        lengths = np.array([line.length for line in lines])
        counts = _largest_remainder(n * lengths / lengths.sum())
        parts = []
        for line, length, count in zip(lines, lengths, counts):
            if count:
                points = shapely.line_interpolate_point(line, length * np.arange(count) / count)
                parts.append(shapely.get_coordinates(points))
        return np.vstack(parts)

    def contains(self, P) -> np.ndarray:
        """Which points lie in the closed region (within 1e-12 x its size of it)."""
        P = as_points2d(P)
        return shapely.dwithin(self.geometry, shapely.points(P), self._tolerance)

    def signed_distance(self, P) -> np.ndarray:
        """Distance to the polygon's boundary, negative inside, positive outside.

        Parameters
        ----------
        P : (K, 2) array_like

        Returns
        -------
        (K,) float64
        """
        P = as_points2d(P)
        distance = shapely.distance(self._outline, shapely.points(P))
        return np.where(self._interior(P), -distance, distance)

    @property
    def area(self) -> float:
        """The polygon's area."""
        return float(self.geometry.area)

    @property
    def centroid(self) -> np.ndarray:
        """(2,) float64 area centroid of the polygon."""
        return np.asarray(self.geometry.centroid.coords[0], dtype=np.float64)


def _largest_remainder(shares: np.ndarray) -> np.ndarray:
    """Integers summing to ``round(shares.sum())``, each the floor of its share or one more:
    the largest fractional parts round up (ties to the earlier entry)."""
    counts = np.floor(shares).astype(np.int64)
    missing = int(round(shares.sum())) - int(counts.sum())
    order = np.argsort(-(shares - counts), kind="stable")
    counts[order[:missing]] += 1
    return counts
