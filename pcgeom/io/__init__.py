"""Files in and out: point clouds, result maps, atomic writes.

- :mod:`pcgeom.io.points`: :func:`read_points` (PLY, OBJ, OFF, XYZ/TXT/CSV, NPZ) and
  :func:`write_ply_atomic`.
- :mod:`pcgeom.io.results`: :class:`ParamResult`, the map file written by ``pcgeom param``
  (``ParamResult.save`` / ``ParamResult.load``).
- :mod:`pcgeom.io.landmarks`: :func:`read_landmarks` (JSON landmark pairs).
- :mod:`pcgeom.io.atomic`: :func:`write_atomic`, :func:`write_files_atomic`,
  :func:`check_writable`.
"""

from ..errors import InputError
from .atomic import check_writable, save_npz_atomic, write_atomic, write_files_atomic
from .landmarks import LandmarkPair, read_landmarks
from .points import SUPPORTED_EXTENSIONS, PointCloud, read_points, write_ply_atomic
from .results import ParamResult

__all__ = [
    "InputError",
    "PointCloud",
    "SUPPORTED_EXTENSIONS",
    "read_points",
    "write_ply_atomic",
    "check_writable",
    "write_atomic",
    "write_files_atomic",
    "save_npz_atomic",
    "ParamResult",
    "LandmarkPair",
    "read_landmarks",
]
