"""Boundary loops of a point cloud from its free-boundary map (the paper's section 8, boundary
detection).

1. Delaunay-triangulate the map ``U`` (duplicate map points are triangulated once).
2. Remove the triangles that span gaps: with a user threshold ``h``, the paper's rule, every
   triangle with an edge longer than ``h``; by default a local rule (below).
3. Boundary edges are the edges of exactly one kept triangle.
4. Order them into closed loops: the outer loop first (counter-clockwise in the map), then
   the holes (clockwise), by enclosed area, largest first.

The default rule: why not one global ``h``
-------------------------------------------
A global threshold must lie above the longest edge of every triangle of the surface and
below the width of every gap, everywhere in the map. Real clouds are sampled unevenly and a
conformal map scales them further, so no such value exists. Measured on the test surfaces'
LSCM maps (libigl, the true meshes; point spacing = nearest-neighbour distance in the map):
the spacing spans 0.3-2.8 times its median on face_3holes_small_choi, 0.03-9 times on
face_human_choi and 0.01-15 times on peaks_three_cgal; on face_3holes_small_choi the rim's
edges reach 4.1 median spacings while triangles of the surface reach 5.7. No
``h = c * median`` (c from 1 to 3) nor ``h = c * 90th percentile`` gives the 4 loops of
face_3holes_small_choi, and none gives the single loop of face_human_choi or peaks_three_cgal
with a vertex Jaccard index above 0.9. Edge length also keeps *ears*: the sliver triangle of
three consecutive boundary points has edges s, s and nearly 2s, so any ``h`` above twice the
boundary spacing cuts boundary points off the loop.

So by default a triangle is judged against the spacing *around it*, and by its circumradius
(the alpha-shape criterion, which rejects slivers and ears since their circumradius is the
radius of curvature of the boundary, not the spacing):

    remove triangle t  iff  R(t) > c * median(l_i for the 3 vertices i of t),

``R(t)`` the circumradius in the map and ``l_i`` the median length of the triangulation's
edges at vertex i. The spacing is computed twice: first from all Delaunay triangles, then,
after a first removal, from the kept triangles only, and every triangle is judged again with
it. At a vertex on the border of a gap, the fan of Delaunay edges across the gap can make up
half of its edges and inflate the first estimate; one triangle spanning a hole then survives
and splits the hole in two (face_3holes_small_choi with noise, one pass: 6 loops instead of
4). The rule does not change under a similarity of the map.

``c = 1`` (:data:`DEFAULT_C`) is measured on maps whose loops are known: the LSCM maps of
the test surfaces (libigl, on the true meshes) and, for the height field
peaks_7holes_choi, its projection onto the xy plane. Each cell: loops found / Jaccard index
of the worst-matched true loop's vertex set (loops of 8 points or more); "noise": Gaussian
noise of 0.1 times each point's nearest-neighbour distance added to the map.

=====================  ==========  ==========  ==========  ==========  ==============
surface                true loops  c = 0.75    c = 1.0     c = 1.25    c = 1.0, noise
=====================  ==========  ==========  ==========  ==========  ==============
peaks_7holes (xy)      8           8 / 0.45    8 / 0.41    8 / 0.37    8 / 0.39
face_3holes_small      4           4 / 0.92    4 / 0.97    4 / 0.87    4 / 0.95
face_human             1           7 / 1.00    1 / 1.00    1 / 1.00    3 / 1.00
peaks_three_cgal       1           14 / 0.77   1 / 0.96    1 / 0.95    1 / 0.94
=====================  ==========  ==========  ==========  ==========  ==============

Smaller ``c`` opens spurious holes where the sampling is uneven or anisotropic (face_human
has bands whose rows of points lie several spacings apart: no rule on the map alone tells
such a band from a slit-shaped hole); larger ``c`` bridges narrow holes (the slit of an eye)
and cuts corners off the loops. The low Jaccard index on peaks_7holes is its mesh's: the
holes' borders there are jagged polygons with sliver triangles whose corner points any
Delaunay rule cuts off; each hole still comes out as one loop along its border. The paper's
global rule is still there: pass ``h``.

Loops of fewer than ``min_loop`` distinct points are dropped (kept in
``BoundaryLoops.dropped``): they are gaps of a few points left by uneven sampling or noise,
not holes of the surface. In the runs of the table at c = 1 the dropped loops have at most 7
points, the spurious loops kept with noise on face_human have 11, and the smallest true loop
has 20 points; :data:`DEFAULT_MIN_LOOP` = 8.

Holes narrower than the spacing (optional, with the cloud's points)
------------------------------------------------------------------
Given the cloud (``points``) and ``min_width > 0``, a hole is also judged by its width *on
the surface*: its 3D loop's inradius estimate ``w = 2 A / P`` (``A`` the area of the loop's 3D
polygon, the norm of its vector area about its centroid; ``P`` its 3D perimeter; ``w`` is the
radius of a round hole and the half-width of a slit) over the local spacing at its points (the
median 3D length of the kept triangles' edges at them), :func:`hole_width`. A hole narrower
than ``min_width`` spacings is dropped as a gap of the sampling or a tear of the map. Such
gaps are where the local-mesh map is worst: where sampling changes abruptly (the dense rows
at the eyelid creases of face_human_choi) the local mesh has small holes, which the
free-boundary LSCM opens. Measured (default rule, ``c = 1``; widths in spacings):

============================  ==============================  ==========================
map                           true holes                      spurious holes
============================  ==============================  ==========================
face_3holes_small, ``fast``   3.6, 6.5, 7.4                   none
face_human, its normals       none                            0.16, 0.16, 0.84, 0.84
face_human, bare cloud        none                            19 holes, 0.28-2.0
peaks_7holes, ``fast``        1.3, 1.7 (2 of 7 seen)          none
peaks_7holes, xy projection   0.72-1.7 (all 7)                none
============================  ==============================  ==========================

With ``min_width = 1`` face_human with its normals comes out as one loop (precision and
recall 1.0, from 5 loops and 0.76) and the bare face_human as 5 loops (from 20; precision
0.42 to 0.75), but on the xy projection of peaks_7holes, a good map, 6 of the 7 holes go:
its holes are only about three spacings across, as narrow as those sampling gaps. Other
measures of width (the area of the fan from the loop's centroid; the median distance across
the loop) overlap in the same way. So no width separates them on these surfaces, and the
default, :data:`DEFAULT_MIN_WIDTH` = 0, keeps every hole; pass ``min_width = 1`` for scans
sampled unevenly whose holes are known to be wide. The outer loop and islands are never
judged by width.

Small holes that the map shrinks (optional: ``cloud_spacing``)
--------------------------------------------------------------
A map can shrink a small hole below the spacing of the points around it: the local-mesh map
of peaks_7holes_choi (1850 points, holes about three spacings across) covers its holes with
fan triangles and LSCM crushes them into jagged stars, where no rule on the map sees 5 of
the 7. The cloud still knows them: with ``cloud_spacing=True`` (and ``points``), a Delaunay
triangle of the map is also removed when its circumradius *in 3D* exceeds ``c`` times the
median at its vertices of the cloud's own spacing (the mean distance to the 4 nearest
points, which no triangle spanning a hole can inflate). Measured on the ``fast`` maps
(loops found, true loops recovered one-to-one, precision / recall of boundary points):

=====================  ==========================  ==========================================
surface                default rule                ``cloud_spacing``, ``min_width = 1``
=====================  ==========================  ==========================================
peaks_7holes           3, 2/8, 0.976 / 0.558       8, 8/8, 0.941 / 0.810
face_3holes_small      4, 4/4, 0.997 / 0.994       4, 4/4, 0.992 / 1.000
face_human, normals    5, 1/1, 0.764 / 1.000       21, 1/1, 0.096 / 1.000
peaks_7holes, LSCM     2, 1/8, 0.993 / 0.510       7, 7/8, 0.970 / 0.769 (9, 8/8 at width 0)
peaks_7holes, xy       8, 8/8, 0.902 / 0.881       6, 4/8, 0.492 / 0.656
=====================  ==========================  ==========================================

(LSCM: libigl's, on the true mesh.) So it is for evenly sampled clouds and conformal maps
(pcgeom's free maps are) only: where the sampling is anisotropic (face_human's dense rows at
the eyelid creases), the cloud's spacing along a row is far below the spacing across rows and
the rule opens spurious holes; on a map that stretches (the xy projection of peaks, steep
slopes) the map's Delaunay triangles are long in 3D and it cuts the surface. Not the
default.

What the default gets wrong, and rules measured against it
----------------------------------------------------------
On the bare clouds' ``fast`` maps, plain LSCM (before ``LocalMeshConfig.robust_rounds``;
with its round face_human_choi gives 28 loops, precision 0.379, the others the same loops:
BENCHMARKS.md, bench_apps), normals estimated (loops found, true loops recovered,
precision / recall of boundary points): face_3holes_small_choi 4, 4/4, 0.997 / 0.994;
face_human_choi 24, 1/1, 0.433 / 1.000; peaks_7holes_choi 3, 2/8, 0.970 / 0.551;
peaks_three_cgal 2, 1/1, 0.910 / 1.000; the pleat of :func:`pcgeom.synthetic.pleated_sheet`
with sheets 1.5 / 2 / 2.5 spacings apart 2 / 1 / 1 loops, recall 0.228 / 0.958 / 0.939. The
false loops of face_human_choi are slits where its sampling jumps from coarse to dense rows
(eyelids, lips): its local mesh has holes there (76 loops), which the free map opens; the holes
of peaks_7holes_choi are bridged by the local mesh's fans (its loops there have 5-7 points) and
the map crushes them. Measured on the same maps and not kept:

- Each Delaunay triangle judged in 3D against the median circumradius of the local mesh's
  triangles at its corners (c = 2-3): face_3holes_small_choi 7 loops (2/4 recovered),
  face_human_choi 33-35, peaks_7holes_choi 1 (recall 0.35-0.40), the 1.5-spacing pleat 17-26.
  The fans' bridges inflate the spacing of rim points, and rows closer together than their
  points (face_human_choi) make Delaunay triangles of circumradius ``s^2 / (8 g)`` (``s``
  along a row, ``g`` across) that belong to the surface.
- The same circumradius rule inside the fans (a star's triangle dropped above c = 2 or 3
  times the median distance to the star's points): face_human_choi's local mesh falls apart
  (its LSCM system is singular), for the same rows.
- Fans without triangles longer than 2 or 3 times the largest distance to the 8th neighbour
  at their corners: peaks_7holes_choi 2-3 loops, face_human_choi 21-28; the triangles that
  bridge peaks' holes are not that long in 3D.
- ``cloud_spacing`` with a hole's width measured across it (the median distance from its
  points to the loop's far side, in spacings): the true holes of peaks_7holes_choi 1.8-2.8,
  the false ones of face_human_choi 0.8-16.6 (among them loops of 824 and 206 points at the
  eyes): they overlap.
- The 3D circumradius measured in each corner's neighbourhood metric (the inverse square root
  of its 12 neighbours' covariance in the tangent plane, which makes rows round): face_human_choi
  32-54 loops, peaks_7holes_choi 1.
- A crease test on the holes' rims (surface variation, normals' disagreement with the 8
  nearest): peaks_7holes_choi's true holes score higher than face_human_choi's false ones.

Outer, hole or gap: the evidence in 3D (the default with the cloud)
-----------------------------------------------------------------
With ``points`` (and no ``h``), the rules above only cast the candidates: the map's rule and
``cloud_spacing`` together, so that the holes a map shrinks open. Each candidate loop is then
judged against the sampling around it in 3D (:mod:`pcgeom.apps.loop_kinds`: its own largest
empty circle over the widest one the sampling leaves nearby, its roundness, its rim's
normals), and gets a kind and a confidence. The outside stays as the map's rule leaves it;
holes are removed; every other candidate region (gaps of the sampling, loops under
``min_loop``) is spanned by its triangles again and listed apart (``BoundaryLoops.gaps``).
Measured on the shared surfaces' ``fast`` maps (true holes found / loops marked hole that
are not holes): peaks_7holes_choi 7/7 and 0 (before 2 of 7 seen), face_3holes_small_choi 3/3
and 0, face_human_choi 0 false with normals and bare (before 4 and 21), peaks_three_cgal
bare 0 (before 1), with normals 1. ``kinds=False`` keeps every loop of the rule, as before.

Rims two points thick
---------------------
A hole cut out of a mesh (every triangle at a removed point dropped) leaves a jagged rim:
between two rim points, a point set back by about half an edge is on the boundary too, since
its triangle towards the hole went. The map's Delaunay triangle across that notch is kept
by any rule (it is as small as the surface's own), so the loop walks the outer row and misses
the notches: peaks_7holes_choi, recall of its true boundary points 0.82. So, with the cloud,
each hole's rim is carved (:func:`_carve_notches`): a kept triangle with one edge on a hole's
loop goes when its angle opposite that edge is at least :data:`NOTCH_ANGLE_DEG` (65) in 3D
and that edge is at least :data:`NOTCH_CHORD` (1.05) times the mean of the loop edges
beside it (a chord across a notch, longer than the rim's steps; the second row behind a
smooth, densely sampled rim, as on face_3holes_small_choi, sits behind edges no longer
than their neighbours), :data:`NOTCH_ROUNDS` (2) rounds. The outer loop is not carved (its
recall is 1.0 on every shared surface; carving it costs peaks_three_cgal precision). The
loops' evidence and kinds are those of the loops before carving. Measured on the ``fast``
maps (recall / precision of the true boundary points, bare and with normals):

=================  ============================  ============================
surface            not carved                    carved (65, 1.05, 2)
=================  ============================  ============================
peaks_7holes       0.823 / 0.942, 0.816 / 0.930  0.966 / 0.869, 0.963 / 0.855
face_3holes_small  1.000 / 0.997 (both)          1.000 / 0.970 (both)
peaks_three_cgal   1.000 / 0.972, 1.000 / 0.860  1.000 / 0.972, 1.000 / 0.825
face_human         1.000 / 1.000 (both)          1.000 / 1.000 (both)
=================  ============================  ============================

Without the chord test (any angle of 60-70 degrees, 1-3 rounds) face_3holes_small's
precision falls to 0.87-0.94 for the same recall on peaks_7holes; with it at 70 degrees, 2
rounds, peaks_7holes with normals reaches only 0.949, at 60 degrees 0.969 (face_3holes_small
0.965). No local figure separates the two kinds of points cleanly (of the candidates at 60
degrees or more, the notches' angles are 61-121 degrees, median 90, their chords 0.89-1.45
times the steps beside them; the second row's behind a smooth rim 60-107, median 71, chords
0.95-1.30): the reference meshes' notches are a convention of how their holes were
cut, so the precision lost on peaks_7holes (points behind the rim marked) is the price.

Where loops touch (a non-manifold vertex)
-----------------------------------------
Each boundary edge is walked with its kept triangle on the left and the removed region on
the right. At a vertex with several outgoing boundary edges the walk leaves by the first one
counter-clockwise from the edge it came in by, so it keeps following the *same* removed
region. Each loop is therefore the boundary of one connected piece of the removed region
(the outside or one hole): a hole that touches the rim at one point stays a hole of its own,
and two patches of the map joined at one vertex form one outer loop that passes through that
vertex twice.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..cloud import _float_rows
from ..errors import InputError
from ..mesh import edge_ids, half_edges, opposite_corners, shoelace, signed_areas, unique_edges
from .loop_kinds import LoopJudge
from .planar import delaunay, distinct_points, validate_map

__all__ = ["BoundaryLoops", "detect_boundary", "unkept_holes", "local_spacing", "hole_width",
           "DEFAULT_C", "DEFAULT_MIN_LOOP", "DEFAULT_MIN_WIDTH"]

DEFAULT_C = 1.0
"""Factor of the default local rule: a triangle goes when its circumradius exceeds ``c`` times
the local spacing (module docstring)."""

DEFAULT_MIN_LOOP = 8
"""Fewest distinct points on a reported loop (see :func:`detect_boundary`)."""

DEFAULT_MIN_WIDTH = 0.0
"""Narrowest hole kept when the cloud is given, in local spacings (its 3D inradius estimate,
:func:`hole_width`): 0, every hole, since no width separates the test surfaces' sampling gaps
from their small holes (module docstring)."""


@dataclass(frozen=True)
class BoundaryLoops:
    """Boundary loops of a 2D map, as rows of the map (and of the cloud it came from)."""

    loops: list[np.ndarray]
    """Each loop as int64 input rows in walking order, closed implicitly (the last point
    joins the first). The outer loop comes first (counter-clockwise in the map), then the
    holes (clockwise), by enclosed area, largest first. Each loop starts at its smallest
    row."""
    areas: np.ndarray
    """(len(loops),) signed area each loop encloses in the map: positive counter-clockwise
    (the outer loop, or an island), negative clockwise (a hole)."""
    h: float | None
    """The global edge threshold that was used, or None for the default local rule."""
    c: float | None
    """The factor of the local rule, or None when ``h`` was given."""
    min_loop: int
    """Loops with fewer distinct points than this were dropped."""
    dropped: list[np.ndarray] = field(default_factory=list)
    """The dropped loops (same form as ``loops``): fewer than ``min_loop`` points, or holes
    narrower than ``min_width``; largest area first."""
    triangles: np.ndarray = field(default_factory=lambda: np.zeros((0, 3), np.int64))
    """(M, 3) int64 kept Delaunay triangles, input rows, counter-clockwise in the map."""
    removed: np.ndarray = field(default_factory=lambda: np.zeros((0, 3), np.int64))
    """(K, 3) int64 Delaunay triangles that were removed, input rows."""
    widths: np.ndarray | None = None
    """(len(loops),) width of each hole on the surface in local spacings
    (:func:`hole_width`), NaN for the outer loop and islands; None without the cloud."""
    min_width: float | None = None
    """Holes narrower than this (in spacings) were dropped; None without the cloud."""
    evidence: list[dict] | None = None
    """Per loop, the evidence on it and its ``kind`` (``"outer"`` or ``"hole"``) and
    ``confidence`` (:mod:`pcgeom.apps.loop_kinds`), measured on the loop before the notches
    of its rim were carved (module docstring); None without the cloud or with
    ``kinds=False``."""
    gaps: list[np.ndarray] = field(default_factory=list)
    """Loops the evidence calls gaps of the sampling (same form as ``loops``): the surface
    spans them, so their triangles are kept and they bound nothing; largest perimeter first."""
    gap_evidence: list[dict] = field(default_factory=list)
    """The evidence on each of ``gaps`` (kind ``"gap"``)."""

    def to_dict(self) -> dict:
        """The JSON form written by ``pcgeom boundary``: loops as lists of input rows."""
        return {
            "loops": [loop.tolist() for loop in self.loops],
            "h": self.h,
            "rule": "edge length > h" if self.h is not None
                    else "circumradius > c * local spacing",
            "c": self.c,
            "min_loop": self.min_loop,
            "areas": [float(a) for a in self.areas],
            "min_width": self.min_width,
            "widths": None if self.widths is None
                      else [None if np.isnan(w) else float(w) for w in self.widths],
            "dropped": [loop.tolist() for loop in self.dropped],
            "kinds": self.kinds(),
            "loop_evidence": self.evidence,
            "gaps": [loop.tolist() for loop in self.gaps],
            "gap_evidence": self.gap_evidence,
        }

    def kinds(self) -> list[str]:
        """Each loop's kind: the evidence's, else by orientation (the first loop ``outer``,
        clockwise ones ``hole``, other counter-clockwise ones ``outer``: islands)."""
        if self.evidence is not None:
            return [e["kind"] for e in self.evidence]
        return ["outer" if i == 0 or a > 0 else "hole" for i, a in enumerate(self.areas)]


def _check_positive(value, name: str) -> float:
    return _check_number(value, name, allow_zero=False)


def _check_number(value, name: str, *, allow_zero: bool) -> float:
    """``value`` as a finite float, > 0 (or >= 0 with ``allow_zero``), or a one-line error."""
    want = "a non-negative" if allow_zero else "a positive"
    if isinstance(value, bool):
        raise InputError(f"{name}: expected {want} number, got {value!r}")
    try:
        value = float(value)
    except (TypeError, ValueError):
        raise InputError(f"{name}: expected {want} number, got {value!r}") from None
    if not np.isfinite(value) or value < 0 or (value == 0 and not allow_zero):
        raise InputError(f"{name}: expected {want} number, got {value}")
    return value


def _validate_points_of(points, n: int) -> np.ndarray:
    """``points`` as a finite (n, 3) float64 array (the cloud of a map of n rows)."""
    X = _float_rows(points, "points", 3)
    if len(X) != n:
        raise InputError(f"points: expected shape ({n}, 3) (one row per map row), got {X.shape}")
    return X


def _check_non_negative(value, name: str) -> float:
    return _check_number(value, name, allow_zero=True)


def _edge_lengths(U: np.ndarray, T: np.ndarray) -> np.ndarray:
    """Length of edge (T[:, k], T[:, k+1]) for k = 0, 1, 2. (M, 3)"""
    return np.linalg.norm(U[T] - U[np.roll(T, -1, axis=1)], axis=2)


def local_spacing(U, T) -> np.ndarray:
    """Median length of the triangulation's edges at each vertex.

    Parameters
    ----------
    U : (N, 2) array_like
        Points.
    T : (M, 3) array_like of int
        Triangles (e.g. the Delaunay triangulation of ``U``).

    Returns
    -------
    (N,) float64
        NaN for a point on no triangle.
    """
    U = np.asarray(U, dtype=np.float64)
    T = np.asarray(T, dtype=np.int64)
    E = unique_edges(T)  # (E, 2) undirected edges, each once
    length = np.linalg.norm(U[E[:, 0]] - U[E[:, 1]], axis=1)
    vertex = np.concatenate([E[:, 0], E[:, 1]])  # each edge at both of its ends
    length = np.concatenate([length, length])
    order = np.lexsort((length, vertex))
    vertex, length = vertex[order], length[order]
    start = np.searchsorted(vertex, np.arange(len(U) + 1))
    count = np.diff(start)
    out = np.full(len(U), np.nan)
    has = count > 0
    # The median of a sorted run: mean of its two middle entries (equal for odd counts).
    lo = start[:-1] + (count - 1) // 2
    hi = start[:-1] + count // 2
    out[has] = 0.5 * (length[lo[has]] + length[hi[has]])
    return out


def hole_width(X, loop, spacing) -> float:
    """Width of a hole on the surface, in local spacings: ``2 A / (P s)``.

    Parameters
    ----------
    X : (N, 3) array_like
        The cloud.
    loop : (K,) array_like of int
        The hole's loop, rows of ``X`` in order.
    spacing : (N,) array_like
        Local point spacing (e.g. :func:`local_spacing` of the kept triangles in 3D).

    Returns
    -------
    float
        ``A``: area of the loop's 3D polygon (the norm of its vector area about its centroid);
        ``P``: its 3D perimeter; ``s``: the median of ``spacing`` over the loop. ``2 A / P``
        is the radius of a round hole and the half-width of a slit; 0 for a degenerate loop.
    """
    X = np.asarray(X, dtype=np.float64)
    loop = np.asarray(loop, dtype=np.int64)
    Q = X[loop] - X[loop].mean(axis=0)  # (K, 3)
    nxt = np.roll(Q, -1, axis=0)
    perimeter = float(np.linalg.norm(nxt - Q, axis=1).sum())
    area = 0.5 * float(np.linalg.norm(np.cross(Q, nxt).sum(axis=0)))
    s = float(np.median(np.asarray(spacing, dtype=np.float64)[loop]))
    if perimeter <= 0 or not s > 0:
        return 0.0
    return 2.0 * area / (perimeter * s)


def _kept(U: np.ndarray, T: np.ndarray, h: float | None, c: float) -> np.ndarray:
    """Which Delaunay triangles stay: longest edge <= h, or the two-pass local rule."""
    L = _edge_lengths(U, T)  # (M, 3)
    if h is not None:
        return L.max(axis=1) <= h
    area2 = 2.0 * np.abs(signed_areas(U, T))
    with np.errstate(divide="ignore"):
        R = L.prod(axis=1) / (2.0 * area2)  # abc / (4 A); inf for a degenerate triangle
    first = local_spacing(U, T)  # (K,) every Delaunay edge counts, those across gaps too
    keep = R <= c * np.median(first[T], axis=1)
    # Second pass: spacing from the kept triangles only, so that the edges a gap's fan adds at
    # its border vertices no longer inflate it (a point with no kept triangle keeps its first
    # value).
    second = local_spacing(U, T[keep])
    second = np.where(np.isnan(second), first, second)
    return R <= c * np.median(second[T], axis=1)


CLOUD_NEIGHBOURS = 4
"""The cloud's spacing at a point for ``cloud_spacing``: its mean distance to this many
nearest points."""


def _kept_in_cloud(X: np.ndarray, T: np.ndarray, c: float) -> np.ndarray:
    """Which triangles ``T`` (rows of the cloud ``X``) have a 3D circumradius of at most ``c``
    times the median of the cloud's spacing at their vertices."""
    from scipy.spatial import cKDTree

    d, _ = cKDTree(X).query(X, k=min(CLOUD_NEIGHBOURS + 1, len(X)))
    spacing = d[:, 1:].mean(axis=1)  # (N,) itself excluded
    L = np.linalg.norm(X[T] - X[np.roll(T, -1, axis=1)], axis=2)  # (M, 3)
    a, b, e = L[:, 0], L[:, 1], L[:, 2]
    area4 = np.sqrt(np.maximum((a + b + e) * (-a + b + e) * (a - b + e) * (a + b - e), 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        R = np.where(area4 > 0, a * b * e / area4, np.inf)  # abc / (4 A)
    return R <= c * np.median(spacing[T], axis=1)


def _walk_loops(U: np.ndarray, T: np.ndarray) -> list[np.ndarray]:
    """Closed loops of the boundary edges of triangles ``T`` (counter-clockwise), as vertex
    sequences, with the removed region on the right of each walk."""
    K = len(U)
    half = np.stack([T, np.roll(T, -1, axis=1)], axis=2).reshape(-1, 2)  # (3M, 2) a -> b
    key = half[:, 0] * K + half[:, 1]
    twin = half[:, 1] * K + half[:, 0]
    bd = half[~np.isin(twin, key)]  # edges of one triangle only, kept triangle on the left
    if len(bd) == 0:
        return []
    bd = bd[np.lexsort((bd[:, 1], bd[:, 0]))]  # by tail vertex, deterministic
    start = np.searchsorted(bd[:, 0], np.arange(K + 1))
    out_degree = np.diff(start)
    # Next edge after a -> b: the only edge leaving b, or, where several leave b (loops touch
    # there), the first one counter-clockwise from the incoming direction b -> a.
    nxt = start[bd[:, 1]].copy()
    for e in np.flatnonzero(out_degree[bd[:, 1]] > 1):
        a, b = bd[e]
        cand = np.arange(start[b], start[b + 1])
        d_in = U[a] - U[b]
        d_out = U[bd[cand, 1]] - U[b]
        turn = (np.arctan2(d_out[:, 1], d_out[:, 0]) - np.arctan2(d_in[1], d_in[0])) % (2 * np.pi)
        turn[turn == 0.0] = 2 * np.pi  # going back along the same edge comes last
        nxt[e] = cand[np.argmin(turn)]
    nxt_list = nxt.tolist()
    tail = bd[:, 0].tolist()
    seen = bytearray(len(bd))
    loops = []
    for first in range(len(bd)):
        if seen[first]:
            continue
        loop, e = [], first
        while not seen[e]:
            seen[e] = 1
            loop.append(tail[e])
            e = nxt_list[e]
        loops.append(np.array(loop, dtype=np.int64))
    return loops


def _start_at_smallest(loop: np.ndarray) -> np.ndarray:
    return np.roll(loop, -int(np.argmin(loop)))


def detect_boundary(U, h: float | None = None, *, c: float = DEFAULT_C,
                    min_loop: int = DEFAULT_MIN_LOOP, points=None,
                    min_width: float = DEFAULT_MIN_WIDTH,
                    cloud_spacing: bool = False, kinds: bool = True) -> BoundaryLoops:
    """Boundary loops of a free-boundary map: Delaunay, long triangles removed, loops ordered.

    Parameters
    ----------
    U : (N, 2) array_like
        The map, one row per point of the cloud (e.g. ``ParamResult.uv``). Duplicate rows are
        allowed: each distinct map point is triangulated once, and a loop names the first
        (smallest) of its rows.
    h : float, optional
        The paper's rule: remove every Delaunay triangle with an edge longer than ``h`` (map
        units). Default: the local rule of the module docstring, which needs no scale.
    c : float
        Factor of the local rule (a triangle goes when its circumradius exceeds ``c`` times
        the local spacing); ignored when ``h`` is given.
    min_loop : int
        Loops with fewer distinct points are dropped (``BoundaryLoops.dropped``). The default
        8 is measured (module docstring): the gaps that uneven sampling leaves on the test
        surfaces' maps have up to 7 points, their smallest true loop 20. A hole only a few
        point spacings across has fewer points and cannot be told from a sampling gap.
    points : (N, 3) array_like, optional
        The cloud the map was made from (same rows). With it, each hole's width on the
        surface is measured (``BoundaryLoops.widths``), and holes narrower than
        ``min_width`` local spacings are dropped (module docstring).
    min_width : float
        Narrowest hole kept, in local spacings (:func:`hole_width`); the default 0 keeps
        every hole. Used only with ``points``.
    cloud_spacing : bool
        Also remove the triangles whose 3D circumradius exceeds ``c`` times the cloud's own
        spacing at their vertices (module docstring: for evenly sampled clouds whose map
        shrinks small holes). Needs ``points``.
    kinds : bool
        With ``points``: cast the candidates wide (the map's rule and ``cloud_spacing``),
        judge each loop by its evidence in 3D (:mod:`pcgeom.apps.loop_kinds`) and keep the
        outer loop and the holes; the gaps of the sampling are spanned by the kept triangles
        and listed apart (``BoundaryLoops.gaps``); each hole's loop walks through the
        notches of its rim (module docstring). ``False``: every loop of the rule, as
        without ``points``. Not with ``h`` (the paper's rule stays as it is).

    Returns
    -------
    BoundaryLoops
        Loops as input rows, outer first; also the kept and the removed triangles.

    Raises
    ------
    InputError
        ``U`` not (N, 2), with NaN or inf, fewer than 3 distinct points, or all on one line;
        ``h`` or ``c`` not a positive number; ``min_loop`` not an integer >= 3;
        ``points`` not (N, 3) finite with the rows of ``U``; ``min_width`` negative;
        ``cloud_spacing`` without ``points``.

    Notes
    -----
    Points that the triangulation leaves out (Qhull drops a point closer to another than its
    rounding error) are on no loop. Triangles and loops are in input rows: for duplicates,
    the smallest row.
    """
    U = validate_map(U)
    if h is not None:
        h = _check_positive(h, "h")
    c = _check_positive(c, "c")
    if (isinstance(min_loop, bool) or not isinstance(min_loop, (int, np.integer))
            or min_loop < 3):
        raise InputError(f"min_loop: expected an integer >= 3, got {min_loop!r}")
    X = None
    if points is not None:
        X = _validate_points_of(points, len(U))
        min_width = _check_non_negative(min_width, "min_width")
    elif cloud_spacing:
        raise InputError("cloud_spacing: needs the cloud (points)")
    unique, row = distinct_points(U)

    T = delaunay(unique)
    keep = _kept(unique, T, h, c)
    judge, gaps, gap_evidence = None, [], []
    if X is not None and kinds and h is None:
        keep, judge, gaps, gap_evidence = _judged(unique, T, X[row], keep, c, min_loop)
        gaps = [_start_at_smallest(row[loop]) for loop in gaps]
    elif cloud_spacing:
        keep &= _kept_in_cloud(X, row[T], c)
    walked = judged = _walk_loops(unique, T[keep])
    if judge is not None:
        carved = _carve_notches(unique, T, keep, X[row], min_loop)
        if (carved != keep).any():
            keep, walked = carved, _walk_loops(unique, T[carved])
            judged = _loops_before(walked, judged, len(unique))
    loops = [_start_at_smallest(row[loop]) for loop in walked]
    areas = [shoelace(U[loop]) for loop in loops]
    # Largest enclosed area first (ties: smallest row); the outer loop, the largest
    # counter-clockwise one, then moves to the front.
    order = sorted(range(len(loops)), key=lambda i: (-abs(areas[i]), int(loops[i][0])))
    kept = [i for i in order if len(np.unique(loops[i])) >= min_loop]
    widths = np.full(len(loops), np.nan)
    if X is not None:
        spacing = local_spacing(X, row[T[keep]])  # 3D lengths of the kept edges
        for i in kept:
            if areas[i] < 0:  # a hole (clockwise)
                widths[i] = hole_width(X, loops[i], spacing)
        kept = [i for i in kept if not widths[i] < min_width]  # NaN (not a hole) stays
    dropped = [i for i in order if i not in set(kept)]
    if kept:
        kept.insert(0, kept.pop(int(np.argmax([areas[i] for i in kept]))))
    evidence = None
    if judge is not None:
        evidence = [judge.evidence(judged[i], outer=(k == 0 or areas[i] > 0)) for k, i in
                    enumerate(kept)]
    return BoundaryLoops(
        loops=[loops[i] for i in kept],
        areas=np.array([areas[i] for i in kept], dtype=np.float64),
        h=h,
        c=None if h is not None else c,
        min_loop=int(min_loop),
        dropped=[loops[i] for i in dropped],
        triangles=row[T[keep]],
        removed=row[T[~keep]],
        widths=None if X is None else widths[kept],
        min_width=None if X is None else float(min_width),
        evidence=evidence,
        gaps=gaps,
        gap_evidence=gap_evidence,
    )


def _judged(U: np.ndarray, T: np.ndarray, X: np.ndarray, keep: np.ndarray, c: float,
            min_loop: int) -> tuple[np.ndarray, LoopJudge, list[np.ndarray], list[dict]]:
    """The kept triangles once each candidate loop is judged (:mod:`.loop_kinds`): the
    outside as the map's rule ``keep`` leaves it, the holes removed, everything else kept
    (gaps, and loops of fewer than ``min_loop`` points, spanned). Also the judge and the gaps
    (indices of ``U``, largest perimeter first) with their evidence."""
    candidate = keep & _kept_in_cloud(X, T, c)
    judge = LoopJudge(X, T, keep, candidate)
    loops = _walk_loops(U, T[candidate])
    if not loops:
        return keep, judge, [], []
    areas = np.array([shoelace(U[loop]) for loop in loops])
    outside = judge.regions_of(loops[int(np.argmax(areas))])
    holes, gaps = set(), []
    for loop, area in zip(loops, areas):
        regions = judge.regions_of(loop)
        if area > 0 or regions & outside or len(np.unique(loop)) < min_loop:
            continue  # the outside, an island (its hole's loop decides), or too small
        found = judge.evidence(loop, outer=False)
        if found["kind"] == "hole":
            holes |= regions
        else:
            gaps.append((loop, found))
    gaps = [(loop, found) for loop, found in gaps if not judge.regions_of(loop) & holes]
    gaps.sort(key=lambda g: -g[1]["perimeter"])
    out = np.ones(len(T), dtype=bool)
    region = judge.labels
    at_outside = np.isin(region, list(outside))
    out[judge.removed[at_outside]] = keep[judge.removed[at_outside]]
    out[judge.removed[np.isin(region, list(holes))]] = False
    return out, judge, [g[0] for g in gaps], [g[1] for g in gaps]


NOTCH_ANGLE_DEG = 65.0
"""A kept triangle on a hole's rim whose angle opposite the rim edge (in 3D) is at least this
wide is a notch of the rim (module docstring, "Rims two points thick")."""

NOTCH_CHORD = 1.05
"""... when that rim edge is also at least this many times as long as the mean of the two
loop edges beside it (a chord across a point set back, not a step of a smooth rim)."""

NOTCH_ROUNDS = 2
"""Rounds of notch carving (a carved point's own notches are carved in the next round)."""


def _carve_notches(U: np.ndarray, T: np.ndarray, keep: np.ndarray, X: np.ndarray,
                   min_loop: int) -> np.ndarray:
    """``keep`` without the notches of the holes' rims: a kept triangle with one edge on a
    hole's loop (of ``min_loop`` points or more), its angle opposite that edge at least
    :data:`NOTCH_ANGLE_DEG` in 3D, that edge at least :data:`NOTCH_CHORD` times the loop
    edges beside it, its third point on no loop; the loop then walks through that point.
    :data:`NOTCH_ROUNDS` rounds, one triangle per point a round."""
    keep = keep.copy()
    limit = np.cos(np.radians(NOTCH_ANGLE_DEG))
    for _ in range(NOTCH_ROUNDS):
        at = np.flatnonzero(keep)
        F = T[at]
        loops = _walk_loops(U, F)
        if not loops:
            break
        on_loop = np.zeros(len(U), dtype=bool)
        on_loop[np.concatenate(loops)] = True
        # Each hole's edge a -> b and the mean length of the loop edges beside it.
        chord, beside = [], []
        for loop in loops:
            if shoelace(U[loop]) >= 0 or len(np.unique(loop)) < min_loop:
                continue
            nxt = np.roll(loop, -1)
            length = np.linalg.norm(X[nxt] - X[loop], axis=1)
            chord.append(np.stack([loop, nxt], axis=1))
            beside.append(0.5 * (np.roll(length, 1) + np.roll(length, -1)) / length)
        if not chord:
            break
        chord, beside = np.concatenate(chord), np.concatenate(beside)
        edges = half_edges(F)  # (3M, 2): the kept triangle of a loop edge a -> b has a -> b
        eid = edge_ids(edges)
        rim = np.bincount(eid)[eid] == 1
        face = np.arange(len(edges)) % len(F)
        n = len(U)
        key = edges[:, 0] * n + edges[:, 1]
        order = np.argsort(key)
        pos = np.searchsorted(key[order], chord[:, 0] * n + chord[:, 1])
        pos = np.minimum(pos, len(order) - 1)
        found = key[order][pos] == chord[:, 0] * n + chord[:, 1]
        half = order[pos][found]
        beside = beside[found]
        c = opposite_corners(F)[half]
        u, w = X[edges[half, 0]] - X[c], X[edges[half, 1]] - X[c]
        cos = (u * w).sum(axis=1) / np.maximum(
            np.linalg.norm(u, axis=1) * np.linalg.norm(w, axis=1), 1e-300)
        one_rim = np.bincount(face[rim], minlength=len(F)) == 1
        pick = (cos <= limit) & (beside * NOTCH_CHORD <= 1.0) & ~on_loop[c] \
            & one_rim[face[half]]
        _, first = np.unique(c[pick], return_index=True)
        carve = face[half[pick][first]]
        if not len(carve):
            break
        keep[at[carve]] = False
    return keep


def _loops_before(loops: list[np.ndarray], before: list[np.ndarray], n: int
                  ) -> list[np.ndarray]:
    """For each loop after carving, the loop it was before (the one most of its points were
    on: carving only adds points to a loop), or itself."""
    owner = np.full(n, -1, dtype=np.int64)
    for j, loop in enumerate(before):
        owner[loop] = j
    out = []
    for loop in loops:
        was = owner[loop]
        was = was[was >= 0]
        out.append(before[int(np.bincount(was).argmax())] if len(was) else loop)
    return out


def unkept_holes(U, domain, points=None, **options) -> tuple[int, int]:
    """How many holes a map onto ``domain`` shows, and how many the domain has.

    The holes of the cloud are the hole loops of :func:`detect_boundary` on its map (a
    hole of the surface stays an empty region of the map whatever the domain); a mesh of
    the domain itself (``pcgeom reconstruct --domain``) fills every one beyond the
    domain's own holes.

    Parameters
    ----------
    U : (N, 2) array_like
        The map onto ``domain``.
    domain : pcgeom.domains.Domain
        A bounded domain (its holes: its boundary loops but the outer one).
    points : (N, 3) array_like, optional
        The surface the map was made of, as :func:`detect_boundary` takes it.
    **options
        ``min_width``, ``cloud_spacing`` as :func:`detect_boundary`.

    Returns
    -------
    (int, int)
        The map's holes and the domain's.
    """
    found = detect_boundary(U, points=points, **options)
    return int((np.asarray(found.areas) < 0).sum()), len(domain.boundary_loops()) - 1

