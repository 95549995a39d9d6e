"""The two networks of a run, their optimizer, and one stage of Algorithm 1 (lines 6-13)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from ..config import OptimizerConfig, ParamConfig
from ..domains import Domain
from ..nets import LambdaInvNet, ParamNet
from ..train.data import TrainData
from ..train.objective import Batch, Objective, StageLog, landmark_fit, step
from ..train.plan import Stage

__all__ = ["Networks", "build_networks", "initial_plane", "run_network_stage"]


@dataclass
class Networks:
    """The parametrization net f, the inverse-lambda net l and their optimizer."""

    param_net: ParamNet
    lambda_net: LambdaInvNet
    optimizer: torch.optim.Optimizer

    def state_dict(self) -> dict:
        return {"param_net": self.param_net.state_dict(),
                "lambda_net": self.lambda_net.state_dict(),
                "optimizer": self.optimizer.state_dict()}

    def load_state_dict(self, state: dict) -> None:
        self.param_net.load_state_dict(state["param_net"])
        self.lambda_net.load_state_dict(state["lambda_net"])
        self.optimizer.load_state_dict(state["optimizer"])


def make_optimizer(params, config: OptimizerConfig) -> torch.optim.Optimizer:
    """The optimizer ``config`` names (validated when the config was built)."""
    if config.name == "rmsprop":
        return torch.optim.RMSprop(params, lr=config.lr, alpha=config.rmsprop_alpha,
                                   momentum=config.momentum)
    return torch.optim.Adam(params, lr=config.lr)


def initial_plane(Xn: np.ndarray, domain: Domain,
                  W: torch.Tensor | None) -> tuple[torch.Tensor, torch.Tensor]:
    """The (2, 3) linear term and (2,) offset that start f as the best-fit-plane projection.

    The projection onto the cloud's two principal directions is centred at the domain's
    centroid and, for a bounded domain, scaled to the domain sample's reach from it.
    """
    _, _, vt = np.linalg.svd(Xn - Xn.mean(axis=0), full_matrices=False)
    plane = vt[:2]  # (2, 3): the two principal directions
    centroid = np.asarray(domain.centroid, dtype=np.float64)
    if W is not None:
        extent = np.linalg.norm(Xn @ plane.T, axis=1).max()
        reach = np.linalg.norm(W.cpu().double().numpy() - centroid, axis=1).max()
        plane = plane * (reach / extent)
    return torch.tensor(plane, dtype=torch.float32), torch.tensor(centroid, dtype=torch.float32)


def build_networks(config: ParamConfig, Xn: np.ndarray, domain: Domain,
                   data: TrainData) -> Networks:
    """f, l and the optimizer, initialized from torch's global RNG (seeded by the caller)."""
    dev, dtype = data.X.device, data.X.dtype
    plane = offset = None
    if config.init_map == "plane":
        plane, offset = initial_plane(Xn, domain, data.W)
    param_net = ParamNet(config.param_net, plane=plane, offset=offset).to(dev, dtype)
    lambda_net = LambdaInvNet(config.lambda_net).to(dev, dtype)
    params = list(param_net.parameters()) + list(lambda_net.parameters())
    return Networks(param_net, lambda_net, make_optimizer(params, config.optimizer))


def run_network_stage(stage: Stage, nets: Networks, data: TrainData, objective: Objective, *,
                      n_stages: int, progress: bool) -> dict:
    """Lines 6-13 of Algorithm 1 for one stage; returns the stage's history record."""
    f, lam = nets.param_net, nets.lambda_net
    # The landmarks ride at the tail of every LEG batch (eq. optim problem overall: LEG over
    # X u P); their rows in it:
    P_all = torch.cat(data.landmark_points) if data.landmark_points else None
    ends = np.cumsum([0] + [len(p) for p in data.landmark_points]) + stage.batch_points
    tail = [torch.arange(a, b, device=data.X.device) for a, b in zip(ends[:-1], ends[1:])]
    log = StageLog(stage.epochs, f"stage {stage.index + 1}/{n_stages}", progress)
    n_landmarks = int(ends[-1]) - stage.batch_points
    mask = stage.drop_cross_sheet and data.normals is not None
    n_steps = 0
    for epoch in range(stage.epochs):
        alpha = stage.alpha(epoch)
        for _ in range(stage.steps_per_epoch):
            idx = data.point_batch(stage.batch_points)
            xb = data.X[idx] if P_all is None else torch.cat([data.X[idx], P_all])
            yb = f(xb)
            batch = Batch(
                X=xb, Y=yb, lam_inv=lam(xb), sigma=stage.sigma, alpha=alpha,
                leg_weight=data.same_sheet_weight(idx, n_landmarks) if mask else None,
                W=data.domain_batch(stage.batch_domain), domain_rows=stage.batch_points,
                landmark_index=tail,
            )
            terms = step(objective, batch, nets.optimizer)
            n_steps += 1
        log.read(terms, alpha=alpha)  # once per epoch: the last step's terms
        log.advance()
    record = log.record(
        stage=stage.index + 1, kind="network", epochs=stage.epochs, steps=n_steps,
        sigma=stage.sigma, alpha_initial=stage.alpha_initial, alpha_final=stage.alpha_final,
        batch_points=stage.batch_points, batch_domain=stage.batch_domain,
        same_sheet_pairs=bool(mask),
    )
    if data.landmark_points:
        with torch.no_grad():
            images = [f(p) for p in data.landmark_points]
        record["landmark_hausdorff"] = landmark_fit(images, data.landmark_targets)
    return record
