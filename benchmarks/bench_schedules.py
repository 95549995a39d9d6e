"""Side by side in one run: the paper's schedule (a fraction of its epochs) against ``fast``.

The paper preset takes hours on a CPU, so its schedule is run with every epoch count
(E and E_min) multiplied by ``--epoch-fraction``; everything else is section 6 exactly.
Angle distortion and flips are measured after every stage on the reference mesh of the
surface, and the section between the markers below is replaced in BENCHMARKS.md.

    python benchmarks/bench_schedules.py                   # peaks3, 5% of the epochs
    python benchmarks/bench_schedules.py --epoch-fraction 0.02 --out /tmp/B.md
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
from pcgeom.train import parametrize, resolve_device  # noqa: E402
from sections import write_section  # noqa: E402

def run(name: str, config, V, F, device, seed: int) -> list[dict]:
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
                on_stage=on_stage)
    return rows


def table(rows: list[dict]) -> list[str]:
    out = ["| stage | epochs | batch | sigma | steps | cumulative s | mean abs angle, rad | flips |",
           "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        sigma = f"{r['sigma']:.3g}"
        out.append(f"| {r['stage']} | {r['epochs']} | {r['batch_points']} | {sigma} | {r['steps']} "
                   f"| {r['elapsed']:.0f} | {r['mean_abs_angle_rad']:.4f} | {r['flipped']} "
                   f"({r['flipped_percent']:.2f}%) |")
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--surface", default="peaks3", choices=EXAMPLES)
    parser.add_argument("--epoch-fraction", type=float, default=0.05,
                        help="multiply the paper's E and E_min by this (default 0.05)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=REPO / "BENCHMARKS.md")
    args = parser.parse_args(argv)
    if not 0 < args.epoch_fraction <= 1:
        parser.error(f"--epoch-fraction must be in (0, 1], got {args.epoch_fraction}")

    V, F = load_example(args.surface)
    device = resolve_device("auto")
    schedule = get_preset("paper").schedule
    scaled = get_preset("paper", schedule=dataclasses.replace(
        schedule,
        epochs=max(1, round(schedule.epochs * args.epoch_fraction)),
        epochs_min=max(1, round(schedule.epochs_min * args.epoch_fraction)),
    ))
    fast_rows = run("fast", get_preset("fast"), V, F, device, args.seed)
    paper_rows = run("paper", scaled, V, F, device, args.seed)

    lines = [
        "## The paper's schedule against `fast`, stage by stage",
        "",
        f"- date: {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC; "
        f"{os.cpu_count()} cores, torch {torch.__version__} ({torch.get_num_threads()} threads), "
        f"device {device}; one process, one after the other, seed {args.seed}",
        f"- command: `python benchmarks/bench_schedules.py "
        f"{' '.join(argv if argv is not None else sys.argv[1:])}".rstrip() + "`",
        f"- surface: {args.surface} ({len(V)} points, free boundary); angle distortion on its "
        f"{len(F)} reference triangles after each stage",
        f"- `paper`: section 6 exactly but every epoch count times {args.epoch_fraction} "
        f"(E = {scaled.schedule.epochs}, E_min = {scaled.schedule.epochs_min}); the full "
        "schedule is 1/fraction times longer",
        "",
        "`fast`:",
        "",
        *table(fast_rows),
        "",
        f"`paper` at {args.epoch_fraction:g} of its epochs:",
        "",
        *table(paper_rows),
        "",
        f"Time to the final map, same run: `fast` {fast_rows[-1]['elapsed']:.0f} s, "
        f"`paper` x {args.epoch_fraction:g} {paper_rows[-1]['elapsed']:.0f} s "
        f"(ratio {paper_rows[-1]['elapsed'] / fast_rows[-1]['elapsed']:.1f}).",
    ]
    section = "\n".join(lines)
    write_section(args.out, "bench_schedules", section)
    print(section)
    return 0


if __name__ == "__main__":
    sys.exit(main())
