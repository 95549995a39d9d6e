"""Tutte's embedding (flip-free by Tutte's theorem) and the ``"pull"`` start: the paired
loops pulled onto their rings under the barrier."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ...config import BarrierConfig, InjectiveConfig, PullConfig
from ...mesh import boundary_loops, shoelace, signed_areas
from .barrier import _descend
from .jacobians import _scaled_reference, flipped
from .rings import _Layout, _region

__all__ = ["tutte_fill"]


def tutte_fill(V, F, outer, outer_uv) -> np.ndarray:
    """Tutte's embedding with mean-value weights (Floater 2003), every hole filled.

    Each boundary loop of ``F`` other than ``outer`` gets a virtual vertex at its 3D centroid
    and a fan of triangles to it, so the mesh is a disk; the loop ``outer`` is held at
    ``outer_uv`` and every other vertex is the weighted mean of its neighbours,
    ``sum_j w_ij (u_j - u_i) = 0`` with ``w_ij = (tan(a_ij / 2) + tan(b_ij / 2)) / |x_j -
    x_i|`` (``a_ij, b_ij``: the 3D angles at ``x_i`` beside the edge ``ij``). The weights are
    positive, so when ``outer_uv`` is a convex polygon (in order, counter-clockwise) no
    triangle folds (Tutte 1963, Floater 2003).

    Parameters
    ----------
    V : (n, 3) float64
    F : (m, 3) int64
        Consistently oriented; one connected part.
    outer : (k,) int
        The loop held.
    outer_uv : (k, 2) float64
        Where it is held.

    Returns
    -------
    (n, 2) float64
    """
    import scipy.sparse as sp
    from scipy.sparse.linalg import splu

    V = np.asarray(V, dtype=np.float64)
    if V.shape[1] == 2:
        V = np.column_stack([V, np.zeros(len(V))])
    n = len(V)
    outer = np.asarray(outer, dtype=np.int64)
    taken = set(outer.tolist())
    points, faces = [V], [F]
    for loop in boundary_loops(F):
        if loop[0] in taken:
            continue
        c = n + sum(len(p) for p in points[1:])
        points.append(V[loop].mean(axis=0, keepdims=True))
        loop = np.asarray(loop)
        # The loop runs along F's boundary edges (a -> b); the fan holds b -> a.
        faces.append(np.column_stack([np.roll(loop, -1), loop, np.full(len(loop), c)]))
    X = np.vstack(points)
    T = np.vstack(faces)
    N = len(X)
    rows, cols, vals = [], [], []
    for q in range(3):
        i, j, k = T[:, q], T[:, (q + 1) % 3], T[:, (q + 2) % 3]
        e1, e2 = X[j] - X[i], X[k] - X[i]
        l1, l2 = np.linalg.norm(e1, axis=1), np.linalg.norm(e2, axis=1)
        cos = np.clip((e1 * e2).sum(axis=1) / np.maximum(l1 * l2, 1e-300), -1.0, 1.0)
        half = np.tan(0.5 * np.arccos(cos))  # the angle at i, shared by edges ij and ik
        rows += [i, i]
        cols += [j, k]
        vals += [half / np.maximum(l1, 1e-300), half / np.maximum(l2, 1e-300)]
    Wm = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                       shape=(N, N))
    L = sp.diags(np.asarray(Wm.sum(axis=1)).ravel()) - Wm
    used = np.zeros(N, dtype=bool)
    used[T.ravel()] = True
    used[outer] = False
    free = np.flatnonzero(used)
    U = np.zeros((N, 2))
    U[outer] = outer_uv
    A = L[free][:, free].tocsc()
    U[free] = splu(A).solve(np.asarray(-(L[free][:, outer] @ outer_uv)))
    return U[:n]


def _convex(ring: np.ndarray) -> bool:
    """The closed polyline turns one way only (collinear points allowed)."""
    P = ring[:-1] if np.allclose(ring[0], ring[-1]) else ring
    e = np.roll(P, -1, axis=0) - P
    turn = e[:, 0] * np.roll(e[:, 1], -1) - e[:, 1] * np.roll(e[:, 0], -1)
    scale = np.abs(turn).max()
    return bool((turn >= -1e-12 * scale).all() or (turn <= 1e-12 * scale).all())


def _pull_onto(V: np.ndarray, F: np.ndarray, U: np.ndarray, weights: np.ndarray, *,
               held: np.ndarray, index: np.ndarray, targets: np.ndarray,
               config: PullConfig, barrier: BarrierConfig) -> tuple[np.ndarray, dict]:
    """From the flip-free ``U``, pull the vertices ``index`` towards ``targets`` under the
    barrier, the pull's weight growing, until every one is within ``config.tolerance``
    (relative to the square root of the map's area) or ``config.stages`` weights are spent."""
    used = np.zeros(len(V), dtype=bool)
    used[F.ravel()] = True
    used[held] = False
    free = np.flatnonzero(used)
    area_G = _scaled_reference(V, F, U, weights)
    size = math.sqrt(float(signed_areas(U, F).sum()))
    steps = dataclasses.replace(barrier, iterations=config.iterations, flip_guard=0.0)
    weight = config.weight
    iterations, stages, gap = 0, 0, math.inf
    for stages in range(1, config.stages + 1):
        U, info = _descend(V, F, _Layout(U, free, None), steps, area_G,
                           pull=(index, targets, weight))
        iterations += info["iterations"]
        gap = float(np.linalg.norm(U[index] - targets, axis=1).max()) / size
        if gap < config.tolerance:
            break
        weight *= config.growth
    return U, {"stages": stages, "iterations": iterations, "weight": weight, "gap": gap}


def _pull_start(V, F, U, weights, *, loops, rings, slide, index, config: InjectiveConfig
                ) -> tuple[np.ndarray, dict]:
    """The ``"pull"`` start: Tutte's embedding with the outer loop on its ring (on a circle
    of its area when the ring is not convex), then every paired loop pulled to its place."""
    targets = U[index].copy()
    outer = loops[0]
    convex = _convex(rings[0])
    if convex:
        outer_uv = U[outer]
    else:  # a circle of the ring's area, the loop spread as on the ring
        angle = 2 * np.pi * (slide.t[0] - slide.t[0][0]) / slide.length[0]
        radius = math.sqrt(abs(shoelace(rings[0])) / np.pi)
        centre = np.asarray(_region(rings).centroid.coords[0])
        outer_uv = centre + radius * np.column_stack([np.cos(angle), np.sin(angle)])
    U = tutte_fill(V, F, outer, outer_uv)
    if flipped(U, F):
        raise ValueError(f"Tutte's embedding folds {flipped(U, F)} triangle(s): the cleaned "
                         "mesh is not a disk with holes")
    held = outer if convex else np.zeros(0, dtype=np.int64)
    U, pulled = _pull_onto(V, F, U, weights, held=held, index=index, targets=targets,
                           config=config.pull, barrier=config.barrier)
    return U, {"outer_convex": convex, **pulled}
