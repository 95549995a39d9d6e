"""The evidence on each boundary loop of a cloud's map, and its kind: ``outer``, ``hole`` or
``gap`` (a hole of the sampling, not of the surface). Used by
:func:`pcgeom.apps.boundary.detect_boundary` when it has the cloud.

Why evidence, and which
-----------------------
A loop of the map is a region with no triangle of the surface in it. A rule on the map alone
cannot tell a hole of the surface from a gap of the sampling (the module docstring of
:mod:`pcgeom.apps.boundary` lists the rules measured and rejected): face_human_choi's bare
map opens 20-odd gaps where its rows of points jump from coarse to dense, while
peaks_7holes_choi's true holes are only about three spacings across and its map crushes five of
them. So the candidates are cast wide (the map's local rule and the cloud's own spacing,
``cloud_spacing``) and each is judged in 3D against the sampling around it:

- ``empty_spacings``: the loop's own largest empty circle, the largest distance from the
  centre of one of its region's triangles' smallest enclosing circles to the nearest point of
  the cloud, in local spacings (:func:`pcgeom.maps.topology.knn_spacing`);
- ``sampling_empty_spacings``: the widest empty circle the sampling leaves around it,
  :func:`pcgeom.maps.topology.widest_empty` of the enclosing radii (in local spacings) of the
  map rule's kept triangles within :data:`NEAR` spacings of its points (where rows lie
  several spacings apart, the triangles across them set it high, and a gap between rows
  falls under it), and at least the same over the whole map (a large random sample leaves,
  somewhere, circles wider than any neighbourhood's own extrapolated widest: a 320k-point
  random sheet read 520 false holes on the local figure alone);
- ``empty_ratio``: the first over the second;
- ``perimeter`` (3D, input units) and ``perimeter_spacings``; ``width_spacings``, the 3D
  inradius estimate ``2 A / P`` in local spacings (:func:`pcgeom.apps.boundary.hole_width`);
  ``roundness``, ``2 pi width / perimeter`` (1 for a circle, small for a slit one or two
  rows wide: the gaps that run along rows);
- ``normals_agree``: the share of the loop's edges whose ends' PCA normals (16 neighbours)
  agree within :data:`NORMALS_DEG` degrees (a loop where the surface folds or two sheets
  meet has a rim whose normals disagree: its kind is less certain).

A loop that is not the outer one is a ``hole`` when ``empty_ratio >= HOLE_RATIO`` and
``roundness >= HOLE_ROUNDNESS``, or ``empty_ratio >= SURE_RATIO``, else a ``gap``; a
counter-clockwise loop inside a hole (an island) keeps the kind ``outer``, one inside a gap goes
with the gap. ``confidence`` is
``(1 - exp(-|ln q| / CONFIDENCE_SCALE)) * (1 + normals_agree) / 2`` with ``q =
max(min(empty_ratio / HOLE_RATIO, roundness / HOLE_ROUNDNESS), empty_ratio / SURE_RATIO)``
(a hole when ``q >= 1``): near the thresholds, or where
normals disagree, it is low. The outer loop (the rim of the kept triangles, always there):
``(1 + normals_agree) / 2``. A gap's triangles go back into the kept ones (the surface spans it), so
it leaves no loop; it is listed apart with its evidence.

Measured on the ``fast`` maps of the shared surfaces (loops of 8 points or more; true loops
from their meshes), each candidate's ``empty_ratio`` / ``roundness`` on the local figure
alone (the whole map's floor only lowers the ratios where it is the higher):

=========================  =====================================  ==============================
map                        true holes                             false loops (highest ratios)
=========================  =====================================  ==============================
peaks_7holes, bare         1.17-2.04 / 0.33-0.74 (all 7)          1.09 / 0.45
peaks_7holes, normals      1.28-1.95 / 0.33-1.03 (all 7)          1.09 / 0.45
face_3holes_small          3.8-8.8 / 0.42-1.03 (all 3)            none
peaks_three_cgal, bare     none                                   1.37 / 0.13, 1.35 / 0.15
peaks_three_cgal, normals  none                                   1.38 / 0.39, 1.16 / 0.57
face_human, bare           none                                   3.46 / 0.53, 2.61 / 0.61, then
                                                                  1.24 / 0.08 and lower
face_human, normals        none                                   1.06 / 0.09 and lower
=========================  =====================================  ==============================

So ``HOLE_RATIO = 1.15`` and ``HOLE_ROUNDNESS = 0.3``. With the whole map's floor (face_human's
map, bare: 4.5 spacings, which its two round gaps do not reach), loops marked hole / of them
not holes: peaks_7holes 7 / 0 (bare and with normals), face_3holes_small 3 / 0,
peaks_three_cgal bare 0, with normals 1 / 1, face_human 0 bare and with normals. Holes on the
order of the sampling's own widest circles cannot be told from gaps: on holed sheets of 50k
points with the true parameters as the map, holes of radius 1-5 spacings, grid sampling 4 of
5 found (radius 1 not), uniform and scan (density falling 4x) 5 holes marked and some false
ones among the thousands of candidate gaps.
"""

from __future__ import annotations

import numpy as np

from ..maps.topology import enclosing_radius, knn_spacing, widest_empty

__all__ = ["HOLE_RATIO", "HOLE_ROUNDNESS", "SURE_RATIO", "NEAR", "NORMALS_DEG", "CONFIDENCE_SCALE",
           "LoopJudge", "enclosing_centres"]

HOLE_RATIO = 1.15
"""A loop is a hole when its own largest empty circle is at least this many times the widest
the sampling leaves around it (module docstring)."""

HOLE_ROUNDNESS = 0.3
"""... and its roundness ``2 pi width / perimeter`` at least this."""

SURE_RATIO = 2.0
"""... or, whatever its roundness, its empty circle at least this many times the sampling's: a
hole that the candidates joined to the sampling's gaps beside it (on random samples) comes out
long and winding."""

NEAR = 6.0
"""The sampling around a loop: the kept triangles within this many local spacings of its
points."""

NORMALS_DEG = 30.0
"""Two rim points' normals agree within this many degrees."""

CONFIDENCE_SCALE = 0.15
"""How fast ``confidence`` rises with the distance ``|ln q|`` from the thresholds."""

PCA_NEIGHBOURS = 16
"""Neighbours of the PCA normals of ``normals_agree``."""


def enclosing_centres(X: np.ndarray, F: np.ndarray) -> np.ndarray:
    """(M, 3) centre of each triangle's smallest enclosing circle: its circumcentre when it is
    acute, the midpoint of its longest edge otherwise (as
    :func:`pcgeom.maps.topology.enclosing_radius`)."""
    A, B, C = X[F[:, 0]], X[F[:, 1]], X[F[:, 2]]
    ab, ac = B - A, C - A
    n = np.cross(ab, ac)
    circum = A + (np.cross(n, ab) * (ac * ac).sum(axis=1)[:, None]
                  + np.cross(ac, n) * (ab * ab).sum(axis=1)[:, None]) / np.maximum(
        2.0 * (n * n).sum(axis=1), 1e-300)[:, None]
    e2 = np.stack([((B - C) ** 2).sum(axis=1), ((C - A) ** 2).sum(axis=1),
                   ((A - B) ** 2).sum(axis=1)], axis=1)
    mids = np.stack([B + C, C + A, A + B], axis=1)[np.arange(len(F)), e2.argmax(axis=1)] / 2
    obtuse = 2.0 * e2.max(axis=1) >= e2.sum(axis=1)
    return np.where(obtuse[:, None], mids, circum)


def _regions(T: np.ndarray, n: int) -> tuple[np.ndarray, dict]:
    """Connected pieces of the triangles ``T`` through shared edges: each triangle's label,
    and each undirected edge key ``a * n + b`` (a < b) to one triangle that has it."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    m = len(T)
    E = np.sort(np.concatenate([T[:, [0, 1]], T[:, [1, 2]], T[:, [2, 0]]]), axis=1)
    key = E[:, 0] * n + E[:, 1]
    tri = np.tile(np.arange(m), 3)
    order = np.argsort(key, kind="stable")
    same = key[order][1:] == key[order][:-1]
    A = coo_matrix((np.ones(int(same.sum())), (tri[order][:-1][same], tri[order][1:][same])),
                   shape=(m, m))
    labels = connected_components(A, directed=False)[1] if m else np.zeros(0, np.int64)
    return labels, dict(zip(key.tolist(), tri.tolist()))


class LoopJudge:
    """The evidence on loops of one map: built once from the cloud, the map's Delaunay
    triangles and the two rules' kept masks, then asked about loops.

    Parameters
    ----------
    X : (K, 3) float64
        The cloud, one row per distinct map point (the triangles' indices).
    T : (M, 3) int64
        The map's Delaunay triangles.
    reference : (M,) bool
        The map rule's kept triangles: the sampling around a loop.
    candidate : (M,) bool
        The kept triangles whose loops are judged (the map rule and the cloud's spacing).
    """

    def __init__(self, X: np.ndarray, T: np.ndarray, reference: np.ndarray,
                 candidate: np.ndarray):
        from scipy.spatial import cKDTree

        self.X, self.T, self.n = X, T, len(X)
        self.spacing = knn_spacing(X)
        ref = T[reference]
        self.ref_width = enclosing_radius(X, ref) / np.median(self.spacing[ref], axis=1)
        self.ref_tree = cKDTree(X[ref].mean(axis=1)) if len(ref) else None
        # The widest empty circle of the whole sampling: a floor under the local one, since
        # a large random sample leaves, somewhere, circles wider than any neighbourhood's
        # own extrapolated widest (320k uniform-random points: 520 false holes without it).
        self.whole_empty = widest_empty(self.ref_width) if len(ref) else 0.0
        self.removed = np.flatnonzero(~candidate)
        R = T[self.removed]
        self.labels, self.edge_to = _regions(R, self.n)
        self.tree = cKDTree(X)
        empty = (self.tree.query(enclosing_centres(X, R))[0]
                 / np.median(self.spacing[R], axis=1)) if len(R) else np.zeros(0)
        # Each removed region's largest empty circle.
        self.region_empty = np.zeros(int(self.labels.max()) + 1 if len(R) else 0)
        np.maximum.at(self.region_empty, self.labels, empty)
        self._normals: dict[int, np.ndarray] = {}

    def normals(self, rows: np.ndarray) -> np.ndarray:
        """(len(rows), 3) unoriented PCA normals of ``PCA_NEIGHBOURS`` neighbours at ``rows``
        (computed for the loops' points only, once each)."""
        todo = np.array([r for r in np.unique(rows).tolist() if r not in self._normals],
                        dtype=np.int64)
        if len(todo):
            k = min(PCA_NEIGHBOURS + 1, self.n)
            nb = self.tree.query(self.X[todo], k=k)[1]  # (t, k) itself first
            Q = self.X[nb] - self.X[nb].mean(axis=1, keepdims=True)
            vectors = np.linalg.eigh(np.einsum("tki,tkj->tij", Q, Q))[1][:, :, 0]
            self._normals.update(zip(todo.tolist(), vectors))
        return np.array([self._normals[r] for r in np.asarray(rows).tolist()])

    def regions_of(self, loop: np.ndarray) -> set:
        """The removed regions (labels) that the loop's edges border."""
        nxt = np.roll(loop, -1)
        key = np.minimum(loop, nxt) * self.n + np.maximum(loop, nxt)
        return {int(self.labels[self.edge_to[k]]) for k in key.tolist() if k in self.edge_to}

    def evidence(self, loop: np.ndarray, outer: bool) -> dict:
        """The figures of the module docstring for one loop (indices of ``X``), ``kind``
        (``"outer"`` when ``outer``, else hole or gap by the thresholds) and
        ``confidence``."""
        X, s = self.X, self.spacing
        nxt = np.roll(loop, -1)
        step = np.linalg.norm(X[nxt] - X[loop], axis=1)
        perimeter = float(step.sum())
        unit = float(np.median(s[loop]))
        Q = X[loop] - X[loop].mean(axis=0)
        area = 0.5 * float(np.linalg.norm(np.cross(Q, np.roll(Q, -1, axis=0)).sum(axis=0)))
        width = 2.0 * area / (perimeter * unit) if perimeter > 0 and unit > 0 else 0.0
        per_s = perimeter / unit if unit > 0 else 0.0
        roundness = 2.0 * np.pi * width / per_s if per_s > 0 else 0.0
        regions = self.regions_of(loop)
        empty = max((float(self.region_empty[r]) for r in regions), default=0.0)
        sampling = 0.0
        if self.ref_tree is not None:
            near = self.ref_tree.query_ball_point(X[loop], NEAR * s[loop])
            near = np.unique(np.concatenate([np.asarray(i, dtype=np.int64) for i in near]))
            sampling = widest_empty(self.ref_width[near]) if len(near) else 0.0
        sampling = max(sampling, self.whole_empty)
        ratio = empty / sampling if sampling > 0 else float("inf")
        normals = self.normals(loop)
        cos = np.abs((normals * np.roll(normals, -1, axis=0)).sum(axis=1))
        agree = float((cos >= np.cos(np.radians(NORMALS_DEG))).mean())
        q = max(min(ratio / HOLE_RATIO, roundness / HOLE_ROUNDNESS), ratio / SURE_RATIO)
        margin = abs(np.log(q)) if 0 < q < np.inf else np.inf
        confidence = (1.0 - np.exp(-margin / CONFIDENCE_SCALE)) * 0.5 * (1.0 + agree)
        if outer:  # the rim of the kept triangles: there is one, only its normals can doubt it
            kind, confidence = "outer", 0.5 * (1.0 + agree)
        else:
            kind = "hole" if q >= 1.0 else "gap"
        return {"kind": kind, "confidence": round(float(confidence), 4),
                "perimeter": perimeter, "perimeter_spacings": per_s, "width_spacings": width,
                "roundness": float(roundness), "empty_spacings": empty,
                "sampling_empty_spacings": float(sampling), "empty_ratio": float(ratio),
                "normals_agree": agree}
