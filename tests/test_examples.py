"""The example scripts of examples/ run with --quick and their JSON holds each one's claim.

The scripts are loaded from their files and their ``main(argv)`` called in this process (no
interpreter and torch start-up per script). Those that need the shared test surfaces skip
when ../shared/data is absent.
"""

from __future__ import annotations

import importlib.util
import json
import sys
from pathlib import Path

import numpy as np
import pytest
import torch

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
DATA = EXAMPLES.parent.parent / "shared" / "data"


def _load(name: str):
    """The script ``examples/NAME.py`` as a module (its folder on sys.path for _common)."""
    if str(EXAMPLES) not in sys.path:
        sys.path.insert(0, str(EXAMPLES))
    spec = importlib.util.spec_from_file_location(f"examples_{name}", EXAMPLES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _run(name: str, out: Path, *extra: str) -> dict:
    torch.set_num_threads(1)
    assert _load(name).main(["--out", str(out), "--quick", *extra]) == 0
    result = json.loads((out / f"{name}.json").read_text())
    for fig in result["figures"]:
        assert (out / fig).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    return result


def _needs(name: str):
    return pytest.mark.skipif(not (DATA / name).is_file(), reason=f"needs {DATA / name}")


def test_hand_only_hausdorff_falls_with_alpha(tmp_path):
    result = _run("hand_only", tmp_path)
    assert [r["alpha"] for r in result["rows"]] == [2, 5, 10, 25, 50, 100]
    hs = [r["hausdorff"] for r in result["rows"]]
    assert np.isfinite(hs).all()
    # Measured with --quick (500 points, 40 steps): 0.59 at alpha 2, 0.42 at alpha 100.
    assert result["hausdorff_alpha100"] < 0.85 * result["hausdorff_alpha2"]
    assert result["falls_from_2_to_100"] is True


def test_hand_only_blob_is_irregular_and_uniform():
    module = _load("hand_only")
    n = 4000
    blob = module.blob(n, seed=1)
    assert blob.shape == (n, 2)
    r = np.linalg.norm(blob - [0.15, -0.1], axis=1)
    assert 0.75 < r.max() < 0.9  # the widest lobe; the narrowest is about 0.3
    # Area-uniform: the share within 0.2 of the centre is that disk's share of the blob's
    # area (0.5 * integral of r(t)^2), within 4 binomial standard deviations.
    t = np.linspace(0, 2 * np.pi, 20001)[:-1]
    radius = 0.55 * (1 + 0.25 * np.sin(2 * t + 0.3) + 0.15 * np.cos(3 * t)
                     + 0.1 * np.sin(5 * t + 1.0))
    assert radius.min() > 0.2
    share = np.pi * 0.2**2 / (0.5 * np.mean(radius**2) * 2 * np.pi)
    assert abs((r < 0.2).mean() - share) < 4 * np.sqrt(share * (1 - share) / n)


@_needs("face_human_choi.ply")
def test_face_disk_records_every_stage(tmp_path):
    result = _run("face_disk", tmp_path)
    stages = result["networks"]["stages"]
    assert [s["stage"] for s in stages] == [1, 2, "refine"]
    for s in stages:
        assert 0 < s["hausdorff"] < 1 and 0 < s["mean_abs_angle_rad"] < 1
    # The paper's claim, stage by stage: the refinement ends closer to the disk and with
    # smaller angle distortion than the first network stage. Measured with --quick (1585
    # points): Hausdorff 0.214 -> 0.140, angle 0.320 -> 0.261 rad.
    assert stages[-1]["hausdorff"] < 0.9 * stages[0]["hausdorff"]
    assert stages[-1]["mean_abs_angle_rad"] < 0.95 * stages[0]["mean_abs_angle_rad"]
    fast, harmonic = result["fast"], result["harmonic_true_mesh"]
    assert 0 < fast["hausdorff"] < 0.15 and 0 < fast["mean_abs_angle_rad"] < 0.3
    # The conformal disk map's surface reaches the circle; its points keep their gaps.
    assert fast["surface_hausdorff"] < 0.5 * fast["hausdorff"]
    assert all(0 <= s["surface_hausdorff"] < 1 for s in stages)
    assert harmonic["flipped"] <= 1  # the harmonic map of a disk mesh folds nothing (1 sliver)


def test_hole_landing_judges_holes():
    from pcgeom import get_domain
    from pcgeom.apps.evaluate import domain_holes, hole_landing
    from pcgeom.io.landmarks import sample_polyline

    targets = domain_holes(get_domain("smile"))
    assert sorted(t["name"] for t in targets) == ["left eye", "mouth", "right eye"]
    # A map that puts each "cloud hole" loop just outside a domain hole (scaled 1.1 about
    # its centre) lands every hole; one loop moved to the middle of the face does not.
    rings = [sample_polyline(t["ring"], 0.02)[:-1] for t in targets]
    loops = [c + 1.1 * (r - r.mean(axis=0)) for r, c in ((r, r.mean(axis=0)) for r in rings)]
    U = np.vstack(loops)
    idx = np.split(np.arange(len(U)), np.cumsum([len(r) for r in rings])[:-1])
    good = hole_landing(U, idx, targets)
    assert good["all_land"]
    assert [h["nearest"] for h in good["holes"]] == [t["name"] for t in targets]
    assert all(h["hausdorff"] < 0.06 for h in good["holes"])
    moved = U.copy()
    moved[idx[0]] = 0.1 * (U[idx[0]] - U[idx[0]].mean(axis=0)) + [0.0, 0.05]
    bad = hole_landing(moved, idx, targets)
    assert not bad["all_land"] and not bad["holes"][0]["lands"]
    assert bad["holes"][0]["encloses"] == []


@_needs("face_3holes_small_choi.ply")
def test_face_smile_runs_both_ways(tmp_path):
    result = _run("face_smile", tmp_path, "--landmarks", "always")
    assert len(result["cloud_holes"]) == 3
    assert set(result["runs"]) == {"default", "landmarks"}
    lm = result["runs"]["landmarks"]
    assert sorted(p["target"] for p in lm["landmarks"]) == ["left eye", "mouth", "right eye"]
    for run in result["runs"].values():
        last = run["stages"][-1]
        assert len(last["landing"]["holes"]) == 3
        assert 0 < last["hausdorff"] < 2 and 0 < last["mean_abs_angle_rad"] < 1
    assert len(lm["stages"][-1]["landmark_hausdorff"]) == 3
    # The holes land without landmarks, from the first map on (the local mesh laid on the
    # smile, holes on holes, by the injective map, which no refinement follows; the networks
    # of 0.2 did not land them).
    assert [s["stage"] for s in result["runs"]["default"]["stages"]] == ["localmesh"]
    assert all(s["landing"]["all_land"] for s in result["runs"]["default"]["stages"])


def test_car_shell_is_an_open_sheet_with_its_window_edges():
    import igl

    from pcgeom import synthetic as car

    V, F, edges = car.car_shell(1500)
    assert len(edges) == 2 * car.CAR_EDGE_POINTS == 134
    assert len(igl.boundary_loop_all(F)) == 1  # one sheet, open underneath
    gaps = np.sort(np.linalg.norm(V[:, None] - V[None, :], axis=-1), axis=1)[:, 1]
    assert gaps.min() > 1e-3  # the lift is one to one
    E = V[edges]
    # The edges run along the car (x), at the roof's edge, one per side.
    assert np.allclose(np.abs(E[:, 1]), 0.9 * car.CAR_ROOF)
    assert E[:, 0].min() == pytest.approx(car.CAR_WINDOW[0])
    assert E[:, 0].max() == pytest.approx(car.CAR_WINDOW[1])


def test_car_landmarks_pull_the_window_edges_onto_the_lines(tmp_path):
    result = _run("car", tmp_path)
    assert (result["n_landmarks"], result["n_targets"]) == (134, 400)
    without = result["runs"]["without landmarks"]["stages"]
    with_lm = result["runs"]["with landmarks"]["stages"]
    # The history's landmark Hausdorff and the one measured from the map agree.
    for s in with_lm:
        assert s["landmark_hausdorff"][0] == pytest.approx(s["landmark_fit"], abs=2e-3)
    # Measured with --quick (200 refinement steps): 0.241 without, 0.023 with landmarks.
    assert with_lm[-1]["landmark_fit"] < 0.5 * without[-1]["landmark_fit"]
    assert with_lm[-1]["landmark_fit"] < 0.06
    marks = json.loads((tmp_path / "car_landmarks.json").read_text())
    assert len(marks) == 1 and len(marks[0]["indices"]) == 134


def test_missing_data_is_one_line(tmp_path, monkeypatch, capsys):
    module = _load("face_disk")
    monkeypatch.setattr(module._common, "DATA_DIR", tmp_path / "absent")
    with pytest.raises(SystemExit) as info:
        module.main(["--out", str(tmp_path / "o"), "--quick"])
    message = str(info.value.code)
    assert "face_human_choi.ply" in message and "it is missing" in message
    assert "\n" not in message
    assert not (tmp_path / "o").exists()
