"""Paths in and out: checks before any work, and atomic writes.

Writes go to a temporary file beside the target, then ``os.replace``: an interrupted run never
leaves a truncated or half-written output behind, and an existing file is only replaced by a
complete new one. :func:`check_writable` checks an output path and :func:`check_readable` an
input path before any work starts; :func:`read_json` reads a small JSON input.
"""

from __future__ import annotations

import json
import os
import secrets
from collections.abc import Callable
from pathlib import Path
from typing import BinaryIO

import numpy as np

from ..errors import InputError

__all__ = ["check_readable", "read_json", "check_writable", "write_atomic", "write_files_atomic",
           "save_npz_atomic"]


def _with_extension(path, ext: str, kind: str) -> Path:
    """``path`` as a Path, or ``"<path>: <kind> must have extension '.ext', got ..."``."""
    want = "." + ext.lower().lstrip(".")
    p = Path(path)
    if p.suffix.lower() != want:
        got = repr(p.suffix) if p.suffix else "none"
        raise InputError(f"{os.fspath(path)}: {kind} must have extension {want!r}, got {got}")
    return p


def check_readable(path, ext: str, kind: str) -> Path:
    """``path`` as a Path, checked to be an existing file with extension ``.ext``.

    Raises
    ------
    InputError
        ``"<path>: <kind> must have extension '.ext', got ..."``, ``"<path>: no such file"``
        or ``"<path>: not a regular file"``.
    """
    name = os.fspath(path)
    path = _with_extension(path, ext, kind)
    if not path.exists():
        raise InputError(f"{name}: no such file")
    if not path.is_file():
        raise InputError(f"{name}: not a regular file")
    return path


def read_json(path, kind: str):
    """The parsed content of a ``.json`` input file (:func:`check_readable` first).

    Raises
    ------
    InputError
        Wrong extension, missing, unreadable, or not valid JSON; one line naming the file.
    """
    path = check_readable(path, "json", kind)
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise InputError(f"{os.fspath(path)}: cannot parse: {' '.join(str(exc).split())}") from None


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
    path = _with_extension(path, ext, "output")
    parent = path.parent
    if not parent.is_dir():
        raise InputError(f"{name}: output directory {os.fspath(parent)!r} does not exist")
    if path.is_dir():
        raise InputError(f"{name}: is a directory, expected a file")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise InputError(f"{name}: output directory {os.fspath(parent)!r} is not writable")
    return path


def _write_temporary(path: Path, write: Callable[[BinaryIO], None],
                     temporaries: list[Path]) -> None:
    """``write(f)`` into a new temporary file beside ``path``, flushed to disk; its path is
    added to ``temporaries`` as soon as it exists.

    Created with ``os.open(..., 0o666)`` so the result gets the usual umask-derived
    permissions (``tempfile`` would leave it at 0600)."""
    tmp = path.with_name(f".{path.name}.{secrets.token_hex(6)}.tmp")
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
    temporaries.append(tmp)
    with os.fdopen(fd, "wb") as f:
        write(f)
        f.flush()
        os.fsync(f.fileno())


def _unlink_quietly(path: Path) -> None:
    try:
        os.unlink(path)
    except FileNotFoundError:
        pass


def write_atomic(path, write: Callable[[BinaryIO], None]) -> None:
    """Run ``write(f)`` on a temporary file beside ``path``, then rename it over ``path``.

    On any exception the temporary file is removed and an existing ``path`` is left untouched.
    """
    write_files_atomic({path: write})


def write_files_atomic(writers) -> None:
    """Write several files that belong together (a mesh, its material, its image): every
    ``write(f)`` runs on a temporary file beside its path, and only when all of them have
    succeeded are the temporary files renamed over their paths.

    Parameters
    ----------
    writers : mapping of path -> callable
        Each output path and the function that writes its bytes to a binary file object.

    On any exception while writing, every temporary file is removed and no output is touched:
    an error never leaves some of the files written and others not.
    """
    items = [(Path(path), write) for path, write in writers.items()]
    temporaries: list[Path] = []
    try:
        for path, write in items:
            _write_temporary(path, write, temporaries)
        for tmp, (path, _) in zip(temporaries, items):
            os.replace(tmp, path)
    except BaseException:
        for tmp in temporaries:
            _unlink_quietly(tmp)
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
