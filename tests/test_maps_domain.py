"""The local mesh laid on a domain (pcgeom.maps.domain)."""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
import pytest
import shapely

from pcgeom.cloud import normalize
from pcgeom.domains import Annulus, ShapelyDomain, Smile, Square
from pcgeom.errors import InputError
from pcgeom.maps.domain import harmonic_onto
from pcgeom.maps.free import lscm_free
from pcgeom.maps.localmesh import local_mesh


def _sheet(domain, n: int, turn: float, mirror: bool, bump: float = 0.0):
    """The domain's own quasi-uniform sample, mirrored, turned, scaled by 3 and lifted into a
    tilted plane of 3D (plus an optional bump): a cloud whose exact map onto the domain is
    known (the sample itself, up to the domain's symmetries)."""
    P = domain.sample(n, seed=1)
    Q = P * [1.0, -1.0] if mirror else P.copy()
    c, s = np.cos(turn), np.sin(turn)
    Q = 3.0 * Q @ np.array([[c, -s], [s, c]]).T
    X = np.column_stack([Q, bump * np.exp(-(Q ** 2).sum(axis=1))])
    tilt = np.array([[1.0, 0.0, 0.0], [0.0, 0.8, -0.6], [0.0, 0.6, 0.8]])
    return P, X @ tilt.T, np.tile(tilt[:, 2], (n, 1))


def _map(domain, X, normals, landmarks=()):
    Xn, _, _ = normalize(X)
    mesh = local_mesh(Xn, normals, 24)
    return harmonic_onto(Xn, mesh, lscm_free(Xn, mesh), domain, landmarks=landmarks)


@pytest.mark.parametrize("turn, mirror", [(0.0, False), (1.2, False), (2.5, True)])
def test_a_flat_smile_lands_on_itself_whatever_its_pose(turn, mirror):
    smile = Smile()
    P, X, normals = _sheet(smile, 3000, turn, mirror)
    U, info = _map(smile, X, normals)
    assert info["mesh_holes"] == 3 and info["paired"] == 3
    # The smile is symmetric about x = 0: its mirror image is as good a map.
    error = min(np.linalg.norm(U - P, axis=1).mean(),
                np.linalg.norm(U - P * [-1.0, 1.0], axis=1).mean())
    # Measured 0.004-0.006 (the boundary is laid by arc length, so the rim points slide a
    # little); a wrong pairing of the eyes and the mouth is off by 0.3 or more.
    assert error < 0.02, error


def test_each_hole_of_a_bent_smile_encloses_its_domain_hole():
    smile = Smile()
    _, X, normals = _sheet(smile, 3000, 0.7, True, bump=1.0)
    U, _ = _map(smile, X, normals)
    deep = [int(shapely.contains_xy(shapely.Polygon(ring).buffer(-0.02), *U.T).sum())
            for ring in smile.boundary_loops()[1:]]
    # Measured [0, 1, 0]: a harmonic map onto a region that is not convex may cross a hole's
    # rim (the refinement mends it). A hole of the cloud laid elsewhere leaves about
    # 3000 x (hole area / domain area) points in it: 50 in an eye, 392 in the mouth.
    assert max(deep) <= 3, deep


def test_landmarks_choose_among_the_turns_of_a_square():
    square = Square()
    P, X, normals = _sheet(square, 2000, 0.4, False)
    edge = np.flatnonzero(P[:, 0] > 0.9)  # points near the edge x = 1
    target = np.column_stack([np.full(50, -1.0), np.linspace(-1, 1, 50)])  # onto x = -1
    U, _ = _map(square, X, normals, landmarks=[(edge, target)])
    assert U[edge, 0].mean() < -0.85
    U, _ = _map(square, X, normals)
    # Without them the square's eight symmetries are all as good; with them the rotation by
    # pi is the one that sends x = 1 to x = -1.
    assert np.abs(U[edge, 0]).mean() > 0.85


def test_harmonic_onto_refuses_a_domain_of_two_parts():
    @dataclass(frozen=True)
    class TwoSquares(ShapelyDomain):
        """Two unit squares apart."""

        name: ClassVar[str] = "two_squares"

        def _build_geometry(self):
            return shapely.MultiPolygon([shapely.box(0, 0, 1, 1), shapely.box(2, 0, 3, 1)])

    _, X, normals = _sheet(Square(), 500, 0.0, False)
    with pytest.raises(InputError, match="has 2 separate parts; the local-mesh map needs one "
                                         "connected region"):
        _map(TwoSquares(), X, normals)


def test_landmarks_turn_the_conformal_disk_map():
    from pcgeom.domains import Disk
    from pcgeom.maps.disk import conformal_disk
    from pcgeom.maps.domain import align_onto

    disk = Disk()
    P, X, normals = _sheet(disk, 2000, 0.9, True)
    Xn, _, _ = normalize(X)
    mesh = local_mesh(Xn, normals, 24)
    D = conformal_disk(Xn, mesh, lscm_free(Xn, mesh))
    edge = np.flatnonzero(P[:, 0] > 0.9)
    target = np.array([[0.0, -1.0]])  # the bottom of the disk
    U, info = align_onto(Xn, mesh, D, disk, landmarks=[(edge, target)])
    assert np.linalg.norm(U[edge].mean(axis=0) - [0.0, -0.95]) < 0.1
    # Turned and perhaps mirrored, never stretched: the map stays in the disk.
    assert np.linalg.norm(U, axis=1).max() < 1.0 + 1e-2
    assert info["domain_holes"] == 0 and info["paired"] == 0


def test_holes_that_match_the_domain_give_no_warning_and_their_area_ratios():
    smile = Smile()
    _, X, normals = _sheet(smile, 3000, 0.3, False)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        _, info = _map(smile, X, normals)
    assert len(info["hole_area_ratios"]) == 3
    assert all(0.8 < r < 1.2 for r in info["hole_area_ratios"]), info  # its own holes


def test_a_domain_hole_without_a_hole_of_the_cloud_is_warned_of():
    _, X, normals = _sheet(Square(), 2000, 0.0, False)
    match = (r"^the domain smile has 3 hole\(s\) and the cloud none: 3 domain hole\(s\) get "
             r"no hole of the cloud, and the map tears the surface open there")
    with pytest.warns(UserWarning, match=match):
        _, info = _map(Smile(), X, normals)
    assert info["paired"] == 0 and info["hole_area_ratios"] == []


def test_a_hole_much_smaller_than_its_domain_hole_is_warned_of():
    _, X, normals = _sheet(Annulus(inner=0.1), 3000, 0.0, False)
    with pytest.warns(UserWarning, match=r"^1 of the 1 holes of the domain annulus get a hole "
                                         r"of the cloud of only \d\.\d% to \d\.\d% of their "
                                         r"area: the map stretches the surface open"):
        _, info = _map(Annulus(), X, normals)
    # Its hole has 0.01 of the disk's area, the domain's 0.25 of it, after scaling the
    # regions to the same area: (0.01 / 0.99) / (0.25 / 0.75) = 0.030; the loop through the
    # points around the hole is inscribed in it, a little smaller (measured 0.0255).
    (ratio,) = info["hole_area_ratios"]
    assert 0.02 < ratio < 0.0303


def _planar_annulus(r: float, n: int = 3000, seed: int = 0):
    """Area-uniform points of the planar annulus ``r <= |x| <= 1`` (z = 0), both circles
    sampled."""
    rng = np.random.default_rng(seed)
    rho = np.sqrt(rng.uniform(r * r, 1.0, n))
    t = rng.uniform(0, 2 * np.pi, n)
    k_out, k_in = 120, max(12, int(120 * r))
    rim = np.concatenate([np.exp(2j * np.pi * np.arange(k_out) / k_out),
                          r * np.exp(2j * np.pi * np.arange(k_in) / k_in)])
    z = np.concatenate([rho * np.exp(1j * t), rim])
    return np.column_stack([z.real, z.imag, np.zeros(len(z))])


@pytest.mark.parametrize("r", [0.3, 0.55])
def test_annulus_radius_is_the_modulus_of_a_planar_annulus(r):
    """Analytic: the harmonic function between the circles of ``r <= |x| <= 1`` has energy
    2 pi / log(1 / r), so the radius read back is r."""
    from pcgeom.maps.domain import annulus_radius

    X = _planar_annulus(r)
    normals = np.tile([0.0, 0.0, 1.0], (len(X), 1))
    mesh = local_mesh(X, normals, 24)
    assert annulus_radius(X, mesh, lscm_free(X, mesh)) == pytest.approx(r, rel=0.03)


def test_annulus_auto_is_resolved_from_the_cloud_and_recorded():
    import dataclasses

    from pcgeom import get_domain, parametrize
    from pcgeom.config import get_preset

    config = get_preset("fast")
    config = dataclasses.replace(config, local_mesh=dataclasses.replace(
        config.local_mesh, domain_refine=dataclasses.replace(config.local_mesh.domain_refine,
                                                             steps=0)))
    X = 2.0 * _planar_annulus(0.4, n=2000)
    normals = np.tile([0.0, 0.0, 1.0], (len(X), 1))
    result = parametrize(X, "annulus:auto", config=config, normals=normals, progress=False)
    assert isinstance(result.domain, Annulus) and not result.domain.auto
    assert result.domain.inner == pytest.approx(0.4, rel=0.03)
    assert result.history[0]["auto_inner"] == pytest.approx(result.domain.inner, abs=1e-6)
    assert get_domain(result.domain.spec) == result.domain  # the results file names it
    from pcgeom.examples import peaks_surface

    V, _ = peaks_surface("peaks3", n_side=30)  # a disk: no hole to measure
    with pytest.raises(InputError, match="annulus:auto needs a surface with a hole"):
        parametrize(V, "annulus:auto", config=config, progress=False)


@pytest.mark.parametrize("spec, message", [
    ("disk:auto", r"domain 'disk:auto': only annulus takes 'auto' \(its inner radius from the "
                  r"surface\)"),
    ("annulus:auto,x", r"domain 'annulus:auto,x': expected numbers after 'annulus:auto,'"),
    ("annulus:auto,1,2", r"domain 'annulus:auto,1,2': annulus:auto takes at most outer; got 2 "
                         r"value\(s\)"),
])
def test_bad_auto_specs_are_refused_in_one_line(spec, message):
    from pcgeom import get_domain

    with pytest.raises(InputError, match=message):
        get_domain(spec)
    auto = get_domain("annulus:auto,2")
    assert auto.auto and auto.outer == 2.0 and auto.spec == "annulus:auto,2.0"
    assert get_domain(auto.spec) == auto and get_domain(auto.to_dict()) == auto


# ------------------------------------------------------------------ injective_onto


def test_injective_onto_a_bent_smile_turns_no_triangle_and_lays_holes_on_holes():
    """The bent smile whose harmonic map crosses a hole (above): under the barrier, no
    triangle of the cleaned local mesh turns over, no point lies deep in a domain hole, and
    the history says which hole of the cloud went onto which hole of the domain."""
    from pcgeom.maps.domain import injective_onto
    from pcgeom.maps.localmesh import mesh_flips

    smile = Smile()
    _, X, normals = _sheet(smile, 3000, 0.7, True, bump=1.0)
    Xn, _, _ = normalize(X)
    mesh = local_mesh(Xn, normals, 24)
    U, info = injective_onto(Xn, mesh, lscm_free(Xn, mesh), smile)
    assert info["injective"]["flipped"] == 0
    flips = mesh_flips(Xn, mesh, U, info["dropped_faces"])
    assert flips["count"] == 0, flips
    # Measured: 188 of 5893 set aside, 183 of them rim triangles wider than 120 degrees
    # (peeled), 5 of two fans at a vertex; no handle on a sheet.
    assert flips["dropped"] <= 0.05 * flips["faces"]
    assert info["injective"]["handles"] == 0 and info["injective"]["pinched"] <= 10
    deep = [int(shapely.contains_xy(shapely.Polygon(ring).buffer(-0.02), *U.T).sum())
            for ring in smile.boundary_loops()[1:]]
    assert deep == [0, 0, 0], deep
    assert sorted(h["domain_hole"] for h in info["holes_onto"]) == [0, 1, 2]
    assert [h["hole"] for h in info["holes_onto"]] == [0, 1, 2]


def test_a_flat_smile_lands_on_itself_under_the_barrier():
    """Analytic: the smile's own sample in a tilted plane is mapped onto the smile by a
    similarity, which the barrier keeps (root MIPS is least there)."""
    from pcgeom.maps.domain import injective_onto

    smile = Smile()
    P, X, normals = _sheet(smile, 3000, 1.2, False)
    Xn, _, _ = normalize(X)
    mesh = local_mesh(Xn, normals, 24)
    U, _ = injective_onto(Xn, mesh, lscm_free(Xn, mesh), smile)
    error = min(np.linalg.norm(U - P, axis=1).mean(),
                np.linalg.norm(U - P * [-1.0, 1.0], axis=1).mean())
    assert error < 0.02, error


def test_a_planar_annulus_onto_annulus_auto_is_a_rotation():
    """Analytic: a planar annulus r = 0.4 onto ``annulus:auto`` (its own modulus) by the
    default map: the injective one, no refinement, each point at its own radius."""
    from pcgeom import parametrize

    X = 2.0 * _planar_annulus(0.4, n=2000)
    normals = np.tile([0.0, 0.0, 1.0], (len(X), 1))
    result = parametrize(X, "annulus:auto", normals=normals, progress=False)
    record = result.history[0]
    assert record["method"] == "injective" and len(result.history) == 1
    assert record["flips"]["count"] == 0 and record["injective"]["flipped"] == 0
    radius = np.linalg.norm(result.uv, axis=1)
    error = np.abs(radius - np.linalg.norm(X[:, :2], axis=1) / 2.0)
    assert np.median(error) < 0.01 and error.max() < 0.05, (np.median(error), error.max())


def test_landmarks_pull_the_conformal_car_map_without_a_fold():
    """The car shell with its window edges (the paper's 7.4), 1500 points: the conformal map
    turned and moved by a disk automorphism to fit the landmarks, then pulled onto them under
    the barrier: the window edges come closer to their targets and no triangle of the cleaned
    local mesh turns over."""
    from pcgeom.config import get_preset
    from pcgeom.domains import get_domain
    from pcgeom.io.landmarks import sample_polyline
    from pcgeom.maps.disk import conformal_disk
    from pcgeom.maps.domain import landmarks_onto
    from pcgeom.maps.free import free_start
    from pcgeom.maps.localmesh import mesh_flips
    from pcgeom.maps.riemann import riemann_onto
    from pcgeom.metrics import hausdorff

    from pcgeom.synthetic import CAR_TARGET_LINES, CAR_TARGET_SPACING, car_shell

    V, _, edges = car_shell(1500, seed=0)
    targets = np.vstack([sample_polyline(line, CAR_TARGET_SPACING)
                         for line in CAR_TARGET_LINES])
    X, _, _ = normalize(V)
    uv, mesh, _, _ = free_start(X, None, get_preset("fast"), progress=False)
    disk = conformal_disk(X, mesh, uv)
    car = get_domain("car")
    plain, _ = riemann_onto(X, mesh.faces, disk, car)
    U, info = landmarks_onto(X, mesh, disk, car, [(edges, targets)])
    # The pull started from the conformal map turned and moved by a disk automorphism
    # (riemann_onto with the landmarks: its record is the pull's).
    assert len(info["automorphism"]) == 2
    before = hausdorff(plain[edges], targets)
    after = hausdorff(U[edges], targets)
    assert info["injective"]["flipped"] == 0
    assert mesh_flips(X, mesh, U, info["dropped_faces"])["count"] == 0
    # Measured: 0.301 plain (0.308 turned), 0.0113 pulled along the lines by arc length
    # (0.034 with nearest-target pairs).
    assert after < 0.5 * before and after < 0.02, (before, after)


def test_a_domain_hole_without_a_hole_of_the_cloud_gets_the_tearing_refinement():
    """No injective map leaves a domain hole empty when the cloud has no hole for it: three
    peaks (a disk) onto the smile get the harmonic layout and the refinement, which tears."""
    import dataclasses

    from pcgeom import parametrize
    from pcgeom.config import get_preset
    from pcgeom.examples import peaks_surface

    config = get_preset("fast")
    config = dataclasses.replace(config, local_mesh=dataclasses.replace(
        config.local_mesh, domain_refine=dataclasses.replace(config.local_mesh.domain_refine,
                                                             steps=20)))
    V, _ = peaks_surface("peaks3", n_side=24)
    with pytest.warns(UserWarning, match="3 domain hole\\(s\\) get no hole of the cloud"):
        result = parametrize(V, "smile", config=config, progress=False)
    assert result.history[0]["method"] == "harmonic" and "injective" not in result.history[0]
    assert [r["stage"] for r in result.history][-1] != "localmesh"  # refined


def _grid(n: int):
    """An n x n grid of unit spacing in the plane and its triangles (counter-clockwise)."""
    g = np.stack(np.meshgrid(np.arange(n), np.arange(n), indexing="xy"), -1).reshape(-1, 2)
    i, j = np.meshgrid(np.arange(n - 1), np.arange(n - 1), indexing="xy")
    v = (j * n + i).ravel()
    F = np.vstack([np.column_stack([v, v + 1, v + n + 1]), np.column_stack([v, v + n + 1, v + n])])
    return g.astype(np.float64), F


def test_rows_off_the_mesh_move_with_an_affine_map_exactly():
    """follow_rest: rows off the map's triangles go where the piecewise linear map from the
    start takes them, so an affine move of the known rows takes them exactly; the
    inverse-distance mean of the moved neighbours (the rows laid anew) misses by a tenth of
    the spacing."""
    from pcgeom.maps.follow import follow_rest
    from pcgeom.maps.localmesh import _interpolate_rest

    g, F = _grid(8)
    off = np.random.default_rng(0).uniform(0.5, 6.5, (20, 2))
    S = np.vstack([g, off])
    X = np.column_stack([S, np.zeros(len(S))])
    known = np.arange(len(S)) < len(g)
    A = np.array([[0.6, -0.9], [1.1, 0.4]])  # turns, shears, scales
    U = np.where(known[:, None], S @ A.T + [2.0, -1.0], np.nan)
    moved = follow_rest(X, U, known, S, F)
    exact = S @ A.T + [2.0, -1.0]
    assert np.abs(moved - exact).max() < 1e-12
    laid = _interpolate_rest(X, U.copy(), known)
    assert np.abs(laid - exact)[~known].max() > 0.1


def test_a_row_off_the_mesh_stays_on_its_side_of_a_bent_edge():
    """A true triangle with a corner off the local mesh, that corner a twentieth of the
    spacing beside the triangle's other edge, and a landmark pulled hard two spacings away
    (as on peaks_three_cgal, bench_landmarks' seed 0 at 0.05 off): laid anew from its moved
    neighbours the corner crosses the edge and the triangle turns over; moved with the map
    from the start (landmarks_onto's follow_bend) it stays on its side."""
    from pcgeom.maps.follow import follow_rest
    from pcgeom.maps.localmesh import _interpolate_rest
    from pcgeom.mesh import signed_areas

    g, F = _grid(8)
    S = np.vstack([g, [[3.5, 3.05]]])
    X = np.column_stack([S, np.zeros(len(S))])
    known = np.arange(len(S)) < len(g)
    # A smooth pull downwards around (3.5, 4.3), no triangle of the grid turned over.
    D = S - [0.0, 0.4] * np.exp(-((S - [3.5, 4.3]) ** 2).sum(axis=1) / 0.64)[:, None]
    assert (signed_areas(D[:len(g)], F) > 0).all()
    U = np.where(known[:, None], D, np.nan)
    true = np.array([[3 * 8 + 3, 3 * 8 + 4, len(g)]])  # (3, 3), (4, 3), the row off the mesh
    assert signed_areas(S, true)[0] > 0
    assert signed_areas(_interpolate_rest(X, U.copy(), known), true)[0] < 0
    assert signed_areas(follow_rest(X, U, known, S, F), true)[0] > 0
