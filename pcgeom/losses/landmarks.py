"""Landmark term: HAND between each mapped landmark set and its target set."""

from __future__ import annotations

from collections.abc import Sequence

import torch

from .hand import hand

__all__ = ["landmark_hand"]


def landmark_hand(
    mapped: Sequence[torch.Tensor], targets: Sequence[torch.Tensor], alpha: float
) -> torch.Tensor:
    r"""Sum of HAND over landmark pairs (paper, eq. optim problem overall, third term).

    .. math::
        \sum_{k=1}^{M} H_\alpha\big(f(P_k), Q_k\big)

    ``f(P_k)`` and ``Q_k`` need not have the same size nor any correspondence:
    a landmark curve of 134 points can match a target line of 400 samples.

    Parameters
    ----------
    mapped : sequence of (n_k, 2) tensors
        Mapped landmark sets ``f(P_k)``.
    targets : sequence of (m_k, 2) tensors
        Target sets ``Q_k``, same length as ``mapped``.
    alpha : float
        HAND sharpness.
    """
    if len(mapped) != len(targets):
        raise ValueError(
            f"landmark_hand: got {len(mapped)} landmark sets but {len(targets)} target sets"
        )
    if len(mapped) == 0:
        raise ValueError("landmark_hand: need at least one landmark pair")
    return torch.stack([hand(p, q, alpha) for p, q in zip(mapped, targets)]).sum()
