"""Analytic closed test surfaces (:mod:`pcgeom.synthetic_closed`): their true triangulations
are closed, edge-manifold, outward and of the right genus; normals and noise as documented."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from pcgeom.errors import InputError
from pcgeom.synthetic_closed import SAMPLINGS, SHAPES, closed_surface


@pytest.mark.parametrize("name", SHAPES)
@pytest.mark.parametrize("sampling", SAMPLINGS)
def test_true_mesh_is_closed_outward_and_of_the_genus(name, sampling):
    s = closed_surface(name, 1500, sampling=sampling, seed=3)
    mesh = trimesh.Trimesh(s.clean_points, s.faces, process=False)
    euler = len(s.points) - len(mesh.edges_unique) + len(s.faces)
    assert euler == 2 - 2 * s.genus
    assert mesh.is_watertight and mesh.is_winding_consistent
    assert mesh.volume > 0  # outward
    # Analytic normals agree with the true mesh's own face normals around each point.
    fn = mesh.face_normals
    agree = np.einsum("ij,ij->i", fn, s.normals[s.faces].mean(axis=1))
    # (The sparse bottom of a 1500-point scan of the torus has coarse triangles.)
    assert np.median(agree) > 0.98 and np.percentile(agree, 1) > 0.8


def test_sphere_points_lie_on_it_and_noise_is_in_spacings():
    clean = closed_surface("sphere", 4000, seed=0)
    np.testing.assert_allclose(np.linalg.norm(clean.points, axis=1), 1.0, atol=1e-12)
    np.testing.assert_allclose(clean.normals, clean.points, atol=1e-6)
    noisy = closed_surface("sphere", 4000, noise=0.5, seed=0)
    np.testing.assert_array_equal(noisy.clean_points, clean.points)
    offset = np.linalg.norm(noisy.points, axis=1) - 1.0
    assert abs(offset.std() / noisy.spacing - 0.5) < 0.05


def test_scan_sampling_is_denser_on_top():
    s = closed_surface("ellipsoid", 6000, sampling="scan", seed=0)
    top = (s.points[:, 2] > 0.25).sum()
    bottom = (s.points[:, 2] < -0.25).sum()
    assert top > 3 * bottom


@pytest.mark.parametrize("kwargs, message", [
    ({"name": "cube"}, "unknown shape 'cube'"),
    ({"sampling": "random"}, "unknown sampling 'random'"),
    ({"n": 10}, "n must be an integer >= 100"),
    ({"noise": -1.0}, "noise must be a number >= 0"),
])
def test_bad_arguments(kwargs, message):
    with pytest.raises(InputError, match=message):
        closed_surface(**kwargs)
