"""The unit sphere: the parameter domain of closed genus-0 surfaces."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from .base import Domain, check_count

__all__ = ["Sphere"]


def _as_points3d(P, name: str = "P") -> np.ndarray:
    P = np.asarray(P, dtype=np.float64)
    if P.ndim != 2 or P.shape[1] != 3:
        raise ValueError(f"{name}: expected shape (K, 3), got {P.shape}")
    return P


@dataclass(frozen=True)
class Sphere(Domain):
    """The unit sphere (closed genus-0 surfaces; a map is one unit vector per point)."""

    name: ClassVar[str] = "sphere"
    closed: ClassVar[bool] = True
    dim: ClassVar[int] = 3

    def sample(self, n: int, seed: int = 0) -> np.ndarray:
        """``n`` points of a Fibonacci lattice on the sphere, turned about the z axis by the
        golden angle times ``seed``: (n, 3) unit vectors."""
        n = check_count(n)
        golden = np.pi * (3.0 - np.sqrt(5.0))
        k = np.arange(n) + 0.5
        z = 1.0 - 2.0 * k / n
        r = np.sqrt(np.maximum(1.0 - z * z, 0.0))
        phi = golden * (np.arange(n) + seed)
        return np.column_stack([r * np.cos(phi), r * np.sin(phi), z])

    def boundary(self, n: int) -> np.ndarray:
        """No boundary: (0, 3)."""
        check_count(n)
        return np.zeros((0, 3))

    def boundary_loops(self) -> list[np.ndarray]:
        """No loops: ``[]``."""
        return []

    def contains(self, P) -> np.ndarray:
        """Points within 1e-9 of the unit sphere."""
        return np.abs(np.linalg.norm(_as_points3d(P), axis=1) - 1.0) <= 1e-9

    def signed_distance(self, P) -> np.ndarray:
        """``|p| - 1``: the distance to the sphere, negative inside the ball."""
        return np.linalg.norm(_as_points3d(P), axis=1) - 1.0

    @property
    def area(self) -> float:
        """``4 pi``."""
        return 4.0 * np.pi

    @property
    def centroid(self) -> np.ndarray:
        """The origin (3,): where a sphere map's area is centred."""
        return np.zeros(3)
