"""pcgeom: meshless low-distortion parametrization of 3D point clouds (HAND + LEG).

The public API::

    import pcgeom
    cloud = pcgeom.read_points("scan.ply")
    result = pcgeom.parametrize(cloud, "disk", config=pcgeom.get_preset("fast"))
    result.save("scan_uv.npz")
    again = pcgeom.ParamResult.load("scan_uv.npz")
"""

from ._version import __version__
from .config import get_preset
from .domains import get_domain
from .errors import InputError
from .io import ParamResult, read_points
from .maps import parametrize

__all__ = [
    "__version__",
    "parametrize",
    "ParamResult",
    "get_preset",
    "read_points",
    "get_domain",
    "InputError",
]
