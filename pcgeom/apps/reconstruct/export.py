"""Writing a reconstructed mesh: :func:`write_mesh` (PLY or OBJ by extension), and
:func:`check_mesh_path` to refuse a bad output path before any work."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ...cloud import validate_faces
from ...errors import InputError
from ...io import check_writable, write_atomic, write_ply_atomic

MESH_FORMATS = ("ply", "obj")
"""File formats :func:`write_mesh` writes, by extension."""


def check_mesh_path(path) -> Path:
    """``path`` as a Path, checked (before any work) to be a writable ``.ply`` or ``.obj``.

    Raises
    ------
    InputError
        Another extension (the message lists :data:`MESH_FORMATS`), or anything
        :func:`pcgeom.io.check_writable` refuses.
    """
    ext = Path(path).suffix.lower().lstrip(".")
    if ext not in MESH_FORMATS:
        got = repr(Path(path).suffix) if ext else "none"
        raise InputError(f"{os.fspath(path)}: mesh output must have extension "
                         f"{' or '.join('.' + f for f in MESH_FORMATS)}, got {got}")
    return check_writable(path, ext)


def write_mesh(path, V, F) -> Path:
    """Write the triangle mesh ``(V, F)`` atomically, in the format of ``path``'s extension.

    ``.ply``: binary PLY (:func:`pcgeom.io.write_ply_atomic`, float64 coordinates, exact).
    ``.obj``: Wavefront OBJ from trimesh's exporter, vertices and faces only, coordinates
    with 17 decimal places: rounded by at most 5e-18, so exact in float64 for magnitudes of
    0.1 or more.

    Parameters
    ----------
    path : str or os.PathLike
    V : (K, 3) array_like
    F : (M, 3) array_like of int

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    InputError
        A bad path (:func:`check_mesh_path`), no faces, or bad faces
        (:func:`pcgeom.cloud.validate_faces`).
    ValueError
        Vertices of the wrong shape or not finite.
    """
    path = check_mesh_path(path)
    V = np.asarray(V, dtype=np.float64)
    if V.ndim != 2 or V.shape[1] != 3:
        raise ValueError(f"V: expected shape (K, 3), got {V.shape}")
    if not np.isfinite(V).all():
        raise ValueError("V: contains NaN or inf")
    F = validate_faces(F, len(V), name="F", allow_empty=False)
    if path.suffix.lower() == ".ply":
        write_ply_atomic(path, V, F)
        return path
    import trimesh
    from trimesh.exchange.obj import export_obj

    from ..._version import __version__

    mesh = trimesh.Trimesh(vertices=V, faces=F, process=False)  # process=False: keep rows
    text = export_obj(mesh, include_normals=False, include_color=False, include_texture=False,
                      digits=17, header=f"pcgeom {__version__}")
    write_atomic(path, lambda f: f.write(text.encode("utf-8")))
    return path


