"""pcgeom.mesh: the mesh primitives against hand-made meshes whose answers are known."""

from __future__ import annotations

import math

import numpy as np

from pcgeom.mesh import (boundary_loops, edge_ids, edge_sides, face_keys, half_edges, main_part,
                         one_fan, peel_rim, shoelace, signed_areas, unique_edges)


def _grid(n: int = 4):
    """An n x n grid of unit cells, two counter-clockwise triangles each."""
    idx = np.arange((n + 1) ** 2).reshape(n + 1, n + 1)
    x, y = np.meshgrid(np.arange(n + 1.0), np.arange(n + 1.0), indexing="xy")
    V = np.column_stack([x.ravel(), y.ravel()])
    F = []
    for i in range(n):
        for j in range(n):
            a, b, c, d = idx[i, j], idx[i, j + 1], idx[i + 1, j + 1], idx[i + 1, j]
            F += [[a, b, c], [a, c, d]]
    return V, np.array(F)


def test_areas_and_shoelace():
    V, F = _grid(3)
    A = signed_areas(V, F)
    np.testing.assert_allclose(A, 0.5)  # every triangle half a unit cell, counter-clockwise
    np.testing.assert_allclose(signed_areas(V, F[:, ::-1]), -0.5)
    square = np.array([[0, 0], [2, 0], [2, 1], [0, 1]], dtype=float)
    assert shoelace(square) == 2.0 and shoelace(square[::-1]) == -2.0


def test_edges_and_boundary():
    V, F = _grid(3)  # 16 vertices, 18 triangles, 33 edges, 12 on the boundary
    E = half_edges(F)
    assert E.shape == (54, 2) and (E[:18] == F[:, [0, 1]]).all()
    assert len(unique_edges(F)) == 33
    ids = edge_ids(E)
    assert ids.max() == 32 and (ids == edge_ids(E[:, ::-1])).all()
    _, boundary = edge_sides(F)
    assert boundary.sum() == 12
    (loop,) = boundary_loops(F)
    assert len(loop) == 12 and shoelace(V[loop]) == 9.0  # counter-clockwise, the whole square


def test_main_part_and_keys():
    V, F = _grid(2)
    corner = np.array([[8, 9, 10]])  # touches the grid at vertex 8 only
    main = main_part(np.vstack([F, corner]), 11)
    assert main[:9].all() and not main[9:].any()
    assert (face_keys(F, 9) == face_keys(F[:, [1, 2, 0]], 9)).all()
    assert len(np.unique(face_keys(F, 9))) == len(F)


def test_one_fan_keeps_the_largest_fan():
    _, F = _grid(2)  # the centre, vertex 4, has a closed fan of 6 triangles
    extra = np.array([[4, 20, 21], [4, 21, 22]])  # a second fan of two at the centre
    kept, dropped = one_fan(np.vstack([F, extra]))
    assert dropped == 2 and (kept == F).all()
    # Bowties only: the centre has one boundary edge leaving it, no bowtie; nothing goes.
    kept, dropped = one_fan(np.vstack([F, extra]), bowties_only=True)
    assert dropped == 0 and len(kept) == len(F) + 2
    # Corner 2 holds one grid triangle and a fan of two: two boundary edges leave it.
    pinned = np.array([[2, 30, 31], [2, 31, 32]])
    kept, dropped = one_fan(np.vstack([F, pinned]), bowties_only=True)
    assert dropped == 1 and [1, 2, 5] not in kept.tolist() and len(kept) == len(F) + 1


def test_peel_rim_drops_the_sliver_over_a_notch():
    V, F = _grid(2)
    V = V.copy()
    V[1] = [1.0, 0.2]  # the bottom side's middle point pushed in
    sliver = np.array([[0, 2, 1]])  # 0 -> 2 along the rim, 157 degrees at its apex 1
    for one in (True, False):
        kept, dropped = peel_rim(V, np.vstack([F, sliver]), rounds=5, one_per_vertex=one)
        assert dropped == 1 and (kept == F).all()
        (loop,) = boundary_loops(kept)
        assert 1 in loop  # the apex joined the rim
    # A wider threshold keeps it.
    kept, dropped = peel_rim(V, np.vstack([F, sliver]), math.radians(160.0))
    assert dropped == 0 and len(kept) == len(F) + 1


def test_fan_counts_and_parts_as_the_graphs_give_them():
    """The fans per vertex and the parts found by walking the half-edges' twins
    (:func:`pcgeom.mesh.fan_counts`, :func:`pcgeom.mesh.face_parts`) are those of the corner
    graph (:func:`pcgeom.mesh.corner_fans`) and libigl's ``facet_components``: a grid whose
    centre lost two opposite triangles (two open fans there), a closed octahedron pinched to
    a second one at a vertex (two closed fans), and a loose triangle."""
    import igl

    from pcgeom.mesh import corner_fans, face_parts, fan_counts, twins

    _, F = _grid(4)
    star = np.flatnonzero((F == 12).any(axis=1))
    grid = np.delete(F, star[[0, 3]], axis=0)
    octa = np.array([[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 1],
                     [5, 2, 1], [5, 3, 2], [5, 4, 3], [5, 1, 4]])
    twice = np.concatenate([octa, np.where(octa == 5, 5, octa + 6)])  # 5 pinched
    for mesh in (grid, twice, np.concatenate([grid, [[30, 31, 32]]])):
        twin, consistent = twins(mesh)
        assert consistent
        label = corner_fans(mesh, twin)
        fan_vertex = np.empty(label.max() + 1, dtype=np.int64)
        fan_vertex[label] = mesh.T.ravel()
        expected = np.bincount(fan_vertex, minlength=mesh.max() + 1)
        assert np.array_equal(fan_counts(mesh, twin), expected)
        count, parts = face_parts(mesh, twin)
        count0, parts0 = igl.facet_components(np.ascontiguousarray(mesh, dtype=np.int64))
        assert count == count0 and np.array_equal(parts, parts0)
    assert fan_counts(twice, twins(twice)[0])[5] == 2
    assert fan_counts(grid, twins(grid)[0])[12] == 2


def test_twin_pairs_are_each_shared_edge_s_two_triangles():
    """:func:`pcgeom.mesh.twin_pairs` against a loop over the edges: a grid that lost two
    triangles at its centre gives each edge two triangles share once, its halves opposite."""
    from pcgeom.mesh import twin_pairs

    _, F = _grid(4)
    F = np.delete(F, np.flatnonzero((F == 12).any(axis=1))[[0, 3]], axis=0)
    h1, h2 = twin_pairs(F)
    he, m = half_edges(F), len(F)
    expected = {}
    for h, (a, b) in enumerate(he.tolist()):
        expected.setdefault((min(a, b), max(a, b)), []).append(h)
    shared = sorted(tuple(hs) for hs in expected.values() if len(hs) == 2)
    assert sorted(zip(h1.tolist(), h2.tolist())) == shared
    assert (he[h1, 0] == he[h2, 1]).all() and (he[h1, 1] == he[h2, 0]).all()
    assert (h1 % m != h2 % m).all()
