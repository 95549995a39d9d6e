"""The checks every config runs when it is built: one-line :class:`pcgeom.errors.InputError`
messages naming ``Owner.field`` and what is allowed."""

from __future__ import annotations

import math

from ..errors import InputError


def _choice(owner: str, field: str, value, choices: tuple[str, ...]) -> None:
    if value not in choices:
        raise InputError(f"{owner}.{field}: unknown value {value!r}; choose one of: "
                         f"{', '.join(choices)}")


def _positive(owner: str, field: str, value, *, allow_zero: bool = False) -> None:
    ok = isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
    if not ok or value < 0 or (value == 0 and not allow_zero):
        want = "a non-negative" if allow_zero else "a positive"
        raise InputError(f"{owner}.{field}: expected {want} finite number, got {value!r}")


def _count(owner: str, field: str, value, *, allow_zero: bool = False) -> None:
    if isinstance(value, bool) or not isinstance(value, int):
        raise InputError(f"{owner}.{field}: expected an int, got {type(value).__name__}")
    if value < 0 or (value == 0 and not allow_zero):
        want = ">= 0" if allow_zero else ">= 1"
        raise InputError(f"{owner}.{field}: expected an int {want}, got {value}")


def _fraction(owner: str, field: str, value, *, closed: bool = False) -> None:
    """``0 < value < 1`` (``<= 1`` when ``closed``)."""
    ok = isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
    if not ok or value <= 0 or value > 1 or (value == 1 and not closed):
        want = "(0, 1]" if closed else "(0, 1)"
        raise InputError(f"{owner}.{field}: expected a number in {want}, got {value!r}")


def _flag(owner: str, field: str, value) -> None:
    if not isinstance(value, bool):
        raise InputError(f"{owner}.{field}: expected True or False, got {value!r}")
