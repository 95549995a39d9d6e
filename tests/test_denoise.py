"""Denoised geometry for the map (pcgeom.denoise): analytic surfaces with known noise, the
config and the ``--denoise`` option.

Thresholds are from measurement (seeds 0-2, noise 0.25 / 0.5 / 1 spacing) with a margin:
on a plane and a unit sphere cap, the denoised points' mean distance to the true surface was
0.15-0.24 of the noise's standard deviation (0.78-0.81 before), the estimated noise
0.85-0.98 of the true one, and a clean surface read below 0.001 spacings.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

import pcgeom.cli.param as param_command
from pcgeom import ParamResult, cli, parametrize
from pcgeom.config import DenoiseConfig, denoise_config, get_preset, with_denoise
from pcgeom.denoise import denoise_points, estimate_noise, fit_heights
from pcgeom.errors import InputError

from tests.helpers import assert_cli_fails, tiny_preset


def _plane(n_side: int = 30, sigma: float = 0.5, seed: int = 0) -> np.ndarray:
    """A jittered unit grid in z = 0 with Gaussian noise of std ``sigma`` along z."""
    rng = np.random.default_rng(seed)
    g = np.stack(np.meshgrid(np.arange(n_side), np.arange(n_side)), -1).reshape(-1, 2)
    g = g + rng.uniform(-0.25, 0.25, g.shape)
    return np.column_stack([g, rng.normal(scale=sigma, size=len(g))])


def _sphere_cap(sigma_spacings: float, seed: int = 0, n: int = 4000):
    """The unit sphere's cap of half-angle 60 degrees (Fibonacci points, 1000 of them), with
    radial noise of ``sigma_spacings`` spacings; the points and the noise's std."""
    i = np.arange(n) + 0.5
    z = 1 - 2 * i / n
    phi = np.pi * (1 + 5**0.5) * i
    P = np.column_stack([np.sqrt(1 - z**2) * np.cos(phi), np.sqrt(1 - z**2) * np.sin(phi), z])
    P = P[P[:, 2] > 0.5]
    sigma = sigma_spacings * np.sqrt(4 * np.pi / n)
    return P * (1 + np.random.default_rng(seed).normal(scale=sigma, size=(len(P), 1))), sigma


ON = DenoiseConfig(mode="on")


# --------------------------------------------------------------------------- analytic surfaces


@pytest.mark.parametrize("sigma", [0.25, 0.5, 1.0])
@pytest.mark.parametrize("seed", [0, 1])
def test_noisy_plane_is_fitted_and_its_noise_estimated(sigma, seed):
    X = _plane(sigma=sigma, seed=seed)
    est = estimate_noise(X, 32)  # the level a run reports (it decides with 16 neighbours)
    assert 0.75 * sigma < est.std < 1.2 * sigma
    assert 0.75 < est.spacing < 1.0  # the jittered unit grid's nearest neighbours
    Y, record = denoise_points(X, DenoiseConfig(mode="auto"))
    assert record["applied"] and record["noise"] == pytest.approx(est.relative)
    assert np.abs(X[:, 2]).mean() > 0.7 * sigma
    assert np.abs(Y[:, 2]).mean() < 0.3 * sigma
    # Each point moves across the plane, hardly along it.
    assert np.linalg.norm(Y[:, :2] - X[:, :2], axis=1).mean() < 0.1 * sigma


@pytest.mark.parametrize("sigma", [0.25, 0.5, 1.0])
@pytest.mark.parametrize("seed", [0, 1])
def test_noisy_sphere_cap_is_fitted_and_its_noise_estimated(sigma, seed):
    P, std = _sphere_cap(sigma, seed)
    est = estimate_noise(P, 32)
    assert 0.75 * std < est.std < 1.2 * std
    Y, record = denoise_points(P, ON)
    before = np.abs(np.linalg.norm(P, axis=1) - 1)
    after = np.abs(np.linalg.norm(Y, axis=1) - 1)
    assert before.mean() > 0.7 * std
    assert after.mean() < 0.3 * std
    assert after.max() < 1.5 * std


def test_clean_surfaces_read_no_noise_and_auto_leaves_them():
    for X in (_plane(sigma=0.0), _sphere_cap(0.0)[0]):
        assert estimate_noise(X).relative < 0.01
        Y, record = denoise_points(X, DenoiseConfig(mode="auto"))
        assert Y is X or np.array_equal(Y, X)
        assert not record["applied"] and record["noise"] < 0.01


@pytest.mark.parametrize("n_side, measured", [(16, 0.094), (24, 0.042), (76, 0.005)])
def test_a_coarse_clean_surface_is_not_taken_for_noise(n_side, measured):
    """A quadric over 16 neighbours follows the three peaks down to a 16 x 16 grid (the
    32-neighbour fits read 0.247 there: curvature the fit cannot follow reads as noise)."""
    from pcgeom.cloud import normalize
    from pcgeom.examples import peaks_surface

    X = normalize(peaks_surface("peaks3", n_side=n_side)[0])[0]
    assert estimate_noise(X).relative == pytest.approx(measured, abs=0.01)
    Y, record = denoise_points(X, DenoiseConfig(mode="auto"))
    assert not record["applied"] and np.array_equal(Y, X)


def test_strays_stay_where_they_are_and_a_volume_is_not_fitted():
    X = _plane(sigma=0.5)
    strays = np.array([[5.0, 5.0, 10.0], [20.0, 12.0, -8.0], [14.0, 3.0, 6.0]])
    Y, record = denoise_points(np.concatenate([X, strays]), ON)
    np.testing.assert_array_equal(Y[-3:], strays)
    assert record["strays"] == 3 and np.abs(Y[:-3, 2]).mean() < 0.15
    volume = np.random.default_rng(0).uniform(size=(2000, 3))
    Y, record = denoise_points(volume, ON)
    assert np.array_equal(Y, volume) and record["skipped"] == "not a surface"


def test_off_does_nothing_and_estimates_nothing():
    X = _plane(sigma=0.5)
    Y, record = denoise_points(X, DenoiseConfig(mode="off"))
    assert np.array_equal(Y, X) and record["noise"] is None and not record["applied"]


def test_oriented_normals_keep_two_close_sheets_apart():
    """Two noisy planes 1.5 spacings apart facing away from each other (the two sides of a
    pleat): with their normals each fit keeps its own sheet; without, the fits average the
    two sheets and pull them together."""
    top, bottom = _plane(sigma=0.25, seed=0), _plane(sigma=0.25, seed=1)
    top[:, 2] += 0.75
    bottom[:, 2] -= 0.75
    X = np.concatenate([top, bottom])
    normals = np.repeat([[0.0, 0.0, 1.0], [0.0, 0.0, -1.0]], len(top), axis=0)
    sheet = np.repeat([0.75, -0.75], len(top))
    est = estimate_noise(top)
    kept = fit_heights(X, 3.0, est.spacing, normals=normals)
    merged = fit_heights(X, 3.0, est.spacing)
    assert np.abs(kept[:, 2] - sheet).mean() < 0.1
    assert np.abs(merged[:, 2] - sheet).mean() > 0.3


# --------------------------------------------------------------------------- in a run


def test_parametrize_maps_the_fitted_points_and_reports_the_noise(tmp_path):
    P, std = _sphere_cap(0.5)
    P = np.concatenate([P, P[:5]])  # duplicates get the rows of their first copy
    config = with_denoise(get_preset("fast"), "auto")
    result = parametrize(P, config=config, progress=False)
    assert result.uv.shape == (len(P), 2)
    record = result.denoise
    assert record["applied"] and record["stage"] == "denoise"
    assert 0.75 * std < record["noise_std"] < 1.2 * std  # in the input's units
    assert result.history[0] == record and result.history[1]["kind"] == "localmesh"
    assert result.fitted.shape == P.shape
    assert np.array_equal(result.fitted[-5:], result.fitted[:5])
    assert np.abs(np.linalg.norm(result.fitted, axis=1) - 1).mean() < 0.3 * std
    loaded = ParamResult.load(result.save(tmp_path / "map.npz"))
    assert loaded.denoise == record
    np.testing.assert_array_equal(loaded.fitted, result.fitted)


def test_clean_run_keeps_its_points_and_history():
    P, _ = _sphere_cap(0.0)
    result = parametrize(P, config=get_preset("fast"), progress=False)
    assert result.fitted is None and not result.denoise["applied"]
    assert result.history[0]["kind"] == "localmesh"
    off = parametrize(P, config=with_denoise(get_preset("fast"), "off"), progress=False)
    assert off.denoise is None
    np.testing.assert_array_equal(off.uv, result.uv)


# --------------------------------------------------------------------------- config and CLI


def test_denoise_config_values():
    assert denoise_config("auto").mode == "auto"
    assert denoise_config("OFF").mode == "off"
    strength = denoise_config("2.5")
    assert (strength.mode, strength.width, strength.width_per_noise) == ("on", 2.5, 0.0)
    assert get_preset("fast").denoise.mode == "auto"
    assert get_preset("paper").denoise.mode == "off"
    assert with_denoise(get_preset("fast")) == get_preset("fast")


@pytest.mark.parametrize("value", ["-1", "0", "foo", "nan", "inf", "", True, None])
def test_denoise_config_refuses(value):
    with pytest.raises(InputError, match=r"denoise: expected auto, off or a positive number "
                                         r"\(the fit's width in spacings\), got "):
        denoise_config(value)


@pytest.mark.parametrize("field, value, message", [
    ("mode", "always", "DenoiseConfig.mode: unknown value 'always'; choose one of: auto, off, on"),
    ("width", 0, "DenoiseConfig.width: expected a positive finite number, got 0"),
    ("threshold", -0.1, "DenoiseConfig.threshold: expected a non-negative finite number"),
    ("neighbours", 8, "DenoiseConfig.neighbours: expected an int >= 12, got 8"),
])
def test_denoise_config_validation(field, value, message):
    with pytest.raises(InputError, match=message.replace("(", r"\(").replace(")", r"\)")):
        DenoiseConfig(**{field: value})


@pytest.fixture
def no_training(monkeypatch):
    def forbidden(*args, **kwargs):
        raise AssertionError("parametrize was called although the input is invalid")

    monkeypatch.setattr(param_command, "parametrize", forbidden)


@pytest.mark.parametrize("argv, message", [
    (["param", "--example", "peaks3", "--denoise", "-1"],
     "argument --denoise: expected auto, off or a positive number (the fit's width in "
     "spacings), got '-1'"),
    (["param", "--example", "peaks3", "--denoise", "foo"],
     "argument --denoise: expected auto, off or a positive number (the fit's width in "
     "spacings), got 'foo'"),
    (["reconstruct", "scan.xyz", "--out", "mesh.ply", "--denoise", "0"],
     "argument --denoise: expected auto, off or a positive number (the fit's width in "
     "spacings), got '0'"),
])
def test_bad_denoise_option_is_one_line(tmp_path, monkeypatch, capsys, no_training, argv,
                                        message):
    monkeypatch.chdir(tmp_path)
    assert_cli_fails(capsys, argv, message)
    assert list(tmp_path.iterdir()) == []


def test_reconstruct_refuses_denoise_with_a_map(tmp_path, capsys):
    np.savetxt(tmp_path / "scan.xyz", _plane(n_side=8))
    assert_cli_fails(capsys, ["reconstruct", str(tmp_path / "scan.xyz"), "--map",
                              str(tmp_path / "scan_uv.npz"), "--out", str(tmp_path / "m.ply"),
                              "--denoise", "auto"],
                     "--denoise: the map is read from --map; denoise when making it")


def test_param_reports_the_noise(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(param_command, "get_preset", tiny_preset)
    P, std = _sphere_cap(0.5)
    np.savetxt(tmp_path / "cap.xyz", P)
    for option, applied in (("auto", True), ("off", None), ("4", True)):
        assert cli.main(["param", str(tmp_path / "cap.xyz"), "--denoise", option, "--quiet",
                         "--json"]) == 0
        summary = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
        record = summary["denoise"]
        assert (record and record["applied"]) == applied
        if option == "4":
            assert record["width"] == 4.0
    assert cli.main(["param", str(tmp_path / "cap.xyz"), "--quiet"]) == 0
    assert "spacings estimated" in capsys.readouterr().out
    result = ParamResult.load(tmp_path / "cap_uv.npz")
    assert result.fitted is not None and result.denoise["noise"] > 0.3


def test_landmarks_follow_their_points_onto_the_fitted_surface():
    """A landmark named by an input point acts through that point's fitted position."""
    P, _ = _sphere_cap(0.5)
    apex = int(np.argmax(P[:, 2]))
    rim = int(np.argmin(P[:, 2]))
    landmarks = [(P[[apex]], np.array([[0.0, 0.0]])), (P[[rim]], np.array([[1.0, 0.0]]))]
    config = with_denoise(tiny_preset("fast"), "auto")
    result = parametrize(P, "disk", config=config, landmarks=landmarks, progress=False)
    assert result.denoise["applied"]
    # Measured: 0.034 and 0.002 (tiny preset: a few refinement steps).
    assert np.linalg.norm(result.uv[apex] - [0.0, 0.0]) < 0.06
    assert np.linalg.norm(result.uv[rim] - [1.0, 0.0]) < 0.02
    # The landmark points are moved exactly as the points they name.
    import torch

    from pcgeom.maps.run import _denoise

    Xn = P / np.linalg.norm(P, axis=1).max()
    marks = [torch.tensor(Xn[[apex, rim]])]
    fitted, _, _ = _denoise(Xn, None, config, marks)
    np.testing.assert_allclose(marks[0].numpy(), fitted[[apex, rim]])
