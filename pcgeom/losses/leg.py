"""LEG: Localized Energy for Geometry, dense and over a given list of pairs."""

from __future__ import annotations

import torch

__all__ = ["leg", "leg_pairs"]


def leg(X: torch.Tensor, Y: torch.Tensor, lam_inv: torch.Tensor, sigma: float) -> torch.Tensor:
    r"""Dense LEG over all ordered pairs (paper, eq. LDDE: full).

    .. math::
        D_\sigma(f, \lambda, X) = \frac{1}{N^2} \sum_{i, j}
            \Big(e^{-\|x_i - x_j\|^2/\sigma^2}
                 - e^{-\|f(x_i) - f(x_j)\|^2 / \sigma^2 \lambda_{ij}^2}\Big)^2,
        \qquad \frac{1}{\lambda_{ij}} = l(x_i) + l(x_j).

    The conformal factor is modelled through ``l = lambda_inv`` so that
    ``lambda_ij`` has at most N degrees of freedom (paper, section 5.3): a free
    ``lambda_ij`` would make any map a zero of the energy.

    Parameters
    ----------
    X : (N, 3) tensor
        Points on the surface (normalized frame; sigma is in these units).
    Y : (N, 2) tensor
        Their images ``f(X)``.
    lam_inv : (N,) tensor, > 0
        ``l(x_i)``, the inverse-lambda net's output.
    sigma : float
        Kernel width; pairs farther apart than a few sigma hardly count.

    Returns
    -------
    () tensor

    Notes
    -----
    Memory is O(N^2); for large N use :func:`leg_pairs` on sampled pairs.
    """
    dx2 = (X[:, None, :] - X[None, :, :]).pow(2).sum(-1)  # (N, N)
    dy2 = (Y[:, None, :] - Y[None, :, :]).pow(2).sum(-1)  # (N, N)
    inv_lam = lam_inv[:, None] + lam_inv[None, :]  # (N, N) = 1 / lambda_ij
    s2 = sigma * sigma
    diff = torch.exp(-dx2 / s2) - torch.exp(-dy2 * inv_lam.pow(2) / s2)
    return diff.pow(2).mean()


def leg_pairs(
    X: torch.Tensor,
    Y: torch.Tensor,
    lam_inv: torch.Tensor,
    sigma: float,
    i: torch.Tensor,
    j: torch.Tensor,
    weight: torch.Tensor | None = None,
) -> torch.Tensor:
    r"""LEG restricted to the listed pairs ``(i[p], j[p])``: a weighted mean of ``D_ij``.

    .. math::
        D^{\mathcal{P}}_\sigma = \frac{\sum_{p} w_p D_{i_p j_p}}{\sum_p w_p}, \qquad
        D_{ij} = \Big(e^{-\|x_i - x_j\|^2/\sigma^2}
                 - e^{-\|y_i - y_j\|^2 (l_i + l_j)^2/\sigma^2}\Big)^2

    With all N^2 ordered pairs and unit weights it equals :func:`leg` exactly;
    with pairs sampled at random it is an estimate of it, and with pairs
    sampled near each point (importance weights ``w_p``) an estimate of the
    part of LEG that carries the signal (pairs within a few sigma).

    Parameters
    ----------
    X, Y, lam_inv, sigma
        As in :func:`leg`.
    i, j : (P,) int64 tensors
        Pair indices into the rows of ``X``.
    weight : (P,) tensor, optional
        Non-negative weights; unit weights when omitted.
    """
    dx2 = (X[i] - X[j]).pow(2).sum(-1)  # (P,)
    dy2 = (Y[i] - Y[j]).pow(2).sum(-1)  # (P,)
    inv_lam = lam_inv[i] + lam_inv[j]  # (P,)
    s2 = sigma * sigma
    d = (torch.exp(-dx2 / s2) - torch.exp(-dy2 * inv_lam.pow(2) / s2)).pow(2)
    if weight is None:
        return d.mean()
    return (weight * d).sum() / weight.sum()
