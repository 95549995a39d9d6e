"""Training: Algorithm 1's stages, the per-point refinement, checkpoints.

- :mod:`.run`: :func:`parametrize`, the entry point.
- :mod:`.plan`: :class:`Stage`, :func:`stage_plan` (Algorithm 1's schedule).
- :mod:`.objective`: the one objective and step both loops share, :data:`LOSS_TERMS`.
- :mod:`.networks`: the two nets, their optimizer, one network stage.
- :mod:`.refine`: the per-point refinement.
- :mod:`.checkpoint`: stage checkpoints (loaded with ``weights_only=True``).
"""

from .device import resolve_device
from .objective import LOSS_TERMS
from .run import parametrize
from .plan import Stage, stage_plan

__all__ = ["parametrize", "Stage", "stage_plan", "resolve_device", "LOSS_TERMS"]
