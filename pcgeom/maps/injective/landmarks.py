"""The landmark term's pairs: along target curves by arc length, other targets nearest-first
both ways."""

from __future__ import annotations

import numpy as np

from .rings import _Rings


def _landmark_pairs(V: np.ndarray, U: np.ndarray, marks: list, weight: float):
    """The landmark term's pairs for :func:`_descend`'s ``pull``.

    Where a set's targets are curves sampled evenly (:func:`_target_curves`, as a landmark
    file's ``polylines`` are), its points are paired along them by arc length
    (:func:`_curve_pairs`): each curve's points, ordered by where they project on it, are
    spread over its whole length in proportion to their 3D spacing, so the ends reach the
    curve's ends and no stretch of it is left uncovered. Other targets pair each landmark
    point with its nearest target and each target with its nearest landmark point (the two
    halves of a Chamfer distance)."""
    from scipy.spatial import cKDTree

    index, targets = [], []
    for i, q in marks:
        curves = _target_curves(q)
        if curves:
            # Each piece of the landmark points (near one another on the surface) follows
            # the curve nearest to it on average; the targets of a curve no piece follows
            # pull as a Chamfer distance would.
            pieces = _pieces(V[i])
            trees = [cKDTree(q[a:b]) for a, b in curves]
            owner = np.array([np.argmin([np.mean(tree.query(U[i[p]])[0]) for tree in trees])
                              for p in pieces])
            left = np.ones(len(q), dtype=bool)
            for c, (a, b) in enumerate(curves):
                mine = np.concatenate([pieces[k] for k in np.flatnonzero(owner == c)]
                                      + [np.zeros(0, dtype=np.int64)])
                if len(mine):
                    index.append(i[mine])
                    targets.append(_curve_pairs(V[i[mine]], U[i[mine]], q[a:b]))
                    left[a:b] = False
            if left.any():
                index.append(i[cKDTree(U[i]).query(q[left])[1]])
                targets.append(q[left])
            continue
        index.append(i)
        targets.append(q[cKDTree(q).query(U[i])[1]])
        index.append(i[cKDTree(U[i]).query(q)[1]])
        targets.append(q)
    return np.concatenate(index), np.vstack(targets), weight


def _pieces(P: np.ndarray, reach: float = 2.5) -> list[np.ndarray]:
    """The connected pieces of the points ``P``: two points are joined when closer than
    ``reach`` times the median distance of a point to its nearest other point."""
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    if len(P) < 2:
        return [np.arange(len(P))]
    tree = cKDTree(P)
    spacing = float(np.median(tree.query(P, k=2)[0][:, 1]))
    graph = tree.sparse_distance_matrix(tree, reach * max(spacing, 1e-300),
                                        output_type="coo_matrix")
    count, label = connected_components(graph, directed=False)
    return [np.flatnonzero(label == c) for c in range(count)]


def _target_curves(q: np.ndarray, tolerance: float = 0.05) -> list[tuple[int, int]]:
    """The runs ``q[a:b]`` (at least 4 points) whose consecutive points are evenly spaced:
    no gap wider than ``1 + tolerance`` times the run's median gap, and at most a tenth of
    them narrower than ``1 - tolerance`` times it (the chords across a polyline's corners).
    Scattered targets make no run."""
    if len(q) < 4:
        return []
    gaps = np.linalg.norm(np.diff(q, axis=0), axis=1)
    runs, a = [], 0
    while a < len(gaps):
        h = gaps[a]
        b = a
        # Extend while the gaps stay within the tolerance of the run's first full gap.
        while b < len(gaps) and 0 < gaps[b] <= (1 + tolerance) * h:
            b += 1
        g = gaps[a:b]
        if b - a >= 3 and h > 0 and np.mean(g < (1 - tolerance) * h) <= 0.1:
            runs.append((a, b + 1))
            a = b + 1
        else:
            a += 1
    return runs


def _curve_pairs(P: np.ndarray, u: np.ndarray, curve: np.ndarray) -> np.ndarray:
    """Targets on ``curve`` (an evenly sampled polyline, closed when its ends are within two
    of its gaps) for the points ``P`` (3D) mapped to ``u``: ordered by their projection on
    the curve, then spread along it by their cumulative 3D distance."""
    seg = np.linalg.norm(np.diff(curve, axis=0), axis=1)
    cum = np.concatenate([[0.0], np.cumsum(seg)])
    length = cum[-1]
    closed = len(curve) > 3 and np.linalg.norm(curve[-1] - curve[0]) <= 2 * np.median(seg)
    s = _Rings._project(curve, cum, u)  # arc length of each point's nearest on the curve
    order = np.argsort(s, kind="stable")
    if len(order) == 1:
        spread = s[order]
    else:
        step = np.linalg.norm(np.diff(P[order], axis=0), axis=1)
        if closed:
            step = np.append(step, np.linalg.norm(P[order[0]] - P[order[-1]]))
        share = np.concatenate([[0.0], np.cumsum(step)]) / max(step.sum(), 1e-300)
        if closed:  # turned along the loop to move the points least
            spread = share[:-1] * length
            turn = np.angle(np.mean(np.exp(2j * np.pi * (s[order] - spread) / length)))
            spread = (spread + turn * length / (2 * np.pi)) % length
        else:
            spread = share * length
    out = np.empty((len(P), 2))
    out[order] = np.column_stack([np.interp(spread, cum, curve[:, 0]),
                                  np.interp(spread, cum, curve[:, 1])])
    return out
