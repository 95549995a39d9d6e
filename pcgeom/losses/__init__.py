"""Pure torch loss functions of the paper: Boltzmann operator, HAND, LEG, landmark HAND.

LEG and HAND each dispatch through one backend table (:data:`LEG_BACKENDS`,
:data:`HAND_BACKENDS`) with an ``"auto"`` rule. Nothing here imports an app, a plotting or a
meshing library.
"""

from .boltzmann import boltzmann
from .hand import (HAND_BACKENDS, hand, hand_chunked, hand_dense, hand_knn, modified_hausdorff,
                   pairwise_distances)
from .landmarks import landmark_hand
from .leg import LEG_BACKENDS, leg, leg_chunked, leg_dense, leg_pairs

__all__ = [
    "boltzmann",
    "hand",
    "hand_dense",
    "hand_chunked",
    "hand_knn",
    "HAND_BACKENDS",
    "modified_hausdorff",
    "pairwise_distances",
    "landmark_hand",
    "leg",
    "leg_dense",
    "leg_chunked",
    "leg_pairs",
    "LEG_BACKENDS",
]
