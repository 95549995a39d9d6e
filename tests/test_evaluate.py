"""Evaluation of a map (pcgeom.apps.evaluate): hand-computed angle figures on two triangles,
the landmark and domain distances, the timed baselines and the figures of ``--plot DIR``."""

from __future__ import annotations

import json

import numpy as np
import pytest

from pcgeom import cli, parametrize
from pcgeom.apps.baselines import harmonic_disk, lscm
from pcgeom.apps.evaluate import (PLOT_FILES, angle_figures, evaluate_map, has_losses, landmark_hausdorff,
                                  map_report, plot_evaluation, run_baselines,
                                  vertex_angle_distortion)
from pcgeom.apps.plot import plot_angle_histogram
from pcgeom.domains import Disk
from pcgeom.examples import peaks_surface
from pcgeom.io import write_ply_atomic
from pcgeom.metrics import angle_distortion, domain_hausdorff, hausdorff, surface_hausdorff

from tests.helpers import tiny_preset

igl = pytest.importorskip("igl")

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def _two_triangles():
    """The unit square split along its diagonal, and a map that keeps the first triangle and
    makes the second one equilateral (vertex 3 rotated to 60 degrees from the diagonal).

    Corner angles, in degrees, (corner order of each face):
    3D:  face (0, 1, 2): 45, 90, 45;  face (0, 2, 3): 45, 45, 90
    map: face (0, 1, 2): 45, 90, 45;  face (0, 2, 3): 60, 60, 60
    so the six distortions are 0, 0, 0, 15, 15, 30 degrees.
    """
    V = np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]])
    F = np.array([[0, 1, 2], [0, 2, 3]])
    c, s = np.cos(np.pi / 3), np.sin(np.pi / 3)
    U = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [c - s, s + c]])
    return V, F, U


def test_two_triangles_by_hand():
    V, F, U = _two_triangles()
    deg = np.pi / 180
    report = map_report(U, V=V, F=F)
    np.testing.assert_allclose(angle_distortion(V, F, U).per_corner,
                               [[0, 0, 0], [15 * deg, 15 * deg, 30 * deg]], atol=1e-12)
    assert report["mean_abs_angle_rad"] == pytest.approx(10 * deg, abs=1e-12)  # 60 / 6
    # Sorted 0, 0, 0, 15, 15, 30: the median is between the third and fourth values ...
    assert report["median_abs_angle_rad"] == pytest.approx(7.5 * deg, abs=1e-12)
    # ... the 95th percentile at position 0.95 * 5 = 4.75: 15 + 0.75 (30 - 15) = 26.25.
    assert report["p95_abs_angle_rad"] == pytest.approx(26.25 * deg, abs=1e-12)
    assert report["max_abs_angle_rad"] == pytest.approx(30 * deg, abs=1e-12)
    assert (report["flipped"], report["n_faces"], report["flipped_percent"]) == (0, 2, 0.0)
    assert report["n_points"] == 4
    assert report["domain_hausdorff"] is None and report["landmark_hausdorff"] is None
    assert report["surface_hausdorff"] is None


def test_report_without_faces_has_no_angle_figures():
    report = map_report(np.zeros((5, 2)))
    assert report == {"n_points": 5, **dict.fromkeys(angle_figures(None)),
                      "domain_hausdorff": None, "surface_hausdorff": None,
                      "landmark_hausdorff": None}


def test_domain_and_landmark_distances_of_a_trained_map():
    V, F = peaks_surface("peaks3", n_side=12)
    edge = np.flatnonzero(V[:, 0] == 1.0)
    targets = np.column_stack([np.full(11, 0.9), np.linspace(-0.3, 0.3, 11)])
    result = parametrize(V, "disk", config=tiny_preset("fast"), landmarks=[(V[edge], targets)],
                         progress=False)
    report = map_report(result.uv, result.domain, V, F, history=result.history)
    assert report["domain_hausdorff"] == domain_hausdorff(result.uv, Disk())
    # The mapped triangles fill the disk closer than the mapped points (no sampling floor).
    assert report["surface_hausdorff"] == surface_hausdorff(result.uv, F, Disk())
    assert report["surface_hausdorff"] < report["domain_hausdorff"]
    (fit,) = report["landmark_hausdorff"]
    assert fit == result.history[-1]["landmark_hausdorff"][0]
    assert fit == pytest.approx(hausdorff(result.uv[edge], targets), rel=1e-5)  # float32 run
    assert landmark_hausdorff([]) is None and landmark_hausdorff([{"total": 1.0}]) is None


def test_baselines_are_timed_and_measured_like_the_map():
    V, F = peaks_surface("peaks3", n_side=10)
    runs = run_baselines(V, F)
    assert [r.name for r in runs] == ["lscm", "harmonic_disk"]
    for run, method in zip(runs, (lscm, harmonic_disk)):
        assert run.error is None and run.seconds > 0
        expected = angle_distortion(V, F, method(V, F))
        np.testing.assert_allclose(run.angles.per_corner, expected.per_corner, atol=1e-9)
        figures = run.to_dict()
        assert figures["p95_abs_angle_rad"] == pytest.approx(expected.p95_abs, abs=1e-9)
        assert figures["label"].startswith(("LSCM", "harmonic disk map"))
    with pytest.raises(ValueError, match="baselines: unknown 'abf'; expected some of lscm, "):
        run_baselines(V, F, ["lscm", "abf"])


def test_a_closed_mesh_reports_the_baselines_as_not_run():
    import trimesh

    sphere = trimesh.creation.icosphere(subdivisions=1)
    V, F = np.asarray(sphere.vertices), np.asarray(sphere.faces, dtype=np.int64)
    evaluation = evaluate_map(V[:, :2], V, F)
    assert evaluation.report["n_faces"] == len(F) == 80
    for name, base in evaluation.report["baselines"].items():
        assert base["seconds"] is None and base["mean_abs_angle_rad"] is None
        assert "no boundary loop" in base["error"]
    json.dumps(evaluation.report)  # JSON-ready


def test_vertex_angle_distortion_matches_a_loop():
    V, F = peaks_surface("peaks3", n_side=7)
    d = np.random.default_rng(0).random(F.shape)
    got = vertex_angle_distortion(F, d, len(V) + 1)  # one more vertex, in no triangle
    for v in range(len(V)):
        assert got[v] == pytest.approx(d[F == v].mean(), rel=1e-12)
    assert np.isnan(got[-1])
    with pytest.raises(ValueError, match=r"per_corner: expected shape \(72, 3\) .*got \(72,\)"):
        vertex_angle_distortion(F, d[:, 0], len(V))


def test_plot_evaluation_writes_the_figures(tmp_path):
    V, F = peaks_surface("peaks3", n_side=10)
    U = lscm(V, F)
    history = [{"stage": 1, "total": 1.0, "leg": 0.5}, {"stage": "refine", "total": 0.4}]
    evaluation = evaluate_map(U, V, F, history=history)
    written = plot_evaluation(evaluation, tmp_path / "figs", title="peaks3")
    assert set(written) == set(PLOT_FILES) - {"sphere_factor"}  # that one: a sphere map's
    for key, path in written.items():
        assert path == tmp_path / "figs" / PLOT_FILES[key]
        assert path.read_bytes()[:8] == PNG_SIGNATURE
    no_history = plot_evaluation(evaluate_map(U, V, F, baselines=()), tmp_path / "figs2")
    assert no_history["history"] is None and not (tmp_path / "figs2" / "history.png").exists()
    # A local-mesh map's history (preset fast) records no loss: no (empty) figure.
    local = [{"stage": "localmesh", "kind": "localmesh", "flips": 0, "seconds": 0.1}]
    assert not has_losses(local) and has_losses(history) and not has_losses([])
    written = plot_evaluation(evaluate_map(U, V, F, history=local, baselines=()),
                              tmp_path / "figs3")
    assert written["history"] is None and not (tmp_path / "figs3" / "history.png").exists()


def test_angle_histogram_overlay_rejects_bad_values(tmp_path):
    d = np.abs(np.random.default_rng(1).normal(0, 0.1, 90))
    path = plot_angle_histogram(d, tmp_path / "a.png", others={"LSCM": d * 2, "harmonic": d})
    assert path.read_bytes()[:8] == PNG_SIGNATURE
    with pytest.raises(ValueError, match=r"others\['LSCM'\]: contains NaN or inf"):
        plot_angle_histogram(d, tmp_path / "a.png", others={"LSCM": [np.nan]})
    with pytest.raises(ValueError, match=r"others\['LSCM'\]: expected at least one value"):
        plot_angle_histogram(d, tmp_path / "a.png", others={"LSCM": []})


def test_cli_png_plot_is_the_histogram_only(tmp_path, capsys):
    V, F = peaks_surface("peaks3", n_side=10)
    mesh = tmp_path / "mesh.ply"
    write_ply_atomic(mesh, V, F)
    mapped = tmp_path / "map.npz"
    np.savez(mapped, uv=lscm(V, F))
    png = tmp_path / "angles.png"
    assert cli.main(["evaluate", str(mesh), str(mapped), "--plot", str(png), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["plots"] == {"angles": str(png)}
    assert png.read_bytes()[:8] == PNG_SIGNATURE
    assert report["baselines"]["lscm"]["mean_abs_angle_rad"] == pytest.approx(
        report["mean_abs_angle_rad"], abs=1e-9)  # the same map, measured the same way
