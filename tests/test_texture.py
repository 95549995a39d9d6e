"""A map as texture coordinates (pcgeom.apps.texture, ``pcgeom param --out-mesh``): the scaling
into the unit square, the checkerboard image against the parity the figures colour, the mesh
that carries a map (the input's, or a bare cloud's local mesh), and the figure."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import pcgeom.apps.texture as texture
import pcgeom.cli.param as param_command
from pcgeom import InputError, ParamResult, cli, parametrize
from pcgeom.apps.plot import plot_checker
from pcgeom.apps.texture import (CHECKER_COLOURS, CHECKER_SQUARES, Texture, checker_image,
                                 checker_parity, map_mesh, parse_texture, uv_scaling)
from pcgeom.examples import peaks_surface
from pcgeom.io import read_points

from tests.helpers import assert_cli_fails, tiny_preset

trimesh = pytest.importorskip("trimesh")

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


# --------------------------------------------------------------------------- scaling and image


def test_uv_scaling_fills_the_unit_square_along_the_longer_side_and_keeps_the_aspect():
    U = np.array([[-1.0, 2.0], [3.0, 2.0], [3.0, 4.0], [0.0, 3.0]])  # 4 wide, 2 high
    scaling = uv_scaling(U)
    assert scaling.offset == (-1.0, 2.0) and scaling.scale == 4.0
    uv = scaling.apply(U)
    np.testing.assert_allclose(uv, [[0, 0], [1, 0], [1, 0.5], [0.25, 0.25]], rtol=0, atol=0)
    assert scaling.to_dict() == {"uv_offset": [-1.0, 2.0], "uv_scale": 4.0}
    with pytest.raises(ValueError, match=r"U: expected shape \(K, 2\) with K >= 1, got \(4,\)"):
        uv_scaling(U[:, 0])
    with pytest.raises(ValueError, match="U: contains NaN or inf"):
        uv_scaling(np.array([[0.0, np.nan], [1.0, 1.0]]))
    with pytest.raises(ValueError, match="U: all points at one place; no texture coordinates"):
        uv_scaling(np.ones((3, 2)))


@pytest.mark.parametrize("spec, squares", [("checker", CHECKER_SQUARES), ("checker:1", 1),
                                           ("checker:12", 12), (" checker:256 ", 256)])
def test_texture_specs(spec, squares):
    texture = parse_texture(spec)
    assert texture == Texture("checker", squares)
    assert parse_texture(texture.spec) == texture


@pytest.mark.parametrize("spec", ["checker:0", "checker:abc", "checker:257", "checker:",
                                  "checker:-3", "checker:2.5", "chess", ""])
def test_bad_texture_specs_name_the_accepted_forms(spec):
    with pytest.raises(InputError, match=r"^texture: expected checker or checker:N \(N squares "
                                         r"along the longer side of the map, 1 to 256\), got "
                                         + repr(spec).replace(".", r"\.") + "$"):
        parse_texture(spec)


@pytest.mark.parametrize("squares", [1, 5, 8])
def test_checker_image_has_the_colour_checker_parity_gives_each_triangle(squares):
    """Sample the image where a triangle's centroid falls in texture space, away from the
    squares' edges: the pixel is the colour of that triangle's parity (v points up in texture
    space, down the image's rows)."""
    image = np.asarray(checker_image(squares))
    assert image.shape[0] == image.shape[1] and image.shape[0] % squares == 0
    assert 512 <= image.shape[0] <= 1024
    rng = np.random.default_rng(squares)
    centre = (rng.integers(0, squares, (200, 2)) + rng.uniform(0.1, 0.9, (200, 2))) / squares
    uv = np.repeat(centre, 3, axis=0)  # three equal corners: the centroid is the point
    F = np.arange(len(uv)).reshape(-1, 3)
    parity = checker_parity(uv, F, squares)
    H, W = image.shape[:2]
    pixels = image[((1.0 - centre[:, 1]) * H).astype(int), (centre[:, 0] * W).astype(int)]
    np.testing.assert_array_equal(pixels, np.asarray(CHECKER_COLOURS)[parity])
    assert set(np.unique(parity)) == ({0} if squares == 1 else {0, 1})
    with pytest.raises(ValueError, match="squares: expected 1 to 256, got 0"):
        checker_image(0)


# --------------------------------------------------------------------------- the mesh of a map


def test_map_mesh_of_a_mesh_keeps_its_faces_and_leaves_out_unused_vertices():
    V, F = peaks_surface("peaks3", n_side=8)
    P = np.vstack([V, [[5.0, 5.0, 5.0]]])  # one stray vertex no triangle uses
    U = P[:, :2] * 2.0
    mesh = map_mesh(P, U, F)
    assert mesh.source == "input" and mesh.unused == 1 and mesh.n_input == len(P)
    np.testing.assert_array_equal(mesh.rows, np.arange(len(V)))
    np.testing.assert_array_equal(mesh.faces, F)
    np.testing.assert_array_equal(mesh.vertices, V)
    np.testing.assert_array_equal(mesh.uv, U[:-1])
    with pytest.raises(InputError, match=r"U: expected shape \(65, 2\) \(one row per point\), "
                                         r"got \(64, 2\)"):
        map_mesh(P, U[:-1], F)
    with pytest.raises(InputError, match="faces"):
        map_mesh(P, U, F + len(P))


def test_map_mesh_of_a_bare_cloud_is_the_local_mesh_its_map_was_built_on():
    V, _ = peaks_surface("peaks3", n_side=24)
    P = np.vstack([V, V[:5]])  # duplicates: the first row of each carries it
    result = parametrize(P, "free", config=tiny_preset("fast"), progress=False)
    mesh = map_mesh(P, result.uv, config=result.config)
    assert mesh.source == "local mesh"
    assert len(mesh.faces) == result.history[0]["faces"]  # the map's own local mesh
    assert mesh.unused == 5 and (mesh.rows < len(V)).all()
    np.testing.assert_array_equal(mesh.vertices, P[mesh.rows])
    np.testing.assert_array_equal(mesh.uv, result.uv[mesh.rows])
    # Oriented as the map: no triangle turns over.
    e1 = mesh.uv[mesh.faces[:, 1]] - mesh.uv[mesh.faces[:, 0]]
    e2 = mesh.uv[mesh.faces[:, 2]] - mesh.uv[mesh.faces[:, 0]]
    assert (e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0] > 0).all()


def test_the_result_keeps_the_local_mesh_so_nothing_is_rebuilt(tmp_path):
    """ParamResult.mesh_faces: the main part of the map's local mesh as input rows (here the
    mesh rebuilt from the same points and settings, as no normal round ran), saved and
    loaded; map_mesh takes it as it is; a file written before it existed loads without it."""
    V, _ = peaks_surface("peaks3", n_side=24)
    P = np.vstack([V, V[:5]])  # duplicates: the first row stands for each
    result = parametrize(P, "free", config=tiny_preset("fast"), progress=False)
    assert result.mesh_faces.dtype == np.int64 and result.mesh_faces.shape[1] == 3
    assert (result.mesh_faces < len(V)).all()
    rebuilt = map_mesh(P, result.uv, config=result.config)
    kept = map_mesh(P, result.uv, mesh_faces=result.mesh_faces)
    assert kept.source == "local mesh"
    np.testing.assert_array_equal(kept.rows, rebuilt.rows)
    np.testing.assert_array_equal(kept.faces, rebuilt.faces)
    path = result.save(tmp_path / "map.npz")
    np.testing.assert_array_equal(ParamResult.load(path).mesh_faces, result.mesh_faces)
    with np.load(path) as archive:
        old = {k: archive[k] for k in archive.files if k != "mesh_faces"}
    np.savez(tmp_path / "old.npz", **old)
    assert ParamResult.load(tmp_path / "old.npz").mesh_faces is None
    np.savez(tmp_path / "bad.npz", **old, mesh_faces=result.mesh_faces + len(P))
    with pytest.raises(InputError, match=r"bad\.npz: mesh_faces: faces reference vertex "
                                         r"indices \d+\.\.\d+ but there are 581 points"):
        ParamResult.load(tmp_path / "bad.npz")
    with pytest.raises(InputError, match="^mesh_faces: faces reference vertex indices"):
        map_mesh(P, result.uv, mesh_faces=result.mesh_faces + len(P))


# --------------------------------------------------------------------------- pcgeom param


@pytest.fixture
def tiny(monkeypatch):
    monkeypatch.setattr(param_command, "get_preset", tiny_preset)


def _run_json(capsys, argv) -> dict:
    code = cli.main(argv)
    captured = capsys.readouterr()
    assert code == 0, captured.err
    return json.loads(captured.out)


def test_param_out_mesh_of_a_mesh_input_carries_the_map(tmp_path, capsys, tiny):
    out = tmp_path / "peaks_uv.obj"
    summary = _run_json(capsys, ["param", "--example", "peaks3", "--out",
                                 str(tmp_path / "uv.npz"), "--out-mesh", str(out),
                                 "--texture", "checker:6", "--quiet", "--json"])
    V, F = peaks_surface("peaks3")
    result = ParamResult.load(tmp_path / "uv.npz")
    mesh = summary["mesh"]
    assert summary["out_mesh"] == str(out)
    assert mesh["source"] == "input" and mesh["n_vertices"] == len(V)
    assert mesh["n_faces"] == len(F) and mesh["unused_points"] == 0
    assert mesh["texture"] == "checker:6"
    assert mesh["texture_files"] == {"material": str(tmp_path / "peaks_uv.mtl"),
                                     "image": str(tmp_path / "peaks_uv_checker.png")}
    loaded = trimesh.load(out, process=False)
    np.testing.assert_allclose(loaded.vertices, V, rtol=0, atol=1e-15)
    np.testing.assert_array_equal(loaded.faces, F)
    offset, scale = np.array(mesh["uv_offset"]), mesh["uv_scale"]
    np.testing.assert_allclose(loaded.visual.uv, (result.uv - offset) / scale, rtol=0, atol=1e-15)
    assert loaded.visual.material.image.size[0] >= 512  # trimesh found the image
    assert "map_Kd peaks_uv_checker.png" in (tmp_path / "peaks_uv.mtl").read_text()


def test_param_out_mesh_of_a_bare_cloud_is_its_local_mesh_and_says_so(tmp_path, capsys, tiny,
                                                                       monkeypatch):
    # The map file keeps the local mesh: --out-mesh writes it, rebuilding nothing.
    monkeypatch.setattr(texture, "_local_mesh_faces",
                        lambda *args: pytest.fail("the local mesh was rebuilt"))
    V, _ = peaks_surface("peaks3", n_side=24)
    src = tmp_path / "cloud.xyz"
    np.savetxt(src, V)
    out = tmp_path / "cloud_mesh.ply"
    code = cli.main(["param", str(src), "--out-mesh", str(out), "--quiet"])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    lines = [line for line in captured.out.splitlines() if line.startswith(str(out))]
    assert len(lines) == 1
    assert (f"{out}: the input has no faces, so this is its local mesh (the one the map was "
            "built on): ") in lines[0]
    assert "  texture coordinates: uv = (p - (" in captured.out
    result = ParamResult.load(tmp_path / "cloud_uv.npz")
    loaded = trimesh.load(out, process=False)
    assert len(loaded.faces) == result.history[0]["faces"] == len(result.mesh_faces)
    rows = np.array([np.flatnonzero((read_points(src).points == v).all(axis=1))[0]
                     for v in loaded.vertices])
    scaling = uv_scaling(result.uv[rows])
    np.testing.assert_allclose(loaded.visual.uv, scaling.apply(result.uv[rows]), rtol=0,
                               atol=1e-15)


def test_param_mesh_errors_are_one_line_before_training(tmp_path, capsys, monkeypatch):
    def forbidden(*args, **kwargs):
        raise AssertionError("parametrize was called although the input is invalid")

    monkeypatch.setattr(param_command, "parametrize", forbidden)
    monkeypatch.chdir(tmp_path)
    (tmp_path / "m_checker.png").mkdir()
    before = sorted(p.name for p in tmp_path.iterdir())
    example = ["param", "--example", "peaks3"]
    assert_cli_fails(capsys, example + ["--texture", "checker"],
                     "--texture needs --out-mesh MESH.obj (the mesh it textures)")
    assert_cli_fails(capsys, example + ["--out-mesh", "m.stl"],
                     "m.stl: mesh output must have extension .ply or .obj, got '.stl'")
    assert_cli_fails(capsys, example + ["--out-mesh", "m.stl", "--texture", "checker"],
                     "m.stl: mesh output must have extension .ply or .obj, got '.stl'")
    assert_cli_fails(capsys, example + ["--out-mesh", "m.ply", "--texture", "checker"],
                     "m.ply: a texture needs an .obj mesh (its .mtl material names the image); "
                     "a .ply holds the texture coordinates (texture_u texture_v) but no "
                     "material: drop --texture, or write .obj")
    assert_cli_fails(capsys, example + ["--out-mesh", "m.obj", "--texture", "checker"],
                     "m_checker.png: is a directory, expected a file")
    assert_cli_fails(capsys, example + ["--out-mesh", "m.obj", "--texture", "checker:0"],
                     "argument --texture: expected checker or checker:N (N squares along the "
                     "longer side of the map, 1 to 256), got 'checker:0'")
    assert_cli_fails(capsys, example + ["--out-mesh", "peaks3_uv.npz"],
                     "mesh output must have extension .ply or .obj, got '.npz'")
    assert sorted(p.name for p in tmp_path.iterdir()) == before


# --------------------------------------------------------------------------- the figure


def test_plot_checker_writes_a_png_and_checks_its_input(tmp_path):
    V, F = peaks_surface("peaks3", n_side=12)
    uv = uv_scaling(V[:, :2]).apply(V[:, :2])
    path = plot_checker(V, F, uv, tmp_path / "c.png", squares=4, values=np.arange(len(F)),
                        title="peaks3")
    assert path.read_bytes()[:8] == PNG_SIGNATURE
    assert plot_checker(V, F, uv, tmp_path / "plain.png").exists()
    with pytest.raises(ValueError, match=r"uv: expected 144 rows \(one per vertex\), got 143"):
        plot_checker(V, F, uv[:-1], tmp_path / "x.png")
    with pytest.raises(ValueError, match=r"values: expected shape \(242,\), got \(3,\)"):
        plot_checker(V, F, uv, tmp_path / "x.png", values=[1, 2, 3])
    with pytest.raises(ValueError, match=r"F: expected shape \(M, 3\) with indices below 144"):
        plot_checker(V, F + 1, uv, tmp_path / "x.png")
    with pytest.raises(ValueError, match="expected extension '.png', got '.jpg'"):
        plot_checker(V, F, uv, tmp_path / "x.jpg")
    assert sorted(p.name for p in Path(tmp_path).iterdir()) == ["c.png", "plain.png"]
