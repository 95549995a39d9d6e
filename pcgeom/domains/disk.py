"""The disk domain (the paper's default parameter domain)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from .base import Domain, as_points2d, check_count

__all__ = ["Disk"]

_GOLDEN_ANGLE = np.pi * (3.0 - np.sqrt(5.0))  # radians, about 2.39996
CIRCLE_SEGMENTS = 512
"""Segments of a full circle in :meth:`Disk.boundary_loops` (chord error 1.9e-5 x radius)."""


@dataclass(frozen=True)
class Disk(Domain):
    """The disk |u - center| <= radius (the unit disk by default)."""

    center: tuple[float, float] = (0.0, 0.0)
    """Centre of the disk."""
    radius: float = 1.0
    """Radius, > 0."""

    name: ClassVar[str] = "disk"
    spec_args: ClassVar[tuple[str, ...]] = ("radius",)

    def __post_init__(self) -> None:
        c = np.asarray(self.center, dtype=np.float64)
        if c.shape != (2,) or not np.isfinite(c).all():
            raise ValueError(f"center: expected two finite numbers, got {self.center!r}")
        if not (np.isfinite(self.radius) and self.radius > 0):
            raise ValueError(f"radius: expected a positive finite number, got {self.radius!r}")

    def sample(self, n: int, seed: int = 0) -> np.ndarray:
        """Vogel (sunflower) spiral: ``r_k = R sqrt((k + 1/2) / n)``, ``theta_k = k g + phi``.

        ``g`` is the golden angle; each point owns an equal area ``pi R^2 / n``, so the sample
        is near-uniform with no clumps. ``phi`` is a rotation drawn from ``seed`` (0 for seed 0).

        Returns
        -------
        (n, 2) float64
            Points strictly inside the disk.
        """
        n = check_count(n)
        phase = 0.0 if seed == 0 else float(np.random.default_rng(seed).uniform(0.0, 2 * np.pi))
        k = np.arange(n, dtype=np.float64)
        r = self.radius * np.sqrt((k + 0.5) / n)
        theta = k * _GOLDEN_ANGLE + phase
        return np.column_stack([r * np.cos(theta), r * np.sin(theta)]) + np.asarray(self.center)

    def boundary(self, n: int) -> np.ndarray:
        """``n`` points on the circle at angles ``2 pi k / n``, counter-clockwise from +x.

        Returns
        -------
        (n, 2) float64
        """
        n = check_count(n)
        theta = 2 * np.pi * np.arange(n) / n
        return self.radius * np.column_stack([np.cos(theta), np.sin(theta)]) + np.asarray(
            self.center
        )

    def boundary_loops(self) -> list[np.ndarray]:
        """The circle as one closed polyline of :data:`CIRCLE_SEGMENTS` segments, counter-clockwise.

        Returns
        -------
        list of one (CIRCLE_SEGMENTS + 1, 2) float64
            Vertices on the circle; the last row repeats the first.
        """
        loop = self.boundary(CIRCLE_SEGMENTS)
        return [np.vstack([loop, loop[:1]])]

    def contains(self, P) -> np.ndarray:
        """``|P - center| <= radius`` up to a relative 1e-12 (boundary points count as inside)."""
        P = as_points2d(P)
        d = np.linalg.norm(P - np.asarray(self.center), axis=1)
        return d <= self.radius * (1 + 1e-12)

    def signed_distance(self, P) -> np.ndarray:
        """``|P - center| - radius``: negative inside, positive outside.

        Parameters
        ----------
        P : (K, 2) array_like

        Returns
        -------
        (K,) float64
        """
        P = as_points2d(P)
        return np.linalg.norm(P - np.asarray(self.center), axis=1) - self.radius

    @property
    def area(self) -> float:
        """``pi radius^2``."""
        return float(np.pi * self.radius**2)

    @property
    def centroid(self) -> np.ndarray:
        """The centre."""
        return np.asarray(self.center, dtype=np.float64)
