"""Built-in polygonal and curved domains: square, rectangle, annulus, smiling face, car.

All are centred at the origin and sized like the unit disk (the normalized cloud fits in the
unit ball): the square is [-1, 1]^2, and with default parameters every shape has an area
between 2.3 and 4 and lies within 1.42 of the origin. Their regions are shapely polygons
(:class:`~pcgeom.domains.region.ShapelyDomain`); circular arcs are polygons with a vertex every
:data:`~pcgeom.domains.region.ARC_STEP` radians (chord error at most 1.9e-5 x radius).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
import shapely

from .base import as_points2d, check_count
from .disk import CIRCLE_SEGMENTS
from .region import ShapelyDomain, arc

__all__ = ["Square", "Rect", "Annulus", "Smile", "Car"]


def _positive(name: str, value) -> None:
    """``ValueError`` naming ``name`` unless ``value`` is a positive finite number."""
    if not (isinstance(value, (int, float, np.integer, np.floating)) and np.isfinite(value)
            and value > 0):
        raise ValueError(f"{name}: expected a positive finite number, got {value!r}")


@dataclass(frozen=True)
class Square(ShapelyDomain):
    """The square [-side/2, side/2]^2 (default [-1, 1]^2, area 4)."""

    side: float = 2.0
    """Side length, > 0."""

    name: ClassVar[str] = "square"
    spec_args: ClassVar[tuple[str, ...]] = ("side",)

    def __post_init__(self) -> None:
        _positive("side", self.side)

    def _build_geometry(self):
        h = self.side / 2
        return shapely.box(-h, -h, h, h)


@dataclass(frozen=True)
class Rect(ShapelyDomain):
    """A rectangle of aspect width/height, area size^2 (default 2.83 x 1.41, area 4).

    Width ``size sqrt(aspect)`` and height ``size / sqrt(aspect)``: the rectangle keeps the
    area of the square of side ``size`` whatever its aspect, so ``rect:1`` is ``square``.
    """

    aspect: float = 2.0
    """Width / height, > 0 (``rect:2`` is twice as wide as high)."""
    size: float = 2.0
    """Square root of the area, > 0: the side of the square of the same area."""

    name: ClassVar[str] = "rect"
    spec_args: ClassVar[tuple[str, ...]] = ("aspect", "size")

    def __post_init__(self) -> None:
        _positive("aspect", self.aspect)
        _positive("size", self.size)

    @property
    def width(self) -> float:
        """``size sqrt(aspect)``."""
        return self.size * math.sqrt(self.aspect)

    @property
    def height(self) -> float:
        """``size / sqrt(aspect)``."""
        return self.size / math.sqrt(self.aspect)

    def _build_geometry(self):
        w, h = self.width / 2, self.height / 2
        return shapely.box(-w, -h, w, h)


@dataclass(frozen=True)
class Annulus(ShapelyDomain):
    """The ring inner <= |u| <= outer (default 0.5 <= |u| <= 1), doubly connected.

    Containment, signed distance and the boundary are exact (circles); only sampling uses
    the generic sampler, with the exact containment test.
    """

    inner: float = 0.5
    """Inner radius, 0 < inner < outer."""
    outer: float = 1.0
    """Outer radius."""
    auto: bool = False
    """``annulus:auto`` (``annulus:auto,OUTER``): the inner radius is the surface's own
    conformal modulus, so that a surface with one hole maps onto it conformally;
    :func:`pcgeom.parametrize` measures it on the cloud
    (:func:`pcgeom.maps.domain.annulus_radius`) and maps onto that annulus, which its result
    records. Until then ``inner`` holds a placeholder (half of ``outer``)."""

    name: ClassVar[str] = "annulus"
    spec_args: ClassVar[tuple[str, ...]] = ("inner", "outer")

    @property
    def spec(self) -> str:
        if self.auto:
            return "annulus:auto" + ("" if self.outer == 1.0 else f",{float(self.outer)!r}")
        return super().spec

    def with_inner(self, inner: float) -> "Annulus":
        """The concrete annulus of inner radius ``inner`` (``auto`` resolved)."""
        return Annulus(inner=float(inner), outer=self.outer)

    def __post_init__(self) -> None:
        _positive("inner", self.inner)
        _positive("outer", self.outer)
        if not isinstance(self.auto, bool):
            raise ValueError(f"auto: expected true or false, got {self.auto!r}")
        if self.inner >= self.outer:
            raise ValueError(f"inner: expected a radius below outer = {self.outer!r}, "
                             f"got {self.inner!r}")

    def _build_geometry(self):  # for drawing and the bounding box; queries below are exact
        return shapely.Polygon(arc((0, 0), self.outer, 0.0, 2 * np.pi)[:-1],
                               [arc((0, 0), self.inner, 0.0, 2 * np.pi)[:-1]])

    def _interior(self, P: np.ndarray) -> np.ndarray:
        r = np.linalg.norm(P, axis=1)
        return (r > self.inner) & (r < self.outer)

    def _circle_counts(self, n: int) -> tuple[int, int]:
        """Points on the outer and inner circle, in proportion to their lengths."""
        n_outer = int(round(n * self.outer / (self.outer + self.inner)))
        return n_outer, n - n_outer

    def boundary(self, n: int) -> np.ndarray:
        """``n`` points: on the outer circle counter-clockwise from +x, then the inner circle
        clockwise from +x, each evenly spaced, in proportion to the circles' lengths.

        Returns
        -------
        (n, 2) float64
        """
        n_outer, n_inner = self._circle_counts(check_count(n))
        t_outer = 2 * np.pi * np.arange(n_outer) / max(n_outer, 1)
        t_inner = -2 * np.pi * np.arange(n_inner) / max(n_inner, 1)
        return np.vstack([
            self.outer * np.column_stack([np.cos(t_outer), np.sin(t_outer)]),
            self.inner * np.column_stack([np.cos(t_inner), np.sin(t_inner)]),
        ])

    def boundary_loops(self) -> list[np.ndarray]:
        """The outer circle (counter-clockwise) and the inner circle (clockwise), each with
        ``CIRCLE_SEGMENTS`` segments and vertices on the circle.

        Returns
        -------
        list of two (CIRCLE_SEGMENTS + 1, 2) float64
        """
        t = 2 * np.pi * np.arange(CIRCLE_SEGMENTS + 1) / CIRCLE_SEGMENTS
        t[-1] = 0.0  # close the loop exactly
        circle = np.column_stack([np.cos(t), np.sin(t)])
        return [self.outer * circle, self.inner * circle[::-1]]

    def contains(self, P) -> np.ndarray:
        """``inner <= |P| <= outer`` up to a relative 1e-12."""
        r = np.linalg.norm(as_points2d(P), axis=1)
        return (r >= self.inner * (1 - 1e-12)) & (r <= self.outer * (1 + 1e-12))

    def signed_distance(self, P) -> np.ndarray:
        """``max(|P| - outer, inner - |P|)``: negative in the ring, positive outside or in the
        hole.

        Parameters
        ----------
        P : (K, 2) array_like

        Returns
        -------
        (K,) float64
        """
        r = np.linalg.norm(as_points2d(P), axis=1)
        return np.maximum(r - self.outer, self.inner - r)

    @property
    def area(self) -> float:
        """``pi (outer^2 - inner^2)``."""
        return float(np.pi * (self.outer**2 - self.inner**2))

    @property
    def centroid(self) -> np.ndarray:
        """The origin."""
        return np.zeros(2)


@dataclass(frozen=True)
class Smile(ShapelyDomain):
    """The paper's smiling face: the unit disk minus two half-disk eyes and a half-disk mouth.

    The paper (section 7.3, figure "param domain smiling car") forms it by removing half disks
    from the unit disk but gives no coordinates; these are chosen to match its description:

    - face: the unit disk ``|u| <= 1``;
    - eyes: the upper half-disks of radius 0.2 centred at ``(-0.4, 0.25)`` and ``(0.4, 0.25)``
      (flat side down, ``y >= 0.25``), so each eye spans ``x`` in ``[+-0.2, +-0.6]``;
    - mouth: the lower half-disk of radius 0.5 centred at ``(0, -0.15)`` (flat side up,
      ``y <= -0.15``), spanning ``x`` in ``[-0.5, 0.5]`` and ``y`` in ``[-0.65, -0.15]``.

    Every hole is at least 0.35 from the face's edge and 0.4 from the others. Area
    ``pi (1 - 0.04 - 0.125) = 2.623`` (polygon: 2.6232). Four boundary loops.
    """

    name: ClassVar[str] = "smile"

    EYE_RADIUS: ClassVar[float] = 0.2
    EYE_CENTERS: ClassVar[tuple[tuple[float, float], ...]] = ((-0.4, 0.25), (0.4, 0.25))
    MOUTH_RADIUS: ClassVar[float] = 0.5
    MOUTH_CENTER: ClassVar[tuple[float, float]] = (0.0, -0.15)

    def _build_geometry(self):
        face = arc((0.0, 0.0), 1.0, 0.0, 2 * np.pi)[:-1]
        # Upper half of each eye circle; shapely closes the ring with the flat side.
        eyes = [arc(c, self.EYE_RADIUS, 0.0, np.pi) for c in self.EYE_CENTERS]
        mouth = arc(self.MOUTH_CENTER, self.MOUTH_RADIUS, np.pi, 2 * np.pi)
        return shapely.Polygon(face, [*eyes, mouth])


@dataclass(frozen=True)
class Car(ShapelyDomain):
    """The paper's car: a car body seen from above, sides unfolded, with four wheel arches.

    The paper (section 7.3) describes a car-shaped domain bounded by straight lines and
    circular arcs, onto which a car's outer shell is mapped, and matches the upper edges of
    the two side windows to the lines ``[-0.5, 0.5] x {-0.25, 0.25}``. So the roof is the
    middle band, the two sides unfold to ``y > 0.25`` and ``y < -0.25``, the bonnet points to
    ``+x``. No coordinates are given; these are chosen:

    - sides: the lines ``y = +-0.7`` for ``-0.85 <= x <= 0.85``;
    - wheel arches: four half-disk notches of radius 0.2 cut into the sides, centred at
      ``(+-0.55, +-0.7)``;
    - front: the arc of the circle centred at ``(11/60, 0)`` through ``(0.85, +-0.7)`` and
      ``(1.15, 0)`` (radius 29/30);
    - rear: the arc of the circle centred at ``(0.275, 0)`` through ``(-0.85, +-0.7)`` and
      ``(-1.05, 0)`` (radius 1.325).

    Simply connected: one boundary loop. Area 2.6083; the landmark lines are at least 0.25
    from the boundary (nearest: the wheel arches).
    """

    name: ClassVar[str] = "car"

    HALF_WIDTH: ClassVar[float] = 0.7
    SIDE_END: ClassVar[float] = 0.85  # |x| where the sides meet the front and rear arcs
    WHEEL_X: ClassVar[float] = 0.55
    WHEEL_RADIUS: ClassVar[float] = 0.2
    FRONT_TIP: ClassVar[float] = 1.15
    REAR_TIP: ClassVar[float] = -1.05

    def _build_geometry(self):
        w, e, wx, wr = self.HALF_WIDTH, self.SIDE_END, self.WHEEL_X, self.WHEEL_RADIUS
        front_c, front_r = _circle_through_tip(e, w, self.FRONT_TIP)
        rear_c, rear_r = _circle_through_tip(-e, w, self.REAR_TIP)
        front_a = math.atan2(w, e - front_c)
        rear_a = math.atan2(w, -e - rear_c)  # in (pi/2, pi)
        pieces = [
            arc((front_c, 0.0), front_r, -front_a, front_a),  # bonnet, (e, -w) to (e, w)
            arc((wx, w), wr, 0.0, -np.pi),  # front arch, top side, right to left
            arc((-wx, w), wr, 0.0, -np.pi),  # rear arch, top side
            arc((rear_c, 0.0), rear_r, rear_a, 2 * np.pi - rear_a),  # boot, (-e, w) to (-e, -w)
            arc((-wx, -w), wr, np.pi, 0.0),  # rear arch, bottom side, left to right
            arc((wx, -w), wr, np.pi, 0.0),  # front arch, bottom side
        ]
        return shapely.Polygon(np.vstack(pieces))  # straight sides join the pieces


def _circle_through_tip(x_end: float, half_width: float, tip: float) -> tuple[float, float]:
    """Centre ``(c, 0)`` and radius of the circle through ``(x_end, +-half_width)`` and
    ``(tip, 0)``: ``(tip - c)^2 = (x_end - c)^2 + half_width^2``."""
    c = (tip**2 - x_end**2 - half_width**2) / (2 * (tip - x_end))
    return c, abs(tip - c)
