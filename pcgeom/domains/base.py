"""The parameter-domain interface: what training, evaluation and figures need of a 2D region."""

from __future__ import annotations

import abc
import dataclasses
from typing import ClassVar

import numpy as np

__all__ = ["Domain", "check_count", "as_points2d", "CORNER_DEG"]

CORNER_DEG = 15.0
"""A vertex of a domain's boundary ring where the ring turns by more than this (degrees) is a
corner: the Riemann map sends a rim point of the cloud exactly onto it
(:func:`pcgeom.maps.riemann.snap_corners`), and a domain's mesh keeps it when its rings are
resampled to the element size (:func:`pcgeom.apps.reconstruct.mesh_domain`)."""


def check_count(n, name: str = "n") -> int:
    """``n`` as a positive int, or ``TypeError`` / ``ValueError`` naming ``name``."""
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)):
        raise TypeError(f"{name}: expected an int, got {type(n).__name__}")
    if n < 1:
        raise ValueError(f"{name}: expected a positive count, got {n}")
    return int(n)


def as_points2d(P, name: str = "P") -> np.ndarray:
    """``P`` as a (K, 2) float64 array, or a ``ValueError`` naming ``name``."""
    P = np.asarray(P, dtype=np.float64)
    if P.ndim != 2 or P.shape[1] != 2:
        raise ValueError(f"{name}: expected shape (K, 2), got {P.shape}")
    return P


class Domain(abc.ABC):
    """A 2D parameter domain, constructed with its parameters (subclasses are frozen dataclasses).

    A bounded domain (``bounded = True``) is a region the cloud is pulled onto by HAND; the
    free boundary (:class:`pcgeom.domains.FreeBoundary`) is the one unbounded domain: no
    region, no HAND term, the map's boundary is whatever LEG makes of it.

    Subclasses set ``name`` (the registry name of :func:`pcgeom.domains.get_domain`) and
    ``spec_args`` (the fields that the short spec ``"name:a,b"`` sets, in order), and implement
    :meth:`sample`, :meth:`boundary`, :meth:`boundary_loops`, :meth:`contains`,
    :meth:`signed_distance`, :attr:`area` and :attr:`centroid`. The first line of a subclass's
    docstring is its one-line description in ``pcgeom domains``.
    """

    name: ClassVar[str]
    """Registry name, as accepted by :func:`pcgeom.domains.get_domain`."""
    spec_args: ClassVar[tuple[str, ...]] = ()
    """Fields set, in this order, by the values of a spec string ``"name:v1,v2"``."""
    bounded: ClassVar[bool] = True
    """False only for the free boundary: no region to sample, no HAND term."""
    closed: ClassVar[bool] = False
    """True only for the sphere (:class:`pcgeom.domains.Sphere`): a closed surface, whose
    maps hold one unit vector per point, ``(N, 3)``, and which has no boundary."""
    dim: ClassVar[int] = 2
    """Coordinates of a point of the domain: 2, or 3 for the sphere."""

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
        """Points on the boundary, evenly spaced by arc length along each boundary loop.

        The ``n`` points are shared among the loops of :meth:`boundary_loops` in proportion to
        their lengths and listed loop by loop in the same order: the outer loop first,
        counter-clockwise, then the holes, clockwise (the region is on the left).

        Returns
        -------
        (n, 2) float64
        """

    @abc.abstractmethod
    def boundary_loops(self) -> list[np.ndarray]:
        """The boundary as closed polylines, one per loop.

        Returns
        -------
        list of (k, 2) float64
            Each loop's last row repeats its first. The outer loop comes first,
            counter-clockwise, then the holes, clockwise. Empty for the free boundary.
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

    @abc.abstractmethod
    def signed_distance(self, P) -> np.ndarray:
        """Euclidean distance to the boundary, negative inside the region, positive outside.

        Parameters
        ----------
        P : (K, 2) array_like

        Returns
        -------
        (K,) float64
            0 on the boundary.
        """

    @property
    @abc.abstractmethod
    def area(self) -> float:
        """Area of the region."""

    @property
    @abc.abstractmethod
    def centroid(self) -> np.ndarray:
        """(2,) float64 area centroid; the initial plane map is centred there."""

    def to_dict(self) -> dict:
        """``{"name": ..., **parameters}``, plain JSON data; ``get_domain`` inverts it."""
        params = {f.name: _plain(getattr(self, f.name)) for f in dataclasses.fields(self)}
        return {"name": self.name, **params}

    @property
    def spec(self) -> str:
        """A short description that :func:`pcgeom.domains.get_domain` accepts back.

        ``"disk"`` for default parameters, ``"name:v1,v2"`` when only ``spec_args`` differ from
        their defaults, otherwise the JSON of :meth:`to_dict`.
        """
        import json

        changed = [f.name for f in dataclasses.fields(self)
                   if _plain(getattr(self, f.name)) != _plain(f.default)]
        if not changed:
            return self.name
        if set(changed) <= set(self.spec_args):
            last = max(self.spec_args.index(c) for c in changed)
            values = [repr(float(getattr(self, a))) for a in self.spec_args[: last + 1]]
            return f"{self.name}:{','.join(values)}"
        return json.dumps(self.to_dict())

    @property
    def label(self) -> str:
        """A name for people: :attr:`spec` when it is short, else the domain's name and size
        (a polygon's spec holds all its coordinates)."""
        spec = self.spec
        return spec if len(spec) <= LABEL_LIMIT else self._long_label()

    def _long_label(self) -> str:
        return self.name


LABEL_LIMIT = 40
"""The longest :attr:`Domain.spec` that :attr:`Domain.label` shows as it is."""


def _plain(value):
    """Tuples and NumPy scalars as JSON-friendly lists and floats (for specs and comparisons)."""
    if isinstance(value, (tuple, list, np.ndarray)):
        return [_plain(v) for v in value]
    if isinstance(value, (np.floating, np.integer)):
        return value.item()
    return value
