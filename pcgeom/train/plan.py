"""Algorithm 1's stage plan: what each stage trains with, decided before training starts."""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..config import ScheduleConfig

__all__ = ["Stage", "stage_plan"]


@dataclass(frozen=True)
class Stage:
    """One stage of Algorithm 1 as it will run."""

    index: int
    """0-based position in the plan."""
    epochs: int
    """E of this stage."""
    batch_points: int
    """B_X."""
    batch_domain: int
    """B_W (0 for the free boundary)."""
    sigma: float
    """LEG kernel width."""
    alpha_initial: float
    """HAND sharpness at the first epoch."""
    alpha_final: float
    """HAND sharpness at the last epoch."""
    steps_per_epoch: int
    """ceil(|X| / B_X) mini-batches per epoch, at most ``max_steps_per_epoch`` when the
    schedule caps it."""

    drop_cross_sheet: bool = False
    """LEG pairs whose normals disagree get weight 0, when the cloud has normals."""

    def alpha(self, epoch: int) -> float:
        """alpha during epoch ``epoch`` (0-based): linear from alpha_initial to alpha_final
        (lines 6, 11)."""
        if self.epochs <= 1:
            return self.alpha_initial
        return (self.alpha_initial
                + epoch * (self.alpha_final - self.alpha_initial) / (self.epochs - 1))


def stage_plan(n_points: int, n_domain: int, schedule: ScheduleConfig,
               max_stages: int = 0) -> list[Stage]:
    """The sequence of stages Algorithm 1 runs for a cloud of ``n_points``.

    Stages continue until the stage whose batch is the whole cloud has run
    (lines 3-5). A first batch larger than the cloud is clamped to it, as line
    18 would clamp it. ``n_domain = 0`` (free boundary) gives domain batches of 0.
    ``max_stages > 0`` truncates the plan. ``schedule.max_steps_per_epoch > 0`` caps the
    ceil(|X| / B_X) steps of each epoch (not in the paper), so that a stage's time stops
    growing with |X|.
    """
    cap = schedule.max_steps_per_epoch
    E = schedule.epochs
    bx = min(schedule.batch_points, n_points)
    bw = min(schedule.batch_domain, n_domain) if n_domain else 0
    sigma, a0, a1 = schedule.sigma, schedule.alpha_initial, schedule.alpha_final
    stages = []
    while True:
        last = bx == n_points
        steps = math.ceil(n_points / bx)
        steps = min(steps, cap) if cap else steps
        stages.append(Stage(len(stages), E, bx, bw, sigma, a0, a1, steps,
                            schedule.drop_cross_sheet))
        if last or (max_stages and len(stages) >= max_stages):
            return stages
        sigma = max(sigma / math.sqrt(2.0), schedule.sigma_min)
        a0, a1 = a1, min(2.0 * a1, schedule.alpha_max)
        E = max(E // 2, schedule.epochs_min)
        bx = min(2 * bx, n_points)
        bw = min(2 * bw, n_domain) if n_domain else 0
