"""Quality of a map on a reference mesh: angle distortion, flips, domain fit."""

from __future__ import annotations

import numpy as np

__all__ = ["angle_distortion", "AngleReport"]

from dataclasses import dataclass


@dataclass(frozen=True)
class AngleReport:
    mean_abs: float
    """Mean over all triangle corners of |angle in 3D - angle in the map| (radians)."""
    flipped: int
    """Triangles whose orientation in the map is opposite to the majority."""
    n_faces: int
    per_corner: np.ndarray
    """(M, 3) absolute angle differences."""


def angle_distortion(V: np.ndarray, F: np.ndarray, U: np.ndarray) -> AngleReport:
    import igl

    V = np.ascontiguousarray(V, dtype=np.float64)
    F = np.ascontiguousarray(F, dtype=np.int64)
    U = np.ascontiguousarray(U, dtype=np.float64)
    a3 = igl.internal_angles(V, F)
    a2 = igl.internal_angles(np.column_stack([U, np.zeros(len(U))]), F)
    diff = np.abs(a3 - a2)
    e1 = U[F[:, 1]] - U[F[:, 0]]
    e2 = U[F[:, 2]] - U[F[:, 0]]
    signed = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    pos, neg = int((signed > 0).sum()), int((signed < 0).sum())
    flipped = min(pos, neg) + int((signed == 0).sum())
    return AngleReport(float(diff.mean()), flipped, len(F), diff)
