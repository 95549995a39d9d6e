"""pcgeom.maps.injective: untangling, the feasible step, the barrier map onto a domain."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from pcgeom.maps import injective as inj
from pcgeom.maps.injective import energies, jacobians, landmarks, newton
from pcgeom.maps.injective.loops import _rebuild_loops
from pcgeom.maps.injective.rings import _Rings
from pcgeom.maps.injective import (
    BarrierConfig,
    InjectiveConfig,
    UntangleConfig,
    conformal_energy,
    flipped,
    injective_map,
    max_feasible_step,
    signed_areas,
    untangle,
)
from pcgeom.mesh import one_fan, peel_rim, shoelace

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"


def _annulus(r0: float = 0.3, r1: float = 1.0, n_r: int = 6, n_t: int = 40):
    """A planar annulus mesh: vertices (n, 3) with z = 0, counter-clockwise faces, the outer
    loop counter-clockwise and the inner loop clockwise (each in its ring's direction)."""
    radii = np.geomspace(r0, r1, n_r)  # conformal spacing: rings of near-square cells
    theta = 2 * np.pi * np.arange(n_t) / n_t
    R, T = np.meshgrid(radii, theta, indexing="ij")  # (n_r, n_t)
    V = np.column_stack([(R * np.cos(T)).ravel(), (R * np.sin(T)).ravel(), np.zeros(R.size)])
    idx = np.arange(R.size).reshape(n_r, n_t)
    F = []
    for i in range(n_r - 1):
        for j in range(n_t):
            a, b = idx[i, j], idx[i, (j + 1) % n_t]
            c, d = idx[i + 1, j], idx[i + 1, (j + 1) % n_t]
            F += [[a, d, c], [a, b, d]][::-1] if False else [[a, c, d], [a, d, b]]
    outer = idx[-1]
    inner = idx[0][::-1]
    return V, np.asarray(F, dtype=np.int64), outer, inner


def _circle(radius: float, clockwise: bool = False, n: int = 512) -> np.ndarray:
    t = 2 * np.pi * np.arange(n + 1) / n
    ring = radius * np.column_stack([np.cos(t), np.sin(t)])
    return ring[::-1] if clockwise else ring


def _square_grid(k: int = 9):
    """A planar grid on [-1, 1]^2, counter-clockwise faces; its boundary loop
    counter-clockwise."""
    s = np.linspace(-1.0, 1.0, k)
    X, Y = np.meshgrid(s, s, indexing="xy")
    V = np.column_stack([X.ravel(), Y.ravel(), np.zeros(X.size)])
    idx = np.arange(k * k).reshape(k, k)  # [row (y), col (x)]
    F = []
    for i in range(k - 1):
        for j in range(k - 1):
            a, b, c, d = idx[i, j], idx[i, j + 1], idx[i + 1, j], idx[i + 1, j + 1]
            F += [[a, b, d], [a, d, c]]
    loop = np.concatenate([idx[0, :], idx[1:, -1], idx[-1, -2::-1], idx[-2:0:-1, 0]])
    return V, np.asarray(F, dtype=np.int64), loop


def _fold(U: np.ndarray, vertices: np.ndarray, shift) -> np.ndarray:
    """``U`` with ``vertices`` moved by ``shift``: far enough, their triangles turn over."""
    U = U.copy()
    U[vertices] += np.asarray(shift)
    return U


def _best_rotation(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """``A`` turned (about the origin, no mirror) onto ``B`` by least squares."""
    u, _, vt = np.linalg.svd(A.T @ B)
    R = u @ vt
    if np.linalg.det(R) < 0:
        u[:, -1] *= -1
        R = u @ vt
    return A @ R


# --------------------------------------------------------------------------- basics


def test_flipped_counts_non_positive_areas():
    V, F, _ = _square_grid(3)
    U = V[:, :2]
    assert flipped(U, F) == 0
    assert flipped(U, F[:, ::-1]) == len(F)  # a mirrored map counts every triangle
    assert np.isclose(signed_areas(U, F).sum(), 4.0)
    flat = U.copy()
    flat[:, 1] = 0.0
    assert flipped(flat, F) == len(F)  # zero area counts


@pytest.mark.parametrize("energy, value", [("mips", 2.0), ("root_mips", energies._ROOT_DELTA),
                                           ("symmetric_dirichlet", None)])
def test_similarity_is_the_minimum(energy, value):
    """A similarity has s1 = s2: MIPS 2 per area exactly (its minimum), root MIPS delta; an
    isometry has symmetric Dirichlet 4."""
    V, F, _, _ = _annulus(n_r=3, n_t=12)
    c, s = math.cos(0.7), math.sin(0.7)
    scale = 1.0 if value is None else 2.5
    U = scale * V[:, :2] @ np.array([[c, -s], [s, c]]).T + [0.3, -1.0]
    assert conformal_energy(V, F, U, energy) == pytest.approx(value or 4.0, rel=1e-12)
    # any other map costs more
    W = U * [1.3, 1.0]
    assert conformal_energy(V, F, W, energy) > conformal_energy(V, F, U, energy)


def test_folded_map_has_infinite_barrier():
    V, F, _ = _square_grid(3)
    U = _fold(V[:, :2], [4], [2.0, 0.0])
    assert flipped(U, F) > 0
    assert conformal_energy(V, F, U) == math.inf


@pytest.mark.parametrize("energy", inj.ENERGIES)
def test_barrier_gradient_matches_finite_differences(energy):
    rng = np.random.default_rng(1)
    V, F, _, _ = _annulus(n_r=3, n_t=10)
    area, G = inj.reference_triangles(V, F)
    U = V[:, :2] + 0.01 * rng.standard_normal((len(V), 2))
    D = rng.standard_normal(U.shape)

    def energy_at(W):
        return energies._barrier(jacobians._jacobians(W, F, G), area, energy, 0.5, 0.1)

    _, dJ = energy_at(U)
    grad = jacobians._scatter(dJ, F, G, len(V))
    h = 1e-6
    fd = (energy_at(U + h * D)[0] - energy_at(U - h * D)[0]) / (2 * h)
    assert fd == pytest.approx(float((grad * D).sum()), rel=1e-6)


def test_untangle_energy_gradient_and_hessian():
    """The gradient of E_eps against finite differences, and its Hessian (unprojected part:
    the projection only drops negative curvature) along a direction where it is convex."""
    rng = np.random.default_rng(2)
    V, F, _, _ = _annulus(n_r=3, n_t=10)
    area, G = inj.reference_triangles(V, F)
    U = _fold(V[:, :2], [12], [0.4, 0.1])  # some triangles folded: eps matters
    D = rng.standard_normal(U.shape)
    eps = 0.3

    def energy_at(W):
        return energies._untangle_energy(jacobians._jacobians(W, F, G), area, eps, 1 / 128)

    _, dJ = energy_at(U)
    grad = jacobians._scatter(dJ, F, G, len(V))
    h = 1e-6
    fd = (energy_at(U + h * D)[0] - energy_at(U - h * D)[0]) / (2 * h)
    assert fd == pytest.approx(float((grad * D).sum()), rel=1e-6)
    H = newton._Assembly(F, len(V))(
        energies._untangle_hessian(jacobians._jacobians(U, F, G), area, eps, 1 / 128),
        jacobians._jacobian_matrices(G))
    assert (H - H.T).count_nonzero() == 0 or abs(H - H.T).max() < 1e-9
    eig = np.linalg.eigvalsh(H.toarray())
    assert eig.min() > -1e-9 * eig.max()  # positive semi-definite


# --------------------------------------------------------------------------- feasible step


def test_max_feasible_step_is_the_first_zero_area():
    """At a = amax some triangle's area is zero; just below every area is positive."""
    rng = np.random.default_rng(3)
    V, F, _ = _square_grid(5)
    U = V[:, :2] + 0.02 * rng.standard_normal((len(V), 2))
    assert flipped(U, F) == 0
    for _ in range(5):
        D = rng.standard_normal(U.shape)
        a = max_feasible_step(U, F, D)
        assert math.isfinite(a) and a > 0
        scale = signed_areas(U, F).max()
        assert abs(signed_areas(U + a * D, F).min()) < 1e-9 * scale
        assert (signed_areas(U + (1 - 1e-6) * a * D, F) > 0).all()
        # the minimum of the areas along the way is first zero at a
        for s in np.linspace(0, 1 - 1e-6, 50):
            assert (signed_areas(U + s * a * D, F) > 0).all()


def test_max_feasible_step_quadratic_and_none():
    """One triangle: its area along the path is a quadratic; rigid motion never flips."""
    F = np.array([[0, 1, 2]])
    U = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    D = np.array([[0.0, 0.0], [0.0, 0.0], [0.0, -2.0]])  # the apex down: area 1/2 - a
    assert max_feasible_step(U, F, D) == pytest.approx(0.5)
    D = np.array([[0.0, 0.0], [-1.0, 0.0], [0.0, -0.5]])  # 2 area = (1 - a)(1 - a / 2)
    assert max_feasible_step(U, F, D) == pytest.approx(1.0)
    D = np.array([[0.0, 0.0], [-1.0, 0.0], [0.0, -1.0]])  # (1 - a)^2: touches zero at 1
    assert max_feasible_step(U, F, D) == pytest.approx(1.0, rel=1e-6)
    D = np.array([[0.0, 0.0], [-1.0, 1.0], [-1.0, -1.0]])  # (1 - a)^2 + a^2: never zero
    assert max_feasible_step(U, F, D) == math.inf
    assert max_feasible_step(U, F, np.ones_like(U)) == math.inf  # a translation


# --------------------------------------------------------------------------- untangle


def test_untangle_unfolds_a_grid_with_its_boundary_held():
    V, F, loop = _square_grid(9)
    interior = np.setdiff1d(np.arange(len(V)), loop)
    U0 = _fold(V[:, :2], interior[:20], [0.9, 0.5])
    assert flipped(U0, F) > 10
    U, info = untangle(V, F, U0, loop)
    assert flipped(U, F) == 0 and info["flipped"] == 0
    assert info["flipped_start"] == flipped(U0, F)
    np.testing.assert_array_equal(U[loop], U0[loop])


def test_untangle_lbfgs_as_the_paper():
    V, F, loop = _square_grid(7)
    interior = np.setdiff1d(np.arange(len(V)), loop)
    U0 = _fold(V[:, :2], interior[:6], [0.7, 0.0])
    U, info = untangle(V, F, U0, loop, config=UntangleConfig(method="lbfgs", decrease=0.1))
    assert info["flipped"] == 0 and flipped(U, F) == 0


# --------------------------------------------------------------------------- injective_map


def test_injective_map_unfolds_an_annulus_onto_its_rings():
    V, F, outer, inner = _annulus()
    rings = [_circle(1.0), _circle(0.3, clockwise=True)]
    middle = np.flatnonzero(np.isclose(np.linalg.norm(V[:, :2], axis=1), np.geomspace(0.3, 1, 6)[2]))
    U0 = _fold(V[:, :2] @ np.array([[0.0, -1.0], [1.0, 0.0]]).T, middle[:8], [0.25, 0.25])
    assert flipped(U0, F) > 0
    U, info = injective_map(V, F, U0, [outer, inner], rings)
    assert info["flipped"] == 0 and flipped(U, F) == 0
    assert info["flipped_start"] > 0 and info["in_order"]
    radius = np.linalg.norm(U, axis=1)
    np.testing.assert_allclose(radius[outer], 1.0, atol=1e-4)
    np.testing.assert_allclose(radius[inner], 0.3, atol=1e-4)


def test_annulus_onto_the_same_annulus_is_a_rotation():
    """A planar annulus mapped onto an annulus of the same modulus: the conformal map is a
    rotation; the barrier map, started folded and turned, finds it."""
    V, F, outer, inner = _annulus()
    rings = [_circle(1.0), _circle(0.3, clockwise=True)]
    c, s = math.cos(0.5), math.sin(0.5)
    U0 = V[:, :2] @ np.array([[c, -s], [s, c]]).T
    interior = np.setdiff1d(np.arange(len(V)), np.concatenate([outer, inner]))
    U0 = _fold(U0, interior[::7], [0.05, -0.04])
    U, info = injective_map(V, F, U0, [outer, inner], rings,
                            config=InjectiveConfig(barrier=BarrierConfig(energy="mips")))
    assert info["flipped"] == 0
    assert conformal_energy(V, F, U, "mips") < 2.0 + 1e-3  # 2 for a similarity
    err = np.linalg.norm(_best_rotation(V[:, :2], U) - U, axis=1)
    assert err.max() < 0.003


def test_square_grid_onto_the_square_keeps_its_corners():
    """A planar square onto the square domain: a vertex pinned at each corner, the map the
    identity up to the sliding of the sides."""
    from pcgeom.domains import get_domain

    V, F, loop = _square_grid(9)
    ring = np.asarray(get_domain("square").boundary_loops()[0])
    U0 = _fold(V[:, :2], [40], [0.3, 0.2])
    U, info = injective_map(V, F, U0, [loop], [ring])
    assert info["flipped"] == 0 and info["corners"] == 4
    corners = V[[0, 8, 72, 80], :2]
    np.testing.assert_allclose(U[[0, 8, 72, 80]], corners, atol=1e-9)
    assert np.abs(U - V[:, :2]).max() < 1e-6


def test_unpaired_hole_stays_a_hole():
    """An annulus whose inner loop is paired with no ring: a free hole, filled by a scaffold
    fan so that it cannot fold over the map."""
    V, F, outer, _ = _annulus()
    U0 = _fold(V[:, :2], [100], [0.2, 0.0])
    U, info = injective_map(V, F, U0, [outer], [_circle(1.0)])
    assert info["scaffold"] == 1 and info["flipped"] == 0 and info["free_loops_simple"]
    assert flipped(U, F) == 0


def test_one_fan_drops_the_smaller_fan_at_a_pinch():
    """Two disks glued at one vertex: the vertex has two fans; the smaller goes."""
    _, big, _, _ = _annulus(n_r=2, n_t=8)  # one strip
    small = np.array([[0, 100, 101], [0, 101, 102]])  # a second fan at vertex 0
    kept, dropped = one_fan(np.vstack([big, small]))
    assert dropped == 2 and len(kept) == len(big)


def test_rebuild_loops_follows_the_peeled_rim():
    """A sliver on the rim (its apex just inside the boundary edge) is peeled; the apex joins
    the loop, between the edge's ends on the ring."""
    V, F, loop = _square_grid(5)
    V = V.copy()
    apex = 7  # the third vertex of the triangle on the bottom side's edge 1-2
    V[apex, :2] = [-0.25, -0.99]  # its angle near 180 degrees
    F2, peeled = peel_rim(V, F, math.radians(120))
    assert peeled >= 1
    U = V[:, :2].copy()
    ring = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1], [-1, -1]], dtype=float)
    loops, ts, joined = _rebuild_loops(V, F2, _Rings([loop], [ring], U))
    assert apex in loops[0].tolist() and joined[0] >= 1
    assert (np.diff(ts[0]) > 0).all()


# --------------------------------------------------------------------------- bad input


def test_bad_input_is_named():
    V, F, outer, inner = _annulus(n_r=3, n_t=10)
    U = V[:, :2]
    rings = [_circle(1.0), _circle(0.3, clockwise=True)]
    with pytest.raises(ValueError, match=r"V: expected shape \(n, 3\)"):
        injective_map(V[:, :1], F, U, [outer], rings[:1])
    with pytest.raises(TypeError, match="F: expected integer indices"):
        injective_map(V, F.astype(float), U, [outer], rings[:1])
    with pytest.raises(ValueError, match=r"U0: expected shape \(30, 2\)"):
        injective_map(V, F, U[:5], [outer], rings[:1])
    with pytest.raises(ValueError, match="expected one ring per loop"):
        injective_map(V, F, U, [outer, inner], rings[:1])
    with pytest.raises(ValueError, match=r"loops\[0\]: expected at least 3 indices"):
        injective_map(V, F, U, [outer[:2]], rings[:1])
    with pytest.raises(ValueError, match=r"rings\[0\]: expected finite points"):
        injective_map(V, F, U, [outer], [np.zeros((2, 2))])
    with pytest.raises(ValueError, match=r"loops\[0\]: its vertices are not in order"):
        injective_map(V, F, U, [outer[::-1]], rings[:1])
    with pytest.raises(ValueError, match=r"fixed_uv: expected shape \(3, 2\)"):
        untangle(V, F, U, [0, 1, 2], np.zeros((2, 2)))
    with pytest.raises(ValueError, match=r"weights: expected \(40,\) positive"):
        untangle(V, F, U, [0], weights=np.ones(3))
    flat = V.copy()
    flat[1] = flat[0]
    with pytest.raises(ValueError, match="triangle.*of zero area"):
        untangle(flat, F, U, [0])


# --------------------------------------------------------------------------- real data


@pytest.mark.slow
@pytest.mark.skipif(not (DATA / "face_3holes_small_choi.ply").exists(),
                    reason="../shared/data is absent")
def test_face_with_three_holes_onto_the_smile():
    """The bare cloud's local mesh, laid on the smile by harmonic_onto (4.3% of the true
    triangles folded), mapped without a fold of the local mesh; judged on the true
    triangles (measured: 0.054 rad, 0.031% flipped, 0.025 from the domain)."""
    from pcgeom import read_points
    from pcgeom.cloud import normalize
    from pcgeom.config import get_preset
    from pcgeom.domains import get_domain
    from pcgeom.maps.domain import _laid_out, harmonic_onto
    from pcgeom.maps.free import free_start
    from pcgeom.metrics import angle_distortion, surface_hausdorff

    cloud = read_points(DATA / "face_3holes_small_choi.ply", normals=False)
    X, _, _ = normalize(cloud.points)
    domain = get_domain("smile")
    uv, mesh, _, _ = free_start(X, None, get_preset("fast"), progress=False)
    U0, _ = harmonic_onto(X, mesh, uv, domain)
    main, V, F, P, outer, holes, rings, align = _laid_out(X, mesh, uv, domain, ())
    Z = align(P)
    loops, paired = [], []
    for loop, r in [(outer, 0)] + [(holes[k], 1 + j) for k, j in enumerate(align.pairing)]:
        if (shoelace(Z[loop]) > 0) != (shoelace(rings[r][:-1]) > 0):
            loop = loop[::-1]
        loops.append(np.asarray(loop))
        paired.append(rings[r])
    U, info = injective_map(V, F, U0[main], loops, paired)
    assert info["flipped"] == 0 and info["in_order"]
    W = U0.copy()
    W[main] = U
    report = angle_distortion(X, cloud.faces, W)
    assert report.mean_abs < 0.065
    assert report.flipped <= 0.001 * report.n_faces
    assert surface_hausdorff(W, cloud.faces, domain, n=50_000) < 0.035


def test_target_curves_finds_evenly_sampled_polylines_only():
    from pcgeom.io.landmarks import sample_polyline

    line = sample_polyline([[-0.5, -0.25], [0.5, -0.25]], 1 / 199)  # 200 points
    corner = sample_polyline([[0, 0], [1, 0], [1, 1]], 0.01)  # 201, one chord at the corner
    assert landmarks._target_curves(np.vstack([line, corner])) == [(0, 200), (200, 401)]
    t = np.linspace(0, 2 * np.pi, 100)
    assert landmarks._target_curves(np.column_stack([np.cos(t), np.sin(t)])) == [(0, 100)]
    scattered = np.random.default_rng(0).uniform(size=(50, 2))
    assert landmarks._target_curves(scattered) == []
    assert landmarks._target_curves(line[:3]) == []


def test_curve_pairs_spread_points_by_their_3d_arc_length():
    """Points along a 3D line, twice as far apart in their second half, mapped anywhere near
    a target segment: they keep their order along it, the ends go to its ends, and the gaps
    follow the 3D gaps."""
    from pcgeom.io.landmarks import sample_polyline

    x = np.concatenate([np.linspace(0, 1, 5), np.linspace(1.5, 3, 4)])  # gaps 0.25, 0.5
    P = np.column_stack([x, np.zeros_like(x), np.zeros_like(x)])
    u = np.column_stack([np.linspace(-0.2, 0.1, 9), np.full(9, 0.05)])
    shuffle = np.random.default_rng(1).permutation(9)
    curve = sample_polyline([[-0.5, 0.0], [0.5, 0.0]], 0.01)
    q = landmarks._curve_pairs(P[shuffle], u[shuffle], curve)
    np.testing.assert_allclose(q[np.argsort(shuffle)], np.column_stack(
        [-0.5 + x / 3, np.zeros(9)]), atol=1e-12)


def test_landmark_pairs_follow_each_curve_with_its_own_piece():
    """Two landmark edges (3D pieces) and two target lines: each edge is paired along the
    line it lies nearer to, one target per landmark point; scattered targets get the
    Chamfer pairs (every landmark point and every target paired)."""
    from pcgeom.io.landmarks import sample_polyline

    x = np.linspace(0, 1, 11)
    V = np.vstack([np.column_stack([x, np.zeros(11), np.zeros(11)]),
                   np.column_stack([x, np.ones(11), np.zeros(11)])])
    U = V[:, :2] * [0.8, 0.4] - [0.4, 0.1]  # the first edge near y = -0.1, the other 0.3
    lines = np.vstack([sample_polyline([[-0.5, 0.25], [0.5, 0.25]], 0.01),
                       sample_polyline([[-0.5, -0.25], [0.5, -0.25]], 0.01)])
    index, targets, weight = landmarks._landmark_pairs(V, U, [(np.arange(22), lines)], 7.0)
    assert weight == 7.0 and sorted(index.tolist()) == list(range(22))
    y = dict(zip(index.tolist(), targets[:, 1]))
    assert all(y[k] == -0.25 for k in range(11)) and all(y[k] == 0.25 for k in range(11, 22))
    scattered = np.random.default_rng(0).uniform(-0.5, 0.5, size=(30, 2))
    index, targets, _ = landmarks._landmark_pairs(V, U, [(np.arange(22), scattered)], 1.0)
    assert len(index) == 22 + 30 and set(index.tolist()) <= set(range(22))


def test_curve_pairs_on_a_closed_curve_turn_the_least():
    """Points evenly around a 3D circle, mapped onto a target circle turned by a little:
    each goes to the target point at its own angle (the loop is not cut at the curve's
    first sample)."""
    t = np.linspace(0, 2 * np.pi, 201)
    curve = np.column_stack([np.cos(t), np.sin(t)])
    a = 2 * np.pi * (np.arange(12) + 0.5) / 12 + 0.02
    P = np.column_stack([np.cos(a), np.sin(a), np.zeros(12)])
    q = landmarks._curve_pairs(P, 1.1 * P[:, :2], curve)
    np.testing.assert_allclose(np.arctan2(q[:, 1], q[:, 0]) % (2 * np.pi), a, atol=2e-3)
