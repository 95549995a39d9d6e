"""The one objective and optimization step that network stages and the refinement share.

eq. (optim problem overall):

    beta_1 LEG(f, l, X u P) + beta_2 HAND(f(X), W) + beta_3 sum_k HAND(f(P_k), Q_k)

A loop builds a :class:`Batch` (what it maps this step), :func:`step` evaluates the
:class:`Objective` on it, backpropagates and steps the optimizer, and a :class:`StageLog`
reads the terms (sparingly: each read synchronizes a GPU), drives the progress bar and builds
the stage's history record. A new loss term or LEG backend is one edit here.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, field

import torch

from ..config import LossWeights
from ..losses import hand, landmark_hand, leg
from ..metrics import hausdorff
from ..progress import Progress

__all__ = ["LOSS_TERMS", "Batch", "Objective", "step", "StageLog", "landmark_fit"]

LOSS_TERMS = ("total", "leg", "hand", "landmarks")
"""Names of the loss terms in history records, in display order."""


@dataclass
class Batch:
    """What one optimization step maps, in the normalized frame."""

    X: torch.Tensor
    """(B, 3) points whose pairs enter LEG (the landmark points are its tail, when any)."""
    Y: torch.Tensor
    """(B, 2) their images."""
    lam_inv: torch.Tensor
    """(B,) l at those points."""
    sigma: float
    """LEG kernel width."""
    alpha: float
    """HAND sharpness (domain and landmark terms)."""
    pairs: tuple[torch.Tensor, torch.Tensor] | None = None
    """LEG pairs (i, j) into the rows of X; None: all pairs (dense)."""
    leg_weight: torch.Tensor | None = None
    """LEG pair weights: (P,) with ``pairs``, else (B, B) (e.g. 0 for the pairs whose normals
    disagree); None: unit weights."""
    W: torch.Tensor | None = None
    """(M, 2) domain samples this step; None for the free boundary (no HAND term)."""
    domain_rows: int | None = None
    """HAND pulls ``Y[:domain_rows]`` onto ``W`` (all of ``Y`` when None)."""
    hand_backend: str = "auto"
    """Backend of that HAND term (:data:`pcgeom.losses.HAND_BACKENDS`)."""
    hand_neighbours: int = 8
    """k of the ``"knn"`` HAND backend."""
    landmark_index: Sequence[torch.Tensor] = field(default_factory=tuple)
    """Rows of ``Y`` holding the images f(P_k) of each landmark set."""


@dataclass(frozen=True)
class Objective:
    """The weighted sum of the terms a run has: LEG always, HAND with a domain, landmarks."""

    weights: LossWeights
    """beta_1, beta_2, beta_3."""
    landmark_targets: Sequence[torch.Tensor] = ()
    """Target sets Q_k, in domain units."""

    def __call__(self, batch: Batch) -> dict[str, torch.Tensor]:
        """Every term of the batch by name (``LOSS_TERMS``), with ``"total"`` last.

        The views of ``Y`` each term reads are taken here, term after term: autograd sums
        the gradients reaching ``Y`` in the order the views were made, so one fixed order
        keeps a seed's result bit for bit.
        """
        beta, Y = self.weights, batch.Y
        terms = {"leg": leg(batch.X, Y, batch.lam_inv, batch.sigma, pairs=batch.pairs,
                            weight=batch.leg_weight)}
        total = beta.leg * terms["leg"]
        if batch.W is not None:
            pulled = Y if batch.domain_rows is None else Y[: batch.domain_rows]
            terms["hand"] = hand(pulled, batch.W, batch.alpha, backend=batch.hand_backend,
                                 k=batch.hand_neighbours)
            total = total + beta.domain * terms["hand"]
        if batch.landmark_index:
            mapped = [Y[rows] for rows in batch.landmark_index]
            terms["landmarks"] = landmark_hand(mapped, self.landmark_targets, batch.alpha)
            total = total + beta.landmarks * terms["landmarks"]
        terms["total"] = total
        return terms


def step(objective: Objective, batch: Batch, optimizer: torch.optim.Optimizer
         ) -> dict[str, torch.Tensor]:
    """One optimizer step on ``objective(batch)``; returns the terms (tensors, not read)."""
    terms = objective(batch)
    optimizer.zero_grad(set_to_none=True)
    terms["total"].backward()
    optimizer.step()
    return terms


class StageLog:
    """Progress bar, sparse reads of the loss terms, and the history record of one stage.

    Reading a loss value synchronizes a GPU, so the loops call :meth:`read` only where a
    value is shown or recorded (once per epoch, or every 50 refinement steps).
    """

    def __init__(self, total: int, desc: str, progress: bool) -> None:
        self.t0 = time.perf_counter()
        self.last: dict[str, float] = {}
        self.bar = Progress(total, desc, enabled=progress, unit="step")

    def read(self, terms: dict[str, torch.Tensor], **shown: float) -> None:
        """Record the current terms as floats and show them (with ``shown``) on the bar (on a
        log: on the stage's one line)."""
        self.last = {k: float(v.detach()) for k, v in terms.items()}
        if self.bar.enabled:
            values = self.last | shown
            self.bar.set_postfix({k: f"{v:.3g}" for k, v in values.items()})

    def advance(self, n: int = 1) -> None:
        self.bar.update(n)

    def record(self, **schedule) -> dict:
        """The stage's history record: ``schedule`` values, seconds, and the last terms read.

        Only the terms this run computes appear: a 0.0 for an unused term would read as a
        perfect fit.
        """
        self.bar.close()
        return {**schedule, "seconds": time.perf_counter() - self.t0, **self.last}


def landmark_fit(images: Sequence[torch.Tensor], targets: Sequence[torch.Tensor]) -> list[float]:
    """Exact Hausdorff distance of each mapped landmark set to its target set (domain units)."""
    return [hausdorff(y.detach().cpu().double().numpy(), q.cpu().double().numpy())
            for y, q in zip(images, targets)]
