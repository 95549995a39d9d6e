"""Landmark files (pcgeom.io.landmarks) and landmarks through the CLI."""

from __future__ import annotations

import json

import numpy as np
import pytest
import torch

import pcgeom.cli.param as param_command
from pcgeom import cli
from pcgeom.errors import InputError
from pcgeom.examples import peaks_surface
from pcgeom.io import read_landmarks, write_ply_atomic
from pcgeom.io.landmarks import SNAP_SPACINGS, parse_landmarks, sample_polyline
from pcgeom.metrics import hausdorff

from tests.helpers import tiny_preset


@pytest.fixture(scope="module")
def cloud():
    return peaks_surface("peaks3", n_side=12)[0]  # (144, 3), spacing 2/11


def _write(tmp_path, data, name="marks.json"):
    path = tmp_path / name
    path.write_text(json.dumps(data))
    return path


def test_indices_and_points_and_polylines(tmp_path, cloud):
    noisy = cloud[[7, 50]] + 0.01  # within a spacing: snaps to rows 7 and 50
    data = {"landmarks": [
        {"indices": [3, 4, 5], "targets": [[0.5, 0.0], [0.6, 0.0]]},
        {"points": noisy.tolist(),
         "polylines": [[[-0.5, -0.25], [0.5, -0.25]], [[-0.5, 0.25], [0.0, 0.25], [0.5, 0.25]]],
         "spacing": 0.1},
    ]}
    a, b = read_landmarks(_write(tmp_path, data), cloud)
    np.testing.assert_array_equal(a.indices, [3, 4, 5])
    np.testing.assert_array_equal(a.targets, [[0.5, 0.0], [0.6, 0.0]])
    np.testing.assert_array_equal(b.indices, [7, 50])
    # Two curves of length 1 sampled every 0.1: 11 points each, end points included.
    assert b.targets.shape == (22, 2)
    np.testing.assert_allclose(np.unique(b.targets[:, 1]), [-0.25, 0.25])
    np.testing.assert_allclose(np.sort(b.targets[:11, 0]), np.linspace(-0.5, 0.5, 11), atol=1e-12)
    # A bare list works like {"landmarks": [...]}.
    (c,) = parse_landmarks([{"indices": [1], "targets": [[0, 0]]}], cloud)
    np.testing.assert_array_equal(c.indices, [1])


def test_sample_polyline_is_even_by_arc_length():
    S = sample_polyline([[0, 0], [1, 0], [1, 2]], 0.25)  # length 3
    assert S.shape == (13, 2)
    steps = np.linalg.norm(np.diff(S, axis=0), axis=1)
    # Chords equal the arc steps except across the corner.
    assert np.sum(np.abs(steps - 0.25) > 1e-12) <= 1
    np.testing.assert_array_equal(S[[0, -1]], [[0, 0], [1, 2]])


@pytest.mark.parametrize(
    "pair, message",
    [
        ({"indices": [1, 144], "targets": [[0, 0]]},
         "pair 0: index 144 out of range; the cloud has 144 points (0..143)"),
        ({"indices": [-1], "targets": [[0, 0]]}, "pair 0: index -1 out of range"),
        ({"indices": [], "targets": [[0, 0]]}, "pair 0: 'indices' must be a non-empty list"),
        ({"indices": [0.5], "targets": [[0, 0]]}, "pair 0: 'indices' must be integers"),
        ({"points": [[5.0, 5.0, 5.0]], "targets": [[0, 0]]},
         "pair 0: point 0 [5.0, 5.0, 5.0] is "),
        ({"indices": [1], "targets": []}, "pair 0: 'targets' must have shape (k, 2), got (0,)"),
        ({"indices": [1], "targets": [[0, 0, 0]]}, "pair 0: 'targets' must have shape (k, 2)"),
        ({"indices": [1], "targets": [[0, None]]}, "pair 0: 'targets' contains NaN or inf"),
        ({"indices": [1], "polylines": []}, "pair 0: 'polylines' is empty"),
        ({"indices": [1], "polylines": [[[0, 0], [1, 0]]]},
         "pair 0: 'polylines' need a positive 'spacing', got None"),
        ({"indices": [1], "polylines": [[[0, 0]]], "spacing": 0.1},
         "pair 0: polyline 0 needs at least 2 vertices, got 1"),
        ({"indices": [1], "points": [[0, 0, 0]], "targets": [[0, 0]]},
         "pair 0: give exactly one of 'indices' or 'points'"),
        ({"indices": [1]}, "pair 0: give exactly one of 'targets' or 'polylines'"),
        ({"indices": [1], "targets": [[0, 0]], "weight": 2}, "pair 0: unknown key(s) weight"),
    ],
)
def test_bad_pairs(tmp_path, cloud, pair, message):
    with pytest.raises(InputError) as info:
        read_landmarks(_write(tmp_path, [pair]), cloud)
    assert str(info.value).startswith(f"{tmp_path / 'marks.json'}: ")
    assert message in str(info.value)
    assert "\n" not in str(info.value)


def test_far_points_message_names_the_distance_and_rule(tmp_path, cloud):
    with pytest.raises(InputError, match=rf"more than {SNAP_SPACINGS:g} point spacings"):
        read_landmarks(_write(tmp_path, [{"points": [[0, 0, 2.0]], "targets": [[0, 0]]}]), cloud)


@pytest.mark.parametrize(
    "content, name, message",
    [
        ("[", "marks.json", "marks.json: cannot parse"),
        ("[]", "marks.json", "marks.json: expected a non-empty list of landmark pairs"),
        ('{"pairs": []}', "marks.json", "marks.json: expected a non-empty list"),
        ("[1]", "marks.json", "marks.json: pair 0: expected an object"),
        ("[]", "marks.txt", "marks.txt: landmark file must have extension '.json', got '.txt'"),
    ],
)
def test_bad_files(tmp_path, cloud, content, name, message):
    path = tmp_path / name
    path.write_text(content)
    with pytest.raises(InputError) as info:
        read_landmarks(path, cloud)
    assert message in str(info.value)
    with pytest.raises(InputError, match="absent.json: no such file"):
        read_landmarks(tmp_path / "absent.json", cloud)


# --------------------------------------------------------------------------- through the CLI


def _tiny(name: str):
    return tiny_preset(name, epochs=3, max_stages=2, refine_steps=30)


# fast onto the disk with landmarks: the barrier map pulls the conformal map onto them, and
# nothing is refined (a refinement could only fold it).
@pytest.mark.parametrize("preset, stages", [("fast", ["localmesh"]),
                                            ("networks", [1, 2, "refine"])])
def test_cli_landmarks_reach_training_and_the_report(tmp_path, monkeypatch, capsys, preset,
                                                     stages):
    monkeypatch.setattr(param_command, "get_preset", _tiny)
    torch.set_num_threads(1)
    V, F = peaks_surface("peaks3", n_side=16)
    mesh = tmp_path / "m.ply"
    write_ply_atomic(mesh, V, F)
    edge = np.flatnonzero(V[:, 0] == 1.0)  # the 16 points of the edge x = 1
    marks = _write(tmp_path, [{"indices": edge.tolist(),
                               "polylines": [[[0.9, -0.3], [0.9, 0.3]]], "spacing": 0.05}])
    out = tmp_path / "m.npz"
    argv = ["param", str(mesh), "--domain", "disk", "--landmarks", str(marks), "--quiet",
            "--json", "--out", str(out), "--preset", preset]
    assert cli.main(argv) == 0
    report = json.loads(capsys.readouterr().out)
    (fit,) = report["landmark_hausdorff"]
    from pcgeom import ParamResult

    result = ParamResult.load(out)
    target = sample_polyline([[0.9, -0.3], [0.9, 0.3]], 0.05)
    assert fit == pytest.approx(hausdorff(result.uv[edge], target), rel=1e-5)  # float32 training
    assert [r["stage"] for r in result.history] == stages
    if preset == "fast":  # the barrier map onto the disk, as onto the other domains
        assert result.history[0]["method"] == "riemann+landmarks"
        assert result.history[0]["flips"]["count"] == 0
    assert [len(r["landmark_hausdorff"]) for r in result.history] == [1] * len(stages)
    # The landmark HAND term is recorded by every stage (the first local-mesh map's at the
    # refinement's alpha).
    assert all(r["landmarks"] > 0 for r in result.history)
    # Measured 0.225 after 2 tiny stages and 30 refinement steps, one thread.
    assert fit < 0.5


def test_cli_landmark_errors_come_before_training(tmp_path, monkeypatch, capsys):
    def forbidden(*args, **kwargs):
        raise AssertionError("training started")

    monkeypatch.setattr(param_command, "parametrize", forbidden)
    monkeypatch.chdir(tmp_path)
    marks = _write(tmp_path, [{"indices": [99999], "targets": [[0, 0]]}])
    for argv, message in [
        (["--example", "peaks3", "--preset", "networks", "--landmarks", str(marks)],
         "landmarks on the free boundary are built for the local-mesh map only"),
        (["--example", "peaks3", "--landmarks", str(marks), "--landmark-weight", "-1"],
         "LocalMeshConfig.free_landmark_weight: expected a non-negative finite number"),
        (["--example", "peaks3", "--domain", "disk", "--landmarks", str(marks)],
         "pair 0: index 99999 out of range; the cloud has 5776 points"),
    ]:
        assert cli.main(["param", *argv]) == 2
        err = capsys.readouterr().err
        assert err.startswith("pcgeom: error: ") and err.count("\n") == 1 and message in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["marks.json"]


# --------------------------------------------------------------------------- free boundary


def _free_case(n_side=30, k=6, seed=2):
    """peaks3 with ``k`` landmark vertices and targets near libigl's free LSCM of its true
    mesh (scaled to a unit box, moved by 0.03 at random)."""
    import igl

    V, F = peaks_surface("peaks3", n_side=n_side)
    L0 = igl.lscm(V, F, np.array([0, len(V) - 1]), np.array([[0.0, 0.0], [1.0, 0.0]]))[0]
    rng = np.random.default_rng(seed)
    rows = rng.choice(len(V), k, replace=False)
    Q = (L0[rows] - L0.mean(axis=0)) / np.ptp(L0, axis=0).max()
    return V, F, rows, Q + 0.03 * rng.standard_normal(Q.shape)


def test_free_boundary_pins_meet_their_targets_as_libigl_does():
    import igl

    from pcgeom import parametrize
    from pcgeom.metrics import angle_distortion

    V, F, rows, Q = _free_case()
    result = parametrize(V, "free", landmarks=[(V[[i]], Q[[k]]) for k, i in enumerate(rows)],
                         progress=False)
    assert result.history[0]["free_landmarks"]["landmarks"] == "pinned"
    assert np.abs(result.uv[rows] - Q).max() < 1e-6
    ours = angle_distortion(V, F, result.uv)
    theirs = angle_distortion(V, F, igl.lscm(V, F, rows.astype(np.int64), Q)[0])
    assert ours.flipped == theirs.flipped == 0
    # Measured 1.06x (the local mesh of the bare points against the true mesh).
    assert ours.mean_abs <= 1.2 * theirs.mean_abs


def test_free_boundary_pulled_landmarks_stay_between_free_and_pinned(tmp_path, capsys):
    V, F, rows, Q = _free_case()
    mesh = tmp_path / "m.ply"
    write_ply_atomic(mesh, V, F)
    marks = _write(tmp_path, [{"indices": [int(i)], "targets": [q.tolist()]}
                              for i, q in zip(rows, Q)])
    from pcgeom import ParamResult

    misses = []
    for weight in ("0", "0.01"):
        out = tmp_path / f"m{weight}.npz"
        assert cli.main(["param", str(mesh), "--landmarks", str(marks), "--quiet", "--out",
                         str(out), "--landmark-weight", weight]) == 0
        result = ParamResult.load(out)
        misses.append(np.abs(result.uv[rows] - Q).max())
    assert misses[0] < 1e-6 < misses[1] < 0.05


def test_free_boundary_swapped_pins_warn_and_fold_nothing():
    import igl

    from pcgeom import parametrize
    from pcgeom.metrics import angle_distortion

    V, F, rows, Q = _free_case(n_side=40, k=6)
    d = np.linalg.norm(Q[:, None] - Q[None], axis=2) + 9 * np.eye(len(Q))
    a, b = np.unravel_index(np.argmin(d), d.shape)
    Q[[a, b]] = Q[[b, a]]  # the two nearest targets swapped
    assert angle_distortion(V, F, igl.lscm(V, F, rows.astype(np.int64), Q)[0]).flipped > 0
    with pytest.warns(UserWarning, match=r"pinned where asked they turn \d+ triangle\(s\) over "
                      r"\(two landmarks swapped.*pulled them instead \(weight"):
        result = parametrize(V, "free", landmarks=[(V[[i]], Q[[k]]) for k, i in enumerate(rows)],
                             progress=False)
    assert result.history[0]["free_landmarks"]["landmarks"] == "pulled"
    assert angle_distortion(V, F, result.uv).flipped == 0


def test_free_boundary_one_landmark_shifts_the_free_map():
    from pcgeom import parametrize

    V, F, rows, Q = _free_case(k=1)
    result = parametrize(V, "free", landmarks=[(V[rows], Q)], progress=False)
    assert result.history[0]["free_landmarks"]["landmarks"] == "shifted"
    assert np.abs(result.uv[rows] - Q).max() < 1e-6

