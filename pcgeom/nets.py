"""Sine-activated networks: parametrization net, inverse-lambda net, 2D shape-deform net."""

from __future__ import annotations

import math

import torch
from torch import nn

from .config import NetConfig

__all__ = ["SineMLP", "ParamNet", "LambdaInvNet", "DeformNet"]


class SineMLP(nn.Module):
    """``in_dim -> [sin(Linear)] * depth -> Linear -> out_dim``.

    With ``init="siren"`` the first layer computes ``sin(w0 * (W x + b))`` and
    the weights follow SIREN (first layer U(-1/in, 1/in), hidden layers
    U(-sqrt(6/width)/w0', ...)) so that activations stay well spread; with
    ``init="default"`` every layer is ``sin(W x + b)`` with PyTorch's default init.
    """

    def __init__(self, in_dim: int, out_dim: int, config: NetConfig) -> None:
        super().__init__()
        self.config = config
        dims = [in_dim] + [config.width] * config.depth
        self.hidden = nn.ModuleList(nn.Linear(a, b) for a, b in zip(dims[:-1], dims[1:]))
        self.out = nn.Linear(dims[-1], out_dim)
        self.first_scale = config.w0 if config.init == "siren" else 1.0
        if config.init == "siren":
            self._siren_init()

    @torch.no_grad()
    def _siren_init(self) -> None:
        for k, layer in enumerate(self.hidden):
            fan_in = layer.in_features
            bound = 1.0 / fan_in if k == 0 else math.sqrt(6.0 / fan_in)
            layer.weight.uniform_(-bound, bound)
            layer.bias.uniform_(-1.0 / math.sqrt(fan_in), 1.0 / math.sqrt(fan_in))
        bound = math.sqrt(6.0 / self.out.in_features)
        self.out.weight.uniform_(-bound, bound)
        self.out.bias.zero_()

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        h = torch.sin(self.first_scale * self.hidden[0](x))
        for layer in self.hidden[1:]:
            h = torch.sin(layer(h))
        return self.out(h)


class ParamNet(SineMLP):
    """Parametrization net f: R^3 -> R^2, sine hidden layers, linear output.

    With ``plane`` (a (2, 3) matrix, e.g. the cloud's two principal directions)
    the net becomes ``f(x) = plane @ x + g(x)``, a trainable linear term plus the
    sine MLP ``g`` whose output layer starts at the constant ``offset`` (the
    domain's centroid; zero by default): training starts from the projection onto
    that plane, an unfolded map for any surface that is a graph over it, instead
    of a random one.
    """

    def __init__(
        self,
        config: NetConfig = NetConfig(),
        plane: torch.Tensor | None = None,
        offset: torch.Tensor | None = None,
    ) -> None:
        super().__init__(3, 2, config)
        self.plane: nn.Linear | None = None
        if plane is not None:
            if tuple(plane.shape) != (2, 3):
                raise ValueError(f"ParamNet plane: expected shape (2, 3), got {tuple(plane.shape)}")
            self.plane = nn.Linear(3, 2, bias=False)
            with torch.no_grad():
                self.plane.weight.copy_(plane)
                self.out.weight.zero_()
                self.out.bias.zero_()
                if offset is not None:
                    self.out.bias.copy_(offset)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        y = super().forward(x)
        return y if self.plane is None else y + self.plane(x)


class LambdaInvNet(nn.Module):
    """Inverse-lambda net l: R^3 -> R_{>0}, sine hidden layers, softplus output.

    ``1 / lambda(x_i, x_j) = l(x_i) + l(x_j)`` in LEG; softplus keeps it positive.
    """

    def __init__(self, config: NetConfig = NetConfig(width=64, depth=2)) -> None:
        super().__init__()
        self.body = SineMLP(3, 1, config)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return nn.functional.softplus(self.body(x)).squeeze(-1)


class DeformNet(SineMLP):
    """2D shape-deform net R^2 -> R^2 (the paper's HAND-only experiment, section 7.1)."""

    def __init__(self, config: NetConfig = NetConfig(width=64, depth=2)) -> None:
        super().__init__(2, 2, config)
