"""A map as texture coordinates: the map scaled into the unit square (:func:`uv_scaling`), the
checkerboard a texture spec names (:func:`parse_texture`, :func:`checker_image`,
:func:`checker_parity`), and the triangle mesh that carries a map (:func:`map_mesh`: the
input's faces, or the local mesh a bare cloud's map was built on).

A checkerboard in the map's coordinates, drawn on the surface, shows the map's distortion:
where the map is conformal the squares stay squares (of varying size), where it shears them
they become parallelograms, and a fold shows as squares that overlap.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from ..cloud import deduplicate, normalize, validate_faces, validate_normals, validate_points
from ..errors import InputError
from ..io.points import PointCloud

__all__ = ["UVScaling", "uv_scaling", "Texture", "parse_texture", "TEXTURES", "CHECKER_SQUARES",
           "CHECKER_MAX_SQUARES", "CHECKER_COLOURS", "checker_image", "checker_parity",
           "MapMesh", "map_mesh"]

TEXTURES = ("checker",)
"""The texture images :func:`parse_texture` knows."""
CHECKER_SQUARES = 8
"""Squares along the longer side of the map when the spec gives none (``checker``)."""
CHECKER_MAX_SQUARES = 256
"""The most squares a side: 4 pixels each in the 1024-pixel image."""
CHECKER_COLOURS = ((235, 235, 235), (46, 88, 160))
"""RGB of the squares whose indices ``i + j`` are even, and odd."""
_IMAGE_PIXELS = 1024
"""About the width of a checkerboard image (a whole number of pixels per square)."""


@dataclass(frozen=True)
class UVScaling:
    """How a map's coordinates ``p`` become texture coordinates: ``uv = (p - offset) / scale``.

    ``offset`` is the lower-left corner of the map's bounding box and ``scale`` its longer
    side, so ``uv`` fills ``[0, 1]`` along that side and keeps the map's aspect ratio (a
    square of the map is a square of the texture)."""

    offset: tuple[float, float]
    scale: float

    def apply(self, U) -> np.ndarray:
        """``(U - offset) / scale``, (K, 2) float64."""
        return (np.asarray(U, dtype=np.float64) - np.asarray(self.offset)) / self.scale

    def to_dict(self) -> dict:
        """``{"uv_offset": [x, y], "uv_scale": s}``: the keys of the commands' ``--json``."""
        return {"uv_offset": [float(v) for v in self.offset], "uv_scale": float(self.scale)}


def uv_scaling(U) -> UVScaling:
    """The :class:`UVScaling` that puts the map ``U`` (K, 2) into the unit square, aspect kept.

    Raises
    ------
    ValueError
        ``U`` not (K, 2) with K >= 1, not finite, or all its points at one place.
    """
    U = np.asarray(U, dtype=np.float64)
    if U.ndim != 2 or U.shape[1] != 2 or len(U) == 0:
        raise ValueError(f"U: expected shape (K, 2) with K >= 1, got {U.shape}")
    if not np.isfinite(U).all():
        raise ValueError("U: contains NaN or inf")
    lo = U.min(axis=0)
    scale = float((U.max(axis=0) - lo).max())
    if scale <= 0:
        raise ValueError("U: all points at one place; no texture coordinates")
    return UVScaling((float(lo[0]), float(lo[1])), scale)


@dataclass(frozen=True)
class Texture:
    """A texture image for a mesh: ``kind`` (one of :data:`TEXTURES`) and its size."""

    kind: str
    squares: int
    """Squares along the longer side of the map (the texture's unit side)."""

    @property
    def spec(self) -> str:
        """The spec :func:`parse_texture` reads back, e.g. ``"checker:8"``."""
        return f"{self.kind}:{self.squares}"

    def image(self):
        """The image (a PIL image): :func:`checker_image`."""
        return checker_image(self.squares)


def parse_texture(spec: str) -> Texture:
    """The :class:`Texture` of a spec: ``checker`` (:data:`CHECKER_SQUARES` squares along the
    longer side of the map) or ``checker:N`` (N from 1 to :data:`CHECKER_MAX_SQUARES`).

    Raises
    ------
    InputError
        Any other spec; the message gives the accepted forms.
    """
    text = str(spec).strip()
    match = re.fullmatch(r"checker(?::(\d+))?", text)
    squares = CHECKER_SQUARES if match and match.group(1) is None else None
    if match and match.group(1) is not None and 1 <= int(match.group(1)) <= CHECKER_MAX_SQUARES:
        squares = int(match.group(1))
    if squares is None:
        raise InputError(f"texture: expected checker or checker:N (N squares along the longer "
                         f"side of the map, 1 to {CHECKER_MAX_SQUARES}), got {spec!r}")
    return Texture("checker", squares)


def _square_index(uv: np.ndarray, squares: int) -> np.ndarray:
    """Column and row of the checkerboard square of each texture coordinate, (K, 2) int."""
    return np.clip(np.floor(uv * squares), 0, squares - 1).astype(np.int64)


def checker_image(squares: int = CHECKER_SQUARES):
    """A checkerboard of ``squares`` x ``squares`` squares covering texture space ``[0, 1]^2``,
    as an RGB PIL image of about 1024 pixels a side.

    The square holding ``(u, v)`` has column ``i = floor(u N)`` and row ``j = floor(v N)``
    counted from the bottom (``v`` points up, as in OBJ's ``vt``; an image's rows go down), and
    the colour ``CHECKER_COLOURS[(i + j) % 2]``: the colour :func:`checker_parity` gives a
    triangle there.
    """
    from PIL import Image

    squares = int(squares)
    if not 1 <= squares <= CHECKER_MAX_SQUARES:
        raise ValueError(f"squares: expected 1 to {CHECKER_MAX_SQUARES}, got {squares}")
    pixels = max(1, _IMAGE_PIXELS // squares) * squares
    centre = (np.arange(pixels) + 0.5) / pixels  # texture coordinate of each pixel's centre
    i = _square_index(centre, squares)  # (W,) column of each pixel column
    j = _square_index(1.0 - centre, squares)  # (H,) row 0 of the image is v = 1
    parity = (i[None, :] + j[:, None]) % 2  # (H, W)
    rgb = np.asarray(CHECKER_COLOURS, dtype=np.uint8)[parity]  # (H, W, 3)
    return Image.fromarray(rgb, mode="RGB")


def checker_parity(uv, F, squares: int = CHECKER_SQUARES) -> np.ndarray:
    """For each triangle, the parity of the checkerboard square under its centroid in texture
    space: 0 for the colour ``CHECKER_COLOURS[0]``, 1 for the other (:func:`checker_image`).

    Parameters
    ----------
    uv : (K, 2) array_like
        Texture coordinates in ``[0, 1]`` (:meth:`UVScaling.apply`).
    F : (M, 3) array_like of int
    squares : int

    Returns
    -------
    (M,) int64
    """
    uv = np.asarray(uv, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    ij = _square_index(uv[F].mean(axis=1), int(squares))  # (M, 2)
    return ij.sum(axis=1) % 2


@dataclass(frozen=True)
class MapMesh:
    """A triangle mesh that carries a map (:func:`map_mesh`)."""

    vertices: np.ndarray
    """(K, 3) float64: the input points that some triangle uses, in input order."""
    faces: np.ndarray
    """(M, 3) int64 rows of ``vertices``."""
    uv: np.ndarray
    """(K, 2) float64: the map at each vertex, in the map's own (domain) coordinates."""
    rows: np.ndarray
    """(K,) int64: the input row of each vertex."""
    source: str
    """``"input"`` (the input's faces) or ``"local mesh"`` (the bare cloud's local mesh)."""
    n_input: int
    """Rows of the input."""

    @property
    def unused(self) -> int:
        """Input rows that no triangle uses, left out of the mesh (stray points, points outside
        the local mesh's main part, copies of a duplicated point)."""
        return self.n_input - len(self.rows)


def map_mesh(points, U, faces=None, *, mesh_faces=None, config=None, normals=None,
             progress: bool = False) -> MapMesh:
    """The triangle mesh that carries the map ``U`` of ``points``: the input's own ``faces``
    when it has them, else the cloud's local mesh (the triangles of the local-mesh maps,
    :func:`pcgeom.maps.localmesh.mesh_cloud`, largest connected part): the one the map kept
    (``mesh_faces``), or else rebuilt from the points and the same settings.

    Vertices that no triangle uses are left out (a reader such as trimesh drops them anyway).

    Parameters
    ----------
    points : (N, 3) array_like, or PointCloud
        A :class:`pcgeom.io.PointCloud` was checked when it was built and is not checked
        again; its normals stand for ``normals`` when that is None (its faces are not used:
        pass them as ``faces``).
    U : (N, 2) array_like
        Its map (``ParamResult.uv``).
    faces : (M, 3) array_like of int, optional
        The input's triangles.
    mesh_faces : (M, 3) array_like of int, optional
        The local mesh the map was built on (``ParamResult.mesh_faces``), when there are no
        ``faces``: nothing is rebuilt.
    config : ParamConfig, optional
        The map's config (``ParamResult.config``); its ``local_mesh`` settings rebuild the
        local mesh (without ``faces`` and ``mesh_faces``). Default: the ``fast`` preset.
    normals : (N, 3) array_like, optional
        The normals the map was made with (the input's), else estimated as the map did.
    progress : bool
        Progress of the local mesh on stderr.

    Returns
    -------
    MapMesh

    Raises
    ------
    InputError
        Bad shapes or faces; a cloud that has no local mesh (as for the map itself).
    """
    if isinstance(points, PointCloud):  # checked when it was built
        P = points.points
        normals = points.normals if normals is None else normals
    else:
        P = validate_points(points, name="points")
    U = np.asarray(U, dtype=np.float64)
    if U.shape != (len(P), 2):
        raise InputError(f"U: expected shape ({len(P)}, 2) (one row per point), got {U.shape}")
    if faces is not None:
        F = validate_faces(faces, len(P), name="faces", allow_empty=False)
        source = "input"
    elif mesh_faces is not None:
        F = validate_faces(mesh_faces, len(P), name="mesh_faces", allow_empty=False)
        source = "local mesh"
    else:
        F = _local_mesh_faces(P, config, normals, progress)
        source = "local mesh"
    rows, F = np.unique(F, return_inverse=True)  # used rows, in input order; F re-indexed
    return MapMesh(P[rows], F.reshape(-1, 3).astype(np.int64), U[rows], rows.astype(np.int64),
                   source, len(P))


def _local_mesh_faces(P: np.ndarray, config, normals, progress: bool) -> np.ndarray:
    """The triangles of the local mesh's main part, as rows of ``P``, built as
    :func:`pcgeom.maps.parametrize` builds them (duplicates removed, normalized, the first
    row's normal for a duplicated point)."""
    from ..config import get_preset
    from ..maps.localmesh import mesh_cloud

    config = config if config is not None else get_preset("fast")
    normals = validate_normals(normals, len(P))
    unique, inverse = deduplicate(P)
    first = np.full(len(unique), len(P))
    np.minimum.at(first, inverse, np.arange(len(P)))  # the first row of each distinct point
    Xn, _, _ = normalize(unique)
    settings = config.local_mesh
    mesh, _, _ = mesh_cloud(Xn, None if normals is None else normals[first], settings.neighbours,
                            settings.normal_neighbours, progress=progress,
                            normal_scales=settings.normal_scales,
                            normal_tolerance=settings.normal_tolerance)
    F = mesh.faces[mesh.main[mesh.faces].all(axis=1)]
    return first[F]
