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


def test_a_bend_of_nothing_moves_nothing_and_a_small_one_meets_its_targets():
    from pcgeom.maps.bend import conformal_bend, spread_pairs
    from pcgeom.mesh import signed_areas

    V, F = peaks_surface("peaks3", n_side=20)
    Z = parametrize(V, "disk", progress=False).uv
    rim = np.flatnonzero(np.linalg.norm(Z, axis=1) > 1 - 1e-9)
    index = np.flatnonzero(np.linalg.norm(Z, axis=1) < 0.7)[[10, 60]]
    B = conformal_bend(V, F, Z, rim, index, Z[index])
    np.testing.assert_allclose(B, Z, atol=1e-12)
    q = Z[index] + [[0.03, 0.0], [0.0, -0.03]]
    B = conformal_bend(V, F, Z, rim, *spread_pairs(Z, index, q)[:2],
                       pair_weights=spread_pairs(Z, index, q)[2])
    assert np.abs(B[index] - q).max() < 1e-3
    np.testing.assert_allclose(np.linalg.norm(B[rim], axis=1), 1.0)
    sign = np.sign(signed_areas(Z, F).sum())
    assert not ((sign * signed_areas(Z, F) > 0) & (sign * signed_areas(B, F) <= 0)).any()


@pytest.mark.parametrize("off, bend", [(0.01, "linear"), (0.08, "barrier")])
def test_targets_off_the_conformal_image_bend_without_folds(off, bend):
    """Targets off the automorphism's image: a small offset is met by the linear bend, a
    larger one by the barrier map; either way the landmarks are met and nothing turns over."""
    V, F = peaks_surface("peaks3", n_side=30)
    plain = parametrize(V, "disk", progress=False)
    free = plain.uv
    rows = np.array([200, 470, 610])
    w = Moebius(0.7, 0.2 + 0.1j, False)(free[rows, 0] + 1j * free[rows, 1])
    w = w + off * np.exp(1j * np.array([0.3, 2.5, 4.4]))
    Q = np.column_stack([w.real, w.imag])
    result = parametrize(V, "disk", landmarks=[(V[[i]], Q[[k]]) for k, i in enumerate(rows)],
                         progress=False)
    assert result.history[0]["bend"] == bend
    assert np.abs(result.uv[rows] - Q).max() < 0.005
    # Of the local mesh: those of the landmark-free map (5 on its rim), no more.
    assert result.history[0]["flips"]["count"] <= plain.history[0]["flips"]["count"]
    before, after = angle_distortion(V, F, free), angle_distortion(V, F, result.uv)
    # The grid's own diagonals differ from the local mesh's: measured 0 and 1 of 1682.
    assert after.flipped <= 1
    assert after.mean_abs <= 1.5 * before.mean_abs


def test_polish_lowers_the_anticonformal_ratio_and_holds_landmarks_and_rim():
    """The polish of a disk map moved by an automorphism (|c| 0.36): the mean
    anti-conformal ratio of the triangles goes down, the landmarks stay on their targets, the
    rim on the circle, no triangle turns over; a map it cannot better comes back as it is."""
    from pcgeom.maps.free import _anticonformal
    from pcgeom.maps.polish import polish_disk
    from pcgeom.mesh import signed_areas

    V, F = peaks_surface("peaks3", n_side=20)
    Z0 = parametrize(V, "disk", progress=False).uv
    z = Moebius(0.3, 0.3 - 0.2j, False)(Z0[:, 0] + 1j * Z0[:, 1])
    Z = np.column_stack([z.real, z.imag])
    rim = np.flatnonzero(np.linalg.norm(Z, axis=1) > 1 - 1e-9)
    index = np.flatnonzero(np.linalg.norm(Z, axis=1) < 0.7)[[5, 50, 90]]
    U, info = polish_disk(V, F, Z, rim, index, Z[index])
    assert info["used"] and info["after"] < info["before"]
    ratio = [np.mean(_anticonformal(V, F, M[:, 0], M[:, 1])) for M in (Z, U)]
    assert ratio[1] < ratio[0]
    assert np.abs(U[index] - Z[index]).max() < 1e-4
    np.testing.assert_allclose(np.linalg.norm(U[rim], axis=1), 1.0)
    sign = np.sign(signed_areas(Z, F).sum())
    assert (sign * signed_areas(U, F) > 0).all()
    again, info = polish_disk(V, F, U, rim, index, U[index], rounds=0)
    assert not info["used"] and again is U
