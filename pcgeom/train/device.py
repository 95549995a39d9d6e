"""Which torch device a run uses."""

from __future__ import annotations

import torch

from ..errors import InputError

__all__ = ["DEVICES", "resolve_device"]

DEVICES = ("auto", "cpu", "cuda")


def resolve_device(name: str | torch.device) -> torch.device:
    """``"auto"`` (CUDA when present), ``"cpu"``, ``"cuda"``, or a ``torch.device`` as is.

    Raises
    ------
    InputError
        Unknown name (the message lists the choices), or ``"cuda"`` without CUDA.
    """
    if isinstance(name, torch.device):
        return name
    if name not in DEVICES:
        raise InputError(f"unknown device {name!r}; choose one of: {', '.join(DEVICES)}")
    if name == "cuda" and not torch.cuda.is_available():
        raise InputError("--device cuda requested but CUDA is not available")
    if name == "auto":
        return torch.device("cuda" if torch.cuda.is_available() else "cpu")
    return torch.device(name)
