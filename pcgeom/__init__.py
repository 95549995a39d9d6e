"""pcgeom: meshless low-distortion parametrization of 3D point clouds (HAND + LEG)."""

__version__ = "0.1.0"
__all__ = ["__version__"]
