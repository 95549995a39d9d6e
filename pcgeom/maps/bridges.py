"""Bridges between sheets that nearly touch: triangles of the local mesh that join opposite
sides of a thin gap (not in the paper).

Where two sheets of a surface come within a spacing of each other (lips, nostrils, the walls
of a fold), the local mesh (:mod:`pcgeom.maps.localmesh`) can join them with triangles: each
such bridge adds a handle that the surface does not have, and LSCM over a mesh with a handle
spreads its error over the whole map. The oriented normals say which side each point is on.

**The rule.** A triangle is a bridge candidate when two of its corners' normals point opposite
ways (``n_a . n_b < 0``): a triangle of one sheet, at the spacing the mesh is built at, turns
by less than a right angle between its corners (or one of its corners' estimated normals is
turned over). The candidates are cut only when the repaired local mesh
(:func:`pcgeom.maps.topology.repair`) has handles (genus > 0) and the mesh repaired without
them has fewer: a handle the cloud's boundary does not explain is a bridge.

**In runs of clouds with normals** (:data:`pcgeom.maps.localmesh.BRIDGES_WITH_INPUT_NORMALS`;
``local_mesh(..., bridges=True)`` asks for it anywhere). Measured side by side on the lips
sheet with rounded lips and nostrils (fillets of radius 2.5 where the folds meet the flat,
walls 0.75 apart: 0.74 true spacings at 11k points; ``fast`` onto free, angle and flips on
the true triangles, 2026-12-05; benchmarks/bench_bridges.py in BENCHMARKS.md): with its
normals better at all nine samplings (3k-11k points; 11k, seeds 0-2: 0.0730, 0.0762, 0.0581
rad -> 0.0429, 0.0353, 0.0370, that is 2.04-2.29x libigl's LSCM on the true mesh ->
1.06-1.32x, flipped 1.04-1.13% -> 0.87-1.03%); the pleats and the four shared open surfaces
with normals unchanged (no handle: nothing cut, same times). Not on bare clouds: the
estimated normals of walls that nearly touch are turned the wrong way in patches, and the
pleats' repaired meshes in the normal rounds have handles that are not bridges (bare pleats
0.026 -> 0.068 rad, 0.34 -> 0.73% flipped: their half-circle folds, 0.75 spacings in radius,
turn by more than a right angle within a triangle).

What is left on the rounded lips sheet with normals (11k, seeds 0-2: 0.87 / 0.83 / 0.68%
flipped, LSCM on the true mesh itself 0.12 / 0.10 / 0.04%; benchmarks/bench_bridges.py, "Where
the flips are"): nearly every flipped true triangle (all but 4-19 of 150-191) is one the local
mesh lacks, beside a false hole of it (43-121 beside holes of 17 or more points, where a fold
tapers off) or with a corner outside its main part (26-64); 108-130 lie where a fold is under
half its size. There the fold is narrower than the sampling and its true triangles join
corners whose normals point apart: 238-315 of the true mesh's triangles have two corners
with opposite normals (197-255 of them where a fold tapers), which no fan makes (each keeps
its neighbours with ``n_i . n_j > 0``); the fans lose 497-556 true triangles, the merge
224-258 more. A pair across a gap and a pair on a bulb as narrow are alike (two points,
opposite normals, the chord along them): no rule on pairs tells them apart. Bare (2.2-2.8x
LSCM, 3.2-5.4% flipped): the orientation crosses the gap (:mod:`pcgeom.maps.normals`), and
the flips follow its wrong patches.

Measured again after the unmeshed points were placed from their own sheet (2026-12-05, with
normals, seeds 0-2: 167 / 177 / 136 true triangles flipped, 0.76 / 0.81 / 0.62%): the map
turns over 12 / 21 / 5 of its own local mesh's 21.8k triangles, so a flip-free finish on the
local mesh (:mod:`pcgeom.maps.injective`) could mend at most those; 14 / 30 / 24 flipped
true triangles are slivers of the sampling's rim (an angle over 170 degrees) that no local
mesh has; the rest lie across false holes where a fold tapers, and 36 / 45 / 39 of the
mesh's 55 / 65 / 56 false loops cross themselves in the map: the mesh round them overlaps
itself (a flap of the fold attached on one side, swung over the flat) while none of its
triangles turns. Not kept, one run each, seeds 0-2 with normals (x LSCM, flipped %), before
the unmeshed points were so placed: each false loop with opposite normals filled in the
map's solve by a cone to its centroid (0.87 / 1.23 / 0.99x, 0.81 / 0.83 / 0.68% -> 1.79 /
2.81 / 1.93x, 0.75 / 0.78 / 0.59%), by its least-area triangulation in space (1.33 / 2.75 /
1.73x, 0.61 / 0.73 / 0.58%), by the true triangles on its points (the truth known: 1.11 /
1.43 / 1.15x, 0.68 / 0.69 / 0.56%); triangles dropped whose edge passes within half its
length of a point whose normal is over 60 degrees from both ends' (a lid over a tapering
fold), after the merge (0.87 / 1.23 / 0.99x, 0.81 / 0.83 / 0.68% -> 0.93 / 1.21 / 1.03x,
0.88 / 0.77 / 0.76%) or, with the unmeshed points placed from their own sheet, as candidates
before it (0.85 / 1.22 / 0.97x, 0.76 / 0.81 / 0.62% -> 0.90 / 1.19 / 1.01x, 0.84 / 0.72 /
0.69%).

On the first lips sheet, whose folds met the flat at right-angle creases (``crease_radius=0``):
what limited it was not bridges alone: its edges were right-angle creases, across
which true normals have ``n_i . n_j = 0`` and the fans (same-sheet neighbours: ``> 0``) join
neither side, so its folds hang from the flat only where they taper off, while the flats
either side of the slit (same normals, 0.75 spacings apart) are bridged; bare, the two walls'
PCA normals are oriented the same way and the fans mix them. Cutting every true bridge (the
truth known) took the sheet with normals from 0.087 to 0.201 rad at 11k points and from
0.129 to 0.299 at 5k (the folds come off: 852 -> 1951 points unmeshed), bare from 0.148 to
0.194 at 11k; the rule's cut unmeshes points too (3k with normals: 99 -> 578).

Rules measured and not kept (one run each, every build): a threshold of 0.3 instead of 0
(face_human_choi bare 0.033 -> 0.037 rad); cutting triangles whose edges leave the tangent
plane (component along the normals over 0.7 or 0.8: pleats 0.026 -> 0.038, lips with
normals 0.087 -> 0.131); triangles over a cloud point close under them (lips bare 0.148 ->
0.135 rad but 10.9 -> 11.3% flipped, pleats 0.026 -> 0.046); edges with opposite normals
whose ends are more than 2-3 times further apart on the mesh without them (few cut, no
change); fans that drop neighbours whose offset is steep to the normal (lips with normals
0.087 -> 0.131 at slope 1); fans that take neighbours up to ``n_i . n_j > -0.1`` (to cross the
creases: lips with normals 0.087 -> 0.195, pleats 0.026 -> 0.079); orienting bare normals
by patches of parallel tangent neighbours and votes between patches (lips 10.9 -> 7.1%
flipped but 0.148 -> 0.162 rad, pleats 0.026 -> 0.034). The nearest to a lead: fans that
also take neighbours across a crease (``n_i . n_j > -0.2`` and height off the tangent plane
under half the tangential distance, triangles whose other two corners face away dropped)
with triangles cut whose edge passes next to a point whose normal differs from both ends'
(``dot < 0.5``, within half the edge's length of its midpoint): lips 11k with normals 0.087
rad, 4.55% -> 0.099, 2.83% (unmeshed 687 -> 100, genus 2 -> 6), bare 0.148, 10.8% -> 0.120,
11.6%. What is left then with normals: 625 of its 772 bridging edges join the flats where
the folds taper off (their walls 0.1-0.5 spacings apart, the fold narrower than the
sampling): no rule on normals or distances at the spacing sees that fold.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..mesh import shape_quality

if TYPE_CHECKING:
    from .topology import Topology

__all__ = ["bridge_candidates", "cut_bridges", "disagreeing", "one_sided", "OPPOSITE",
           "DISAGREE", "DISAGREE_QUALITY", "DETOUR_HOPS"]

OPPOSITE = 0.0
"""Two corners of a triangle whose normals' dot product is below this lie on opposite sheets.
Measured with the cut gated on the unrepaired mesh's genus: at 0.3 it took 768 of
face_human_choi's bare triangles and its free map went from 0.033 to 0.037 rad; at -0.5 it
cut none of them, and 24 of the lips sheet's (11k, with its normals: 0.0838 rad, 4.51%
flipped, against 0.0741 and 4.32% at 0)."""


DISAGREE = 0.5
"""A well-shaped triangle of the local mesh whose normal makes more than 60 degrees
(``cos < DISAGREE``) with one of its corners' normals is dropped before the repair, in runs of
clouds with normals (:func:`disagreeing`)."""

DISAGREE_QUALITY = 0.65
"""... well-shaped: shape quality (1 equilateral, 0 degenerate) above this. A sliver's own
normal says nothing: measured with any quality, the rule took face_human_choi's free map
with normals from 0.06% to 0.30% flipped and peaks_three_cgal's from 0.00% to 0.05%, the
triangles it dropped there slivers (median quality 0.31 and 0.02); the lips sheet's were
not (0.74)."""


def disagreeing(X: np.ndarray, normals: np.ndarray, faces: np.ndarray,
                cos: float = DISAGREE, quality: float = DISAGREE_QUALITY) -> np.ndarray:
    """Which well-shaped triangles (shape quality above ``quality``) turn from one of their
    corners' normals by more than ``arccos(cos)``: they join points the normals put on
    different sheets, or across a fold narrower than the sampling.

    Measured side by side (``fast`` onto free, angle on the true triangles, 2026-12-05, with
    the standing triangles left out, :attr:`pcgeom.config.LocalMeshConfig.facing`): the lips
    sheet with its normals (11k, seeds 0-2) 0.0438 / 0.0695 / 0.0341 rad -> 0.0321 / 0.0410 /
    0.0281 (1.23x / 2.09x / 1.22x libigl's LSCM on the true mesh -> 0.90x / 1.23x / 1.01x),
    flipped 0.92 / 1.09 / 0.81% -> 0.87 / 0.83 / 0.68%; the pleats and the four shared open
    surfaces with normals, free and disk, within 0.0004 rad (face_human_choi 0.12 -> 0.13%
    flipped free, 0.15 -> 0.16% disk; peaks_7holes_choi 0.03 -> 0.00%). Not on bare
    clouds: the pleats' PCA normals lean in their folds and the rule took their mesh apart
    (20% of the points left meshed). :func:`pcgeom.maps.localmesh.local_mesh` drops them
    only where the mesh's largest part keeps its points (a crease is not a bridge).

    Parameters
    ----------
    X : (N, 3) float64
    normals : (N, 3) float64
        Unit normals, consistently oriented.
    faces : (M, 3) int64
        Oriented by the normals (the local mesh's).
    cos, quality : float

    Returns
    -------
    (M,) bool
    """
    F = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    if len(F) == 0:
        return np.zeros(0, dtype=bool)
    cross = np.cross(X[F[:, 1]] - X[F[:, 0]], X[F[:, 2]] - X[F[:, 0]])
    shape = shape_quality(X, F, cross)
    unit = cross / np.maximum(np.linalg.norm(cross, axis=1), 1e-300)[:, None]
    turn = np.einsum("md,mkd->mk", unit, np.asarray(normals, dtype=np.float64)[F]).min(axis=1)
    return (turn < cos) & (shape > quality)


DETOUR_HOPS = 9
"""An edge of the local mesh that only one of its ends' fans made is a bridge when its ends
are farther apart than this many edges that both ends' fans made (:func:`one_sided`; 5 and
12 measured there)."""


def one_sided(faces: np.ndarray, fans: np.ndarray, n: int, hops: int = DETOUR_HOPS
              ) -> np.ndarray:
    """Which triangles have a one-sided edge without a detour: an edge that only one of its
    ends' fans (their Delaunay stars, :func:`pcgeom.maps.localmesh._fans`) has, whose ends
    no path of ``hops`` two-sided edges of the mesh joins.

    Where a groove's mouth meets the rim of the sheet, or a hole of the sampling, a lip
    point's star is one-sided and takes a point on the facing lip: the merge keeps that
    triangle (nothing else claims its edges there) and it bridges the groove as a lid, two
    points 2 spacings apart in space and 15-25 along the surface, which LSCM must bring
    together (:func:`pcgeom.synthetic_folds.deep_folds`, uniformly random points, walls 1.5
    spacings apart, with their normals: the true map's angle error on the mesh's
    triangles over 0.5 rad on 3-5 of them, which carry most of the map's). An edge of the
    surface that one star missed still has its ends a couple of two-sided edges apart; a
    lid's are 10 or more (down the wall, round the bottom and up; unjoined within 20 on the
    deeper grooves). Measured side by side (``fast``, with their normals, on the true
    triangles, this rule off -> on): the uniformly random grooves 1.5 spacings apart, seeds
    0-1, 0.0223 / 0.0223 rad, 0.33 / 0.34% flipped -> 0.0107 / 0.0110, 0.08 / 0.06% (the
    exact map 0.0101), 1 apart 0.0644 / 0.0878 -> 0.0244 / 0.0386, the evenly sampled ones
    1 apart 0.0262 / 0.0264 -> 0.0073 / 0.0092, 1.5-3 apart and the uniform ones 2-3 apart
    the same; the lips sheet (11k, seeds 0-2) 0.0305 / 0.0405 / 0.0273 rad, 167 / 177 / 132
    flipped -> 0.0298 / 0.0287 / 0.0271, 170 / 137 / 137; the pleats unchanged;
    face_human_choi with its mesh's normals onto free 0.0235 -> 0.0237 rad (18 flipped
    either way), onto the disk 0.0259, 37 -> 0.0258, 33; the other shared surfaces
    unchanged. With 5 hops the rim of face_human_choi lost triangles over notches (18 -> 59
    flipped onto free); with 12 one groove of the second cloud kept its lids.

    Parameters
    ----------
    faces : (M, 3) int64
        The merged mesh (rows of the cloud).
    fans : (K, 3) int64
        The fans' triangles, each with the point whose star it is first.
    n : int
        Points of the cloud.
    hops : int

    Returns
    -------
    (M,) bool
    """
    import scipy.sparse as sp

    F = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    if len(F) == 0 or len(fans) == 0:
        return np.zeros(len(F), dtype=bool)
    fans = np.asarray(fans, dtype=np.int64)
    star = np.unique(np.concatenate([fans[:, 0] * n + fans[:, 1], fans[:, 0] * n + fans[:, 2]]))
    E = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    two = _member(E[:, 0] * n + E[:, 1], star) & _member(E[:, 1] * n + E[:, 0], star)
    lone = np.flatnonzero(~two)
    if not len(lone):
        return np.zeros(len(F), dtype=bool)
    M = E[two]
    ones = np.ones(2 * len(M), dtype=np.int32)
    A = sp.csr_matrix((ones, (np.concatenate([M[:, 0], M[:, 1]]),
                              np.concatenate([M[:, 1], M[:, 0]]))), shape=(n, n))
    A.data[:] = 1
    # Breadth-first from every lone edge's first end at once, one row each.
    reach = sp.csr_matrix((np.ones(len(lone), dtype=np.int32),
                           (np.arange(len(lone)), E[lone, 0])), shape=(len(lone), n))
    for _ in range(hops):
        reach = reach + reach @ A
        reach.data[:] = 1
    joined = np.asarray(reach[np.arange(len(lone)), E[lone, 1]]).ravel() > 0
    bad = np.zeros(len(E), dtype=bool)
    bad[lone[~joined]] = True
    return bad.reshape(3, -1).any(axis=0)


def _member(keys: np.ndarray, sorted_keys: np.ndarray) -> np.ndarray:
    """Which ``keys`` are among the sorted, distinct ``sorted_keys``."""
    at = np.minimum(np.searchsorted(sorted_keys, keys), len(sorted_keys) - 1)
    return sorted_keys[at] == keys


def bridge_candidates(normals: np.ndarray, faces: np.ndarray,
                      opposite: float = OPPOSITE) -> np.ndarray:
    """Which triangles join points on opposite sheets: two of their corners' normals have a
    dot product below ``opposite``.

    Parameters
    ----------
    normals : (N, 3) float64
        Unit normals, consistently oriented.
    faces : (M, 3) int64
    opposite : float

    Returns
    -------
    (M,) bool
    """
    normals = np.asarray(normals, dtype=np.float64)
    F = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    dots = [np.einsum("md,md->m", normals[F[:, a]], normals[F[:, b]])
            for a, b in ((0, 1), (1, 2), (2, 0))]
    return np.min(dots, axis=0, initial=np.inf) < opposite if len(F) else np.zeros(0, bool)


def shows_bridges(X: np.ndarray, normals: np.ndarray, faces: np.ndarray) -> bool:
    """Whether a mesh shows what a build with its bridges cut would cut: a triangle with two
    corners' normals facing apart (:func:`bridge_candidates`) or one turned from a corner's
    normal (:func:`disagreeing`). :func:`pcgeom.maps.free._cut` runs its rounds only then:
    they rebuilt and solved a smooth sheet's mesh one to three times for nothing (the
    five-bump height field, 200k uniform bare points: the whole run 25 -> 65 s). Measured on
    the 26 runs of ``benchmarks/folds_rules.cut_rows`` (6000 points, seeds 0-1, and the
    shared open surfaces): every run whose cut mesh was kept shows one (the fewest: the
    pleat 2.5 spacings apart, cloud seed 0: 2 turned triangles); the runs that show none
    (grooves 3 apart evenly sampled, face_3holes_small_choi) did not keep it.

    Parameters
    ----------
    X : (N, 3) float64
    normals : (N, 3) float64
        Unit normals, consistently oriented (the ones the mesh was built from).
    faces : (M, 3) int64

    Returns
    -------
    bool
    """
    return bool(bridge_candidates(normals, faces).any() or disagreeing(X, normals, faces).any())


def cut_bridges(X: np.ndarray, normals: np.ndarray, faces: np.ndarray, repair, *,
                opposite: float = OPPOSITE, **where) -> tuple[np.ndarray, Topology]:
    """The local mesh repaired (``repair``, :func:`pcgeom.maps.topology.repair`), less its
    bridges between sheets when cutting them lowers the repaired mesh's genus (the module's
    rule).

    Parameters
    ----------
    X : (N, 3) float64
        The points.
    normals : (N, 3) float64
        Unit normals, consistently oriented (the ones the mesh was built from).
    faces : (M, 3) int64
        The local mesh: edge-manifold, consistently oriented.
    repair : callable
        ``repair(X, normals, faces, **where) -> (faces, Topology)``.
    opposite : float
        :data:`OPPOSITE`.
    **where
        Passed on to ``repair`` (``exclude``, ``spacing``).

    Returns
    -------
    faces : (M', 3) int64
        The repaired mesh, bridges cut or not.
    Topology
        Its topology; ``bridges_cut``: the triangles cut (0: none).
    """
    import dataclasses

    from .topology import measure

    faces = np.asarray(faces, dtype=np.int64)
    repaired, topology = repair(X, normals, faces, **where)
    if topology.genus <= 0:
        return repaired, topology
    bridge = bridge_candidates(normals, faces, opposite)
    # The cheap test first: the cut must lower the genus before the repair too.
    if not bridge.any() or measure(faces[~bridge])["genus"] >= measure(faces)["genus"]:
        return repaired, topology
    cut, cut_topology = repair(X, normals, faces[~bridge], **where)
    if cut_topology.genus >= topology.genus:
        return repaired, topology
    return cut, dataclasses.replace(cut_topology, bridges_cut=int(bridge.sum()))
