"""What prepares a cloud for training: validation, deduplication, normalization, fingerprint.

Every check on user arrays lives here, once: :func:`validate_points` for coordinates and
:func:`validate_faces` for reference triangles. Both raise :class:`pcgeom.errors.InputError`
(a ``ValueError``) with a one-line message naming the argument or file.
"""

from __future__ import annotations

import hashlib

import numpy as np

from .errors import InputError, _one_line

__all__ = [
    "validate_normals",
    "validate_points",
    "validate_faces",
    "deduplicate",
    "normalize",
    "fingerprint",
]

# Second singular value below this fraction of the first: the cloud lies on a line.
_COLLINEAR_RTOL = 1e-9


def _float_rows(X, name: str, columns: int) -> np.ndarray:
    """``X`` as a float64 ``(N, columns)`` array whose rows are all finite, or a one-line
    InputError naming ``name``: the entry checks of :func:`validate_points`, shared with the
    checks of maps (``columns=2``)."""
    try:
        X = np.asarray(X, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{name}: cannot convert to a float array ({_one_line(exc)})") from None
    if X.ndim != 2 or X.shape[1] != columns:
        raise InputError(f"{name}: expected shape (N, {columns}), got {X.shape}")
    bad_rows = int((~np.isfinite(X)).any(axis=1).sum())
    if bad_rows:
        raise InputError(f"{name}: {bad_rows} of {len(X)} rows contain NaN or inf")
    return X


def validate_points(P, name: str = "points", min_points: int = 10) -> np.ndarray:
    """Check that ``P`` is a usable cloud of 3D points and return it as float64.

    Duplicate points are allowed (see :func:`deduplicate`); what is rejected is a cloud that no
    surface parametrization can work with.

    Parameters
    ----------
    P : (N, 3) array_like
        Point coordinates.
    name : str
        Name of the argument or file, used as the prefix of error messages.
    min_points : int
        Fewest points, and fewest *distinct* points, accepted.

    Returns
    -------
    P : (N, 3) float64
        ``np.asarray(P, dtype=np.float64)``.

    Raises
    ------
    InputError
        Wrong shape (not ``(N, 3)``); rows with NaN or inf; fewer than ``min_points`` points;
        all points coincident; all points on one line (second singular value of the centred
        cloud below ``1e-9`` times the first); fewer than ``min_points`` distinct points.
    """
    P = _float_rows(P, name, 3)
    n = len(P)
    if n < min_points:
        raise InputError(f"{name}: {n} points, need at least {min_points}")
    centred = P - P.mean(axis=0)
    extent = float(np.abs(centred).max())
    # Relative to the coordinates' magnitude so a far-away tiny cloud still counts as coincident.
    if extent <= 1e-12 * max(1.0, float(np.abs(P).max())):
        raise InputError(f"{name}: all {n} points coincide")
    s = np.linalg.svd(centred, compute_uv=False)  # (3,), descending
    if s[1] < _COLLINEAR_RTOL * s[0]:
        raise InputError(f"{name}: all {n} points lie on one line; need a surface")
    n_distinct = len(np.unique(P, axis=0))
    if n_distinct < min_points:
        raise InputError(
            f"{name}: {n_distinct} distinct points (of {n}), need at least {min_points}"
        )
    return P


def deduplicate(P) -> tuple[np.ndarray, np.ndarray]:
    """Remove exactly repeated points, keeping the order of first occurrence.

    Parameters
    ----------
    P : (N, d) array_like
        Points.

    Returns
    -------
    unique : (K, d) float64
        Distinct rows of ``P``, in order of first appearance.
    inverse : (N,) int64
        Indices such that ``unique[inverse] == P``.
    """
    P = np.asarray(P, dtype=np.float64)
    if P.ndim != 2:
        raise ValueError(f"P: expected a 2-D array (N, d), got shape {P.shape}")
    if len(P) == 0:
        return P.copy(), np.zeros(0, dtype=np.int64)
    sorted_unique, first, inverse = np.unique(P, axis=0, return_index=True, return_inverse=True)
    order = np.argsort(first, kind="stable")  # sorted-unique index -> position by first use
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    return sorted_unique[order], rank[inverse.reshape(-1)].astype(np.int64)


def normalize(P) -> tuple[np.ndarray, np.ndarray, float]:
    """Centre a cloud at its centroid and scale it into the unit ball.

    ``Pn = (P - center) / scale`` with ``center = mean(P)`` and
    ``scale = max_i |P_i - center|``, so the farthest point lies on the unit sphere. Undo with
    ``P = Pn * scale + center``. Loss parameters such as sigma assume this scale.

    Parameters
    ----------
    P : (N, 3) array_like
        Points.

    Returns
    -------
    Pn : (N, 3) float64
        Normalized points; centroid 0, largest norm 1.
    center : (3,) float64
        Centroid of ``P``.
    scale : float
        Largest distance from the centroid.

    Raises
    ------
    ValueError
        ``P`` is not (N, 3) with N >= 1, or all points coincide (scale 0).
    """
    P = np.asarray(P, dtype=np.float64)
    if P.ndim != 2 or P.shape[1] != 3 or len(P) == 0:
        raise ValueError(f"P: expected shape (N, 3) with N >= 1, got {P.shape}")
    center = P.mean(axis=0)
    scale = float(np.linalg.norm(P - center, axis=1).max())
    if not np.isfinite(scale) or scale == 0.0:
        raise ValueError(f"P: cannot normalize, scale is {scale} (coincident or non-finite points)")
    return (P - center) / scale, center, scale


def validate_faces(F, n_points: int, name: str = "faces", allow_empty: bool = True):
    """Check reference triangles against a cloud of ``n_points`` and return them as int64.

    Parameters
    ----------
    F : (M, 3) array_like of int, or None
        Vertex indices. Float arrays holding whole numbers (faces from MATLAB files) are
        accepted.
    n_points : int
        Number of points the indices refer to.
    name : str
        Prefix of error messages (a file name, or ``"F"``).
    allow_empty : bool
        With True, None or an empty array gives None (a bare cloud); with False it is an error
        (evaluation needs triangles).

    Returns
    -------
    (M, 3) int64, or None

    Raises
    ------
    InputError
        Wrong shape, non-integer indices, indices outside ``[0, n_points)``, or no faces when
        ``allow_empty`` is False.
    """
    if F is None or np.asarray(F).size == 0:
        if allow_empty:
            return None
        raise InputError(f"{name}: expected at least one face, got none")
    F = np.asarray(F)
    if F.ndim != 2 or F.shape[1] != 3:
        raise InputError(f"{name}: faces must have shape (M, 3), got {F.shape}")
    if not np.issubdtype(F.dtype, np.integer):
        if not (np.issubdtype(F.dtype, np.floating) and np.all(F == np.round(F))):
            raise InputError(f"{name}: faces must hold integer vertex indices, got {F.dtype}")
    F = F.astype(np.int64)
    lo, hi = int(F.min()), int(F.max())
    if lo < 0 or hi >= n_points:
        raise InputError(
            f"{name}: faces reference vertex indices {lo}..{hi} but there are {n_points} points"
        )
    return F


def validate_normals(normals, n_points: int, name: str = "normals") -> np.ndarray | None:
    """Check per-point normals against a cloud of ``n_points`` and return them as unit float64.

    Parameters
    ----------
    normals : (N, 3) array_like, or None
        One normal per point, any positive length (scanners write unit normals; others do
        not). Their sign matters: it tells the two sides of a surface apart.
    n_points : int
        Number of points the normals belong to.
    name : str
        Prefix of error messages (a file name, or ``"normals"``).

    Returns
    -------
    (N, 3) float64 of unit length, or None when ``normals`` is None

    Raises
    ------
    InputError
        Wrong shape or count, NaN or inf, or a normal of (near) zero length.
    """
    if normals is None:
        return None
    N = np.asarray(normals)
    if N.dtype.kind not in "fiu":
        raise InputError(f"{name}: normals must be numbers, got dtype {N.dtype}")
    N = N.astype(np.float64)
    if N.ndim != 2 or N.shape[1] != 3:
        raise InputError(f"{name}: expected normals of shape (N, 3), got {N.shape}")
    if len(N) != n_points:
        raise InputError(f"{name}: {len(N)} normals for {n_points} points")
    bad = ~np.isfinite(N).all(axis=1)
    if bad.any():
        raise InputError(f"{name}: normal of row {int(np.flatnonzero(bad)[0])} contains NaN or inf")
    length = np.linalg.norm(N, axis=1)
    zero = length < 1e-12
    if zero.any():
        raise InputError(f"{name}: normal of row {int(np.flatnonzero(zero)[0])} has zero length "
                         f"({int(zero.sum())} such rows)")
    return N / length[:, None]


def fingerprint(points) -> str:
    """SHA-1 of the float64 coordinates: identifies an input in checkpoints and result files."""
    return hashlib.sha1(np.ascontiguousarray(points, dtype=np.float64).tobytes()).hexdigest()
