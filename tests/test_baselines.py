"""Classical baselines (pcgeom.apps.baselines) against analytic truths."""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest

from pcgeom.apps.baselines import BASELINES, harmonic_disk, lscm, plane_delaunay_lscm
from pcgeom.errors import InputError
from pcgeom.examples import peaks_surface
from pcgeom.metrics import angle_distortion

pytestmark = pytest.mark.skipif(importlib.util.find_spec("igl") is None, reason="needs libigl")


def _flat_tilted(n_side: int = 12):
    """The peaks grid flattened (z = 0) and rotated into a tilted plane: every conformal map of
    it is a similarity, so LSCM must have zero angle distortion."""
    V, F = peaks_surface("peaks3", n_side=n_side)
    V = V.copy()
    V[:, 2] = 0.0
    rot = np.linalg.qr(np.random.default_rng(0).normal(size=(3, 3)))[0]
    return V @ rot.T, F


def test_lscm_of_a_plane_is_a_similarity():
    V, F = _flat_tilted()
    U = lscm(V, F)
    assert U.shape == (len(V), 2) and U.dtype == np.float64
    rep = angle_distortion(V, F, U)
    assert rep.mean_abs < 1e-8 and rep.flipped == 0


def test_plane_delaunay_lscm_of_a_flat_cloud_is_a_similarity():
    V, F = _flat_tilted()
    rep = angle_distortion(V, F, plane_delaunay_lscm(V))  # points only; judged on the true F
    assert rep.mean_abs < 1e-6 and rep.flipped == 0


def test_harmonic_disk_puts_the_boundary_on_the_unit_circle():
    V, F = peaks_surface("peaks3", n_side=12)
    U = harmonic_disk(V, F)
    ring = np.unique(np.concatenate([np.arange(12), np.arange(12) * 12, np.arange(12) * 12 + 11,
                                     np.arange(132, 144)]))  # the grid's border vertices
    np.testing.assert_allclose(np.linalg.norm(U[ring], axis=1), 1.0, atol=1e-9)
    inner = np.setdiff1d(np.arange(len(V)), ring)
    assert np.linalg.norm(U[inner], axis=1).max() < 1.0
    assert angle_distortion(V, F, U).flipped == 0


def test_peaks3_figures_match_benchmarks():
    # BENCHMARKS.md (libigl 2.6.3): LSCM 0.0085, harmonic 0.1802, plane + Delaunay + LSCM 0.0077.
    V, F = peaks_surface("peaks3")
    got = {name: angle_distortion(V, F, fn(V, F)).mean_abs for name, (*_, fn) in BASELINES.items()}
    assert got == pytest.approx({"lscm": 0.0085, "harmonic_disk": 0.1802,
                                 "plane_delaunay_lscm": 0.0077}, abs=2e-4)


def test_a_closed_mesh_is_refused_before_libigl_sees_it():
    # A tetrahedron has no boundary loop.
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]])
    V = np.vstack([V, V[:3] + 2.0, V[:3] * 3.0 + [0.1, 0.2, 0.3]])  # 10 points, not collinear
    F = np.array([[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]])
    with pytest.raises(ValueError, match="F: the mesh has no boundary loop; LSCM needs one"):
        lscm(V, F)
    with pytest.raises(InputError, match=r"F: faces reference vertex indices 0\.\.12"):
        harmonic_disk(V, np.array([[0, 1, 12]]))
