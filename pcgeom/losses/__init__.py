"""Pure torch loss functions of the paper: Boltzmann operator, HAND, LEG, landmark HAND."""

from .boltzmann import boltzmann
from .hand import hand, hausdorff, modified_hausdorff, pairwise_distances
from .landmarks import landmark_hand
from .leg import leg, leg_pairs

__all__ = [
    "boltzmann",
    "hand",
    "hausdorff",
    "modified_hausdorff",
    "pairwise_distances",
    "landmark_hand",
    "leg",
    "leg_pairs",
]
