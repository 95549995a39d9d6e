"""Evaluate a map: the report ``pcgeom param`` and ``pcgeom evaluate`` print.

Wraps :mod:`pcgeom.metrics` (one implementation of each measure) into one plain dict per map,
the same for a fresh result and for a map file read back with ``ParamResult.load``.
"""

from __future__ import annotations

import numpy as np

from ..domains import Domain
from ..metrics import angle_distortion, domain_hausdorff

__all__ = ["map_report"]


def map_report(U, domain: Domain | None = None, V=None, F=None) -> dict:
    """Quality figures of a map, as plain data (JSON-ready).

    Parameters
    ----------
    U : (N, 2) array_like
        The map.
    domain : Domain, optional
        Its parameter domain; a bounded one adds ``domain_hausdorff``.
    V, F : (N, 3) and (M, 3) array_like, optional
        Reference mesh (one vertex per row of ``U``); adds the angle distortion and flips.

    Returns
    -------
    dict
        ``n_points``; ``mean_abs_angle_rad``, ``flipped``, ``n_faces`` and ``flipped_percent``
        when faces are given; ``domain_hausdorff`` when the domain is bounded. Keys whose
        measure does not apply are None.
    """
    U = np.asarray(U, dtype=np.float64)
    report = {"n_points": int(len(U)), "mean_abs_angle_rad": None, "flipped": None,
              "n_faces": None, "flipped_percent": None, "domain_hausdorff": None}
    if F is not None:
        rep = angle_distortion(V, F, U)
        report.update(mean_abs_angle_rad=rep.mean_abs, flipped=rep.flipped, n_faces=rep.n_faces,
                      flipped_percent=100.0 * rep.flipped / rep.n_faces)
    if domain is not None and domain.bounded:
        report["domain_hausdorff"] = domain_hausdorff(U, domain)
    return report
