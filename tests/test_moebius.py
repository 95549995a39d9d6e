"""Landmarks a conformal map can meet (pcgeom.maps.moebius): the disk automorphism fitted to
them, and the map that needs no bend."""

import numpy as np
import pytest

from pcgeom import get_domain, parametrize
from pcgeom.examples import peaks_surface
from pcgeom.maps.moebius import Moebius, fit_moebius
from pcgeom.maps.riemann import domain_disk
from pcgeom.metrics import angle_distortion

pytest.importorskip("igl")


@pytest.mark.parametrize("mirror", [False, True])
def test_fit_recovers_an_automorphism(mirror):
    rng = np.random.default_rng(3)
    z = 0.8 * np.sqrt(rng.random(6)) * np.exp(2j * np.pi * rng.random(6))
    truth = Moebius(1.1, 0.4 - 0.3j, mirror)
    M, rms = fit_moebius(z, truth(z), ridge=0.0)
    assert rms < 1e-9
    assert M.mirror == mirror and abs(M.c - truth.c) < 1e-7
    assert abs(np.exp(1j * M.theta) - np.exp(1j * truth.theta)) < 1e-7


def test_one_pair_takes_the_automorphism_nearest_the_balanced_map():
    M, rms = fit_moebius([0.0], [0.3 + 0.1j], mirrors=(False,))
    assert rms < 1e-3 and abs(abs(M.c) - abs(0.3 + 0.1j)) < 2e-3  # c moves 0 onto the target


def test_forward_inverts_the_inverse_riemann_map():
    dd = domain_disk(get_domain("square"), n=2000)
    rng = np.random.default_rng(0)
    Q = rng.uniform(-0.9, 0.9, (50, 2))
    np.testing.assert_allclose(dd.inverse(dd.forward(Q)), Q, atol=1e-9)


def test_targets_an_automorphism_reaches_cost_no_distortion():
    """Targets where a disk automorphism moves the landmark-free disk map: the landmark map is
    that conformal map (no barrier bend), landmarks on target, the angle error unchanged."""
    V, F = peaks_surface("peaks3", n_side=30)
    free = parametrize(V, "disk", progress=False).uv
    rows = np.array([40, 200, 470, 610, 820])
    move = Moebius(0.7, 0.25 + 0.15j, False)  # |c| 0.29
    w = move(free[rows, 0] + 1j * free[rows, 1])
    marks = [(V[[i]], np.array([[t.real, t.imag]])) for i, t in zip(rows, w)]
    result = parametrize(V, "disk", landmarks=marks, progress=False)
    record = result.history[0]
    assert record["method"] == "riemann+landmarks" and record["bend"] == "none"
    assert np.abs(result.uv[rows] - np.column_stack([w.real, w.imag])).max() < 1e-3
    before, after = angle_distortion(V, F, free), angle_distortion(V, F, result.uv)
    assert after.flipped == before.flipped == 0
    assert after.mean_abs <= 1.1 * before.mean_abs
