"""Surface reconstruction (pcgeom.apps.reconstruct, ``pcgeom reconstruct``): planes and an
analytic height field with known surfaces, a real test surface against its mesh, the lifting
rule, gmsh's session handling and the command line."""

from __future__ import annotations

import json
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial import cKDTree

import pcgeom.cli.reconstruct as reconstruct_command
from pcgeom import InputError, cli, get_domain, parametrize
from pcgeom.apps.baselines import lscm
from pcgeom.apps.boundary import BoundaryLoops, detect_boundary
from pcgeom.apps.reconstruct import (lift, map_delaunay, mesh_report, reconstruct_on_domain,
                                     reconstruct_surface)
from pcgeom.cloud import fingerprint
from pcgeom.examples import BUMPS, peaks_surface
from pcgeom.io import read_points

from tests.helpers import assert_cli_fails, tiny_preset

gmsh = pytest.importorskip("gmsh")
igl = pytest.importorskip("igl")

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"


def _grid(n: int = 20, hole: tuple[int, int] | None = None, shear: float = 0.2) -> np.ndarray:
    """An n x n grid sheared by ``shear``, optionally without the block hole[0]..hole[1]
    squared of grid indices. (N, 2)"""
    i, j = (a.ravel() for a in np.meshgrid(np.arange(n), np.arange(n), indexing="xy"))
    keep = np.ones(len(i), dtype=bool)
    if hole is not None:
        lo, hi = hole
        keep = ~((i >= lo) & (i <= hi) & (j >= lo) & (j <= hi))
    return np.column_stack([i[keep] + shear * j[keep], j[keep]]).astype(np.float64)


def _assert_clean(report: dict, loops: int) -> None:
    assert report["edge_manifold"] and report["oriented"]
    assert report["n_boundary_loops"] == loops


# --------------------------------------------------------------------------- planes


@pytest.mark.parametrize("hole, loops", [(None, 1), ((7, 11), 2)])
def test_flat_grid_is_rebuilt_on_its_plane(hole, loops):
    U = _grid(20, hole)
    P = np.column_stack([U, np.zeros(len(U))])
    found = detect_boundary(U)
    assert len(found.loops) == loops
    V, F, report = reconstruct_surface(P, U, found, target_vertices=800)
    assert np.abs(V[:, 2]).max() < 1e-12  # on the plane z = 0
    _assert_clean(report, loops)
    assert 640 <= report["n_vertices"] <= 960  # within 20% of the target
    # Every triangle counter-clockwise in the map (here the xy of the mesh): normals +z.
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    assert (np.cross(b - a, c - a)[:, 2] > 0).all()
    # The loop points are mesh vertices, exactly.
    rows = np.concatenate(found.loops)
    assert np.isin(P[rows].view("f8,f8,f8"), V.view("f8,f8,f8")).all()
    if hole is not None:  # nothing inside the hole
        lo, hi = hole[0] - 1 + 0.5, hole[1] + 1 - 0.5  # well inside the hole in grid units
        y = V[:, 1]
        x = V[:, 0] - 0.2 * y
        assert not ((x > lo) & (x < hi) & (y > lo) & (y < hi)).any()


def test_tilted_plane_is_exact_with_the_vertices_outside_too():
    """Barycentric interpolation and the edge rule both reproduce a linear function; the
    grid's rim loses corner triangles to boundary detection, so some vertices are outside."""
    U = _grid(16, (5, 8))
    P = np.column_stack([U, 0.3 * U[:, 0] - 0.2 * U[:, 1] + 1.0])
    V, F, report = reconstruct_surface(P, U, detect_boundary(U), target_vertices=600)
    assert report["n_outside"] > 0
    np.testing.assert_allclose(V[:, 2], 0.3 * V[:, 0] - 0.2 * V[:, 1] + 1.0, atol=1e-12)
    _assert_clean(report, 2)


def test_adaptive_size_follows_lambda():
    """lambda_inv 16 times larger on the right half: size lambda_inv^-1/2 is 4 times smaller
    there (smoothed over 8 neighbours and graded by gmsh: measured edge ratio 0.32)."""
    U = _grid(30)
    P = np.column_stack([U, np.zeros(len(U))])
    x = U[:, 0] - 0.2 * U[:, 1]  # the unsheared grid column
    lam = np.where(x > 14.5, 16.0, 1.0)
    found = detect_boundary(U)
    V, F, report = reconstruct_surface(P, U, found, size="adaptive", target_vertices=2000,
                                       lambda_inv=lam)
    _assert_clean(report, 1)
    assert 1600 <= report["n_vertices"] <= 2400
    edge = np.linalg.norm(V[F] - V[np.roll(F, -1, axis=1)], axis=2).mean(axis=1)  # (M,)
    cx = (V[F, 0] - 0.2 * V[F, 1]).mean(axis=1)
    ratio = edge[cx > 19].mean() / edge[cx < 10].mean()
    assert 0.2 < ratio < 0.45
    V, F, _ = reconstruct_surface(P, U, found, target_vertices=2000)  # uniform: same sizes
    edge = np.linalg.norm(V[F] - V[np.roll(F, -1, axis=1)], axis=2).mean(axis=1)
    cx = (V[F, 0] - 0.2 * V[F, 1]).mean(axis=1)
    assert 0.85 < edge[cx > 19].mean() / edge[cx < 10].mean() < 1.15


def test_lift_inside_is_barycentric_and_outside_takes_the_nearest_edge_point():
    U = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])
    T = np.array([[0, 1, 3], [0, 3, 2]])
    P = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 2.0], [0.0, 1.0, 4.0], [1.0, 1.0, 8.0]])
    Q = np.array([[0.75, 0.25], [0.5, -1.0], [3.0, 0.5], [-1.0, -1.0]])
    V, outside = lift(P, U, T, Q)
    assert outside.tolist() == [False, True, True, True]
    # (0.75, 0.25) = 0.25 p0 + 0.5 p1 + 0.25 p3 in triangle (0, 1, 3).
    np.testing.assert_allclose(V[0], 0.25 * P[0] + 0.5 * P[1] + 0.25 * P[3])
    np.testing.assert_allclose(V[1], 0.5 * P[0] + 0.5 * P[1])  # nearest: (0.5, 0) on 0-1
    np.testing.assert_allclose(V[2], 0.5 * P[1] + 0.5 * P[3])  # nearest: (1, 0.5) on 1-3
    np.testing.assert_allclose(V[3], P[0])  # nearest: the corner


def test_lift_finds_triangles_where_matplotlibs_trifinder_refuses_them(monkeypatch):
    """matplotlib's trapezoid map refuses some valid triangulations ('Triangulation is
    invalid'); the map's own Delaunay triangles are then located through scipy's, with the
    same lifted points, and triangles that are not the map's are a one-line error."""
    import matplotlib.tri as mtri

    P, F0 = peaks_surface("peaks3", n_side=20)
    U = lscm(P, F0)
    found = detect_boundary(U)
    Q = np.random.default_rng(1).uniform(U.min(axis=0) - 0.05, U.max(axis=0) + 0.05,
                                         size=(500, 2))
    want = lift(P, U, found.triangles, Q)

    def refuse(self):
        raise RuntimeError("Triangulation is invalid")

    monkeypatch.setattr(mtri.Triangulation, "get_trifinder", refuse)
    got = lift(P, U, found.triangles, Q)
    np.testing.assert_array_equal(got[1], want[1])
    np.testing.assert_allclose(got[0], want[0], atol=1e-12)
    with pytest.raises(InputError, match="not all triangles of the map's Delaunay"):
        lift(P, U, np.array([[0, 1, 25]]), Q)


# --------------------------------------------------------------------------- curved surfaces


def test_peaks_height_field_is_close_to_the_true_surface():
    P, F0 = peaks_surface("peaks3", n_side=40)
    U = lscm(P, F0)  # a good map of the cloud, standing in for pcgeom's
    found = detect_boundary(U)
    V, F, report = reconstruct_surface(P, U, found, target_vertices=2000)
    _assert_clean(report, 1)
    assert 1600 <= report["n_vertices"] <= 2400
    z = np.zeros(len(V))
    for a, cx, cy, w in BUMPS["peaks3"]:
        z += a * np.exp(-((V[:, 0] - cx) ** 2 + (V[:, 1] - cy) ** 2) / w**2)
    diag = np.linalg.norm(P.max(axis=0) - P.min(axis=0))
    # Measured: 0.0023 of the diagonal (piecewise-linear interpolation of a 40 x 40 grid).
    assert np.abs(z - V[:, 2]).max() / diag < 0.005
    # Vertex-to-point: up to half a grid spacing on the true surface. Measured: 0.016.
    assert report["hausdorff_rel"] < 0.025 and report["mean_distance_rel"] < 0.01
    assert report["min_angle_deg"] > 15


@pytest.mark.skipif(not (DATA / "face_3holes_small_choi.ply").exists(),
                    reason="shared test data not present")
def test_face_with_three_holes_has_four_loops_and_stays_on_the_surface():
    cloud = read_points(DATA / "face_3holes_small_choi.ply")
    P, F0 = cloud.points, cloud.faces
    U = lscm(P, F0)
    found = detect_boundary(U)
    assert len(found.loops) == 4
    V, F, report = reconstruct_surface(P, U, found, target_vertices=3000)
    _assert_clean(report, 4)
    assert 2400 <= report["n_vertices"] <= 3600
    d2, _, _ = igl.point_mesh_squared_distance(V, P, np.ascontiguousarray(F0, dtype=np.int64))
    diag = np.linalg.norm(P.max(axis=0) - P.min(axis=0))
    # The target: within 1% of the diagonal of the true surface.
    assert np.sqrt(d2.max()) / diag < 0.01


# --------------------------------------------------------------------------- bad input, gmsh


def test_bad_input_is_rejected():
    U = _grid(12)
    P = np.column_stack([U, np.zeros(len(U))])
    found = detect_boundary(U)
    with pytest.raises(InputError, match="size: expected one of uniform, adaptive, got 'fine'"):
        reconstruct_surface(P, U, found, size="fine")
    with pytest.raises(InputError, match="lambda_inv: needed by size='adaptive'"):
        reconstruct_surface(P, U, found, size="adaptive")
    with pytest.raises(InputError, match="lambda_inv: expected 144 finite positive values"):
        reconstruct_surface(P, U, found, size="adaptive", lambda_inv=-np.ones(len(U)))
    with pytest.raises(InputError, match=r"U: expected 144 rows \(one per point\), got 143"):
        reconstruct_surface(P, U[:-1], found)
    with pytest.raises(InputError, match="target_vertices: expected an integer >= 3, got 2"):
        reconstruct_surface(P, U, found, target_vertices=2)
    with pytest.raises(InputError, match="no boundary loop; the reconstruction would be empty"):
        reconstruct_surface(P, U, replace(found, loops=[], areas=np.zeros(0)))
    loop = found.loops[0]
    sharing = replace(found, loops=[loop, loop[:5][::-1]], areas=np.array([1.0, -0.1]))
    with pytest.raises(InputError, match=r"loops: the edge of rows \d+ and \d+ is on loops "
                                         "twice; loops may touch at points but not share edges"):
        reconstruct_surface(P, U, sharing)
    with pytest.raises(InputError, match="first loop must be the outer loop"):
        reconstruct_surface(P, U, replace(found, loops=[loop[::-1]], areas=-found.areas))
    with pytest.raises(TypeError, match="loops: expected BoundaryLoops"):
        reconstruct_surface(P, U, found.loops)


def _square(i0: int, j0: int, n: int = 12, side: int = 2) -> np.ndarray:
    """Rows of ``_grid(n)`` on the square of grid corners (i0, j0) and (i0 + side, j0 + side),
    clockwise (a hole's orientation), every grid point on its sides."""
    ring = ([(i0, j0 + k) for k in range(side)] + [(i0 + k, j0 + side) for k in range(side)]
            + [(i0 + side, j0 + side - k) for k in range(side)]
            + [(i0 + side - k, j0) for k in range(side)])
    return np.array([j * n + i for i, j in ring])


def _holes(U, found, *holes) -> BoundaryLoops:
    return BoundaryLoops(loops=[found.loops[0], *holes],
                         areas=np.array([1.0] + [-1.0] * len(holes)), h=None, c=1.0,
                         min_loop=3, triangles=found.triangles)


def test_loops_that_touch_at_a_point_are_meshed_with_one_copy_per_visit():
    U = _grid(12)
    P = np.column_stack([U, 0.3 * U[:, 0] - 0.2 * U[:, 1]])
    found = detect_boundary(U)
    # Two holes with the grid point (4, 4) in common, as detection reports them.
    touching = _holes(U, found, _square(2, 2), _square(4, 4))
    assert len(np.intersect1d(touching.loops[1], touching.loops[2])) == 1
    V, F, report = reconstruct_surface(P, U, touching, target_vertices=400)
    _assert_clean(report, 3)  # the two holes stay two loops
    np.testing.assert_allclose(V[:, 2], 0.3 * V[:, 0] - 0.2 * V[:, 1], atol=1e-12)


def test_crossing_loops_of_a_folded_map_are_repaired_into_simple_polygons():
    from pcgeom.apps.reconstruct.polygons import _polygons, _valid

    U = _grid(12)
    P = np.column_stack([U, np.zeros(len(U))])
    found = detect_boundary(U)
    # Two holes that overlap, as where a fold lays kept triangles over each other.
    crossing = _holes(U, found, _square(3, 3), _square(4, 4))
    parts = _polygons(U, crossing)
    assert _valid(parts) and len(parts) == 1 and len(parts[0]) == 2  # one merged hole
    V, F, report = reconstruct_surface(P, U, crossing, target_vertices=300)
    _assert_clean(report, 2)


def test_gmsh_is_finalized_when_meshing_fails(monkeypatch):
    U = _grid(12)
    P = np.column_stack([U, np.zeros(len(U))])

    def broken(dim):
        raise Exception("meshing failed on purpose")

    monkeypatch.setattr(gmsh.model.mesh, "generate", broken)
    with pytest.raises(InputError, match="gmsh could not mesh the region: meshing failed"):
        reconstruct_surface(P, U, detect_boundary(U), target_vertices=200)
    assert gmsh.isInitialized() == 0


def test_mesh_report_sees_a_flipped_triangle_and_a_non_manifold_edge():
    V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [0.5, 0.5, 1]])
    ok = mesh_report(V, np.array([[0, 1, 3], [0, 3, 2]]), V)
    assert ok["oriented"] and ok["edge_manifold"] and ok["n_boundary_loops"] == 1
    assert ok["min_angle_deg"] == pytest.approx(45.0)
    assert not mesh_report(V, np.array([[0, 1, 3], [0, 2, 3]]), V)["oriented"]
    fan = np.array([[0, 1, 3], [0, 3, 2], [0, 3, 4]])  # edge 0-3 on three triangles
    assert not mesh_report(V, fan, V)["edge_manifold"]


# --------------------------------------------------------------------------- command line


_tiny = tiny_preset


@pytest.fixture
def sheet(tmp_path):
    """A flat grid with a hole at z = 0.1 x, as XYZ, and a map file holding its xy."""
    U = _grid(16, (5, 8))
    P = np.column_stack([U, 0.1 * U[:, 0]])
    src = tmp_path / "sheet.xyz"
    np.savetxt(src, P)
    P = read_points(src).points
    result = parametrize(P, "free", config=_tiny("fast"), progress=False)
    map_path = replace(result, uv=U).save(tmp_path / "map.npz")
    return src, map_path, P, result


def test_cli_with_a_map_writes_the_mesh(tmp_path, capsys, sheet):
    src, map_path, P, _ = sheet
    out = tmp_path / "mesh.ply"
    code = cli.main(["reconstruct", str(src), "--map", str(map_path), "--target-vertices",
                     "500", "--out", str(out), "--json"])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    summary = json.loads(captured.out)
    mesh = read_points(out)
    assert summary["n_vertices"] == len(mesh.points) and summary["n_faces"] == len(mesh.faces)
    assert 400 <= len(mesh.points) <= 600
    assert summary["n_boundary_loops"] == summary["n_loops_detected"] == 2
    assert summary["edge_manifold"] and summary["oriented"]
    np.testing.assert_allclose(mesh.points[:, 2], 0.1 * mesh.points[:, 0], atol=1e-12)

    code = cli.main(["reconstruct", str(src), "--map", str(map_path), "--target-vertices",
                     "500", "--out", str(out), "--size", "adaptive"])
    stdout = capsys.readouterr().out
    assert code == 0
    assert "boundary loops: 2 (2 detected), edge-manifold: True, oriented: True" in stdout


_fails = assert_cli_fails


def test_cli_bad_input_is_one_line_and_writes_nothing(tmp_path, capsys, sheet, monkeypatch):
    src, map_path, P, result = sheet
    other = replace(result, uv=result.uv[:-5], lambda_inv=result.lambda_inv[:-5]).save(
        tmp_path / "other.npz")
    moved = replace(result, fingerprint=fingerprint(P + [0.0, 0.0, 1e-3])).save(
        tmp_path / "moved.npz")
    disk = replace(result, domain=get_domain("disk")).save(tmp_path / "disk.npz")
    monkeypatch.setattr(reconstruct_command, "parametrize", None)  # no training from here on
    out = tmp_path / "mesh.ply"
    before = {p.name for p in tmp_path.iterdir()}

    _fails(capsys, ["reconstruct", str(tmp_path / "missing.xyz"), "--out", str(out)],
           "missing.xyz: no such file")
    _fails(capsys, ["reconstruct", str(src), "--out", str(tmp_path / "mesh.stl")],
           "mesh.stl: mesh output must have extension .ply or .obj, got '.stl'")
    _fails(capsys, ["reconstruct", str(src), "--out", str(tmp_path / "mesh")],
           "mesh: mesh output must have extension .ply or .obj, got none")
    _fails(capsys, ["reconstruct", str(src), "--out", str(out), "--target-vertices", "2"],
           "argument --target-vertices: expected an integer >= 3, got 2")
    _fails(capsys, ["reconstruct", str(src), "--out", str(out), "--size", "fine"],
           "argument --size: invalid choice: 'fine'")
    _fails(capsys, ["reconstruct", str(src), "--map", str(other), "--out", str(out)],
           f"map has {len(P) - 5} rows but {src} has {len(P)} points")
    _fails(capsys, ["reconstruct", str(src), "--map", str(moved), "--out", str(out)],
           "moved.npz: was made from another cloud than")
    _fails(capsys, ["reconstruct", str(src), "--map", str(disk), "--out", str(out)],
           "was trained onto the domain 'disk'; surface reconstruction needs a free-boundary "
           "map (pcgeom param without --domain) or --domain with the map's domain")
    _fails(capsys, ["reconstruct", str(src), "--map", str(disk), "--domain", "square",
                    "--out", str(out)],
           "disk.npz: was trained onto the domain 'disk', not 'square' (--domain)")
    _fails(capsys, ["reconstruct", str(src), "--map", str(disk), "--domain", "disk:2",
                    "--out", str(out)], "not 'disk:2.0' (--domain)")
    _fails(capsys, ["reconstruct", str(src), "--map", str(map_path), "--domain", "disk",
                    "--out", str(out)],
           "map.npz: is a free-boundary map, not a map onto 'disk' (--domain); drop --domain")
    _fails(capsys, ["reconstruct", str(src), "--domain", "blob", "--out", str(out)], "blob")
    _fails(capsys, ["reconstruct", str(src), "--map", str(map_path), "--out",
                    str(tmp_path / "nowhere" / "mesh.ply")], "does not exist")
    _fails(capsys, ["reconstruct", str(src)], "the following arguments are required: --out")
    assert {p.name for p in tmp_path.iterdir()} == before  # nothing written


def test_cli_refuses_a_map_with_no_loop_to_mesh(tmp_path, capsys, monkeypatch):
    """Ten points whose map is a hexagon around four points: its only loop has 6 points, under
    the minimum loop size, so there is nothing to mesh."""
    angles = np.linspace(0.0, 2 * np.pi, 7)[:-1]
    U = np.vstack([np.column_stack([np.cos(angles), np.sin(angles)]),
                   0.4 * np.column_stack([np.cos(angles[:4] + 0.3), np.sin(angles[:4] + 0.3)])])
    src = tmp_path / "ten.xyz"
    np.savetxt(src, np.column_stack([U, 0.1 * U[:, 0] ** 2]))
    P = read_points(src).points
    result = parametrize(P, "free", config=_tiny("fast"), progress=False)
    map_path = replace(result, uv=U).save(tmp_path / "ten.npz")
    monkeypatch.setattr(reconstruct_command, "parametrize", None)  # no training from here on
    out = tmp_path / "mesh.obj"
    _fails(capsys, ["reconstruct", str(src), "--map", str(map_path), "--out", str(out)],
           f"{src}: its map has no boundary loop of 8 points or more (1 smaller ones dropped); "
           "the reconstruction would be empty")
    assert not out.exists()


def test_missing_gmsh_names_the_install_command(tmp_path, capsys, monkeypatch, sheet):
    from pcgeom.apps.reconstruct import require_gmsh

    monkeypatch.setitem(sys.modules, "gmsh", None)  # makes `import gmsh` raise ImportError
    with pytest.raises(ImportError, match=r"^surface reconstruction needs gmsh: "
                                          r"pip install 'gmsh>=4\.11'$"):
        require_gmsh()
    src, map_path, _, _ = sheet
    monkeypatch.setattr(reconstruct_command, "parametrize", None)
    out = tmp_path / "mesh.ply"
    assert cli.main(["reconstruct", str(src), "--out", str(out)]) == 1  # before any training
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err == ("pcgeom: error: ImportError: surface reconstruction needs gmsh: "
                            "pip install 'gmsh>=4.11'\n")
    assert not out.exists()


def test_a_gmsh_that_cannot_load_names_the_system_libraries(monkeypatch):
    import builtins

    from pcgeom.apps.reconstruct import require_gmsh

    real_import = builtins.__import__

    def failing(name, *args, **kwargs):
        if name == "gmsh":
            raise OSError("libGLU.so.1: cannot open shared object file: No such file")
        return real_import(name, *args, **kwargs)

    monkeypatch.delitem(sys.modules, "gmsh", raising=False)
    monkeypatch.setattr(builtins, "__import__", failing)
    with pytest.raises(ImportError, match=r"gmsh is installed but cannot load \(libGLU\.so\.1: "
                                          r".*\); on Debian or Ubuntu: apt-get install libgl1 "):
        require_gmsh()


def test_cli_writes_obj_by_extension(tmp_path, capsys, sheet):
    src, map_path, P, _ = sheet
    meshes = {}
    for ext in ("ply", "obj"):
        out = tmp_path / f"mesh.{ext}"
        code = cli.main(["reconstruct", str(src), "--map", str(map_path), "--target-vertices",
                         "300", "--out", str(out), "--json"])
        captured = capsys.readouterr()
        assert code == 0, captured.err
        assert json.loads(captured.out)["out"] == str(out)
        meshes[ext] = read_points(out)
    assert out.read_text().startswith("# pcgeom ")
    np.testing.assert_array_equal(meshes["obj"].faces, meshes["ply"].faces)
    np.testing.assert_allclose(meshes["obj"].points, meshes["ply"].points, rtol=0, atol=1e-14)
    assert {p.name for p in tmp_path.iterdir() if p.name.startswith(".")} == set()


def _read_back(path: Path):
    """Vertices, faces and per-vertex texture coordinates of a written mesh, as trimesh reads
    it (process=False: no merging, rows kept) and as pymeshlab (MeshLab's reader) reads it."""
    import trimesh

    loaded = trimesh.load(path, process=False)
    ours = (np.asarray(loaded.vertices), np.asarray(loaded.faces), np.asarray(loaded.visual.uv))
    pymeshlab = pytest.importorskip("pymeshlab")
    ms = pymeshlab.MeshSet()
    ms.load_new_mesh(str(path))
    m = ms.current_mesh()
    uv = m.vertex_tex_coord_matrix() if m.has_vertex_tex_coord() else None
    if path.suffix == ".obj":  # MeshLab reads an OBJ's vt per corner ("wedge")
        corners = m.wedge_tex_coord_matrix().reshape(-1, 3, 2)  # (M, 3, 2)
        uv = np.zeros((m.vertex_number(), 2))
        uv[m.face_matrix()] = corners
    return ours, (m.vertex_matrix(), m.face_matrix(), uv)


def test_cli_mesh_carries_its_map_as_texture_coordinates(tmp_path, capsys, sheet):
    """The sheet's map is its own xy and it is flat in the map (z = 0.1 x), so a vertex made
    at map position q is (q, 0.1 q_x): its texture coordinates must be
    (xy - uv_offset) / uv_scale, as --json records them. Read back with trimesh and with
    pymeshlab, from OBJ (vt) and PLY (texture_u texture_v); with --texture the material and
    the checkerboard come along."""
    src, map_path, P, _ = sheet
    summaries, meshes = {}, {}
    for name, extra in [("mesh.obj", []), ("mesh.ply", []), ("tex.obj", ["--texture",
                                                                         "checker:5"])]:
        out = tmp_path / name
        code = cli.main(["reconstruct", str(src), "--map", str(map_path), "--target-vertices",
                         "400", "--out", str(out), "--json", *extra])
        captured = capsys.readouterr()
        assert code == 0, captured.err
        summaries[name] = summary = json.loads(captured.out)
        (V, F, uv), (Vm, Fm, uvm) = _read_back(out)
        assert len(V) == len(Vm) == summary["n_vertices"]
        assert len(F) == len(Fm) == summary["n_faces"]
        offset, scale = np.array(summary["uv_offset"]), summary["uv_scale"]
        np.testing.assert_allclose(uv, (V[:, :2] - offset) / scale, rtol=0, atol=1e-12)
        # the unit square along the map's longer side (the sheet is wider than high)
        np.testing.assert_allclose(uv.min(axis=0), [0.0, 0.0], atol=1e-12)
        assert uv[:, 0].max() == pytest.approx(1.0, abs=1e-12) and uv[:, 1].max() < 1.0
        np.testing.assert_allclose(Vm, V, rtol=0, atol=1e-12)
        np.testing.assert_array_equal(Fm, F)
        np.testing.assert_allclose(uvm, uv, rtol=0, atol=1e-6)  # MeshLab's uv are float32
        meshes[name] = (V, F, uv)
    for k in range(3):  # one mesh whatever the format
        np.testing.assert_allclose(meshes["mesh.obj"][k], meshes["mesh.ply"][k], rtol=0,
                                   atol=1e-14)
    assert summaries["mesh.obj"]["texture"] is None and not (tmp_path / "mesh.mtl").exists()
    assert "mtllib" not in (tmp_path / "mesh.obj").read_text()
    assert summaries["tex.obj"]["texture"] == "checker:5"
    assert summaries["tex.obj"]["texture_files"] == {"material": str(tmp_path / "tex.mtl"),
                                                    "image": str(tmp_path / "tex_checker.png")}
    assert "map_Kd tex_checker.png" in (tmp_path / "tex.mtl").read_text()
    from PIL import Image

    with Image.open(tmp_path / "tex_checker.png") as image:
        assert image.size[0] == image.size[1] and image.size[0] % 5 == 0
    assert {p.name for p in tmp_path.iterdir() if p.name.startswith(".")} == set()


def test_reconstructions_return_the_map_positions_they_lifted():
    """``return_uv``: the mesh's vertices in the map (free boundary) or in the domain; lifting
    them again gives the mesh's vertices."""
    U = _grid(16, (5, 8))
    P = np.column_stack([U, 0.1 * U[:, 0]])
    V, F, Q, report = reconstruct_surface(P, U, detect_boundary(U), target_vertices=300,
                                          return_uv=True)
    assert Q.shape == (len(V), 2) and report["n_vertices"] == len(V)
    np.testing.assert_allclose(V[:, :2], Q, rtol=0, atol=1e-12)
    t = np.linspace(0.0, 2 * np.pi, 64, endpoint=False)
    D = np.vstack([get_domain("disk").sample(300, seed=0), np.column_stack([np.cos(t),
                                                                           np.sin(t)])])
    P = np.column_stack([D, 0.1 * D[:, 0]])  # a tilted disk whose map is its own xy
    V, F, Q, _ = reconstruct_on_domain(P, D, get_domain("disk"), target_vertices=300,
                                       return_uv=True)
    assert (np.hypot(Q[:, 0], Q[:, 1]) <= 1.0 + 1e-9).all()
    np.testing.assert_allclose(V, lift(P, D, map_delaunay(D), Q)[0], rtol=0, atol=1e-12)
    inside = np.hypot(Q[:, 0], Q[:, 1]) < 0.99  # within the map's hull: lifted exactly
    np.testing.assert_allclose(V[inside, :2], Q[inside], rtol=0, atol=1e-12)


def test_cli_texture_errors_are_one_line_before_any_work_and_write_nothing(
        tmp_path, capsys, sheet, monkeypatch):
    src, map_path, _, _ = sheet
    monkeypatch.setattr(reconstruct_command, "parametrize", None)  # no training from here on
    monkeypatch.setattr(reconstruct_command, "reconstruct_surface", None)  # nor meshing
    (tmp_path / "taken_checker.png").mkdir()
    (tmp_path / "busy.mtl").mkdir()
    before = sorted(p.name for p in tmp_path.iterdir())
    start = ["reconstruct", str(src), "--map", str(map_path), "--out"]
    _fails(capsys, start + [str(tmp_path / "mesh.stl"), "--texture", "checker"],
           "mesh.stl: mesh output must have extension .ply or .obj, got '.stl'")
    _fails(capsys, start + [str(tmp_path / "mesh.ply"), "--texture", "checker"],
           "mesh.ply: a texture needs an .obj mesh (its .mtl material names the image); a .ply "
           "holds the texture coordinates (texture_u texture_v) but no material: drop "
           "--texture, or write .obj")
    _fails(capsys, start + [str(tmp_path / "taken.obj"), "--texture", "checker:4"],
           "taken_checker.png: is a directory, expected a file")
    _fails(capsys, start + [str(tmp_path / "busy.obj"), "--texture", "checker"],
           "busy.mtl: is a directory, expected a file")
    _fails(capsys, start + [str(tmp_path / "my mesh.obj"), "--texture", "checker"],
           "my mesh.obj: a textured OBJ's file name cannot hold white space (the mtllib line "
           "names the material file)")
    for spec in ("checker:0", "checker:abc", "checker:1000", "stripes"):
        _fails(capsys, start + [str(tmp_path / "mesh.obj"), "--texture", spec],
               "argument --texture: expected checker or checker:N (N squares along the longer "
               f"side of the map, 1 to 256), got {spec!r}")
    assert sorted(p.name for p in tmp_path.iterdir()) == before


def test_a_textured_mesh_whose_writing_fails_leaves_none_of_its_files(tmp_path, monkeypatch):
    """The image, the material and the OBJ are written together: an error in the last one
    leaves none of them, and earlier versions of all three untouched."""
    from pcgeom.apps.reconstruct import write_mesh
    from pcgeom.apps.texture import parse_texture

    V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])
    uv = V[:, :2]
    texture = parse_texture("checker:2")
    write_mesh(tmp_path / "m.obj", V, [[0, 1, 2]], uv=uv, texture=texture)
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    assert set(before) == {"m.obj", "m.mtl", "m_checker.png"}

    real_write = write_mesh.__globals__["write_files_atomic"]

    def failing(writers):
        def boom(f):
            f.write(b"half")
            raise OSError("disk full")
        path = next(p for p in writers if Path(p).suffix == ".obj")
        real_write({**writers, path: boom})

    monkeypatch.setitem(write_mesh.__globals__, "write_files_atomic", failing)
    with pytest.raises(OSError, match="disk full"):
        write_mesh(tmp_path / "m.obj", V * 2, [[0, 1, 2]], uv=uv,
                   texture=parse_texture("checker:3"))
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == before
    with pytest.raises(ValueError, match="texture: needs uv"):
        write_mesh(tmp_path / "n.obj", V, [[0, 1, 2]], texture=texture)
    with pytest.raises(ValueError, match=r"uv: expected shape \(3, 2\), got \(2, 2\)"):
        write_mesh(tmp_path / "n.obj", V, [[0, 1, 2]], uv=uv[:2])
    with pytest.raises(ValueError, match="uv: contains NaN or inf"):
        write_mesh(tmp_path / "n.ply", V, [[0, 1, 2]], uv=uv * np.nan)
    assert not (tmp_path / "n.obj").exists() and not (tmp_path / "n.ply").exists()


def test_write_mesh_checks_its_input(tmp_path):
    from pcgeom.apps.reconstruct import write_mesh

    V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])
    with pytest.raises(InputError, match=r"m\.off: mesh output must have extension "
                                         r"\.ply or \.obj, got '\.off'"):
        write_mesh(tmp_path / "m.off", V, [[0, 1, 2]])
    with pytest.raises(InputError, match="F: expected at least one face, got none"):
        write_mesh(tmp_path / "m.obj", V, np.zeros((0, 3), dtype=np.int64))
    with pytest.raises(ValueError, match=r"V: expected shape \(K, 3\), got \(3, 2\)"):
        write_mesh(tmp_path / "m.obj", V[:, :2], [[0, 1, 2]])
    assert not list(tmp_path.iterdir())
    assert write_mesh(tmp_path / "M.OBJ", V, [[0, 1, 2]]) == tmp_path / "M.OBJ"


def test_help_has_examples(capsys):
    assert cli.main(["reconstruct", "--help"]) == 0
    text = capsys.readouterr().out
    assert "--target-vertices" in text and "examples:" in text


def test_cli_without_a_map_trains_first(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(reconstruct_command, "get_preset", _tiny)
    U = _grid(14)
    src = tmp_path / "sheet.xyz"
    np.savetxt(src, np.column_stack([U, 0.1 * U[:, 0]]))
    out = tmp_path / "mesh.ply"
    code = reconstruct_command.main([str(src), "--target-vertices", "300", "--out", str(out),
                                     "--quiet", "--json"])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    summary = json.loads(captured.out)
    assert summary["map"] is None and summary["mapped_seconds"] > 0
    assert summary["edge_manifold"] and summary["n_boundary_loops"] >= 1
    assert len(read_points(out).points) == summary["n_vertices"]
    assert captured.err == ""  # --quiet: no progress bars


# --------------------------------------------------------------------------- onto a domain


def _bump(x, y):
    """The analytic height field of the domain tests."""
    return 0.4 * np.exp(-((x - 0.2) ** 2 + y**2) / 0.2) + 0.1 * x * y


def test_height_field_on_the_disk_is_rebuilt_on_the_disk_within_its_interpolation_error():
    disk = get_domain("disk")
    U = disk.sample(1500)  # the map, analytically: the height field over the unit disk
    P = np.column_stack([U, _bump(U[:, 0], U[:, 1])])
    V, F, report = reconstruct_on_domain(P, U, disk, target_vertices=600)
    _assert_clean(report, 1)
    assert report["n_domain_loops"] == 1 and report["domain"] == "disk"
    assert 480 <= report["n_vertices"] <= 720
    # Every vertex on the true surface up to the piecewise-linear interpolation error of the
    # cloud's spacing (0.044): the vertical gap bounds the distance (measured 0.0018).
    assert np.abs(V[:, 2] - _bump(V[:, 0], V[:, 1])).max() < 0.005
    # The mesh's boundary is the disk's circle, lifted onto the rim of the cloud: the vertices
    # outside the mapped points' hull take the nearest hull point (measured radius >= 0.985).
    rim = igl.boundary_loop_all(F)[0]
    radius = np.linalg.norm(V[rim, :2], axis=1)
    assert radius.max() <= 1.0 and radius.min() > 1.0 - 0.044
    assert report["n_outside"] == len(rim)  # the circle lies outside the sample's hull


def test_every_loop_of_a_domain_is_a_loop_of_the_mesh():
    annulus = get_domain("annulus")
    U = annulus.sample(1200)
    P = np.column_stack([U, _bump(U[:, 0], U[:, 1])])
    V, F, report = reconstruct_on_domain(P, U, annulus, size="adaptive", target_vertices=400,
                                         lambda_inv=1.0 + U[:, 0] ** 2)
    _assert_clean(report, 2)
    # The inner circle lies inside the hull of the mapped points: its vertices interpolate
    # over Delaunay triangles spanning the hole (measured 0.0084).
    assert np.abs(V[:, 2] - _bump(V[:, 0], V[:, 1])).max() < 0.02


def test_domain_reconstruction_refuses_a_free_domain_and_bad_input():
    U = get_domain("disk").sample(200)
    P = np.column_stack([U, np.zeros(len(U))])
    with pytest.raises(InputError, match="domain: expected a bounded domain, got 'free'"):
        reconstruct_on_domain(P, U, get_domain("free"))
    with pytest.raises(TypeError, match="domain: expected a Domain"):
        reconstruct_on_domain(P, U, "disk")
    with pytest.raises(InputError, match=r"U: expected 200 rows \(one per point\), got 199"):
        reconstruct_on_domain(P, U[:-1], get_domain("disk"))
    with pytest.raises(InputError, match="lambda_inv: needed by size='adaptive'"):
        reconstruct_on_domain(P, U, get_domain("disk"), size="adaptive")


def test_cli_meshes_the_domain_of_a_disk_map(tmp_path, capsys, sheet):
    src, _, P, result = sheet
    # A map onto the disk, analytically: the sheet's xy scaled into the unit disk.
    uv = P[:, :2] - P[:, :2].mean(axis=0)
    uv /= 1.05 * np.linalg.norm(uv, axis=1).max()
    disk_map = replace(result, uv=uv, domain=get_domain("disk")).save(tmp_path / "disk.npz")
    out = tmp_path / "disk_mesh.ply"
    code = cli.main(["reconstruct", str(src), "--map", str(disk_map), "--domain", "disk",
                     "--target-vertices", "300", "--out", str(out), "--json"])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    summary = json.loads(captured.out)
    assert summary["domain"] == "disk" and summary["n_boundary_loops"] == 1
    assert summary["edge_manifold"] and summary["oriented"]
    mesh = read_points(out)
    assert len(mesh.points) == summary["n_vertices"]
    # The sheet is the plane z = 0.1 x: every lifted vertex stays on it.
    np.testing.assert_allclose(mesh.points[:, 2], 0.1 * mesh.points[:, 0], atol=1e-12)
    # Issue 39: the sheet's hole is filled (the disk has none), and the command says so.
    assert [line for line in captured.err.splitlines() if "hole" in line] == [
        f"pcgeom: warning: {src}: the cloud has 1 hole(s) and the domain disk 0: the mesh "
        "covers the whole domain and fills 1 of them; to keep them, reconstruct without "
        "--domain (the free boundary)"]


def test_cli_maps_with_the_files_normals_as_param_does(tmp_path, capsys):
    """Issue 39 (as for boundary): without --map, reconstruct mapped the bare points."""
    U = _grid(12)
    P = np.column_stack([U, 0.1 * U[:, 0]])
    N = np.tile(np.array([-0.1, 0.0, 1.0]) / np.hypot(0.1, 1.0), (len(P), 1))
    src = tmp_path / "oriented.xyz"
    np.savetxt(src, np.column_stack([P, N]))
    normals = {}
    for label, extra in (("auto", []), ("ignore", ["--normals", "ignore"])):
        assert cli.main(["reconstruct", str(src), "--out", str(tmp_path / f"{label}.ply"),
                         "--target-vertices", "100", "--quiet", "--json", *extra]) == 0
        normals[label] = json.loads(capsys.readouterr().out)["normals"]
    assert normals == {"auto": "input", "ignore": "estimated"}


def test_unkept_holes_counts_the_clouds_holes_against_the_domains():
    from pcgeom.apps.boundary import unkept_holes

    for hole, expected in (((5, 8), 1), (None, 0)):
        U = _grid(16, hole)
        uv = U - U.mean(axis=0)
        uv /= 1.05 * np.linalg.norm(uv, axis=1).max()
        P = np.column_stack([U, 0.1 * U[:, 0]])
        assert unkept_holes(uv, get_domain("disk"), points=P) == (expected, 0)
        assert unkept_holes(uv, get_domain("annulus"), points=P) == (expected, 1)


def test_strays_are_never_lifted_into_the_mesh(tmp_path, capsys):
    """Issue 39 item 4: a stray's map point lies among the surface's, and a triangle with it
    for a corner lifted a spike (face_3holes_small_choi with depth noise and 1% strays: the
    farthest vertex 16.9% of the diagonal off the surface). The mesh is lifted over the
    inliers only: the map's local mesh, or without it the outlier test's inliers."""
    from pcgeom.synthetic import holey_heightfield

    scan = holey_heightfield(1200, holes=2, outliers=0.02, noise=0.0, seed=1)
    src = tmp_path / "strays.xyz"
    np.savetxt(src, scan.points)
    P = read_points(src).points
    result = parametrize(P, "free", config=_tiny("fast"), progress=False)
    surface = P[~scan.is_outlier]
    for label, faces in (("local mesh", result.mesh_faces), ("outlier test", None)):
        # The true parameters as the map: the strays' map points (their own x, y) lie among
        # the surface's, as a map puts them.
        path = replace(result, uv=scan.uv_true, mesh_faces=faces).save(tmp_path / "m.npz")
        out = tmp_path / "mesh.ply"
        code = cli.main(["reconstruct", str(src), "--map", str(path), "--target-vertices",
                         "800", "--out", str(out), "--json"])
        captured = capsys.readouterr()
        assert code == 0, captured.err
        summary = json.loads(captured.out)
        assert summary["n_strays"] == scan.is_outlier.sum(), label
        V = read_points(out).points
        # Every vertex within a spacing of the surface points (measured 0.76 spacing; before,
        # the strays' triangles lifted vertices 8.8 spacings off).
        gap = cKDTree(surface).query(V)[0].max() / scan.spacing
        assert gap < 1.0, (label, gap)
        assert summary["max_offset_spacings"] < 2.0, label


def test_a_denoised_rim_is_smoothed_along_its_loop_before_lifting():
    """Issue 39 item 4: a rim point's fit is one-sided, so a point of the noise's tail (or a
    stray within it) on the rim stayed off the surface, and the mesh's boundary vertex on it
    was the farthest (face_3holes_small_choi, depth noise and 1% strays: 1.08% of the
    diagonal). With ``smooth_rim`` each loop point is ``(p_prev + 2 p + p_next) / 4``."""
    from pcgeom.apps.reconstruct import reconstruct_surface
    from pcgeom.apps.reconstruct.lifting import smooth_rim

    i, j = (a.ravel() for a in np.meshgrid(np.arange(12), np.arange(12), indexing="xy"))
    U = np.column_stack([i + 0.2 * j, j]).astype(np.float64)
    P = np.column_stack([U, np.zeros(len(U))])
    loops = detect_boundary(U, points=P)
    up = int(loops.loops[0][5])  # a rim point 1 spacing off the plane
    P[up, 2] = 1.0
    assert smooth_rim(P, loops.loops)[up, 2] == 0.5
    assert smooth_rim(P, loops.loops)[:, 2].sum() == 1.0  # shared with its two neighbours
    heights = {}
    for smooth in (False, True):
        V, _, report = reconstruct_surface(P, U, loops, target_vertices=300, smooth_rim=smooth)
        heights[smooth] = np.abs(V[:, 2]).max()
        assert report["smooth_rim"] is smooth
    assert heights[False] == pytest.approx(1.0) and heights[True] == pytest.approx(0.5)
