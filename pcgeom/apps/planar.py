"""The planar helpers the boundary detection and the reconstruction share: a map checked at
the edge, its distinct points and their Delaunay triangles."""

from __future__ import annotations

import numpy as np

from ..cloud import _float_rows, deduplicate
from ..errors import InputError
from ..mesh import signed_areas

__all__ = ["validate_map", "distinct_points", "delaunay"]


def validate_map(U) -> np.ndarray:
    """``U`` as a finite (N, 2) float64 array, or InputError."""
    return _float_rows(U, "U", 2)


def distinct_points(U: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The distinct points of a map (K, 2), in order of first use, and the first input row of
    each (K,) int64; InputError when fewer than 3."""
    unique, inverse = deduplicate(U)  # unique[inverse] == U
    if len(unique) < 3:
        raise InputError(f"U: {len(unique)} distinct points (of {len(U)}), need at least 3")
    row = np.empty(len(unique), dtype=np.int64)
    row[inverse[::-1]] = np.arange(len(U))[::-1]
    return unique, row


def delaunay(U: np.ndarray) -> np.ndarray:
    """Delaunay triangles of distinct points ``U``, each counter-clockwise. (M, 3) int64."""
    from scipy.spatial import Delaunay, QhullError

    try:
        T = Delaunay(U).simplices.astype(np.int64)
    except QhullError:
        # Qhull fails on degenerate input only: all points on one line.
        raise InputError(f"U: all {len(U)} distinct points lie on one line; "
                         "a map of a surface spans an area") from None
    flip = signed_areas(U, T) < 0
    T[flip] = T[flip][:, [0, 2, 1]]
    return T
