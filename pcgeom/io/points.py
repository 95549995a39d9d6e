"""Read point clouds and meshes from files; write meshes and mapped points as PLY.

Supported inputs: PLY (with or without faces), OBJ, OFF, XYZ/TXT/CSV tables and NPZ archives.
Every problem with user input raises :class:`pcgeom.errors.InputError` with a one-line message
that names the file and the problem, e.g. ``"input.ply: 3 points, need at least 10"``.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import BinaryIO

import numpy as np

from ..cloud import _one_line, validate_faces, validate_points
from ..errors import InputError
from .atomic import check_writable, write_atomic

__all__ = ["PointCloud", "SUPPORTED_EXTENSIONS", "read_points", "write_ply_atomic"]

SUPPORTED_EXTENSIONS = (".csv", ".npz", ".obj", ".off", ".ply", ".txt", ".xyz")
"""File extensions :func:`read_points` understands (case-insensitive)."""

_TABLE_EXTENSIONS = (".csv", ".txt", ".xyz")
_NPZ_POINT_KEYS = ("points", "V", "vertices")
_NPZ_FACE_KEYS = ("faces", "F")


@dataclass(frozen=True, eq=False)
class PointCloud:
    """A point cloud as read from a file, with the reference faces when the file has them.

    ``eq=False``: comparing arrays element-wise has no single truth value.
    """

    points: np.ndarray
    """(N, 3) float64 coordinates, in the file's order (duplicates kept)."""
    faces: np.ndarray | None
    """(M, 3) int64 vertex indices into ``points``, or None for a bare cloud."""
    source: str
    """Where the cloud came from (the path as given)."""


# --------------------------------------------------------------------------- reading


def _read_trimesh(path: Path, name: str) -> tuple[np.ndarray, np.ndarray | None]:
    """PLY and OFF through trimesh; ``process=False`` keeps vertex order and duplicates."""
    import trimesh

    try:
        loaded = trimesh.load(str(path), process=False)
    except Exception as exc:  # any parser failure is the file's fault here
        raise InputError(f"{name}: cannot parse: {_one_line(exc)}") from None
    if isinstance(loaded, trimesh.Scene):
        geometries = list(loaded.geometry.values())
        if not geometries:
            raise InputError(f"{name}: file holds no points")
        if len(geometries) > 1:
            raise InputError(
                f"{name}: file holds {len(geometries)} separate geometries, expected one"
            )
        loaded = geometries[0]
    vertices = np.asarray(getattr(loaded, "vertices", np.zeros((0, 3))), dtype=np.float64)
    faces = getattr(loaded, "faces", None)  # a trimesh.PointCloud has no faces
    return vertices, faces


def _read_obj(path: Path, name: str) -> tuple[np.ndarray, np.ndarray | None]:
    """Wavefront OBJ, parsed here: trimesh drops unreferenced vertices and splits by UV.

    Reads ``v x y z`` (extra values such as colours ignored) and ``f`` records (``i``, ``i/t``,
    ``i//n``, ``i/t/n``; negative indices are relative); polygons are fan-triangulated.
    """
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError:
        raise InputError(f"{name}: cannot parse: not a text OBJ file") from None
    vertices: list[list[float]] = []
    faces: list[list[int]] = []
    for lineno, line in enumerate(text.splitlines(), start=1):
        tokens = line.split("#", 1)[0].split()
        if not tokens:
            continue
        try:
            if tokens[0] == "v":
                vertices.append([float(t) for t in tokens[1:4]])
                if len(vertices[-1]) != 3:
                    raise ValueError(f"vertex has {len(tokens) - 1} coordinates, need 3")
            elif tokens[0] == "f":
                idx = [int(t.split("/", 1)[0]) for t in tokens[1:]]
                if len(idx) < 3:
                    raise ValueError(f"face has {len(idx)} vertices, need at least 3")
                n = len(vertices)
                idx = [i - 1 if i > 0 else n + i for i in idx]  # 1-based, or relative if < 0
                faces.extend([idx[0], idx[k], idx[k + 1]] for k in range(1, len(idx) - 1))
        except ValueError as exc:
            raise InputError(f"{name}: cannot parse line {lineno}: {_one_line(exc)}") from None
    V = np.array(vertices, dtype=np.float64).reshape(-1, 3)
    F = np.array(faces, dtype=np.int64).reshape(-1, 3) if faces else None
    return V, F


def _read_table(path: Path, name: str) -> np.ndarray:
    """Numeric table: whitespace or comma separated, ``#`` comments, x y z first."""
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError:
        raise InputError(f"{name}: cannot parse: not a text file") from None
    # Allow one header row of column names (``x,y,z``) before the numbers.
    lines = [ln.split("#", 1)[0].replace(",", " ").split() for ln in text.splitlines()]
    rows = [ln for ln in lines if ln]
    if rows and not any(_is_number(tok) for tok in rows[0]):
        rows = rows[1:]
    if not rows:
        raise InputError(f"{name}: file holds no points")
    widths = {len(r) for r in rows}
    if len(widths) > 1:
        first = len(rows[0])
        row = next(i for i, r in enumerate(rows) if len(r) != first)
        raise InputError(
            f"{name}: rows have different numbers of columns ({first} in row 1, "
            f"{len(rows[row])} in row {row + 1})"
        )
    try:
        table = np.array(rows, dtype=np.float64)  # (N, C)
    except ValueError as exc:
        raise InputError(f"{name}: cannot parse: {_one_line(exc)}") from None
    if table.shape[1] < 3:
        raise InputError(f"{name}: expected shape (N, 3) (x y z columns), got {table.shape}")
    return table[:, :3]


def _is_number(token: str) -> bool:
    try:
        float(token)
    except ValueError:
        return False
    return True


def _read_npz(path: Path, name: str) -> tuple[np.ndarray, np.ndarray | None]:
    """NPZ: points under "points", "V" or "vertices" (else the only array); faces optional."""
    try:
        with np.load(path, allow_pickle=False) as archive:
            arrays = {key: archive[key] for key in archive.files}
    except Exception as exc:  # zipfile.BadZipFile, ValueError for pickled objects, ...
        raise InputError(f"{name}: cannot parse: {_one_line(exc)}") from None
    point_key = next((k for k in _NPZ_POINT_KEYS if k in arrays), None)
    if point_key is None:
        candidates = [k for k in arrays if k not in _NPZ_FACE_KEYS]
        if len(candidates) != 1:
            found = ", ".join(sorted(arrays)) or "none"
            raise InputError(
                f"{name}: no point array; expected key "
                f"{' or '.join(repr(k) for k in _NPZ_POINT_KEYS)} or a single array, found: {found}"
            )
        point_key = candidates[0]
    face_key = next((k for k in _NPZ_FACE_KEYS if k in arrays), None)
    faces = arrays[face_key] if face_key is not None else None
    return arrays[point_key], faces


def read_points(path, min_points: int = 10) -> PointCloud:
    """Read a point cloud (and its faces, when the file has them) and validate it.

    Parameters
    ----------
    path : str or os.PathLike
        A ``.ply`` (with or without faces), ``.obj``, ``.off``, ``.xyz``/``.txt``/``.csv``
        (numeric table, whitespace or comma separated, first three columns x y z, extra
        columns ignored, ``#`` comments and one header row of names allowed) or ``.npz``
        (points under key ``"points"``, ``"V"`` or ``"vertices"``, else its only array; faces
        optionally under ``"faces"`` or ``"F"``).
    min_points : int
        Passed to :func:`validate_points`.

    Returns
    -------
    PointCloud
        ``points`` (N, 3) float64 in file order (duplicates kept), ``faces`` (M, 3) int64 or
        None, ``source`` the path as given.

    Raises
    ------
    InputError
        Missing file, empty file (0 bytes or no points), unknown extension, unparsable content,
        wrong shape, faces out of range, or any check of :func:`validate_points`.
    """
    name = os.fspath(path)
    path = Path(path)
    ext = path.suffix.lower()
    if ext not in SUPPORTED_EXTENSIONS:
        shown = repr(path.suffix) if path.suffix else "(none)"
        raise InputError(
            f"{name}: unknown extension {shown}; supported: {', '.join(SUPPORTED_EXTENSIONS)}"
        )
    if not path.exists():
        raise InputError(f"{name}: no such file")
    if not path.is_file():
        raise InputError(f"{name}: not a regular file")
    if path.stat().st_size == 0:
        raise InputError(f"{name}: file is empty (0 bytes)")

    faces = None
    if ext in (".ply", ".off"):
        points, faces = _read_trimesh(path, name)
    elif ext == ".obj":
        points, faces = _read_obj(path, name)
    elif ext == ".npz":
        points, faces = _read_npz(path, name)
    else:
        points = _read_table(path, name)

    points = np.asarray(points)
    if points.size == 0:
        raise InputError(f"{name}: file holds no points")
    if points.ndim != 2 or points.shape[1] != 3:
        raise InputError(f"{name}: expected shape (N, 3), got {points.shape}")
    points = validate_points(points, name=name, min_points=min_points)
    faces = validate_faces(faces, len(points), name)
    return PointCloud(points=points, faces=faces, source=name)


# --------------------------------------------------------------------------- writing


def _write_ply(f: BinaryIO, V: np.ndarray, F: np.ndarray | None) -> None:
    """Binary little-endian PLY with float64 coordinates (trimesh's export is float32)."""
    header = [
        "ply",
        "format binary_little_endian 1.0",
        "comment written by pcgeom",
        f"element vertex {len(V)}",
        "property double x",
        "property double y",
        "property double z",
    ]
    if F is not None:
        header += [f"element face {len(F)}", "property list uchar int vertex_indices"]
    header.append("end_header\n")
    f.write("\n".join(header).encode("ascii"))
    f.write(np.ascontiguousarray(V, dtype="<f8").tobytes())
    if F is not None:
        rows = np.empty(len(F), dtype=[("n", "u1"), ("v", "<i4", (3,))])
        rows["n"] = 3
        rows["v"] = F
        f.write(rows.tobytes())


def write_ply_atomic(path, vertices, faces=None) -> None:
    """Write vertices (and optional triangles) as a binary PLY, atomically.

    Parameters
    ----------
    path : str or os.PathLike
        Output ``.ply`` file (checked with :func:`check_writable`).
    vertices : (N, 3) array_like
        Finite coordinates, stored as float64 (exact round trip through :func:`read_points`).
    faces : (M, 3) array_like of int, optional
        Vertex indices in ``[0, N)``.

    Raises
    ------
    InputError
        Bad path (see :func:`check_writable`), or faces of the wrong shape, not integers, or
        out of range (:func:`pcgeom.cloud.validate_faces`).
    ValueError
        Vertices of the wrong shape or not finite.
    """
    path = check_writable(path, "ply")
    V = np.asarray(vertices, dtype=np.float64)
    if V.ndim != 2 or V.shape[1] != 3:
        raise ValueError(f"vertices: expected shape (N, 3), got {V.shape}")
    if not np.isfinite(V).all():
        raise ValueError("vertices: contain NaN or inf")
    F = validate_faces(faces, len(V))
    write_atomic(path, lambda f: _write_ply(f, V, F))
