"""Map quality measures (pcgeom.metrics)."""

from __future__ import annotations

import importlib.util
import sys

import numpy as np
import pytest
from scipy.spatial.distance import cdist

from pcgeom.domains import Annulus, Disk, FreeBoundary, Square
from pcgeom.errors import InputError
from pcgeom.metrics import (AngleReport, angle_distortion, domain_hausdorff, hausdorff,
                            surface_hausdorff)
from pcgeom.examples import peaks_surface

requires_igl = pytest.mark.skipif(importlib.util.find_spec("igl") is None, reason="needs libigl")


def _planar_mesh() -> tuple[np.ndarray, np.ndarray]:
    """Flat grid in z = 0 with a slight shear so angles vary. V (36, 3), F (50, 3)."""
    V, F = peaks_surface("peaks3", n_side=6)
    V = V.copy()
    V[:, 0] += 0.2 * V[:, 1]
    V[:, 2] = 0.0
    return V, F


def _signed_areas(U, F) -> np.ndarray:
    """Naive loop reference for twice the signed area of each triangle. (M,)"""
    out = []
    for a, b, c in F:
        (x0, y0), (x1, y1), (x2, y2) = U[a], U[b], U[c]
        out.append((x1 - x0) * (y2 - y0) - (y1 - y0) * (x2 - x0))
    return np.array(out)


@requires_igl
def test_identity_and_similarity_have_no_distortion():
    V, F = _planar_mesh()
    report = angle_distortion(V, F, V[:, :2])
    assert isinstance(report, AngleReport)
    assert report.mean_abs < 1e-12 and report.flipped == 0 and report.n_faces == len(F)
    assert report.per_corner.shape == (len(F), 3)
    c, s = np.cos(0.7), np.sin(0.7)
    U = 3.5 * V[:, :2] @ np.array([[c, -s], [s, c]]) + np.array([10.0, -4.0])
    report = angle_distortion(V, F, U)
    assert report.mean_abs < 1e-12 and report.flipped == 0


@requires_igl
def test_mirrored_map_flips_nothing():
    V, F = _planar_mesh()
    U = V[:, :2] * np.array([1.0, -1.0])
    report = angle_distortion(V, F, U)
    assert (_signed_areas(U, F) < 0).all()  # every triangle reversed ...
    assert report.flipped == 0  # ... which is a mirror, not a fold
    assert report.mean_abs < 1e-12


@requires_igl
def test_folded_triangles_are_counted():
    # Triangle soup: each face owns its vertices, so single triangles can be mirrored.
    V0, F0 = _planar_mesh()
    V = V0[F0].reshape(-1, 3)
    F = np.arange(len(V)).reshape(-1, 3)
    U = V[:, :2].copy()
    folded = [3, 17, 40]
    for f in folded:
        U[F[f]] = U[F[f]] * np.array([-1.0, 1.0])
    report = angle_distortion(V, F, U)
    assert report.flipped == len(folded)
    assert report.mean_abs < 1e-12  # a mirrored triangle keeps its angles
    # Majority rule: mirroring all but those three leaves the same three flipped.
    report = angle_distortion(V, F, U * np.array([-1.0, 1.0]))
    assert report.flipped == len(folded)


@requires_igl
def test_fold_in_a_connected_mesh_matches_naive_count():
    V, F = _planar_mesh()
    U = V[:, :2].copy()
    U[14] = U[14] + np.array([0.9, 0.0])  # drag an interior vertex across its neighbours
    areas = _signed_areas(U, F)
    expected = min((areas > 0).sum(), (areas < 0).sum()) + (areas == 0).sum()
    report = angle_distortion(V, F, U)
    assert expected > 0 and report.flipped == expected
    assert report.mean_abs > 0.01


@requires_igl
def test_degenerate_triangle_counts_as_flipped():
    V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]])
    F = np.array([[0, 1, 2], [1, 3, 2]])
    U = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [1.0, 1.0]])  # first face collinear
    assert angle_distortion(V, F, U).flipped == 1


@requires_igl
def test_two_points_mapped_to_one_give_a_finite_distortion():
    # The right isosceles triangle (angles pi/2 at 0, pi/4 at 1 and 2) with vertices 0 and 2
    # mapped to one point: the corner at 1 closes (0), the two at the collapsed edge take
    # pi/2 each, the limit of a thinning sliver.
    V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])
    F = np.array([[0, 1, 2]])
    U = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 0.0]])
    report = angle_distortion(V, F, U)
    np.testing.assert_allclose(report.per_corner, [[0.0, np.pi / 4, np.pi / 4]], atol=1e-12)
    assert report.flipped == 1
    # A whole triangle collapsed to a point: pi/3 at every corner.
    report = angle_distortion(V, F, np.zeros((3, 2)))
    np.testing.assert_allclose(report.per_corner, [[np.pi / 6, np.pi / 12, np.pi / 12]],
                               atol=1e-12)


@requires_igl
def test_single_triangle_by_hand():
    # Right isosceles triangle (90, 45, 45 degrees) mapped to an equilateral one (60 each).
    V = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    U = np.array([[0.0, 0.0], [1.0, 0.0], [0.5, np.sqrt(3) / 2]])
    report = angle_distortion(V, [[0, 1, 2]], U)
    np.testing.assert_allclose(report.per_corner, [[np.pi / 6, np.pi / 12, np.pi / 12]])
    assert report.mean_abs == pytest.approx(np.pi / 9)
    assert report.flipped == 0 and report.n_faces == 1
    # Sorted pi/12, pi/12, pi/6: the 95th percentile sits at 0.95 * 2 = 1.9, nine tenths of
    # the way from the second value to the third.
    assert report.median_abs == pytest.approx(np.pi / 12)
    assert report.p95_abs == pytest.approx(np.pi / 12 + 0.9 * np.pi / 12)
    assert report.max_abs == pytest.approx(np.pi / 6)


@requires_igl
def test_lscm_on_peaks_is_accurate():
    import igl

    V, F = peaks_surface("peaks3")
    loop = igl.boundary_loop(F)
    pinned = np.array([loop[0], loop[len(loop) // 2]])
    uv, _ = igl.lscm(V, F, pinned, np.array([[0.0, 0.0], [1.0, 0.0]]))
    report = angle_distortion(V, F, uv)
    assert report.mean_abs < 0.02  # measured 0.0085 rad (libigl 2.6)
    assert report.flipped == 0


@requires_igl
def test_float_faces_holding_integers_are_accepted():
    V, F = _planar_mesh()
    assert angle_distortion(V, F.astype(np.float64), V[:, :2]).flipped == 0


def test_angle_distortion_input_errors():
    V, F = _planar_mesh()
    U = V[:, :2]
    with pytest.raises(ValueError, match=r"V: expected shape \(N, 3\), got \(36, 2\)"):
        angle_distortion(V[:, :2], F, U)
    match = r"U: expected shape \(36, 2\) \(one row per row of V\), got \(35, 2\)"
    with pytest.raises(ValueError, match=match):
        angle_distortion(V, F, U[:-1])
    with pytest.raises(ValueError, match=r"U: expected shape \(36, 2\) .*, got \(36, 4\)"):
        angle_distortion(V, F, np.column_stack([V, V[:, :1]]))
    # Three columns are a sphere map's unit vectors (tests/test_sphere.py): one row per vertex.
    with pytest.raises(ValueError, match=r"U: expected shape \(36, 3\) .*, got \(35, 3\)"):
        angle_distortion(V, F, V[:-1])
    U_nan = U.copy()
    U_nan[3, 1] = np.nan
    with pytest.raises(ValueError, match="U: contains NaN or inf"):
        angle_distortion(V, F, U_nan)


@pytest.mark.parametrize(
    "faces, match",
    [
        (lambda F: np.column_stack([F, F[:, 0]]),
         r"^F: faces must have shape \(M, 3\), got \(50, 4\)$"),
        (lambda F: np.zeros((0, 3), dtype=np.int64), r"^F: expected at least one face, got none$"),
        (lambda F: None, r"^F: expected at least one face, got none$"),
        (lambda F: np.vstack([F, [[0, 1, 36]]]),
         r"^F: faces reference vertex indices 0\.\.36 but there are 36 points$"),
        (lambda F: np.vstack([F, [[0, 1, -1]]]),
         r"^F: faces reference vertex indices -1\.\.35 but there are 36 points$"),
        (lambda F: F + 0.5, r"^F: faces must hold integer vertex indices, got float64$"),
        (lambda F: F.astype(str), r"^F: faces must hold integer vertex indices, got <U"),
    ],
    ids=["shape", "empty", "none", "above", "negative", "fractional", "strings"],
)
def test_angle_distortion_face_errors_come_from_the_one_face_validator(faces, match):
    """Every face problem is an InputError from pcgeom.cloud.validate_faces, named "F"."""
    V, F = _planar_mesh()
    with pytest.raises(InputError, match=match):
        angle_distortion(V, faces(F), V[:, :2])


def test_missing_igl_gives_install_command(monkeypatch):
    V, F = _planar_mesh()
    monkeypatch.setitem(sys.modules, "igl", None)  # makes `import igl` raise ImportError
    match = r"angle_distortion needs libigl: pip install 'libigl>=2\.6'"
    with pytest.raises(ImportError, match=match):
        angle_distortion(V, F, V[:, :2])


def test_hausdorff_known_value_and_naive_reference():
    assert hausdorff([[0.0, 0.0]], [[0.0, 0.0], [3.0, 4.0]]) == pytest.approx(5.0)
    assert hausdorff([[0.0, 0.0], [3.0, 4.0]], [[0.0, 0.0]]) == pytest.approx(5.0)
    rng = np.random.default_rng(2)
    A, B = rng.normal(size=(300, 3)), rng.normal(size=(170, 3)) + 0.3
    D = cdist(A, B)
    naive = max(D.min(axis=1).max(), D.min(axis=0).max())
    assert hausdorff(A, B) == pytest.approx(naive, rel=1e-12)
    assert hausdorff(A, A) == 0.0


def test_hausdorff_errors():
    with pytest.raises(ValueError, match=r"B: expected shape \(m, 2\) with m >= 1, got \(4, 3\)"):
        hausdorff(np.zeros((3, 2)), np.zeros((4, 3)))
    match = r"A: expected a non-empty \(n, d\) array, got shape \(0, 2\)"
    with pytest.raises(ValueError, match=match):
        hausdorff(np.zeros((0, 2)), np.zeros((4, 2)))
    with pytest.raises(ValueError, match="A, B: contain NaN or inf"):
        hausdorff([[np.nan, 0.0]], [[0.0, 0.0]])


def test_domain_hausdorff():
    disk = Disk()
    # Mapped cloud covers the disk: only the two samples' resolutions remain.
    assert domain_hausdorff(disk.sample(5000, seed=1), disk) < 0.03
    # Cloud squeezed into the half-radius disk misses the outer ring by about 0.5.
    assert domain_hausdorff(Disk(radius=0.5).sample(5000), disk) == pytest.approx(0.5, abs=0.01)
    # Cloud only on the circle: the centre is about 1 away.
    assert domain_hausdorff(disk.boundary(400), disk) == pytest.approx(1.0, abs=0.01)
    with pytest.raises(TypeError, match="domain: expected a pcgeom.domains.Domain, got NoneType"):
        domain_hausdorff(disk.sample(10), None)
    with pytest.raises(ValueError, match=r"U: expected shape \(N, 2\), got \(10, 3\)"):
        domain_hausdorff(np.zeros((10, 3)), disk)
    with pytest.raises(ValueError, match=r"^U: expected at least one point, got shape \(0, 2\)$"):
        domain_hausdorff(np.zeros((0, 2)), disk)


def test_domain_hausdorff_of_an_off_centre_disk():
    """The distance is to the domain where it is, not to a disk at the origin."""
    disk = Disk(center=(3.0, -2.0), radius=0.5)
    assert domain_hausdorff(disk.sample(5000, seed=1), disk) < 0.02
    # The same cloud at the origin is a whole centre offset, |(3, -2)| = 3.61, away.
    far = domain_hausdorff(Disk(radius=0.5).sample(5000, seed=1), disk)
    assert far == pytest.approx(np.hypot(3.0, 2.0), abs=0.02)


def test_domain_hausdorff_needs_a_bounded_domain():
    match = r"^domain: 'free' has no region to measure a distance to$"
    with pytest.raises(ValueError, match=match):
        domain_hausdorff(Disk().sample(10), FreeBoundary())


def test_domain_hausdorff_is_exact_outside_and_fine_inside():
    disk = Disk()
    cover = disk.sample(20000, seed=2)
    # One stray point 0.37 outside the circle: exactly 0.37, not blurred by a sample.
    stray = np.vstack([cover, [[1.37, 0.0]]])
    assert domain_hausdorff(stray, disk) == pytest.approx(0.37, abs=1e-12)
    # A hole of radius 0.05 punched around (0.3, 0.2): the true gap is between 0.05 and 0.05
    # plus the cloud's spacing; the sample under-reads it by at most its resolution (0.004),
    # where the old 20 000-point floor (0.013) would have blurred it by a quarter.
    holed = cover[np.linalg.norm(cover - [0.3, 0.2], axis=1) > 0.05]
    got = domain_hausdorff(holed, disk)
    assert 0.05 - 0.004 <= got < 0.05 + np.sqrt(np.pi / 20000)
    # A cloud that covers the disk densely reads near zero: the two samples' spacings only.
    assert domain_hausdorff(cover, disk) < np.sqrt(np.pi / 20000)


def _grid(k: int) -> tuple[np.ndarray, np.ndarray]:
    """The square [-1, 1]^2 as a k x k grid of cells, two triangles each. U (k+1)^2 x 2."""
    t = np.linspace(-1.0, 1.0, k + 1)
    U = np.stack(np.meshgrid(t, t, indexing="ij"), axis=-1).reshape(-1, 2)
    i, j = np.meshgrid(np.arange(k), np.arange(k), indexing="ij")
    a = (i * (k + 1) + j).ravel()
    b, c, d = a + k + 1, a + k + 2, a + 1
    return U, np.concatenate([np.column_stack([a, b, c]), np.column_stack([a, c, d])])


def test_surface_hausdorff_of_a_mesh_that_tiles_its_domain_is_zero():
    U, F = _grid(8)
    assert surface_hausdorff(U, F, Square()) < 1e-12
    # Its 81 vertices alone leave gaps of half a cell's diagonal: the sampling floor the
    # surface measure does not have.
    assert domain_hausdorff(U, Square()) == pytest.approx(np.hypot(0.125, 0.125), abs=0.004)


def test_surface_hausdorff_reads_a_hole_and_a_shift():
    U, F = _grid(8)
    # Drop the two triangles of the cell [0, 0.25]^2: its centre is 0.125 from the rest.
    cell = np.all(U[F] >= -1e-12, axis=(1, 2)) & np.all(U[F] <= 0.25 + 1e-12, axis=(1, 2))
    assert cell.sum() == 2
    got = surface_hausdorff(U, F[~cell], Square())
    assert 0.125 - np.sqrt(4.0 / 200_000) <= got <= 0.125 + 1e-12
    # Shifted by 0.3: exactly 0.3 outside (vertices), and the strip x < -0.7 is uncovered.
    assert surface_hausdorff(U + [0.3, 0.0], F, Square()) == pytest.approx(0.3, abs=1e-9)


def test_surface_hausdorff_of_an_inscribed_polygon_is_its_sagitta():
    k = 16
    ring = np.exp(2j * np.pi * np.arange(k) / k)
    U = np.vstack([[0.0, 0.0], np.column_stack([ring.real, ring.imag])])
    F = np.column_stack([np.zeros(k, int), 1 + np.arange(k), 1 + (np.arange(k) + 1) % k])
    sagitta = 1.0 - np.cos(np.pi / k)  # 0.0192
    got = surface_hausdorff(U, F, Disk())
    assert sagitta - np.sqrt(np.pi / 200_000) <= got <= sagitta + 1e-12
    # The folded copy of the same fan (every triangle reversed) covers the same region.
    assert surface_hausdorff(U, F[:, ::-1], Disk()) == pytest.approx(got, abs=1e-12)


def test_surface_hausdorff_sees_a_triangle_across_a_hole_with_its_vertices_inside():
    """A non-convex domain: a triangle over the annulus's hole, its three vertices inside
    the annulus, reaches the centre, 0.4 from the region; its vertices alone read 0."""
    domain = Annulus(inner=0.4)
    from scipy.spatial import Delaunay

    U = np.vstack([domain.sample(3000, seed=3), domain.boundary(400)])
    F = Delaunay(U).simplices
    F = F[domain.contains(U[F].mean(axis=1))]
    base = surface_hausdorff(U, F, domain)
    assert base < 0.01  # the two circles' chords only
    corners = np.array([[0.6, 0.0], [-0.3, 0.5], [-0.3, -0.5]])
    assert np.all(domain.contains(corners))
    V = np.vstack([U, corners])
    across = np.vstack([F, [[len(U), len(U) + 1, len(U) + 2]]])
    got = surface_hausdorff(V, across, domain)
    assert 0.39 <= got <= 0.4 + 1e-9
    assert domain_hausdorff(V, domain) < 0.05


def test_surface_hausdorff_errors():
    U, F = _grid(2)
    with pytest.raises(TypeError, match="domain: expected a pcgeom.domains.Domain, got str"):
        surface_hausdorff(U, F, "disk")
    with pytest.raises(ValueError, match=r"^domain: 'free' has no region to measure a distance"):
        surface_hausdorff(U, F, FreeBoundary())
    with pytest.raises(InputError, match="F"):
        surface_hausdorff(U, F + 100, Square())
    with pytest.raises(InputError, match="F: expected at least one face, got none"):
        surface_hausdorff(U, np.zeros((0, 3), int), Square())
    with pytest.raises(ValueError, match=r"U: expected shape \(N, 2\), got \(9, 3\)"):
        surface_hausdorff(np.zeros((9, 3)), F, Square())


def test_flip_locations_tell_the_rim_from_a_hole_and_the_inside():
    """A 20 x 20 grid with a square hole in the middle: one triangle turned over at the rim,
    one beside the hole, one in between; each is counted where it is."""
    from pcgeom.metrics import angle_distortion, flip_locations

    n = 21
    x, y = np.meshgrid(np.arange(n, dtype=float), np.arange(n, dtype=float))
    V = np.column_stack([x.ravel(), y.ravel(), np.zeros(n * n)])
    F = []
    for i in range(n - 1):
        for j in range(n - 1):
            if 9 <= i <= 10 and 9 <= j <= 10:
                continue  # the hole: cells (9..10, 9..10)
            a = i * n + j
            F += [[a, a + 1, a + n + 1], [a, a + n + 1, a + n]]
    F = np.array(F)
    U = V[:, :2].copy()

    def cell(i, j):
        return next(k for k, f in enumerate(F) if f[0] == i * n + j)

    flipped = np.zeros(len(F), dtype=bool)
    flipped[[cell(0, 3), cell(8, 9), cell(5, 5)]] = True
    assert flip_locations(V, F, flipped) == {"rim": 1, "hole": 1, "inside": 1}
    assert flip_locations(V, F, np.zeros(len(F), dtype=bool)) == {"rim": 0, "hole": 0,
                                                                  "inside": 0}
    # angle_distortion reports the same places for a map that really turns them over.
    k = cell(5, 5)
    U[F[k, 0]] = U[F[k, 1]] + U[F[k, 2]] - U[F[k, 0]] + 0.0  # reflect a corner across its edge
    report = angle_distortion(V, F, U)
    assert report.flipped >= 1
    assert report.where == {"rim": 0, "hole": 0, "inside": report.flipped}
