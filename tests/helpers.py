"""What several test modules share."""

from __future__ import annotations

import dataclasses

from pcgeom import cli
from pcgeom.config import (PRESETS, LocalMeshConfig, NetConfig, RefineConfig, ScheduleConfig,
                           get_preset)


def tiny_preset(name: str, *, epochs: int = 1, max_stages: int = 1, refine_steps: int = 5):
    """The named preset shrunk to seconds: short stages, small nets, a few refinement steps.

    Unknown names still raise the real error, so a test can patch a command's ``get_preset``
    with it and keep checking the CLI's messages.
    """
    return get_preset(
        name,
        schedule=ScheduleConfig(epochs=epochs, epochs_min=max(1, epochs // 2), batch_points=128,
                                batch_domain=128),
        param_net=NetConfig(width=32, depth=2, init="siren", w0=5.0),
        lambda_net=NetConfig(width=16, depth=1, init="siren", w0=5.0),
        domain_samples=512,
        max_stages=max_stages,
        refine=RefineConfig(steps=refine_steps),
        local_mesh=_tiny_local_mesh(name, refine_steps),
    )


def _tiny_local_mesh(name: str, refine_steps: int):
    """The preset's local-mesh settings with the refinement onto a domain as short."""
    if name not in PRESETS:
        return LocalMeshConfig()
    return dataclasses.replace(PRESETS[name].local_mesh, domain_refine=RefineConfig(
        steps=refine_steps, batch_domain=512, hand_backend="knn"))


def assert_cli_fails(capsys, argv: list[str], message: str) -> None:
    """``pcgeom argv`` exits with 2, prints nothing on stdout and exactly one stderr line,
    ``pcgeom: error: ...``, containing ``message``."""
    code = cli.main(argv)
    out, err = capsys.readouterr()
    assert code == 2, err
    assert out == ""
    assert err.startswith("pcgeom: error: ")
    assert err.count("\n") == 1, err
    assert message in err, err


def map_record(result) -> dict:
    """The map's first history record: the one after the denoising's, when the run fitted a
    noisy cloud first (``--denoise``), else the first."""
    return next(r for r in result.history if r.get("stage") != "denoise")
