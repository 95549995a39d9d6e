"""Applications built on the core: evaluation, figures, classical baselines, boundary
detection, surface reconstruction, batches of scans on a Dask cluster.

Apps may import :mod:`pcgeom.train`, :mod:`pcgeom.metrics`, :mod:`pcgeom.io` and the
domains; nothing in the core imports an app.
"""

__all__ = ["evaluate", "plot", "baselines", "boundary", "reconstruct", "batch"]
