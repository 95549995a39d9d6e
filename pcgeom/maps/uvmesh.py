"""The local mesh built again from its free map: a Delaunay triangulation in the map's plane,
kept where it is one of the surface (not in the paper).

The local mesh's fans leave false holes where they disagree, whose outlines cross themselves
in the map (the mesh round them overlaps itself) or run through pinched vertices, and local
fills in space do not close them. A first free map that is nearly one-to-one already says
which points are neighbours on the surface, so the mesh is built again from it:

1. **Plane.** The points are Delaunay-triangulated at their map positions ``u_i`` (each
   triangle counter-clockwise in the map). A triangulation of points in the plane is a disk:
   no handle, no pinch, no hole.
2. **Surface.** A triangle is kept where it is one of the surface's: its smallest enclosing
   circle in space (:func:`pcgeom.maps.topology.enclosing_radius`) no wider, in local
   spacings, than the repair's bound (:data:`pcgeom.maps.topology.HOLE_MARGIN` times the
   widest empty circle the mesh's own triangles show, :func:`pcgeom.maps.topology.
   widest_empty`), and facing every corner's normal (``n_t . n_i > 0``, ``n_t`` its normal in
   space in the map's counter-clockwise order: where the map turns a flap over, or a
   triangle would join two sheets, it does not). A hole of the surface narrower than that
   bound leaves, among the kept triangles, a round part whose circles are emptier than the
   sampling leaves: the parts of at least :data:`PART_MIN` triangles whose empty circle
   (:func:`pcgeom.maps.fills._empty_radius`) is wider than :data:`pcgeom.maps.fills.
   REFILL_WIDTH` times the bound are dropped when round (``4 pi A / P^2`` at least
   :data:`ROUND`, as :mod:`pcgeom.apps.loop_kinds` tells a hole from a gap along a row of
   the sampling, which is long).
3. **Topology.** The open mesh's repair (:func:`pcgeom.maps.topology.repair`'s fills,
   re-meshes, pinches' mend, regions re-triangulated and slits filled) with its fill pass
   under the same empty-circle rule.
4. **Grow.** Where the first map folded (a flap over the flat), step 2 leaves a slit; mapped
   on the new mesh it opens. The Delaunay triangles of the new map (every point, those the
   mesh left out at their interpolated places), filtered as in step 2, are grown into the
   new mesh's holes from their rims (:func:`grow_into_holes`), and step 3 follows again.

:func:`remeshed` is the step as :func:`pcgeom.maps.free.free_start` takes it
(``LocalMeshConfig.uv_remesh``): the mesh built, mapped, grown and mapped again, and kept
when it has fewer boundary loops and maps better on its own mesh.
"""

from __future__ import annotations

import numpy as np

from ..mesh import cross3, edge_ids, edge_sides, half_edges, main_part, signed_areas
from .topology import HOLE_MARGIN, enclosing_radius, knn_spacing, widest_empty

__all__ = ["uv_faces", "uv_mesh", "grow_into_holes", "remeshed", "UV_UNMESHED"]

ROUND = 0.3
"""Step 2: a part of triangles with circles emptier than the sampling leaves is a hole when
its roundness ``4 pi A / P^2`` is at least this (:data:`pcgeom.apps.loop_kinds.
HOLE_ROUNDNESS`, measured there on the maps' loops)."""

EMPTY = 0.75
"""Step 2: a triangle's circle is emptier than the sampling leaves when its empty circle
(:func:`pcgeom.maps.fills._empty_radius`) is wider than this times the bound."""

PART_MIN = 4
"""... and it has at least this many triangles (a hole of radius 1.5-2 spacings spans 10 or
more; on random samples, lone empty triangles: with 1, the uniform holed sheet, 6000
points, seed 2, kept 3 false loops, with 4 one, as the local mesh)."""


def uv_faces(X: np.ndarray, uv: np.ndarray, normals: np.ndarray, points: np.ndarray,
             h: np.ndarray, bound: float, *, cloud=None, rim: np.ndarray | None = None
             ) -> np.ndarray:
    """Steps 1-2: the Delaunay triangles of ``uv[points]`` (rows of ``X``, counter-clockwise
    in the map) no wider in space than ``bound`` local spacings ``h`` (enclosing radius over
    the corners' mean spacing), facing every corner's normal, and, with ``cloud`` (the k-d
    tree of the cloud's points), not in a round part of empty circles (:func:`_round_parts`).
    (M, 3) int64."""
    from scipy.spatial import Delaunay

    points = np.asarray(points, dtype=np.int64)
    if len(points) < 3:
        return np.zeros((0, 3), dtype=np.int64)
    F = points[Delaunay(uv[points]).simplices]
    turned = signed_areas(uv, F) < 0
    F[turned] = F[turned][:, [0, 2, 1]]
    scale = np.maximum(h[F].mean(axis=1), 1e-300)
    width = enclosing_radius(X, F) / scale
    cross = cross3(X[F[:, 1]] - X[F[:, 0]], X[F[:, 2]] - X[F[:, 0]])
    facing = (np.einsum("md,mkd->mk", cross, normals[F]) > 0).all(axis=1)
    ok = (width <= bound) & facing
    if cloud is not None:
        from .fills import _empty_radius

        empty = np.zeros(len(F), dtype=bool)
        empty[ok] = _empty_radius(X, F[ok], cloud) / scale[ok] > EMPTY * bound
        if rim is not None:  # across a loop of the mesh the map came from
            empty |= ok & rim[F].all(axis=1)
        ok &= ~_round_parts(X, F, empty, cross)
    return F[ok]


def _round_parts(X: np.ndarray, F: np.ndarray, chosen: np.ndarray, cross: np.ndarray
                 ) -> np.ndarray:
    """(M,) bool: the ``chosen`` triangles of the edge-connected parts of them of at least
    :data:`PART_MIN` triangles whose roundness ``4 pi A / P^2`` (``A`` their area, ``P`` their
    outline's length, in space; ``cross``: each triangle's edge cross product) is at least
    :data:`ROUND`."""
    import scipy.sparse as sp
    from scipy.sparse.csgraph import connected_components

    out = np.zeros(len(F), dtype=bool)
    idx = np.flatnonzero(chosen)
    if not len(idx):
        return out
    G = F[idx]
    m = len(G)
    he = half_edges(G)
    ids = edge_ids(he)
    n_edges = int(ids.max()) + 1
    incidence = sp.csr_matrix((np.ones(3 * m), (np.tile(np.arange(m), 3), ids)),
                              shape=(m, n_edges))
    _, label = connected_components(incidence @ incidence.T, directed=False)
    length = np.linalg.norm(X[he[:, 1]] - X[he[:, 0]], axis=1)
    rim = np.bincount(ids, minlength=n_edges)[ids] == 1
    A = np.bincount(label, weights=0.5 * np.linalg.norm(cross[idx], axis=1))
    P = np.bincount(np.tile(label, 3)[rim], weights=length[rim], minlength=len(A))
    hole = ((4.0 * np.pi * A / np.maximum(P * P, 1e-300) >= ROUND)
            & (np.bincount(label) >= PART_MIN))
    out[idx[hole[label]]] = True
    return out


def grow_into_holes(F: np.ndarray, other: np.ndarray, n: int, rounds: int = 8) -> np.ndarray:
    """``F`` with the triangles of ``other`` (oriented alike) that attach to its rim added,
    round by round (up to ``rounds``): a triangle is added when one of its edges is a rim
    edge of the mesh taken the other way, none of its corners is inside the mesh (each on
    the rim or not yet meshed: no triangle over the mesh) and none of its directed edges is
    taken; of two that want one edge, the first in ``other``'s order."""
    from .localmesh import _greedy_claims

    he = half_edges(F)
    keys = np.sort(he[:, 0] * n + he[:, 1])
    other = other[~_among(other * n + np.roll(other, -1, axis=1), keys).any(axis=1)]
    for _ in range(rounds):
        if not len(other):
            break
        he = half_edges(F)
        keys = np.sort(he[:, 0] * n + he[:, 1])
        rim = he[~_among(he[:, 1] * n + he[:, 0], keys)]
        rim_keys = np.sort(rim[:, 0] * n + rim[:, 1])
        free = np.ones(n, dtype=bool)
        free[F.ravel()] = False
        free[rim[:, 0]] = True
        edges = other * n + np.roll(other, -1, axis=1)
        twin = np.roll(other, -1, axis=1) * n + other
        ok = (free[other].all(axis=1) & _among(twin, rim_keys).any(axis=1)
              & ~_among(edges, keys).any(axis=1))
        if not ok.any():
            break
        found = other[ok]
        added = found[_greedy_claims(found * n + np.roll(found, -1, axis=1))]
        F = np.concatenate([F, added])
        other = other[~ok]
    return F


def _among(values: np.ndarray, ordered: np.ndarray) -> np.ndarray:
    """``np.isin(values, ordered)`` for ``ordered`` sorted, by a binary search."""
    if not len(ordered):
        return np.zeros(values.shape, dtype=bool)
    at = np.minimum(np.searchsorted(ordered, values), len(ordered) - 1)
    return ordered[at] == values


def _repair(X: np.ndarray, normals: np.ndarray, F: np.ndarray, h: np.ndarray, bound: float, *,
            exclude: np.ndarray | None, tree):
    """Step 3: the open mesh's repair (:func:`pcgeom.maps.topology.repair`) with the fill
    pass's fills under the re-meshes' empty-circle rule (no triangle leaving an empty circle
    wider than :data:`pcgeom.maps.fills.REFILL_WIDTH` times the bound: with the repair's
    own, peaks_7holes_choi's map lost two of its seven holes). The faces and their
    :class:`pcgeom.maps.topology.Topology`."""
    from . import topology as tp
    from .fills import REFILL_WIDTH, refill_small_loops
    from .pinches import mend_pinches
    from .topology_batch import CloudTree, KnownTwins

    known = KnownTwins()
    found: dict = {}
    before, pinched_before = tp._measure(F, found, known.of, fans_of=known.fans,
                                           parts_of=known.parts)
    trees = CloudTree(X, exclude, tree)
    loops = tp.simple_loops(F, found.get("twin"))
    F, filled, _, _ = tp._fill_pass(X, normals, F, h, bound, exclude, loops=loops,
                                     empty=REFILL_WIDTH, found=found, cloud=trees)
    memo = tp.FILLS.bind(X, exclude, h)
    F, refilled = refill_small_loops(X, normals, F, h, bound, exclude, cloud=trees,
                                     twins_of=known.of, memo=memo)
    filled += refilled
    if tp.PINCH_MEND:
        F, mended = mend_pinches(X, normals, F, h, bound, exclude, cloud=trees,
                                 twins_of=known.of, memo=memo, fans_of=known.fans)
        filled += mended
    after = tp._measure(F, None, known.of, fans_of=known.fans, parts_of=known.parts)
    if tp.REGIONS and after[0]["genus"] == 0 and after[0]["boundary_loops"] > 1:
        relaid_faces, relaid = tp.retriangulate_regions(X, normals, F, h, bound, exclude,
                                                        cloud=trees, twins_of=known.of,
                                                        fans_of=known.fans,
                                                        parts_of=known.parts)
        relaid_faces, slits = tp.fill_slits(X, normals, relaid_faces, h, bound, exclude,
                                            cloud=trees)
        if relaid or slits:
            F, filled = relaid_faces, filled + relaid + slits
            after = tp._measure(F, None, known.of, fans_of=known.fans, parts_of=known.parts)
    return F, tp._topology(before, pinched_before, *after, filled, 0)


def uv_mesh(X: np.ndarray, uv: np.ndarray, normals: np.ndarray, mesh, *,
            exclude: np.ndarray | None = None, spacing: np.ndarray | None = None,
            grow: bool = False):
    """The local mesh ``mesh`` (:class:`pcgeom.maps.localmesh.LocalMesh`) built again from
    the map ``uv`` (N, 2): steps 1-3 of the module on its main part's points, or, with
    ``grow``, step 4 (the mesh's main part grown with the triangles of every point not in
    ``exclude``, then step 3). A :class:`~pcgeom.maps.localmesh.LocalMesh` with ``mesh``'s
    own normals (:attr:`~pcgeom.maps.localmesh.LocalMesh.normals`); ``spacing``: each
    point's local spacing (:func:`pcgeom.maps.topology.knn_spacing`), when known."""
    from scipy.spatial import cKDTree

    from .localmesh import LocalMesh

    n = len(X)
    h = knn_spacing(X) if spacing is None else np.asarray(spacing, dtype=np.float64)
    width = enclosing_radius(X, mesh.faces) / np.maximum(h[mesh.faces].mean(axis=1), 1e-300)
    bound = HOLE_MARGIN * widest_empty(width)
    inlier = np.ones(n, dtype=bool) if exclude is None else ~np.asarray(exclude, dtype=bool)
    tree = cKDTree(X[inlier])
    points = np.flatnonzero((inlier if grow else mesh.main) & np.isfinite(uv).all(axis=1))
    edges, on_rim = edge_sides(mesh.faces[mesh.main[mesh.faces].all(axis=1)])
    rim = np.zeros(n, dtype=bool)
    rim[edges[on_rim].ravel()] = True
    F = uv_faces(X, uv, normals, points, h, bound, cloud=tree, rim=rim)
    if grow:
        F = grow_into_holes(mesh.faces[mesh.main[mesh.faces].all(axis=1)], F, n)
    faces, topology = _repair(X, normals, F, h, bound, exclude=exclude, tree=tree)
    return LocalMesh(faces=faces, main=main_part(faces, n),
                     boundary_edges=int(edge_sides(faces)[1].sum()), candidates=len(F),
                     topology=topology, normals=mesh.normals)


UV_UNMESHED = 0.02
"""The share of the points the mesh built again from the map (:func:`remeshed`) may leave
out of its main part beyond those the kept mesh leaves out (more, and it is not kept): the
lips sheet with its normals (11k, walls 0.75 spacings apart) leaves 119 points out, 23
before (0.9%), and maps its true triangles better (0.0273 -> 0.0241 rad, 0.73 -> 0.72%
flipped); where the first map folds over a flap, the mesh loses the flap
(face_human_choi bare: its first mesh from the map leaves 824 points out, 4.8%: not
mapped, twice this share being the bound there)."""


def remeshed(Xn: np.ndarray, kept: tuple, solve, *, outlier: np.ndarray, record: dict
                 ) -> tuple:
    """The local mesh built again from the kept map (:func:`pcgeom.maps.uvmesh.uv_mesh`),
    mapped, grown into its holes from that map (step 4 there) and mapped again;
    ``(uv, mesh, stats)`` of that map when its mesh has fewer boundary loops than the kept
    one, it scores better on its own mesh (:func:`pcgeom.maps.free._score_above`: flips
    beyond :data:`pcgeom.maps.free.VOTE_ALLOW`, then angle) and it leaves at most
    :data:`UV_UNMESHED` more points out; ``kept``'s (``(uv, mesh, normals, stats)``)
    otherwise, as soon as a step shows it will not be (the first mesh no open surface, no
    fewer loops or twice as many points out; its map no better). ``record`` receives
    ``uv_remesh``: ``kept``, and the meshes' ``loops``, ``unmeshed`` and ``scores``
    (``[flips, angle]``), the kept mesh's first."""
    from .free import VOTE_ALLOW, _map_score, _score_above
    from .localmesh import MIN_MESHED, topology_record

    uv, mesh, normals, stats = kept
    if mesh.topology is None:
        return uv, mesh, stats
    allow = VOTE_ALLOW * mesh.n_faces
    scores = [_map_score(Xn, mesh, uv)]
    out = {"kept": False, "loops": [mesh.topology.boundary_loops],
           "unmeshed": [int((~mesh.main).sum())], "scores": scores}
    record["uv_remesh"] = out

    def fits(again, share: float = UV_UNMESHED) -> bool:
        out["loops"].append(again.topology.boundary_loops)
        out["unmeshed"].append(int((~again.main).sum()))
        return (again.main.mean() >= MIN_MESHED and not again.looks_closed
                and again.topology.boundary_loops < mesh.topology.boundary_loops
                and (~again.main).sum() <= (~mesh.main).sum() + share * len(Xn))

    again = uv_mesh(Xn, uv, normals, mesh, exclude=outlier)
    if not fits(again, 2.0 * UV_UNMESHED):
        return uv, mesh, stats
    uv_again, stats_again = solve(again)
    scores.append(_map_score(Xn, again, uv_again))
    if _score_above(scores[-1], allow) >= _score_above(scores[0], allow):
        return uv, mesh, stats
    grown = uv_mesh(Xn, uv_again, normals, again, exclude=outlier, grow=True)
    if not fits(grown):
        return uv, mesh, stats
    uv_grown, stats_grown = solve(grown)
    scores.append(_map_score(Xn, grown, uv_grown))
    if _score_above(scores[-1], allow) >= _score_above(scores[0], allow):
        return uv, mesh, stats
    out["kept"] = True
    record.update(faces=grown.n_faces, boundary_edges=grown.boundary_edges,
                  unmeshed=int((~grown.main).sum()), **topology_record(grown.topology))
    return uv_grown, grown, stats_grown
