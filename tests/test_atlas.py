"""``cut="auto"``: seams (tree-cotree), the cut mesh, the chart without a fold, the atlas in the
unit square, its results fields and OBJ, and every error message."""

from __future__ import annotations

import numpy as np
import pytest

from pcgeom import ParamResult, parametrize
from pcgeom.errors import InputError
from pcgeom.io import write_ply_atomic
from pcgeom.maps.atlas import boundary_simple, overlap_area
from pcgeom.maps.seams import cut_graph, cut_open, euler_characteristic
from pcgeom.mesh import boundary_loops, signed_areas
from pcgeom.synthetic_closed import closed_surface

from .helpers import assert_cli_fails


@pytest.fixture(scope="module")
def torus():
    return closed_surface("torus", 2000, seed=1)


@pytest.fixture(scope="module")
def torus_map(torus):
    return parametrize(torus.points, "free", cut="auto", progress=False)


@pytest.mark.parametrize("name, genus", [("torus", 1), ("ellipsoid", 0)])
def test_cut_true_mesh_is_a_disk(name, genus):
    """Tree-cotree on the true closed mesh: the cut mesh has Euler characteristic 1 and one
    boundary loop (a disk), 2g loops (one path at genus 0), every edge of the seams doubled."""
    s = closed_surface(name, 2000)
    E, cut, info = cut_graph(s.points, s.faces)
    assert info["genus"] == genus and info["loops"] == (2 * genus if genus else 1)
    Fc, origin = cut_open(s.faces, E, cut, len(s.points))
    assert euler_characteristic(Fc) == 1
    loops = boundary_loops(Fc)
    assert len(loops) == 1
    assert len(loops[0]) == 2 * cut.sum()  # each seam edge once on each side
    np.testing.assert_array_equal(origin[Fc], s.faces)
    # Pruned: every seam vertex of a loop graph has degree 2 or more.
    if genus:
        deg = np.bincount(E[cut].ravel(), minlength=len(s.points))
        assert deg[deg > 0].min() >= 2


def test_torus_atlas(torus, torus_map):
    r = torus_map
    rec = r.history[-1]
    assert rec["seams"]["genus"] == 1 and rec["seams"]["loops"] == 2
    assert rec["cut_euler"] == 1 and rec["cut_loops"] == 1
    assert rec["flips"]["count"] == 0 and rec["overlap"] is False
    assert r.uv.shape == (len(torus.points), 2)
    assert (r.uv >= 0).all() and (r.uv <= 1).all()
    assert (r.corner_uv >= 0.02 - 1e-12).all() and (r.corner_uv <= 0.98 + 1e-12).all()
    np.testing.assert_array_equal(r.chart, 0)
    # No corner triangle turned over, none overlapping another (shapely union).
    U = r.corner_uv.reshape(-1, 2)
    F = np.arange(len(U)).reshape(-1, 3)
    assert (signed_areas(U, F) > 0).all()
    assert overlap_area(U, F) < 1e-9
    # Seams split the uv: some points carry two or more uv.
    keys = np.unique(np.column_stack([r.mesh_faces.reshape(-1, 1), U]), axis=0)
    assert len(keys) > len(np.unique(r.mesh_faces))
    # The scale-factor spread of a torus of radii 1 and 0.4 is about ((1 + .4)/(1 - .4))^2.
    assert 2.0 < rec["stretch"] < 8.0


def test_overlap_checks_fail_on_a_fold():
    """boundary_simple and overlap_area see a chart folded over itself."""
    U = np.array([[0, 0], [1, 0], [0, 1], [1, 1]], dtype=float)
    F = np.array([[0, 1, 2], [1, 0, 3]])  # the second triangle lies over the first's side
    U2 = np.array([[0, 0], [1, 0], [0, 1], [0.6, 0.6]], dtype=float)
    F2 = np.array([[0, 1, 2], [0, 1, 3]])
    assert overlap_area(U2, F2) > 0.1
    assert overlap_area(U, np.array([[0, 1, 2], [1, 3, 2]])) < 1e-12
    assert boundary_simple(U, np.array([[0, 1, 2], [1, 3, 2]]))
    del F


def test_round_trip_and_old_files(tmp_path, torus_map):
    r = torus_map
    path = r.save(tmp_path / "t.npz")
    q = ParamResult.load(path)
    np.testing.assert_array_equal(q.chart, r.chart)
    np.testing.assert_array_equal(q.corner_uv, r.corner_uv)
    np.testing.assert_array_equal(q.uv, r.uv)
    # A file without the atlas keys (every file before them) loads as before.
    with np.load(path) as data:
        old = {k: data[k] for k in data.files if k not in ("chart", "corner_uv")}
    np.savez(tmp_path / "old.npz", **old)
    o = ParamResult.load(tmp_path / "old.npz")
    assert o.chart is None and o.corner_uv is None
    np.testing.assert_array_equal(o.uv, r.uv)
    bad = dict(old, chart=np.zeros(3, dtype=np.int64), corner_uv=r.corner_uv)
    np.savez(tmp_path / "bad.npz", **bad)
    with pytest.raises(InputError, match="'chart' must have shape"):
        ParamResult.load(tmp_path / "bad.npz")


def test_open_disk_gets_no_seam():
    e = closed_surface("ellipsoid", 2000)
    z = e.points[:, 2]
    r = parametrize(e.points[z < 0.6 * np.abs(z).max()], cut="auto", progress=False)
    rec = r.history[-1]
    assert rec["seams"]["length"] == 0.0 and rec["flips"]["count"] == 0
    assert rec["cut_loops"] == 1 and (r.uv >= 0).all() and (r.uv <= 1).all()


@pytest.mark.parametrize("holes", [1, 2])
def test_open_torus_and_annulus_cut_into_a_disk(holes):
    """Open meshes: the boundary contracted to the root, 2g + b - 1 paths from the boundary
    to the boundary; the true mesh cut is a disk, and so is the cloud's."""
    s = closed_surface("torus", 2000)
    P, F = s.points, s.faces
    for k, c in enumerate([P[np.argmax(P[:, 0])], P[np.argmin(P[:, 0])]][:holes]):
        F = F[(np.linalg.norm(P - c, axis=1) > 0.5)[F].all(axis=1)]
    E, cut, info = cut_graph(P, F)
    assert info["genus"] == 1 and info["boundary_loops"] == holes
    assert info["loops"] == 2 + holes - 1
    Fc, _ = cut_open(F, E, cut, len(P))
    assert euler_characteristic(Fc) == 1 and len(boundary_loops(Fc)) == 1
    e = closed_surface("ellipsoid", 2000)
    z = e.points[:, 2]
    r = parametrize(e.points[np.abs(z) < 0.8 * np.abs(z).max()], cut="auto", progress=False)
    rec = r.history[-1]
    assert rec["seams"]["boundary_loops"] == 2 and rec["seams"]["loops"] == 1
    assert rec["cut_euler"] == 1 and rec["cut_loops"] == 1
    assert rec["flips"]["count"] == 0 and not rec["overlap"]


@pytest.mark.parametrize("kwargs, message", [
    ({"cut": "yes"}, "cut must be one of none, auto, got 'yes'"),
    ({"cut": "auto", "domain": "disk"}, "--cut auto maps onto the free domain only"),
    ({"cut": "auto", "max_stretch": 1.0}, "max-stretch must be a number above 1, got 1.0"),
    ({"cut": "auto", "max_stretch": "abc"}, "max-stretch must be a number above 1, got 'abc'"),
    ({"cut": "auto", "max_stretch": float("nan")}, "max-stretch must be a number above 1"),
])
def test_api_errors(torus, kwargs, message):
    with pytest.raises(InputError, match=message):
        parametrize(torus.points, progress=False, **kwargs)


@pytest.fixture(scope="module")
def torus_file(tmp_path_factory, torus):
    path = tmp_path_factory.mktemp("atlas") / "torus.ply"
    write_ply_atomic(path, torus.points, torus.faces)
    return path


@pytest.mark.parametrize("extra, message", [
    (["--cut", "auto", "--domain", "disk"], "--cut auto maps onto the free domain only"),
    (["--cut", "auto", "--max-stretch", "0.5"], "max-stretch must be a number above 1, got '0.5'"),
    (["--cut", "auto", "--max-stretch", "big"], "max-stretch must be a number above 1, got 'big'"),
    (["--cut", "auto", "--out-mesh", "m.ply"], "--out-mesh with --cut auto writes per-corner"),
    (["--cut", "some"], "argument --cut: invalid choice: 'some'"),
])
def test_cli_errors(tmp_path, monkeypatch, capsys, torus_file, extra, message):
    monkeypatch.chdir(tmp_path)
    assert_cli_fails(capsys, ["param", str(torus_file), "--out", "o.npz", *extra], message)
    assert not any(tmp_path.iterdir())


def test_cli_obj(tmp_path, capsys, torus_file):
    import trimesh

    from pcgeom import cli

    obj = tmp_path / "t.obj"
    assert cli.main(["param", str(torus_file), "--cut", "auto", "--out", str(tmp_path / "t.npz"),
                     "--out-mesh", str(obj), "--texture", "checker:8", "--quiet",
                     "--plot", str(tmp_path / "p.png")]) == 0
    capsys.readouterr()
    assert (tmp_path / "p.png").stat().st_size > 10000  # the atlas figure
    r = ParamResult.load(tmp_path / "t.npz")
    text = obj.read_text()
    n_v = sum(line.startswith("v ") for line in text.splitlines())
    n_vt = sum(line.startswith("vt ") for line in text.splitlines())
    assert n_v == len(np.unique(r.mesh_faces)) and n_vt > n_v  # split in uv, not in 3D
    m = trimesh.load(obj, process=False)
    assert len(m.faces) == len(r.mesh_faces)
    assert len(m.vertices) == n_vt  # trimesh splits a vertex per vt
    assert (m.visual.uv >= 0).all() and (m.visual.uv <= 1).all()
    assert (tmp_path / "t.mtl").exists() and (tmp_path / "t_checker.png").exists()
    # MeshLab keeps one vertex per point and the uv per corner (wedge texture coordinates).
    pymeshlab = pytest.importorskip("pymeshlab")
    ms = pymeshlab.MeshSet()
    ms.load_new_mesh(str(obj))
    mm = ms.current_mesh()
    assert (mm.vertex_number(), mm.face_number()) == (n_v, len(r.mesh_faces))
    wedge = mm.wedge_tex_coord_matrix()
    assert wedge.shape == (3 * len(r.mesh_faces), 2)
    assert (wedge >= 0).all() and (wedge <= 1).all()


def test_cut_map_report(torus, torus_map):
    """Inside charts no true triangle flips and the angle error is that of a smooth map; the
    per-point uv alone (one side of every seam) turns the seam's triangles over."""
    from pcgeom.maps.atlas_eval import cut_map_report, triangle_uv
    from pcgeom.metrics import angle_distortion

    rep = cut_map_report(torus.points, torus.faces, torus_map)
    assert rep["flipped"] == 0 and rep["overlap"] < 1e-9
    assert 0 < rep["seam_crossed_percent"] < 2.0
    assert rep["mean_abs_angle_rad"] < 0.03
    assert rep["n_faces"] + rep["seam_crossed"] == len(torus.faces)
    naive = angle_distortion(torus.points, torus.faces, torus_map.uv)
    assert naive.flipped > rep["seam_crossed"] / 4
    T, crossed = triangle_uv(torus.points, torus.faces, torus_map.mesh_faces,
                             torus_map.corner_uv)
    assert (signed_areas(T[~crossed].reshape(-1, 2),
                         np.arange(3 * (~crossed).sum()).reshape(-1, 3)) > 0).all()


def test_cli_evaluate_cut_map(tmp_path, capsys, torus_file):
    import json

    from pcgeom import cli

    out = tmp_path / "t.npz"
    assert cli.main(["param", str(torus_file), "--cut", "auto", "--out", str(out), "--quiet",
                     "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["evaluation"]["flipped"] == 0
    assert cli.main(["evaluate", str(torus_file), str(out), "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert rep["flipped"] == 0 and rep["charts"] == 1 and rep["seam_crossed"] > 0
    # --plot: the atlas, charts coloured, seams on the surface (param --plot: test_cli_obj).
    assert cli.main(["evaluate", str(torus_file), str(out), "--plot",
                     str(tmp_path / "a.png"), "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert rep["plots"]["atlas"] == str(tmp_path / "a.png")
    assert (tmp_path / "a.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_more_roots_never_longer():
    """cut_graph keeps the shortest of its roots' cuts, still a disk."""
    s = closed_surface("torus", 2000)
    E, one, _ = cut_graph(s.points, s.faces)
    E, four, info = cut_graph(s.points, s.faces, roots=4)
    length = np.linalg.norm(s.points[E[:, 0]] - s.points[E[:, 1]], axis=1)
    assert info["roots"] == 4 and length[four].sum() <= length[one].sum() + 1e-12
    Fc, _ = cut_open(s.faces, E, four, len(s.points))
    assert euler_characteristic(Fc) == 1 and len(boundary_loops(Fc)) == 1


def test_double_torus_short_seams():
    """Genus 2 (the classic double torus, 1.5k points): the greedy homology-basis cut graph
    opens it into one disk chart with no flip, seams at most 3 square roots of the area
    (tree-cotree's loops through one root: 3.4 at 5k-20k)."""
    from pcgeom.synthetic_atlas import pretzel

    rec = parametrize(pretzel(2, 1500), cut="auto", progress=False).history[-1]
    assert rec["seams"]["genus"] == 2 and rec["seams"]["cut"] == "short"
    assert rec["cut_euler"] == 1 and rec["cut_loops"] == 1 and rec["flips"]["count"] == 0
    assert rec["overlap_area"] < 1e-9 and rec["stretch"] <= 10
    assert rec["seam_length"] <= 3.0


def test_an_overlapping_chart_is_split(monkeypatch):
    """A chart whose boundary crosses itself is split into charts, each one-to-one, packed
    apart by xatlas; when nothing maps it (Tutte's embedding held to fail too), a one-line
    error, no result."""
    import pcgeom.maps.atlas as atlas
    import pcgeom.maps.charts as charts

    real = atlas.chart_map
    calls = []

    def crossed(V, F):
        U, info = real(V, F)
        calls.append(len(F))
        if len(F) == calls[0]:  # the whole torus, whichever cut: its boundary made to cross
            loop = np.asarray(boundary_loops(F)[0])
            U = U.copy()
            U[loop[0]] = U[loop[len(loop) // 2]] + (U[loop[len(loop) // 2]] - U.mean(axis=0))
        return U, info

    monkeypatch.setattr(atlas, "chart_map", crossed)
    small = closed_surface("torus", 1000, seed=3).points
    r = parametrize(small, cut="auto", progress=False)
    rec = r.history[-1]
    assert rec["charts"] >= 2 and rec["seams"]["splits"] >= 1 and rec["packer"] == "xatlas"
    assert rec["flips"]["count"] == 0 and rec["overlap_area"] < 1e-9
    U = r.corner_uv.reshape(-1, 2)
    F = np.arange(len(U)).reshape(-1, 3)
    assert (signed_areas(U, F) > 0).all() and overlap_area(U, F) < 1e-9
    assert (U >= 0.02 - 1e-12).all() and (U <= 0.98 + 1e-12).all()
    assert set(np.unique(r.chart)) == set(range(rec["charts"]))

    def never(V, chart):
        return charts.Chart(chart.faces, chart.F, chart.origin, chart.U,
                            dict(chart.info, ok=False))

    calls.clear()
    monkeypatch.setattr(charts, "_tutte", never)
    monkeypatch.setattr(charts, "DEPTH", 0)
    monkeypatch.setattr(charts.fit_charts, "__kwdefaults__", {"roots": 1, "slits": 6, "depth": 0})
    with pytest.raises(InputError, match=r"the atlas of this cloud is not one-to-one \(0 "
                       r"triangles turned over, [0-9.]+% of its area covered twice\) when"):
        parametrize(small, cut="auto", progress=False)


def test_finger_gets_seams_within_the_bound():
    """A disk with a long thin finger: its one free map shrinks the finger (spread over the
    true mesh in the hundreds); --cut auto brings every chart within the bound with no flip
    and no overlap, the angle error inside charts that of libigl's LSCM on the true mesh cut
    along the same seams. With a bound it already meets, no seam."""
    from pcgeom.maps.atlas_eval import cut_map_report, same_seams_lscm
    from pcgeom.synthetic_atlas import finger

    s = finger(1500, seed=2)
    assert euler_characteristic(s.faces) == 1 and len(boundary_loops(s.faces)) == 1
    # One chart (a bound it meets): the free LSCM map of the disk, the finger shrunk.
    loose = parametrize(s.points, "free", cut="auto", max_stretch=1e9, progress=False)
    assert loose.history[-1]["seams"]["length"] == 0.0 and loose.history[-1]["charts"] == 1
    assert loose.history[-1]["stretch"] > 100
    r = parametrize(s.points, "free", cut="auto", progress=False)
    rec = r.history[-1]
    assert rec["seams"]["length"] > 0 and rec["chart_stretch"] <= 10.0
    assert rec["flips"]["count"] == 0 and rec["overlap_area"] < 1e-9
    rep = cut_map_report(s.points, s.faces, r)
    assert rep["flipped"] == 0 and rep["stretch"] <= 10.0 and rep["overlap"] < 1e-9
    assert rep["seam_crossed_percent"] < 2.0
    base = same_seams_lscm(s.points, s.faces, r)
    assert rep["mean_abs_angle_rad"] <= 1.5 * base["mean_abs_angle_rad"]


def test_atlas_figure_parts(torus_map):
    """The figure's cut mesh: one chart on the torus, its seams the atlas's boundary (each
    seam edge on two sides), no rim on a closed surface."""
    from pcgeom.apps.plot_atlas import cut_mesh, seam_edges

    origin, U, Fc, chart = cut_mesh(torus_map.mesh_faces, torus_map.corner_uv)
    assert (chart == 0).all() and len(U) == len(origin) > len(np.unique(torus_map.mesh_faces))
    seams = seam_edges(torus_map.mesh_faces, Fc, origin)
    assert len(seams) == len(boundary_loops(Fc)[0])
    pairs = np.sort(origin[seams], axis=1)
    _, counts = np.unique(pairs, axis=0, return_counts=True)
    assert (counts == 2).all()  # each seam edge of the surface: once per side


def test_cut_map_refused_by_boundary(tmp_path, capsys, torus_file, torus_map):
    """A cut map's point uv jump across seams: boundary refuses it in one line (before any
    output) and names what writes its mesh with the atlas."""
    path = torus_map.save(tmp_path / "t.npz")
    out = tmp_path / "b.json"
    assert_cli_fails(capsys, ["boundary", str(torus_file), "--map", str(path), "--out",
                              str(out)], "is a cut map (--cut auto); ")
    assert not out.exists()


def test_reconstruct_cut_map(tmp_path, capsys, torus_file, torus_map):
    """reconstruct on a cut map writes its own mesh with the atlas per corner (one vertex per
    meshed point, more uv than vertices, every uv in [0, 1], the checkerboard beside; trimesh
    and MeshLab read the same counts); a
    PLY path or remeshing options are refused in one line, nothing written."""
    import json

    import trimesh

    from pcgeom import cli

    path = torus_map.save(tmp_path / "t.npz")
    for extra, message in [(["--out", str(tmp_path / "m.ply")], "give an .obj path to --out"),
                           (["--out", str(tmp_path / "m.obj"), "--target-vertices", "900"],
                            "not remeshed; drop --target-vertices and --size")]:
        assert_cli_fails(capsys, ["reconstruct", str(torus_file), "--map", str(path), *extra],
                         message)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["t.npz"]
    obj = tmp_path / "m.obj"
    assert cli.main(["reconstruct", str(torus_file), "--map", str(path), "--out", str(obj),
                     "--texture", "checker:8", "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    n_faces = len(torus_map.mesh_faces)
    assert summary["n_faces"] == n_faces and summary["charts"] == 1 and summary["uv_inside"]
    assert summary["n_vertices"] == len(np.unique(torus_map.mesh_faces))
    assert summary["n_uv"] > summary["n_vertices"]  # seams split in uv, not in 3D
    m = trimesh.load(obj, process=False)
    assert len(m.faces) == n_faces and len(m.vertices) == summary["n_uv"]
    assert (m.visual.uv >= 0).all() and (m.visual.uv <= 1).all()
    assert (tmp_path / "m.mtl").exists() and (tmp_path / "m_checker.png").exists()
    # MeshLab reads the same OBJ: one vertex per point, every corner's uv in [0, 1].
    pymeshlab = pytest.importorskip("pymeshlab")
    ms = pymeshlab.MeshSet()
    ms.load_new_mesh(str(obj))
    mm = ms.current_mesh()
    assert (mm.vertex_number(), mm.face_number()) == (summary["n_vertices"], n_faces)
    wedge = mm.wedge_tex_coord_matrix()
    assert wedge.shape == (3 * n_faces, 2) and len(np.unique(wedge, axis=0)) == summary["n_uv"]
    assert (wedge >= 0).all() and (wedge <= 1).all()
