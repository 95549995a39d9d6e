"""The barrier map, :func:`injective_map`: clean, scaffold, untangle, barrier (see
:mod:`pcgeom.maps.injective`)."""

from __future__ import annotations

import dataclasses
import math
import time

import numpy as np

from ...config import InjectiveConfig
from ...mesh import one_fan, peel_rim, shoelace, signed_areas
from .barrier import _descend
from .clean import _cut_handles, _place_dropped, _scaffold
from .jacobians import _as_mesh, _near_folds, _scaled_reference, flipped, reference_triangles
from .landmarks import _landmark_pairs
from .linesearch import _snap
from .loops import _free_loops_simple, _pin_corners, _rebuild_loops, _release
from .rings import _Layout, _Rings, _increasing, _region
from .tutte import _pull_start
from .untangle import _untangle

__all__ = ["injective_map"]


LANDMARKS_MET = 1e-4
"""Point-to-point landmarks are met when every one is within this fraction of the square root
of the map's area of its target: the rounds of the landmark term stop there."""


def _landmarks_met(U: np.ndarray, F: np.ndarray, pull) -> bool:
    index, targets, _ = pull
    scale = math.sqrt(abs(float(signed_areas(U, F).sum())))
    return bool(np.linalg.norm(U[index] - targets, axis=1).max() <= LANDMARKS_MET * scale)


def injective_map(V, F, U0, loops, rings, *, landmarks=(),
                  config: InjectiveConfig = InjectiveConfig()) -> tuple[np.ndarray, dict]:
    """A bijection of the mesh onto the domain bounded by ``rings``, low in angle distortion
    (steps 1-4 of the module).

    Parameters
    ----------
    V : (n, 3) float64
        The mesh's vertices; its 3D triangles are the reference shapes.
    F : (m, 3) int64
        Triangles, consistently oriented, one connected part. When they run clockwise in
        ``U0`` (a mirrored start: the signed areas sum below zero), they are reversed.
    U0 : (n, 2) float64
        The start, each paired loop's vertices on (or near) its ring, in order; may fold.
    loops : sequence of (k_i,) int
        Boundary loops of ``F`` paired with a ring, each in the ring's direction.
    rings : sequence of (r_i, 2) float64
        Closed polylines (the last point may repeat the first), one for each loop: the
        domain's outer ring counter-clockwise, its holes clockwise
        (:meth:`pcgeom.domains.Domain.boundary_loops`).
    landmarks : sequence of ((k_j,) int, (m_j, 2) float64)
        Vertices of each landmark set and the points they should cover: step 4 adds the
        term of :attr:`BarrierConfig.landmarks`, which the barrier keeps from folding
        anything.
    config : InjectiveConfig

    Returns
    -------
    U : (n, 2) float64
        The map. Every triangle of the cleaned mesh is positive; a vertex on none of them
        (the tip of a dropped triangle) sits at the mean of its neighbours.
    info : dict
        What cleaning did: ``reversed``, ``pinched``, ``peeled``, ``handles`` (triangles
        dropped for each reason), ``joined`` (vertices each paired loop gained), ``corners``
        (vertices pinned on ring corners), ``scaffold`` (holes filled); ``start`` (its method
        and that method's info), ``flipped_start`` (folded triangles in ``U0``), ``released``
        (loop vertices off their ring); step 4's ``energy``, ``energy_start``,
        ``energy_end`` (per area), ``iterations``, ``evaluations``, ``steps_cut`` (steps the
        feasible step shortened), ``min_det``, ``min_area``, ``flipped`` (0: the cleaned
        mesh), ``in_order``, ``history`` (energy every 10 steps); ``flipped_all`` (on every
        triangle of ``F``, dropped ones included), ``faces`` (the cleaned mesh's triangles,
        every one positive in ``U``), ``free_loops_simple``, ``seconds``.

    Raises
    ------
    ValueError
        Wrong shapes, not one ring per loop, a loop out of order along its ring, a flat
        reference triangle, or no flip-free start found.
    """
    t0 = time.perf_counter()
    V, F, U0 = _as_mesh(V, F, U0)
    if V.shape[1] == 2:
        V = np.column_stack([V, np.zeros(len(V))])
    n = len(V)
    loops = [np.asarray(loop, dtype=np.int64).ravel() for loop in loops]
    rings = [np.asarray(r, dtype=np.float64) for r in rings]
    if len(loops) != len(rings) or not loops:
        raise ValueError(f"loops, rings: expected one ring per loop, at least one, got "
                         f"{len(loops)} loops and {len(rings)} rings")
    for k, (loop, ring) in enumerate(zip(loops, rings)):
        if len(loop) < 3 or loop.min() < 0 or loop.max() >= n:
            raise ValueError(f"loops[{k}]: expected at least 3 indices in [0, {n}), got "
                             f"{len(loop)} in [{loop.min(initial=0)}, {loop.max(initial=0)}]")
        if ring.ndim != 2 or ring.shape[1] != 2 or len(ring) < 3 or not np.isfinite(ring).all():
            raise ValueError(f"rings[{k}]: expected finite points of shape (r, 2) with r >= 3, "
                             f"got {ring.shape}")
    reference_triangles(V, F)  # raises on a flat reference triangle
    reverse = float(signed_areas(U0, F).sum()) < 0
    F_all = F[:, ::-1].copy() if reverse else F
    corner = math.radians(config.corner_angle)

    # Step 1: clean; the loops follow the cleaned rim, each vertex at an arc length.
    F, pinched = one_fan(F_all)
    F, peeled = peel_rim(V, F, math.radians(config.rim_angle))
    F, handles = _cut_handles(V, F)
    U = U0.copy()
    loops, ts, joined = _rebuild_loops(V, F, _Rings(loops, rings, U))
    slide = _Rings(loops, rings, U, t=ts, corner=corner)
    pinned = _pin_corners(slide, corner)
    for k, loop in enumerate(loops):
        U[loop] = slide.positions(k, slide.t[k])[0]
    index = np.concatenate(loops)

    # Step 2: the holes paired with no ring filled by fans.
    m_mesh = len(F)  # the fans follow the mesh's own triangles
    V, F, U = _scaffold(V, F, U, loops)
    weights = np.ones(len(F))
    weights[m_mesh:] = config.scaffold

    # Step 3: a flip-free start.
    flipped_start = flipped(U, F)
    start: dict = {"method": "given"}
    if flipped_start and config.start in ("auto", "untangle"):
        hold = np.setdiff1d(index, _release(U, F, loops, rings))
        used = np.zeros(len(V), dtype=bool)
        used[F.ravel()] = True
        used[hold] = False
        untangled = {"flipped": 1}
        if config.untangle.local > 0:
            near = _near_folds(U, F, config.untangle.local) & used
            U_try, untangled = _untangle(V, F, _Layout(U, np.flatnonzero(near), None),
                                         config.untangle, weights)
            untangled["local"] = int(near.sum())
        if untangled["flipped"]:
            U_try, untangled = _untangle(V, F, _Layout(U, np.flatnonzero(used), None),
                                         config.untangle, weights)
        start = {"method": "untangle", **untangled}
        if not untangled["flipped"]:
            U = U_try
        elif config.start == "untangle":
            raise ValueError(f"U0: {untangled['flipped']} triangle(s) still folded after "
                             "untangling; try config.start='pull'")
    if flipped(U, F):
        U, pulled = _pull_start(V, F, U, weights, loops=loops, rings=rings, slide=slide,
                                index=index, config=config)
        start = {"method": "pull", "untangle": start if start["method"] != "given" else None,
                 **pulled}

    # Step 4: the loop vertices onto their rings where nothing folds, then the barrier.
    t_all = [slide._project(slide.rings[k], slide.cum[k], U[loop])
             for k, loop in enumerate(loops)]
    moved = _snap(F, U, index, np.vstack([slide.positions(k, t)[0]
                                          for k, t in enumerate(t_all)]))
    released = index[~moved]
    sliding, ts = [], []
    for k, (loop, t) in enumerate(zip(loops, t_all)):
        keep = ~np.isin(loop, released) & ~np.isin(loop, pinned)
        loop, t = loop[keep], t[keep]
        # A start that moved loop vertices (the pull, a released ear) may leave two of them
        # crossed along the ring: the longest run in order slides, the others are released.
        u = (t - t[0]) % slide.length[k] if len(t) else t
        order = _increasing(u) if len(t) else np.zeros(0, dtype=np.int64)
        released = np.concatenate([released, np.delete(loop, order)])
        sliding.append(loop[order])
        ts.append(t[0] + u[order] if len(t) else t)
    slide = _Rings(sliding, rings, U, t=ts, corner=corner)
    used = np.zeros(len(V), dtype=bool)
    used[F.ravel()] = True
    used[np.concatenate(sliding)] = False
    used[pinned] = False
    outside = None
    if len(released):
        # A released vertex pays for leaving the domain: config.barrier.cover times its
        # squared distance to it, per area (a wall in the line search stalls Newton's steps,
        # which keep pointing out).
        outside = (released, _region(rings))

    layout = _Layout(U, np.flatnonzero(used), slide if config.barrier.slide else None)
    cover = None
    if config.barrier.slide and config.barrier.cover > 0:
        # The polygons through the vertices on the rings: a released vertex would only earn
        # area by going deeper into the domain (``outside`` keeps it from leaving it).
        cover = ([loop[~np.isin(loop, released)] for loop in loops],
                 [shoelace(r) for r in rings])
    reference = _scaled_reference(V, F, U, weights)
    marks = [(np.asarray(i, dtype=np.int64).ravel(), np.asarray(q, dtype=np.float64))
             for i, q in landmarks]
    if not marks:
        U, info = _descend(V, F, layout, config.barrier, reference, outside=outside,
                           cover=cover)
    else:
        # Pairs of one point and one target never change: the rounds go on only while the
        # landmarks are not met (14k points of the three peaks, four such landmarks: 188
        # steps in five rounds, 145 s; 35 in one, 17 s, the same angle error to 0.3%).
        single = all(len(i) == 1 and len(q) == 1 for i, q in marks)
        rounds = max(1, config.barrier.landmark_rounds)
        per_round = dataclasses.replace(config.barrier,
                                        iterations=max(1, config.barrier.iterations // rounds))
        iterations = 0
        for _ in range(rounds):
            pull = _landmark_pairs(V, U, marks, config.barrier.landmarks)
            U, info = _descend(V, F, layout, per_round, reference, pull=pull,
                               outside=outside, cover=cover)
            iterations += info["iterations"]
            if config.barrier.slide:
                slide.t = info.pop("t")
            layout = _Layout(U, layout.free, slide if config.barrier.slide else None)
            if single and _landmarks_met(U, F[:m_mesh], pull):
                break
        info["iterations"] = iterations
    info.pop("t", None)
    info["flipped"] = flipped(U, F[:m_mesh])
    U = _place_dropped(U[:n], F[:m_mesh], F_all)
    info.update(reversed=reverse, pinched=pinched, peeled=peeled, handles=handles,
                joined=joined, corners=len(pinned), scaffold=len(V) - n, start=start,
                flipped_start=flipped_start, released=len(released),
                flipped_all=flipped(U, F_all), faces=F[:m_mesh],
                seconds=time.perf_counter() - t0)
    info["free_loops_simple"] = _free_loops_simple(U, F[:m_mesh], loops)
    return U, info
