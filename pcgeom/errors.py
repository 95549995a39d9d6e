"""The one exception type for bad user input."""

from __future__ import annotations

__all__ = ["InputError"]


class InputError(ValueError):
    """Bad user input (file, array or option); the message is one line naming the source and
    the problem, e.g. ``"scan.ply: 3 points, need at least 10"``."""
