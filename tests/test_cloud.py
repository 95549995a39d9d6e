"""Preparing a cloud for training (pcgeom.cloud): validation, faces, duplicates, normalization.

Reading files is tested in test_io.py; here the arrays are given directly.
"""

from __future__ import annotations

import numpy as np
import pytest

from pcgeom.cloud import deduplicate, fingerprint, normalize, validate_faces, validate_points
from pcgeom.errors import InputError


def _saddle() -> np.ndarray:
    """z = x^2 - y^2 on a 6 x 5 grid with non-round coordinates. (30, 3)"""
    x, y = np.meshgrid(np.linspace(-0.7, 0.9, 6), np.linspace(-0.3, 1.1, 5), indexing="xy")
    return np.column_stack([x.ravel(), y.ravel(), (x**2 - y**2).ravel()]) * np.pi


# --------------------------------------------------------------------------- points


def test_input_error_is_a_value_error():
    assert issubclass(InputError, ValueError)


def test_coplanar_is_fine():
    x, y = np.meshgrid(np.arange(4.0), np.arange(4.0))
    P = np.column_stack([x.ravel(), y.ravel(), np.zeros(16)])
    assert validate_points(P).shape == (16, 3)


def test_too_few_distinct_points():
    V = _saddle()
    P = np.vstack([V[:6]] * 3)  # 18 points, 6 distinct
    with pytest.raises(InputError, match=r"cloud: 6 distinct points \(of 18\), need at least 10"):
        validate_points(P, name="cloud")


def test_validate_points_shape_and_conversion():
    with pytest.raises(InputError, match=r"points: expected shape \(N, 3\), got \(12,\)"):
        validate_points(np.zeros(12))
    with pytest.raises(InputError, match=r"P: expected shape \(N, 3\), got \(4, 3, 1\)"):
        validate_points(np.zeros((4, 3, 1)), name="P")
    with pytest.raises(InputError, match=r"points: cannot convert to a float array"):
        validate_points([["a", "b", "c"]])
    V = _saddle()
    out = validate_points(V.astype(np.float32).tolist())
    assert out.dtype == np.float64 and out.shape == (30, 3)


# --------------------------------------------------------------------------- faces


def test_validate_faces_accepts_integers_and_whole_floats():
    F = np.array([[0, 1, 2], [2, 1, 3]], dtype=np.int32)
    out = validate_faces(F, 4)
    assert out.dtype == np.int64
    np.testing.assert_array_equal(out, F)
    out = validate_faces(F.astype(np.float64), 4)  # faces from MATLAB files
    assert out.dtype == np.int64
    np.testing.assert_array_equal(out, F)
    np.testing.assert_array_equal(validate_faces(F.tolist(), 4), F)


def test_validate_faces_empty_is_none_unless_faces_are_required():
    assert validate_faces(None, 4) is None
    assert validate_faces(np.zeros((0, 3), dtype=np.int64), 4) is None
    with pytest.raises(InputError, match=r"^mesh\.ply: expected at least one face, got none$"):
        validate_faces(None, 4, name="mesh.ply", allow_empty=False)


@pytest.mark.parametrize(
    "F, match",
    [
        (np.zeros((2, 4), dtype=np.int64), r"faces must have shape \(M, 3\), got \(2, 4\)$"),
        (np.zeros(3, dtype=np.int64), r"faces must have shape \(M, 3\), got \(3,\)$"),
        (np.array([[0, 1, 2.5]]), r"faces must hold integer vertex indices, got float64$"),
        (np.array([[0, 1, np.nan]]), r"faces must hold integer vertex indices, got float64$"),
        (np.array([[True, False, True]]), r"faces must hold integer vertex indices, got bool$"),
        (np.array([[0, 1, 4]]), r"faces reference vertex indices 0\.\.4 but there are 4 points$"),
        (np.array([[-1, 1, 2]]), r"faces reference vertex indices -1\.\.2 but there are 4 points$"),
    ],
    ids=["shape", "flat", "fraction", "nan", "bool", "above", "negative"],
)
def test_validate_faces_errors(F, match):
    with pytest.raises(InputError, match="^faces: " + match):
        validate_faces(F, 4)


# --------------------------------------------------------------------------- duplicates


def test_deduplicate_order_matches_naive_loop():
    rng = np.random.default_rng(1)
    P = rng.integers(0, 4, size=(200, 3)).astype(np.float64)
    seen: dict[tuple, int] = {}
    naive_inverse = [seen.setdefault(tuple(p), len(seen)) for p in P]
    unique, inverse = deduplicate(P)
    np.testing.assert_array_equal(unique, np.array(list(seen)))
    np.testing.assert_array_equal(inverse, naive_inverse)


# --------------------------------------------------------------------------- normalize


def test_normalize():
    V = _saddle()
    P = V * 7.0 + np.array([100.0, -3.0, 2.0])
    Pn, center, scale = normalize(P)
    np.testing.assert_allclose(Pn.mean(axis=0), 0.0, atol=1e-14)
    assert np.linalg.norm(Pn, axis=1).max() == pytest.approx(1.0, abs=1e-14)
    np.testing.assert_allclose(center, P.mean(axis=0))
    np.testing.assert_allclose(Pn * scale + center, P, atol=1e-12)
    with pytest.raises(ValueError, match=r"P: expected shape \(N, 3\) with N >= 1, got \(0, 3\)"):
        normalize(np.zeros((0, 3)))
    with pytest.raises(ValueError, match="P: cannot normalize, scale is 0.0"):
        normalize(np.ones((5, 3)))


# --------------------------------------------------------------------------- fingerprint


def test_fingerprint_identifies_the_float64_coordinates():
    import hashlib

    V = _saddle()
    assert fingerprint(V) == hashlib.sha1(V.astype(np.float64).tobytes()).hexdigest()
    assert fingerprint(V.tolist()) == fingerprint(V)  # the values, not the container
    assert fingerprint(np.asfortranarray(V)) == fingerprint(V)  # nor the memory layout
    W = V.copy()
    W[3, 2] = np.nextafter(W[3, 2], np.inf)  # one ulp
    assert fingerprint(W) != fingerprint(V)
    assert fingerprint(V[::-1]) != fingerprint(V)  # row order is part of the input


# --------------------------------------------------------------------------- adaptive PCA


def test_adaptive_pca_at_one_scale_is_the_plain_neighbourhood_pca():
    from pcgeom.neighbours import adaptive_pca, local_pca, surface_variation

    X = np.random.default_rng(0).normal(size=(2000, 3)) * [1.0, 1.0, 0.1]
    variation, normals, k, per_scale = adaptive_pca(X, scales=(16,), tolerance=0.0)
    values, vectors = local_pca(X, 16)
    np.testing.assert_allclose(variation, surface_variation(values), atol=1e-12)
    np.testing.assert_allclose(per_scale[:, 0], variation)
    np.testing.assert_allclose(np.abs((normals * vectors[:, :, 0]).sum(axis=1)), 1.0, atol=1e-9)
    assert (k == 16).all()


def test_adaptive_pca_averages_noise_on_a_plane():
    """A noisy plane is about as flat at the largest scale as at its flattest: nearly every
    point takes it, and the normals are those of the plane (the smallest scale alone tilts
    them by the noise)."""
    from pcgeom.neighbours import adaptive_pca

    rng = np.random.default_rng(1)
    X = np.column_stack([rng.uniform(size=(3000, 2)), rng.normal(scale=0.004, size=3000)])
    _, normals, k, _ = adaptive_pca(X, scales=(6, 24))
    _, small, _, _ = adaptive_pca(X, scales=(6,))
    assert np.mean(k == 24) > 0.9
    tilt = np.degrees(np.arccos(np.abs(normals[:, 2])))
    assert np.median(tilt) < 0.5 * np.median(np.degrees(np.arccos(np.abs(small[:, 2]))))


def test_adaptive_pca_keeps_the_facing_sheet_of_a_fold_out():
    """Sheets 2 spacings apart: 16 neighbours reach across and tilt the normals of several
    percent of the points by more than 30 degrees; the adaptive scale almost none (measured
    7.4% and 0.13%)."""
    from pcgeom.neighbours import adaptive_pca, local_pca
    from pcgeom.synthetic import pleated_sheet

    sheet = pleated_sheet(6000, folds=4, gap=2.0)
    _, normals, _, _ = adaptive_pca(sheet.points)
    _, vectors = local_pca(sheet.points, 16)

    def off(n):
        return np.mean(np.abs((n * sheet.normals).sum(axis=1)) < np.cos(np.radians(30)))

    assert off(vectors[:, :, 0]) > 0.03 and off(normals) < 0.005


def test_shared_neighbours_are_the_queries_each_step_made_alone():
    from scipy.spatial import cKDTree

    from pcgeom.neighbours import Neighbours, find_outliers

    rng = np.random.default_rng(3)
    X = np.column_stack([rng.uniform(-1, 1, (3000, 2)), np.zeros(3000)])
    X[:, 2] = 0.2 * np.sin(2 * X[:, 0]) + 0.01 * rng.normal(size=3000)
    X[:20, 2] += 0.5  # strays
    knn = Neighbours.of(X, 24)
    dist, index = cKDTree(X).query(X, 17)
    np.testing.assert_array_equal(knn.first(16)[1], index)
    np.testing.assert_allclose(knn.first(16)[0], dist)
    outlier = find_outliers(X, knn=knn)
    np.testing.assert_array_equal(outlier, find_outliers(X))
    assert outlier[:20].all() and outlier[20:].mean() < 0.01
    # Among the inliers: the rows that named a stray are queried again.
    sub = knn.among(~outlier, X)
    Xi = X[~outlier]
    dist, index = cKDTree(Xi).query(Xi, 25)
    np.testing.assert_array_equal(sub.index, index)
    np.testing.assert_allclose(sub.dist, dist)
    with pytest.raises(ValueError, match="30 neighbours asked of a query of 24"):
        knn.first(30)
    # A cloud smaller than the query: every other point.
    small = Neighbours.of(X[:10], 24)
    assert small.k == 9 and small.first(16)[1].shape == (10, 10)
