"""Parameter domains: 2D regions the cloud is mapped onto, and their near-uniform samples.

A domain is looked up by name with :func:`get_domain`; ``"free"`` means no prescribed domain
(free boundary) and maps to None. New domains (square, polygon with holes, smiling face) are
added to :data:`DOMAINS`.
"""

from __future__ import annotations

import abc
from collections.abc import Callable
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

__all__ = ["Domain", "Disk", "DOMAINS", "get_domain"]

_GOLDEN_ANGLE = np.pi * (3.0 - np.sqrt(5.0))  # radians, about 2.39996


def _check_count(n, name: str = "n") -> int:
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)):
        raise TypeError(f"{name}: expected an int, got {type(n).__name__}")
    if n < 1:
        raise ValueError(f"{name}: expected a positive count, got {n}")
    return int(n)


class Domain(abc.ABC):
    """A bounded 2D region.

    Subclasses set ``name`` and implement :meth:`sample`, :meth:`boundary`, :meth:`contains` and
    :attr:`area`.
    """

    name: ClassVar[str]
    """Registry name, as accepted by :func:`get_domain`."""

    @abc.abstractmethod
    def sample(self, n: int, seed: int = 0) -> np.ndarray:
        """Near-uniform points covering the region (no random clumps).

        Parameters
        ----------
        n : int
            Number of points.
        seed : int
            Selects one of a family of equally good samples; the same seed gives the same
            points.

        Returns
        -------
        (n, 2) float64
            Points inside the region.
        """

    @abc.abstractmethod
    def boundary(self, n: int) -> np.ndarray:
        """Points on the boundary, evenly spaced by arc length, counter-clockwise.

        Returns
        -------
        (n, 2) float64
        """

    @abc.abstractmethod
    def contains(self, P) -> np.ndarray:
        """Which points lie in the closed region.

        Parameters
        ----------
        P : (K, 2) array_like

        Returns
        -------
        (K,) bool
        """

    @property
    @abc.abstractmethod
    def area(self) -> float:
        """Area of the region."""


@dataclass(frozen=True)
class Disk(Domain):
    """The disk ``|u - center| <= radius`` (the unit disk by default)."""

    center: tuple[float, float] = (0.0, 0.0)
    """Centre of the disk."""
    radius: float = 1.0
    """Radius, > 0."""

    name: ClassVar[str] = "disk"

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
        n = _check_count(n)
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
        n = _check_count(n)
        theta = 2 * np.pi * np.arange(n) / n
        return self.radius * np.column_stack([np.cos(theta), np.sin(theta)]) + np.asarray(
            self.center
        )

    def contains(self, P) -> np.ndarray:
        """``|P - center| <= radius`` up to a relative 1e-12 (boundary points count as inside).

        Parameters
        ----------
        P : (K, 2) array_like

        Returns
        -------
        (K,) bool
        """
        P = np.asarray(P, dtype=np.float64)
        if P.ndim != 2 or P.shape[1] != 2:
            raise ValueError(f"P: expected shape (K, 2), got {P.shape}")
        d = np.linalg.norm(P - np.asarray(self.center), axis=1)
        return d <= self.radius * (1 + 1e-12)

    @property
    def area(self) -> float:
        """``pi radius^2``."""
        return float(np.pi * self.radius**2)


DOMAINS: dict[str, Callable[[], Domain | None]] = {
    "free": lambda: None,
    "disk": Disk,
}
"""Registry: domain name -> factory. ``"free"`` (no prescribed domain) gives None."""


def get_domain(name: str) -> Domain | None:
    """The domain registered under ``name`` (see :data:`DOMAINS`).

    Parameters
    ----------
    name : str
        ``"free"`` (free boundary, returns None) or ``"disk"`` (unit disk).

    Raises
    ------
    TypeError
        ``name`` is not a string.
    ValueError
        Unknown name; the message lists the registered ones.
    """
    if not isinstance(name, str):
        raise TypeError(f"name: expected a domain name (str), got {type(name).__name__}")
    if name not in DOMAINS:
        raise ValueError(f"unknown domain {name!r}; choose one of: {', '.join(DOMAINS)}")
    return DOMAINS[name]()
