"""Boundary detection (pcgeom.apps.boundary, ``pcgeom boundary``): analytic maps with known
loops, the real test surfaces' loops against their meshes, and the command line."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial import ConvexHull, cKDTree

import pcgeom.cli.boundary as boundary_command
from pcgeom import InputError, cli, get_domain, parametrize
from pcgeom.apps.boundary import BoundaryLoops, _walk_loops, detect_boundary
from pcgeom.apps.plot import plot_boundary, plot_boundary_h_sweep
from pcgeom.cloud import fingerprint
from pcgeom.io import read_points

from tests.helpers import assert_cli_fails, tiny_preset

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def _sheared_grid(n: int = 12, hole: tuple[int, int] = (4, 6), shear: float = 0.2):
    """An n x n grid sheared by ``shear`` (so no four points are cocircular and Delaunay is
    unique), with the block of grid indices hole[0]..hole[1] squared removed.

    Returns the map and the grid indices (i, j) of its rows.
    """
    i, j = (a.ravel() for a in np.meshgrid(np.arange(n), np.arange(n), indexing="xy"))
    lo, hi = hole
    keep = ~((i >= lo) & (i <= hi) & (j >= lo) & (j <= hi))
    i, j = i[keep], j[keep]
    return np.column_stack([i + shear * j, j]).astype(np.float64), i, j


def _shoelace(U, loop) -> float:
    x, y = U[loop, 0], U[loop, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def _assert_walks_kept_edges(found: BoundaryLoops) -> None:
    """Consecutive points of every loop (cyclically) form a directed edge of exactly one kept
    triangle, with that triangle on the left: each loop is closed and consistently ordered."""
    T = found.triangles
    directed = {}
    for a, b in np.concatenate([T[:, [0, 1]], T[:, [1, 2]], T[:, [2, 0]]]).tolist():
        directed[(a, b)] = directed.get((a, b), 0) + 1
    for loop in found.loops:
        for a, b in zip(loop.tolist(), np.roll(loop, -1).tolist()):
            assert directed.get((a, b)) == 1, (a, b)
            assert (b, a) not in directed, (a, b)  # a boundary edge: no triangle on the right


# --------------------------------------------------------------------------- analytic maps


def test_grid_with_a_square_hole_gives_its_rim_and_its_hole():
    U, i, j = _sheared_grid(12, hole=(4, 6))
    found = detect_boundary(U)
    assert len(found.loops) == 2 and found.dropped == []
    rim = {k for k in range(len(U)) if i[k] in (0, 11) or j[k] in (0, 11)}
    # The hole's border: the 12 points sharing a grid edge with the removed 3 x 3 block. The
    # four corner points of the ring around it are cut off by kept triangles of the lattice's
    # own shape (circumradius 0.78 spacings; the hole's triangles have 1.29 or more).
    hole = {k for k in range(len(U))
            if (3 <= i[k] <= 7 and 3 <= j[k] <= 7) and (i[k] in (3, 7)) != (j[k] in (3, 7))}
    assert len(rim) == 44 and len(hole) == 12
    assert set(found.loops[0].tolist()) == rim and len(found.loops[0]) == 44
    assert set(found.loops[1].tolist()) == hole and len(found.loops[1]) == 12
    # Outer loop counter-clockwise, the hole clockwise, areas as the shoelace gives them.
    assert _shoelace(U, found.loops[0]) > 0 > _shoelace(U, found.loops[1])
    np.testing.assert_allclose(found.areas, [_shoelace(U, loop) for loop in found.loops])
    assert found.areas[0] == pytest.approx(121.0)  # the sheared 11 x 11 square
    assert all(loop[0] == loop.min() for loop in found.loops)
    _assert_walks_kept_edges(found)


def test_the_rule_does_not_change_under_a_similarity():
    U, _, _ = _sheared_grid(12, hole=(4, 6))
    a = np.deg2rad(33.0)
    rot = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    moved = detect_boundary(1e-3 * U @ rot.T + [5.0, -7.0])
    found = detect_boundary(U)
    assert [loop.tolist() for loop in moved.loops] == [loop.tolist() for loop in found.loops]


def test_annulus_sample_gives_two_loops_on_its_circles():
    U = get_domain("annulus").sample(1500)  # radii 0.5 and 1
    spacing = float(np.median(cKDTree(U).query(U, k=2)[0][:, 1]))
    found = detect_boundary(U)
    assert len(found.loops) == 2
    r = np.linalg.norm(U, axis=1)
    outer, inner = found.loops
    assert found.areas[0] > 0 > found.areas[1]
    # Loop points lie within about a spacing of their circle; every point closer to a circle
    # than half a spacing is on its loop (measured: 1.14 and 0.70 spacings).
    assert (1.0 - r[outer]).max() < 1.3 * spacing
    assert (r[inner] - 0.5).max() < 1.3 * spacing
    assert set(np.flatnonzero(1.0 - r < 0.5 * spacing)) <= set(outer.tolist())
    assert set(np.flatnonzero(r - 0.5 < 0.5 * spacing)) <= set(inner.tolist())
    _assert_walks_kept_edges(found)


def test_disk_sample_gives_one_loop_of_the_outermost_points():
    U = get_domain("disk").sample(1000)
    spacing = float(np.median(cKDTree(U).query(U, k=2)[0][:, 1]))
    found = detect_boundary(U)
    assert len(found.loops) == 1 and found.areas[0] > 0
    loop = found.loops[0]
    r = np.linalg.norm(U, axis=1)
    assert set(ConvexHull(U).vertices.tolist()) <= set(loop.tolist())
    # Measured: loop points at most 0.85 spacings deep, all others at least 0.86.
    assert (1.0 - r[loop]).max() < 1.0 * spacing
    assert set(np.flatnonzero(1.0 - r < 0.7 * spacing)) <= set(loop.tolist())
    _assert_walks_kept_edges(found)


def test_duplicate_rows_are_triangulated_once_and_reported_by_their_first_row():
    U, _, _ = _sheared_grid(10, hole=(3, 5))
    rng = np.random.default_rng(0)
    copies = rng.choice(len(U), size=40, replace=False)
    doubled = np.concatenate([U, U[copies]])
    order = rng.permutation(len(doubled))
    shuffled = doubled[order]
    found = detect_boundary(shuffled)
    plain = detect_boundary(U)
    assert [len(loop) for loop in found.loops] == [len(loop) for loop in plain.loops]
    for loop, reference in zip(found.loops, plain.loops):
        # Same points, each named by the first of the rows that hold it.
        assert {tuple(p) for p in shuffled[loop]} == {tuple(p) for p in U[reference]}
        for k in loop:
            assert k == np.flatnonzero((shuffled == shuffled[k]).all(axis=1)).min()
    _assert_walks_kept_edges(found)


def test_small_h_breaks_the_map_into_many_loops_and_huge_h_gives_the_convex_hull():
    U = get_domain("disk").sample(800)
    spacing = float(np.median(cKDTree(U).query(U, k=2)[0][:, 1]))
    many = detect_boundary(U, h=1.4 * spacing, min_loop=3)  # measured: 42 loops
    assert len(many.loops) > 20
    assert len(detect_boundary(U, h=2.0 * spacing).loops) == 1  # the disk's own rim
    hull = detect_boundary(U, h=10.0)
    assert len(hull.loops) == 1 and len(hull.removed) == 0
    assert hull.h == 10.0 and hull.c is None
    assert hull.loops[0].tolist() == _hull_from_smallest(U)
    default = detect_boundary(U)
    assert default.h is None and default.c == 1.0


def _hull_from_smallest(U) -> list[int]:
    """scipy's convex hull vertices, counter-clockwise, from the smallest row."""
    v = ConvexHull(U).vertices  # counter-clockwise in 2D
    return np.roll(v, -int(np.argmin(v))).tolist()


def test_patches_joined_at_one_vertex_are_one_loop_through_it_twice():
    # Two triangles touching at the origin (a bow-tie); h removes the two long ones between.
    U = np.array([[0.0, 0.0], [1.0, -0.3], [1.0, 0.3], [-1.0, 0.3], [-1.0, -0.3]])
    found = detect_boundary(U, h=1.1, min_loop=3)
    assert len(found.triangles) == 2 and len(found.loops) == 1
    loop = found.loops[0].tolist()
    assert len(loop) == 6 and loop.count(0) == 2
    assert found.areas[0] == pytest.approx(2 * 0.3)
    _assert_walks_kept_edges(found)


def test_a_hole_touching_the_rim_at_one_vertex_stays_its_own_loop():
    # A 4 x 4 grid of points, all cells as two triangles except the corner cell (0, 0) and
    # the middle cell (1, 1), which touch at the point (1, 1): the removed region is the
    # outside (with the corner notch) and the middle hole, joined only at that vertex.
    P = np.array([[x, y] for y in range(4) for x in range(4)], dtype=np.float64)

    def v(x, y):
        return 4 * y + x

    T = []
    for y in range(3):
        for x in range(3):
            if (x, y) in ((0, 0), (1, 1)):
                continue
            T += [[v(x, y), v(x + 1, y), v(x + 1, y + 1)], [v(x, y), v(x + 1, y + 1), v(x, y + 1)]]
    loops = _walk_loops(P, np.array(T))
    assert sorted(len(loop) for loop in loops) == [4, 12]
    hole = next(loop for loop in loops if len(loop) == 4)
    rim = next(loop for loop in loops if len(loop) == 12)
    assert set(hole.tolist()) == {v(1, 1), v(2, 1), v(2, 2), v(1, 2)}
    assert _shoelace(P, hole) == pytest.approx(-1.0)  # clockwise
    assert _shoelace(P, rim) == pytest.approx(8.0)  # 9 cells minus the notch
    assert v(1, 1) in rim.tolist() and v(0, 0) not in rim.tolist()


def test_min_loop_drops_small_loops_and_keeps_them_aside():
    U, _, _ = _sheared_grid(12, hole=(5, 6))  # 2 x 2 points missing: a hole of 8 points
    found = detect_boundary(U, min_loop=9)
    assert len(found.loops) == 1 and [len(loop) for loop in found.dropped] == [8]
    kept = detect_boundary(U)  # min_loop 8
    assert [len(loop) for loop in kept.loops] == [44, 8] and kept.dropped == []
    assert kept.areas[1] < 0
    # One missing point leaves a gap no larger than the lattice's own triangles: no hole.
    single, _, _ = _sheared_grid(12, hole=(5, 5))
    assert [len(loop) for loop in detect_boundary(single, min_loop=3).loops] == [44]


def test_cloud_spacing_opens_a_hole_that_the_map_shrank():
    # A flat grid with a 6 x 6 hole, mapped with the hole shrunk: every point within 5 of the
    # hole's centre pulled towards it, so the hole is barely a gap in the map.
    i, j = (a.ravel() for a in np.meshgrid(np.arange(20), np.arange(20), indexing="xy"))
    keep = ~((i >= 7) & (i <= 12) & (j >= 7) & (j <= 12))
    P = np.column_stack([i + 0.2 * j, j, np.zeros(len(i))]).astype(np.float64)[keep]
    centre = np.array([9.5 + 0.2 * 9.5, 9.5])
    d = P[:, :2] - centre
    r = np.linalg.norm(d, axis=1, keepdims=True)
    U = centre + d * np.where(r < 7.0, (r - 2.5) / (7.0 - 2.5) * 7.0 / r, 1.0).clip(0.1)
    U[r[:, 0] >= 7.0] = P[r[:, 0] >= 7.0, :2]
    plain = detect_boundary(U, points=P, kinds=False)
    opened = detect_boundary(U, points=P, cloud_spacing=True, kinds=False)
    assert len(plain.loops) == 1  # the map alone does not see it
    assert len(opened.loops) == 2 and opened.areas[1] < 0
    assert len(opened.loops[1]) >= 24  # along the 28 grid points around the hole (32 found)
    # By default (kinds) the cloud's spacing casts the candidates, and the evidence keeps it.
    judged = detect_boundary(U, points=P)
    assert judged.kinds() == ["outer", "hole"] and judged.gaps == []
    # ... and walks through the notches of the square hole's rim too: its four corners.
    corners = {(6, 6), (13, 6), (6, 13), (13, 13)}
    ij = list(zip(i[keep].tolist(), j[keep].tolist()))
    assert {ij[k] for k in judged.loops[1]} >= {ij[k] for k in opened.loops[1]} | corners


def test_a_holes_loop_walks_through_the_notches_of_its_rim(monkeypatch):
    """Issue 39 item 3: a round hole cut out of a triangulated grid (every triangle at a
    removed point dropped) has a rim two points thick in places: the points set back between
    two rim points are on the reference's boundary too. The hole's loop holds all of them."""
    import pcgeom.apps.boundary as boundary

    n, rad = 16, 3.2
    i, j = (a.ravel() for a in np.meshgrid(np.arange(n), np.arange(n), indexing="xy"))
    q = np.arange(n * n).reshape(n, n)
    F = np.concatenate([np.stack([q[:-1, :-1], q[:-1, 1:], q[1:, 1:]], -1).reshape(-1, 3),
                        np.stack([q[:-1, :-1], q[1:, 1:], q[1:, :-1]], -1).reshape(-1, 3)])
    gone = np.hypot(i - 7.8, j - 7.8) < rad
    F = F[~gone[F].any(axis=1)]  # the reference mesh
    E = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    edges, count = np.unique(E, axis=0, return_counts=True)
    rim = np.zeros(n * n, dtype=bool)
    rim[edges[count == 1]] = True
    rim &= np.hypot(i - 7.8, j - 7.8) < n / 2 - 1  # the hole's, not the sheet's
    P = np.column_stack([i + 0.2 * j, j, 0.1 * i]).astype(np.float64)[~gone]
    ring = set(np.flatnonzero(rim[~gone]).tolist())
    found = detect_boundary(P[:, :2], points=P)
    assert found.kinds() == ["outer", "hole"] and len(ring) == 24
    assert ring <= set(found.loops[1]) and len(set(found.loops[1]) - ring) <= 4
    monkeypatch.setattr(boundary, "NOTCH_ROUNDS", 0)  # the map's rule alone: 20 of 24
    assert len(ring & set(detect_boundary(P[:, :2], points=P).loops[1])) == 20


def test_min_width_measures_holes_on_the_surface_and_drops_the_narrow_ones():
    from pcgeom.apps.boundary import hole_width

    i, j = (a.ravel() for a in np.meshgrid(np.arange(24), np.arange(24), indexing="xy"))
    wide = (i >= 4) & (i <= 11) & (j >= 4) & (j <= 11)  # 8 x 8 points missing
    narrow = (i >= 14) & (i <= 20) & (j >= 15) & (j <= 16)  # 7 x 2 points missing
    keep = ~(wide | narrow)
    U = np.column_stack([i + 0.2 * j, j]).astype(np.float64)[keep]
    # On a bent surface, so that widths are measured in 3D: a cylinder of radius 10.
    P = np.column_stack([10 * np.sin(U[:, 0] / 10), U[:, 1], 10 * np.cos(U[:, 0] / 10)])
    every = detect_boundary(U, points=P)  # min_width 0: nothing dropped for width
    assert len(every.loops) == 3 and every.min_width == 0.0
    assert np.isnan(every.widths[0])  # the outer loop is not judged
    # Inradius estimates 2A/P (grid units: the 9 x 9 gap 4.5, the 8 x 3 slit 2.2) over a
    # spacing of about one grid step (measured 4.41 and 2.16).
    w_wide, w_narrow = every.widths[1], every.widths[2]
    assert 3.5 < w_wide < 5.0 and 1.5 < w_narrow < 2.5
    dropped = detect_boundary(U, points=P, min_width=3.0)
    assert len(dropped.loops) == 2 and dropped.widths[1] == w_wide
    assert [len(loop) for loop in dropped.dropped] == [len(every.loops[2])]
    assert dropped.to_dict()["min_width"] == 3.0 and dropped.to_dict()["widths"][0] is None
    assert detect_boundary(U).widths is None  # without the cloud nothing is measured
    # A round hole: its radius over the spacing.
    t = np.linspace(0, 2 * np.pi, 50, endpoint=False)
    circle = np.column_stack([np.cos(t), np.sin(t), np.zeros(50)])
    assert hole_width(circle, np.arange(50), np.full(50, 0.5)) == pytest.approx(2.0, rel=0.01)


@pytest.mark.parametrize("kwargs, message", [
    ({"U": np.zeros((5, 3))}, r"U: expected shape \(N, 2\), got \(5, 3\)"),
    ({"U": np.zeros(6)}, r"U: expected shape \(N, 2\), got \(6,\)"),
    ({"U": [["a", "b"]]}, "U: cannot convert to a float array"),
    ({"U": np.array([[0, 0], [1, 0], [np.nan, 1], [0, 1]])}, "U: 1 of 4 rows contain NaN or inf"),
    ({"U": np.array([[0, 0], [1, 0], [1, 0], [0, 0]])}, r"U: 2 distinct points \(of 4\), need at least 3"),
    ({"U": np.column_stack([np.arange(10.0), 2 * np.arange(10.0)])},
     "U: all 10 distinct points lie on one line"),
    ({"h": 0.0}, "h: expected a positive number, got 0.0"),
    ({"h": -1}, "h: expected a positive number, got -1.0"),
    ({"h": float("nan")}, "h: expected a positive number, got nan"),
    ({"h": "big"}, "h: expected a positive number, got 'big'"),
    ({"c": 0}, "c: expected a positive number, got 0.0"),
    ({"min_loop": 2}, "min_loop: expected an integer >= 3, got 2"),
    ({"min_loop": 4.0}, "min_loop: expected an integer >= 3, got 4.0"),
    ({"points": np.zeros((49, 3))}, r"points: expected shape \(50, 3\) \(one row per map row\), "
                                    r"got \(49, 3\)"),
    ({"points": np.full((50, 3), np.nan)}, "points: 50 of 50 rows contain NaN or inf"),
    ({"points": np.zeros((50, 3)), "min_width": -1},
     "min_width: expected a non-negative number, got -1.0"),
    ({"cloud_spacing": True}, r"cloud_spacing: needs the cloud \(points\)"),
])
def test_bad_input_is_one_line_input_error(kwargs, message):
    args = {"U": get_domain("disk").sample(50), **kwargs}
    with pytest.raises(InputError, match=message) as info:
        detect_boundary(args.pop("U"), **args)
    assert "\n" not in str(info.value)


# --------------------------------------------------------------------------- figures


def _assert_png(path) -> None:
    import matplotlib.image

    assert path.read_bytes()[:8] == PNG_SIGNATURE
    assert matplotlib.image.imread(path).shape[0] > 100
    assert sorted(p.name for p in path.parent.iterdir()) == [path.name]


def test_plot_boundary_and_h_sweep_write_pngs(tmp_path):
    U = get_domain("annulus").sample(600)
    found = detect_boundary(U)
    (tmp_path / "one").mkdir()
    _assert_png(plot_boundary(U, found, tmp_path / "one" / "loops.png"))
    (tmp_path / "sweep").mkdir()
    _assert_png(plot_boundary_h_sweep(U, [None, 0.03, 0.08, 0.3], tmp_path / "sweep" / "h.png",
                                      title="annulus"))


def test_plot_boundary_rejects_loops_of_another_map(tmp_path):
    U = get_domain("disk").sample(300)
    found = detect_boundary(U)
    with pytest.raises(ValueError, match="found: refers to row 29"):
        plot_boundary(U[:30], found, tmp_path / "x.png")
    with pytest.raises(ValueError, match="hs: expected at least one threshold"):
        plot_boundary_h_sweep(U, [], tmp_path / "x.png")
    with pytest.raises(InputError, match="h: expected a positive number"):
        plot_boundary_h_sweep(U, [0.1, -1.0], tmp_path / "x.png")
    assert list(tmp_path.iterdir()) == []


# --------------------------------------------------------------------------- real surfaces

needs_data = pytest.mark.skipif(not DATA.is_dir(), reason=f"test surfaces not found at {DATA}")


def _true_loops(F) -> list[np.ndarray]:
    igl = pytest.importorskip("igl")
    return [np.asarray(loop, dtype=np.int64) for loop in igl.boundary_loop_all(F)]


def _match(found: BoundaryLoops, truth: list[np.ndarray]) -> list[tuple[int, float]]:
    """For each true loop, the detected loop of largest vertex Jaccard index, and that index."""
    out = []
    for t in truth:
        jac = [len(set(t) & set(loop)) / len(set(t) | set(loop)) for loop in found.loops]
        out.append((int(np.argmax(jac)), float(max(jac))))
    return out


def _noisy(U, scale: float, seed: int = 1):
    """``U`` plus Gaussian noise of ``scale`` times each point's nearest-neighbour distance."""
    d1 = cKDTree(U).query(U, k=2)[0][:, 1]
    return U + np.random.default_rng(seed).normal(size=U.shape) * (scale * d1)[:, None]


@needs_data
@pytest.mark.parametrize("noise", [0.0, 0.1])
def test_face_with_three_holes_gives_its_four_true_loops(noise):
    from pcgeom.apps.baselines import lscm

    mesh = read_points(DATA / "face_3holes_small_choi.ply")
    truth = _true_loops(mesh.faces)
    assert len(truth) == 4
    # LSCM on the true mesh stands in for a good free-boundary map (the faces are used for
    # nothing else: detection sees only the map).
    U = _noisy(lscm(mesh.points, mesh.faces), noise)
    found = detect_boundary(U)
    assert len(found.loops) == 4
    matched = _match(found, truth)
    assert sorted(k for k, _ in matched) == [0, 1, 2, 3]  # one detected loop per true loop
    assert min(j for _, j in matched) >= 0.9  # measured 0.97 (noise 0.95)
    assert found.areas[0] > 0 and (found.areas[1:] < 0).all()
    _assert_walks_kept_edges(found)


@needs_data
@pytest.mark.parametrize("noise", [0.0, 0.1])
def test_peaks_with_seven_holes_gives_its_eight_true_loops(noise):
    mesh = read_points(DATA / "peaks_7holes_choi.ply")
    truth = _true_loops(mesh.faces)
    assert len(truth) == 8
    # A height field: its projection onto the xy plane is a map with the holes open (LSCM
    # shrinks these holes to a few spacings, where no rule on the map can see them).
    U = _noisy(mesh.points[:, :2].copy(), noise)
    found = detect_boundary(U)
    assert len(found.loops) == 8
    matched = _match(found, truth)
    assert sorted(k for k, _ in matched) == list(range(8))
    # The mesh's hole borders are jagged polygons edged with slivers, whose corner points any
    # Delaunay rule cuts off: judge each loop by its distance to the true one (measured at
    # most 1.7 median spacings).
    spacing = float(np.median(cKDTree(U).query(U, k=2)[0][:, 1]))
    for t, (k, _) in zip(truth, matched):
        loop = found.loops[k]
        gap = max(cKDTree(U[loop]).query(U[t])[0].max(), cKDTree(U[t]).query(U[loop])[0].max())
        assert gap < 2.5 * spacing
    assert found.areas[0] > 0 and (found.areas[1:] < 0).all()


# --------------------------------------------------------------------------- command line


_tiny = tiny_preset


@pytest.fixture
def tiny(monkeypatch):
    monkeypatch.setattr(boundary_command, "get_preset", _tiny)


@pytest.fixture
def no_training(monkeypatch):
    def forbidden(*args, **kwargs):
        raise AssertionError("parametrize was called although the input is invalid")

    monkeypatch.setattr(boundary_command, "parametrize", forbidden)


def _flat_cloud(tmp_path: Path) -> tuple[Path, np.ndarray, np.ndarray, np.ndarray]:
    """A flat sheared grid with a hole, lifted to z = 0.1 x, written as XYZ."""
    U, i, j = _sheared_grid(12, hole=(4, 6))
    P = np.column_stack([U, 0.1 * U[:, 0]])
    path = tmp_path / "sheet.xyz"
    np.savetxt(path, P)
    return path, U, i, j


def _write_map(path: Path, P: np.ndarray, uv: np.ndarray, **changes) -> Path:
    """A results file for cloud ``P`` holding the map ``uv``: a real (tiny) run's file, with
    ``changes`` applied to its fields."""
    result = parametrize(P, "free", config=_tiny("fast"), progress=False)
    return replace(result, uv=uv, **changes).save(path)


def test_cli_with_a_map_writes_the_loops(tmp_path, capsys):
    src, U, i, j = _flat_cloud(tmp_path)
    P = read_points(src).points
    map_path = _write_map(tmp_path / "map.npz", P, U)
    out = tmp_path / "loops.json"
    code = cli.main(["boundary", str(src), "--map", str(map_path), "--out", str(out),
                     "--plot", str(tmp_path / "loops.png")])
    stdout = capsys.readouterr().out
    assert code == 0
    doc = json.loads(out.read_text())
    assert doc["h"] is None and doc["n_points"] == len(U)
    # The 3 x 3 block's rim: 12 points, and its 4 corners (notches, carved with the cloud).
    assert [len(loop) for loop in doc["loops"]] == [44, 16]
    assert doc["loops"] == [loop.tolist() for loop in detect_boundary(U, points=P).loops]
    assert "2 boundary loop(s)" in stdout
    assert "loop 1 (outer): 44 points" in stdout
    assert "loop 2 (hole): 16 points" in stdout
    # Issue 39 item 3: every loop's evidence and kind, the gaps apart (none here).
    assert doc["kinds"] == ["outer", "hole"] and doc["gaps"] == doc["gap_evidence"] == []
    hole = doc["loop_evidence"][1]
    assert hole["kind"] == "hole" and 0.0 <= hole["confidence"] <= 1.0
    assert set(hole) == {"kind", "confidence", "perimeter", "perimeter_spacings",
                         "width_spacings", "roundness", "empty_spacings",
                         "sampling_empty_spacings", "empty_ratio", "normals_agree"}
    assert hole["empty_ratio"] >= 1.15 and hole["normals_agree"] == 1.0  # a flat sheet
    assert (tmp_path / "loops.png").read_bytes()[:8] == PNG_SIGNATURE

    code = cli.main(["boundary", str(src), "--map", str(map_path), "--out", str(out),
                     "--h", "100", "--json"])
    summary = json.loads(capsys.readouterr().out)
    assert code == 0
    assert summary["h"] == 100.0 and summary["n_loops"] == 1  # the convex hull
    assert json.loads(out.read_text())["h"] == 100.0


def test_cli_without_a_map_trains_first(tmp_path, capsys, tiny):
    src, U, _, _ = _flat_cloud(tmp_path)
    out = tmp_path / "loops.json"
    code = boundary_command.main([str(src), "--out", str(out), "--quiet", "--json"])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    summary = json.loads(captured.out)
    assert summary["map"] is None and summary["mapped_seconds"] > 0
    doc = json.loads(out.read_text())
    assert summary["n_loops"] == len(doc["loops"]) >= 1
    rows = np.concatenate([np.asarray(loop) for loop in doc["loops"]])
    assert rows.min() >= 0 and rows.max() < len(U)
    assert captured.err == ""  # --quiet: no progress bars


_fails = assert_cli_fails


def test_cli_bad_input_is_one_line_before_training(tmp_path, capsys, no_training):
    src, U, _, _ = _flat_cloud(tmp_path)
    out = tmp_path / "loops.json"
    before = {p.name for p in tmp_path.iterdir()}

    _fails(capsys, ["boundary", str(tmp_path / "missing.xyz"), "--out", str(out)],
           "missing.xyz: no such file")
    _fails(capsys, ["boundary", str(src), "--out", str(tmp_path / "loops.txt")],
           "loops.txt: output must have extension '.json', got '.txt'")
    _fails(capsys, ["boundary", str(src), "--out", str(out), "--plot", str(tmp_path / "p.jpg")],
           "p.jpg: output must have extension '.png'")
    for bad in ("0", "-1", "nan", "wide"):
        _fails(capsys, ["boundary", str(src), "--out", str(out), "--h", bad],
               f"argument --h: expected a positive number, got '{bad}'")
    for bad in ("-1", "inf", "thin"):
        _fails(capsys, ["boundary", str(src), "--out", str(out), "--min-width", bad],
               f"argument --min-width: expected a non-negative number, got '{bad}'")
    _fails(capsys, ["boundary", str(src), "--out", str(out), "--map", str(tmp_path / "m.json")],
           "m.json: map must have extension '.npz', got '.json'")
    _fails(capsys, ["boundary", str(src)], "the following arguments are required: --out")

    assert {p.name for p in tmp_path.iterdir()} == before  # nothing written


def test_cli_rejects_a_map_of_another_cloud_or_domain(tmp_path, capsys, monkeypatch):
    src, U, _, _ = _flat_cloud(tmp_path)
    P = read_points(src).points
    base = parametrize(P, "free", config=_tiny("fast"), progress=False)
    other = replace(base, uv=U[:-5], lambda_inv=base.lambda_inv[:-5]).save(
        tmp_path / "other.npz")  # fewer rows
    moved = replace(base, uv=U, fingerprint=fingerprint(P + [0.0, 0.0, 1e-3])).save(
        tmp_path / "moved.npz")  # as many rows, made from other points
    disk = replace(base, uv=U, domain=get_domain("disk")).save(tmp_path / "disk.npz")
    monkeypatch.setattr(boundary_command, "parametrize", None)  # no training from here on
    out = tmp_path / "loops.json"

    _fails(capsys, ["boundary", str(src), "--map", str(other), "--out", str(out)],
           f"map has {len(U) - 5} rows but {src} has {len(U)} points")
    _fails(capsys, ["boundary", str(src), "--map", str(moved), "--out", str(out)],
           "moved.npz: was made from another cloud than")
    _fails(capsys, ["boundary", str(src), "--map", str(disk), "--out", str(out)],
           "was trained onto the domain 'disk'; boundary detection needs a free-boundary map")
    _fails(capsys, ["boundary", str(src), "--map", str(tmp_path / "none.npz"), "--out",
                    str(out)], "none.npz: no such file")
    assert not out.exists()


def test_help_has_examples(capsys):
    assert cli.main(["boundary", "--help"]) == 0
    out = capsys.readouterr().out
    assert "examples:" in out and "--map scan_uv.npz" in out and "--h 0.02" in out
    assert "Loops of fewer than 8 points are dropped" in out


def test_cli_measures_hole_widths_on_the_points_a_denoised_map_was_made_of(tmp_path, capsys):
    src, U, _, _ = _flat_cloud(tmp_path)
    P = read_points(src).points
    fitted = P.copy()
    fitted[:, 2] += np.random.default_rng(0).normal(scale=0.3, size=len(P))  # not P's widths
    map_path = _write_map(tmp_path / "map.npz", P, U, fitted=fitted)
    out = tmp_path / "loops.json"
    assert cli.main(["boundary", str(src), "--map", str(map_path), "--out", str(out),
                     "--json"]) == 0
    widths = json.loads(capsys.readouterr().out)["hole_widths"]
    on_fitted = detect_boundary(U, points=fitted).to_dict()["widths"]
    assert widths == on_fitted != detect_boundary(U, points=P).to_dict()["widths"]


def test_cli_maps_with_the_files_normals_as_param_does(tmp_path, capsys):
    """Issue 39: without --map, boundary mapped the bare points (normals estimated) although
    'pcgeom param' maps with the file's normals; the same file must give the same loops
    with and without --map, and --normals ignore reads none."""
    _, U, _, _ = _flat_cloud(tmp_path)
    P = np.column_stack([U, 0.1 * U[:, 0]])
    N = np.tile(np.array([-0.1, 0.0, 1.0]) / np.hypot(0.1, 1.0), (len(P), 1))
    src = tmp_path / "oriented.xyz"
    np.savetxt(src, np.column_stack([P, N]))
    map_path = tmp_path / "oriented_uv.npz"
    assert cli.main(["param", str(src), "--out", str(map_path), "--quiet", "--json"]) == 0
    capsys.readouterr()

    loops, normals = {}, {}
    for label, extra in (("map", ["--map", str(map_path)]), ("own", []),
                         ("ignore", ["--normals", "ignore"])):
        out = tmp_path / f"{label}.json"
        assert cli.main(["boundary", str(src), "--out", str(out), "--quiet", "--json",
                         *extra]) == 0
        normals[label] = json.loads(capsys.readouterr().out)["normals"]
        loops[label] = json.loads(out.read_text())["loops"]
    assert normals == {"map": "input", "own": "input", "ignore": "estimated"}
    assert loops["own"] == loops["map"] and len(loops["own"]) == 2

    _fails(capsys, ["boundary", str(src), "--map", str(map_path), "--normals", "ignore",
                    "--out", str(tmp_path / "x.json")],
           "--normals applies only without --map (when the cloud is mapped here); a map's "
           "normals were chosen by 'pcgeom param --normals'")


def _torn_sheet() -> tuple[np.ndarray, np.ndarray]:
    """A sheared grid at z = 0.1 i with a round hole (radius 3.2 spacings), and its map torn
    open along a lens between two rows that the surface does not have (as the local-mesh map
    opens where a scan's rows jump)."""
    i, j = (a.ravel() for a in np.meshgrid(np.arange(30), np.arange(24), indexing="xy"))
    P = np.column_stack([i + 0.2 * j, j, 0.1 * i]).astype(np.float64)
    hole = np.linalg.norm(P[:, :2] - [22 + 0.2 * 16, 16], axis=1) < 3.2
    P, i, j = P[~hole], i[~hole], j[~hole]
    U = P[:, :2].copy()
    lens = np.clip(1 - np.abs(i - 9) / 5.0, 0, None) * (np.abs(j - 6.5) < 2)
    U[:, 1] += np.where(j >= 7, 1.0, -1.0) * lens
    return U, P


def test_a_tear_of_the_map_is_a_gap_and_the_hole_stays_a_hole():
    """Issue 39 item 3: the map's rule sees three loops; in 3D the tear has no empty circle
    wider than the sampling's (ratio 1.0, roundness 0.24) and the hole has (3.9, 0.84)."""
    U, P = _torn_sheet()
    every = detect_boundary(U, points=P, kinds=False)
    assert [len(loop) for loop in every.loops] == [104, 20, 14]
    judged = detect_boundary(U, points=P)
    assert judged.kinds() == ["outer", "hole"]
    assert set(every.loops[1]) < set(judged.loops[1])  # and the notches of its rim
    assert len(judged.gaps) == 1 and judged.gap_evidence[0]["kind"] == "gap"
    assert set(every.loops[2]) <= set(judged.gaps[0])  # the tear, spanned and set apart
    assert judged.gap_evidence[0]["empty_ratio"] < 1.15 < judged.evidence[1]["empty_ratio"]
    # The tear's triangles are kept: the surface spans it, so a reconstruction does too.
    tear = every.removed[np.isin(every.removed, every.loops[2]).all(axis=1)]
    kept = {tuple(t) for t in np.sort(judged.triangles, axis=1).tolist()}
    assert len(tear) and all(tuple(t) in kept for t in np.sort(tear, axis=1).tolist())
    doc = judged.to_dict()
    assert doc["gaps"] == [judged.gaps[0].tolist()] and doc["kinds"] == ["outer", "hole"]


def test_cli_every_loop_keeps_the_rules_loops(tmp_path, capsys):
    U, P = _torn_sheet()
    src = tmp_path / "torn.xyz"
    np.savetxt(src, P)
    map_path = _write_map(tmp_path / "map.npz", read_points(src).points, U)
    out = tmp_path / "loops.json"
    for extra, kinds, gaps in (([], ["outer", "hole"], 1),
                               (["--every-loop"], ["outer", "hole", "hole"], 0)):
        assert cli.main(["boundary", str(src), "--map", str(map_path), "--out", str(out),
                         "--json", *extra]) == 0
        summary = json.loads(capsys.readouterr().out)
        assert summary["kinds"] == kinds and summary["n_gaps"] == gaps, extra
        assert (summary["confidence"] is None) == bool(extra)
