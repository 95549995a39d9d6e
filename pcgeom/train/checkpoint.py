"""Stage checkpoints: written atomically after each stage, loaded without running code.

A checkpoint holds tensors, numbers, strings, lists and dicts only, and is loaded with
``torch.load(weights_only=True)``: a crafted ``.ckpt`` cannot execute anything, it fails to
load. It also records the run's identity (the input's fingerprint, the config, the seed, the
domain, the normals and the landmarks), and a run resumes only from a checkpoint of the same
identity.
"""

from __future__ import annotations

from pathlib import Path

import torch

from ..errors import InputError, _one_line
from ..io.atomic import write_atomic

__all__ = ["save_checkpoint", "load_checkpoint"]



# How a differing identity key is named in the refusal.
_IDENTITY_NAMES = {"fingerprint": "input", "config": "preset or settings"}


def save_checkpoint(path, state: dict) -> None:
    """``torch.save(state)`` to ``path`` atomically."""
    write_atomic(Path(path), lambda f: torch.save(state, f))


def load_checkpoint(path, identity: dict) -> dict:
    """The state saved at ``path``, checked to hold the same ``identity`` (plain data: the
    input's fingerprint, config, seed, domain, normals, landmarks) as the run that resumes it.

    Loaded onto the CPU: the RNG states must be CPU ByteTensors (``set_state`` rejects CUDA
    ones); ``load_state_dict`` then copies weights and optimizer state to the run's device.

    Raises
    ------
    InputError
        The file is not a pcgeom checkpoint, holds anything but plain data (e.g. pickled
        objects), or comes from a different input, config or seed.
    """
    try:
        state = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as exc:  # pickle.UnpicklingError for code, RuntimeError for garbage, ...
        raise InputError(f"{path}: not a loadable pcgeom checkpoint ({_one_line(exc)[:200]}); "
                         "delete it to start over") from None
    if not isinstance(state, dict) or not set(identity) <= set(state):
        raise InputError(f"{path}: not a pcgeom checkpoint; delete it to start over")
    differ = [_IDENTITY_NAMES.get(key, key) for key, value in identity.items()
              if state[key] != value]
    if differ:
        raise InputError(f"{path}: checkpoint is from a different input, normals, domain, "
                         f"landmarks, config or seed (here: {', '.join(differ)}); delete it "
                         "to start over")
    return state
