"""The quality of a reconstructed mesh: :func:`mesh_report`."""

from __future__ import annotations

import numpy as np

from ...maps.topology import SPACING_NEIGHBOURS, knn_spacing
from ...mesh import half_edges


def mesh_report(V, F, points) -> dict:
    """Quality of a reconstructed mesh ``(V, F)`` against its cloud ``points``.

    Returns a dict: ``n_vertices``, ``n_faces``, ``n_boundary_loops`` (libigl),
    ``edge_manifold`` (libigl), ``oriented`` (no directed edge used twice: neighbours agree),
    ``hausdorff_rel`` and ``mean_distance_rel`` (the largest and the mean distance from each
    mesh *vertex* to its nearest cloud point, vertex-to-point, over the cloud's bounding-box
    diagonal; a vertex between cloud points is up to half a spacing from every point even on
    the true surface), ``max_offset_spacings`` (the largest vertex-to-point distance in the
    cloud's median spacing, :func:`pcgeom.maps.topology.knn_spacing`: a vertex lifted over
    the inliers stays within a spacing or so of them), ``min_angle_deg`` and ``max_aspect_ratio``
    (circumradius over twice the inradius, 1 for an equilateral triangle) of the triangles in 3D.
    """
    import igl
    from scipy.spatial import cKDTree

    V = np.asarray(V, dtype=np.float64)
    F = np.ascontiguousarray(F, dtype=np.int64)
    P = np.asarray(points, dtype=np.float64)
    manifold = bool(igl.is_edge_manifold(F)[0])
    half = half_edges(F)
    oriented = len(np.unique(half, axis=0)) == len(half)
    loops = igl.boundary_loop_all(F) if manifold else []
    diag = float(np.linalg.norm(P.max(axis=0) - P.min(axis=0)))
    dist, _ = cKDTree(P).query(V, k=1)
    spacing = float(np.median(knn_spacing(P))) if len(P) > SPACING_NEIGHBOURS else np.inf
    L = np.linalg.norm(V[F] - V[np.roll(F, -1, axis=1)], axis=2)  # (M, 3), edge k opposite k+2
    a, b, c = L[:, 0], L[:, 1], L[:, 2]
    area = 0.25 * np.sqrt(np.maximum((a + b + c) * (-a + b + c) * (a - b + c) * (a + b - c), 0))
    cos = np.clip(np.stack([(b**2 + c**2 - a**2) / (2 * b * c), (a**2 + c**2 - b**2) / (2 * a * c),
                            (a**2 + b**2 - c**2) / (2 * a * b)], axis=1), -1.0, 1.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        aspect = (a * b * c / (4 * area)) / (2 * area / (0.5 * (a + b + c)))
    return {
        "n_vertices": len(V),
        "n_faces": len(F),
        "n_boundary_loops": len(loops),
        "boundary_loop_vertices": [len(loop) for loop in loops],
        "edge_manifold": manifold,
        "oriented": bool(oriented),
        "hausdorff_rel": float(dist.max() / diag),
        "mean_distance_rel": float(dist.mean() / diag),
        "max_offset_spacings": float(dist.max() / spacing) if spacing > 0 else None,
        "min_angle_deg": float(np.degrees(np.arccos(cos).min())),
        "max_aspect_ratio": float(np.nan_to_num(aspect, nan=np.inf).max()),
    }

