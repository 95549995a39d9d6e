"""What a run trains on, on its device: the normalized cloud, the domain sample, landmarks."""

from __future__ import annotations

from dataclasses import dataclass

import torch

__all__ = ["TrainData"]


@dataclass
class TrainData:
    """The tensors of one run and the generator that draws its mini-batches.

    Every random draw of training goes through :attr:`gen` (on the CPU, so a seed gives the
    same batches on every device), in a fixed order: a point batch, then a domain batch.
    """

    X: torch.Tensor
    """(N, 3) normalized cloud, distinct points."""
    W: torch.Tensor | None
    """(|W|, 2) sample of the domain; None for the free boundary."""
    landmark_points: list[torch.Tensor]
    """Landmark sets P_k, normalized like the cloud."""
    landmark_targets: list[torch.Tensor]
    """Their targets Q_k, in domain units."""
    gen: torch.Generator
    """CPU generator of every mini-batch."""

    @property
    def n_domain(self) -> int:
        """|W|, 0 for the free boundary."""
        return 0 if self.W is None else len(self.W)

    def point_batch(self, size: int) -> torch.Tensor:
        """Indices of ``size`` distinct random points, on the cloud's device."""
        return torch.randperm(len(self.X), generator=self.gen)[:size].to(self.X.device)

    def domain_batch(self, size: int) -> torch.Tensor | None:
        """``size`` distinct random domain samples, or None for the free boundary."""
        if self.W is None:
            return None
        widx = torch.randperm(len(self.W), generator=self.gen)[:size].to(self.X.device)
        return self.W[widx]
