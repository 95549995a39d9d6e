"""Read and write point clouds and meshes; validate a cloud before any training starts.

Supported inputs: PLY (with or without faces), OBJ, OFF, XYZ/TXT/CSV tables and NPZ archives.
Every problem with user input raises :class:`InputError` with a one-line message that names the
file or argument and the problem, e.g. ``"input.ply: 3 points, need at least 10"``.

Outputs are written atomically (temporary file in the target directory, then ``os.replace``), so
an interrupted run never leaves a truncated result behind.
"""

from __future__ import annotations

import os
import secrets
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import BinaryIO

import numpy as np

__all__ = [
    "InputError",
    "PointCloud",
    "SUPPORTED_EXTENSIONS",
    "read_points",
    "validate_points",
    "deduplicate",
    "normalize",
    "check_writable",
    "write_atomic",
    "save_npz_atomic",
    "write_ply_atomic",
]

SUPPORTED_EXTENSIONS = (".csv", ".npz", ".obj", ".off", ".ply", ".txt", ".xyz")
"""File extensions :func:`read_points` understands (case-insensitive)."""

_TABLE_EXTENSIONS = (".csv", ".txt", ".xyz")
_NPZ_POINT_KEYS = ("points", "V", "vertices")
_NPZ_FACE_KEYS = ("faces", "F")
# Second singular value below this fraction of the first: the cloud lies on a line.
_COLLINEAR_RTOL = 1e-9


class InputError(ValueError):
    """Bad user input (file or array); the message is one line naming the source and problem."""


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


def _one_line(exc: BaseException) -> str:
    """A library exception squeezed onto one line (type name when it has no message)."""
    text = " ".join(str(exc).split())
    return text if text else type(exc).__name__


def validate_points(P, name: str = "points", min_points: int = 10) -> np.ndarray:
    """Check that ``P`` is a usable cloud of 3D points and return it as float64.

    Duplicate points are allowed (see :func:`deduplicate`); what is rejected is a cloud that no
    surface parametrization can work with.

    Parameters
    ----------
    P : (N, 3) array_like
        Point coordinates.
    name : str
        Name of the argument or file, used as the prefix of error messages.
    min_points : int
        Fewest points, and fewest *distinct* points, accepted.

    Returns
    -------
    P : (N, 3) float64
        ``np.asarray(P, dtype=np.float64)``.

    Raises
    ------
    InputError
        Wrong shape (not ``(N, 3)``); rows with NaN or inf; fewer than ``min_points`` points;
        all points coincident; all points on one line (second singular value of the centred
        cloud below ``1e-9`` times the first); fewer than ``min_points`` distinct points.
    """
    try:
        P = np.asarray(P, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{name}: cannot convert to a float array ({_one_line(exc)})") from None
    if P.ndim != 2 or P.shape[1] != 3:
        raise InputError(f"{name}: expected shape (N, 3), got {P.shape}")
    bad_rows = int((~np.isfinite(P)).any(axis=1).sum())
    if bad_rows:
        raise InputError(f"{name}: {bad_rows} of {len(P)} rows contain NaN or inf")
    n = len(P)
    if n < min_points:
        raise InputError(f"{name}: {n} points, need at least {min_points}")
    centred = P - P.mean(axis=0)
    extent = float(np.abs(centred).max())
    # Relative to the coordinates' magnitude so a far-away tiny cloud still counts as coincident.
    if extent <= 1e-12 * max(1.0, float(np.abs(P).max())):
        raise InputError(f"{name}: all {n} points coincide")
    s = np.linalg.svd(centred, compute_uv=False)  # (3,), descending
    if s[1] < _COLLINEAR_RTOL * s[0]:
        raise InputError(f"{name}: all {n} points lie on one line; need a surface")
    n_distinct = len(np.unique(P, axis=0))
    if n_distinct < min_points:
        raise InputError(
            f"{name}: {n_distinct} distinct points (of {n}), need at least {min_points}"
        )
    return P


def deduplicate(P) -> tuple[np.ndarray, np.ndarray]:
    """Remove exactly repeated points, keeping the order of first occurrence.

    Parameters
    ----------
    P : (N, d) array_like
        Points.

    Returns
    -------
    unique : (K, d) float64
        Distinct rows of ``P``, in order of first appearance.
    inverse : (N,) int64
        Indices such that ``unique[inverse] == P``.
    """
    P = np.asarray(P, dtype=np.float64)
    if P.ndim != 2:
        raise ValueError(f"P: expected a 2-D array (N, d), got shape {P.shape}")
    if len(P) == 0:
        return P.copy(), np.zeros(0, dtype=np.int64)
    sorted_unique, first, inverse = np.unique(P, axis=0, return_index=True, return_inverse=True)
    order = np.argsort(first, kind="stable")  # sorted-unique index -> position by first use
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    return sorted_unique[order], rank[inverse.reshape(-1)].astype(np.int64)


def normalize(P) -> tuple[np.ndarray, np.ndarray, float]:
    """Centre a cloud at its centroid and scale it into the unit ball.

    ``Pn = (P - center) / scale`` with ``center = mean(P)`` and
    ``scale = max_i |P_i - center|``, so the farthest point lies on the unit sphere. Undo with
    ``P = Pn * scale + center``. Loss parameters such as sigma assume this scale.

    Parameters
    ----------
    P : (N, 3) array_like
        Points.

    Returns
    -------
    Pn : (N, 3) float64
        Normalized points; centroid 0, largest norm 1.
    center : (3,) float64
        Centroid of ``P``.
    scale : float
        Largest distance from the centroid.

    Raises
    ------
    ValueError
        ``P`` is not (N, 3) with N >= 1, or all points coincide (scale 0).
    """
    P = np.asarray(P, dtype=np.float64)
    if P.ndim != 2 or P.shape[1] != 3 or len(P) == 0:
        raise ValueError(f"P: expected shape (N, 3) with N >= 1, got {P.shape}")
    center = P.mean(axis=0)
    scale = float(np.linalg.norm(P - center, axis=1).max())
    if not np.isfinite(scale) or scale == 0.0:
        raise ValueError(f"P: cannot normalize, scale is {scale} (coincident or non-finite points)")
    return (P - center) / scale, center, scale


# --------------------------------------------------------------------------- reading


def _validate_faces(F, n_points: int, name: str) -> np.ndarray | None:
    """Faces as (M, 3) int64 with indices in range, or None when there are none."""
    if F is None:
        return None
    F = np.asarray(F)
    if F.size == 0:
        return None
    if F.ndim != 2 or F.shape[1] != 3:
        raise InputError(f"{name}: faces must have shape (M, 3), got {F.shape}")
    if not np.issubdtype(F.dtype, np.integer):
        if not np.issubdtype(F.dtype, np.floating) or not np.all(F == np.round(F)):
            raise InputError(f"{name}: faces must hold integer vertex indices, got {F.dtype}")
    F = F.astype(np.int64)
    lo, hi = int(F.min()), int(F.max())
    if lo < 0 or hi >= n_points:
        raise InputError(
            f"{name}: faces reference vertex indices {lo}..{hi} but there are {n_points} points"
        )
    return F


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
    faces = _validate_faces(faces, len(points), name)
    return PointCloud(points=points, faces=faces, source=name)


# --------------------------------------------------------------------------- writing


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
        Bad path (see :func:`check_writable`).
    ValueError
        Wrong shapes, non-finite vertices, or face indices out of range.
    """
    path = check_writable(path, "ply")
    V = np.asarray(vertices, dtype=np.float64)
    if V.ndim != 2 or V.shape[1] != 3:
        raise ValueError(f"vertices: expected shape (N, 3), got {V.shape}")
    if not np.isfinite(V).all():
        raise ValueError("vertices: contain NaN or inf")
    F = None
    if faces is not None:
        F = np.asarray(faces)
        if F.ndim != 2 or F.shape[1] != 3 or not np.issubdtype(F.dtype, np.integer):
            raise ValueError(f"faces: expected integer shape (M, 3), got {F.dtype} {F.shape}")
        if F.size and (F.min() < 0 or F.max() >= len(V)):
            raise ValueError(
                f"faces: indices {F.min()}..{F.max()} out of range for {len(V)} vertices"
            )
    write_atomic(path, lambda f: _write_ply(f, V, F))
