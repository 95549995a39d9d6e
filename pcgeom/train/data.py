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
    normals: torch.Tensor | None = None
    """(N, 3) oriented unit normals of the rows of ``X``, when the cloud has them."""

    @property
    def n_domain(self) -> int:
        """|W|, 0 for the free boundary."""
        return 0 if self.W is None else len(self.W)

    def point_batch(self, size: int) -> torch.Tensor:
        """Indices of ``size`` distinct random points, on the cloud's device."""
        return torch.randperm(len(self.X), generator=self.gen)[:size].to(self.X.device)

    def same_sheet_weight(self, idx: torch.Tensor, extra: int = 0) -> torch.Tensor | None:
        """(B + extra, B + extra) LEG weight of the batch ``idx``: 0 for the pairs whose
        normals disagree (``n_i . n_j <= 0``: the other sheet of a surface that doubles back),
        1 otherwise and for the ``extra`` rows appended after the batch (landmarks, which have
        no normals). None when the cloud has no normals.
        """
        if self.normals is None:
            return None
        n = self.normals[idx]  # (B, 3)
        same = (n @ n.T > 0).to(self.X.dtype)  # (B, B)
        if extra:
            same = torch.nn.functional.pad(same, (0, extra, 0, extra), value=1.0)
        return same

    def domain_batch(self, size: int) -> torch.Tensor | None:
        """``size`` distinct random domain samples, or None for the free boundary."""
        if self.W is None:
            return None
        widx = torch.randperm(len(self.W), generator=self.gen)[:size].to(self.X.device)
        return self.W[widx]
