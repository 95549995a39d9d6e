"""Landmark files: which points of the cloud go where in the domain.

A landmark file is JSON: a list of pairs (or ``{"landmarks": [...]}``). Each pair names its
landmark points on the surface and its targets in the domain; the two sides may have
different counts, and a pair may hold several curves (the paper's car windows)::

    [
      {"indices": [10, 11, 12], "targets": [[0.5, 0.0], [0.6, 0.0]]},
      {"points": [[0.1, 0.2, 0.3], [0.1, 0.25, 0.3]],
       "polylines": [[[-0.5, -0.25], [0.5, -0.25]], [[-0.5, 0.25], [0.5, 0.25]]],
       "spacing": 0.0025}
    ]

- ``indices``: rows of the input cloud (0-based); or ``points``: 3D coordinates in the
  input's frame, each snapped to its nearest input point. A coordinate farther than
  :data:`SNAP_SPACINGS` times the cloud's median point spacing from every input point is an
  error (a landmark file for another scan, or in other units).
- ``targets``: 2D points; or ``polylines``: 2D polylines sampled every ``spacing`` along
  their length (both end points included).
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from .atomic import read_json

__all__ = ["LandmarkPair", "read_landmarks", "parse_landmarks", "sample_polyline",
           "SNAP_SPACINGS"]

SNAP_SPACINGS = 5.0
"""A 3D landmark may lie at most this many median point spacings from its nearest input
point."""


@dataclass(frozen=True, eq=False)
class LandmarkPair:
    """One landmark set and its target set."""

    indices: np.ndarray
    """(n,) int64 rows of the input cloud."""
    targets: np.ndarray
    """(m, 2) float64 target points in the domain."""


def sample_polyline(vertices, spacing: float) -> np.ndarray:
    """Points every ``spacing`` along a polyline, both end points included.

    Parameters
    ----------
    vertices : (k, 2) array_like, k >= 2
    spacing : float, > 0

    Returns
    -------
    (m, 2) float64
        ``m = ceil(length / spacing) + 1`` points, evenly spaced by arc length.
    """
    V = np.asarray(vertices, dtype=np.float64)
    seg = np.linalg.norm(np.diff(V, axis=0), axis=1)  # (k - 1,)
    s = np.concatenate([[0.0], np.cumsum(seg)])  # arc length at each vertex
    m = int(np.ceil(s[-1] / spacing)) + 1
    t = np.linspace(0.0, s[-1], m)
    return np.column_stack([np.interp(t, s, V[:, 0]), np.interp(t, s, V[:, 1])])


def _array(value, shape_tail: tuple[int, ...], where: str, what: str) -> np.ndarray:
    """``value`` as a finite float array of shape (k, *shape_tail) with k >= 1."""
    try:
        A = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(f"{where}: {what} must be numbers") from None
    if A.ndim != 1 + len(shape_tail) or A.shape[1:] != shape_tail:
        want = "(k, " + ", ".join(map(str, shape_tail)) + ")"
        raise InputError(f"{where}: {what} must have shape {want}, got {A.shape}")
    if len(A) == 0:
        raise InputError(f"{where}: {what} is empty")
    if not np.isfinite(A).all():
        raise InputError(f"{where}: {what} contains NaN or inf")
    return A


def _landmark_indices(pair: dict, where: str, points: np.ndarray, tree,
                      spacing: float) -> np.ndarray:
    if ("indices" in pair) == ("points" in pair):
        raise InputError(f"{where}: give exactly one of 'indices' or 'points'")
    n = len(points)
    if "indices" in pair:
        idx = np.asarray(pair["indices"])
        if idx.ndim != 1 or len(idx) == 0:
            raise InputError(f"{where}: 'indices' must be a non-empty list of integers")
        if not (np.issubdtype(idx.dtype, np.integer)
                or (np.issubdtype(idx.dtype, np.floating) and np.all(idx == np.round(idx)))):
            raise InputError(f"{where}: 'indices' must be integers, got {idx.dtype}")
        idx = idx.astype(np.int64)
        bad = idx[(idx < 0) | (idx >= n)]
        if len(bad):
            raise InputError(f"{where}: index {int(bad[0])} out of range; the cloud has {n} "
                             f"points (0..{n - 1})")
        return idx
    xyz = _array(pair["points"], (3,), where, "'points'")
    dist, idx = tree.query(xyz)
    far = int(np.argmax(dist))
    if dist[far] > SNAP_SPACINGS * spacing:
        raise InputError(f"{where}: point {far} {xyz[far].tolist()} is {dist[far]:.4g} from the "
                         f"cloud, more than {SNAP_SPACINGS:g} point spacings ({spacing:.3g} each)")
    return idx.astype(np.int64)


def _targets(pair: dict, where: str) -> np.ndarray:
    if ("targets" in pair) == ("polylines" in pair):
        raise InputError(f"{where}: give exactly one of 'targets' or 'polylines'")
    if "targets" in pair:
        return _array(pair["targets"], (2,), where, "'targets'")
    lines = pair["polylines"]
    if not isinstance(lines, list) or not lines:
        raise InputError(f"{where}: 'polylines' is empty")
    spacing = pair.get("spacing")
    if isinstance(spacing, bool) or not isinstance(spacing, (int, float)) or not spacing > 0:
        raise InputError(f"{where}: 'polylines' need a positive 'spacing', got {spacing!r}")
    curves = []
    for k, line in enumerate(lines):
        V = _array(line, (2,), where, f"polyline {k}")
        if len(V) < 2:
            raise InputError(f"{where}: polyline {k} needs at least 2 vertices, got {len(V)}")
        curves.append(sample_polyline(V, float(spacing)))
    return np.vstack(curves)


def parse_landmarks(data, points, name: str = "landmarks") -> list[LandmarkPair]:
    """Landmark pairs from parsed JSON ``data`` (see the module doc), against ``points``.

    Parameters
    ----------
    data : list or dict
        A list of pairs, or ``{"landmarks": [...]}``.
    points : (N, 3) array_like
        The input cloud the indices refer to and 3D landmarks snap to.
    name : str
        Prefix of error messages (the file name).

    Raises
    ------
    InputError
        Wrong structure, an empty side, indices out of range, 3D points far from the cloud,
        non-finite values, or polylines without a positive spacing.
    """
    from scipy.spatial import cKDTree

    if isinstance(data, dict) and "landmarks" in data:
        data = data["landmarks"]
    if not isinstance(data, list) or not data:
        raise InputError(f"{name}: expected a non-empty list of landmark pairs")
    points = np.asarray(points, dtype=np.float64)
    tree = cKDTree(points)
    spacing = float(np.median(tree.query(points, k=2)[0][:, 1]))
    pairs = []
    for k, pair in enumerate(data):
        where = f"{name}: pair {k}"
        if not isinstance(pair, dict):
            raise InputError(f"{where}: expected an object with 'indices' or 'points' and "
                             "'targets' or 'polylines'")
        unknown = sorted(set(pair) - {"indices", "points", "targets", "polylines", "spacing"})
        if unknown:
            raise InputError(f"{where}: unknown key(s) {', '.join(unknown)}")
        pairs.append(LandmarkPair(_landmark_indices(pair, where, points, tree, spacing),
                                  _targets(pair, where)))
    return pairs


def read_landmarks(path, points) -> list[LandmarkPair]:
    """Read a landmark file (see the module doc) for the cloud ``points``.

    Raises
    ------
    InputError
        Missing or unreadable file, not JSON, or anything :func:`parse_landmarks` rejects.
    """
    data = read_json(path, "landmark file")
    return parse_landmarks(data, points, os.fspath(path))
