"""HAND: Hausdorff Approximation from Node-wise Distances, and its limit d'_H.

:func:`hand` dispatches through :data:`HAND_BACKENDS` like :func:`pcgeom.losses.leg`; today
there is one backend, ``"dense"`` (the N x M distance matrix), and ``"auto"`` picks it.
The exact Hausdorff distance used to *measure* maps is :func:`pcgeom.metrics.hausdorff`.
"""

from __future__ import annotations

import torch

from .boltzmann import boltzmann

__all__ = ["hand", "hand_dense", "HAND_BACKENDS", "modified_hausdorff", "pairwise_distances"]


def pairwise_distances(Y: torch.Tensor, W: torch.Tensor) -> torch.Tensor:
    """Euclidean distances ``d[i, k] = |Y[i] - W[k]|``, shape (N, M).

    The squared distance is clamped away from zero before the square root so
    that coincident points (``hand(X, X)``) get a zero, not a NaN, gradient.
    """
    d2 = (Y[:, None, :] - W[None, :, :]).pow(2).sum(-1)  # (N, M)
    return d2.clamp_min(1e-30).sqrt()


def hand_dense(Y: torch.Tensor, W: torch.Tensor, alpha: float) -> torch.Tensor:
    r"""HAND, the smooth modified Hausdorff distance (paper, eq. DDHD).

    .. math::
        H_\alpha(Y, W) = B_\alpha\big(\{B_{-\alpha}(\{d^i_k\}_{k=1}^M)\}_{i=1}^N\big)
                       + B_\alpha\big(\{B_{-\alpha}(\{d^i_k\}_{i=1}^N)\}_{k=1}^M\big),
        \qquad d^i_k = \|y_i - w_k\|.

    It tends to :func:`modified_hausdorff` (``d'_H``) as ``alpha`` grows
    (Theorem 1), and bounds the Hausdorff distance of the continuous sets up to
    the sampling densities (Theorem "error bound for approximation").

    Parameters
    ----------
    Y : (N, D) tensor
        Moving points (the mapped cloud, or mapped landmarks).
    W : (M, D) tensor
        Target points (a sample of the domain, or landmark targets); ``M`` may
        differ from ``N``.
    alpha : float, > 0
        Sharpness, in units of 1 / distance (paper: 2 -> 20 -> ... -> 100 for
        domains of diameter about 2).

    Returns
    -------
    () tensor
    """
    d = pairwise_distances(Y, W)  # (N, M)
    y_to_w = boltzmann(boltzmann(d, -alpha, dim=1), alpha, dim=0)  # soft max_i min_k
    w_to_y = boltzmann(boltzmann(d, -alpha, dim=0), alpha, dim=0)  # soft max_k min_i
    return y_to_w + w_to_y


def modified_hausdorff(Y: torch.Tensor, W: torch.Tensor) -> torch.Tensor:
    r"""The paper's modified Hausdorff distance (eq. d'_H): the sum of both directed distances."""
    d = pairwise_distances(Y, W)
    return d.min(dim=1).values.max() + d.min(dim=0).values.max()


HAND_BACKENDS = {"dense": hand_dense}
"""HAND implementations by name; :func:`hand` picks one."""


def hand(Y: torch.Tensor, W: torch.Tensor, alpha: float, *, backend: str = "auto") -> torch.Tensor:
    """HAND (paper, eq. DDHD; see :func:`hand_dense`) through :data:`HAND_BACKENDS`.

    Parameters
    ----------
    Y : (N, D) tensor
    W : (M, D) tensor
    alpha : float, > 0
    backend : {"auto", "dense"}
        ``"auto"`` picks ``"dense"``.

    Raises
    ------
    ValueError
        Unknown backend (the message lists them).
    """
    if backend == "auto":
        backend = "dense"
    if backend not in HAND_BACKENDS:
        raise ValueError(f"hand: unknown backend {backend!r}; choose one of: auto, "
                         f"{', '.join(HAND_BACKENDS)}")
    return HAND_BACKENDS[backend](Y, W, alpha)
