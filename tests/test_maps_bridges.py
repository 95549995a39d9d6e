"""Bridges between sheets that nearly touch (pcgeom.maps.bridges): which triangles are
candidates, and the local mesh of the lips sheet with its normals cut of them."""

from __future__ import annotations

import numpy as np

from pcgeom.cloud import normalize
from pcgeom.maps.localmesh import local_mesh
from pcgeom.maps.bridges import bridge_candidates, cut_bridges
from pcgeom.maps.topology import repair
from pcgeom.synthetic_sheets import lips_sheet


def test_a_triangle_joining_opposite_sheets_is_a_candidate():
    """Two walls 0.75 apart whose normals face each other (as the lips'): the triangle with
    corners on both is a candidate, the triangles of one wall and of a plane are not."""
    N = np.array([[1.0, 0, 0], [1.0, 0, 0], [-1.0, 0, 0], [1.0, 0, 0],
                  [0, 0, 1.0], [0, 0.6, 0.8], [0, -0.6, 0.8]])
    F = np.array([[0, 1, 2], [0, 1, 3], [4, 5, 6]])
    assert bridge_candidates(N, F).tolist() == [True, False, False]
    assert bridge_candidates(N, F[:0]).shape == (0,)


def test_nothing_is_cut_without_a_handle():
    """A mesh whose repair leaves no handle keeps its candidates (the pleats' tight folds
    turn by more than a right angle within a triangle)."""
    N = np.array([[1.0, 0, 0], [1.0, 0, 0], [-1.0, 0, 0]])
    X = np.array([[0.0, 0, 0], [0, 1.0, 0], [0.75, 0.5, 0]])
    F = np.array([[0, 1, 2]])
    faces, topology = cut_bridges(X, N, F, repair)
    assert topology.genus == 0 and topology.bridges_cut == 0
    assert np.array_equal(faces, repair(X, N, F)[0])


def test_the_lips_sheets_bridges_are_cut_with_its_normals():
    """The lips sheet (walls 0.75 spacings apart) with its true normals: its repaired local
    mesh has a handle; cut of its bridges (cut_bridges) it has fewer and the topology says
    how many went; built with bridges=True (the triangles that turn from their normals
    dropped first, then the cut) fewer handles and about half the triangles joining
    opposite sheets are left."""
    s = lips_sheet(3000, gap=0.75)
    Xn, _, _ = normalize(s.points)
    today = local_mesh(Xn, s.normals, 24)
    assert today.topology.bridges_cut == 0 and today.topology.genus >= 1
    assert bridge_candidates(s.normals, today.faces).any()

    _, cut_topology = cut_bridges(Xn, s.normals, today.faces, repair)
    assert 0 < cut_topology.bridges_cut and cut_topology.genus < today.topology.genus
    cut = local_mesh(Xn, s.normals, 24, bridges=True)
    assert cut.topology.genus < today.topology.genus
    # (the repair's fills may join opposite normals again, a few)
    left = bridge_candidates(s.normals, cut.faces).sum()
    assert left < 0.6 * bridge_candidates(s.normals, today.faces).sum()


def test_runs_cut_bridges_when_the_cloud_has_normals():
    """mesh_cloud drops the lips sheet's triangles that turn from its normals and cuts its
    bridges when it has normals (BRIDGES_WITH_INPUT_NORMALS): fewer handles; asked not to,
    it cuts none."""
    from pcgeom.maps.localmesh import mesh_cloud

    s = lips_sheet(3000, gap=0.75)
    Xn, _, _ = normalize(s.points)
    _, _, record = mesh_cloud(Xn, s.normals, 24, 16, progress=False, onto=None)
    _, _, kept = mesh_cloud(Xn, s.normals, 24, 16, progress=False, onto=None, bridges=False)
    assert kept["topology"]["bridges_cut"] == 0
    assert record["genus"] < kept["genus"]


def test_well_shaped_triangles_that_turn_from_their_normals_are_dropped():
    """bridges.disagreeing: a well-shaped triangle whose normal makes more than 60 degrees
    with a corner's normal goes; one within, or a sliver, stays."""
    from pcgeom.maps.bridges import disagreeing

    X = np.array([[0.0, 0, 0], [1, 0, 0], [0.5, 0.8, 0], [0, 0, 0.01], [2, 0, 0]])
    F = np.array([[0, 1, 2], [0, 1, 2], [0, 4, 3]])
    up = np.tile([0.0, 0, 1], (5, 1))
    tilted = up.copy()
    tilted[2] = [np.sin(1.2), 0, np.cos(1.2)]  # 69 degrees off the first triangle's normal
    assert not disagreeing(X, up, F[:1]).any()
    assert disagreeing(X, tilted, F[:1]).all()
    side = np.tile([0.0, 0, 1], (5, 1))  # the sliver (0, 4, 3) faces -y: 90 degrees off
    assert not disagreeing(X, side, F[2:]).any()


def test_the_arc_signs_orient_the_walls_of_a_thin_fold():
    """Exact normal lines with random signs, oriented along a spanning tree, come out the
    wrong way in patches where the walls 0.75 spacings apart face each other; signed as a
    whole by the arc relation, far fewer do, and the pairs across the gap agree."""
    from pcgeom.maps.normals import arc_relation, arc_signs, orient_normals
    from pcgeom.neighbours import Neighbours

    s = lips_sheet(11000, gap=0.75, seed=0)
    X, _, _ = normalize(s.points)
    lines = s.normals * np.random.default_rng(0).choice([-1.0, 1.0], len(X))[:, None]
    knn = Neighbours.of(X, 16)
    tree = orient_normals(X, lines, 16, knn=knn)
    whole = tree * arc_signs(X, tree, knn.first(16)[1])[:, None]

    def wrong(N):
        w = np.einsum("nd,nd->n", N, s.normals) < 0
        return int(min(w.sum(), (~w).sum()))

    assert wrong(tree) > 300  # measured 468
    assert wrong(whole) < 0.4 * wrong(tree)  # measured 112
    # The true normals across the gap read as agreeing, as Hoppe's dot product does not.
    _, _, d = arc_relation(X, s.normals, knn.first(16)[1])
    _, _, hoppe = arc_relation(X, s.normals, knn.first(16)[1], arc=0.0)
    assert (d < 0).sum() < 0.4 * (hoppe < 0).sum()  # measured 2876 against 12691



def test_the_cut_rounds_run_only_where_the_mesh_shows_a_bridge():
    """shows_bridges: a grid's mesh with its upward normals shows none; one corner's normal
    turned down shows one. A bare smooth sheet then maps without the cut rounds (no scores
    recorded), bare grooves 1.5 spacings apart with them."""
    import warnings

    import pcgeom
    from pcgeom.maps.bridges import shows_bridges
    from pcgeom.synthetic_folds import deep_folds

    g = np.stack(np.meshgrid(np.arange(6.0), np.arange(6.0)), -1).reshape(-1, 2)
    X = np.column_stack([g, np.zeros(len(g))])
    F = np.array([[i, i + 1, i + 7] for i in range(29) if i % 6 < 5]
                 + [[i, i + 7, i + 6] for i in range(29) if i % 6 < 5])
    N = np.tile([0.0, 0.0, 1.0], (len(X), 1))
    assert not shows_bridges(X, N, F)
    N[14] = -N[14]
    assert shows_bridges(X, N, F)

    fast = pcgeom.get_preset("fast")
    rng = np.random.default_rng(0)
    xy = rng.uniform(-1, 1, (2000, 2))
    sheet = np.column_stack([xy, 0.3 * np.sin(2 * xy[:, 0]) * np.cos(xy[:, 1])])
    grooves = deep_folds(2500, gap=1.5, depths=(4.0, 8.0), sampling="uniform", seed=0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        flat = pcgeom.parametrize(sheet, config=fast, seed=0, progress=False)
        folded = pcgeom.parametrize(grooves.points, config=fast, seed=0, progress=False)
    record = next(r for r in flat.history if "cut_kept" in r)
    assert record["cut_scores"] == [] and not record["cut_kept"]
    record = next(r for r in folded.history if "cut_kept" in r)
    assert len(record["cut_scores"]) >= 2
