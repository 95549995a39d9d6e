"""The region to mesh, as simple polygons gmsh can take: the map inside the detected loops
(:func:`_polygons`), or a bounded domain's boundary resampled to the element size
(:func:`_resample`).

Where loops touch
-----------------
Boundary detection can return loops that pass through one point twice (a hole touching the
rim or another hole at one point, or a rim pinched at one point; :mod:`pcgeom.apps.boundary`).
gmsh cannot mesh a polygon through a point twice, so each visit of such a point becomes its
own mesh vertex, moved a tenth of its shorter loop edge (:data:`TOUCH_STEP`) into its own
corner of the region (along the corner's bisector; the corner runs counter-clockwise from the
visit's outgoing edge to the next loop edge at the point). The copies are lifted like any vertex, so
the mesh's loops touch in 3D only up to that step: it stays edge-manifold, with one boundary
loop per detected loop. Loops that share an edge are refused (detection never makes them).

Where the map folds (a bare cloud whose sheets touch), the kept triangles overlap in the map
and the detected loops can cross themselves and each other, which gmsh cannot mesh (it does
not fail: it runs on). Such loops are repaired first: the region is the outer polygon minus
the union of the holes, each made valid by shapely (``make_valid``), shrunk by a thousandth
of the median loop edge (:data:`REPAIR_SHRINK`) so that no two rings share a point (a hole
that touched the rim then opens into it), and meshed part by part, largest first, without
the slivers under a hundredth of the largest part (:data:`REPAIR_MIN_PART`), and with the
ring points closer than a fifth of the median loop edge to their predecessor merged away
where the region stays valid (:data:`REPAIR_MIN_EDGE`: crossings leave such short edges, and
gmsh slivers at them); the mesh's loops are then those of the repaired region, which the
report counts. On face_human_choi as a bare cloud (its ``fast`` map folds 3.45% of the triangles),
11 pairs of its 19 detected holes overlap and 4 cross themselves.
"""

from __future__ import annotations

import numpy as np

from ...domains.base import CORNER_DEG
from ...errors import InputError
from ..boundary import BoundaryLoops

TOUCH_STEP = 0.1
"""Where loops touch, each visit of the shared point moves this fraction of its shorter loop
edge into its own corner of the region (module docstring)."""

REPAIR_SHRINK = 1e-3
"""Loops that cross (a folded map) are repaired into a region shrunk by this fraction of the
median loop edge, so that its rings share no point."""

REPAIR_MIN_EDGE = 0.2
"""In a repaired region, ring points closer than this fraction of the median loop edge to
the previous point are merged away (the crossings leave such edges; gmsh slivers at them)."""

REPAIR_MIN_PART = 0.01
"""Parts of a repaired region smaller than this fraction of the largest are left out (the
slivers between crossing loops)."""


def _polygons(U: np.ndarray, loops: BoundaryLoops) -> list[list[np.ndarray]]:
    """The region inside ``loops`` (one outer loop minus its holes) as simple map polygons:
    a list of parts, each its outer ring (counter-clockwise) and its holes (clockwise), with
    every point that rings share split into one copy per visit (module docstring)."""
    if not loops.loops:
        raise InputError("loops: no boundary loop; the reconstruction would be empty")
    rows = np.concatenate(loops.loops)
    if rows.min() < 0 or rows.max() >= len(U):
        raise InputError(f"loops: rows out of range for a map of {len(U)} points")
    edges = np.sort(np.concatenate([np.column_stack([loop, np.roll(loop, -1)])
                                    for loop in loops.loops]), axis=1)
    pairs, counts = np.unique(edges, axis=0, return_counts=True)
    if (counts > 1).any():
        a, b = pairs[counts > 1][0]
        raise InputError(f"loops: the edge of rows {int(a)} and {int(b)} is on loops twice; "
                         "loops may touch at points but not share edges")
    if loops.areas[0] <= 0:
        raise InputError("loops: the first loop must be the outer loop (counter-clockwise)")
    islands = [i for i, a in enumerate(loops.areas[1:], 1) if a > 0]
    if islands:
        raise InputError(f"loops: {len(islands)} more counter-clockwise loop(s) (separate "
                         "patches of the map); only one outer loop and its holes are supported")
    rings = [U[loop] for loop in loops.loops]
    if _simple_region(rings):
        parts = _split_shared([rings])
        if _valid(parts):
            return parts
    edge = float(np.median(np.concatenate([np.linalg.norm(np.roll(r, -1, axis=0) - r, axis=1)
                                           for r in rings])))
    parts = _repaired(rings, REPAIR_SHRINK * edge)
    # Crossing points make edges far shorter than the spacing, and gmsh slivers at them:
    # merge them away where the region stays valid.
    for i, part in enumerate(parts):
        for j in range(len(part)):  # ring by ring, each merge kept if its part stays valid
            trial = part[:j] + [_merge_short(part[j], REPAIR_MIN_EDGE * edge)] + part[j + 1:]
            if _valid([trial]):
                part = trial
        parts[i] = part
    if not _valid(parts):
        raise InputError("loops: the region inside the loops could not be made into simple "
                         "polygons for gmsh (the map folds there)")
    return parts


def _merge_short(ring: np.ndarray, min_edge: float) -> np.ndarray:
    """``ring`` without the points closer than ``min_edge`` to the previous kept point (at
    least 3 points stay)."""
    keep = [0]
    for k in range(1, len(ring)):
        if np.linalg.norm(ring[k] - ring[keep[-1]]) >= min_edge:
            keep.append(k)
    if len(keep) > 1 and np.linalg.norm(ring[keep[-1]] - ring[0]) < min_edge:
        keep.pop()
    return ring[keep] if len(keep) >= 3 else ring


def _valid(parts: list[list[np.ndarray]]) -> bool:
    """Every part a valid polygon (shapely), and no ring point used twice."""
    from shapely.geometry import Polygon

    allpts = np.concatenate([r for rings in parts for r in rings])
    if len(np.unique(allpts, axis=0)) < len(allpts):
        return False
    return all(Polygon(rings[0], rings[1:]).is_valid for rings in parts)


def _simple_region(rings: list[np.ndarray]) -> bool:
    """Whether the outer ring and the holes are simple, the holes inside the outer ring and
    apart from each other (touching at points allowed): what gmsh can mesh once the shared
    points are split."""
    from shapely import STRtree
    from shapely.geometry import LinearRing, Polygon

    if not all(LinearRing(r).is_simple for r in rings):
        return False
    outer = Polygon(rings[0])
    holes = [Polygon(r) for r in rings[1:]]
    if not all(outer.covers(h) for h in holes):
        return False
    tree = STRtree(holes)
    for i, h in enumerate(holes):
        for j in tree.query(h):
            if j > i and h.intersection(holes[j]).area > 0:
                return False
    return True


def _repaired(rings: list[np.ndarray], shrink: float) -> list[list[np.ndarray]]:
    """Where the map folds, detected loops can cross themselves and each other: the region is
    then the outer polygon minus the union of the holes, each made valid by shapely
    (``make_valid``: a self-crossing ring becomes the polygons it bounds), shrunk by
    ``shrink`` (map units) so that no two rings share a point; its parts of at least
    :data:`REPAIR_MIN_PART` of the largest one's area, largest first."""
    from shapely import make_valid, unary_union
    from shapely.geometry import Polygon
    from shapely.geometry.polygon import orient

    def valid(ring):
        return make_valid(Polygon(ring))

    region = valid(rings[0]).difference(unary_union([valid(r) for r in rings[1:]]))
    region = region.buffer(-shrink, join_style="mitre")
    parts = sorted((g for g in getattr(region, "geoms", [region])
                    if g.geom_type == "Polygon" and g.area > 0), key=lambda g: -g.area)
    if not parts:
        raise InputError("loops: the holes cover the outer loop; the reconstruction would be "
                         "empty")
    out = []
    for part in parts:
        if part.area < REPAIR_MIN_PART * parts[0].area:
            break
        part = orient(part, 1.0)  # exterior counter-clockwise, holes clockwise
        out.append([np.asarray(part.exterior.coords)[:-1]]
                   + [np.asarray(h.coords)[:-1] for h in part.interiors])
    return out


def _split_shared(parts: list[list[np.ndarray]]) -> list[list[np.ndarray]]:
    """Each ring point that appears more than once (in one ring or several) moved into its
    own corner of the region at each visit.

    The region is on the left of every ring edge, so at a visit of point ``v`` (on to ``q``)
    it fills the corner counter-clockwise from ``v -> q`` to the next ring edge at ``v``, of
    any visit (as boundary detection walks). The copy goes along that corner's bisector,
    :data:`TOUCH_STEP` times the shorter of the visit's two edges: the corners of the visits
    do not overlap, so the copies are distinct and the rings simple.
    """
    visits: dict[tuple, list] = {}  # point -> [(part, ring, k, angle out, angle back)]
    for i, rings in enumerate(parts):
        for j, ring in enumerate(rings):
            nxt, prv = np.roll(ring, -1, axis=0) - ring, np.roll(ring, 1, axis=0) - ring
            a_out = np.arctan2(nxt[:, 1], nxt[:, 0])
            a_back = np.arctan2(prv[:, 1], prv[:, 0])
            step = TOUCH_STEP * np.minimum(np.linalg.norm(nxt, axis=1),
                                           np.linalg.norm(prv, axis=1))
            for k, key in enumerate(map(tuple, ring.tolist())):
                visits.setdefault(key, []).append((i, j, k, a_out[k], a_back[k], step[k]))
    out = [[ring.copy() for ring in rings] for rings in parts]
    for key, here in visits.items():
        if len(here) < 2:
            continue
        angles = np.array([a for v in here for a in (v[3], v[4])])  # every edge at the point
        for i, j, k, a_out, _, step in here:
            turn = (angles - a_out) % (2 * np.pi)
            turn[turn < 1e-12] = 2 * np.pi  # its own outgoing edge bounds the corner last
            angle = a_out + 0.5 * turn.min()
            out[i][j][k] = np.asarray(key) + step * np.array([np.cos(angle), np.sin(angle)])
    return out


def _resample(loop: np.ndarray, size: float) -> np.ndarray:
    """A closed polyline (last row = first) resampled by arc length to about one point per
    ``size``, through its corners (turns over :data:`pcgeom.domains.base.CORNER_DEG`); at
    least 3 points."""
    ring = loop[:-1] if np.allclose(loop[0], loop[-1]) else loop
    d_out = np.roll(ring, -1, axis=0) - ring
    d_in = ring - np.roll(ring, 1, axis=0)
    turn = np.abs(np.arctan2(d_in[:, 0] * d_out[:, 1] - d_in[:, 1] * d_out[:, 0],
                             np.einsum("ij,ij->i", d_in, d_out)))
    corners = np.flatnonzero(turn > np.radians(CORNER_DEG))
    if len(corners) == 0:
        corners = np.array([0])
    out = []
    for a, b in zip(corners, np.roll(corners, -1)):
        # The run of polyline from corner a to the next corner b (all the way round if one).
        idx = np.arange(a, a + ((b - a) % len(ring) or len(ring)) + 1) % len(ring)
        run = ring[idx]
        s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(run, axis=0), axis=1))])
        n = max(1, int(round(s[-1] / size)), 3 if len(corners) == 1 else 1)
        t = np.linspace(0.0, s[-1], n + 1)[:-1]  # the next corner starts the next run
        out.append(np.column_stack([np.interp(t, s, run[:, 0]), np.interp(t, s, run[:, 1])]))
    return np.concatenate(out)
