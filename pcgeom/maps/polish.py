"""The last step of a disk map with landmarks: the least anti-conformal map of the local mesh
near it, landmarks held, nothing turned over.

A disk automorphism (:mod:`pcgeom.maps.moebius`) keeps a map conformal, but not its piecewise
linear angles: the angle error of a triangle of size ``h`` under a conformal map ``f`` grows
with ``h |f''/f'|``, and an automorphism that squeezes one side of the disk raises it there
(face_3holes_small_choi, ``|c|`` 0.36: 1.10x the landmark-free map's angle error; the discrete
Riemann map centred where the automorphism sends 0, instead of the automorphism, 1.19x: the
loss is the measure's, not the composition's). So the map is moved, not recomputed: with the
landmark points held on their targets and the rim sliding on the circle, each triangle's
anti-conformal ratio ``r_t = |d_zbar u| / |d_z u|`` against its own 3D triangle is lowered by
reweighted least squares (the weights ``A_t / (r_t + floor)`` make the sum of squares about
the sum of ``r_t``, the mean angle error's measure; triangles with ``r_t`` above
:data:`CAP`, the local mesh's folded flaps, are left out of it), plus ``mu`` times the squared
distance to the map it starts from:

    ``E(u) = sum_t w_t A_t |d_zbar u_t / d_z u0_t|^2 + mu k |u - u0|^2 + W k sum_j |u_j - q_j|^2``

one linear solve per round (``d_z u0`` from the current map, ``k`` the mean diagonal of the
first term's matrix). A step that would turn over a triangle of the local mesh the start had
positive, or make a convex quad of two of its triangles concave (the true triangles may be
its other diagonal: :data:`QUAD_QUALITY`), is halved until it does not; a result whose
mean ``r_t`` over the local mesh is not lower than the start's is dropped (``r_t`` capped
at 1).
"""

from __future__ import annotations

import numpy as np

__all__ = ["polish_disk", "polish_onto", "CAP", "FLOOR", "PROXIMITY", "ROUNDS", "QUAD_QUALITY",
           "AROUND", "HOLD"]

CAP = 0.3
"""Triangles whose anti-conformal ratio is above this (flaps of the local mesh folded over or
slivers) are left out of the energy."""

FLOOR = 0.01
"""Added to ``r_t`` in the weights ``1 / (r_t + floor)``."""

PROXIMITY = 1e-4
"""``mu``: the pull towards the start, times ``k``. Measured (one round, no quad kept convex),
face_3holes_small_choi, four landmarks a disk automorphism reaches (|c| 0.31-0.36), seeds 0
and 2: start 1.103x and 1.096x the landmark-free angle error; mu 1e-2: 1.059x, 1.044x; 1e-3:
1.046x, 1.031x; 1e-4: 1.040x, 1.024x (none turned over); the 14k three peaks
1.078/1.028/1.096x at any mu. In the map (three rounds, quads kept, :data:`AROUND`), seed 2
1e-3 -> 1e-4: 1.043 -> 1.037x; 0.05 off, seeds 2 and 0: 1.504, 1.473 -> 1.483, 1.462x."""

ROUNDS = 3
"""Reweighted solves (each from the last one's map and weights). face_3holes_small_choi,
seeds 0 and 2 above (mu 1e-3): one 1.046x, 1.054x (half the second's step: a full one turned
a triangle over); three 1.043x, 1.044x."""

QUAD_QUALITY = 0.5
"""A quad of two triangles is kept convex when both triangles of its other diagonal have at
least this shape quality in 3D (:func:`pcgeom.mesh.shape_quality`): only then can they be
the true surface's. face_3holes_small_choi, free boundary, 4 pins, seed 2: every quad kept
convex, the polish moves nothing (1.241x libigl's pinned LSCM); 0.3: 1.233x; 0.5: 1.127x; none:
1.127x, and 2 true triangles turned over on the 900 points of the three peaks with 6 pins
(none at 0.5)."""

AROUND = 0.05
"""After a bend (linear or barrier), the points within this distance of a landmark point (in
the unit disk) are held as the bend put them: the bend arranged them so that the landmark
moves without a fold, and the polish, free there, would undo that (its steps halved to
nothing). face_3holes_small_choi, four landmarks 0.05 off an automorphism's image, seeds
0-2, barrier map 1.549/1.345/1.558x the landmark-free angle error: held within 0 (the
landmarks alone) 1.549/1.314/1.558x; 0.03: 1.465/1.332/1.504x; 0.05: 1.464/1.222/1.495x;
0.1: 1.487/1.231/1.505x; 0.2: 1.507/1.253/1.530x. On the 14k and 1.9k three peaks every
step folds (nothing changes)."""

HOLD = 1e4
"""``W``: the weight of the landmark pairs, times ``k``."""


def _gradients(V: np.ndarray, F: np.ndarray):
    """Each triangle's gradient operators ``Gx, Gy`` (M, N) in its own plane (the triangle
    counter-clockwise in its frame), and its area."""
    import scipy.sparse as sp

    m, n = len(F), len(V)
    e1, e2 = V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]
    normal = np.cross(e1, e2)
    normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-300)
    x = e1 / np.maximum(np.linalg.norm(e1, axis=1, keepdims=True), 1e-300)
    y = np.cross(normal, x)
    P = np.zeros((m, 3, 2))
    P[:, 1, 0] = np.linalg.norm(e1, axis=1)
    P[:, 2, 0], P[:, 2, 1] = (e2 * x).sum(axis=1), (e2 * y).sum(axis=1)
    twice = np.maximum(P[:, 1, 0] * P[:, 2, 1], 1e-300)
    rows = np.tile(np.arange(m), 3)
    cols = F.T.ravel()
    gx = np.concatenate([(P[:, (i + 1) % 3, 1] - P[:, (i + 2) % 3, 1]) / twice
                         for i in range(3)])
    gy = np.concatenate([(P[:, (i + 2) % 3, 0] - P[:, (i + 1) % 3, 0]) / twice
                         for i in range(3)])
    Gx = sp.csr_matrix((gx, (rows, cols)), shape=(m, n))
    Gy = sp.csr_matrix((gy, (rows, cols)), shape=(m, n))
    return Gx, Gy, twice / 2


def _rim_basis(U: np.ndarray, rim: np.ndarray):
    """The offsets the variables make: two per vertex, one (along the circle) per rim vertex."""
    import scipy.sparse as sp

    n = len(U)
    on_rim = np.zeros(n, dtype=bool)
    on_rim[rim] = True
    inner = np.flatnonzero(~on_rim)
    k = len(inner)
    p = U[rim] / np.linalg.norm(U[rim], axis=1, keepdims=True)
    rows = np.concatenate([inner, n + inner, rim, n + rim])
    cols = np.concatenate([np.arange(k), k + np.arange(k), 2 * k + np.arange(len(rim)),
                           2 * k + np.arange(len(rim))])
    vals = np.concatenate([np.ones(2 * k), -p[:, 1], p[:, 0]])
    return sp.csr_matrix((vals, (rows, cols)), shape=(2 * n, 2 * k + len(rim)))


def _other_diagonals(F: np.ndarray) -> np.ndarray:
    """For each pair of triangles ``(a, b, c)``, ``(b, a, d)`` sharing an edge, the two
    triangles of the quad's other diagonal, ``(c, a, d)`` and ``(c, d, b)``: (2p, 3)."""
    m = len(F)
    a = F.ravel()  # edge i of face f: F[f, i] -> F[f, i + 1], opposite F[f, i + 2]
    b = np.roll(F, -1, axis=1).ravel()
    c = np.roll(F, -2, axis=1).ravel()
    n = int(F.max()) + 1
    key = np.minimum(a, b) * n + np.maximum(a, b)
    order = np.argsort(key, kind="stable")
    same = np.flatnonzero(key[order][1:] == key[order][:-1])
    s, t = order[same], order[same + 1]
    keep = (a[s] == b[t]) & (b[s] == a[t]) & (s // 3 != t // 3) & (m > 0)
    s, t = s[keep], t[keep]
    A, B, C, D = a[s], b[s], c[s], c[t]
    return np.concatenate([np.column_stack([C, A, D]), np.column_stack([C, D, B])])


def _ratios(Gx, Gy, U: np.ndarray):
    """``d_z u`` per triangle (complex, times 2) and ``r_t``."""
    ax, ay, bx, by = Gx @ U[:, 0], Gy @ U[:, 0], Gx @ U[:, 1], Gy @ U[:, 1]
    dz = (ax + by) + 1j * (bx - ay)
    dzbar = (ax - by) + 1j * (bx + ay)
    return dz, np.abs(dzbar) / np.maximum(np.abs(dz), 1e-300)


def polish_disk(V: np.ndarray, F: np.ndarray, Z: np.ndarray, rim: np.ndarray,
                index: np.ndarray, targets: np.ndarray, *, mu: float = PROXIMITY,
                rounds: int = ROUNDS, halvings: int = 6) -> tuple[np.ndarray, dict]:
    """The map ``Z`` (n, 2) of the mesh ``(V, F)`` onto the unit disk, polished as the module
    says.

    Parameters
    ----------
    V : (n, 3) float64
    F : (m, 3) int64
    Z : (n, 2) float64
        The map; its ``rim`` vertices on the unit circle.
    rim : (k,) int
        Vertices that slide on the circle.
    index : (p,) int
        Landmark vertices, held on ``targets`` (p, 2).
    mu : float
        :data:`PROXIMITY`.

    Returns
    -------
    U : (n, 2) float64
        The polished map (``Z`` itself when polishing lowers nothing).
    info : dict
        ``used``, ``step`` (the fraction of the last solve's step taken), ``before`` and
        ``after`` (the mean ``r_t``).
    """
    import scipy.sparse as sp

    from ..mesh import shape_quality, signed_areas
    from ._sparse import spd_factor

    n = len(Z)
    sign = np.sign(signed_areas(Z, F).sum()) or 1.0
    if sign < 0:  # the frames are counter-clockwise: the map must turn as they do
        F = F[:, ::-1]
    F = np.ascontiguousarray(F, dtype=np.int64)
    positive = signed_areas(Z, F) > 0
    # The other diagonal of each quad of two triangles: the true surface's triangles can be
    # those, and turn over when the quad stops being convex (a free map pinned at 4 points on
    # face_3holes_small_choi: 2 true triangles turned over without this check).
    Q = _other_diagonals(F)
    good = shape_quality(V, Q, np.cross(V[Q[:, 1]] - V[Q[:, 0]], V[Q[:, 2]] - V[Q[:, 0]]))
    half = len(Q) // 2
    good = np.tile(np.minimum(good[:half], good[half:]), 2) >= QUAD_QUALITY
    convex = (signed_areas(Z, Q) > 0) & good
    Gx, Gy, area = _gradients(V, F)
    DR, DI = sp.hstack([Gx, -Gy]), sp.hstack([Gy, Gx])  # d_zbar's parts, on [u; v]
    index = np.asarray(index, dtype=np.int64)
    S = sp.csr_matrix((np.ones(2 * len(index)),
                       (np.arange(2 * len(index)), np.concatenate([index, n + index]))),
                      shape=(2 * len(index), 2 * n))
    t = np.concatenate([targets[:, 0], targets[:, 1]])
    z0 = np.concatenate([Z[:, 0], Z[:, 1]])
    before = float(np.mean(np.minimum(_ratios(Gx, Gy, Z)[1], 1.0)))
    U, step = Z, 0.0
    for _ in range(rounds):
        dz, r = _ratios(Gx, Gy, U)
        k = 1.0 / dz  # r_t = |d_zbar u / d_z u|, linear in u with d_z u frozen
        R = sp.vstack([sp.diags(k.real) @ DR - sp.diags(k.imag) @ DI,
                       sp.diags(k.imag) @ DR + sp.diags(k.real) @ DI]).tocsr()
        w = area / area.mean() / (np.minimum(r, CAP) + FLOOR) * (r < CAP)
        H = R.T @ sp.diags(np.tile(w, 2)) @ R
        scale = float(H.diagonal().mean())
        P = _rim_basis(U, rim)
        u0 = np.concatenate([U[:, 0], U[:, 1]])
        A = P.T @ (H + HOLD * scale * (S.T @ S) + mu * scale * sp.identity(2 * n)) @ P
        rhs = P.T @ (-(H @ u0) + HOLD * scale * (S.T @ (t - S @ u0)) - mu * scale * (u0 - z0))
        d = P @ spd_factor(sp.csc_matrix(0.5 * (A + A.T)))(rhs)
        step = 1.0
        for _ in range(halvings + 1):
            u = u0 + step * d
            B = np.column_stack([u[:n], u[n:]])
            B[rim] /= np.linalg.norm(B[rim], axis=1, keepdims=True)
            if not ((positive & (signed_areas(B, F) <= 0)).any()
                    or (convex & (signed_areas(B, Q) <= 0)).any()):
                break
            step /= 2
        else:
            break
        U = B
    after = float(np.mean(np.minimum(_ratios(Gx, Gy, U)[1], 1.0)))
    used = U is not Z and after < before
    return (U if used else Z), {"used": bool(used), "step": step, "before": round(before, 5),
                                "after": round(after, 5)}


def polish_onto(X: np.ndarray, mesh, U: np.ndarray, domain, landmarks, *,
                around: float = 0.0) -> tuple[np.ndarray, dict]:
    """:func:`polish_disk` of the map ``U`` (N, 2) of every row of ``X`` onto the disk
    ``domain``, on the local mesh's main part, its landmark pairs as the barrier map pairs
    them (:mod:`pcgeom.maps.injective.landmarks`); the other rows move with it
    (:func:`pcgeom.maps.follow.follow_rest`). ``around``
    (in the unit disk's units; :data:`AROUND` after a bend): the points that close to a
    landmark point are held where ``U`` has them too."""
    import time

    from .domain import _main_loops, _on_all_rows, _on_main
    from .injective.landmarks import _landmark_pairs

    t0 = time.perf_counter()
    centre, radius = np.asarray(domain.center, dtype=np.float64), float(domain.radius)
    main, V, F, loops = _main_loops(X, mesh, U)
    if not loops or not landmarks:
        return U, {"used": False}
    D = (U[main] - centre) / radius
    rim = loops[0][np.linalg.norm(D[loops[0]], axis=1) > 1.0 - 1e-6]
    marks = _on_main([(i, (np.asarray(q, dtype=np.float64) - centre) / radius)
                      for i, q in landmarks], main, len(X))
    index, q, _ = _landmark_pairs(V, D, marks, 1.0)
    if around > 0:
        from scipy.spatial import cKDTree

        near = cKDTree(D).query_ball_point(D[np.unique(index)], around)
        near = np.setdiff1d(np.concatenate([np.asarray(k, dtype=np.int64) for k in near]),
                            index)
        index, q = np.concatenate([index, near]), np.vstack([q, D[near]])
    B, info = polish_disk(V, F, D, rim, index, q)
    info["seconds"] = round(time.perf_counter() - t0, 3)
    if not info["used"]:
        return U, info
    return _on_all_rows(X, main, centre + radius * B, (U, F)), info
