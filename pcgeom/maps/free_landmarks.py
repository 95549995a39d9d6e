"""Landmarks on the free boundary: LSCM with the landmark points pinned or pulled.

As UV tools pin vertices (libigl's ``lscm(V, F, b, bc)``, Blender's pinned UVs), the free map
of the local mesh (:func:`pcgeom.maps.free.lscm_free`) can be made with landmark points held:

1. **Pairs.** The free map is moved onto the targets by the similarity (turn, scale, shift,
   mirror or not) of least squares over the landmark pairs, paired as the barrier map pairs
   them (:mod:`pcgeom.maps.injective.landmarks`: one point with its target, curves by arc
   length, other sets nearest-first both ways), again from each fit until the pairs settle.
2. **Solve.** LSCM's conformal energy (libigl's form) with each paired landmark vertex pinned
   to its target (a vertex paired twice: the mean of its targets), or, with a weight ``w``,
   pulled: ``E(u) + w k sum_j |u_j - q_j|^2`` (``k`` the mean diagonal entry of the energy's
   matrix, so that ``w`` does not depend on the mesh's size). One sparse solve.
3. **No fold.** Pins placed in another order than the surface's (two of them swapped) turn
   triangles over whatever the solver does. Where the solve turns over a triangle the free
   map had positive, the pins become pulls, the weight divided by 10 until nothing turns
   over (at most :data:`MAX_SOFTENING` times; then the free map moved by step 1's
   similarity), and a warning says so, with how far the landmarks stayed from their targets.
4. **Polish.** Where nothing folds, :func:`pcgeom.maps.polish.polish_disk` (no rim: the
   boundary is free) lowers each triangle's anti-conformal ratio against its 3D triangle by
   reweighted least squares, the landmark vertices held where step 2 put them, no triangle
   turned over. The pinned solve is libigl's ``lscm(V, F, b, bc)`` on the local mesh (the same
   angle error to 0.001x on face_3holes_small_choi, 4 pins, seed 2), so what it lacks against
   the same pins on the true mesh is the local mesh's; polished: 1.241x -> 1.127x of it.
"""

from __future__ import annotations

import math
import time
import warnings

import numpy as np

from ..mesh import signed_areas
from .localmesh import LocalMesh, _interpolate_rest, _submesh

__all__ = ["pinned_free", "fit_similarity", "MAX_SOFTENING", "PULL_START"]

MAX_SOFTENING = 8
"""At most this many divisions by 10 of the landmark weight before the landmarks are given
up (the free map, moved by the similarity)."""

PULL_START = 1e3
"""The weight that pins turn into when they fold, before it is divided."""


def fit_similarity(u: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, bool]:
    """The map ``x -> x A^T + b`` (A a scaled rotation, mirrored or not) of least
    ``sum |u_k A^T + b - q_k|^2``: ``(A, b, mirror)``."""
    best = None
    for mirror in (False, True):
        v = u * [1.0, -1.0] if mirror else u
        zu = v[:, 0] + 1j * v[:, 1]
        zq = q[:, 0] + 1j * q[:, 1]
        mu, mq = zu.mean(), zq.mean()
        du = zu - mu
        den = float(np.vdot(du, du).real)
        a = complex(np.vdot(du, zq - mq) / den) if den > 1e-300 else 1.0
        res = float(np.sum(np.abs(a * du + mq - zq) ** 2))
        if best is None or res < best[0]:
            A = np.array([[a.real, -a.imag], [a.imag, a.real]])
            if mirror:
                A = A @ np.diag([1.0, -1.0])
            b = np.array([(mq - a * mu).real, (mq - a * mu).imag])
            best = (res, A, b, mirror)
    return best[1], best[2], best[3]


def _pairs(V: np.ndarray, U: np.ndarray, marks: list, rounds: int = 10):
    """Step 1: the similarity of ``U`` onto the targets and the pairs it settles on."""
    from .injective.landmarks import _landmark_pairs

    A, b = np.eye(2), np.zeros(2)
    index, q, _ = _landmark_pairs(V, U, marks, 1.0)
    for _ in range(rounds):
        A, b, _ = fit_similarity(U[index], q)
        new_index, new_q, _ = _landmark_pairs(V, U @ A.T + b, marks, 1.0)
        if np.array_equal(new_index, index) and np.allclose(new_q, q):
            break
        index, q = new_index, new_q
    return A, b, index, q


def _lscm_system(V: np.ndarray, F: np.ndarray):
    import igl
    import scipy.sparse as sp

    L = igl.cotmatrix(V, F)
    Q = sp.csr_matrix(-0.5 * sp.block_diag([L, L]) - igl.vector_area_matrix(F))
    return 0.5 * (Q + Q.T)


def _pinned(Q, n: int, index: np.ndarray, q: np.ndarray) -> np.ndarray:
    """LSCM with ``index`` pinned at ``q`` (a vertex listed twice at the mean)."""
    from ._sparse import spd_factor

    pins, inverse = np.unique(index, return_inverse=True)
    value = np.zeros((len(pins), 2))
    np.add.at(value, inverse, q)
    value /= np.bincount(inverse)[:, None]
    fixed = np.concatenate([pins, n + pins])
    values = np.concatenate([value[:, 0], value[:, 1]])
    free = np.setdiff1d(np.arange(2 * n), fixed)
    Q = Q.tocsr()
    rows = Q[free]
    z = np.empty(2 * n)
    z[fixed] = values
    z[free] = spd_factor(rows[:, free].tocsc())(-(rows[:, fixed] @ values))
    return np.column_stack([z[:n], z[n:]])


def _pulled(Q, n: int, index: np.ndarray, q: np.ndarray, weight: float) -> np.ndarray:
    """LSCM plus ``weight k sum |u_j - q_j|^2`` (:data:`k`: the mean diagonal of ``Q``)."""
    import scipy.sparse as sp

    from ._sparse import spd_factor

    w = weight * float(Q.diagonal().mean())
    S = sp.csr_matrix((np.ones(2 * len(index)),
                       (np.arange(2 * len(index)), np.concatenate([index, n + index]))),
                      shape=(2 * len(index), 2 * n))
    t = np.concatenate([q[:, 0], q[:, 1]])
    z = spd_factor((Q + w * (S.T @ S)).tocsc())(w * (S.T @ t))
    return np.column_stack([z[:n], z[n:]])


def _rows(U: np.ndarray, main: np.ndarray, n: int) -> np.ndarray:
    out = np.full((n, 2), np.nan)
    out[main] = U
    return out


def _known(main: np.ndarray, n: int) -> np.ndarray:
    known = np.zeros(n, dtype=bool)
    known[main] = True
    return known


def pinned_free(X: np.ndarray, mesh: LocalMesh, uv: np.ndarray, landmarks, *,
                weight: float = 0.0, robust: tuple = (0, 0.02, 0.1)
                ) -> tuple[np.ndarray, dict]:
    """The free-boundary map with landmarks (steps 1-3 of the module).

    Parameters
    ----------
    X : (N, 3) float64
        The normalized points.
    mesh : LocalMesh
        Their local mesh.
    uv : (N, 2) float64
        Its free map (:func:`pcgeom.maps.free.lscm_free`): orientation and step 3's
        reference.
    landmarks : sequence of ((n_k,) int, (m_k, 2) float64)
        Rows of ``X`` of each landmark set, and its targets.
    weight : float
        0: pinned; above 0: pulled with this weight.
    robust : (rounds, scale, floor)
        Reweighted solves after the first, as the free map's
        (:attr:`pcgeom.config.LocalMeshConfig.robust_rounds`).

    Returns
    -------
    U : (N, 2) float64
        The map, in the targets' frame.
    info : dict
        ``landmarks`` (``"pinned"``, ``"pulled"``, ``"free"`` when even a pull folds, or
        ``"shifted"``: one target, the free map moved onto it), ``weight`` (the one used, after any
        softening), ``softened`` (divisions by 10), ``pins`` (vertices held), ``polished``
        (step 4 kept), ``seconds``.

    Warns
    -----
    UserWarning
        The pins turn triangles over: what was done instead and how far the landmarks are.
    """
    from ..metrics import hausdorff
    from .domain import _on_main

    t0 = time.perf_counter()
    main, V, F = _submesh(X, mesh.faces, mesh.main)
    marks = _on_main(landmarks, main, len(X))
    D = uv[main]
    A, b, index, q = _pairs(V, D, marks)
    moved = D @ A.T + b
    if np.linalg.det(A) < 0:  # the energy wants the triangles as the moved map turns them
        F = F[:, ::-1].copy()
    sign = np.sign(signed_areas(moved, F).sum())
    positive = sign * signed_areas(moved, F) > 0
    Q = _lscm_system(V, F)
    n = len(V)
    pins = np.unique(index)
    if len(np.unique(q, axis=0)) < 2 or len(pins) < 2:
        # One target (or one landmark point) fixes a place, not a turn or a scale: the free
        # map, shifted onto it.
        U = moved + (q - moved[index]).mean(axis=0)
        out = _interpolate_rest(X, _rows(U, main, len(X)), _known(main, len(X)))
        return out, {"landmarks": "shifted", "weight": 0.0, "softened": 0, "pins": len(pins),
                     "seconds": round(time.perf_counter() - t0, 3)}
    hard = weight == 0
    w = weight if weight > 0 else PULL_START
    U = _pinned(Q, n, index, q) if hard else _pulled(Q, n, index, q, w)
    folds = int((positive & (sign * signed_areas(U, F) <= 0)).sum())
    if robust[0] and not folds:
        from .bend import _form_matrix
        from .free import _anticonformal, _weighted_form

        Q_w, U_w = Q, U
        for _ in range(robust[0]):
            # The free map's robust rounds (lscm_free): triangles the local mesh got wrong
            # weigh less, each by how far from conformal the last solve mapped it; kept
            # only when they fold nothing (face_3holes_small_choi, 4 pins: 1.16x libigl's
            # pinned LSCM on the true mesh -> 1.04-1.11x).
            d = _anticonformal(V, F, U_w[:, 0], U_w[:, 1])
            weights = np.where(np.isfinite(d), np.maximum(
                1.0 / (1.0 + (d / robust[1]) ** 2), robust[2]), robust[2])
            Q_w = _form_matrix(_weighted_form(V, F, weights), n)
            U_w = _pinned(Q_w, n, index, q) if hard else _pulled(Q_w, n, index, q, w)
        if not (positive & (sign * signed_areas(U_w, F) <= 0)).any():
            U = U_w
    softened = 0
    first_folds = folds
    while folds and softened < MAX_SOFTENING:
        softened += 1
        w = (w if not hard or softened > 1 else PULL_START) / 10.0
        U = _pulled(Q, n, index, q, w)
        folds = int((positive & (sign * signed_areas(U, F) <= 0)).sum())
    kind = "pinned" if hard else "pulled"
    if folds:
        U, w = moved, 0.0
    polished = {"used": False}
    if not folds:
        # Step 4: the least anti-conformal map near it, the landmark vertices where they are.
        from .polish import polish_disk

        U, polished = polish_disk(V, F, U, np.zeros(0, dtype=np.int64), pins, U[pins])
    out = _interpolate_rest(X, _rows(U, main, len(X)), _known(main, len(X)))
    if softened:
        miss = max(hausdorff(out[main[i]], t) for i, t in marks)
        done = ("left them free (the free map, moved onto them by a similarity)" if folds
                else f"pulled them instead (weight {w:g}) as far as nothing turns over")
        warnings.warn(f"landmarks on the free boundary: {kind} where asked they turn "
                      f"{first_folds} triangle(s) over (two landmarks swapped, or targets in "
                      f"another order than on the surface?); {done}: landmarks up to "
                      f"{miss:.3g} from their targets", stacklevel=3)
        kind = "pulled" if not folds else "free"
    return out, {"landmarks": kind, "weight": w if kind != "pinned" else math.inf,
                 "softened": softened, "pins": len(pins), "polished": polished["used"],
                 "seconds": round(time.perf_counter() - t0, 3)}
