"""What the example scripts share: arguments, data paths, timing, JSON and figure output.

Not part of the pcgeom API; each script imports it from its own folder.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
DATA_DIR = REPO.parent / "shared" / "data"
"""The shared test surfaces sit at ``../shared/data/`` beside the checkout."""


def parser(description: str) -> argparse.ArgumentParser:
    """``--out DIR`` (required), ``--quick`` and ``--seed``."""
    p = argparse.ArgumentParser(description=description)
    p.add_argument("--out", required=True, metavar="DIR",
                   help="folder for the figures (PNG) and the numbers (JSON); created if absent")
    p.add_argument("--quick", action="store_true",
                   help="a tiny budget (seconds): checks that the script runs, not the paper's "
                        "figures")
    p.add_argument("--seed", type=int, default=0, help="random seed (default: 0)")
    return p


def data_file(name: str) -> Path:
    """``../shared/data/NAME``, or exit with a one-line message when it is missing."""
    path = DATA_DIR / name
    if not path.is_file():
        sys.exit(f"{Path(sys.argv[0]).name}: needs {path} (the shared test surfaces, "
                 "../shared/data/ beside the checkout); it is missing")
    return path


def out_dir(path) -> Path:
    out = Path(path)
    out.mkdir(parents=True, exist_ok=True)
    return out


def write_json(path: Path, data: dict) -> Path:
    """``data`` as indented JSON, atomically (NumPy scalars and arrays converted)."""
    from pcgeom.io import write_atomic

    def plain(v):
        if isinstance(v, dict):
            return {str(k): plain(x) for k, x in v.items()}
        if isinstance(v, (list, tuple)):
            return [plain(x) for x in v]
        if isinstance(v, np.ndarray):
            return plain(v.tolist())
        if isinstance(v, np.generic):
            return v.item()
        return v

    text = json.dumps(plain(data), indent=2) + "\n"
    write_atomic(path, lambda f: f.write(text.encode("utf-8")))
    return path


def figure(width: float, height: float):
    """A matplotlib Figure on the Agg canvas (no pyplot, no display)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width, height), dpi=110, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def save(fig, path: Path) -> Path:
    from pcgeom.io import write_atomic

    write_atomic(path, lambda f: fig.savefig(f, format="png"))
    return path


def draw_domain(ax, domain, color: str = "red") -> None:
    """The domain's boundary loops as closed curves."""
    for loop in domain.boundary_loops():
        loop = np.asarray(loop)
        ax.plot(loop[:, 0], loop[:, 1], color=color, linewidth=1.0)


def scatter_map(ax, U, values=None, title: str | None = None, domain=None) -> None:
    size = float(np.clip(8000.0 / len(U), 0.3, 8.0))
    if values is None:
        ax.scatter(U[:, 0], U[:, 1], s=size, c="tab:blue", linewidths=0)
    else:
        ax.scatter(U[:, 0], U[:, 1], s=size, c=values, cmap="viridis", linewidths=0)
    if domain is not None:
        draw_domain(ax, domain)
    ax.set_aspect("equal", adjustable="datalim")
    if title:
        ax.set_title(title, fontsize=9)


class Clock:
    """Wall seconds since it was made."""

    def __init__(self) -> None:
        self.t0 = time.perf_counter()

    def __call__(self) -> float:
        return time.perf_counter() - self.t0


def log(script: str, msg: str) -> None:
    print(f"[{script}] {msg}", file=sys.stderr, flush=True)


def threads() -> int:
    """torch's thread count: OMP_NUM_THREADS when set, else torch's default."""
    import torch

    if os.environ.get("OMP_NUM_THREADS"):
        torch.set_num_threads(int(os.environ["OMP_NUM_THREADS"]))
    return torch.get_num_threads()


def tiny_config(preset: str = "networks", *, epochs: int = 2, refine_steps: int = 20,
                batch: int = 512, refine_batch_domain: int = 1024):
    """``preset`` shrunk to seconds (``--quick``): short stages, small nets, few refinement
    steps (after the networks, and after the local mesh laid on a domain)."""
    import dataclasses

    from pcgeom import get_preset
    from pcgeom.config import PRESETS, NetConfig, RefineConfig, ScheduleConfig

    local_mesh = PRESETS[preset].local_mesh if preset in PRESETS else None
    if local_mesh is not None:
        local_mesh = dataclasses.replace(local_mesh, domain_refine=dataclasses.replace(
            local_mesh.domain_refine, steps=refine_steps))
    return get_preset(
        preset,
        **({"local_mesh": local_mesh} if local_mesh is not None else {}),
        schedule=ScheduleConfig(epochs=epochs, epochs_min=max(1, epochs // 2), batch_points=batch,
                                batch_domain=batch),
        param_net=NetConfig(width=32, depth=2, init="siren", w0=5.0),
        lambda_net=NetConfig(width=16, depth=1, init="siren", w0=5.0),
        domain_samples=2048,
        refine=RefineConfig(steps=refine_steps, batch_domain=refine_batch_domain),
    )


def parametrize_by_stage(points, domain, config, *, faces=None, normals=None, landmarks=(),
                         seed: int = 0, n_measure: int = 200_000, script: str = "example",
                         extra=None):
    """``pcgeom.parametrize`` with the map measured after every stage.

    Each stage's row holds its history record's name, kind and loss terms, the cumulative
    seconds, the Hausdorff distance of the map to the domain
    (:func:`pcgeom.metrics.domain_hausdorff` on ``n_measure`` samples; with ``faces`` also
    ``surface_hausdorff``, of the mapped triangles), the angle distortion
    and flips on the reference ``faces`` (when given) and, with landmarks, the landmark
    Hausdorff distance the history records; ``extra(U)`` may add more (a dict).

    Returns
    -------
    result : pcgeom.ParamResult
    rows : list of dict
    maps : list of (N, 2) arrays, one per stage
    """
    import pcgeom
    from pcgeom.metrics import angle_distortion, domain_hausdorff, surface_hausdorff
    from pcgeom.train import LOSS_TERMS

    clock = Clock()
    rows, maps = [], []

    def on_stage(record, U):
        row = {"stage": record.get("stage"), "kind": record.get("kind"), "seconds": clock()}
        row.update({k: float(record[k]) for k in LOSS_TERMS if k in record})
        if domain.bounded:
            row["hausdorff"] = domain_hausdorff(U, domain, n=n_measure)
            if faces is not None:
                row["surface_hausdorff"] = surface_hausdorff(U, faces, domain, n=n_measure)
        if faces is not None:
            angles = angle_distortion(points, faces, U)
            row.update(mean_abs_angle_rad=angles.mean_abs, flipped=angles.flipped,
                       flipped_percent=100.0 * angles.flipped / angles.n_faces,
                       per_corner=angles.per_corner)
        if record.get("landmark_hausdorff") is not None:
            row["landmark_hausdorff"] = [float(d) for d in record["landmark_hausdorff"]]
        if extra is not None:
            row.update(extra(U))
        rows.append(row)
        maps.append(np.asarray(U).copy())
        shown = {k: round(row[k], 4) for k in ("hausdorff", "surface_hausdorff",
                                                "mean_abs_angle_rad") if k in row}
        log(script, f"stage {row['stage']} ({row['kind']}) at {row['seconds']:.0f} s: {shown}")

    result = pcgeom.parametrize(points, domain, config=config, landmarks=landmarks,
                                normals=normals, seed=seed, progress=False, on_stage=on_stage)
    return result, rows, maps


def public_rows(rows: list[dict]) -> list[dict]:
    """``rows`` without their per-corner arrays (for the JSON)."""
    return [{k: v for k, v in r.items() if k != "per_corner"} for r in rows]


def decimate(V, F, n_vertices: int):
    """The mesh simplified to about ``n_vertices`` by quadric edge collapse (pymeshlab),
    topology kept; ``(V, F)`` unchanged when it already has no more vertices.

    The examples train the networks on a decimated face so that they run in minutes on two
    CPU cores; the faces are still used only to measure angles.
    """
    if len(V) <= n_vertices:
        return V, F
    try:
        import pymeshlab
    except ImportError:
        sys.exit("this example decimates the face with pymeshlab: pip install pymeshlab "
                 "(or pass --points 0 to use the full mesh)")
    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(np.ascontiguousarray(V, dtype=np.float64),
                               np.ascontiguousarray(F, dtype=np.int32)))
    # About two faces per vertex on a disk-like mesh.
    ms.meshing_decimation_quadric_edge_collapse(targetfacenum=2 * n_vertices,
                                                preservetopology=True, preserveboundary=True,
                                                boundaryweight=2.0, qualitythr=0.5,
                                                planarquadric=True)
    ms.meshing_remove_unreferenced_vertices()
    m = ms.current_mesh()
    return (np.asarray(m.vertex_matrix(), dtype=np.float64),
            np.asarray(m.face_matrix(), dtype=np.int64))
