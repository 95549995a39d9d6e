"""The triangles' reference shapes, their Jacobians in a map, and the folds: what every
step of the barrier map measures."""

from __future__ import annotations

import math

import numpy as np

from ...mesh import signed_areas

__all__ = ["flipped", "reference_triangles"]


def _as_mesh(V, F, U=None) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Validated ``V (n, 2|3)``, ``F (m, 3)`` and ``U (n, 2)``."""
    V = np.asarray(V, dtype=np.float64)
    if V.ndim != 2 or V.shape[1] not in (2, 3):
        raise ValueError(f"V: expected shape (n, 3) or (n, 2), got {V.shape}")
    F = np.asarray(F)
    if F.ndim != 2 or F.shape[1] != 3 or len(F) == 0:
        raise ValueError(f"F: expected shape (m, 3) with m >= 1, got {F.shape}")
    if not np.issubdtype(F.dtype, np.integer):
        raise TypeError(f"F: expected integer indices, got dtype {F.dtype}")
    F = F.astype(np.int64)
    if F.min() < 0 or F.max() >= len(V):
        raise ValueError(f"F: indices must lie in [0, {len(V)}), got [{F.min()}, {F.max()}]")
    if not np.isfinite(V).all():
        raise ValueError("V: contains NaN or inf")
    if U is not None:
        U = np.asarray(U, dtype=np.float64)
        if U.shape != (len(V), 2):
            raise ValueError(f"U0: expected shape ({len(V)}, 2) (one row per row of V), "
                             f"got {U.shape}")
        if not np.isfinite(U).all():
            raise ValueError("U0: contains NaN or inf")
    return V, F, U


def _not_positive(U: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Mask of the triangles folded or flat in ``U``: signed area at most ``1e-9`` of their
    longest edge squared (collinear corners, up to rounding)."""
    e = np.stack([U[F[:, 1]] - U[F[:, 0]], U[F[:, 2]] - U[F[:, 1]], U[F[:, 0]] - U[F[:, 2]]])
    return signed_areas(U, F) <= 1e-9 * (e ** 2).sum(axis=2).max(axis=0)


def flipped(U, F) -> int:
    """Triangles of ``U[F]`` whose signed area is ``<= 0`` (faces counter-clockwise in a
    correct map).

    Unlike :func:`pcgeom.metrics.angle_distortion`'s count, a mirrored map counts every
    triangle: orientation is part of the claim.

    Parameters
    ----------
    U : (n, 2) array_like
        The map.
    F : (m, 3) array_like of int
        Triangles, indices into ``U``.

    Returns
    -------
    int
    """
    return int((signed_areas(U, F) <= 0).sum())


def reference_triangles(V, F, check: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """Each 3D triangle laid flat by an isometry: its area and barycentric gradients.

    Triangle ``t`` with corners ``v_0, v_1, v_2`` gets the 2D corners ``p_0 = 0``,
    ``p_1 = (|e_1|, 0)``, ``p_2 = (e_2 . a, e_2 . b)`` (``e_k = v_k - v_0``, ``a = e_1 /
    |e_1|``, ``b`` the unit vector of the plane orthogonal to ``a``). The Jacobian of a map
    ``u`` on it is ``J = [u_1 - u_0, u_2 - u_0] G`` with ``G = [p_1, p_2]^-1``.

    Parameters
    ----------
    V : (n, 3) or (n, 2) float64
    F : (m, 3) int64

    Returns
    -------
    area : (m,) float64
        Reference areas.
    G : (m, 2, 2) float64
        ``[p_1, p_2]^-1``.

    Raises
    ------
    ValueError
        A triangle of zero area.
    """
    V = np.asarray(V, dtype=np.float64)
    if V.shape[1] == 2:
        V = np.column_stack([V, np.zeros(len(V))])
    e1 = V[F[:, 1]] - V[F[:, 0]]  # (m, 3)
    e2 = V[F[:, 2]] - V[F[:, 0]]
    l1 = np.linalg.norm(e1, axis=1)
    n = np.cross(e1, e2)
    twice = np.linalg.norm(n, axis=1)
    bad = np.flatnonzero(twice <= 1e-14 * np.maximum(l1, 1e-300) ** 2)
    if not check:
        twice = np.maximum(twice, 1e-300)
        l1 = np.maximum(l1, 1e-300)
    elif len(bad):
        raise ValueError(f"V, F: {len(bad)} triangle(s) of zero area (first: face {bad[0]}); "
                         "the reference shapes need proper triangles")
    x2 = np.einsum("md,md->m", e2, e1) / l1
    y2 = twice / l1
    # [p1 p2] = [[l1, x2], [0, y2]]; its inverse:
    G = np.zeros((len(F), 2, 2))
    G[:, 0, 0] = 1.0 / l1
    G[:, 0, 1] = -x2 / (l1 * y2)
    G[:, 1, 1] = 1.0 / y2
    return 0.5 * twice, G


def _jacobians(U: np.ndarray, F: np.ndarray, G: np.ndarray) -> np.ndarray:
    """``J_t = [u_1 - u_0, u_2 - u_0] G_t``, (m, 2, 2)."""
    D = np.stack([U[F[:, 1]] - U[F[:, 0]], U[F[:, 2]] - U[F[:, 0]]], axis=2)  # (m, 2, 2)
    return D @ G


def _scatter(dJ: np.ndarray, F: np.ndarray, G: np.ndarray, n: int) -> np.ndarray:
    """Gradient on the vertices ``(n, 2)`` of a function of the Jacobians, given its
    gradient ``dJ (m, 2, 2)`` with respect to them (chain rule through :func:`_jacobians`)."""
    dD = dJ @ np.swapaxes(G, 1, 2)  # (m, 2, 2): columns for u_1 and u_2
    g1, g2 = dD[:, :, 0], dD[:, :, 1]
    out = np.zeros((n, 2))
    for c in range(2):
        out[:, c] = (np.bincount(F[:, 1], g1[:, c], n) + np.bincount(F[:, 2], g2[:, c], n)
                     - np.bincount(F[:, 0], g1[:, c] + g2[:, c], n))
    return out


def _det_cof(J: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``det J`` (m,) and its gradient, the cofactor matrix (m, 2, 2)."""
    det = J[:, 0, 0] * J[:, 1, 1] - J[:, 0, 1] * J[:, 1, 0]
    cof = np.empty_like(J)
    cof[:, 0, 0], cof[:, 1, 1] = J[:, 1, 1], J[:, 0, 0]
    cof[:, 0, 1], cof[:, 1, 0] = -J[:, 1, 0], -J[:, 0, 1]
    return det, cof


def _jacobian_matrices(G: np.ndarray) -> np.ndarray:
    """``B_t = d vec J_t / d(u_0x, u_0y, u_1x, u_1y, u_2x, u_2y)``, (m, 4, 6):
    ``dJ_rc / du_kr = w_k[c]`` with ``w_1 = G[0]``, ``w_2 = G[1]``, ``w_0 = -w_1 - w_2``."""
    w = np.stack([-(G[:, 0] + G[:, 1]), G[:, 0], G[:, 1]], axis=1)  # (m, 3, 2)
    B = np.zeros((len(G), 4, 6))
    for r in range(2):
        for c in range(2):
            B[:, 2 * r + c, r::2] = w[:, :, c]
    return B


def _scaled_reference(V: np.ndarray, F: np.ndarray, U: np.ndarray,
                      weights: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Reference areas (times ``weights``) and ``G``, the references scaled so that their
    areas sum to the map's signed area (``det J = 1`` on average)."""
    area, G = reference_triangles(V, F, check=False)
    target = float(signed_areas(U, F).sum())
    if target <= 0:
        raise ValueError("U0: the triangles' signed areas sum to <= 0: the faces run "
                         "clockwise in the map (reverse F) or the fixed loops are misplaced")
    scale = math.sqrt(area.sum() / target)  # reference lengths are divided by it
    area = area / scale ** 2
    return (area if weights is None else area * weights), G * scale


def _near_folds(U: np.ndarray, F: np.ndarray, k: int) -> np.ndarray:
    """Mask of the vertices within ``k`` edges of a folded or flat triangle of ``U``."""
    near = np.zeros(len(U), dtype=bool)
    near[F[_not_positive(U, F)].ravel()] = True
    for _ in range(k):
        near[F[near[F].any(axis=1)].ravel()] = True
    return near
