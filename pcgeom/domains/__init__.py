"""Parameter domains: 2D regions the cloud is mapped onto, looked up by a spec.

A spec is a name (``"free"``, ``"disk"``, ``"smile"``, ``"sphere"``: the one closed domain), a name
with values for the domain's ``spec_args`` (``"disk:0.5"``: the disk of radius 0.5; ``"rect:2"``:
aspect 2), the path of a
GeoJSON-style polygon file (``"room.json"``) or of a binary image mask (``"shape.png"``), a
dict ``{"name": ..., **parameters}`` (what result files store, from :meth:`Domain.to_dict`), or
a :class:`Domain` itself. New domains register their class in :data:`DOMAINS`.
"""

from __future__ import annotations

import dataclasses
import json

from ..errors import InputError
from .base import Domain
from .disk import Disk
from .free import FreeBoundary
from .polygon import PolygonDomain
from .region import ShapelyDomain
from .shapes import Annulus, Car, Rect, Smile, Square
from .sphere import Sphere

__all__ = ["Domain", "ShapelyDomain", "FreeBoundary", "Disk", "Square", "Rect", "Annulus",
           "Smile", "Car", "PolygonDomain", "Sphere", "DOMAINS", "get_domain"]

MASK_SUFFIXES = (".png", ".bmp", ".tif", ".tiff", ".gif", ".jpg", ".jpeg")
"""File names read as a binary image mask (:meth:`PolygonDomain.from_mask`)."""

DOMAINS: dict[str, type[Domain]] = {
    cls.name: cls for cls in (FreeBoundary, Disk, Square, Rect, Annulus, Smile, Car, Sphere,
                                   PolygonDomain)
}
"""Registry: domain name -> class (constructed with its parameters)."""


def get_domain(spec) -> Domain:
    """The domain a spec describes.

    Parameters
    ----------
    spec : str, dict or Domain
        ``"name"`` (default parameters), ``"name:v1,v2"`` (numbers for the class's
        ``spec_args``, e.g. ``"disk:0.5"``; ``"annulus:auto"``: the inner radius from the
        surface, see :attr:`Annulus.auto`), a path ending in ``.json`` (a polygon file, read
        by :meth:`PolygonDomain.from_json`) or in an image suffix of :data:`MASK_SUFFIXES`
        (a binary mask, :meth:`PolygonDomain.from_mask`), ``{"name": ..., **parameters}`` as
        written by :meth:`Domain.to_dict` (or its JSON text, as :attr:`Domain.spec` gives it),
        or a :class:`Domain`, returned as is.

    Raises
    ------
    InputError
        Unknown name (the message lists the registered ones), wrong number of values, a value
        that is not a number, unknown parameters, parameters the domain rejects, or a polygon
        file that cannot be read or holds no valid polygon.
    TypeError
        ``spec`` is none of the above (e.g. None: the free boundary is ``"free"``).
    """
    if isinstance(spec, Domain):
        return spec
    if isinstance(spec, str) and spec.lstrip().startswith("{"):  # the JSON form of Domain.spec
        try:
            spec = json.loads(spec)
        except ValueError:
            raise InputError(f"domain {spec!r}: not valid JSON") from None
    if isinstance(spec, str) and spec.strip().lower().endswith(".json"):
        return PolygonDomain.from_json(spec.strip())
    if isinstance(spec, str) and spec.strip().lower().endswith(MASK_SUFFIXES):
        return PolygonDomain.from_mask(spec.strip())
    if isinstance(spec, str):
        name, _, args = spec.partition(":")
        cls = _lookup(name)
        values = [a.strip() for a in args.split(",")] if args else []
        if values and values[0].lower() == "auto":
            return _auto(cls, values[1:], spec)
        if len(values) > len(cls.spec_args):
            takes = ", ".join(cls.spec_args) if cls.spec_args else "no values"
            raise InputError(f"domain {spec!r}: {name} takes {takes}; got {len(values)} value(s)")
        try:
            params = {key: float(v) for key, v in zip(cls.spec_args, values)}
        except ValueError:
            raise InputError(f"domain {spec!r}: expected numbers after '{name}:'") from None
        return _build(cls, params, spec)
    if isinstance(spec, dict):
        params = dict(spec)
        if "name" not in params:
            raise InputError(f"domain {spec!r}: no 'name'; choose one of: {', '.join(DOMAINS)}")
        cls = _lookup(params.pop("name"))
        known = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(params) - known)
        if unknown:
            raise InputError(f"domain {cls.name}: unknown parameter(s) {', '.join(unknown)}; "
                             f"known: {', '.join(sorted(known)) or 'none'}")
        params = {k: tuple(v) if isinstance(v, list) else v for k, v in params.items()}
        return _build(cls, params, cls.name)
    raise TypeError(f"domain: expected a name, a dict or a Domain, got {type(spec).__name__}"
                    + (" (the free boundary is 'free')" if spec is None else ""))


def _auto(cls: type[Domain], rest: list[str], spec: str) -> Domain:
    """``"annulus:auto[,outer]"``: a domain whose first parameter the cloud decides."""
    if "auto" not in {f.name for f in dataclasses.fields(cls)}:
        raise InputError(f"domain {spec!r}: only annulus takes 'auto' (its inner radius from "
                         "the surface)")
    if len(rest) > len(cls.spec_args) - 1:
        raise InputError(f"domain {spec!r}: {cls.name}:auto takes at most "
                         f"{', '.join(cls.spec_args[1:])}; got {len(rest)} value(s)")
    try:
        params = {key: float(v) for key, v in zip(cls.spec_args[1:], rest)}
    except ValueError:
        raise InputError(f"domain {spec!r}: expected numbers after '{cls.name}:auto,'") from None
    placeholder = 0.5 * params.get("outer", 1.0)
    return _build(cls, {cls.spec_args[0]: placeholder, **params, "auto": True}, spec)


SPEC_CHOICES = ", ".join([n for n in DOMAINS if n != PolygonDomain.name]
                         + ["PATH.json (a polygon with holes) or PATH.png (a binary mask)"])
"""What the unknown-domain message offers: every spec that works by name (a polygon has no
default, so its file, not its name)."""


def _lookup(name) -> type[Domain]:
    if name not in DOMAINS:
        raise InputError(f"unknown domain {name!r}; choose one of: {SPEC_CHOICES}")
    return DOMAINS[name]


def _build(cls: type[Domain], params: dict, shown: str) -> Domain:
    try:
        return cls(**params)
    except (TypeError, ValueError) as exc:
        raise InputError(f"domain {shown!r}: {' '.join(str(exc).split())}") from None
