"""LEG: Localized Energy for Geometry, with one entry point over several backends.

:func:`leg` dispatches through :data:`LEG_BACKENDS` (GeomLoss-style):

- ``"dense"`` (:func:`leg_dense`): all N^2 ordered pairs, O(N^2) memory; the paper's energy.
- ``"pairs"`` (:func:`leg_pairs`): the listed pairs only (e.g. each point's k nearest
  neighbours), O(P) memory; with all N^2 pairs it equals the dense energy.
- ``"auto"``: ``"pairs"`` when pairs are given, otherwise ``"dense"``.

Every backend is tested against the dense reference.
"""

from __future__ import annotations

import torch

__all__ = ["leg", "leg_dense", "leg_pairs", "LEG_BACKENDS"]


def leg_dense(X: torch.Tensor, Y: torch.Tensor, lam_inv: torch.Tensor, sigma: float) -> torch.Tensor:
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
    Memory is O(N^2); for large N use the ``"pairs"`` backend on sampled or nearest pairs.
    """
    dx2 = (X[:, None, :] - X[None, :, :]).pow(2).sum(-1)  # (N, N)
    dy2 = (Y[:, None, :] - Y[None, :, :]).pow(2).sum(-1)  # (N, N)
    inv_lambda_ij = lam_inv[:, None] + lam_inv[None, :]  # (N, N)
    s2 = sigma * sigma
    diff = torch.exp(-dx2 / s2) - torch.exp(-dy2 * inv_lambda_ij.pow(2) / s2)
    return diff.pow(2).mean()


def leg_pairs(
    X: torch.Tensor,
    Y: torch.Tensor,
    lam_inv: torch.Tensor,
    sigma: float,
    i: torch.Tensor,
    j: torch.Tensor,
    *,
    weight: torch.Tensor | None = None,
) -> torch.Tensor:
    r"""LEG restricted to the listed pairs ``(i[p], j[p])``: a weighted mean of ``D_ij``.

    .. math::
        D^{\mathcal{P}}_\sigma = \frac{\sum_{p} w_p D_{i_p j_p}}{\sum_p w_p}, \qquad
        D_{ij} = \Big(e^{-\|x_i - x_j\|^2/\sigma^2}
                 - e^{-\|y_i - y_j\|^2 (l_i + l_j)^2/\sigma^2}\Big)^2

    With all N^2 ordered pairs and unit weights it equals :func:`leg_dense` exactly;
    with pairs sampled at random it is an estimate of it, and with pairs
    sampled near each point (importance weights ``w_p``) an estimate of the
    part of LEG that carries the signal (pairs within a few sigma).

    Parameters
    ----------
    X, Y, lam_inv, sigma
        As in :func:`leg_dense`.
    i, j : (P,) int64 tensors
        Pair indices into the rows of ``X``.
    weight : (P,) tensor, optional
        Non-negative weights; unit weights when omitted.
    """
    dx2 = (X[i] - X[j]).pow(2).sum(-1)  # (P,)
    dy2 = (Y[i] - Y[j]).pow(2).sum(-1)  # (P,)
    inv_lambda_ij = lam_inv[i] + lam_inv[j]  # (P,)
    s2 = sigma * sigma
    d = (torch.exp(-dx2 / s2) - torch.exp(-dy2 * inv_lambda_ij.pow(2) / s2)).pow(2)
    if weight is None:
        return d.mean()
    return (weight * d).sum() / weight.sum()


LEG_BACKENDS = {"dense": leg_dense, "pairs": leg_pairs}
"""LEG implementations by name; :func:`leg` picks one (``"auto"``: see the module doc)."""


def leg(
    X: torch.Tensor,
    Y: torch.Tensor,
    lam_inv: torch.Tensor,
    sigma: float,
    *,
    pairs: tuple[torch.Tensor, torch.Tensor] | None = None,
    weight: torch.Tensor | None = None,
    backend: str = "auto",
) -> torch.Tensor:
    r"""LEG (paper, eq. LDDE) through the backend table :data:`LEG_BACKENDS`.

    .. math::
        D_\sigma(f, \lambda, X) = \operatorname{mean}_{(i, j)}
            \Big(e^{-\|x_i - x_j\|^2/\sigma^2}
                 - e^{-\|f(x_i) - f(x_j)\|^2 (l_i + l_j)^2 / \sigma^2}\Big)^2

    over all ordered pairs (``"dense"``) or over ``pairs`` (``"pairs"``, weighted by
    ``weight``).

    Parameters
    ----------
    X : (N, 3) tensor
        Points on the surface (normalized frame; sigma is in these units).
    Y : (N, 2) tensor
        Their images.
    lam_inv : (N,) tensor, > 0
        ``l(x_i)``.
    sigma : float
        Kernel width.
    pairs : ((P,), (P,)) int64 tensors, optional
        Pair indices ``(i, j)``; required by ``"pairs"``.
    weight : (P,) tensor, optional
        Non-negative pair weights (``"pairs"`` only).
    backend : {"auto", "dense", "pairs"}
        ``"auto"``: ``"pairs"`` when ``pairs`` is given, else ``"dense"``.

    Raises
    ------
    ValueError
        Unknown backend (the message lists them), ``"pairs"`` without pairs, or pairs or
        weights given to ``"dense"``.
    """
    if backend == "auto":
        backend = "dense" if pairs is None else "pairs"
    if backend not in LEG_BACKENDS:
        raise ValueError(f"leg: unknown backend {backend!r}; choose one of: auto, "
                         f"{', '.join(LEG_BACKENDS)}")
    if backend == "dense":
        if pairs is not None or weight is not None:
            raise ValueError("leg: the 'dense' backend uses all pairs; do not pass pairs or weight")
        return leg_dense(X, Y, lam_inv, sigma)
    if pairs is None:
        raise ValueError("leg: the 'pairs' backend needs pairs=(i, j)")
    i, j = pairs
    return leg_pairs(X, Y, lam_inv, sigma, i, j, weight=weight)
