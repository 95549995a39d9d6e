"""Per-point refinement after the networks (see :class:`pcgeom.config.RefineConfig`)."""

from __future__ import annotations

import numpy as np
import torch

from ..config import RefineConfig
from ..train.data import TrainData
from ..train.objective import Batch, Objective, StageLog, landmark_fit, step

__all__ = ["refine", "refine_hand_backend", "DENSE_HAND_MAX"]

_READ_EVERY = 50
"""Refinement steps between two reads of the loss terms (each read synchronizes a GPU)."""

DENSE_HAND_MAX = 1 << 23
"""``RefineConfig.hand_backend = "auto"`` computes HAND densely while N x batch_domain is at
most this (8192 points against 1024 samples), and with the O(N) ``"knn"`` backend above."""


def refine_hand_backend(config: RefineConfig, n_points: int, batch_domain: int) -> str:
    """The HAND backend the refinement uses for ``n_points`` against ``batch_domain`` samples."""
    if config.hand_backend != "auto":
        return config.hand_backend
    return "dense" if n_points * batch_domain <= DENSE_HAND_MAX else "knn"


def refine(data: TrainData, Xn: np.ndarray, start: tuple[torch.Tensor, torch.Tensor],
           objective: Objective, config: RefineConfig, *, normals: np.ndarray | None = None,
           progress: bool) -> tuple[torch.Tensor, torch.Tensor, dict]:
    """Optimize each point's image and ``log l_i`` on local LEG pairs, from ``start``.

    Parameters
    ----------
    data : TrainData
        The run's tensors; HAND pulls all points onto a fresh batch of ``data.W`` every step.
    Xn : (N, 3) float64
        The normalized cloud (``data.X`` in NumPy), for the neighbour search.
    start : ((N, 2) tensor, (N,) tensor)
        The networks' map and l at the points.
    objective : Objective
    config : RefineConfig
    normals : (N, 3) float64, optional
        Oriented normals: pairs whose normals disagree (``n_i . n_j <= 0``, the two sheets of
        a surface that doubles back) are left out of LEG.

    Returns
    -------
    U : (N, 2) tensor
    lam_inv : (N,) tensor
    record : dict
        The history record of the refinement.
    """
    from scipy.spatial import cKDTree

    U0, lam0 = start
    X, dev = data.X, data.X.device
    n = len(Xn)
    k = min(config.neighbours, n - 1)
    tree = cKDTree(Xn)
    dist, nb = tree.query(Xn, k + 1)
    spacing = float(dist[:, 1].mean())
    sigma = config.sigma_spacing * spacing
    i = np.arange(n).repeat(k)
    j = nb[:, 1:].reshape(-1)
    if normals is not None:
        same = np.einsum("pd,pd->p", normals[i], normals[j]) > 0
        i, j = i[same], j[same]
    i = torch.as_tensor(i, device=dev)
    j = torch.as_tensor(j, device=dev)
    with torch.no_grad():
        mapped_spacing = float((U0[i] - U0[j]).norm(dim=-1).median())
        start = U0.detach().clone()
        step_scale = None
        if config.local_steps:
            # Each point's median mapped distance to its neighbours, relative to the median.
            near = U0[torch.as_tensor(nb[:, 1:], device=dev)] - U0[:, None]  # (N, k, 2)
            step_scale = (near.norm(dim=-1).median(dim=1).values
                          / max(mapped_spacing, 1e-300)).clamp_min(1e-3)[:, None]  # (N, 1)
    # Adam moves the free tensor D; the map is start + step_scale * D.
    D = torch.zeros_like(start).requires_grad_(True)
    log_l = lam0.detach().clamp_min(1e-12).log().clone().requires_grad_(True)
    opt = torch.optim.Adam([{"params": [D], "lr": config.lr_spacing * mapped_spacing},
                            {"params": [log_l], "lr": config.lr_lambda}])

    def current() -> torch.Tensor:
        return start + (D if step_scale is None else step_scale * D)

    # Each landmark point acts through its nearest cloud point.
    lm_index = [torch.as_tensor(tree.query(p.cpu().double().numpy())[1], device=dev)
                for p in data.landmark_points]
    batch_domain = min(config.batch_domain, data.n_domain)
    hand_backend = refine_hand_backend(config, n, batch_domain)
    log = StageLog(config.steps, "refine", progress)
    for s in range(config.steps):
        batch = Batch(
            X=X, Y=current(), lam_inv=log_l.exp(), sigma=sigma, alpha=config.alpha,
            pairs=(i, j),
            # All points every step: HAND on a random subset would move only that
            # subset's points and tear them from their neighbours.
            W=data.domain_batch(batch_domain), landmark_index=lm_index,
            hand_backend=hand_backend, hand_neighbours=config.hand_neighbours,
        )
        terms = step(objective, batch, opt)
        if s == config.steps - 1 or (log.bar is not None and s % _READ_EVERY == 0):
            log.read(terms)
        log.advance()
    record = log.record(
        stage="refine", kind="refine", epochs=1, steps=config.steps, sigma=sigma,
        alpha_initial=config.alpha, alpha_final=config.alpha, batch_points=n,
        batch_domain=batch_domain,
    )
    if data.W is not None:
        record["hand_backend"] = hand_backend
    U = current().detach()
    if lm_index:
        record["landmark_hausdorff"] = landmark_fit([U[ix] for ix in lm_index],
                                                    data.landmark_targets)
    return U, log_l.detach().exp(), record
