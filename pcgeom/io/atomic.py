"""Atomic writes: a temporary file beside the target, then ``os.replace``.

An interrupted run never leaves a truncated or half-written output behind, and an existing
file is only replaced by a complete new one. :func:`check_writable` checks an output path
before any work starts.
"""

from __future__ import annotations

import os
import secrets
from collections.abc import Callable
from pathlib import Path
from typing import BinaryIO

import numpy as np

from ..errors import InputError

__all__ = ["check_writable", "write_atomic", "save_npz_atomic"]


def check_writable(path, ext: str) -> Path:
    """Fail early, before any training, if ``path`` cannot receive a ``.ext`` output.

    Parameters
    ----------
    path : str or os.PathLike
        Output file.
    ext : str
        Required extension without the dot, e.g. ``"npz"`` or ``"ply"`` (case-insensitive).

    Returns
    -------
    Path
        ``path`` as a :class:`pathlib.Path`.

    Raises
    ------
    InputError
        Wrong extension, missing parent directory, parent not writable, or ``path`` is a
        directory.
    """
    name = os.fspath(path)
    path = Path(path)
    want = "." + ext.lower().lstrip(".")
    if path.suffix.lower() != want:
        got = repr(path.suffix) if path.suffix else "none"
        raise InputError(f"{name}: output must have extension {want!r}, got {got}")
    parent = path.parent
    if not parent.is_dir():
        raise InputError(f"{name}: output directory {os.fspath(parent)!r} does not exist")
    if path.is_dir():
        raise InputError(f"{name}: is a directory, expected a file")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise InputError(f"{name}: output directory {os.fspath(parent)!r} is not writable")
    return path


def write_atomic(path, write: Callable[[BinaryIO], None]) -> None:
    """Run ``write(f)`` on a temporary file beside ``path``, then rename it over ``path``.

    The temporary file is created with ``os.open(..., 0o666)`` so the result gets the usual
    umask-derived permissions (``tempfile`` would leave it at 0600). On any exception the
    temporary file is removed and an existing ``path`` is left untouched.
    """
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{secrets.token_hex(6)}.tmp")
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
    try:
        with os.fdopen(fd, "wb") as f:
            write(f)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        raise


def save_npz_atomic(path, **arrays) -> None:
    """``np.savez_compressed`` to ``path`` atomically.

    Parameters
    ----------
    path : str or os.PathLike
        Output ``.npz`` file (checked with :func:`check_writable`).
    **arrays : array_like
        Arrays stored under their keyword names.
    """
    path = check_writable(path, "npz")
    write_atomic(path, lambda f: np.savez_compressed(f, **arrays))
