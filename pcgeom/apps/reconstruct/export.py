"""Writing a reconstructed mesh: :func:`write_mesh` (PLY or OBJ by extension, with texture
coordinates and a texture image when given), and :func:`check_mesh_path` to refuse a bad
output path before any work."""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np

from ...cloud import validate_faces
from ...errors import InputError
from ...io import check_writable, write_files_atomic, write_ply_atomic
from ...io.points import check_uv

MESH_FORMATS = ("ply", "obj")
"""File formats :func:`write_mesh` writes, by extension."""


def check_mesh_path(path, texture=None) -> Path:
    """``path`` as a Path, checked (before any work) to be a writable ``.ply`` or ``.obj``;
    with a ``texture``, an ``.obj`` whose material and image (:func:`texture_paths`) can be
    written beside it.

    Parameters
    ----------
    path : str or os.PathLike
    texture : Texture, optional
        :func:`pcgeom.apps.texture.parse_texture`'s result.

    Raises
    ------
    InputError
        Another extension (the message lists :data:`MESH_FORMATS`), anything
        :func:`pcgeom.io.check_writable` refuses; with a texture, a ``.ply`` (it holds texture
        coordinates but names no material), a file name with white space (OBJ's ``mtllib``
        line would split it), or a material or image path that is a directory.
    """
    ext = Path(path).suffix.lower().lstrip(".")
    if ext not in MESH_FORMATS:
        got = repr(Path(path).suffix) if ext else "none"
        raise InputError(f"{os.fspath(path)}: mesh output must have extension "
                         f"{' or '.join('.' + f for f in MESH_FORMATS)}, got {got}")
    path = check_writable(path, ext)
    if texture is None:
        return path
    if ext != "obj":
        raise InputError(f"{os.fspath(path)}: a texture needs an .obj mesh (its .mtl material "
                         f"names the image); a .{ext} holds the texture coordinates "
                         "(texture_u texture_v) but no material: drop --texture, or write .obj")
    if re.search(r"\s", path.name):
        raise InputError(f"{os.fspath(path)}: a textured OBJ's file name cannot hold white space "
                         "(the mtllib line names the material file)")
    for extra in texture_paths(path, texture).values():
        check_writable(extra, extra.suffix.lstrip("."))
    return path


def texture_paths(path, texture) -> dict[str, Path]:
    """The files a textured OBJ ``path`` comes with: ``{"material": <stem>.mtl, "image":
    <stem>_<kind>.png}``, beside it (``mesh.obj``: ``mesh.mtl``, ``mesh_checker.png``)."""
    path = Path(path)
    return {"material": path.with_suffix(".mtl"),
            "image": path.with_name(f"{path.stem}_{texture.kind}.png")}


def write_mesh(path, V, F, uv=None, texture=None, *, corner_uv=None) -> Path:
    """Write the triangle mesh ``(V, F)`` atomically, in the format of ``path``'s extension,
    with texture coordinates ``uv`` and a ``texture`` image when given.

    ``.ply``: binary PLY (:func:`pcgeom.io.write_ply_atomic`, float64 coordinates, exact),
    ``uv`` as float64 ``texture_u texture_v`` vertex properties.
    ``.obj``: Wavefront OBJ from trimesh's exporter, coordinates with 17 decimal places:
    rounded by at most 5e-18, so exact in float64 for magnitudes of 0.1 or more; ``uv`` as one
    ``vt`` per vertex (faces ``f a/a b/b c/c``). With a ``texture``, trimesh's material
    (:class:`trimesh.visual.material.SimpleMaterial` with the image) is written beside it as
    :func:`texture_paths` names them, the OBJ naming them with ``mtllib`` and ``usemtl``; the
    three files are written together (:func:`pcgeom.io.write_files_atomic`), so an error
    leaves none of them.

    Parameters
    ----------
    path : str or os.PathLike
    V : (K, 3) array_like
    F : (M, 3) array_like of int
    uv : (K, 2) array_like, optional
        Texture coordinates, one pair per vertex (``UVScaling.apply`` of the map).
    texture : Texture, optional
        The image to map (:func:`pcgeom.apps.texture.parse_texture`); needs ``uv`` (or
        ``corner_uv``) and an ``.obj`` path.
    corner_uv : (M, 3, 2) array_like, optional
        Texture coordinates per corner of ``F`` instead of ``uv`` (an atlas: a seam vertex has
        one per side), ``.obj`` only: one ``vt`` per distinct (vertex, uv) pair, faces
        ``f a/ta b/tb c/tc``; the vertices are not split (a reader that splits them, such as
        trimesh, gets one vertex per ``vt``).

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
        Vertices or texture coordinates of the wrong shape or not finite; a texture without
        ``uv``.
    """
    path = check_mesh_path(path, texture)
    V = np.asarray(V, dtype=np.float64)
    if V.ndim != 2 or V.shape[1] != 3:
        raise ValueError(f"V: expected shape (K, 3), got {V.shape}")
    if not np.isfinite(V).all():
        raise ValueError("V: contains NaN or inf")
    F = validate_faces(F, len(V), name="F", allow_empty=False)
    if corner_uv is not None:
        corner_uv = np.asarray(corner_uv, dtype=np.float64)
        if corner_uv.shape != (len(F), 3, 2) or not np.isfinite(corner_uv).all():
            raise ValueError(f"corner_uv: expected finite values of shape ({len(F)}, 3, 2), "
                             f"got {corner_uv.shape}")
        if path.suffix.lower() != ".obj":
            raise InputError(f"{path}: per-corner texture coordinates are written to .obj only")
        files = _obj_corner_files(path, V, F, corner_uv, texture)
        write_files_atomic({p: (lambda f, data=data: f.write(data)) for p, data in files.items()})
        return path
    if uv is not None:
        uv = check_uv(uv, len(V))
    elif texture is not None:
        raise ValueError("texture: needs uv (texture coordinates)")
    if path.suffix.lower() == ".ply":
        write_ply_atomic(path, V, F, uv=uv)
        return path
    files = _obj_files(path, V, F, uv, texture)
    write_files_atomic({p: (lambda f, data=data: f.write(data)) for p, data in files.items()})
    return path


def _obj_corner_files(path: Path, V, F, corner_uv, texture) -> dict[Path, bytes]:
    """The OBJ text with one ``vt`` per distinct (vertex, corner uv) (and with a texture its
    material and image, from :func:`_obj_files`), by path."""
    first = np.zeros((len(V), 2))
    first[F.ravel()] = corner_uv.reshape(-1, 2)
    files = _obj_files(path, V, F, first, texture)
    header = [line for line in files[path].decode("utf-8").split("\n")
              if line.startswith(("#", "mtllib ", "usemtl "))]
    keys = np.column_stack([F.reshape(-1, 1).astype(np.float64), corner_uv.reshape(-1, 2)])
    unique, vt_index = np.unique(keys, axis=0, return_inverse=True)
    vt_index = vt_index.reshape(-1, 3) + 1
    lines = [h for h in header if not h.startswith("usemtl ")]
    lines += [f"v {x:.17g} {y:.17g} {z:.17g}" for x, y, z in V]
    lines += [f"vt {u:.17g} {v:.17g}" for u, v in unique[:, 1:]]
    lines += [h for h in header if h.startswith("usemtl ")]
    Fv = F + 1
    lines += [f"f {a}/{ta} {b}/{tb} {c}/{tc}"
              for (a, b, c), (ta, tb, tc) in zip(Fv.tolist(), vt_index.tolist())]
    files[path] = ("\n".join(lines) + "\n").encode("utf-8")
    return files


def _obj_files(path: Path, V, F, uv, texture) -> dict[Path, bytes]:
    """The OBJ text (and with a texture its material and image), by path."""
    import trimesh
    from trimesh.exchange.obj import export_obj

    from ..._version import __version__

    header = f"pcgeom {__version__}"
    if uv is None:
        mesh = trimesh.Trimesh(vertices=V, faces=F, process=False)  # process=False: keep rows
        text = export_obj(mesh, include_normals=False, include_color=False,
                          include_texture=False, digits=17, header=header)
        return {path: text.encode("utf-8")}
    names = texture_paths(path, texture) if texture is not None else None
    material = trimesh.visual.material.SimpleMaterial(
        image=texture.image() if texture is not None else None,
        name=names["image"].stem if names is not None else "uv",
        diffuse=(255, 255, 255, 255), ambient=(255, 255, 255, 255),
        specular=(0, 0, 0, 255))
    mesh = trimesh.Trimesh(vertices=V, faces=F, process=False,
                           visual=trimesh.visual.TextureVisuals(uv=uv, material=material))
    text, extra = export_obj(mesh, include_normals=False, include_color=False,
                             include_texture=True, return_texture=True, digits=17,
                             header=header, mtl_name=path.with_suffix(".mtl").name)
    if names is None:
        # vt without a material: trimesh always names one (mtllib, usemtl), which nothing
        # here writes; an OBJ reader would look for it.
        text = "\n".join(line for line in text.split("\n")
                         if not line.startswith(("mtllib ", "usemtl ")))
        return {path: text.encode("utf-8")}
    if set(extra) != {names["material"].name, names["image"].name}:
        raise RuntimeError(f"trimesh named the texture files {sorted(extra)}, expected "
                           f"{names['material'].name} and {names['image'].name}")
    return {names["image"]: extra[names["image"].name],
            names["material"]: extra[names["material"].name],
            path: text.encode("utf-8")}
