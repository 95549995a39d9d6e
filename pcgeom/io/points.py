"""Read point clouds and meshes from files; write meshes and mapped points as PLY.

Supported inputs: PLY (with or without faces), OBJ, OFF, XYZ/TXT/CSV tables, NPZ archives and
LAS/LAZ (through laspy). Per-point normals are read when the file has them: PLY ``nx ny nz``
vertex properties, NPZ key ``"normals"``, six-column tables (or a header row naming the normal
columns) and LAS/LAZ extra dimensions; OBJ and OFF normals are not read. Every problem with user
input raises :class:`pcgeom.errors.InputError` with a one-line message that names the file and
the problem, e.g. ``"input.ply: 3 points, need at least 10"``.
"""

from __future__ import annotations

import os
import re
import warnings
from dataclasses import InitVar, dataclass
from pathlib import Path
from typing import BinaryIO

import numpy as np

from ..cloud import validate_faces, validate_normals, validate_points
from ..errors import InputError, _one_line
from .atomic import check_writable, write_atomic

__all__ = ["PointCloud", "SUPPORTED_EXTENSIONS", "read_points", "write_ply_atomic"]

SUPPORTED_EXTENSIONS = (".csv", ".las", ".laz", ".npz", ".obj", ".off", ".ply", ".txt", ".xyz")
"""File extensions :func:`read_points` understands (case-insensitive)."""

_TABLE_EXTENSIONS = (".csv", ".txt", ".xyz")
_NPZ_POINT_KEYS = ("points", "V", "vertices")
_NPZ_FACE_KEYS = ("faces", "F")
_NPZ_NORMAL_KEY = "normals"
_LAS_EXTENSIONS = (".las", ".laz")
# Names of normal components, compared after lower-casing and dropping everything but letters
# and digits: nx/ny/nz (Open3D, CloudCompare, MeshLab), normal_x/... (PCL), NormalX/... (PDAL).
_NORMAL_NAMES = (("nx", "ny", "nz"), ("normalx", "normaly", "normalz"))
# A LAS extra dimension holding all three components, e.g. laspy's type "3f8".
_NORMAL_VECTOR_NAMES = ("normal", "normals")


@dataclass(frozen=True, eq=False)
class PointCloud:
    """A point cloud as read from a file, with the reference faces when the file has them.

    Validated when built (:func:`pcgeom.cloud.validate_points`, ``validate_faces`` and
    ``validate_normals``, their messages prefixed with ``source``): a ``PointCloud`` is a
    cloud checked once, at the edge, and :func:`pcgeom.maps.parametrize` and
    :func:`pcgeom.apps.texture.map_mesh` take one as it is, without checking it again.

    ``eq=False``: comparing arrays element-wise has no single truth value.
    """

    points: np.ndarray
    """(N, 3) float64 coordinates, in the file's order (duplicates kept)."""
    faces: np.ndarray | None
    """(M, 3) int64 vertex indices into ``points``, or None for a bare cloud."""
    source: str
    """Where the cloud came from (the path as given)."""
    normals: np.ndarray | None = None
    """(N, 3) float64 unit normals, one per row of ``points``, or None when the file has none.

    Their sign is the file's (scanners usually point them towards the sensor); it tells the two
    sides of a surface apart.
    """
    min_points: InitVar[int] = 10
    """Fewest points (and distinct points) accepted (:func:`pcgeom.cloud.validate_points`)."""

    def __post_init__(self, min_points: int) -> None:
        points = validate_points(self.points, name=self.source, min_points=min_points)
        object.__setattr__(self, "points", points)
        object.__setattr__(self, "faces", validate_faces(self.faces, len(points), self.source))
        object.__setattr__(self, "normals",
                           validate_normals(self.normals, len(points), self.source))


# --------------------------------------------------------------------------- reading


def _normal_columns(names, name: str) -> tuple[str, str, str] | None:
    """The three names among ``names`` that hold normal components, in x, y, z order, or None.

    Raises InputError when only some components are present, or when two sets are.
    """
    key = {re.sub(r"[^0-9a-z]", "", str(n).lower()): n for n in names}
    found = []
    for triple in _NORMAL_NAMES:
        present = [key[k] for k in triple if k in key]
        if len(present) == 3:
            found.append(tuple(present))
        elif present:
            missing = [k for k in triple if k not in key]
            raise InputError(f"{name}: incomplete normals: has {', '.join(map(str, present))} "
                             f"but no {', '.join(missing)}")
    if len(found) > 1:
        shown = " and ".join("/".join(map(str, t)) for t in found)
        raise InputError(f"{name}: two sets of normals ({shown}); keep one")
    return found[0] if found else None


def _ply_normals(loaded, name: str) -> np.ndarray | None:
    """The PLY file's own ``nx ny nz`` vertex properties, or None when it has none.

    Read from the raw vertex records that trimesh keeps in ``metadata["_ply_raw"]`` (a structured
    array for binary files, a dict of (N, 1) arrays for ASCII ones). Not
    ``mesh.vertex_normals``: trimesh computes those from the faces when the file has none.
    """
    raw = getattr(loaded, "metadata", {}).get("_ply_raw", {}).get("vertex")
    if raw is None:
        return None
    columns = _normal_columns(raw["properties"], name)
    if columns is None:
        return None
    data = raw["data"]
    return np.column_stack([np.asarray(data[c], dtype=np.float64).reshape(-1) for c in columns])


_PLY_FORMATS = ("ascii", "binary_little_endian", "binary_big_endian")
_PLY_TYPES = {"char", "uchar", "short", "ushort", "int", "uint", "float", "double", "int8",
              "uint8", "int16", "uint16", "int32", "uint32", "float32", "float64"}


def _check_ply(path: Path, name: str) -> None:
    """A PLY file's header (and an ASCII file's data lines) checked against the format, so
    that a malformed file gets a message that says what is wrong.

    The header: ``ply``, ``format ascii|binary_little_endian|binary_big_endian 1.0``,
    ``element NAME COUNT``, ``property TYPE NAME`` or ``property list TYPE TYPE NAME``,
    ``comment``/``obj_info`` lines, ``end_header``. An ASCII body: one line per element record,
    as many values as its properties take (a list: its length, then that many values).

    Raises
    ------
    InputError
        One line naming the file and what is wrong (the header line, or the data line).
    """
    with open(path, "rb") as f:
        head = f.read(1 << 16)
        if not head.startswith(b"ply"):
            raise InputError(f"{name}: cannot parse: not a PLY file (it does not start with "
                             "'ply')")
        end = head.find(b"end_header")
        if end < 0:
            raise InputError(f"{name}: malformed PLY header: no 'end_header' line")
        header = head[:end].decode("ascii", errors="replace").splitlines()[1:]
        elements: list[tuple[str, int, list[list[str]]]] = []
        fmt = None
        for k, line in enumerate(header, start=2):
            words = line.split()
            bad = f"{name}: malformed PLY header, line {k}: {line.strip()!r}"
            if not words or words[0] in ("comment", "obj_info"):
                continue
            if words[0] == "format":
                if len(words) != 3 or words[1] not in _PLY_FORMATS:
                    raise InputError(f"{bad} (expected 'format ascii 1.0' or a binary format)")
                fmt = words[1]
            elif words[0] == "element":
                if len(words) != 3 or not words[2].isdigit():
                    raise InputError(f"{bad} (expected 'element NAME COUNT')")
                elements.append((words[1], int(words[2]), []))
            elif words[0] == "property":
                scalar = len(words) == 3 and words[1] in _PLY_TYPES
                listed = (len(words) == 5 and words[1] == "list"
                          and {words[2], words[3]} <= _PLY_TYPES)
                if not elements or not (scalar or listed):
                    raise InputError(f"{bad} (expected 'property TYPE NAME' or 'property list "
                                     "TYPE TYPE NAME' after an element)")
                elements[-1][2].append(words[1:])
            else:
                raise InputError(f"{bad} (not a PLY header keyword)")
        if fmt is None:
            raise InputError(f"{name}: malformed PLY header: no 'format' line")
        if fmt != "ascii":
            return  # trimesh checks a binary body's length against the header
        f.seek(end)
        f.readline()  # the rest of the end_header line
        lines = (line.split() for line in f)
        _check_ascii_records(lines, elements, name,
                             first=len(header) + 2)


def _check_ascii_records(lines, elements, name: str, first: int) -> None:
    """Each element's records, one non-empty line each, against its properties."""
    declared = ", ".join(f"{count} {element}" for element, count, _ in elements)
    number = first
    for element, count, properties in elements:
        for _ in range(count):
            words = next(lines, None)
            number += 1
            while words is not None and not words:
                words, number = next(lines, None), number + 1
            if words is None:
                raise InputError(f"{name}: truncated PLY: its header declares {declared} but "
                                 f"the data ends at line {number - 1}")
            at = 0
            for prop in properties:
                if prop[0] == "list":
                    try:
                        at += 1 + int(float(words[at]))
                    except (IndexError, ValueError):
                        at = -1
                        break
                else:
                    at += 1
            if at != len(words):
                raise InputError(f"{name}: malformed PLY data, line {number}: {len(words)} "
                                 f"value(s) do not match the {element}'s properties "
                                 f"({' '.join(p[-1] for p in properties)})")


def _read_trimesh(
    path: Path, name: str, with_normals: bool
) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
    """PLY and OFF through trimesh; ``process=False`` keeps vertex order and duplicates."""
    import trimesh

    if path.suffix.lower() == ".ply":
        _check_ply(path, name)  # trimesh's own errors say "list index out of range" and the like
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
    ply = path.suffix.lower() == ".ply"
    normals = _ply_normals(loaded, name) if ply and with_normals else None
    return vertices, faces, normals


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


def _read_table(
    path: Path, name: str, with_normals: bool
) -> tuple[np.ndarray, np.ndarray | None]:
    """Numeric table: whitespace or comma separated, ``#`` comments, x y z first.

    Normals: with a header row, the columns it names ``nx ny nz`` (or ``normal_x`` ...), if
    any; without one, columns 4-6 of a table of exactly six columns when they are unit vectors
    (:func:`_bare_normals`). Other columns are ignored.
    """
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError:
        raise InputError(f"{name}: cannot parse: not a text file") from None
    # Allow one header row of column names (``x,y,z``) before the numbers.
    lines = [ln.split("#", 1)[0].replace(",", " ").split() for ln in text.splitlines()]
    rows = [ln for ln in lines if ln]
    header = None
    if rows and not any(_is_number(tok) for tok in rows[0]):
        header, rows = rows[0], rows[1:]
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
    if not with_normals:
        return table[:, :3], None
    if header is None:
        # Six bare columns are x y z nx ny nz, the layout scanners and Open3D export, when
        # columns 4-6 are unit vectors; otherwise they are something else (x y z r g b).
        if table.shape[1] != 6:
            return table[:, :3], None
        return table[:, :3], _bare_normals(table[:, 3:6], name)
    columns = _normal_columns(header, name)
    if columns is None:
        return table[:, :3], None
    if len(header) != table.shape[1]:
        raise InputError(f"{name}: header names {len(header)} columns but rows have "
                         f"{table.shape[1]}")
    return table[:, :3], table[:, [header.index(c) for c in columns]]


# How far from 1 the length of every row of a headerless table's columns 4-6 may be for them
# to be read as normals (a text file's normals written to 3 decimals are within 0.003).
UNIT_TOLERANCE = 0.02


def _bare_normals(columns: np.ndarray, name: str) -> np.ndarray | None:
    """Columns 4-6 of a headerless six-column table as normals when every row is a unit
    vector (length within ``UNIT_TOLERANCE`` of 1); otherwise None, with one warning line:
    colours (``x y z r g b``) or other values are not normals."""
    length = np.linalg.norm(columns, axis=1)
    if np.all(np.abs(length - 1.0) <= UNIT_TOLERANCE):  # NaN rows fail: validated as normals
        return columns
    if not np.isfinite(length).all():
        return columns  # validate_normals names the row with NaN or inf
    warnings.warn(f"{name}: columns 4-6 are not unit vectors (lengths {length.min():.3g} to "
                  f"{length.max():.3g}), so not read as normals; name them in a header row "
                  "(x y z nx ny nz) to use them", UserWarning, stacklevel=2)
    return None


def _is_number(token: str) -> bool:
    try:
        float(token)
    except ValueError:
        return False
    return True


def _read_npz(
    path: Path, name: str
) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
    """NPZ: points under "points", "V" or "vertices" (else the only other array); faces and
    normals optional."""
    try:
        with np.load(path, allow_pickle=False) as archive:
            arrays = {key: archive[key] for key in archive.files}
    except Exception as exc:  # zipfile.BadZipFile, ValueError for pickled objects, ...
        raise InputError(f"{name}: cannot parse: {_one_line(exc)}") from None
    point_key = next((k for k in _NPZ_POINT_KEYS if k in arrays), None)
    if point_key is None:
        candidates = [k for k in arrays if k not in (*_NPZ_FACE_KEYS, _NPZ_NORMAL_KEY)]
        if len(candidates) != 1:
            found = ", ".join(sorted(arrays)) or "none"
            raise InputError(
                f"{name}: no point array; expected key "
                f"{' or '.join(repr(k) for k in _NPZ_POINT_KEYS)} or a single array, found: {found}"
            )
        point_key = candidates[0]
    face_key = next((k for k in _NPZ_FACE_KEYS if k in arrays), None)
    faces = arrays[face_key] if face_key is not None else None
    return arrays[point_key], faces, arrays.get(_NPZ_NORMAL_KEY)


def _read_las(
    path: Path, name: str, with_normals: bool
) -> tuple[np.ndarray, np.ndarray | None]:
    """LAS/LAZ through laspy: scaled x y z, and normals from extra dimensions.

    Normals are three extra dimensions named like ``NormalX``/``normal_x``/``nx`` (any case),
    or one three-component extra dimension named ``normal`` or ``normals``.
    """
    try:
        import laspy
    except ImportError:
        raise ImportError(
            "reading .las/.laz files needs laspy: pip install 'laspy[lazrs]'"
        ) from None
    if path.suffix.lower() == ".laz" and not laspy.LazBackend.detect_available():
        raise ImportError("reading .laz files needs a LAZ backend: pip install 'laspy[lazrs]'")
    try:
        las = laspy.read(path)
    except Exception as exc:  # laspy.LaspyException, struct errors on truncated files, ...
        raise InputError(f"{name}: cannot parse: {_one_line(exc)}") from None
    # las.x is the stored integer X times the header's scale plus its offset.
    points = np.column_stack([np.asarray(las.x, dtype=np.float64),
                              np.asarray(las.y, dtype=np.float64),
                              np.asarray(las.z, dtype=np.float64)])  # (N, 3)
    if not with_normals:
        return points, None
    extra = list(las.point_format.extra_dimension_names)
    columns = _normal_columns(extra, name)
    if columns is not None:
        normals = np.column_stack([np.asarray(las[c], dtype=np.float64) for c in columns])
        return points, normals
    vector = [d for d in extra if d.lower() in _NORMAL_VECTOR_NAMES]
    if len(vector) > 1:
        raise InputError(f"{name}: two sets of normals ({' and '.join(vector)}); keep one")
    if vector:
        return points, np.asarray(las[vector[0]], dtype=np.float64)
    return points, None


def read_points(path, min_points: int = 10, *, normals: bool = True) -> PointCloud:
    """Read a point cloud (and its faces and normals, when the file has them) and validate it.

    Parameters
    ----------
    path : str or os.PathLike
        One of these formats (by extension, case-insensitive):

        - ``.ply``, with or without faces; normals from the vertex properties ``nx ny nz``
          (or ``normal_x normal_y normal_z``), never computed from the faces.
        - ``.obj``, ``.off``: points and faces; normals are not read.
        - ``.xyz``/``.txt``/``.csv``: numeric table, whitespace or comma separated, first three
          columns x y z, ``#`` comments and one header row of names allowed. Normals: with a
          header row, the columns it names ``nx ny nz`` (or ``normal_x`` ...), if it names them;
          without one, columns 4-6 of a table of exactly six columns (x y z nx ny nz) when
          every row of them is a unit vector (a headerless x y z r g b table: its colours are
          not, and are ignored with a warning). Other columns are ignored.
        - ``.npz``: points under key ``"points"``, ``"V"`` or ``"vertices"``, else its only
          array besides faces and normals; faces optionally under ``"faces"`` or ``"F"``;
          normals optionally under ``"normals"``.
        - ``.las``/``.laz`` (laspy; LAZ through lazrs): scaled x y z coordinates; normals from
          three extra dimensions named like ``NormalX``/``normal_x``/``nx``, or from one
          three-component extra dimension ``normal``/``normals``.
    min_points : int
        Passed to :func:`validate_points`.
    normals : bool
        Read and validate the file's normals (default). False skips them and every check on
        them, so that a file whose extra columns are not normals still reads;
        ``PointCloud.normals`` is then None.

    Returns
    -------
    PointCloud
        ``points`` (N, 3) float64 in file order (duplicates kept), ``faces`` (M, 3) int64 or
        None, ``source`` the path as given, ``normals`` (N, 3) float64 of unit length or None.

    Raises
    ------
    InputError
        Missing file, empty file (0 bytes or no points), unknown extension, unparsable content,
        wrong shape, faces out of range, any check of :func:`validate_points`, or normals that
        fail :func:`pcgeom.cloud.validate_normals` (wrong count, NaN or inf, zero length),
        are incomplete (``nx ny`` without ``nz``) or come in two sets.
    ImportError
        A ``.las``/``.laz`` file without laspy (or ``.laz`` without lazrs) installed.

    Warns
    -----
    UserWarning
        A headerless six-column table whose columns 4-6 are not unit vectors (colours): they
        are not read as normals.
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

    faces = file_normals = None
    if ext in (".ply", ".off"):
        points, faces, file_normals = _read_trimesh(path, name, normals)
    elif ext == ".obj":
        points, faces = _read_obj(path, name)
    elif ext == ".npz":
        points, faces, file_normals = _read_npz(path, name)
    elif ext in _LAS_EXTENSIONS:
        points, file_normals = _read_las(path, name, normals)
    else:
        points, file_normals = _read_table(path, name, normals)

    points = np.asarray(points)
    if points.size == 0:
        raise InputError(f"{name}: file holds no points")
    if points.ndim != 2 or points.shape[1] != 3:
        raise InputError(f"{name}: expected shape (N, 3), got {points.shape}")
    # Checked once, here, as the PointCloud is built.
    return PointCloud(points=points, faces=faces, source=name,
                      normals=file_normals if normals else None, min_points=min_points)


# --------------------------------------------------------------------------- writing


def _write_ply(
    f: BinaryIO, V: np.ndarray, F: np.ndarray | None, N: np.ndarray | None = None,
    UV: np.ndarray | None = None,
) -> None:
    """Binary little-endian PLY with float64 coordinates (trimesh's export is float32),
    float64 ``nx ny nz`` when ``N`` is given and float64 ``texture_u texture_v`` when ``UV``
    is (the names MeshLab, trimesh and Open3D read as per-vertex texture coordinates; trimesh
    would write ``s t``)."""
    header = [
        "ply",
        "format binary_little_endian 1.0",
        "comment written by pcgeom",
        f"element vertex {len(V)}",
        "property double x",
        "property double y",
        "property double z",
    ]
    if N is not None:
        header += ["property double nx", "property double ny", "property double nz"]
    if UV is not None:
        header += ["property double texture_u", "property double texture_v"]
    if F is not None:
        header += [f"element face {len(F)}", "property list uchar int vertex_indices"]
    header.append("end_header\n")
    f.write("\n".join(header).encode("ascii"))
    # x y z [nx ny nz] [texture_u texture_v]: one record per vertex
    rows = np.hstack([V] + [A for A in (N, UV) if A is not None])
    f.write(np.ascontiguousarray(rows, dtype="<f8").tobytes())
    if F is not None:
        rows = np.empty(len(F), dtype=[("n", "u1"), ("v", "<i4", (3,))])
        rows["n"] = 3
        rows["v"] = F
        f.write(rows.tobytes())


def check_uv(uv, n: int) -> np.ndarray:
    """Texture coordinates as finite float64 of shape ``(n, 2)``, one pair per vertex.

    Raises
    ------
    ValueError
        Another shape, NaN or inf.
    """
    UV = np.asarray(uv, dtype=np.float64)
    if UV.shape != (n, 2):
        raise ValueError(f"uv: expected shape ({n}, 2), got {UV.shape}")
    if not np.isfinite(UV).all():
        raise ValueError("uv: contains NaN or inf")
    return UV


def write_ply_atomic(path, vertices, faces=None, normals=None, uv=None) -> None:
    """Write vertices (and optional triangles, normals and texture coordinates) as a binary
    PLY, atomically.

    Parameters
    ----------
    path : str or os.PathLike
        Output ``.ply`` file (checked with :func:`check_writable`).
    vertices : (N, 3) array_like
        Finite coordinates, stored as float64 (exact round trip through :func:`read_points`).
    faces : (M, 3) array_like of int, optional
        Vertex indices in ``[0, N)``.
    normals : (N, 3) array_like, optional
        One normal per vertex, written as float64 ``nx ny nz`` after scaling to unit length
        (:func:`pcgeom.cloud.validate_normals`); :func:`read_points` gives them back.
    uv : (N, 2) array_like, optional
        Finite texture coordinates, one pair per vertex, written as float64 ``texture_u
        texture_v`` (``trimesh.load(path).visual.uv`` gives them back; MeshLab reads them in
        float32).

    Raises
    ------
    InputError
        Bad path (see :func:`check_writable`), faces of the wrong shape, not integers, or
        out of range (:func:`pcgeom.cloud.validate_faces`), or normals of the wrong shape or
        count, not finite, or of zero length (:func:`pcgeom.cloud.validate_normals`).
    ValueError
        Vertices or texture coordinates of the wrong shape or not finite.
    """
    path = check_writable(path, "ply")
    V = np.asarray(vertices, dtype=np.float64)
    if V.ndim != 2 or V.shape[1] != 3:
        raise ValueError(f"vertices: expected shape (N, 3), got {V.shape}")
    if not np.isfinite(V).all():
        raise ValueError("vertices: contain NaN or inf")
    F = validate_faces(faces, len(V))
    N = validate_normals(normals, len(V))
    UV = None if uv is None else check_uv(uv, len(V))
    write_atomic(path, lambda f: _write_ply(f, V, F, N, UV))
