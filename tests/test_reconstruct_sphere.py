"""Closed meshes from a sphere map (pcgeom.apps.reconstruct.sphere): an ellipsoid lifted
through its radial projection (a one-to-one sphere map of a star-shaped surface; not conformal,
which the lifting does not need) against the analytic surface, the location and lifting rule
against a naive search, the adaptive size, and the one-line errors."""

from __future__ import annotations

import json

import numpy as np
import pytest

from pcgeom import InputError, ParamResult, cli, get_domain, get_preset
from pcgeom.apps.reconstruct import (closed_checks, lift_sphere, reconstruct_on_sphere,
                                     sphere_compression, sphere_triangulation)
from pcgeom.apps.reconstruct.sphere import vertex_normals
from pcgeom.cloud import fingerprint
from pcgeom.io import read_points, write_ply_atomic

from tests.helpers import assert_cli_fails
from pcgeom.apps.reconstruct import sphere as sphere_module

gmsh = pytest.importorskip("gmsh")
trimesh = pytest.importorskip("trimesh")

AXES = np.array([2.0, 1.0, 0.7])


def _fibonacci(n: int, jitter: float = 0.0, seed: int = 0) -> np.ndarray:
    """Near-uniform unit vectors on a Fibonacci spiral, optionally jittered. (n, 3)"""
    i = np.arange(n) + 0.5
    z = 1.0 - 2.0 * i / n
    r = np.sqrt(1.0 - z * z)
    t = np.pi * (1.0 + 5.0**0.5) * i
    S = np.column_stack([r * np.cos(t), r * np.sin(t), z])
    S += jitter * np.random.default_rng(seed).normal(size=S.shape)
    return S / np.linalg.norm(S, axis=1, keepdims=True)


def _ellipsoid(n: int = 2000) -> tuple[np.ndarray, np.ndarray]:
    """Points on the ellipsoid of :data:`AXES` and their radial projection. (n, 3) each"""
    X = _fibonacci(n, jitter=0.01) * AXES
    return X, X / np.linalg.norm(X, axis=1, keepdims=True)


def _distance(V: np.ndarray) -> np.ndarray:
    """Distance to the ellipsoid to first order, ``|g| / |grad g|`` with ``g = |V / AXES| - 1``
    (exact to O(d^2 * curvature))."""
    s = np.linalg.norm(V / AXES, axis=1)
    grad = np.linalg.norm(V / AXES**2, axis=1) / s
    return np.abs(s - 1.0) / grad


def test_radially_projected_ellipsoid_lifts_to_a_closed_mesh_on_the_surface():
    X, U = _ellipsoid(2000)
    V, F, Q, report = reconstruct_on_sphere(X, U, target_vertices=2000, return_uv=True)
    assert report["watertight"] and report["winding_consistent"]
    assert report["euler_characteristic"] == 2 and report["genus"] == 0
    assert report["edge_manifold"] and report["oriented"] and report["n_boundary_loops"] == 0
    assert 1800 <= report["n_vertices"] <= 2200 and report["triangulation"] == "convex_hull"
    assert not report["orientation_reversed"]
    np.testing.assert_allclose(np.linalg.norm(Q, axis=1), 1.0, atol=1e-12)
    diag = np.linalg.norm(X.max(axis=0) - X.min(axis=0))
    # Vertices on the cloud's Phong triangles, triangle centres on the mesh's own chords:
    # measured 0.00018 and 0.0031 of the diagonal (flat lifting: 0.0010 and 0.0035).
    assert _distance(V).max() / diag < 0.0005
    centres = V[F].mean(axis=1)
    assert _distance(centres).max() / diag < 0.005
    # Outward and never turned over: each normal against the ellipsoid's at its centre.
    normals = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    assert (np.einsum("ij,ij->i", normals, centres / AXES**2) > 0).all()
    # Chords cut inside a convex surface: measured 0.9941 of the volume (flat: 0.9907).
    assert trimesh.Trimesh(V, F, process=False).volume == pytest.approx(
        4 / 3 * np.pi * AXES.prod(), rel=0.01)


def test_default_target_is_three_vertices_per_point():
    """Without a target the mesh gets three vertices per point (about screened Poisson's at
    its default depth), at most MAX_DEFAULT_VERTICES."""
    X, U = _ellipsoid(300)
    V, F, report = reconstruct_on_sphere(X, U)
    assert report["target_vertices"] == 900 and 810 <= len(V) <= 990
    assert sphere_module.default_vertices(10**6) == sphere_module.MAX_DEFAULT_VERTICES


def test_lift_locates_like_a_naive_search_and_interpolates_barycentrically():
    """Every query against every triangle: the one whose three cone coordinates are all >= 0;
    the lift is then sum(w X) with w the normalised cone coordinates."""
    U = _fibonacci(200, jitter=0.05, seed=1)
    X = U * np.array([1.5, 1.0, 0.8]) + 0.1 * U**2  # any cloud: the lift is linear in X
    T, _ = sphere_triangulation(U)
    Q = _fibonacci(120, jitter=0.3, seed=2)
    V, searched = lift_sphere(X, U, T, Q, interpolation="linear")
    assert searched == 0
    want = np.empty_like(V)
    for k, q in enumerate(Q):
        for t in T:
            a, b, c = U[t]
            w = np.array([np.linalg.det([q, b, c]), np.linalg.det([a, q, c]),
                          np.linalg.det([a, b, q])])
            if (w >= -1e-15).all():
                want[k] = (w / w.sum()) @ X[t]
                break
    np.testing.assert_allclose(V, want, atol=1e-12)
    # A map point lifts to its own cloud point, flat or curved.
    for interpolation in ("linear", "phong"):
        np.testing.assert_allclose(lift_sphere(X, U, T, U[:20], interpolation=interpolation)[0],
                                   X[:20], atol=1e-12)


def test_phong_lift_is_exact_to_second_order_on_a_sphere():
    """The flat triangles of a sphere's cloud sag by h^2 / (8 R) between points; Phong
    tessellation with alpha 1/2 leaves O(h^3): measured, radius 2, 500 points (h about 0.3),
    largest error 0.0190 flat, 0.00027 curved with the exact normals and 0.0026 with the
    triangulation's angle-weighted ones (themselves off by up to 0.025)."""
    U = _fibonacci(500, jitter=0.02, seed=3)
    X = 2.0 * U
    T, _ = sphere_triangulation(U)
    Q = _fibonacci(4000, jitter=0.3, seed=4)
    error = {}
    for name, kwargs in (("flat", {"interpolation": "linear"}), ("exact", {"normals": U}),
                         ("estimated", {})):
        V, _ = lift_sphere(X, U, T, Q, **kwargs)
        error[name] = np.abs(np.linalg.norm(V, axis=1) - 2.0).max()
    assert error["flat"] > 0.015
    assert error["exact"] < 0.0005 and error["estimated"] < 0.004
    np.testing.assert_allclose(vertex_normals(X, T), U, atol=0.04)


def test_map_faces_in_either_winding_and_a_reversed_map_give_an_outward_mesh():
    X, U = _ellipsoid(800)
    hull, _ = sphere_triangulation(U)
    V, F, report = reconstruct_on_sphere(X, U, faces=hull[:, [0, 2, 1]], target_vertices=600)
    assert report["triangulation"] == "mesh_faces" and not report["orientation_reversed"]
    mirrored = U * np.array([-1.0, 1.0, 1.0])  # a sphere map that turns the surface inside out
    V2, F2, report2 = reconstruct_on_sphere(X, mirrored, target_vertices=600)
    assert report2["orientation_reversed"] and report2["watertight"]
    assert trimesh.Trimesh(V2, F2, process=False).volume > 0


def test_adaptive_size_puts_more_vertices_where_the_map_compresses_the_surface():
    """The radial projection of the ellipsoid compresses its long ends most (about 2 surface
    lengths per sphere length there, 0.7 to 1 around the waist): the adaptive mesh has more
    of its vertices there. Measured: 4.4% beyond |x| > 1.6 uniform, 8.2% adaptive."""
    X, U = _ellipsoid(2000)
    rho = sphere_compression(X, U, sphere_triangulation(U)[0])
    tips = np.abs(X[:, 0]) > 1.9
    assert rho[tips].mean() > 1.8 and rho[np.abs(X[:, 0]) < 0.1].mean() < 1.0
    share = {}
    for size in ("uniform", "adaptive"):
        V, F, report = reconstruct_on_sphere(X, U, size=size, target_vertices=1500)
        assert report["watertight"] and report["euler_characteristic"] == 2
        assert 1350 <= report["n_vertices"] <= 1650
        share[size] = float(np.mean(np.abs(V[:, 0]) > 1.6))
    assert share["adaptive"] > 1.5 * share["uniform"]


def test_bad_sphere_maps_are_rejected():
    X, U = _ellipsoid(300)
    with pytest.raises(InputError, match=r"a sphere map has shape \(N, 3\), got \(300, 2\)"):
        reconstruct_on_sphere(X, U[:, :2])
    with pytest.raises(InputError, match="rows are unit vectors; one has length off by 0.5"):
        reconstruct_on_sphere(X, np.vstack([1.5 * U[:1], U[1:]]))
    with pytest.raises(InputError, match="size: expected one of uniform, adaptive"):
        reconstruct_on_sphere(X, U, size="fine")
    # All on one hemisphere: the hull's cap faces the centre.
    half = U * np.array([1.0, 1.0, 0.0]) + np.array([0.0, 0.0, 1.0])
    half /= np.linalg.norm(half, axis=1, keepdims=True)
    with pytest.raises(InputError, match=r"triangulation \(convex_hull\) overlaps: \d+ of"):
        reconstruct_on_sphere(X, half)
    # The map's own mesh with two points swapped on the sphere: a fold.
    T, _ = sphere_triangulation(U)
    folded = U.copy()
    a, b = T[0, 0], T[0, 1]
    folded[[a, b]] = folded[[b, a]]
    with pytest.raises(InputError, match=r"triangulation \(mesh_faces\) overlaps: [1-9]\d* of"):
        reconstruct_on_sphere(X, folded, faces=T)


def test_a_lifted_mesh_that_is_not_closed_is_an_error(monkeypatch):
    """The final check is real: a sphere mesh with a triangle missing is refused."""
    original = sphere_module._gmsh_sphere

    def holed(size, relative=None):
        Q, T = original(size, relative)
        return Q, T[1:]

    monkeypatch.setattr(sphere_module, "_gmsh_sphere", holed)
    X, U = _ellipsoid(300)
    with pytest.raises(InputError, match=r"not closed and genus 0 \(watertight False"):
        reconstruct_on_sphere(X, U, target_vertices=200)
    assert closed_checks(*original(0.5))["euler_characteristic"] == 2


def test_map_faces_with_a_hole_fall_back_to_the_convex_hull():
    """A map's own mesh without some triangles (holes, points left out) but none turned
    over: the map is one-to-one there, and the hull triangulates the whole sphere."""
    X, U = _ellipsoid(500)
    hull, _ = sphere_triangulation(U)
    T, source = sphere_triangulation(U, hull[5:])
    assert source.startswith("convex_hull (mesh_faces cover 3.9")
    np.testing.assert_array_equal(np.sort(np.sort(T, axis=1), axis=0),
                                  np.sort(np.sort(hull, axis=1), axis=0))
    with pytest.raises(InputError, match=r"\(mesh_faces\) overlaps: 0 of 1001 .* 4\.0\d+ pi"):
        sphere_triangulation(U, np.vstack([hull, hull[:5]]))  # five triangles twice


# --------------------------------------------------------------------------- command line


@pytest.fixture
def ellipsoid_files(tmp_path):
    """The ellipsoid's cloud (PLY, bare) and map files onto the sphere (its radial
    projection, with and without the hull as the map's own mesh) and onto the free plane."""
    X, U = _ellipsoid(600)
    write_ply_atomic(src := tmp_path / "ellipsoid.ply", X, None)
    X = read_points(src).points
    U = X / np.linalg.norm(X, axis=1, keepdims=True)
    common = dict(lambda_inv=np.ones(len(X)), center=np.zeros(3), scale=1.0,
                  config=get_preset("fast"), seed=0, fingerprint=fingerprint(X))
    hull, _ = sphere_triangulation(U)
    maps = {
        "sphere": ParamResult(uv=U, domain=get_domain("sphere"), mesh_faces=hull, **common),
        "free": ParamResult(uv=X[:, :2], domain=get_domain("free"), **common),
        "disk": ParamResult(uv=0.3 * X[:, :2], domain=get_domain("disk"), **common),
    }
    folded = U.copy()
    a, b = hull[0, 0], hull[0, 1]
    folded[[a, b]] = folded[[b, a]]
    maps["folded"] = ParamResult(uv=folded, domain=get_domain("sphere"), mesh_faces=hull,
                                 **common)
    return X, src, {k: m.save(tmp_path / f"{k}_uv.npz") for k, m in maps.items()}


@pytest.mark.parametrize("domain", [[], ["--domain", "sphere"]])
def test_cli_meshes_the_sphere_of_a_sphere_map_into_a_closed_mesh(tmp_path, capsys,
                                                                    ellipsoid_files, domain):
    X, src, maps = ellipsoid_files
    out = tmp_path / "mesh.ply"
    code = cli.main(["reconstruct", str(src), "--map", str(maps["sphere"]), *domain,
                     "--size", "adaptive", "--target-vertices", "800", "--out", str(out),
                     "--json"])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    summary = json.loads(captured.out)
    assert summary["domain"] == "sphere" and summary["triangulation"] == "mesh_faces"
    assert summary["watertight"] and summary["winding_consistent"]
    assert summary["euler_characteristic"] == 2 and summary["interpolation"] == "phong"
    mesh = read_points(out)
    assert len(mesh.points) == summary["n_vertices"] and 700 <= len(mesh.points) <= 900
    diag = np.linalg.norm(np.ptp(X, axis=0))
    assert _distance(mesh.points).max() / diag < 0.002  # measured 0.0006
    import trimesh

    closed = trimesh.Trimesh(mesh.points, mesh.faces, process=False)
    assert closed.is_watertight and closed.volume > 0


def test_cli_prints_the_closed_checks(tmp_path, capsys, ellipsoid_files):
    _, src, maps = ellipsoid_files
    code = cli.main(["reconstruct", str(src), "--map", str(maps["sphere"]), "--interpolation",
                     "linear", "--target-vertices", "400", "--out", str(tmp_path / "m.obj")])
    out = capsys.readouterr().out
    assert code == 0
    assert ("closed: watertight True, winding-consistent True, Euler characteristic 2 "
            "(genus 0); lifted over the mesh_faces of the sphere map, linear") in out


@pytest.mark.parametrize("map_name, extra, message", [
    ("free", ["--domain", "sphere"], "is a free-boundary map, not a map onto 'sphere'"),
    ("disk", ["--domain", "sphere"], "was trained onto the domain 'disk', not 'sphere'"),
    ("sphere", ["--domain", "disk"], "was trained onto the domain 'sphere', not 'disk'"),
    ("folded", [], "triangulation (mesh_faces) overlaps: 2 of 1196 triangles turned over"),
    ("sphere", ["--texture", "checker:8"], "a mesh of the sphere has no planar texture"),
])
def test_cli_sphere_errors_are_one_line_and_write_nothing(tmp_path, capsys, ellipsoid_files,
                                                          map_name, extra, message):
    _, src, maps = ellipsoid_files
    out = tmp_path / "mesh.obj"
    assert_cli_fails(capsys, ["reconstruct", str(src), "--map", str(maps[map_name]), *extra,
                              "--out", str(out)], message)
    assert not out.exists()
