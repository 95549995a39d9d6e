"""A user polygon with holes: given by its coordinates, read from a GeoJSON-style file, or
traced from a binary image mask."""

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

    def _long_label(self) -> str:
        n = len(self.shell) + sum(len(h) for h in self.holes)
        holes = len(self.holes)
        return (f"polygon of {n} vertices" if not holes else
                f"polygon of {n} vertices with {holes} hole{'s' if holes > 1 else ''}")

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

    @classmethod
    def from_mask(cls, path, size: float = 2.0) -> PolygonDomain:
        """The region of a binary image mask: its white pixels, as a polygon with holes.

        The image (any format Pillow reads: PNG, BMP, TIFF, JPEG...) is read as greyscale;
        pixels above 127 are the region. Its outline is the level-0.5 contour between pixel
        centres (contourpy's filled contours, marching squares), simplified by a quarter of a
        pixel (shapely, topology kept), with y pointing up, centred on the bounding box and
        scaled so that the box's longer side is ``size``. The polygon is stored as
        coordinates, so a results file rebuilds it without the image.

        Raises
        ------
        InputError
            One line naming the file: unreadable, no region pixel, or a region of several
            separate parts (a domain must be one region).
        """
        import contourpy
        from PIL import Image, UnidentifiedImageError

        name = os.fspath(path)
        try:
            with Image.open(name) as image:
                mask = np.asarray(image.convert("L")) > 127  # (rows, cols)
        except FileNotFoundError:
            raise InputError(f"{name}: no such file") from None
        except (OSError, UnidentifiedImageError, ValueError) as exc:
            raise InputError(f"{name}: cannot read the image mask: "
                             f"{' '.join(str(exc).split())}") from None
        if not mask.any():
            raise InputError(f"{name}: the mask has no region pixel (white, above 127 in grey)")
        z = np.pad(mask, 1).astype(np.float64)  # a dark border closes regions at the edge
        generator = contourpy.contour_generator(z=z, fill_type=contourpy.FillType.OuterOffset)
        points, offsets = generator.filled(0.5, 1.5)
        polygons = []
        for P, cut in zip(points, offsets):
            rings = [P[a:b] * [1.0, -1.0] for a, b in zip(cut[:-1], cut[1:])]  # y up
            polygons.append(shapely.Polygon(rings[0], rings[1:]))
        if len(polygons) > 1:
            raise InputError(f"{name}: the mask has {len(polygons)} separate regions; a domain "
                             "must be one region (join them or keep one)")
        region = shapely.simplify(polygons[0], 0.25, preserve_topology=True)
        xmin, ymin, xmax, ymax = region.bounds
        scale = size / max(xmax - xmin, ymax - ymin)
        center = np.array([xmin + xmax, ymin + ymax]) / 2

        def ring(coords):
            return (np.asarray(coords)[:-1] - center) * scale

        try:
            return cls(shell=ring(region.exterior.coords),
                       holes=tuple(ring(r.coords) for r in region.interiors))
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
