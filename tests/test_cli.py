"""The command line (pcgeom.cli): one-line errors before any training, and real end-to-end runs.

Success tests run the real optimizer with a tiny budget (one short stage and a few refinement
steps), so they check the wiring and the files, not the quality of the map.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
import torch

import pcgeom.cli.param as param_command
from pcgeom import ParamResult, __version__, cli, parametrize
from pcgeom.domains import DOMAINS, Disk, Smile
from pcgeom.examples import peaks_surface
from pcgeom.io import read_points, write_ply_atomic
from pcgeom.metrics import angle_distortion, domain_hausdorff, surface_hausdorff

from tests.helpers import assert_cli_fails, tiny_preset

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


_tiny = tiny_preset


@pytest.fixture
def tiny(monkeypatch):
    """Make every preset the CLI looks up tiny; unknown names still raise the real error."""
    monkeypatch.setattr(param_command, "get_preset", _tiny)


@pytest.fixture
def no_training(monkeypatch):
    """Fail the test if the CLI reaches training: every check must happen before it."""

    def forbidden(*args, **kwargs):
        raise AssertionError("parametrize was called although the input is invalid")

    monkeypatch.setattr(param_command, "parametrize", forbidden)


def _grid(n_side: int = 8):
    """A small curved patch (peaks3 on an n_side x n_side grid) and its faces."""
    return peaks_surface("peaks3", n_side=n_side)


def _write_txt(path: Path, P: np.ndarray) -> Path:
    np.savetxt(path, P)
    return path


def _files(root: Path) -> set[str]:
    """Every file under ``root``, relative (hidden temporaries included)."""
    return {str(p.relative_to(root)) for p in root.rglob("*") if p.is_file()}


_fails = assert_cli_fails


# --------------------------------------------------------------------------- errors


def _bad_inputs(tmp_path: Path) -> dict[str, tuple[Path, str]]:
    """Input files that must be rejected, with the message each must produce."""
    V, _ = _grid()
    cases = {}

    empty = tmp_path / "empty.xyz"
    empty.write_bytes(b"")
    cases["empty"] = (empty, "empty.xyz: file is empty (0 bytes)")

    garbage = tmp_path / "garbage.ply"
    garbage.write_bytes(b"this is not a ply file\x00\x01\x02")
    cases["garbage ply"] = (garbage, "garbage.ply: cannot parse")

    unknown = tmp_path / "cloud.foo"
    unknown.write_text("0 0 0\n")
    cases["unknown extension"] = (unknown, "cloud.foo: unknown extension '.foo'; supported: .csv")

    two_col = _write_txt(tmp_path / "two_columns.txt", V[:, :2])
    cases["two columns"] = (
        two_col, "two_columns.txt: expected shape (N, 3) (x y z columns), got (64, 2)")

    nan = V.copy()
    nan[[3, 7], 1] = np.nan
    cases["nan"] = (_write_txt(tmp_path / "nan.txt", nan), "nan.txt: 2 of 64 rows contain NaN or inf")

    cases["too few"] = (_write_txt(tmp_path / "few.txt", V[:5]), "few.txt: 5 points, need at least 10")

    same = np.tile([[0.5, -1.0, 2.0]], (12, 1))
    cases["coincident"] = (_write_txt(tmp_path / "same.txt", same), "same.txt: all 12 points coincide")

    t = np.linspace(0.0, 1.0, 20)[:, None]
    line = np.hstack([t, 2 * t, -t])
    cases["collinear"] = (
        _write_txt(tmp_path / "line.txt", line), "line.txt: all 20 points lie on one line")

    cases["missing"] = (tmp_path / "nowhere.ply", "nowhere.ply: no such file")
    return cases


@pytest.mark.parametrize(
    "case",
    ["empty", "garbage ply", "unknown extension", "two columns", "nan", "too few", "coincident",
     "collinear", "missing"],
)
def test_bad_input_file(tmp_path, monkeypatch, capsys, no_training, case):
    monkeypatch.chdir(tmp_path)
    path, message = _bad_inputs(tmp_path)[case]
    before = _files(tmp_path)
    _fails(capsys, ["param", str(path)], message)
    assert _files(tmp_path) == before  # no output, no checkpoint, no temporary file


@pytest.mark.parametrize(
    "options, message",
    [
        (["--domain", "hexagon"], "unknown domain 'hexagon'; choose one of: free, disk, square, "
                                  "rect, annulus, smile, car, sphere, PATH.json (a polygon with "
                                  "holes) or PATH.png (a binary mask)"),
        (["--domain", "annulus:1.2"],
         "domain 'annulus:1.2': inner: expected a radius below outer = 1.0, got 1.2"),
        (["--domain", "rect:0"], "domain 'rect:0': aspect: expected a positive finite number"),
        (["--domain", "nowhere.json"], "nowhere.json: no such file"),
        (["--domain", "disk:big"], "domain 'disk:big': expected numbers after 'disk:'"),
        (["--domain", "disk:-1"], "domain 'disk:-1': radius: expected a positive finite number"),
        (["--domain", "free:2"], "domain 'free:2': free takes no values; got 1 value(s)"),
        (["--preset", "slow"], "unknown preset 'slow'; choose one of: paper, fast"),
        (["--device", "tpu"], "unknown device 'tpu'; choose one of: auto, cpu, cuda"),
        (["--example", "peaks9"], "unknown example 'peaks9'; choose one of: peaks3, peaks5"),
    ],
)
def test_unknown_names(tmp_path, monkeypatch, capsys, no_training, options, message):
    monkeypatch.chdir(tmp_path)
    argv = ["param"] + (options if options[0] == "--example" else ["--example", "peaks3"] + options)
    _fails(capsys, argv, message)
    assert _files(tmp_path) == set()


def test_cuda_requested_without_cuda(tmp_path, monkeypatch, capsys, no_training):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(torch.cuda, "is_available", lambda: False)
    _fails(capsys, ["param", "--example", "peaks3", "--device", "cuda"],
           "--device cuda requested but CUDA is not available")
    assert _files(tmp_path) == set()


@pytest.mark.parametrize(
    "options, message",
    [
        (["--out", "{tmp}/missing/map.npz"], "output directory '{tmp}/missing' does not exist"),
        (["--out", "{tmp}/map.txt"], "map.txt: output must have extension '.npz', got '.txt'"),
        (["--out", "{tmp}/map"], "map: output must have extension '.npz', got none"),
        (["--out-ply", "{tmp}/mapped.obj"], "mapped.obj: output must have extension '.ply', got '.obj'"),
        (["--out-ply", "{tmp}/missing/mapped.ply"], "output directory '{tmp}/missing' does not exist"),
        (["--plot", "{tmp}/map.jpg"], "map.jpg: output must have extension '.png', got '.jpg'"),
        (["--plot", "{tmp}/missing/map.png"], "output directory '{tmp}/missing' does not exist"),
    ],
)
def test_bad_output_path(tmp_path, monkeypatch, capsys, no_training, options, message):
    monkeypatch.chdir(tmp_path)
    options = [o.replace("{tmp}", str(tmp_path)) for o in options]
    _fails(capsys, ["param", "--example", "peaks3", *options], message.replace("{tmp}", str(tmp_path)))
    assert _files(tmp_path) == set()


def test_output_is_a_directory(tmp_path, monkeypatch, capsys, no_training):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "taken.npz").mkdir()
    _fails(capsys, ["param", "--example", "peaks3", "--out", "taken.npz"],
           "taken.npz: is a directory, expected a file")


def test_output_would_overwrite_input(tmp_path, monkeypatch, capsys, no_training):
    V, F = _grid()
    mesh = tmp_path / "mesh.ply"
    write_ply_atomic(mesh, V, F)
    before = mesh.read_bytes()
    _fails(capsys, ["param", str(mesh), "--out-ply", str(mesh)],
           "mesh.ply: --out-ply is the same file as INPUT")
    assert mesh.read_bytes() == before
    assert _files(tmp_path) == {"mesh.ply"}


@pytest.mark.parametrize(
    "argv, message",
    [
        (["param"], "give exactly one of INPUT or --example NAME"),
        (["param", "x.ply", "--example", "peaks3"], "give exactly one of INPUT or --example NAME"),
        (["param", "--example", "peaks3", "--seed", "-1"],
         "argument --seed: expected a non-negative integer, got -1"),
        (["param", "--example", "peaks3", "--seed", "one"],
         "argument --seed: expected a non-negative integer, got 'one'"),
        (["param", "--example", "peaks3", "--threads", "0"],
         "argument --threads: expected a positive integer, got 0"),
        (["param", "--example", "peaks3", "--epochs=3"], "unrecognized arguments: --epochs=3"),
        ([], "the following arguments are required: COMMAND"),
        (["remesh"], "argument COMMAND: invalid choice: 'remesh'"),
        (["reconstruct"], "the following arguments are required: INPUT, --out"),
    ],
)
def test_usage_errors(tmp_path, monkeypatch, capsys, no_training, argv, message):
    monkeypatch.chdir(tmp_path)
    _fails(capsys, argv, message)
    assert _files(tmp_path) == set()


def test_help_has_examples(capsys):
    assert cli.main(["--help"]) == 0
    assert "pcgeom param --example peaks3 --out peaks3_uv.npz --plot peaks3_uv.png" in (
        capsys.readouterr().out)
    assert cli.main(["param", "--help"]) == 0
    out = capsys.readouterr().out
    assert "examples:" in out and "--resume" in out and "free, disk" in out
    assert "smile, car" in out and "PATH.json" in out and "rect:2" in out
    assert cli.main(["evaluate", "--help"]) == 0
    assert "pcgeom evaluate mesh.ply mesh_uv.npz" in capsys.readouterr().out


@pytest.mark.parametrize("command", ["param", "boundary", "reconstruct", "batch"])
def test_help_lists_every_readable_format(capsys, command):
    """Issue 39: boundary and reconstruct --help omitted .las/.laz."""
    from pcgeom.io import SUPPORTED_EXTENSIONS

    assert cli.main([command, "--help"]) == 0
    out = " ".join(capsys.readouterr().out.split())
    assert all(ext in out.split("INPUT", 2)[-1] for ext in SUPPORTED_EXTENSIONS), out


def test_interrupt_keeps_no_output(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(param_command, "parametrize", interrupted)
    assert cli.main(["param", "--example", "peaks3"]) == 130
    err = capsys.readouterr().err
    assert err == "pcgeom: error: interrupted (rerun with --resume to continue from the last " \
                  "finished stage)\n"
    assert _files(tmp_path) == set()


# --------------------------------------------------------------------------- success


def test_example_peaks3_writes_map(tmp_path, monkeypatch, capsys, tiny):
    monkeypatch.chdir(tmp_path)
    assert cli.main(["param", "--example", "peaks3", "--quiet"]) == 0
    out, err = capsys.readouterr()
    assert err == ""  # --quiet: no progress bars
    assert _files(tmp_path) == {"peaks3_uv.npz"}  # default name in cwd; checkpoint removed

    V, F = peaks_surface("peaks3")
    with np.load(tmp_path / "peaks3_uv.npz", allow_pickle=False) as z:
        assert sorted(z.files) == ["center", "config_json", "denoise_json", "domain_json",
                                   "faces", "fingerprint", "history_json", "lambda_inv",
                                   "mesh_faces", "scale", "seconds", "seed", "uv", "version"]
        uv, lam = z["uv"], z["lambda_inv"]
        assert uv.shape == (len(V), 2) and uv.dtype == np.float64
        assert np.isfinite(uv).all() and uv.std(axis=0).min() > 1e-3  # not collapsed
        assert lam.shape == (len(V),) and (lam > 0).all()
        np.testing.assert_allclose(z["center"], V.mean(axis=0))
        assert z["scale"].shape == () and float(z["scale"]) > 0
        np.testing.assert_array_equal(z["faces"], F)
        assert json.loads(str(z["config_json"])) == _tiny("fast").to_dict()
        history = json.loads(str(z["history_json"]))
    # fast maps the free boundary by the local mesh (normals estimated: the example has none).
    assert [(row["kind"], row["normals"]) for row in history] == [("localmesh", "estimated")]

    # The library reads it back, and it says what made it.
    result = ParamResult.load(tmp_path / "peaks3_uv.npz", n_points=len(V))
    assert (result.domain.spec, result.seed, result.version) == ("free", 0, __version__)
    assert result.config == _tiny("fast") and result.preset == "custom"  # tiny is not 'fast'
    assert result.history == history
    np.testing.assert_array_equal(result.faces, F)

    lines = out.splitlines()
    assert lines[0] == f"peaks3: {len(V)} points -> peaks3_uv.npz"
    assert lines[1].startswith("preset fast, domain free, device cpu, seed 0: ")
    assert lines[2] == ("method localmesh, normals estimated (a cloud without normals may fold "
                        "where two sheets of its surface touch)")
    # fast's --denoise auto estimates the noise of the clean example and leaves it as it is.
    assert re.fullmatch(r"noise: 0\.0\d\d spacings estimated \(std \S+, spacing \S+\); not "
                        r"denoised \(--denoise STRENGTH to force it\)", lines[3])
    assert re.fullmatch(r"angle distortion: mean \d\.\d{4} rad over 11250 triangles, "
                        r"\d+ flipped \(\d+\.\d\d%\)", lines[4])


def test_mesh_input_json_ply_and_plot(tmp_path, capsys, tiny):
    """A PLY with faces: --json reports the evaluation; the mapped PLY keeps the faces."""
    V, F = _grid(12)
    mesh = tmp_path / "mesh.ply"
    write_ply_atomic(mesh, V, F)
    out_dir = tmp_path / "out"
    out_dir.mkdir()
    argv = ["param", str(mesh), "--domain", "disk", "--seed", "3", "--quiet", "--json",
            "--out", str(out_dir / "m.npz"), "--out-ply", str(out_dir / "m.ply"),
            "--plot", str(out_dir / "m.png")]
    assert cli.main(argv) == 0
    out, err = capsys.readouterr()
    report = json.loads(out)  # exactly one JSON object on stdout
    assert report["out"] == str(out_dir / "m.npz")
    assert report["out_ply"] == str(out_dir / "m.ply")
    assert report["plot"] == str(out_dir / "m.png")
    assert report["n_points"] == len(V)
    assert (report["domain"], report["preset"], report["device"], report["seed"]) == (
        "disk", "fast", "cpu", 3)
    assert report["seconds"] > 0
    # fast maps a disk by the local mesh, made conformal onto it: no loss terms.
    assert (report["method"], report["normals"], report["loss"]) == ("localmesh", "estimated", {})
    assert _files(out_dir) == {"m.npz", "m.ply", "m.png"}
    with np.load(out_dir / "m.npz") as z:
        assert report["domain_hausdorff"] == domain_hausdorff(z["uv"], Disk())
        assert report["surface_hausdorff"] == surface_hausdorff(z["uv"], F, Disk())

    mapped = read_points(out_dir / "m.ply")
    assert mapped.points.shape == (len(V), 3)
    assert (mapped.points[:, 2] == 0).all()
    np.testing.assert_array_equal(mapped.faces, F)
    with np.load(out_dir / "m.npz") as z:
        np.testing.assert_array_equal(mapped.points[:, :2], z["uv"])  # float64 round trip
        expected = angle_distortion(V, F, z["uv"])
    ev = report["evaluation"]
    assert ev == {"mean_abs_angle_rad": expected.mean_abs, "flipped": expected.flipped,
                  "n_faces": len(F), "flipped_where": expected.where}
    assert (out_dir / "m.png").read_bytes()[:8] == PNG_SIGNATURE


def test_bare_cloud_has_no_evaluation(tmp_path, capsys, tiny):
    V, _ = _grid()
    src = _write_txt(tmp_path / "scan.txt", V)
    assert cli.main(["param", str(src), "--quiet", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["evaluation"] is None
    assert report["domain_hausdorff"] is None  # free boundary: no domain to fit
    assert report["surface_hausdorff"] is None
    assert report["out"] == str(tmp_path / "scan_uv.npz")  # default: next to the input
    with np.load(tmp_path / "scan_uv.npz") as z:
        assert "faces" not in z.files


def test_duplicate_points_give_one_row_per_input_row(tmp_path, capsys, tiny):
    V, _ = _grid()
    rows = np.concatenate([V, V[[5, 17, 5, 40]]])  # (68, 3): three extra copies of 5, one of 17/40
    src = _write_txt(tmp_path / "dups.txt", rows)
    out = tmp_path / "dups.npz"
    assert cli.main(["param", str(src), "--quiet", "--out", str(out)]) == 0
    with np.load(out) as z:
        uv = z["uv"]
    assert uv.shape == (len(rows), 2)
    np.testing.assert_array_equal(uv[64], uv[5])
    np.testing.assert_array_equal(uv[66], uv[5])
    np.testing.assert_array_equal(uv[65], uv[17])
    np.testing.assert_array_equal(uv[67], uv[40])


def test_quiet_resume_and_checkpoint_are_passed_through(tmp_path, monkeypatch, capsys, tiny):
    monkeypatch.chdir(tmp_path)
    _write_txt(tmp_path / "scan.txt", _grid()[0])
    calls = []

    def spy(*args, **kwargs):
        calls.append(kwargs)
        return parametrize(*args, **kwargs)

    monkeypatch.setattr(param_command, "parametrize", spy)
    assert cli.main(["param", "scan.txt", "--resume", "--quiet", "--out", "a.npz"]) == 0
    (kw,) = calls
    assert kw["checkpoint"] == Path("a.ckpt")
    assert kw["resume"] is True and kw["progress"] is False
    assert kw["seed"] == 0 and kw["device"] == torch.device("cpu")
    assert _files(tmp_path) == {"scan.txt", "a.npz"}  # checkpoint removed after success


def test_resume_from_foreign_checkpoint_is_an_error(tmp_path, capsys, tiny):
    """A checkpoint made with another seed is refused (one line, exit 2) and kept."""
    V, _ = _grid()
    src = _write_txt(tmp_path / "scan.txt", V)
    ckpt = tmp_path / "scan_uv.ckpt"
    parametrize(V, "free", config=_tiny("networks"), device="cpu", seed=1, checkpoint=ckpt,
                progress=False)
    assert ckpt.exists()
    _fails(capsys, ["param", str(src), "--preset", "networks", "--resume", "--quiet"],
           "scan_uv.ckpt: checkpoint is from a different input, normals, domain, landmarks, "
           "config or seed")
    assert _files(tmp_path) == {"scan.txt", "scan_uv.ckpt"}


def test_resume_with_another_preset_is_refused_and_keeps_the_checkpoint(tmp_path, capsys, tiny):
    """Issue 39: a networks run resumed without --preset ran fast (which writes no
    checkpoint), exited 0 and deleted the checkpoint; a differing preset or setting is
    refused like a differing seed, before any work."""
    V, _ = _grid()
    src = _write_txt(tmp_path / "scan.txt", V)
    ckpt = tmp_path / "scan_uv.ckpt"
    parametrize(V, "free", config=_tiny("networks"), device="cpu", seed=0, checkpoint=ckpt,
                progress=False)
    _fails(capsys, ["param", str(src), "--resume", "--quiet"],
           "scan_uv.ckpt: checkpoint is from a different input, normals, domain, landmarks, "
           "config or seed (here: preset or settings); delete it to start over")
    _fails(capsys, ["param", str(src), "--preset", "networks", "--denoise", "2", "--resume",
                    "--quiet"], "(here: preset or settings)")
    assert _files(tmp_path) == {"scan.txt", "scan_uv.ckpt"}


# --------------------------------------------------------------------------- evaluate


@pytest.fixture
def mesh_and_map(tmp_path):
    """A mesh file and a map file for it (LSCM-free: the grid's own x, y)."""
    V, F = _grid()
    mesh = tmp_path / "mesh.ply"
    write_ply_atomic(mesh, V, F)
    mapped = tmp_path / "map.npz"
    np.savez(mapped, uv=V[:, :2] * 0.5, lambda_inv=np.ones(len(V)))
    return V, F, mesh, mapped


def test_evaluate(tmp_path, capsys, mesh_and_map):
    V, F, mesh, mapped = mesh_and_map
    expected = angle_distortion(V, F, V[:, :2] * 0.5)
    assert cli.main(["evaluate", str(mesh), str(mapped), "--json",
                     "--plot", str(tmp_path / "angles.png")]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["mean_abs_angle_rad"] == expected.mean_abs
    assert report["flipped"] == expected.flipped == 0
    assert report["n_faces"] == len(F) and report["n_points"] == len(V)
    assert (tmp_path / "angles.png").read_bytes()[:8] == PNG_SIGNATURE

    assert cli.main(["evaluate", str(mesh), str(mapped)]) == 0
    out = capsys.readouterr().out
    assert f"angle distortion: mean {expected.mean_abs:.4f} rad over {len(F)} triangles, " \
           "0 flipped (0.00%)" in out
    assert (f"  median {expected.median_abs:.4f}, 95th percentile {expected.p95_abs:.4f}, "
            f"max {expected.max_abs:.4f} rad") in out
    assert "baselines on the same mesh:" in out
    assert "  LSCM, 2 pinned vertices (libigl, true mesh): " in out
    assert "  harmonic disk map (libigl, true mesh): " in out


def test_evaluate_json_has_the_order_statistics_and_the_baselines(tmp_path, capsys,
                                                                    mesh_and_map):
    from pcgeom.apps.baselines import harmonic_disk, lscm

    V, F, mesh, mapped = mesh_and_map
    assert cli.main(["evaluate", str(mesh), str(mapped), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    expected = angle_distortion(V, F, V[:, :2] * 0.5)
    assert report["median_abs_angle_rad"] == expected.median_abs
    assert report["p95_abs_angle_rad"] == expected.p95_abs
    assert report["max_abs_angle_rad"] == expected.max_abs
    assert report["landmark_hausdorff"] is None and report["domain_hausdorff"] is None
    assert report["plot"] is None and report["plots"] is None
    assert set(report["baselines"]) == {"lscm", "harmonic_disk"}
    for name, method in (("lscm", lscm), ("harmonic_disk", harmonic_disk)):
        base = report["baselines"][name]
        assert base["error"] is None and base["seconds"] >= 0
        assert base["max_abs_angle_rad"] == angle_distortion(V, F, method(V, F)).max_abs

    assert cli.main(["evaluate", str(mesh), str(mapped), "--json", "--no-baselines"]) == 0
    assert json.loads(capsys.readouterr().out)["baselines"] == {}


def test_evaluate_plot_dir_writes_the_four_figures(tmp_path, capsys, tiny):
    V, F = _grid()
    mesh = tmp_path / "mesh.ply"
    write_ply_atomic(mesh, V, F)
    out = tmp_path / "m.npz"
    assert cli.main(["param", str(mesh), "--preset", "networks", "--quiet", "--out",
                     str(out)]) == 0
    capsys.readouterr()
    figs = tmp_path / "figs"
    assert cli.main(["evaluate", str(mesh), str(out), "--plot", str(figs), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    names = {"angles": "angle_histogram.png", "map": "map_angle_distortion.png",
             "checker": "surface_checker.png", "history": "history.png"}
    assert report["plots"] == {k: str(figs / v) for k, v in names.items()}
    for name in names.values():
        assert (figs / name).read_bytes()[:8] == PNG_SIGNATURE
    assert _files(figs) == set(names.values())  # no temporary file left behind

    # A bare uv file has no history: three figures, into an existing directory.
    bare = tmp_path / "bare.npz"
    np.savez(bare, uv=V[:, :2])
    assert cli.main(["evaluate", str(mesh), str(bare), "--plot", str(figs)]) == 0
    captured = capsys.readouterr()
    assert (f"figures: {figs / names['angles']}, {figs / names['map']}, "
            f"{figs / names['checker']}\n") in captured.out
    assert captured.out.endswith("  no history.png: the map records no loss per stage (a "
                                 "local-mesh map, as preset fast makes, or a bare uv file)\n")

    # Issue 39: a fast map (the local mesh's, no loss per stage) wrote an empty history.png.
    fast = tmp_path / "fast.npz"
    assert cli.main(["param", str(mesh), "--quiet", "--out", str(fast)]) == 0
    figs2 = tmp_path / "figs2"
    capsys.readouterr()
    assert cli.main(["evaluate", str(mesh), str(fast), "--plot", str(figs2), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["plots"]["history"] is None
    assert _files(figs2) == {names[k] for k in ("angles", "map", "checker")}


def test_evaluate_errors(tmp_path, capsys, mesh_and_map):
    V, F, mesh, mapped = mesh_and_map
    bare = _write_txt(tmp_path / "bare.txt", V)
    _fails(capsys, ["evaluate", str(bare), str(mapped)],
           "bare.txt: has no faces; evaluation needs a triangle mesh")

    short = tmp_path / "short.npz"
    np.savez(short, uv=V[:-1, :2])
    _fails(capsys, ["evaluate", str(mesh), str(short)],
           f"short.npz: map has {len(V) - 1} rows but {mesh} has {len(V)} points")

    no_uv = tmp_path / "no_uv.npz"
    np.savez(no_uv, points=V)
    _fails(capsys, ["evaluate", str(mesh), str(no_uv)], "no_uv.npz: no 'uv' array (found: points)")

    flat = tmp_path / "flat.npz"
    np.savez(flat, uv=V)
    _fails(capsys, ["evaluate", str(mesh), str(flat)],
           f"flat.npz: 'uv' must have shape (N, 2), got ({len(V)}, 3)")

    junk = tmp_path / "junk.npz"
    junk.write_bytes(b"not a zip")
    _fails(capsys, ["evaluate", str(mesh), str(junk)], "junk.npz: cannot parse")

    _fails(capsys, ["evaluate", str(mesh), str(tmp_path / "absent.npz")], "absent.npz: no such file")
    _fails(capsys, ["evaluate", str(mesh), str(mesh)],
           "mesh.ply: map must have extension '.npz', got '.ply'")
    _fails(capsys, ["evaluate", str(mesh), str(mapped), "--plot", str(tmp_path / "a.pdf")],
           "a.pdf: --plot takes a directory or a .png file, got '.pdf'")
    assert not (tmp_path / "a.pdf").exists()
    _fails(capsys, ["evaluate", str(mesh), str(mapped), "--plot", str(tmp_path / "no" / "figs")],
           f"figs: plot directory's parent {str(tmp_path / 'no')!r} does not exist")
    _fails(capsys, ["evaluate", str(mesh), str(mapped), "--plot", str(tmp_path / "no" / "a.png")],
           "a.png: output directory")
    (tmp_path / "figs").write_text("a file, not a directory")
    _fails(capsys, ["evaluate", str(mesh), str(mapped), "--plot", str(tmp_path / "figs")],
           "figs: --plot takes a directory, got a file")


def test_evaluate_reports_what_made_a_pcgeom_map(tmp_path, capsys, tiny):
    V, F = _grid()
    mesh = tmp_path / "mesh.ply"
    write_ply_atomic(mesh, V, F)
    out = tmp_path / "m.npz"
    assert cli.main(["param", str(mesh), "--domain", "disk:0.5", "--seed", "2", "--quiet",
                     "--out", str(out)]) == 0
    capsys.readouterr()
    assert cli.main(["evaluate", str(mesh), str(out), "--json"]) == 0
    out_, err = capsys.readouterr()
    report = json.loads(out_)
    assert err == ""  # a full results file: no warning
    assert (report["domain"], report["seed"], report["version"]) == ("disk:0.5", 2, __version__)
    assert report["preset"] == "custom"  # the tiny fixture's config, not a named preset
    result = ParamResult.load(out)
    assert report["domain_hausdorff"] == domain_hausdorff(result.uv, Disk(radius=0.5))
    assert report["surface_hausdorff"] == surface_hausdorff(result.uv, F, Disk(radius=0.5))


def test_evaluate_warns_in_one_line_on_a_bare_uv_file(tmp_path, capsys, mesh_and_map):
    """A uv array from another tool is evaluated; the missing provenance is one warning line."""
    V, F, mesh, mapped = mesh_and_map
    assert cli.main(["evaluate", str(mesh), str(mapped)]) == 0
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert err.startswith("pcgeom: warning: ")
    assert "map.npz: written by an older pcgeom or another tool; unknown: center, scale" in err


def test_each_command_has_its_own_main(capsys):
    assert param_command.main(["--help"]) == 0
    assert "usage: pcgeom param" in capsys.readouterr().out
    from pcgeom.cli import evaluate as evaluate_command

    assert evaluate_command.main(["--help"]) == 0
    assert "usage: pcgeom evaluate" in capsys.readouterr().out
    code = param_command.main(["--preset", "slow", "--example", "peaks3"])
    assert code == 2
    assert capsys.readouterr().err == (
        "pcgeom: error: unknown preset 'slow'; choose one of: paper, fast, networks\n")


def test_python_dash_m_pcgeom_works_like_pcgeom():
    import subprocess
    import sys

    done = subprocess.run([sys.executable, "-m", "pcgeom", "--version"], capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 0
    assert done.stdout.strip() == f"pcgeom {__version__}"


# --------------------------------------------------------------------------- pcgeom domains


def test_domains_lists_every_registered_domain(capsys):
    assert cli.main(["domains"]) == 0
    out = capsys.readouterr().out
    lines = out.splitlines()
    assert [line.split()[0].split(":")[0] for line in lines] == [
        "PATH.json" if name == "polygon" else name for name in DOMAINS] + ["PATH.png"]
    assert any(line.startswith("annulus:inner,outer ") and "area 2.3562" in line
               for line in lines)
    assert any(line.startswith("smile ") and "smiling face" in line for line in lines)
    assert cli.main(["domains", "list", "--json"]) == 0
    listing = json.loads(capsys.readouterr().out)
    rows = {row["name"]: row for row in listing["domains"]}
    assert list(rows) == list(DOMAINS)
    assert rows["rect"]["spec_args"] == ["aspect", "size"]
    assert rows["disk"]["area"] == pytest.approx(np.pi)
    assert rows["smile"]["area"] == pytest.approx(Smile().area)
    assert rows["free"]["area"] is None and rows["polygon"]["area"] is None
    assert all(row["description"] for row in rows.values())


def test_domains_list_offers_the_file_specs_and_show_says_auto_is_the_clouds(
        tmp_path, monkeypatch, capsys):
    """Issue 39: the listing omitted the PNG mask and offered the bare name 'polygon';
    'show annulus:auto' drew a 0.5 ring without saying the radius comes from the cloud."""
    monkeypatch.chdir(tmp_path)
    assert cli.main(["domains"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert any(line.startswith("PATH.png ") and "binary image mask" in line for line in lines)
    assert any(line.startswith("PATH.json ") and "polygon with holes" in line for line in lines)
    assert not any(line.startswith("polygon") for line in lines)
    assert cli.main(["domains", "--json"]) == 0
    files = json.loads(capsys.readouterr().out)["files"]
    assert [f["spec"] for f in files] == ["PATH.json", "PATH.png"] and ".png" in files[1]["suffixes"]

    assert cli.main(["domains", "show", "annulus:auto", "-o", "ring.png"]) == 0
    assert capsys.readouterr().out == (
        "annulus:auto: area 2.3562, 2 boundary loop(s) -> ring.png (inner radius drawn at 0.5: "
        "a map takes it from the cloud (the surface's own hole))\n")
    assert cli.main(["domains", "show", "annulus:0.5", "-o", "ring.png", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["note"] is None


def test_domains_show_writes_a_png(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert cli.main(["domains", "show", "smile", "-o", "smile.png"]) == 0
    assert capsys.readouterr().out == "smile: area 2.6232, 4 boundary loop(s) -> smile.png\n"
    assert (tmp_path / "smile.png").read_bytes()[:8] == PNG_SIGNATURE
    room = tmp_path / "room.json"
    room.write_text(json.dumps({"type": "Polygon", "coordinates": [
        [[0, 0], [2, 0], [2, 1], [0, 1]], [[0.5, 0.25], [1, 0.25], [1, 0.75]]]}))
    assert cli.main(["domains", "show", "room.json", "-o", "room.png", "--n", "300",
                     "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["boundary_loops"] == 2 and summary["area"] == pytest.approx(2.0 - 0.125)
    assert json.loads(summary["domain"])["name"] == "polygon"
    assert (tmp_path / "room.png").read_bytes()[:8] == PNG_SIGNATURE
    assert _files(tmp_path) == {"smile.png", "room.json", "room.png"}


@pytest.mark.parametrize(
    "argv, message",
    [
        (["domains", "show", "hexagon", "-o", "x.png"], "unknown domain 'hexagon'; choose one of"),
        (["domains", "show", "annulus:1.2", "-o", "x.png"],
         "domain 'annulus:1.2': inner: expected a radius below outer = 1.0, got 1.2"),
        (["domains", "show", "rect:0", "-o", "x.png"],
         "domain 'rect:0': aspect: expected a positive finite number, got 0.0"),
        (["domains", "show", "free", "-o", "x.png"], "domain 'free' has no region to draw"),
        (["domains", "show", "nowhere.json", "-o", "x.png"],
         "nowhere.json: no such file"),
        (["domains", "show", "car", "-o", "x.jpg"],
         "x.jpg: output must have extension '.png', got '.jpg'"),
        (["domains", "show", "car", "-o", "missing/x.png"],
         "output directory 'missing' does not exist"),
        (["domains", "show", "car"], "show needs an output file: -o OUT.png"),
        (["domains", "show"], "show needs a domain: pcgeom domains show SPEC -o OUT.png"),
        (["domains", "car"], "argument ACTION: invalid choice: 'car'"),
        (["domains", "list", "car"], "'pcgeom domains' lists the domains; to draw one"),
        (["domains", "show", "car", "-o", "x.png", "--n", "0"],
         "argument --n: expected a positive integer, got 0"),
    ],
)
def test_domains_errors(tmp_path, monkeypatch, capsys, argv, message):
    monkeypatch.chdir(tmp_path)
    _fails(capsys, argv, message)
    assert _files(tmp_path) == set()


def test_domains_command_has_its_own_main(capsys):
    from pcgeom.cli import domains as domains_command

    assert domains_command.main(["--help"]) == 0
    out = capsys.readouterr().out
    assert "usage: pcgeom domains" in out and "pcgeom domains show smile -o smile.png" in out
    assert domains_command.main(["show", "car"]) == 2
    assert capsys.readouterr().err == "pcgeom: error: show needs an output file: -o OUT.png\n"


def test_polygon_domain_is_named_by_its_file_and_its_size(tmp_path, capsys, tiny):
    """A polygon's spec holds all its coordinates: the JSON gives the file the user named,
    the human lines a short label, and the map file still holds the whole polygon."""
    V, F = _grid(12)
    mesh = tmp_path / "mesh.ply"
    write_ply_atomic(mesh, V, F)
    room = tmp_path / "room.json"
    shell = [[-1, -1], [1, -1], [1, 1], [-1, 1]]
    hole = [[-0.2, -0.2], [0.2, -0.2], [0.2, 0.2], [-0.2, 0.2]]
    room.write_text(json.dumps({"type": "Polygon", "coordinates": [shell, hole]}))
    out = tmp_path / "m.npz"
    argv = ["param", str(mesh), "--domain", str(room), "--quiet", "--out", str(out)]
    assert cli.main(argv + ["--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["domain"] == str(room)
    assert report["surface_hausdorff"] is not None
    assert ParamResult.load(out).domain.holes == (tuple(map(tuple, hole)),)
    assert cli.main(argv) == 0
    text = capsys.readouterr().out
    assert "domain polygon of 8 vertices with 1 hole, device" in text
    assert "to its domain (polygon of 8 vertices with 1 hole): " in text
    assert "[-1.0" not in text


def test_threads_sets_torchs_threads_before_training(tmp_path, capsys, monkeypatch, tiny):
    calls = []
    monkeypatch.setattr(param_command.torch, "set_num_threads", calls.append)
    original = param_command.parametrize
    seen = []

    def check(*args, **kwargs):
        seen.append(list(calls))  # what was set when training began
        return original(*args, **kwargs)

    monkeypatch.setattr(param_command, "parametrize", check)
    V, _ = _grid()
    src = _write_txt(tmp_path / "scan.txt", V)
    assert cli.main(["param", str(src), "--threads", "1", "--quiet", "--json"]) == 0
    calls.clear()
    assert cli.main(["param", str(src), "--quiet", "--json"]) == 0
    assert seen == [[1], []]  # set before any work; torch's own default unless asked


def test_annulus_auto_is_reported_and_judged_with_its_radius(tmp_path, capsys):
    """A planar annulus r = 0.4 onto annulus:auto: the JSON names the annulus the cloud
    decided, and the surface is judged against it (against annulus:auto's placeholder it
    would be 0.1 off)."""
    n, k = 12, 48
    radii = np.geomspace(0.4, 1.0, n)
    angles = 2 * np.pi * np.arange(k) / k
    P = (radii[:, None] * np.exp(1j * angles)[None]).ravel()
    V = np.column_stack([P.real, P.imag, np.zeros(len(P))])
    F = []
    for i in range(n - 1):
        for j in range(k):
            a, b, c, d = i * k + j, i * k + (j + 1) % k, (i + 1) * k + j, (i + 1) * k + (j + 1) % k
            F += [[a, b, d], [a, d, c]]
    mesh = tmp_path / "ring.ply"
    write_ply_atomic(mesh, V, np.asarray(F))
    assert cli.main(["param", str(mesh), "--domain", "annulus:auto", "--quiet", "--json",
                     "--out", str(tmp_path / "ring.npz")]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["domain"].startswith("annulus:0.")
    inner = float(report["domain"].split(":")[1].split(",")[0])
    assert inner == pytest.approx(0.4, rel=0.1)  # measured 0.424 on this coarse 48-gon
    # 0.0072 without the pinches' mend (ee9ef62), 0.0318 with it: it takes off the one-triangle
    # second fan of an inner point (ring 6 of 12; the triangle spans rings 6-9 over an
    # unmeshed point of ring 8) and fills it, no rim point; the outer-rim point at that angle,
    # whose own second fan (two triangles from ring 8) stays, then lies on a boundary walk of
    # 8 points, not 17, and maps at radius 0.94, not on the circle.
    assert report["surface_hausdorff"] < 0.035
    # Measured: 3 of 1056 true triangles flipped, on the rim, where this coarse grid's bare
    # local mesh skips a rim point (37 of its triangles are a second fan at a vertex).
    assert report["evaluation"]["flipped"] <= 0.005 * report["evaluation"]["n_faces"]
