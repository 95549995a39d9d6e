"""LEG: Localized Energy for Geometry, with one entry point over several backends.

:func:`leg` dispatches through :data:`LEG_BACKENDS` (GeomLoss-style):

- ``"dense"`` (:func:`leg_dense`): all N^2 ordered pairs, O(N^2) memory; the paper's energy.
- ``"chunked"`` (:func:`leg_chunked`): the same energy computed in blocks of rows, each block
  recomputed during backward (a custom autograd Function, a checkpoint segment per block):
  O(block * N) memory forward and backward, at the price of a second forward pass of each
  block.
- ``"pairs"`` (:func:`leg_pairs`): the listed pairs only (e.g. each point's k nearest
  neighbours), O(P) memory; with all N^2 pairs it equals the dense energy.
- ``"auto"``: ``"pairs"`` when pairs are given, otherwise ``"dense"`` up to
  :data:`DENSE_MAX_PAIRS` ordered pairs and ``"chunked"`` above.

``"dense"`` and ``"chunked"`` take an optional (N, N) pair weight (e.g. a mask of the pairs whose
normals agree). Every backend is tested against the dense reference.
"""

from __future__ import annotations

import torch

from ._blocks import recomputed

__all__ = ["leg", "leg_dense", "leg_chunked", "leg_pairs", "LEG_BACKENDS", "DENSE_MAX_PAIRS"]

DENSE_MAX_PAIRS = 1 << 26
"""``"auto"`` computes LEG densely up to this many ordered pairs (N = 8192: about 2 GB of
float32 intermediates), in blocks above. The paper's stages on its surfaces (N <= 5809) stay
dense, so their results are unchanged bit for bit."""

_BLOCK_ELEMENTS = 1 << 22
"""Pairs per block of the ``"chunked"`` backends (4M: 16 MB per float32 intermediate)."""


def _pair_energy(dx2: torch.Tensor, dy2: torch.Tensor, inv_lambda_ij: torch.Tensor,
                 s2: float) -> torch.Tensor:
    """``D_ij = (exp(-|x_i - x_j|^2 / s2) - exp(-|y_i - y_j|^2 (l_i + l_j)^2 / s2))^2``."""
    return (torch.exp(-dx2 / s2) - torch.exp(-dy2 * inv_lambda_ij.pow(2) / s2)).pow(2)


def _check_weight(weight: torch.Tensor | None, n: int, backend: str) -> None:
    if weight is not None and tuple(weight.shape) != (n, n):
        raise ValueError(f"leg: the {backend!r} backend takes a weight of shape (N, N) = "
                         f"({n}, {n}), got {tuple(weight.shape)}")


def leg_dense(X: torch.Tensor, Y: torch.Tensor, lam_inv: torch.Tensor, sigma: float, *,
              weight: torch.Tensor | None = None) -> torch.Tensor:
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
    weight : (N, N) tensor, optional
        Non-negative pair weights ``w_ij``: the energy is then the weighted mean
        ``sum w_ij D_ij / sum w_ij`` (not in the paper; a 0/1 mask drops pairs, e.g. those
        from the other sheet of a surface that doubles back).

    Returns
    -------
    () tensor

    Notes
    -----
    Memory is O(N^2); for large N use ``"chunked"`` (the same energy in bounded memory) or
    ``"pairs"`` on sampled or nearest pairs.
    """
    _check_weight(weight, len(X), "dense")
    dx2 = (X[:, None, :] - X[None, :, :]).pow(2).sum(-1)  # (N, N)
    dy2 = (Y[:, None, :] - Y[None, :, :]).pow(2).sum(-1)  # (N, N)
    inv_lambda_ij = lam_inv[:, None] + lam_inv[None, :]  # (N, N)
    d = _pair_energy(dx2, dy2, inv_lambda_ij, sigma * sigma)  # (N, N)
    if weight is None:
        return d.mean()
    return (weight * d).sum() / weight.sum()


def _leg_block(s2: float):
    """The sum of ``w_ij D_ij`` over the rows of one block against all columns, as a pure
    function of its tensors (the weight rows last, when there are any)."""

    def block_sum(Xb, Yb, lb, X, Y, lam_inv, *wb):
        dx2 = (Xb[:, None, :] - X[None, :, :]).pow(2).sum(-1)  # (b, N)
        dy2 = (Yb[:, None, :] - Y[None, :, :]).pow(2).sum(-1)  # (b, N)
        d = _pair_energy(dx2, dy2, lb[:, None] + lam_inv[None, :], s2)  # (b, N)
        return d.sum() if not wb else (wb[0] * d).sum()

    return block_sum


def leg_chunked(X: torch.Tensor, Y: torch.Tensor, lam_inv: torch.Tensor, sigma: float, *,
                weight: torch.Tensor | None = None, block: int | None = None) -> torch.Tensor:
    r"""Dense LEG (:func:`leg_dense`, same equation and arguments) in blocks of rows.

    Each block of ``block`` rows against all N columns is one checkpoint segment (a custom
    autograd Function, :func:`pcgeom.losses._blocks.recomputed`): its (block, N)
    intermediates are freed after the forward pass and recomputed during backward, so memory
    is O(block * N) in both directions (the default block holds about 4M pairs) and backward
    costs one extra forward pass. The value equals :func:`leg_dense` up to the order of
    summation.

    Parameters
    ----------
    X, Y, lam_inv, sigma, weight
        As in :func:`leg_dense` (``weight`` is read one block of rows at a time).
    block : int, optional
        Rows per block.
    """
    n = len(X)
    _check_weight(weight, n, "chunked")
    block = block or max(1, _BLOCK_ELEMENTS // max(n, 1))
    block_sum = _leg_block(sigma * sigma)
    total = X.new_zeros(())
    for a in range(0, n, block):
        b = min(a + block, n)
        wb = () if weight is None else (weight[a:b],)
        total = total + recomputed(block_sum, X[a:b], Y[a:b], lam_inv[a:b], X, Y, lam_inv, *wb)
    return total / (n * n if weight is None else weight.sum())


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
    d = _pair_energy(dx2, dy2, inv_lambda_ij, sigma * sigma)  # (P,)
    if weight is None:
        return d.mean()
    return (weight * d).sum() / weight.sum()


LEG_BACKENDS = {"dense": leg_dense, "chunked": leg_chunked, "pairs": leg_pairs}
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

    over all ordered pairs (``"dense"``, ``"chunked"``) or over ``pairs`` (``"pairs"``), the
    mean weighted by ``weight`` when given.

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
        Pair indices ``(i, j)``; required by ``"pairs"``, refused by the others.
    weight : tensor, optional
        Non-negative pair weights: (P,) for ``"pairs"``, (N, N) for ``"dense"`` and
        ``"chunked"``.
    backend : {"auto", "dense", "chunked", "pairs"}
        ``"auto"``: ``"pairs"`` when ``pairs`` is given, else ``"dense"`` up to
        :data:`DENSE_MAX_PAIRS` ordered pairs, else ``"chunked"``.

    Raises
    ------
    ValueError
        Unknown backend (the message lists them), ``"pairs"`` without pairs, pairs given to
        ``"dense"`` or ``"chunked"``, or a weight of the wrong shape.
    """
    if backend == "auto":
        if pairs is not None:
            backend = "pairs"
        else:
            backend = "dense" if len(X) ** 2 <= DENSE_MAX_PAIRS else "chunked"
    if backend not in LEG_BACKENDS:
        raise ValueError(f"leg: unknown backend {backend!r}; choose one of: auto, "
                         f"{', '.join(LEG_BACKENDS)}")
    if backend != "pairs":
        if pairs is not None:
            raise ValueError(f"leg: the {backend!r} backend uses all pairs; do not pass pairs")
        return LEG_BACKENDS[backend](X, Y, lam_inv, sigma, weight=weight)
    if pairs is None:
        raise ValueError("leg: the 'pairs' backend needs pairs=(i, j)")
    if weight is not None and weight.shape != pairs[0].shape:
        raise ValueError(f"leg: the 'pairs' backend takes a weight of shape (P,) = "
                         f"({len(pairs[0])},), got {tuple(weight.shape)}")
    i, j = pairs
    return leg_pairs(X, Y, lam_inv, sigma, i, j, weight=weight)
