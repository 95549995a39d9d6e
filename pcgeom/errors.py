"""The one exception type for bad user input."""

from __future__ import annotations

__all__ = ["InputError"]


class InputError(ValueError):
    """Bad user input (file, array or option); the message is one line naming the source and
    the problem, e.g. ``"scan.ply: 3 points, need at least 10"``."""


def _one_line(exc: BaseException) -> str:
    """A library exception squeezed onto one line (type name when it has no message): the
    part of an :class:`InputError` message that quotes a library."""
    text = " ".join(str(exc).split())
    return text if text else type(exc).__name__
