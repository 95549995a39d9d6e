"""The mesh's loops on the domain's rings: rebuilt after cleaning, pinned at the rings'
corners, released where no flip-free map can hold them, free loops checked simple."""

from __future__ import annotations

import math

import numpy as np

from ...mesh import boundary_loops, unique_edges
from .jacobians import _not_positive
from .rings import _Rings, _increasing, _region


def _rebuild_loops(V: np.ndarray, F: np.ndarray, slide: _Rings
                   ) -> tuple[list[np.ndarray], list[np.ndarray], list[int]]:
    """The boundary loops of the cleaned faces ``F`` matched to the paired loops of
    ``slide`` (the ones sharing most vertices), each vertex with an arc length on its ring:
    a shared vertex keeps its own, the others are spaced between the shared ones as their
    3D distances along the loop are.

    Returns the matched loops (in the order of ``slide``'s), their arc lengths (unwrapped,
    increasing) and, for each, how many of its vertices are new to it.

    Raises
    ------
    ValueError
        A paired loop has no boundary loop left sharing at least three of its vertices.
    """
    t_of = []
    for k, loop in enumerate(slide.loops):
        t_of.append(dict(zip(loop.tolist(), (slide.t[k] % slide.length[k]).tolist())))
    candidates = [np.asarray(loop, dtype=np.int64) for loop in boundary_loops(F)]
    loops, ts, new = [], [], []
    for k in range(len(slide.loops)):
        shared = [sum(v in t_of[k] for v in c.tolist()) for c in candidates]
        best = int(np.argmax(shared)) if candidates else -1
        if best < 0 or shared[best] < 3:
            raise ValueError(f"loops[{k}]: no boundary loop of the cleaned mesh shares three "
                             "of its vertices")
        loop = candidates[best]
        L = slide.length[k]
        known = np.array([v in t_of[k] for v in loop.tolist()])
        # Anchors: the longest run of shared vertices in order along the ring (a rerouted
        # loop can visit a few of them in another order), tried from a few starts.
        best_anchor = None
        for start in np.flatnonzero(known)[:: max(1, int(known.sum()) // 8)]:
            order = np.roll(np.arange(len(loop)), -int(start))
            idx = order[known[order]]
            u = np.array([(t_of[k][int(loop[i])] - t_of[k][int(loop[start])]) % L
                          for i in idx])
            keep = _increasing(u)
            if best_anchor is None or len(keep) > len(best_anchor[1]):
                best_anchor = (int(start), idx[keep], u[keep])
        start, anchor_idx, anchor_u = best_anchor
        loop = np.roll(loop, -start)
        anchors = (anchor_idx - start) % len(loop)
        t0 = t_of[k][int(loop[0])]
        t = np.full(len(loop), np.nan)
        t[anchors] = t0 + anchor_u
        step = np.linalg.norm(V[np.roll(loop, -1)] - V[loop], axis=1)  # (k,) i -> i + 1
        s = np.concatenate([[0.0], np.cumsum(step)])  # 3D arc length, closing vertex last
        at = np.concatenate([anchors, [len(loop)]])
        tv = np.concatenate([t[anchors], [t0 + L]])
        t = np.interp(s[:len(loop)], s[at], tv)
        loops.append(loop)
        ts.append(t)
        new.append(int((~known).sum()))
    return loops, ts, new


def _pin_corners(slide: _Rings, angle: float) -> np.ndarray:
    """Put a loop vertex on each corner of its ring (a turn sharper than ``angle``): the
    nearer of the two around it, unless it is taken. Updates ``slide.t``; returns the
    vertices pinned.

    A sliding vertex cannot pass a corner: the tangent its step follows ends there. And a
    corner no vertex holds is cut off by a chord."""
    pinned = []
    for k, loop in enumerate(slide.loops):
        ring, cum, L = slide.rings[k], slide.cum[k], slide.length[k]
        e = np.diff(ring, axis=0)  # (r, 2) segments; ring[-1] == ring[0]
        nxt = np.roll(e, -1, axis=0)
        turn = np.arctan2(e[:, 0] * nxt[:, 1] - e[:, 1] * nxt[:, 0], (e * nxt).sum(axis=1))
        corners = cum[1:][np.abs(turn) > angle] % L  # arc length of each sharp vertex
        t = slide.t[k]
        u = (t - t[0]) % L  # increasing from 0
        taken = set()
        for c in corners.tolist():
            cu = (c - t[0]) % L
            i = int(np.searchsorted(u, cu, side="right")) - 1  # u[i] <= cu < u[i + 1]
            j = (i + 1) % len(t)
            nearer = [i, j] if cu - u[i] <= ((u[j] if j else L) - cu) else [j, i]
            for q in nearer:
                if q not in taken:
                    taken.add(q)
                    lo = u[q - 1] if q > 0 else (u[-1] - L)
                    hi = u[q + 1] if q + 1 < len(u) else L
                    if lo < cu < hi:
                        u[q] = cu
                    elif lo < cu - L < hi:
                        u[q] = cu - L
                    else:
                        taken.discard(q)
                        continue
                    break
        slide.t[k] = t[0] + u - (u[0] if 0 in taken else 0.0)
        pinned.extend(loop[sorted(taken)].tolist())
    return np.asarray(pinned, dtype=np.int64)


def _release(U: np.ndarray, F: np.ndarray, loops: list[np.ndarray], rings: list[np.ndarray]
             ) -> np.ndarray:
    """Vertices of the loops that must leave their ring for a flip-free map to exist.

    - **Chords.** An interior edge between two vertices of one loop whose segment leaves the
      domain (a chord of a hole, as every hole's ear has: three consecutive vertices on a
      ring bent away from the triangle) cuts off the loop's arc between them; the part of
      the mesh it bounds cannot fit between the chord and the ring. The vertices strictly
      inside the shorter arc leave the ring (for an ear: its tip).
    - **Triangles.** A triangle whose three corners stay on rings and which is not positive
      there can never turn positive: its corner with the largest angle (the nearest to its
      opposite side) leaves, until none is left.
    """
    import shapely

    n = len(U)
    on = np.zeros(n, dtype=bool)
    loop_of = np.full(n, -1)
    position = np.zeros(n, dtype=np.int64)
    for k, loop in enumerate(loops):
        on[loop] = True
        loop_of[loop] = k
        position[loop] = np.arange(len(loop))
    region = _region(rings)
    shapely.prepare(region)
    edges, counts = unique_edges(F, return_counts=True)
    p, q = edges[counts == 2].T  # interior edges
    same = on[p] & on[q] & (loop_of[p] == loop_of[q])
    p, q = p[same], q[same]
    # Ring vertices are a chord apart along straight segments: far above this tolerance.
    tol = 1e-9 * math.sqrt(abs(region.area))
    out = np.zeros(len(p), dtype=bool)
    for t in (0.25, 0.5, 0.75):
        P = U[p] * (1 - t) + U[q] * t
        pts = shapely.points(P)
        out |= ~shapely.contains_xy(region, P[:, 0], P[:, 1]) & (
            shapely.distance(region, pts) > tol)
    off = np.zeros(n, dtype=bool)
    for a, b in zip(p[out].tolist(), q[out].tolist()):
        loop = loops[loop_of[a]]
        i, j = sorted((position[a], position[b]))
        inner, outer = loop[i + 1:j], np.concatenate([loop[j + 1:], loop[:i]])
        off[inner if len(inner) <= len(outer) else outer] = True
    on &= ~off
    while True:
        bad = np.flatnonzero(on[F].all(axis=1) & _not_positive(U, F))
        if not len(bad):
            break
        T = U[F[bad]]  # (b, 3, 2)
        cosines = []
        for c in range(3):
            e = T[:, (c + 1) % 3] - T[:, c]
            f = T[:, (c + 2) % 3] - T[:, c]
            cosines.append((e * f).sum(axis=1) / np.maximum(
                np.linalg.norm(e, axis=1) * np.linalg.norm(f, axis=1), 1e-300))
        corner = np.argmin(np.stack(cosines, axis=1), axis=1)  # the largest angle
        on[F[bad, corner]] = False
        off[F[bad, corner]] = True
    return np.flatnonzero(off)


def _free_loops_simple(U: np.ndarray, F: np.ndarray, paired: list[np.ndarray]) -> bool:
    """Every boundary loop of ``F`` not in ``paired`` is a simple polygon in ``U``."""
    import shapely

    taken = set(np.concatenate(paired).tolist()) if paired else set()
    for loop in boundary_loops(F):
        if loop[0] in taken:
            continue
        if not shapely.LinearRing(U[loop]).is_simple:
            return False
    return True
