"""Side by side in one run: ``fast``, ``networks`` (the ``fast`` of 0.1.0) and the paper.

The paper preset takes hours on a CPU, so its schedule is run with every epoch count
(E and E_min) multiplied by ``--epoch-fraction``; everything else is section 6 exactly.
Angle distortion and flips are measured after every stage on the reference mesh of the
surface, and the section between the markers below is replaced in BENCHMARKS.md. A shared
surface (``--surface face_human_choi``, from ``../shared/data/``) is mapped with the normals
its file carries, as ``pcgeom param`` does by default.

    python benchmarks/bench_schedules.py                   # peaks3, 5% of the epochs
    python benchmarks/bench_schedules.py --epoch-fraction 0.02 --out /tmp/B.md
    python benchmarks/bench_schedules.py --surface face_human_choi --presets fast networks
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime
import os
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

import torch  # noqa: E402

from pcgeom.apps.evaluate import map_report  # noqa: E402
from pcgeom.config import get_preset  # noqa: E402
from pcgeom.examples import EXAMPLES, load_example  # noqa: E402
from pcgeom.io import read_points  # noqa: E402
from pcgeom.maps import parametrize  # noqa: E402
from pcgeom.train import resolve_device  # noqa: E402
from sections import write_section  # noqa: E402

DATA_DIR = REPO.parent / "shared" / "data"


def load_surface(name: str):
    """Points, reference faces and normals (None for a built-in example) of ``name``."""
    if name in EXAMPLES:
        V, F = load_example(name)
        return V, F, None
    cloud = read_points(DATA_DIR / f"{name}.ply")
    return cloud.points, cloud.faces, cloud.normals


def run(name: str, config, V, F, device, seed: int, normals=None) -> list[dict]:
    """Per-stage rows: the stage's history record, cumulative seconds, and map_report."""
    rows: list[dict] = []
    t0 = time.perf_counter()

    def on_stage(record: dict, uv) -> None:
        elapsed = time.perf_counter() - t0
        report = map_report(uv, V=V, F=F)
        rows.append({**record, **report, "elapsed": elapsed})
        print(f"{name} stage {record['stage']}: {elapsed:.0f} s, "
              f"{report['mean_abs_angle_rad']:.4f} rad, {report['flipped']} flips",
              file=sys.stderr, flush=True)

    parametrize(V, "free", config=config, device=device, seed=seed, progress=False,
                on_stage=on_stage, normals=normals)
    return rows


def table(rows: list[dict]) -> list[str]:
    out = ["| stage | epochs | batch | sigma | steps | cumulative s | mean abs angle, rad | flips |",
           "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        # The local-mesh map is one solve: no epochs, batch, sigma or steps.
        sigma = f"{r['sigma']:.3g}" if "sigma" in r else "–"
        out.append(f"| {r['stage']} | {r.get('epochs', '–')} | {r.get('batch_points', '–')} "
                   f"| {sigma} | {r.get('steps', '–')} "
                   f"| {r['elapsed']:.0f} | {r['mean_abs_angle_rad']:.4f} | {r['flipped']} "
                   f"({r['flipped_percent']:.2f}%) |")
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--surface", default="peaks3",
                        help=f"a built-in example ({', '.join(EXAMPLES)}) or the stem of a PLY "
                             "in ../shared/data (default: peaks3)")
    parser.add_argument("--presets", nargs="+", default=["fast", "networks", "paper"],
                        choices=["fast", "networks", "paper"])
    parser.add_argument("--epoch-fraction", type=float, default=0.05,
                        help="multiply the paper's E and E_min by this (default 0.05)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=REPO / "BENCHMARKS.md")
    args = parser.parse_args(argv)
    if not 0 < args.epoch_fraction <= 1:
        parser.error(f"--epoch-fraction must be in (0, 1], got {args.epoch_fraction}")

    if args.surface not in EXAMPLES and not (DATA_DIR / f"{args.surface}.ply").exists():
        parser.error(f"--surface: {args.surface!r} is neither a built-in example nor a PLY in "
                     f"{DATA_DIR}")
    V, F, normals = load_surface(args.surface)
    device = resolve_device("auto")
    schedule = get_preset("paper").schedule
    scaled = get_preset("paper", schedule=dataclasses.replace(
        schedule,
        epochs=max(1, round(schedule.epochs * args.epoch_fraction)),
        epochs_min=max(1, round(schedule.epochs_min * args.epoch_fraction)),
    ))
    configs = {"fast": get_preset("fast"), "networks": get_preset("networks"), "paper": scaled}
    runs = {name: run(name, configs[name], V, F, device, args.seed, normals)
            for name in args.presets}
    titles = {"fast": "`fast` (the local-mesh map):",
              "networks": "`networks` (the `fast` of 0.1.0: two network stages, then the "
                          "refinement):",
              "paper": f"`paper` at {args.epoch_fraction:g} of its epochs:"}
    body = []
    for name, rows in runs.items():
        body += [titles[name], "", *table(rows), ""]
    finals = ", ".join(f"`{name}` {rows[-1]['elapsed']:.0f} s" for name, rows in runs.items())
    ratio = ""
    if "fast" in runs and "paper" in runs:
        ratio = (f" (paper / fast: "
                 f"{runs['paper'][-1]['elapsed'] / runs['fast'][-1]['elapsed']:.1f})")

    lines = [
        "## The paper's schedule against `fast` and `networks`, stage by stage",
        "",
        f"- date: {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC; "
        f"{os.cpu_count()} cores, torch {torch.__version__} ({torch.get_num_threads()} threads), "
        f"device {device}; one process, one after the other, seed {args.seed}",
        f"- command: `python benchmarks/bench_schedules.py "
        f"{' '.join(argv if argv is not None else sys.argv[1:])}".rstrip() + "`",
        f"- surface: {args.surface} ({len(V)} points, free boundary, "
        f"{'the file' + chr(39) + 's normals' if normals is not None else 'no normals'}); "
        f"angle distortion on its {len(F)} reference triangles after each stage",
        f"- `paper`: section 6 exactly but every epoch count times {args.epoch_fraction} "
        f"(E = {scaled.schedule.epochs}, E_min = {scaled.schedule.epochs_min}); the full "
        "schedule is 1/fraction times longer",
        "",
        *body,
        f"Time to the final map, same run: {finals}{ratio}.",
    ]
    section = "\n".join(lines)
    write_section(args.out, "bench_schedules", section)
    print(section)
    return 0


if __name__ == "__main__":
    sys.exit(main())
