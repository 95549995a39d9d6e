"""The free boundary: no prescribed region; the map's boundary is left to LEG."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from .base import Domain, as_points2d, check_count

__all__ = ["FreeBoundary"]


@dataclass(frozen=True)
class FreeBoundary(Domain):
    """No parameter domain: the free-boundary map (LEG only, no HAND term).

    It has no region: :meth:`sample` and :meth:`boundary` return no points, every point is
    contained, and the area is infinite. Training checks :attr:`bounded` once, when it builds
    its objective.
    """

    name: ClassVar[str] = "free"
    bounded: ClassVar[bool] = False

    def sample(self, n: int, seed: int = 0) -> np.ndarray:
        """No points: (0, 2)."""
        check_count(n)
        return np.zeros((0, 2))

    def boundary(self, n: int) -> np.ndarray:
        """No points: (0, 2)."""
        check_count(n)
        return np.zeros((0, 2))

    def boundary_loops(self) -> list[np.ndarray]:
        """No loops: ``[]``."""
        return []

    def contains(self, P) -> np.ndarray:
        """Every point."""
        return np.ones(len(as_points2d(P)), dtype=bool)

    def signed_distance(self, P) -> np.ndarray:
        """Not defined: raises ``ValueError`` (the free boundary has no region)."""
        as_points2d(P)
        raise ValueError("domain 'free': no region, hence no signed distance; "
                         "choose a bounded domain (e.g. disk)")

    @property
    def area(self) -> float:
        """Infinite."""
        return float("inf")

    @property
    def centroid(self) -> np.ndarray:
        """The origin (where the plane map of a normalized cloud is centred)."""
        return np.zeros(2)
