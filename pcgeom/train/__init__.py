"""The optimization machinery the trained maps share (the maps themselves: :mod:`pcgeom.maps`).

- :mod:`.plan`: :class:`Stage`, :func:`stage_plan` (Algorithm 1's schedule).
- :mod:`.objective`: the one objective and step the network stages and the refinement share,
  :data:`LOSS_TERMS`, :class:`StageLog` (the loss terms read sparingly, progress).
- :mod:`.data`: :class:`TrainData`, the run's tensors and its one batch generator.
- :mod:`.checkpoint`: stage checkpoints (loaded with ``weights_only=True``).
- :mod:`.device`: :func:`resolve_device`.
"""

from .device import resolve_device
from .objective import LOSS_TERMS
from .plan import Stage, stage_plan

__all__ = ["Stage", "stage_plan", "resolve_device", "LOSS_TERMS"]
