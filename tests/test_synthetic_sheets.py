"""pcgeom.synthetic_sheets: the open test surfaces of the topology work, and their truths."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

from pcgeom import InputError
from pcgeom.maps.topology import measure
from pcgeom.metrics import angle_distortion
from pcgeom.synthetic_sheets import holed_sheet, lips_fold_scale, lips_sheet


@pytest.mark.parametrize("crease_radius", [0.0, 2.5])
def test_lips_sheet_is_a_disk_whose_walls_nearly_touch(crease_radius):
    s = lips_sheet(4000, gap=0.75, crease_radius=crease_radius)
    got = measure(s.faces)
    assert (got["euler"], got["boundary_loops"], got["genus"], got["pinched"]) == (1, 1, 0, 0)
    # Outward-consistent: the parameters map the true triangles without a flip.
    assert angle_distortion(s.points, s.faces, s.params).flipped == 0
    # Points with a neighbour of the other wall among their 8 nearest (opposite normals).
    _, nb = cKDTree(s.points).query(s.points, 9)
    cross = (np.einsum("nkd,nd->nk", s.normals[nb[:, 1:]], s.normals) < 0).any(axis=1)
    assert 0.05 < cross.mean() < 0.3, cross.mean()
    np.testing.assert_allclose(np.linalg.norm(s.normals, axis=1), 1.0)


def test_the_folds_profile_is_a_smooth_curve_by_arc_length():
    """Each fold of the lips sheet: a unit-speed curve whose tangent is the one returned, that
    leaves and meets the flat heading +x, its walls ``gap`` apart, with no crease (the
    tangent turns by under 5 degrees per 0.01 of arc length) unless ``crease_radius`` is 0."""
    from pcgeom.synthetic_sheets import _fold, _fold_length, _fold_segments, _fold_width

    for crease in (0.0, 2.5):
        seg = _fold_segments(depth=6.0, gap=0.75, bulb=2.0, crease=crease)
        for scale in (0.3, 1.0):
            t = np.linspace(0.0, float(_fold_length(np.ones(1), seg)[0]) * scale, 20001)
            x, z, tx, tz = _fold(t, np.full_like(t, scale), seg)
            step = np.hypot(np.diff(x), np.diff(z)) / np.diff(t)
            smooth = np.abs(step - 1.0) < 1e-6  # a chord across a crease is shorter
            assert (~smooth).sum() == (0 if crease else 2)  # the bulb's two creases
            assert (step < 1.0 + 1e-6).all()
            _, _, mx, mz = _fold(0.5 * (t[1:] + t[:-1]), np.full(len(t) - 1, scale), seg)
            np.testing.assert_allclose((np.diff(x) / np.diff(t))[smooth], mx[smooth], atol=1e-3)
            np.testing.assert_allclose((np.diff(z) / np.diff(t))[smooth], mz[smooth], atol=1e-3)
            # Off the flat heading +x (at t = 0 a sharp crease has turned already), onto it.
            np.testing.assert_allclose([mx[0], mz[0]], [1.0, 0.0] if crease else [0.0, -1.0],
                                       atol=1e-3)
            np.testing.assert_allclose([tx[-1], tz[-1], z[-1]], [1.0, 0.0, 0.0], atol=1e-9)
            np.testing.assert_allclose(x[-1], scale * (0.75 + 2 * crease), atol=1e-9)
            np.testing.assert_allclose(x[-1], scale * _fold_width(seg), atol=1e-9)
            turn = np.abs(np.diff(np.unwrap(np.arctan2(tz, tx))))
            dt = 0.01 * (len(t) - 1) / t[-1]
            assert (turn.max() * dt < np.radians(5)) == (crease > 0)
    # The walls: points at the same depth on both, gap apart.
    seg = _fold_segments(depth=6.0, gap=0.75, bulb=2.0, crease=2.5)
    x, z, _, _ = _fold(np.array([2.5 * np.pi / 2 + 3.0]), np.ones(1), seg)
    total = float(_fold_length(np.ones(1), seg)[0])
    x2, z2, _, _ = _fold(np.array([total - 2.5 * np.pi / 2 - 3.0]), np.ones(1), seg)
    np.testing.assert_allclose([x2[0] - x[0], z2[0] - z[0]], [0.75, 0.0], atol=1e-9)


def test_lips_fold_scale_says_where_the_folds_taper():
    """Full size on the folds in the middle rows, nothing in the first rows (the folds open
    from y = 8), 1 on the flat away from the folds."""
    s = lips_sheet(3000)
    scale = lips_fold_scale(s.params)
    deep = s.points[:, 2] < -1.0  # on a fold, below its rounded edge
    middle = np.abs(s.params[:, 1] - 40.0) < 2.0
    assert deep.any() and (scale[deep] > 0).all()
    np.testing.assert_allclose(scale[deep & middle], 1.0)  # the mouth at full size there
    first = s.params[:, 1] < 8.0
    u = s.params[first, 0]
    beside = (np.abs(u - 25.0) <= 2.0) | (np.abs(u - 50.0) <= 2.0)  # where the folds start
    assert beside.any() and (scale[first] == np.where(beside, 0.0, 1.0)).all()


@pytest.mark.parametrize("sampling", ["uniform", "grid", "scan"])
def test_holed_sheet_has_its_holes(sampling):
    s = holed_sheet(3000, radii=(2.0, 4.0), sampling=sampling)
    got = measure(s.faces)
    assert (got["boundary_loops"], got["genus"]) == (3, 0) == (s.boundary_loops, 0)
    # An isometric map up to the height field: its own parameters fold nothing.
    assert angle_distortion(s.points, s.faces, s.params).flipped == 0


def test_bad_arguments_are_one_line_errors():
    with pytest.raises(InputError, match=r"^lips_sheet: unknown sampling 'scan'"):
        lips_sheet(1000, sampling="scan")
    with pytest.raises(InputError, match=r"^lips_sheet: gap must be a number > 0, got -1"):
        lips_sheet(1000, gap=-1)
    with pytest.raises(InputError, match=r"^lips_sheet: crease_radius must be a number >= 0, "
                                         r"got -1"):
        lips_sheet(1000, crease_radius=-1)
    with pytest.raises(InputError, match=r"^lips_sheet: gap must be under the bulbs' diameter"):
        lips_sheet(1000, gap=3.5)
    with pytest.raises(InputError, match=r"^holed_sheet: unknown sampling 'x'"):
        holed_sheet(1000, sampling="x")


def test_lips_sheets_normals_are_its_surfaces():
    """The lips sheet's normals are dX/du x dX/dy: where the nostrils' scale changes along y
    the mouth's walls lean, and its true triangles' own normals agree with their corners'
    away from the folds' tapering ends (before 2026-12-05: 22 degrees at the 90th
    percentile)."""
    s = lips_sheet(3000, gap=0.75)
    F, X = s.faces, s.points
    n = np.cross(X[F[:, 1]] - X[F[:, 0]], X[F[:, 2]] - X[F[:, 0]])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    m = s.normals[F].sum(axis=1)
    m /= np.linalg.norm(m, axis=1, keepdims=True)
    angle = np.degrees(np.arccos(np.clip(np.einsum("md,md->m", n, m), -1, 1)))
    whole = (lips_fold_scale(s.params)[F] > 0.5).all(axis=1)
    assert np.percentile(angle[whole], 90) < 10, np.percentile(angle[whole], 90)
