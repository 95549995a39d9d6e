"""The local mesh of a cloud: a manifold mesh of same-sheet tangent fans (not in the paper).

The networks of the paper decide a cloud's global layout from positions alone. Where a scan's
surface doubles back closer than its point spacing, positions cannot tell the sheets apart and
the networks lay a flap of the surface folded onto the other sheet; local refinement steps
cannot unfold it (DESIGN.md, "What limits real scans"). Oriented normals can, and a global
linear solve over a mesh of same-sheet neighbourhoods uses them everywhere at once (the free
map of :mod:`pcgeom.maps.free`, the disk and domain maps after it):

1. **Same-sheet neighbours.** Each point keeps those of its ``k`` nearest neighbours whose
   normal points to the same side as its own (``n_i . n_j > 0``).
2. **Tangent fans.** They are projected on the point's tangent plane and Delaunay-triangulated;
   the triangles at the point form its fan (its star in the local Delaunay triangulation).
3. **Manifold merge.** The fans' triangles are oriented by the normals and added greedily, the
   ones most fans agree on first, then the better-shaped: a triangle is kept only if each of its
   edges stays in at most two triangles, with opposite directions. The result is edge-manifold
   and consistently oriented. (LSCM over the plain union of the fans folds: DESIGN.md.)
4. **Topology.** The mesh is repaired (:mod:`pcgeom.maps.topology`). Its bridges between
   sheets that nearly touch are cut where that lowers the repaired mesh's genus, and
   before that the lids of one-sided stars (an edge only one end's fan made, whose ends no
   short path of edges both ends' fans made joins: :func:`pcgeom.maps.bridges.one_sided`)
   and well-shaped triangles that turn from a corner's normal by more than 60 degrees
   dropped (:mod:`pcgeom.maps.bridges`), when the cloud came with its normals
   (:data:`BRIDGES_WITH_INPUT_NORMALS`; ``local_mesh(..., bridges=True)`` asks for it).

:func:`mesh_cloud` is the whole step as a run takes it: outliers flagged, the surface test,
normals estimated and oriented when the cloud has none (:mod:`pcgeom.maps.normals`), the mesh,
and the tests that it is one open surface. The rest of the module is the mesh's bookkeeping
that the maps share (main part, submesh, vertex-manifold cleaning, boundary loops).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..mesh import (RIM_ANGLE, edge_sides, face_keys, main_part, opposite_corners,
                    shape_quality, signed_areas)
from ..neighbours import (Neighbours, adaptive_pca, find_outliers, local_pca, scale_ladder,
                          surface_variation)
from ..progress import Progress
from .bridges import cut_bridges, disagreeing, one_sided
from .normals import orient_normals
from .topology import PLANAR_CLOSED, SPACING_NEIGHBOURS, Topology, repair, require_open
from .topology_batch import FILLS

__all__ = ["LocalMesh", "local_mesh", "mesh_cloud", "mesh_flips", "mesh_normals", "place_rest",
           "standing",
           "topology_record", "BRIDGES_WITH_INPUT_NORMALS", "CLOSED_SURFACE", "MIN_MESHED",
           "NOT_A_SURFACE", "PLACE_WITH_INPUT_NORMALS"]

BRIDGES_WITH_INPUT_NORMALS = True
""":func:`mesh_cloud` cuts the bridges between sheets (:mod:`pcgeom.maps.bridges`) of a cloud
that came with its normals, and not of a bare one. Measured side by side (``fast`` onto free,
benchmarks/bench_bridges.py): the rounded lips sheet with its normals better at all nine
samplings (3k-11k points; 11k, three seeds: 2.04-2.29x libigl LSCM on the true mesh ->
1.06-1.32x, flipped 1.04-1.13% -> 0.87-1.03%), the pleats and the shared surfaces with
normals unchanged (no handle, nothing cut); on bare clouds the estimated normals of walls
that nearly touch are turned the wrong way in patches, and the cut cost the pleats
(0.026 -> 0.068 rad); the lids of one-sided stars (:func:`pcgeom.maps.bridges.one_sided`,
5 hops), measured bare, cost the pleat 1.5 spacings wide (0.0154 -> 0.0178 rad, 0.32 ->
0.43% flipped). (Those figures are with the lips sheet's normals of before 2026-12-05, up
to 60 degrees off on the mouth's walls. With its true normals the rule,
now with the triangles that turn from their normals dropped first
(:func:`pcgeom.maps.bridges.disagreeing`), gives 0.90x / 1.23x / 1.01x LSCM, 0.87 / 0.83 /
0.68% flipped at 11k, seeds 0-2; without the drop 1.23x / 2.09x / 1.22x, 0.92 / 1.09 /
0.81%.) A bare cloud whose kept mesh has handles gets its normals signed again as a whole
and a mesh with its bridges cut (:data:`pcgeom.maps.free.ARC_ORIENT`), kept when it maps
better; and every bare cloud's kept normals a mesh with its bridges cut, rebuilt from its own
vertex normals (:data:`pcgeom.maps.free.CUT_ROUNDS`), kept when it maps better: the
estimated normals of today (adaptive scale, vote, normal rounds) are seldom turned, and the
cut no longer costs the pleats."""

PLACE_WITH_INPUT_NORMALS = True
"""The free map places the points outside the local mesh's main part by an affine fit to
their same-sheet neighbours (:func:`_interpolate_rest` with normals) when the cloud came with
its normals, not with estimated ones: measured side by side (``fast``, true triangles,
2026-12-05), face_human_choi bare went from 2.46 to 2.53% flipped onto free with it (its
PCA normals turned the wrong way in patches), with its mesh's normals from 0.129 to 0.088%
(0.0229 -> 0.0222 rad)."""

MIN_MESHED = 0.5
"""The smallest share of the points the local mesh's main part must hold."""

MAX_VARIATION = 0.15
"""Largest median surface variation (:func:`pcgeom.neighbours.surface_variation`) of a surface at
:data:`SURFACE_NEIGHBOURS` neighbours; a volume of random points gives about 0.19, a smooth
scan below 0.01, and face_human_choi with noise of half its mean edge length 0.12."""

SURFACE_NEIGHBOURS = 16
"""Neighbours of the surface test's PCA."""

FLAT_VARIATION = 0.03
"""... or largest median surface variation at each point's own scale
(:func:`pcgeom.neighbours.adaptive_pca`): a surface whose sheets come within a couple of spacings
fails the test at 16 neighbours (a pleat with sheets 1.5 spacings apart: 0.23) but is flat at
its points' own scales (0.000); a volume of random points is not (0.087: a few of its points
are never flat)."""

NOT_A_SURFACE = ("the cloud does not look like one sampled surface (its points fill a volume, "
                 "or most are strays); check the input")

CLOSED_SURFACE = PLANAR_CLOSED.format(domain="free")
"""The message of the :class:`InputError` for a closed genus-0 surface onto the free boundary
(:func:`pcgeom.maps.topology.closed_message` gives it for any domain and genus)."""


@dataclass(frozen=True, eq=False)
class LocalMesh:
    """A manifold triangle mesh over a cloud, built from its points and oriented normals."""

    faces: np.ndarray
    """(M, 3) int64, consistently oriented (counter-clockwise seen from the normals' side)."""
    main: np.ndarray
    """(N,) bool: the point is a vertex of the mesh's largest connected part."""
    boundary_edges: int
    """Edges of the whole mesh that belong to one triangle only."""
    candidates: int
    """Distinct triangles the fans proposed."""
    topology: Topology | None = None
    """The topology of the mesh's largest part and its repairs (:mod:`pcgeom.maps.topology`;
    None for a mesh not built by :func:`local_mesh`)."""
    pinch_fans: np.ndarray | None = None
    """(K, 3) the triangles the repair dropped as the smaller fans of pinched vertices
    (:func:`pcgeom.maps.topology.drop_smaller_fans`); the normal rounds count their flips."""
    normals: np.ndarray | None = None
    """(N, 3) the cloud's own unit normals (strays' rows zero), set by :func:`mesh_cloud`
    when the cloud came with them (:data:`PLACE_WITH_INPUT_NORMALS`): the free map places
    the points outside the main part from same-sheet neighbours (:func:`_interpolate_rest`).
    None: from the nearest meshed points."""

    @property
    def n_faces(self) -> int:
        return len(self.faces)

    @property
    def looks_closed(self) -> bool:
        """The repaired mesh's largest part has no boundary loop (:attr:`topology`): the cloud
        samples a closed surface. A mesh without a topology: no boundary edge."""
        if self.topology is not None:
            return self.topology.closed
        return self.boundary_edges == 0


STANDING_QUALITY = 0.05
"""Triangles of worse shape quality than this are not tested for standing (:func:`standing`):
a sliver's plane says nothing of the surface (collinear rim points of a grid: the
three peaks' 30 x 30 grid lost 17 rim slivers of quality 0.0004-0.005 at ``facing`` 0.2, and
its disk map turned 3 true triangles over on the rim)."""

_MIN_QUALITY = 1e-4
"""Triangles of worse shape quality (1: equilateral, 0: degenerate) are never kept."""


def _tangent_basis(n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors spanning the plane orthogonal to each unit ``n`` (N, 3)."""
    helper = np.where(np.abs(n[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    a = np.cross(n, helper)
    a /= np.linalg.norm(a, axis=1, keepdims=True)
    return a, np.cross(n, a)


def _fans(X: np.ndarray, normals: np.ndarray, neighbours: int, progress: bool,
          chunk: int = 50_000, knn: Neighbours | None = None) -> np.ndarray:
    """Triangles of every point's Delaunay star among its same-sheet neighbours (``knn``:
    the points' nearest points, when already found)."""
    nb = (knn if knn is not None else Neighbours.of(X, neighbours)).first(neighbours)[1]
    starts = range(0, len(X), chunk)
    blocks = []
    with Progress(len(starts), "local mesh", enabled=progress, unit="block") as bar:
        for s in starts:
            blocks.append(_stars(X, normals, nb[s:s + chunk], np.arange(s, min(s + chunk, len(X)))))
            bar.update()
    return np.concatenate(blocks).astype(np.int64)


def _circular_neighbours(alive: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For each slot of each row, the previous and the next alive slot in circular order
    (positions in the row doubled: ``< k`` is one lap back, ``>= k`` one lap on; ``-1`` and
    ``>= 2k`` where there is none)."""
    k = alive.shape[1]
    cols = np.arange(k)[None, :]
    before = np.concatenate([np.where(alive, cols, -1), np.where(alive, cols + k, -1)], axis=1)
    prev = np.maximum.accumulate(before, axis=1)[:, k - 1:2 * k - 1]
    after = np.concatenate([np.where(alive, cols, 3 * k), np.where(alive, cols + k, 3 * k)],
                           axis=1)
    nxt = np.minimum.accumulate(after[:, ::-1], axis=1)[:, ::-1][:, 1:k + 1]
    return prev, nxt


def _stars(X: np.ndarray, normals: np.ndarray, nb: np.ndarray, idx: np.ndarray) -> np.ndarray:
    """The Delaunay star of each point ``idx`` among its same-sheet neighbours ``nb[:, 1:]``,
    projected on its tangent plane, for all points at once.

    ``x_j`` is a Delaunay neighbour of the point (the origin) when some circle through both is
    empty. Inversion about the origin (``q = p / |p|^2``) turns those circles into lines, so
    the neighbours are the vertices of the convex hull of the ``q`` and the origin. Sorted by
    angle, a neighbour inside the triangle of the origin and its two hull neighbours (a
    right turn, within a wedge under pi) is never a hull vertex: such neighbours are dropped
    until none is left. The star's triangles join consecutive survivors less than pi apart.
    Equal, up to ties between cocircular points, to scipy's Delaunay of each neighbourhood.
    """
    k = nb.shape[1] - 1
    a, b = _tangent_basis(normals[idx])
    js = nb[:, 1:]
    same = np.einsum("nkd,nd->nk", normals[js], normals[idx]) > 0
    offsets = X[js] - X[idx][:, None, :]
    p = np.stack([np.einsum("nkd,nd->nk", offsets, a), np.einsum("nkd,nd->nk", offsets, b)],
                 axis=-1)
    angle = np.where(same, np.arctan2(p[..., 1], p[..., 0]), np.inf)
    order = np.argsort(angle, axis=1)
    js = np.take_along_axis(js, order, axis=1)
    p = np.take_along_axis(p, order[..., None], axis=1)
    angle = np.take_along_axis(angle, order, axis=1)
    alive = np.isfinite(angle)
    angle = np.where(alive, angle, 0.0)
    q = p / np.maximum((p ** 2).sum(axis=-1, keepdims=True), 1e-300)
    cols = np.arange(k)[None, :]
    rows = np.arange(len(nb))  # the stars that may still lose a neighbour
    for _ in range(k):
        live, qr, ar = alive[rows], q[rows], angle[rows]
        prev, nxt = _circular_neighbours(live)
        pi, ni = prev % k, nxt % k
        valid = live & (prev >= 0) & (nxt < 2 * k) & (pi != ni) & (pi != cols)
        qa = np.take_along_axis(qr, pi[..., None], axis=1)
        qb = np.take_along_axis(qr, ni[..., None], axis=1)
        wedge = np.mod(np.take_along_axis(ar, ni, axis=1)
                       - np.take_along_axis(ar, pi, axis=1), 2 * np.pi)
        turn = ((qr[..., 0] - qa[..., 0]) * (qb[..., 1] - qr[..., 1])
                - (qr[..., 1] - qa[..., 1]) * (qb[..., 0] - qr[..., 0]))
        inside = valid & (wedge < np.pi) & (turn <= 0)
        changed = inside.any(axis=1)
        if not changed.any():
            break
        alive[rows] = live & ~inside
        rows = rows[changed]  # a star that lost nothing this round is final
    _, nxt = _circular_neighbours(alive)
    ni = nxt % k
    gap = np.mod(np.take_along_axis(angle, ni, axis=1) - angle, 2 * np.pi)
    keep = alive & (nxt < 2 * k) & (ni != cols) & (gap < np.pi)
    r, c = np.nonzero(keep)
    return np.column_stack([idx[r], js[r, c], js[r, ni[r, c]]])


def _unique_rows(A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The distinct rows of the non-negative integer array ``A`` (M, c), in lexicographic
    order, and how often each occurs: ``np.unique(A, axis=0, return_counts=True)`` by one
    ``lexsort`` (several times faster than unique's row view at a million rows)."""
    if len(A) == 0:
        return A.reshape(0, A.shape[1]), np.zeros(0, dtype=np.int64)
    order = np.lexsort(A.T[::-1])
    A = A[order]
    first = np.ones(len(A), dtype=bool)
    first[1:] = (A[1:] != A[:-1]).any(axis=1)
    starts = np.flatnonzero(first)
    return A[starts], np.diff(np.append(starts, len(A)))


def _greedy_claims(edges: np.ndarray) -> np.ndarray:
    """Which triangles a greedy pass in row order keeps, when each claims the three directed
    edges ``edges`` (M, 3) (integer keys) and a triangle is kept only if none of its edges is
    claimed by a kept triangle before it.

    The same set as the sequential loop, found in rounds of whole-array steps: a triangle
    that comes first among the undecided ones on each of its edges is kept by the loop too
    (every earlier triangle sharing an edge is already out), so each round keeps all of them
    and drops the undecided triangles they block (the lexicographically first maximal
    independent set of the conflict graph, computed as in Luby's algorithm with the row order
    as priorities). Rounds on the fans of 300k-point height fields: 3 (uniform random
    points) and 2 (a jittered grid).
    """
    m = len(edges)
    ids = np.unique(edges, return_inverse=True)[1].reshape(m, 3)
    n_edges = int(ids.max(initial=-1)) + 1
    kept = np.zeros(m, dtype=bool)
    claimed = np.zeros(n_edges, dtype=bool)
    open_ = np.arange(m)  # undecided triangles, in row order
    while len(open_):
        first = np.full(n_edges, m, dtype=np.int64)
        np.minimum.at(first, ids[open_].ravel(), np.repeat(open_, 3))
        win = open_[(first[ids[open_]] == open_[:, None]).all(axis=1)]
        kept[win] = True
        claimed[ids[win].ravel()] = True
        open_ = open_[~claimed[ids[open_]].any(axis=1)]
    return kept


def _merge(X: np.ndarray, normals: np.ndarray, candidates: np.ndarray,
           facing: float | None = None) -> tuple[np.ndarray, int]:
    """Greedy edge-manifold, consistently oriented union of the fans' triangles, and the
    number of distinct candidates.

    The candidates, oriented by their corners' normals, are taken by votes (how many fans
    made them), then shape quality; one is kept when none of its directed edges is taken
    (each edge then has at most two triangles, on opposite sides: manifold and oriented).
    ``facing``: a candidate whose unit normal ``m`` has ``|m . n_i| <= facing`` at a corner
    ``i`` is no candidate (:func:`standing`).
    """
    tris, votes = _unique_rows(np.sort(candidates, axis=1))
    if len(tris) == 0:
        return tris, 0
    cross = np.cross(X[tris[:, 1]] - X[tris[:, 0]], X[tris[:, 2]] - X[tris[:, 0]])
    flip = np.einsum("md,md->m", cross, normals[tris].sum(axis=1)) < 0
    tris[flip] = tris[flip][:, [0, 2, 1]]
    quality = shape_quality(X, tris, cross)
    # Slivers (collinear points, as on a regular grid) make the cotangent weights blow up.
    order = np.lexsort((-quality, -votes))
    order = order[quality[order] > _MIN_QUALITY]
    if facing is not None:  # slivers' planes are their points' rounding: no test
        order = order[~(standing(cross[order], normals[tris[order]], facing)
                        & (quality[order] > STANDING_QUALITY))]
    n = int(tris.max()) + 1
    ranked = tris[order]
    edges = ranked * n + np.roll(ranked, -1, axis=1)  # a -> b, b -> c, c -> a as a * n + b
    keep = order[_greedy_claims(edges)]
    return tris[np.sort(keep)], len(tris)


def standing(cross: np.ndarray, corner_normals: np.ndarray, facing: float) -> np.ndarray:
    """(M,) bool: triangles that stand across the surface: at one corner or more, the
    triangle's normal (``cross``, (M, 3), any length and side) and the corner's normal line
    (``corner_normals``, (M, 3, 3) unit) are further apart than ``arccos(facing)``.

    A triangle of a sampled surface lies close to the tangent planes at its corners (its
    normal within about its edge length times the curvature of theirs); one that stands
    across them joins points the surface does not join directly: the flat beside a groove to
    the groove's wall under its lip (a corner cut), or one wall of a narrow groove to the
    other (a bridge). The sign of the normals plays no part, so a corner whose estimated normal
    is turned the wrong way keeps its triangles (the normal rounds need them to mend it).
    Cutting them opens the handles such triangles make (``pcgeom.synthetic_folds.deep_folds``,
    walls 2-3 spacings apart: local-mesh genus 1-7 -> 0); see
    :attr:`pcgeom.config.LocalMeshConfig.facing` for the measured maps."""
    unit = cross / np.maximum(np.linalg.norm(cross, axis=1, keepdims=True), 1e-300)
    return (np.abs(np.einsum("md,mkd->mk", unit, corner_normals)) <= facing).any(axis=1)


DROP_KEEPS = 0.99
"""The triangles that turn from their normals (:func:`pcgeom.maps.bridges.disagreeing`) are
dropped only if the mesh's largest part keeps this share of its vertices: a crease (the
folded strip's bulb meets its sheets at a kink) is not a bridge, and dropping its
triangles cut that strip apart (40% of its points left meshed)."""


def _drop_disagreeing(X: np.ndarray, normals: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """The faces less those :func:`pcgeom.maps.bridges.disagreeing` flags, unless that
    shrinks the largest part below :data:`DROP_KEEPS` of its vertices."""
    drop = disagreeing(X, normals, faces)
    if not drop.any():
        return faces
    before = int(main_part(faces, len(X)).sum())
    if main_part(faces[~drop], len(X)).sum() < DROP_KEEPS * before:
        return faces
    return faces[~drop]


def _cut_lids(faces: np.ndarray, fans: np.ndarray, n: int) -> np.ndarray:
    """The faces less the lids of one-sided stars (:func:`pcgeom.maps.bridges.one_sided`),
    but for those with a corner that the mesh's largest part would lose: a lid never holds a
    piece of the surface on its own. On a noisy range scan of a head with its normals
    (tests/test_scans.py, seeds 0-1), the edges both ends' fans made are few about the
    occlusions' rims: 33 / 32 triangles cut there took 290 / 113 points out of the largest
    part, and the map went from 0.0706 / 0.0756 rad, 3 / 3 flipped to 0.0820 / 0.0840, 31 / 29;
    with this rule it keeps them all (the same map); the grooves' lids hold nothing."""
    cut = one_sided(faces, fans, n)
    if not cut.any():
        return faces
    lost = main_part(faces, n) & ~main_part(faces[~cut], n)
    cut &= ~lost[faces].any(axis=1)
    return faces[~cut]


def _submesh(X: np.ndarray, faces: np.ndarray, keep: np.ndarray
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The vertices ``keep`` (bool mask) of the mesh, renumbered: their indices, contiguous
    ``V`` and the faces among them (contiguous, as libigl wants them)."""
    index = np.flatnonzero(keep)
    remap = np.full(len(X), -1, dtype=np.int64)
    remap[index] = np.arange(len(index))
    F = remap[faces]
    return index, np.ascontiguousarray(X[index]), np.ascontiguousarray(F[(F >= 0).all(axis=1)])


def local_mesh(X: np.ndarray, normals: np.ndarray, neighbours: int = 24, *,
               exclude: np.ndarray | None = None, progress: bool = False,
               knn: Neighbours | None = None, bridges: bool = False,
               facing: float | None = None) -> LocalMesh:
    """Build the manifold mesh of same-sheet tangent fans (steps 1-4 of the module).

    Parameters
    ----------
    X : (N, 3) float64
        Distinct points.
    normals : (N, 3) float64
        Unit normals, consistently oriented.
    neighbours : int
        Nearest neighbours each fan is built from.
    exclude : (N,) bool, optional
        Points no fan uses (strays).
    progress : bool
        Progress of the fans on stderr (:mod:`pcgeom.progress`).
    knn : Neighbours, optional
        The nearest points of the points not excluded, among themselves (rows as in
        ``X[~exclude]``), when already found.
    bridges : bool
        Drop the well-shaped triangles that turn from a corner's normal by more than 60
        degrees (:func:`pcgeom.maps.bridges.disagreeing`), and cut the bridges between
        sheets where that lowers the repaired mesh's genus
        (:func:`pcgeom.maps.bridges.cut_bridges`). Runs ask for it when the cloud came with
        its normals (:func:`mesh_cloud`, :data:`BRIDGES_WITH_INPUT_NORMALS`).
    facing : float, optional
        Triangles standing across their corners' normals (:func:`standing`) are no
        candidates (:attr:`pcgeom.config.LocalMeshConfig.facing`). None: all are.

    Returns
    -------
    LocalMesh
    """

    n = len(X)
    kept = np.arange(n) if exclude is None else np.flatnonzero(~np.asarray(exclude, bool))
    if knn is None:  # found here once, for the fans and the repair's spacing
        knn = Neighbours.of(X[kept], neighbours)
    candidates = kept[_fans(X[kept], normals[kept], neighbours, progress, knn=knn)]
    faces, n_candidates = _merge(X, normals, candidates, facing)
    if bridges:  # the lids of one-sided stars first: no two-sided path joins their ends
        faces = _cut_lids(faces, candidates, n)
    del candidates
    if bridges:
        faces = _drop_disagreeing(X, normals, faces)
    spacing = None
    if knn is not None and knn.k >= SPACING_NEIGHBOURS:
        spacing = np.zeros(n)
        spacing[kept] = knn.first(SPACING_NEIGHBOURS)[0][:, 1:].mean(axis=1)
    dropped: list = []
    if bridges:
        faces, topology = cut_bridges(X, normals, faces, repair, exclude=exclude,
                                      spacing=spacing, dropped=dropped, cloud=knn.tree)
    else:
        faces, topology = repair(X, normals, faces, exclude=exclude, spacing=spacing,
                                 dropped=dropped, cloud=knn.tree)
    main = main_part(faces, n)
    boundary = int(edge_sides(faces)[1].sum())
    return LocalMesh(faces=faces, main=main, boundary_edges=boundary, candidates=n_candidates,
                     topology=topology, pinch_fans=dropped[-1] if dropped else None)


def mesh_normals(X: np.ndarray, mesh: LocalMesh, previous: np.ndarray) -> np.ndarray:
    """The mesh's own vertex normals (libigl's, each triangle weighted by its angle at the
    vertex) on its main part, turned to the side of ``previous``; ``previous`` elsewhere
    (points outside the main part, strays, a vertex whose triangles cancel out).

    Parameters
    ----------
    X : (N, 3) float64
        The mesh's points.
    mesh : LocalMesh
        Its local mesh.
    previous : (N, 3) float64
        The normals it was built from (unit, consistently oriented; strays' rows zero).

    Returns
    -------
    (N, 3) float64
        Unit normals where the mesh gives them, ``previous``'s rows elsewhere.
    """
    import igl

    F = np.ascontiguousarray(mesh.faces[mesh.main[mesh.faces].all(axis=1)], dtype=np.int64)
    out = np.array(previous, dtype=np.float64, copy=True)
    if len(F) == 0:
        return out
    found = igl.per_vertex_normals(np.ascontiguousarray(X, dtype=np.float64), F,
                                   igl.PER_VERTEX_NORMALS_WEIGHTING_TYPE_ANGLE)
    length = np.linalg.norm(found, axis=1)
    ok = mesh.main & np.isfinite(length) & (length > 0.5)
    side = np.where(np.einsum("nd,nd->n", found, out) < 0, -1.0, 1.0)
    out[ok] = (found * (side / np.where(ok, length, 1.0))[:, None])[ok]
    return out


SAME_SHEET = 0.5
"""A known point takes part in placing an unmeshed one (:func:`_interpolate_rest`, with
normals) when their normals' dot product is above this: the same sheet, not the facing
wall of a fold narrower than the spacing."""

INTERPOLATION_NEIGHBOURS = 8
"""Known points that place an unmeshed one (:func:`_interpolate_rest`)."""


def _interpolate_rest(X: np.ndarray, U: np.ndarray, known: np.ndarray,
                      normals: np.ndarray | None = None) -> np.ndarray:
    """Fill the rows of ``U`` not in ``known`` from the map at their
    :data:`INTERPOLATION_NEIGHBOURS` nearest known points: their inverse-distance mean.

    With ``normals`` (N, 3; unit, consistently oriented, zero rows for strays), a point with
    at least 4 known points of its own sheet (``n_i . n_j >`` :data:`SAME_SHEET`) among its
    twice as many nearest takes the value at it of the affine map from its tangent plane
    fitted to the nearest of them (least squares, weighted by inverse distance): where a
    fold is narrower than the spacing, the nearest known points include the facing wall's,
    and their mean puts the point between the walls. Measured on the lips sheet with its
    normals (11k, seeds 0-2, ``fast`` onto free, true triangles; 2026-12-05): 0.807 / 0.833
    / 0.675% flipped -> 0.739 / 0.788 / 0.621%, angle 0.0311 / 0.0409 / 0.0277 rad ->
    0.0304 / 0.0405 / 0.0272; benchmarks/bench_bridges.py for the shared surfaces."""
    from scipy.spatial import cKDTree

    rest = np.flatnonzero(~known)
    if not len(rest):
        return U
    have = np.flatnonzero(known)
    k = min(INTERPOLATION_NEIGHBOURS, len(have))
    wide = min(2 * k if normals is not None else k, len(have))
    dist, nb = cKDTree(X[have]).query(X[rest], wide)
    dist, nb = dist.reshape(len(rest), wide), nb.reshape(len(rest), wide)
    w = 1.0 / np.maximum(dist[:, :k], 1e-12)
    U[rest] = np.einsum("rk,rkd->rd", w, U[have][nb[:, :k]]) / w.sum(axis=1, keepdims=True)
    if normals is None:
        return U
    n_rest = np.asarray(normals, dtype=np.float64)[rest]
    same = np.einsum("rkd,rd->rk", normals[have][nb], n_rest) > SAME_SHEET
    # The nearest k of each point's own sheet (stable: nearest first).
    order = np.argsort(~same, axis=1, kind="stable")[:, :k]
    take = np.take_along_axis(same, order, axis=1)
    fit = take.sum(axis=1) >= 4
    if not fit.any():
        return U
    rows = np.flatnonzero(fit)
    nb_s = np.take_along_axis(nb, order, axis=1)[rows]
    w = np.where(take[rows], 1.0 / np.maximum(np.take_along_axis(dist, order, axis=1)[rows],
                                             1e-12), 0.0)
    a, b = _tangent_basis(n_rest[rows])
    offsets = X[have][nb_s] - X[rest[rows]][:, None, :]
    A = np.stack([np.einsum("rkd,rd->rk", offsets, a), np.einsum("rkd,rd->rk", offsets, b),
                  np.ones(w.shape)], axis=-1)
    AtA = np.einsum("rk,rki,rkj->rij", w, A, A)
    AtU = np.einsum("rk,rki,rkd->rid", w, A, U[have][nb_s])
    # Well-posed fits only (neighbours not on one line in the tangent plane).
    ok = np.linalg.cond(AtA) < 1e8
    if ok.any():
        U[rest[rows[ok]]] = np.linalg.solve(AtA[ok], AtU[ok])[:, 2]
    return U


PLACE_BY_RINGS = True
"""The free map of a bare cloud places the points outside its local mesh's main part from the
rings about their nearest meshed point (:func:`place_rest`, :func:`_ring_rest`), not from
their nearest meshed points in space. Measured side by side (``fast`` onto free, bare, seed
0, on the true triangles, 2026-12-06, with :data:`pcgeom.maps.free.CUT_ROUNDS` off / on):
:func:`pcgeom.synthetic_folds.deep_folds` uniformly sampled, walls 1.5 spacings apart, cloud
seed 0, 0.0185 rad, 20 flipped -> 0.0168, 7 (with the cut 0.0089, 7; without the rings
0.0105, 18); evenly sampled 0.0099, 8 -> 0.0095, 4 (with the cut 0.0077, 5; without 0.0088,
17); the pleat 1.5 spacings wide 0.0155, 38 -> 0.0142, 20 (with the cut 0.0110, 1; without
0.0144, 40), cloud seed 1 0.0382, 90 -> 0.0353, 55; face_human_choi 0.0310, 702 -> 0.0296,
693; peaks_three_cgal 0.0406 -> 0.0402; the other shared surfaces the same."""

RING_HOPS = 2
"""The rings about its nearest meshed point whose points place an unmeshed one
(:func:`_ring_rest`)."""


def place_rest(X: np.ndarray, U: np.ndarray, mesh: LocalMesh) -> np.ndarray:
    """The free map's rows outside the mesh's main part filled: by an affine fit to the
    same-sheet neighbours when the mesh carries the cloud's own normals
    (:func:`_interpolate_rest`, :data:`PLACE_WITH_INPUT_NORMALS`), else from the rings about
    the nearest meshed point (:func:`_ring_rest`, :data:`PLACE_BY_RINGS`)."""
    if mesh.normals is None and PLACE_BY_RINGS:
        return _ring_rest(X, U, mesh.main, mesh.faces)
    return _interpolate_rest(X, U, mesh.main, mesh.normals)


def _ring_rest(X: np.ndarray, U: np.ndarray, known: np.ndarray, faces: np.ndarray
               ) -> np.ndarray:
    """Fill the rows of ``U`` not in ``known``: each one's nearest known point ``p`` (one
    with an edge among ``faces``' triangles of known points), the points within
    :data:`RING_HOPS` edges of ``p``, and the affine map fitted to the map there (least
    squares, from their plane: PCA) taken at the point. Rows with fewer than 4 such points,
    points on one line, or farther from ``p`` than the farthest of them (a stray off the
    surface: no fit reaches it) keep :func:`_interpolate_rest`'s value.

    The rings of a point lie on its own sheet, where the nearest known points in space need
    not: a point the mesh left out where a groove's walls or a pleat's sheets are a spacing
    or two apart has the facing wall's points among its nearest, and their inverse-distance
    mean put it between the walls, turning over the true triangles about it (the
    uniformly sampled grooves 1.5 spacings wide, :func:`pcgeom.synthetic_folds.deep_folds`,
    seed 0: 16 of the 17 true triangles turned over had a corner the mesh left out)."""
    import scipy.sparse as sp
    from scipy.spatial import cKDTree

    rest = np.flatnonzero(~known)
    out = _interpolate_rest(X, U, known)
    F = faces[known[faces].all(axis=1)]
    if not len(rest) or not len(F):
        return out
    n = len(X)
    E = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    A = sp.csr_matrix((np.ones(len(E)), (E[:, 0], E[:, 1])), shape=(n, n))
    A = ((A + A.T) > 0).astype(np.float64)
    have = np.flatnonzero(np.diff(A.indptr) > 0)
    nearest = have[cKDTree(X[have]).query(X[rest], 1)[1]]
    R = A[nearest] + sp.csr_matrix((np.ones(len(rest)), (np.arange(len(rest)), nearest)),
                                   shape=(len(rest), n))
    for _ in range(RING_HOPS - 1):
        R = R + R @ A
    R = (R > 0).tocsr()
    R.sort_indices()
    sizes = np.diff(R.indptr)
    slot = np.arange(int(sizes.max()))[None, :] < sizes[:, None]
    idx = np.zeros(slot.shape, dtype=np.int64)
    idx[slot] = R.indices
    w = slot.astype(np.float64)  # (r, K): padded rows weigh nothing
    P = X[idx] - X[nearest][:, None, :]
    centred = (P - (np.einsum("rk,rkd->rd", w, P) / sizes[:, None])[:, None, :]) * w[..., None]
    a, b = _tangent_basis(np.linalg.eigh(np.einsum("rki,rkj->rij", centred, centred))[1][..., 0])
    M = np.stack([np.einsum("rkd,rd->rk", P, a), np.einsum("rkd,rd->rk", P, b), w], axis=-1)
    AtA = np.einsum("rk,rki,rkj->rij", w, M, M)
    at = X[rest] - X[nearest]
    # Within the rings' reach: a fit, not a reach out to a stray far off the surface.
    reach = np.sqrt((w * (P ** 2).sum(axis=-1)).max(axis=1))
    ok = (sizes >= 4) & (np.linalg.norm(at, axis=1) <= reach) & (np.linalg.cond(AtA) < 1e8)
    if not ok.any():
        return out
    coef = np.linalg.solve(AtA[ok], np.einsum("rk,rki,rkd->rid", w, M, U[idx])[ok])
    at = at[ok]
    x = np.stack([np.einsum("rd,rd->r", at, a[ok]), np.einsum("rd,rd->r", at, b[ok]),
                  np.ones(int(ok.sum()))], axis=-1)
    out[rest[ok]] = np.einsum("ri,rid->rd", x, coef)
    return out


def mesh_cloud(Xn: np.ndarray, normals: np.ndarray | None, neighbours: int,
               normal_neighbours: int, *, progress: bool,
               normal_scales: tuple[int, ...] = (6, 8, 12, 16, 24),
               normal_tolerance: float = 0.03, outlier: np.ndarray | None = None,
               closed: bool = False, onto: str | None = "free", bridges: bool | None = None,
               facing: float | None = None) -> tuple[LocalMesh, np.ndarray, dict]:
    """Outliers, the surface test, normals and the local mesh of a normalized cloud.

    Parameters
    ----------
    Xn : (N, 3) float64
        Normalized distinct points.
    normals : (N, 3) float64 or None
        Their oriented unit normals; None: estimated (PCA) and oriented by propagation.
    neighbours, normal_neighbours : int
        Nearest neighbours of each fan, and of the graph that orients estimated normals.
    normal_scales, normal_tolerance
        The neighbourhood PCA's scales (:func:`pcgeom.neighbours.adaptive_pca`): the surface test
        and, without normals, their estimate.
    outlier : (N,) bool, optional
        The cloud's strays (:func:`pcgeom.neighbours.find_outliers`), when already found.
    closed : bool
        The mesh is for a closed surface (the sphere map, :mod:`pcgeom.maps.sphere`): no
        refusal of a closed cloud.
    onto : str or None
        The planar domain the map is for (its name in the message): a closed cloud is
        refused (:func:`pcgeom.maps.topology.require_open`). None: no test.
    bridges : bool or None
        Cut the bridges between sheets (:func:`local_mesh`); None: when ``normals`` are
        given (:data:`BRIDGES_WITH_INPUT_NORMALS`).
    facing : float, optional
        Drop the triangles that stand across their corners' normals (:func:`local_mesh`).

    Returns
    -------
    mesh : LocalMesh
    normals : (N, 3) float64
        As given, or estimated (outliers' rows zero: no pair and no fan uses them).
    record : dict
        The start of the run's history record: ``normals`` (``"input"`` or
        ``"estimated"``), ``neighbours``, ``faces``, ``boundary_edges``, ``outliers`` (stray
        points, :func:`pcgeom.neighbours.find_outliers`), ``unmeshed`` (points outside the mesh's
        main part, outliers included), ``genus``, ``boundary_loops`` and ``topology``
        (the repaired mesh's :class:`pcgeom.maps.topology.Topology`, as a dict).

    Raises
    ------
    InputError
        The cloud fills a volume (:data:`NOT_A_SURFACE`), less than :data:`MIN_MESHED` of it
        fits one local mesh, or it samples a closed surface and ``onto`` is planar
        (:func:`pcgeom.maps.topology.closed_message`).
    """
    FILLS.clear()  # (a run's repairs share the fills they try: a new run starts afresh)
    outlier = find_outliers(Xn) if outlier is None else np.asarray(outlier, bool)
    inliers = np.flatnonzero(~outlier)
    Xi = Xn[inliers]
    # One neighbour query of the inliers serves the PCA, the orientation and the fans.
    scales = scale_ladder(normal_scales, len(inliers))
    knn = Neighbours.of(Xi, max(int(scales[-1]), SURFACE_NEIGHBOURS, normal_neighbours,
                                neighbours))
    # One neighbourhood PCA serves the surface test and, without normals, their estimate;
    # each point at the scale where its neighbours lie flattest, so that the facing sheet of
    # a fold a couple of spacings away stays out.
    variation, estimated, scale, per_scale = adaptive_pca(Xi, normal_scales, normal_tolerance,
                                                          knn=knn)
    if SURFACE_NEIGHBOURS in scales:
        at_16 = per_scale[:, np.flatnonzero(scales == SURFACE_NEIGHBOURS)[0]]
    else:
        at_16 = surface_variation(local_pca(Xi, SURFACE_NEIGHBOURS, knn=knn)[0])
    del per_scale
    if np.median(at_16) > MAX_VARIATION and np.median(variation) > FLAT_VARIATION:
        raise InputError(NOT_A_SURFACE)
    source = "input"
    if normals is None:
        source = "estimated"
        normals = np.zeros_like(Xn)
        normals[inliers] = orient_normals(Xi, estimated, normal_neighbours, knn=knn)
    del estimated, Xi
    if bridges is None:
        bridges = BRIDGES_WITH_INPUT_NORMALS and source == "input"
    mesh = local_mesh(Xn, normals, neighbours, exclude=outlier, progress=progress, knn=knn,
                      bridges=bridges, facing=facing)
    del knn
    if source == "input" and PLACE_WITH_INPUT_NORMALS:
        mesh = dataclasses.replace(mesh, normals=normals)
    meshed = float(mesh.main.mean())
    if meshed < MIN_MESHED:
        raise InputError(f"only {100 * meshed:.0f}% of the points fit one local mesh: "
                         + NOT_A_SURFACE)
    if onto is not None and not closed:
        require_open(mesh.topology, onto)
    record = {"stage": "localmesh", "kind": "localmesh", "normals": source,
              "neighbours": neighbours, "normal_scale": float(np.median(scale)),
              "faces": mesh.n_faces,
              "boundary_edges": mesh.boundary_edges, "outliers": int(outlier.sum()),
              "unmeshed": int((~mesh.main).sum()), **topology_record(mesh.topology)}
    return mesh, normals, record


def topology_record(topology: Topology | None) -> dict:
    """The history's topology fields of a local mesh: ``genus``, ``boundary_loops`` and the
    whole ``topology`` (:meth:`pcgeom.maps.topology.Topology.to_dict`)."""
    if topology is None:
        return {}
    return {"genus": topology.genus, "boundary_loops": topology.boundary_loops,
            "topology": topology.to_dict()}


def mesh_flips(X: np.ndarray, mesh: LocalMesh, U: np.ndarray,
               dropped: np.ndarray | None = None) -> dict:
    """The triangles of the mesh's main part that the map ``U`` (N, 2) turns over, and where
    (:func:`pcgeom.metrics.flip_locations`): ``{"count", "faces", "rim", "hole", "inside"}``,
    and ``"dropped"`` when ``dropped`` is given.

    ``dropped`` (k, 3): triangles (rows of ``X``, any order) the map set aside as no
    flip-free map can hold them (:func:`pcgeom.maps.injective.injective_map`'s cleaning: the
    smaller of two fans at a vertex, rim slivers, handles); they are not counted.

    Measured on the cloud's own mesh, as a run can (the reference mesh, when a user has one,
    is what ``pcgeom evaluate`` measures), without its rim slivers: a triangle on the rim
    whose angle opposite its rim edge is wider than :data:`pcgeom.mesh.RIM_ANGLE` bridges a notch of
    the rim, and the disk map sends the point under it onto the circle (it peels such triangles,
    :func:`pcgeom.mesh.peel_rim`), nor its flat triangles (an angle over 179 degrees:
    collinear points have no orientation). Counted, they turned over 63 of the three peaks'
    11313 triangles onto the disk, all on the rim, where the map of the true triangles turns
    over none."""
    from ..metrics import flip_locations, flipped_mask

    F = mesh.faces[mesh.main[mesh.faces].all(axis=1)]
    edges, boundary = edge_sides(F)
    opposite = opposite_corners(F)
    a, b = X[edges[:, 0]] - X[opposite], X[edges[:, 1]] - X[opposite]
    cos = (a * b).sum(axis=1) / np.maximum(np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1),
                                           1e-300)
    sliver = np.zeros(len(F), dtype=bool)
    face = np.arange(len(edges)) % len(F)
    sliver[face[boundary & (cos < np.cos(RIM_ANGLE))]] = True
    # Flat triangles (collinear points, as along a grid's straight rim) have no orientation.
    sliver[face[cos < np.cos(np.radians(179.0))]] = True
    extra = {}
    if dropped is not None:
        gone = np.isin(face_keys(F, len(X)), face_keys(np.reshape(dropped, (-1, 3)), len(X)))
        sliver |= gone
        extra["dropped"] = int(gone.sum())
    F = F[~sliver]
    mask = flipped_mask(signed_areas(U, F))
    return {"count": int(mask.sum()), "faces": len(F), **flip_locations(X, F, mask), **extra}
