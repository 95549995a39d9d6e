"""A first map of the local mesh onto any bounded domain: aligned, holes matched, harmonic.

The networks of the paper pull a cloud onto a domain by HAND from a start that knows nothing
of the domain's holes, so a hole of the cloud lands wherever the first stages happen to put it
(three-hole face onto the smiling face, ``networks``: no hole on its eye or mouth). The local
mesh (:mod:`pcgeom.maps.localmesh`) has boundary loops, and so has the domain; matching them gives a
start in which every hole is where it belongs:

1. **Loops.** The mesh is made vertex-manifold; its boundary loops in the free LSCM map are
   the outer loop (largest area) and the holes, by decreasing area. The domain's loops are its
   outer ring and its holes (:meth:`pcgeom.domains.Domain.boundary_loops`).
2. **Alignment.** A similarity (mirror or not: estimated normals have no preferred side) takes
   the free map onto the domain: the scale matches the areas, the translation the area
   centroids. The rotation and the pairing of the mesh's largest holes with the domain's holes
   are chosen together, among every pairing and the Procrustes rotation of each (plus 72 evenly
   spaced rotations), by the smallest mean squared distance of the moved loops to the rings
   they are paired with, plus the squared distances between paired hole centroids, plus the
   Chamfer distance of the landmark points to their targets when there are landmarks.
3. **Boundary values.** Each paired loop is laid on its ring by its arc length in the free
   map, from the circular shift that puts it closest to its aligned position (the ring's
   orientation: outer counter-clockwise, holes clockwise). Loops left unpaired (holes of the
   mesh that are not holes of the domain) stay free.
4. **Harmonic extension.** The interior is the harmonic map with those boundary values
   (libigl's cotangent Laplacian), as the disk map of :func:`pcgeom.maps.disk.conformal_disk`.

A harmonic map onto a region that is not convex may cross a hole near its rim; the
refinement that follows (:attr:`pcgeom.config.LocalMeshConfig.domain_refine`: LEG on local
pairs, HAND onto the domain) mends most of that. Moving the points left outside onto the
nearest boundary point afterwards was measured and left out: it changed no Hausdorff distance
(the largest gap inside sets it) and raised the angle distortion (smile: 0.100 -> 0.108 rad).

Measured on face_3holes_small_choi (5053 points, estimated normals) onto ``smile``: every hole
lands on its eye or the mouth; 0.296 rad from this map, 0.098 rad after the refinement, 48 s
on 2 cores (the networks, without this start: no hole lands, 0.155 rad, 287 s).
"""

from __future__ import annotations

import dataclasses
import itertools
import time
import math
from dataclasses import dataclass

import numpy as np

import torch

from ..config import InjectiveConfig, ParamConfig
from ..config.barrier import LANDMARKS_INJECTIVE
from ..domains import Disk, Domain
from ..errors import InputError
from ..losses import landmark_hand
from ..mesh import boundary_loops, face_keys, main_part, one_fan, shoelace, signed_areas
from ..metrics import hausdorff
from ..train.data import TrainData
from ..train.objective import Objective
from ._sparse import spd_factor
from .disk import conformal_disk
from .free import conformal_factor, free_start
from .injective import injective_map
from .follow import follow_rest
from .localmesh import LocalMesh, _interpolate_rest, _submesh, mesh_flips
from .refine import refine
from .riemann import ROTATIONS, riemann_onto, simply_connected

__all__ = ["domain_map", "annulus_radius", "resolve_domain", "harmonic_onto", "injective_onto",
           "landmarks_onto", "align_onto", "Alignment", "ROTATIONS", "CONFORMAL_FIT",
           "MAX_PAIRINGS", "MIN_HOLE_RATIO"]

MAX_PAIRINGS = 720
"""At most this many pairings of mesh holes with domain holes are tried (6 holes: all); above,
the holes are paired by decreasing area only."""

MIN_HOLE_RATIO = 0.05
"""A domain hole paired with a hole of the mesh of less than this fraction of its area (in the
aligned free map) gets a warning: the map must stretch the surface open around it. Measured:
face_3holes_small_choi onto ``smile`` 1.11, 0.13 and 0.43 (its own eyes and mouth);
peaks_7holes_choi onto ``smile`` 0.015 to 0.018 (small holes blown up to eyes and a mouth)."""

CONFORMAL_FIT = 1e-3
"""Landmarks onto a domain without holes: when the disk automorphism fitted to them
(:mod:`pcgeom.maps.moebius`) brings every landmark set within this fraction of the square root
of the domain's area of its targets (Hausdorff distance), the conformal map is kept as it is
and the barrier map does not run."""

BEND_COST = 1.1
"""The linear bend (:mod:`pcgeom.maps.bend`) of the conformal map is the answer when it turns
over nothing, meets the landmarks and adds at most this factor to the area-weighted
anti-conformal distortion ``|mu|`` of the local mesh's triangles; else the barrier map bends
it. Measured (angle error over the landmark-free map's, flips): face_3holes_small_choi, four
landmarks 0.05 off their conformal image, the linear bend 2.11x in 0.3 s (cost 2.1), the
barrier map 1.25x in 7-9 s; 14k points of the three peaks: the linear bend folds 37
triangles."""

_SHIFTS = 256
"""Circular shifts tried when a loop is laid on its ring."""


def _centroid(P: np.ndarray) -> np.ndarray:
    """Area centroid of the closed polygon ``P`` (k, 2); the vertex mean if it has no area."""
    x, y = P[:, 0], P[:, 1]
    cross = x * np.roll(y, -1) - np.roll(x, -1) * y
    a = cross.sum() / 2
    if abs(a) < 1e-12 * max(float(np.ptp(P, axis=0).max()) ** 2, 1e-300):
        return P.mean(axis=0)
    return np.array([((x + np.roll(x, -1)) * cross).sum(),
                     ((y + np.roll(y, -1)) * cross).sum()]) / (6 * a)


def _rotation(theta: float) -> np.ndarray:
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[c, -s], [s, c]])


@dataclass(frozen=True, eq=False)
class Alignment:
    """The similarity chosen in step 2: ``u -> scale * R @ M @ (u - source) + target``."""

    scale: float
    """Ratio of the domain's area to the free map's, square-rooted."""
    rotation: float
    """Angle of R, radians."""
    mirror: bool
    """M is the reflection v -> -v (else the identity)."""
    source: np.ndarray
    """(2,) area centroid of the free map."""
    target: np.ndarray
    """(2,) area centroid of the domain."""
    pairing: tuple[int, ...]
    """Domain hole of each of the mesh's largest holes, in decreasing area."""
    score: float
    """The criterion of step 2 (smaller is better)."""

    def __call__(self, U: np.ndarray) -> np.ndarray:
        M = np.diag([1.0, -1.0]) if self.mirror else np.eye(2)
        A = self.scale * _rotation(self.rotation) @ M
        return (U - self.source) @ A.T + self.target


def _ring_distance2(lines, P: np.ndarray) -> float:
    """Mean squared distance of the points ``P`` to the shapely line ``lines``."""
    import shapely

    return float(np.mean(shapely.distance(lines, shapely.points(P)) ** 2))


def _chamfer2(A: np.ndarray, B: np.ndarray, tree_B) -> float:
    """Symmetric mean squared nearest-neighbour distance between point sets (``tree_B``: the
    cKDTree of ``B``, built once for every candidate)."""
    from scipy.spatial import cKDTree

    return float(np.mean(tree_B.query(A)[0] ** 2) + np.mean(cKDTree(A).query(B)[0] ** 2))


def _align(P: np.ndarray, region: tuple[float, np.ndarray], loops: tuple[np.ndarray, list],
           rings: list[np.ndarray], domain: Domain,
           landmarks: list[tuple[np.ndarray, np.ndarray]]) -> Alignment:
    """Step 2: the similarity of the free map ``P`` onto the domain (see the module).

    ``region`` is the free map's area and area centroid, ``loops`` its outer loop and its
    holes by decreasing area, ``rings`` the domain's outer ring and holes."""
    region_area, region_centroid = region
    outer, holes = loops
    import shapely

    D_holes = rings[1:]
    h = len(D_holes)
    m = min(h, len(holes))
    used = holes[:m]
    outer_line = shapely.LineString(rings[0])
    hole_lines = [shapely.LineString(r) for r in D_holes]
    for line in [outer_line, *hole_lines]:
        shapely.prepare(line)
    from scipy.spatial import cKDTree

    d_centroids = [_centroid(r[:-1]) for r in D_holes]
    marks = [(index, targets, cKDTree(targets)) for index, targets in landmarks]
    scale = math.sqrt(domain.area / region_area)
    target = np.asarray(domain.centroid, dtype=np.float64)
    if math.perm(h, m) <= MAX_PAIRINGS:
        pairings = list(itertools.permutations(range(h), m))
    else:
        by_area = sorted(range(h), key=lambda j: shoelace(D_holes[j][:-1]))  # CW: negative
        pairings = [tuple(by_area[:m])]
    best = None
    for mirror in (False, True):
        M = np.diag([1.0, -1.0]) if mirror else np.eye(2)
        Q = scale * (P - region_centroid) @ M.T  # (n, 2) centred, scaled, mirrored
        src = np.array([_centroid(Q[loop]) for loop in used]).reshape(-1, 2)
        for pairing in pairings:
            dst = np.array([d_centroids[j] - target for j in pairing]).reshape(-1, 2)
            thetas = list(2 * np.pi * np.arange(ROTATIONS) / ROTATIONS)
            if m >= 2:
                Uh, _, Vt = np.linalg.svd(src.T @ dst)
                R = (Uh @ Vt).T
                if np.linalg.det(R) > 0:
                    thetas.append(math.atan2(R[1, 0], R[0, 0]))
            for theta in thetas:
                R = _rotation(theta)
                Z = Q @ R.T + target
                score = _ring_distance2(outer_line, Z[outer])
                for k, j in enumerate(pairing):
                    score += _ring_distance2(hole_lines[j], Z[used[k]])
                    score += float(((src[k] @ R.T - dst[k]) ** 2).sum())
                for index, targets, tree in marks:
                    score += _chamfer2(Z[index], targets, tree)
                if best is None or score < best.score:
                    best = Alignment(scale, float(theta), mirror, region_centroid, target,
                                     tuple(pairing), score)
    return best


def _lay_on_ring(P: np.ndarray, ring: np.ndarray) -> np.ndarray:
    """Points on the closed ``ring`` for the loop ``P`` (k, 2), in the same order and
    orientation: spaced as ``P`` is along its own length, from the best circular shift."""
    import shapely

    line = shapely.LineString(ring)
    seg = np.linalg.norm(np.roll(P, -1, axis=0) - P, axis=1)
    t = np.concatenate([[0.0], np.cumsum(seg)[:-1]]) / max(seg.sum(), 1e-300)  # (k,)
    shifts = np.arange(_SHIFTS) / _SHIFTS
    where = ((t[None, :] + shifts[:, None]) % 1.0) * line.length  # (S, k)
    Q = shapely.get_coordinates(shapely.line_interpolate_point(line, where.ravel()))
    Q = Q.reshape(_SHIFTS, len(P), 2)
    best = int(np.argmin(((Q - P[None]) ** 2).sum(axis=(1, 2))))
    return Q[best]


def _main_loops(X: np.ndarray, mesh: LocalMesh, uv: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[np.ndarray]]:
    """The local mesh made vertex-manifold, its main part (``main``: its rows of ``X``, its
    vertices and faces) and that part's boundary loops, by decreasing area in the map
    ``uv`` (N, 2): the outer loop first, then the holes."""
    faces = one_fan(mesh.faces, 5, bowties_only=True)[0]
    main, V, F = _submesh(X, faces, main_part(faces, len(X)))
    P = uv[main]
    loops = sorted((np.asarray(loop, dtype=np.int64) for loop in boundary_loops(F)),
                   key=lambda loop: -abs(shoelace(P[loop])))
    return main, V, F, loops


def _laid_out(X: np.ndarray, mesh: LocalMesh, uv: np.ndarray, domain: Domain, landmarks):
    """Steps 1-2: the cleaned mesh, its loops in ``uv`` and the alignment onto ``domain``.

    Returns ``main`` (rows of the cleaned mesh's main part), its vertices and faces, its map
    ``P = uv[main]``, the outer loop and the holes (indices into ``main``, by decreasing
    area), the domain's rings and the :class:`Alignment`."""
    if not domain.bounded:
        raise ValueError("the free boundary has no region to map onto")
    geometry = getattr(domain, "geometry", None)
    if geometry is not None and geometry.geom_type == "MultiPolygon":
        raise InputError(f"domain {domain.label!r} has {len(geometry.geoms)} separate parts; "
                         "the local-mesh map needs one connected region (use --preset networks)")
    main, V, F, loops = _main_loops(X, mesh, uv)
    P = uv[main]
    if not loops:
        raise InputError("the local mesh has no boundary loop; a map onto a domain needs one")
    outer, holes = loops[0], loops[1:]
    rings = [np.asarray(r, dtype=np.float64) for r in domain.boundary_loops()]
    tri = P[F]  # (M, 3, 2)
    tri_area = np.abs(signed_areas(P, F))
    region_area = float(tri_area.sum())
    region_centroid = (tri_area[:, None] * tri.mean(axis=1)).sum(axis=0) / region_area
    marks = _on_main(landmarks, main, len(X))
    align = _align(P, (region_area, region_centroid), (outer, holes), rings, domain, marks)
    return main, V, F, P, outer, holes, rings, align


def _on_main(landmarks, main: np.ndarray, n_all: int) -> list:
    """The landmark sets with their rows of the cloud renumbered as rows of ``main`` (rows
    outside it left out; a set with none left is dropped)."""
    remap = np.full(n_all, -1, dtype=np.int64)
    remap[main] = np.arange(len(main))
    marks = []
    for index, targets in landmarks:
        index = remap[np.asarray(index, dtype=np.int64)]
        if (index >= 0).any():
            marks.append((index[index >= 0], np.asarray(targets, dtype=np.float64)))
    return marks


def _warn_unmatched_holes(Z: np.ndarray, holes, rings, align: Alignment,
                          domain: Domain) -> list[float]:
    """Warn when a domain hole has no hole of the mesh, or one much smaller than itself
    (:data:`MIN_HOLE_RATIO`); returns each paired hole's area over its domain hole's. ``Z``
    is the aligned free map."""
    import warnings

    ratios = [abs(shoelace(Z[holes[k]])) / abs(shoelace(rings[1 + j][:-1]))
              for k, j in enumerate(align.pairing)]
    missing = len(rings) - 1 - len(align.pairing)
    small = [r for r in ratios if r < MIN_HOLE_RATIO]
    if missing:
        warnings.warn(f"the domain {domain.label} has {len(rings) - 1} hole(s) and the cloud "
                      f"{len(holes) or 'none'}: {missing} domain hole(s) get no hole of the "
                      "cloud, and the map tears the surface open there; use a domain with "
                      "the cloud's holes", stacklevel=3)
    elif small:
        warnings.warn(f"{len(small)} of the {len(ratios)} holes of the domain {domain.label} "
                      f"get a hole of the cloud of only {100 * min(small):.1f}% to "
                      f"{100 * max(small):.1f}% of their area: the map stretches the surface "
                      "open around them (high distortion there); use a domain whose holes "
                      "match the cloud's", stacklevel=3)
    return ratios


def _info(holes, rings, align: Alignment) -> dict:
    return {"mesh_holes": len(holes), "domain_holes": len(rings) - 1,
            "paired": len(align.pairing), "mirror": align.mirror,
            "rotation_deg": round(math.degrees(align.rotation), 3)}


def align_onto(X: np.ndarray, mesh: LocalMesh, uv: np.ndarray, domain: Domain, *,
               landmarks=()) -> tuple[np.ndarray, dict]:
    """Step 2 alone: the map ``uv`` moved onto the domain by the chosen similarity.

    For a map already shaped like the domain, as the conformal disk map of
    :func:`pcgeom.maps.disk.conformal_disk` is the disk: the landmarks choose its turn and
    mirror. Parameters and returns as :func:`harmonic_onto`.
    """
    *_, holes, rings, align = _laid_out(X, mesh, uv, domain, landmarks)
    return align(uv), _info(holes, rings, align)


def _harmonic_layout(X: np.ndarray, mesh: LocalMesh, free_uv: np.ndarray, domain: Domain,
                     landmarks) -> tuple[np.ndarray, tuple, np.ndarray, list, dict]:
    """Steps 1-4 on the cleaned mesh's main part: ``main`` (its rows of ``X``), ``(V, F)``,
    the harmonic map ``D`` of its vertices, the paired ``(loop, ring)`` (each loop in its
    ring's direction; the outer one first) and the record of :func:`harmonic_onto`."""
    import igl

    main, V, F, P, outer, holes, rings, align = _laid_out(X, mesh, free_uv, domain, landmarks)
    Z = align(P)
    ratios = _warn_unmatched_holes(Z, holes, rings, align, domain)
    pairs = []
    for loop, ring in [(outer, rings[0])] + [(holes[k], rings[1 + j])
                                             for k, j in enumerate(align.pairing)]:
        # Rings: outer counter-clockwise, holes clockwise; the loop must run the same way.
        if (shoelace(Z[loop]) > 0) != (shoelace(ring[:-1]) > 0):
            loop = loop[::-1]
        pairs.append((loop, ring))
    fixed_idx = np.concatenate([loop for loop, _ in pairs])
    fixed_uv = np.vstack([_lay_on_ring(Z[loop], ring) for loop, ring in pairs])
    n = len(V)
    L = (-igl.cotmatrix(V, F)).tocsr()  # positive semi-definite
    free = np.setdiff1d(np.arange(n), fixed_idx)
    D = np.zeros((n, 2))
    D[fixed_idx] = fixed_uv
    if len(free):
        D[free] = spd_factor(L[free][:, free])(np.asarray(-(L[free][:, fixed_idx] @ fixed_uv)))
    if not np.isfinite(D).all():
        raise InputError("the local mesh of the cloud is degenerate (no harmonic map onto the "
                         "domain); try the 'networks' preset")
    info = _info(holes, rings, align)
    info["hole_area_ratios"] = [round(r, 4) for r in ratios]
    # Which hole went where: the mesh's holes by decreasing area (their size in points).
    info["holes_onto"] = [{"hole": k, "points": len(holes[k]), "domain_hole": j}
                          for k, j in enumerate(align.pairing)]
    return main, (V, F), D, pairs, info


def _on_all_rows(X: np.ndarray, main: np.ndarray, D: np.ndarray,
                 follow: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """The map ``D`` of the rows ``main``, the other rows of ``X`` interpolated; with
    ``follow = (start, faces)`` (the map of every row that ``D`` moved, and ``D``'s
    triangles, rows of ``main``) the rows on none of those triangles move with the map from
    the start (:func:`pcgeom.maps.follow.follow_rest`)."""
    U = np.full((len(X), 2), np.nan)
    U[main] = D
    known = np.zeros(len(X), dtype=bool)
    if follow is None:
        known[main] = True
        return _interpolate_rest(X, U, known)
    start, faces = follow
    known[main[faces].ravel()] = True
    U[~known] = np.nan
    return follow_rest(X, U, known, start, main[faces])


def harmonic_onto(X: np.ndarray, mesh: LocalMesh, free_uv: np.ndarray, domain: Domain, *,
                  landmarks=()) -> tuple[np.ndarray, dict]:
    """Map the local mesh onto a bounded domain (steps 1-4 of the module).

    Parameters
    ----------
    X : (N, 3) float64
        The normalized points.
    mesh : LocalMesh
        Their local mesh.
    free_uv : (N, 2) float64
        Its free LSCM map (:func:`pcgeom.maps.free.lscm_free`).
    domain : Domain
        A bounded domain of one connected region.
    landmarks : sequence of ((n_k,) int, (m_k, 2) float64)
        Rows of ``X`` standing for each landmark set, and its targets: they help choose the
        alignment.

    Returns
    -------
    U : (N, 2) float64
        The map; rows outside the cleaned mesh's main part are interpolated.
    info : dict
        ``mesh_holes`` (holes of the mesh), ``domain_holes``, ``paired`` (holes laid on a
        domain hole), ``mirror``, ``rotation_deg`` of the alignment, ``hole_area_ratios``
        (each paired hole's area in the aligned free map over its domain hole's),
        ``holes_onto`` (for each paired hole of the mesh, by decreasing area: its rank
        ``hole``, its loop's ``points``, the ``domain_hole`` it lies on).

    Warns
    -----
    UserWarning
        A domain hole gets no hole of the mesh, or one of less than :data:`MIN_HOLE_RATIO`
        of its area: the map tears or stretches the surface open there.

    Raises
    ------
    InputError
        The domain has more than one region, or the mesh has no boundary loop.
    """
    main, _, D, _, info = _harmonic_layout(X, mesh, free_uv, domain, landmarks)
    return _on_all_rows(X, main, D), info


def injective_onto(X: np.ndarray, mesh: LocalMesh, free_uv: np.ndarray, domain: Domain, *,
                   landmarks=(), config: InjectiveConfig = InjectiveConfig()
                   ) -> tuple[np.ndarray, dict]:
    """Map the local mesh onto a bounded domain with no triangle turned over: the harmonic
    map of :func:`harmonic_onto` (which may fold where the domain is not convex), made a
    bijection of low angle distortion by :func:`pcgeom.maps.injective.injective_map` (its
    paired loops sliding on their rings, under a barrier on the triangles' areas).

    When a hole of the domain gets no hole of the cloud, no injective map leaves it empty:
    the harmonic map is returned as it is (``info`` without ``injective``), for a refinement
    that tears the surface open there.

    Parameters and returns as :func:`harmonic_onto`; ``info`` has besides ``injective``: what
    the cleaning dropped (``pinched``, ``peeled``, ``handles`` triangles), the start's
    ``start`` method and ``flipped_start`` (folds of the harmonic map), ``released`` (loop
    vertices left off their ring), ``iterations``, ``flipped`` (of the cleaned mesh: 0),
    ``seconds``.

    Raises
    ------
    InputError
        As :func:`harmonic_onto`, or no flip-free map was found (the cleaned local mesh is
        not a disk with holes).
    """
    main, (V, F), D, pairs, info = _harmonic_layout(X, mesh, free_uv, domain, landmarks)
    if info["paired"] < info["domain_holes"]:
        # A domain hole with no hole of the cloud: an injective map would cover it; only
        # tearing the surface open (the refinement's HAND) leaves it empty.
        return _on_all_rows(X, main, D), info
    U, more = _injective(X, mesh, (main, V, F, D), pairs, domain=domain, landmarks=landmarks,
                         config=config)
    return U, {**info, **more}


def _injective(X: np.ndarray, mesh: LocalMesh, start: tuple, pairs: list, *, domain: Domain,
               landmarks, config: InjectiveConfig, start_all: np.ndarray | None = None
               ) -> tuple[np.ndarray, dict]:
    """:func:`pcgeom.maps.injective.injective_map` from ``start = (main, V, F, D)`` (the
    cleaned main part and its first map) with the paired ``(loop, ring)``: the map of every
    row of ``X``, and its record (``injective``, ``dropped_faces``). With
    :attr:`InjectiveConfig.follow_bend` and ``start_all`` (the start of every row), the rows
    on none of the cleaned mesh's triangles (off the main part, or tips of dropped triangles)
    move with the map from it (:func:`pcgeom.maps.follow.follow_rest`)."""
    main, V, F, D = start
    try:
        U, inj = injective_map(V, F, D, [loop for loop, _ in pairs],
                               [ring for _, ring in pairs],
                               landmarks=_on_main(landmarks, main, len(X)), config=config)
    except ValueError as err:
        raise InputError(f"no map onto {domain.label} without folds ({err}); try "
                         "--preset networks") from err
    info = {key: inj[key] for key in ("pinched", "peeled", "handles", "flipped_start",
                                      "released", "iterations", "flipped", "seconds")}
    info["start"] = inj["start"]["method"]
    follow = None
    if config.follow_bend and start_all is not None:
        follow = (start_all, inj["faces"])
    # The local mesh's triangles the cleaning set aside (rows of X), for mesh_flips.
    return _on_all_rows(X, main, U, follow), {"injective": info,
                                              "dropped_faces": _dropped(
                                                  mesh.faces, main[inj["faces"]], len(X))}


def landmarks_onto(X: np.ndarray, mesh: LocalMesh, disk_uv: np.ndarray, domain: Domain,
                   landmarks, *, config: InjectiveConfig = LANDMARKS_INJECTIVE,
                   linear: bool = True) -> tuple[np.ndarray, dict]:
    """Map the local mesh onto a simply connected domain with landmarks, folding nothing,
    with the least bend the landmarks ask for:

    1. the conformal map of :func:`pcgeom.maps.riemann.riemann_onto`, its disk automorphism
       fitted to the landmarks by least squares (:mod:`pcgeom.maps.moebius`); when every
       landmark set is within :data:`CONFORMAL_FIT` of its targets, that is the map (with
       the disk map's own folds, if any);
    2. else its linear bend (:mod:`pcgeom.maps.bend`: least conformal energy, one solve), when
       it turns over nothing, meets the landmarks and costs at most :data:`BEND_COST`;
    3. else :func:`pcgeom.maps.injective.injective_map` from step 1's map, with the landmark
       term (:attr:`pcgeom.config.BarrierConfig.landmarks`), the rim sliding on the domain's
       ring, under the barrier that keeps every triangle positive.

    ``disk_uv`` is the conformal disk map (:func:`pcgeom.maps.disk.conformal_disk`);
    ``landmarks`` as :func:`harmonic_onto`'s; ``linear``: try step 2. Returns the map of every
    row of ``X`` and :func:`riemann_onto`'s record with ``moebius`` (the fit), ``bend``
    (``"none"``, ``"linear"`` or ``"barrier"``), ``linear_bend`` (step 2: ``used``, ``folds``,
    ``fit``, ``cost``, ``seconds``) and, after step 3, ``injective`` (as
    :func:`injective_onto`'s).
    """
    tolerance = CONFORMAL_FIT * math.sqrt(domain.area)

    def bend(Z: np.ndarray, to_disk) -> tuple[np.ndarray, dict]:
        return _linear_bend(X, mesh, Z, [(i, to_disk(q)) for i, q in landmarks],
                            tolerance / math.sqrt(domain.area / math.pi))

    U0, info = riemann_onto(X, mesh.faces, disk_uv, domain, landmarks=landmarks,
                            bend=bend if linear else None)
    fit = max(hausdorff(U0[i], q) for i, q in landmarks)
    if fit <= tolerance:
        # The targets are where a conformal map (or a bend that folds nothing new) puts the
        # landmarks: that map is the answer, with the disk map's own folds if it has any (the
        # barrier map would mend them at a cost in angles everywhere: face_3holes_small_choi
        # 1.10x -> 1.15x the landmark-free angle error, its one flipped true triangle kept;
        # untangling alone, 2.2x).
        info["bend"] = "linear" if info.get("linear_bend", {}).get("used") else "none"
        return _polished(X, mesh, U0, domain, landmarks, info)
    info["bend"] = "barrier"
    main, V, F, loops = _main_loops(X, mesh, U0)
    D = U0[main]
    if not loops:
        raise InputError("the local mesh has no boundary loop; a map onto a domain needs one")
    outer = loops[0] if shoelace(D[loops[0]]) > 0 else loops[0][::-1]
    ring = np.asarray(domain.boundary_loops()[0], dtype=np.float64)
    U, more = _injective(X, mesh, (main, V, F, D), [(outer, ring)], domain=domain,
                         landmarks=landmarks, config=config, start_all=U0)
    return _polished(X, mesh, U, domain, landmarks, {**info, **more})


def _polished(X: np.ndarray, mesh: LocalMesh, U: np.ndarray, domain: Domain, landmarks,
              info: dict) -> tuple[np.ndarray, dict]:
    """Onto a disk, ``U`` polished (:func:`pcgeom.maps.polish.polish_onto`), the record in
    ``info["polish"]``; onto other domains ``U`` as it is."""
    if not isinstance(domain, Disk):
        return U, info
    from .polish import AROUND, polish_onto

    U, info["polish"] = polish_onto(X, mesh, U, domain, landmarks)
    if info.get("bend", "none") != "none":
        # Then with the bend's neighbourhoods of the landmarks held (polish.AROUND).
        U, info["polish_around"] = polish_onto(X, mesh, U, domain, landmarks, around=AROUND)
    return U, info


def _linear_bend(X: np.ndarray, mesh: LocalMesh, Z: np.ndarray, marks: list,
                 tolerance: float) -> tuple[np.ndarray, dict]:
    """:func:`pcgeom.maps.bend.conformal_bend` of the disk map ``Z`` (N, 2) of every row of
    ``X`` onto the landmark targets ``marks`` (given in the disk), on the local mesh's main
    part; kept (``used``) when it turns over no triangle the map ``Z`` had positive and
    brings the landmarks within ``tolerance`` (in the disk) of their targets, else ``Z``."""
    from .bend import conformal_bend, spread_pairs
    from .free import _anticonformal
    from .injective.landmarks import _landmark_pairs

    t0 = time.perf_counter()
    if max(hausdorff(Z[i], t) for i, t in marks) <= tolerance:
        return Z, {"used": False}  # the automorphism meets them: nothing to bend
    main, V, F, loops = _main_loops(X, mesh, Z)
    D = Z[main]
    if not loops:
        return Z, {"used": False}
    rim = loops[0][np.linalg.norm(D[loops[0]], axis=1) > 1.0 - 1e-6]
    on_main = _on_main(marks, main, len(X))
    index, q, _ = _landmark_pairs(V, D, on_main, 1.0)
    index, q, weights = spread_pairs(D, index, q)
    B = conformal_bend(V, F, D, rim, index, q, pair_weights=weights)
    sign = np.sign(signed_areas(D, F).sum())
    before = sign * signed_areas(D, F) > 0
    folds = int((before & (sign * signed_areas(B, F) <= 0)).sum())
    area = np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]), axis=1)
    cost = [float(np.sum(area * np.minimum(_anticonformal(V, F, M[:, 0], M[:, 1]), 1.0)))
            for M in (D, B)]
    out = _on_all_rows(X, main, B, (Z, F))  # the other rows follow the bend
    fit = max(hausdorff(out[i], t) for i, t in marks)
    used = folds == 0 and fit <= tolerance and cost[1] <= BEND_COST * cost[0]
    record = {"used": bool(used), "folds": folds, "fit": round(float(fit), 6),
              "cost": round(cost[1] / max(cost[0], 1e-300), 4),
              "seconds": round(time.perf_counter() - t0, 3)}
    return (out if used else Z), record


def _dropped(faces: np.ndarray, kept: np.ndarray, n: int) -> np.ndarray:
    """The triangles of ``faces`` not in ``kept`` (both rows of a cloud of ``n`` points)."""
    return faces[~np.isin(face_keys(faces, n), face_keys(kept, n))]


def annulus_radius(X: np.ndarray, mesh: LocalMesh, free_uv: np.ndarray) -> float:
    """The inner radius of the annulus (outer radius 1) conformally equivalent to the local
    mesh with its outer loop and its largest hole: ``exp(-2 pi / E)``.

    ``E`` is the Dirichlet energy of the harmonic function ``h``, 0 on the outer loop and 1 on
    the hole (other holes free), with libigl's cotangent matrix ``C``: ``E = -h^T C h``. On the
    annulus ``r < |z| < 1``, ``h = log|z| / log r`` has energy ``2 pi / log(1/r)``, and the
    energy is a conformal invariant.

    Raises
    ------
    InputError
        The mesh has no hole.
    """
    import igl

    main, V, F, loops = _main_loops(X, mesh, free_uv)
    if len(loops) < 2:
        raise InputError("annulus:auto needs a surface with a hole, and the cloud's local mesh "
                         "has none; give the inner radius (annulus:R)")
    outer, hole = loops[0], loops[1]
    C = igl.cotmatrix(V, F).tocsr()
    fixed = np.concatenate([outer, hole])
    values = np.concatenate([np.zeros(len(outer)), np.ones(len(hole))])
    free = np.setdiff1d(np.arange(len(V)), fixed)
    h = np.zeros(len(V))
    h[fixed] = values
    if len(free):
        L = -C
        h[free] = spd_factor(L[free][:, free])(np.asarray(-(L[free][:, fixed] @ values)))
    energy = float(-h @ (C @ h))
    if not np.isfinite(energy) or energy <= 0:
        raise InputError("the local mesh of the cloud is degenerate (no harmonic function "
                         "between its rim and its hole); give the inner radius (annulus:R)")
    return math.exp(-2.0 * math.pi / energy)


def resolve_domain(domain: Domain, X: np.ndarray, start) -> tuple[Domain, dict]:
    """``domain`` with what the cloud decides filled in (``annulus:auto``: the inner radius,
    :func:`annulus_radius`), and what was decided (for the history). ``start`` is
    :func:`pcgeom.maps.free.free_start`'s result."""
    if not getattr(domain, "auto", False):
        return domain, {}
    uv, mesh, _, _ = start
    r = annulus_radius(X, mesh, uv)
    return domain.with_inner(r * domain.outer), {"auto_inner": round(r * domain.outer, 6)}


def domain_map(Xn: np.ndarray, normals: np.ndarray | None, config: ParamConfig,
               domain: Domain, data: TrainData, objective: Objective, *,
               progress: bool, on_stage=None, start=None
               ) -> tuple[torch.Tensor, torch.Tensor, list[dict]]:
    """The local-mesh map onto a bounded domain (the run step of ``domain_map =
    "localmesh"``), by ``config.local_mesh.domain_method``:

    - a disk without landmarks comes here only with ``LocalMeshConfig.disk_refine`` (else
      :func:`pcgeom.maps.disk.disk_map`): the conformal disk map, then refined;
    - ``"injective"`` (the default), a domain without holes and no landmarks:
      :func:`pcgeom.maps.riemann.riemann_onto`, the disk map composed with the domain's
      inverse Riemann map; with landmarks: :func:`landmarks_onto`, that map made to meet the
      landmarks by the barrier map (``config.injective_landmarks``); a domain with holes:
      :func:`injective_onto`, the harmonic layout made a bijection by the barrier map
      (``config.injective``). None of them is refined, which could only fold them; where a
      domain hole gets no hole of the cloud the harmonic layout is refined instead;
    - ``"harmonic"``: onto a disk with landmarks the conformal disk map turned and mirrored by
      :func:`align_onto` as the landmarks fit best, onto other domains :func:`harmonic_onto`;
      then refined.

    The refinement is :func:`pcgeom.maps.refine.refine` with
    ``config.local_mesh.domain_refine``: LEG (local pairs), HAND onto the domain sample
    ``data.W`` and the landmark terms.

    Parameters
    ----------
    Xn, normals, config
        As :func:`pcgeom.maps.free.free_map`.
    domain : Domain
        Bounded, one connected region.
    data : TrainData
        The run's tensors: the cloud, the domain sample, the landmarks.
    objective : Objective
        The run's objective (its weights and landmark targets).
    on_stage : callable, optional
        Called with each history record and the map after it, (N, 2) float64.
    start : tuple, optional
        :func:`pcgeom.maps.free.free_start`'s result when the run has it already.

    Returns
    -------
    U : (N, 2) tensor
    lam_inv : (N,) tensor
    records : list of dict
        The ``"localmesh"`` record (as :func:`pcgeom.maps.free.free_map`'s, plus ``onto``, the
        holes of the mesh and of the domain, how many were paired, the alignment's ``mirror``
        and ``rotation_deg``, and, when there are landmarks, the landmark HAND term
        ``landmarks`` at the refinement's alpha and ``landmark_hausdorff`` of the first map),
        then the refinement's when it has steps; each with ``flips``, the local mesh's
        triangles its map turns over (:func:`pcgeom.maps.localmesh.mesh_flips`).
    """
    from scipy.spatial import cKDTree

    if start is None:
        start = free_start(Xn, normals, config, progress=progress, onto=domain.label)
    t0 = time.perf_counter()
    uv, mesh, normals, record = start
    tree = cKDTree(Xn)
    # Each landmark point acts through its nearest cloud point, as in the refinement.
    marks = [(tree.query(p.cpu().double().numpy())[1], q.cpu().double().numpy())
             for p, q in zip(data.landmark_points, data.landmark_targets)]
    refine_config = config.local_mesh.domain_refine
    method = "harmonic"
    barrier_marks = bool(marks) and config.local_mesh.domain_method == "injective"
    if isinstance(domain, Disk) and not barrier_marks:
        # The conformal disk map is the better start (three peaks, refined: 0.026 rad and no
        # flip from it, 0.045 rad and 261 flips from the harmonic map); the landmarks choose
        # its turn.
        disk = np.asarray(domain.center) + domain.radius * conformal_disk(Xn, mesh, uv)
        U0, info = align_onto(Xn, mesh, disk, domain, landmarks=marks)
        method = "disk"
    elif config.local_mesh.domain_method == "injective" and simply_connected(domain) \
            and not marks:
        # Conformal and injective as it is: a refinement could only fold it.
        U0, info = riemann_onto(Xn, mesh.faces, conformal_disk(Xn, mesh, uv), domain,
                                landmarks=marks)
        method = "riemann"
        refine_config = dataclasses.replace(refine_config, steps=0)
    elif config.local_mesh.domain_method == "injective" and simply_connected(domain):
        # The conformal map, pulled onto the landmarks under a barrier: nothing folds.
        U0, info = landmarks_onto(Xn, mesh, conformal_disk(Xn, mesh, uv), domain, marks,
                                  config=config.injective_landmarks)
        method = "riemann+landmarks"
        refine_config = dataclasses.replace(refine_config, steps=0)
    elif config.local_mesh.domain_method == "injective":
        # The surface's holes slide onto the domain's under a barrier: no triangle turns
        # over, and the refinement, which could fold it, does not run.
        U0, info = injective_onto(Xn, mesh, uv, domain, landmarks=marks,
                                  config=config.injective)
        if "injective" in info:
            method = "injective"
            refine_config = dataclasses.replace(refine_config, steps=0)
    else:
        U0, info = harmonic_onto(Xn, mesh, uv, domain, landmarks=marks)
    dropped = info.pop("dropped_faces", None)
    record.update(onto=domain.spec, method=method, **info)
    record["flips"] = mesh_flips(Xn, mesh, U0, dropped)
    if marks:
        # The landmark term as the refinement will weigh it (its alpha), and the exact fit.
        with torch.no_grad():
            term = landmark_hand([torch.as_tensor(U0[i]) for i, _ in marks],
                                 [torch.as_tensor(q) for _, q in marks], refine_config.alpha)
        record["landmarks"] = float(term)
        record["landmark_hausdorff"] = [hausdorff(U0[i], q) for i, q in marks]
    record["seconds"] += time.perf_counter() - t0  # free_start's and this map's
    records = [record]
    if on_stage is not None:
        on_stage(record, U0)
    U = torch.tensor(U0, device=data.X.device, dtype=data.X.dtype)
    lam_inv = torch.tensor(conformal_factor(Xn, U0), device=data.X.device, dtype=data.X.dtype)
    if refine_config.steps > 0:
        U, lam_inv, refined = refine(data, Xn, (U, lam_inv), objective, refine_config,
                                     normals=normals, progress=progress)
        refined["flips"] = mesh_flips(Xn, mesh, U.detach().cpu().double().numpy())
        records.append(refined)
        if on_stage is not None:
            on_stage(refined, U.cpu().double().numpy())
    return U, lam_inv, records
