"""A user polygon with holes, given by its coordinates or read from a GeoJSON-style file."""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
import shapely
from shapely.validation import explain_validity

from ..errors import InputError
from .region import ShapelyDomain

__all__ = ["PolygonDomain"]

Ring = tuple[tuple[float, float], ...]


@dataclass(frozen=True)
class PolygonDomain(ShapelyDomain):
    """A polygon with holes from PATH.json: {"type": "Polygon", "coordinates": [outer, holes...]}.

    The coordinates are the domain's parameters, so :meth:`to_dict` (what a results file
    stores) holds them and :func:`pcgeom.domains.get_domain` rebuilds the domain without the
    file. Rings are stored as tuples of ``(x, y)`` float pairs without the closing vertex
    (GeoJSON repeats the first vertex last; either form is accepted). Orientation is free.
    """

    shell: Ring = ()
    """Outer ring: at least 3 distinct ``(x, y)`` vertices."""
    holes: tuple[Ring, ...] = ()
    """Hole rings, each inside the shell, at least 3 distinct vertices."""

    name: ClassVar[str] = "polygon"

    def __post_init__(self) -> None:
        # Plain tuples of floats, whatever arrived (lists from JSON, arrays): the dataclass
        # stays hashable and equal to its round trip through to_dict.
        if isinstance(self.shell, (tuple, list)) and len(self.shell) == 0:
            raise ValueError("no vertices; give the polygon as a GeoJSON file, PATH.json")
        object.__setattr__(self, "shell", _ring(self.shell, "outer ring"))
        if not isinstance(self.holes, (tuple, list)):
            raise ValueError(f"holes: expected a list of rings, got {type(self.holes).__name__}")
        object.__setattr__(self, "holes", tuple(
            _ring(h, f"hole {i + 1}") for i, h in enumerate(self.holes)))
        geom = shapely.Polygon(self.shell, self.holes)
        if not geom.is_valid:
            raise ValueError(f"polygon is not valid: {explain_validity(geom)}")

    def _build_geometry(self):
        return shapely.Polygon(self.shell, self.holes)

    @classmethod
    def from_json(cls, path) -> PolygonDomain:
        """Read a polygon with holes from a GeoJSON-style file.

        Accepted: ``{"type": "Polygon", "coordinates": [outer_ring, hole_ring, ...]}``, the
        same without ``"type"``, or a GeoJSON ``Feature`` whose ``"geometry"`` is one of them.
        A ring is a list of ``[x, y]`` pairs.

        Raises
        ------
        InputError
            One line naming the file: unreadable, not JSON, wrong structure, a ring with fewer
            than 3 distinct vertices or with zero area, a self-intersection or a hole outside
            the shell (shapely's reason).
        """
        from ..io.atomic import read_json

        name = os.fspath(path)
        data = read_json(path, "domain polygon")
        rings = _coordinates(data, name)
        try:
            return cls(shell=rings[0], holes=tuple(rings[1:]))
        except (TypeError, ValueError) as exc:
            raise InputError(f"{name}: {' '.join(str(exc).split())}") from None


_STRUCTURE = ('expected a GeoJSON Polygon '
              '{"type": "Polygon", "coordinates": [outer ring, hole rings...]}')


def _coordinates(data, name: str) -> list:
    """The list of rings in a parsed GeoJSON-style document, or an ``InputError``."""
    if isinstance(data, dict) and data.get("type") == "Feature":
        data = data.get("geometry")
    if not isinstance(data, dict) or "coordinates" not in data:
        got = "an object without 'coordinates'" if isinstance(data, dict) else type(data).__name__
        raise InputError(f"{name}: {_STRUCTURE}, got {got}")
    kind = data.get("type", "Polygon")
    if kind != "Polygon":
        raise InputError(f"{name}: {_STRUCTURE}, got type {kind!r}")
    rings = data["coordinates"]
    if not isinstance(rings, list) or not rings:
        raise InputError(f"{name}: {_STRUCTURE}, got coordinates {_short(rings)}")
    return rings


def _short(value, limit: int = 60) -> str:
    text = json.dumps(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _ring(ring, label: str) -> Ring:
    """``ring`` as a tuple of ``(x, y)`` float pairs without a closing repeat, or a
    ``ValueError`` naming ``label``: not (k, 2) numbers, non-finite, fewer than 3 distinct
    vertices, or all on one line (zero area)."""
    try:
        P = np.asarray(ring, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{label}: expected a list of [x, y] pairs") from None
    if P.ndim != 2 or P.shape[1] != 2:
        raise ValueError(f"{label}: expected a list of [x, y] pairs, got shape {P.shape}")
    if not np.isfinite(P).all():
        raise ValueError(f"{label}: contains NaN or inf")
    if len(P) > 1 and np.array_equal(P[0], P[-1]):
        P = P[:-1]
    distinct = len(np.unique(P, axis=0))
    if distinct < 3:
        raise ValueError(f"{label}: {distinct} distinct vertices, need at least 3")
    hull = shapely.MultiPoint(P).convex_hull
    extent = float(np.ptp(P, axis=0).max())
    if hull.area <= 1e-12 * extent**2:
        raise ValueError(f"{label}: zero area (its vertices lie on one line)")
    return tuple((float(x), float(y)) for x, y in P)
