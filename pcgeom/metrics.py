"""Quality measures of a map, one implementation each: angle distortion, flips, Hausdorff.

The reference faces are used only here, to measure a map; parametrization itself never sees
them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .cloud import validate_faces
from .mesh import signed_areas, unique_edges

__all__ = ["angle_distortion", "AngleReport", "area_factor", "flip_locations", "flipped_mask",
           "hausdorff", "domain_hausdorff", "surface_hausdorff"]


@dataclass(frozen=True)
class AngleReport:
    """Result of :func:`angle_distortion`."""

    mean_abs: float
    """Mean over all triangle corners of |angle in 3D - angle in the map| (radians)."""
    flipped: int
    """Triangles whose orientation in the map is opposite to the majority."""
    n_faces: int
    """Number of triangles M."""
    per_corner: np.ndarray
    """(M, 3) absolute angle differences."""
    where: dict | None = None
    """Where the flipped triangles are (:func:`flip_locations`): ``rim``, ``hole``,
    ``inside`` counts."""

    # The order statistics are read from per_corner, so they can never disagree with it.
    @property
    def median_abs(self) -> float:
        """Median over all ``3 M`` corners of the absolute angle difference (radians)."""
        return float(np.median(self.per_corner))

    @property
    def p95_abs(self) -> float:
        """95th percentile over all ``3 M`` corners (radians), linearly interpolated between
        order statistics (``numpy.percentile``'s default): for sorted values ``d_0 <= ... <=
        d_(K-1)``, ``d_i + t (d_(i+1) - d_i)`` with ``i + t = 0.95 (K - 1)``."""
        return float(np.percentile(self.per_corner, 95.0))

    @property
    def max_abs(self) -> float:
        """Largest absolute angle difference over all corners (radians)."""
        return float(self.per_corner.max())


def _import_igl():
    try:
        import igl
    except ImportError as exc:
        raise ImportError("angle_distortion needs libigl: pip install 'libigl>=2.6'") from exc
    return igl


def _as_points(X, name: str, dim: int, rows: int | None = None) -> np.ndarray:
    """``X`` as a finite (rows, dim) float64 array, or a ValueError naming ``name``."""
    X = np.asarray(X, dtype=np.float64)
    expected = f"(N, {dim})" if rows is None else f"({rows}, {dim}) (one row per row of V)"
    if X.ndim != 2 or X.shape[1] != dim or (rows is not None and X.shape[0] != rows):
        raise ValueError(f"{name}: expected shape {expected}, got {X.shape}")
    if not np.isfinite(X).all():
        raise ValueError(f"{name}: contains NaN or inf")
    return X


def angle_distortion(V, F, U) -> AngleReport:
    """Angle distortion and flipped triangles of a map ``U`` of a triangle mesh ``(V, F)``.

    For each corner ``j`` of each triangle ``f``, ``d_fj = |theta_fj(V) - theta_fj(U)|`` where
    theta is the interior angle (libigl ``internal_angles``) in 3D and in the plane. The mean of
    ``d`` over all ``3 M`` corners is the paper's mean absolute angle distortion.

    A triangle is flipped when the sign of its signed area in the map differs from the
    majority sign (so a mirrored map has no flips); triangles of zero signed area count as
    flipped. ``flipped = min(#positive, #negative) + #zero``; :func:`flip_locations` says
    where they are.

    A corner at a zero-length edge has no angle (libigl gives NaN): where two vertices of a
    triangle coincide (two points of the cloud mapped to one, or a degenerate reference
    triangle), the corners without an angle share what the others leave of pi, the limit of a
    thinning sliver (pi/2 each for two, pi/3 for three).

    Parameters
    ----------
    V : (N, 3) array_like
        Vertices of the reference surface.
    F : (M, 3) array_like of int
        Triangles, indices into ``V``.
    U : (N, 2) or (N, 3) array_like
        The map: one 2D point per row of ``V``, or a sphere map's unit vector. On the
        sphere the angles are those of the chord triangles (the triangles of ``F`` with the
        unit vectors as corners) and a triangle's orientation is its orientation against the
        centre, the sign of ``det[U_a, U_b, U_c]`` (a mirrored map has no flips either).

    Returns
    -------
    AngleReport
        ``mean_abs`` (radians), ``flipped``, ``n_faces``, ``per_corner`` (M, 3) and ``where``
        (:func:`flip_locations`); its
        ``median_abs``, ``p95_abs`` and ``max_abs`` are order statistics of ``per_corner``.

    Raises
    ------
    ValueError
        Wrong shapes, ``U`` and ``V`` with different row counts, non-finite coordinates.
    InputError
        No faces, non-integer face indices, or faces referencing vertices outside ``V``
        (:func:`pcgeom.cloud.validate_faces`).
    ImportError
        libigl is not installed.
    """
    V = _as_points(V, "V", 3)
    sphere = np.ndim(U) == 2 and np.shape(U)[1] == 3
    U = _as_points(U, "U", 3 if sphere else 2, rows=len(V))
    F = validate_faces(F, len(V), name="F", allow_empty=False)
    igl = _import_igl()

    V = np.ascontiguousarray(V)
    F = np.ascontiguousarray(F)
    U = np.ascontiguousarray(U)
    a3 = _defined(igl.internal_angles(V, F))  # (M, 3)
    flat = U if sphere else np.column_stack([U, np.zeros(len(U))])
    a2 = _defined(igl.internal_angles(flat, F))  # (M, 3)
    diff = np.abs(a3 - a2)
    if sphere:  # (M,) six times the signed volume of the tetrahedron with the centre
        signed = np.einsum("ij,ij->i", U[F[:, 0]], np.cross(U[F[:, 1]], U[F[:, 2]]))
    else:
        signed = signed_areas(U, F)
    mask = flipped_mask(signed)
    return AngleReport(float(diff.mean()), int(mask.sum()), len(F), diff,
                       flip_locations(V, F, mask))


def area_factor(V, F, U) -> np.ndarray:
    """The conformal factor of a map ``U`` of the mesh ``(V, F)`` at each vertex: the square
    root of the ratio of the mapped to the 3D area of the triangles at the vertex, each
    normalised by its total, ``sqrt((A_U(v) / A_U) / (A_V(v) / A_V))`` (1 where the map
    keeps the surface's share of area; a conformal map scales lengths by it).

    ``U`` is (N, 2) or, for a sphere map, (N, 3) (the chord triangles' areas). (N,) float64,
    NaN at a vertex of no triangle."""
    V = np.asarray(V, dtype=np.float64)
    U = np.asarray(U, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    if U.shape[1] == 2:
        U = np.column_stack([U, np.zeros(len(U))])

    def at_vertices(P: np.ndarray) -> np.ndarray:
        a = 0.5 * np.linalg.norm(np.cross(P[F[:, 1]] - P[F[:, 0]], P[F[:, 2]] - P[F[:, 0]]),
                                 axis=1)
        per = np.bincount(F.ravel(), weights=np.repeat(a, 3), minlength=len(P))
        return per / max(a.sum(), 1e-300)

    mapped, surface = at_vertices(U), at_vertices(V)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(surface > 0, np.sqrt(mapped / np.where(surface > 0, surface, 1.0)),
                        np.nan)


def flipped_mask(signed: np.ndarray) -> np.ndarray:
    """(M,) bool: the triangles whose signed area ``signed`` (M,) has the minority sign, or
    is zero (:func:`angle_distortion`'s flips; a mirrored map has none)."""
    minority = -1.0 if (signed > 0).sum() >= (signed < 0).sum() else 1.0
    return (np.sign(signed) == minority) | (signed == 0)


def flip_locations(V, F, flipped: np.ndarray, rings: int = 2) -> dict[str, int]:
    """Where the ``flipped`` (M,) bool triangles of the mesh ``(V, F)`` are, so a user sees at
    once whether a map is usable: folds at the rim trim the surface's edge, folds inside tear
    its middle.

    A flipped triangle is on the ``rim`` when one of its corners is at most ``rings`` edges
    from the outer boundary loop (the longest loop in 3D), ``hole`` when it is that close to
    another boundary loop, else ``inside``.

    Returns
    -------
    dict
        ``{"rim": int, "hole": int, "inside": int}``, summing to ``flipped.sum()``.
    """
    import scipy.sparse as sp
    from scipy.sparse.csgraph import connected_components

    V, F = np.asarray(V, dtype=np.float64), np.asarray(F, dtype=np.int64)
    flipped = np.asarray(flipped, dtype=bool)
    out = {"rim": 0, "hole": 0, "inside": int(flipped.sum())}
    if not flipped.any():
        return out
    n = len(V)
    unique, counts = unique_edges(F, return_counts=True)
    border = unique[counts == 1]  # (B, 2)
    if not len(border):
        return out
    B = sp.coo_matrix((np.ones(len(border)), (border[:, 0], border[:, 1])), shape=(n, n))
    _, label = connected_components(B, directed=False)
    length = np.bincount(label[border[:, 0]], np.linalg.norm(V[border[:, 1]] - V[border[:, 0]],
                                                                axis=1), minlength=n)
    outer = int(np.argmax(length))
    on_border = np.zeros(n, dtype=bool)
    on_border[border.ravel()] = True
    A = sp.coo_matrix((np.ones(len(unique)), (unique[:, 0], unique[:, 1])), shape=(n, n))
    A = (A + A.T + sp.identity(n)).tocsr()
    near_rim = (on_border & (label == outer)).astype(np.float64)
    near_hole = (on_border & (label != outer)).astype(np.float64)
    for _ in range(rings):
        near_rim, near_hole = A @ near_rim, A @ near_hole
    tri = F[flipped]
    rim = (near_rim[tri] > 0).any(axis=1)
    hole = ~rim & (near_hole[tri] > 0).any(axis=1)
    return {"rim": int(rim.sum()), "hole": int(hole.sum()), "inside": int((~rim & ~hole).sum())}


def _defined(angles: np.ndarray) -> np.ndarray:
    """Corner angles (M, 3) with the NaN corners of degenerate triangles filled so that each
    triangle's angles sum to pi (see :func:`angle_distortion`)."""
    missing = ~np.isfinite(angles)
    if missing.any():
        rows = missing.any(axis=1)
        known = np.where(missing, 0.0, angles)[rows].sum(axis=1)
        share = (np.pi - known) / missing[rows].sum(axis=1)
        angles = angles.copy()
        angles[rows] = np.where(missing[rows], share[:, None], angles[rows])
    return angles


def hausdorff(A, B) -> float:
    """Exact symmetric Hausdorff distance between two point sets.

    ``H(A, B) = max(max_a min_b |a - b|, max_b min_a |a - b|)``, computed with exact
    nearest-neighbour queries (scipy ``cKDTree``) both ways.

    Parameters
    ----------
    A : (n, d) array_like
    B : (m, d) array_like
        Same dimension ``d`` as ``A``; both non-empty.

    Returns
    -------
    float
    """
    from scipy.spatial import cKDTree

    A = np.asarray(A, dtype=np.float64)
    B = np.asarray(B, dtype=np.float64)
    if A.ndim != 2 or len(A) == 0:
        raise ValueError(f"A: expected a non-empty (n, d) array, got shape {A.shape}")
    if B.ndim != 2 or len(B) == 0 or B.shape[1] != A.shape[1]:
        raise ValueError(f"B: expected shape (m, {A.shape[1]}) with m >= 1, got {B.shape}")
    if not (np.isfinite(A).all() and np.isfinite(B).all()):
        raise ValueError("A, B: contain NaN or inf")
    d_ab, _ = cKDTree(B).query(A, k=1)  # (n,)
    d_ba, _ = cKDTree(A).query(B, k=1)  # (m,)
    return float(max(d_ab.max(), d_ba.max()))


def _check_bounded(domain) -> None:
    """TypeError unless ``domain`` is a Domain, ValueError unless it has a region."""
    from pcgeom.domains import Domain

    if not isinstance(domain, Domain):
        raise TypeError(f"domain: expected a pcgeom.domains.Domain, got {type(domain).__name__}")
    if not domain.bounded:
        raise ValueError(f"domain: {domain.name!r} has no region to measure a distance to")


def domain_hausdorff(U, domain, n: int = 200_000) -> float:
    """Hausdorff distance between a mapped cloud and the region of its domain.

    ``max(d(U -> region), d(region -> U))``:

    - ``d(U -> region)``: the largest distance of a mapped point outside the region, exact
      (``domain.signed_distance``);
    - ``d(region -> U)``: the largest gap the map leaves in the region, measured at ``n``
      area-uniform samples of it (nearest mapped point of each, scipy ``cKDTree``). It
      under-reads the true gap by at most the sample spacing, about ``sqrt(area / n)``: 0.004
      on the unit disk at the default n = 200 000.

    Parameters
    ----------
    U : (N, 2) array_like
        Mapped points.
    domain : pcgeom.domains.Domain
        A bounded domain.
    n : int
        Size of the domain sample.

    Returns
    -------
    float
    """
    from scipy.spatial import cKDTree

    _check_bounded(domain)
    U = _as_points(U, "U", 2)
    if len(U) == 0:
        raise ValueError("U: expected at least one point, got shape (0, 2)")
    outside = float(max(0.0, domain.signed_distance(U).max()))
    gaps, _ = cKDTree(U).query(domain.sample(n), k=1)  # (n,)
    return max(outside, float(gaps.max()))


def surface_hausdorff(U, F, domain, n: int = 200_000, seed: int = 0) -> float:
    """Hausdorff distance between the mapped surface and the region of its domain.

    ``d_H(f(M), Omega) = max(sup_{y in f(M)} d(y, Omega), sup_{w in Omega} d(w, f(M)))``,
    with ``f(M)`` the union of the mapped reference triangles ``U[F]`` (the map extended
    linearly over each triangle). This is the quantity the paper's theorem on HAND bounds
    (section 5.1:
    ``d_H(f(M), Omega) <= h_Y + h_W + H_alpha(Y, W) + O(exp(-alpha C))``).

    :func:`domain_hausdorff` measures the mapped *points* instead, ``d_H(f(X), Omega)``, and
    so carries the term ``h_Y = d_H(f(M), f(X))``: the gaps between the cloud's own samples,
    which no map removes without distorting (a cloud of N points cannot cover the unit disk
    closer than ``sqrt(2 pi / (3 sqrt(3) N))``, 0.0145 at N = 5776). This measure has no such
    floor: it reads how well the map fills the domain and stays inside it.

    - ``sup_{w in Omega} d(w, f(M))``: ``n`` area-uniform samples of the domain; each inside
      no mapped triangle gets its exact distance to the nearest one (shapely ``STRtree``).
    - ``sup_{y in f(M)} d(y, Omega)``: exact at the vertices, and at ``n`` area-uniform
      samples of the mapped triangles (seeded by ``seed``) for edges that leave a non-convex
      domain between two vertices inside it.

    Both under-read by at most the sample spacing, about ``sqrt(area / n)``.

    Parameters
    ----------
    U : (N, 2) array_like
        The map: one 2D point per vertex.
    F : (M, 3) array_like of int
        Reference triangles, indices into ``U``.
    domain : pcgeom.domains.Domain
        A bounded domain.
    n : int
        Size of each of the two samples.
    seed : int
        Seed of the sample of the mapped triangles.

    Returns
    -------
    float

    Raises
    ------
    ValueError
        A domain without a region, wrong shapes, non-finite coordinates.
    InputError
        No faces, or faces referencing points outside ``U``
        (:func:`pcgeom.cloud.validate_faces`).
    """
    import shapely

    _check_bounded(domain)
    U = _as_points(U, "U", 2)
    F = validate_faces(F, len(U), name="F", allow_empty=False)
    corners = U[F]  # (M, 3, 2)
    tree = shapely.STRtree(shapely.polygons(corners))
    W = shapely.points(domain.sample(n))  # (n,) point geometries
    covered = np.zeros(len(W), dtype=bool)
    covered[tree.query(W, predicate="intersects")[0]] = True
    gap = 0.0
    if not covered.all():
        _, distances = tree.query_nearest(W[~covered], return_distance=True)
        gap = float(distances.max())
    # Area-uniform points of the mapped triangles: folded ones count by their unsigned area.
    area = np.abs(signed_areas(U, F))  # (M,)
    Y = U[np.unique(F)]
    if area.sum() > 0:
        rng = np.random.default_rng(seed)
        face = rng.choice(len(F), size=n, p=area / area.sum())
        a, b = rng.random(n), rng.random(n)
        fold = a + b > 1.0  # reflect into the triangle: uniform barycentric weights
        a[fold], b[fold] = 1.0 - a[fold], 1.0 - b[fold]
        e1, e2 = corners[face, 1] - corners[face, 0], corners[face, 2] - corners[face, 0]
        Y = np.vstack([Y, corners[face, 0] + a[:, None] * e1 + b[:, None] * e2])
    outside = float(max(0.0, domain.signed_distance(Y).max()))
    return max(outside, gap)
