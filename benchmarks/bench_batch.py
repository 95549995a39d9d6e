"""Throughput of ``pcgeom batch``: the same scans on a local Dask cluster, split two ways.

Writes ``--scans`` noisy variants of the three-peaks surface (about ``--points`` points each,
Gaussian noise on every coordinate, each its own seed, with the reference triangles so the
rows carry the angle distortion), then maps them with :func:`pcgeom.apps.batch.run_batch`
once per layout ``WORKERSxTHREADS`` (default ``1x2`` and ``2x1``: one worker with two torch
threads, two workers with one), each into a fresh output directory. The wall time is taken
around the whole batch, cluster start and stop included, and gives scans per minute. The
section between ``<!-- bench_batch: begin -->`` and ``<!-- bench_batch: end -->`` of
BENCHMARKS.md is replaced, with a paper estimate for 1,000 scans on 10 machines of 8 cores.

    python benchmarks/bench_batch.py                       # 8 scans of ~5k points, fast
    python benchmarks/bench_batch.py --scans 2 --points 400 --epoch-fraction 0.05 \\
        --out /tmp/BENCHMARKS.md                           # seconds: checks the script only
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime
import math
import os
import platform
import statistics
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
# This checkout's pcgeom, here and in the worker processes (they inherit the environment).
sys.path.insert(0, str(REPO))
os.environ["PYTHONPATH"] = os.pathsep.join(
    [str(REPO)] + ([os.environ["PYTHONPATH"]] if os.environ.get("PYTHONPATH") else []))

import numpy as np  # noqa: E402
import torch  # noqa: E402

from pcgeom.apps.batch import run_batch  # noqa: E402
from pcgeom.config import PRESETS, get_preset  # noqa: E402
from pcgeom.examples import peaks_surface  # noqa: E402
from pcgeom.io import write_ply_atomic  # noqa: E402
from sections import write_section  # noqa: E402

ESTIMATE_SCANS, ESTIMATE_MACHINES, ESTIMATE_CORES = 1000, 10, 8
"""The issue's question: 1,000 scans on 10 machines of 8 cores."""


def layout(text: str) -> tuple[int, int]:
    """argparse type of a layout ``WORKERSxTHREADS``, e.g. ``2x1``."""
    try:
        workers, threads = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected WORKERSxTHREADS such as 2x1, got {text!r}")
    if workers < 1 or threads < 1:
        raise argparse.ArgumentTypeError(f"expected positive counts, got {text!r}")
    return workers, threads


def write_scans(folder: Path, n: int, points: int, noise: float) -> int:
    """``n`` noisy three-peaks clouds (with faces) in ``folder``; returns points per scan."""
    V, F = peaks_surface("peaks3", n_side=max(4, round(math.sqrt(points))))
    spacing = 2.0 / (math.isqrt(len(V)) - 1)
    for k in range(n):
        rng = np.random.default_rng(k)
        write_ply_atomic(folder / f"peaks3_noisy{k:03d}.ply",
                         V + rng.normal(scale=noise * spacing, size=V.shape), F)
    return len(V)


def scaled_preset(name: str, fraction: float):
    """The preset with its epochs (E, E_min) and refinement steps times ``fraction``."""
    config = get_preset(name)
    if fraction == 1.0:
        return config
    schedule = config.schedule
    return get_preset(name, schedule=dataclasses.replace(
        schedule, epochs=max(1, round(schedule.epochs * fraction)),
        epochs_min=max(1, round(schedule.epochs_min * fraction))),
        refine=dataclasses.replace(config.refine,
                                   steps=max(0, round(config.refine.steps * fraction))))


def run_layout(scans: Path, out: Path, config, workers: int, threads: int) -> dict:
    t0 = time.perf_counter()
    report = run_batch([os.fspath(scans / "*.ply")], out, config=config, workers=workers,
                       threads_per_worker=threads, progress=True)
    wall = time.perf_counter() - t0
    if report.failed:
        errors = [f"{r['name']}: {r['error']}" for r in report.rows if r["status"] == "error"]
        raise SystemExit("bench_batch: scans failed: " + "; ".join(errors))
    n = len(report.rows)
    return {
        "workers": workers, "threads": threads, "scans": n, "wall": wall,
        "per_minute": 60.0 * n / wall,
        "train_median": statistics.median(float(r["seconds"]) for r in report.rows),
        "angle_median": statistics.median(float(r["angle_distortion_rad"])
                                          for r in report.rows),
        "flipped_max": max(int(r["flipped"]) for r in report.rows),
    }


def estimate_lines(results: list[dict], cores: int) -> list[str]:
    """1,000 scans on 10 x 8 cores, from the layout with the best throughput per core."""
    best = max(results, key=lambda r: r["per_minute"] / (r["workers"] * r["threads"]))
    used = best["workers"] * best["threads"]
    core_seconds = used * best["wall"] / best["scans"]  # cluster start-up included
    slots = ESTIMATE_MACHINES * (ESTIMATE_CORES // best["threads"])  # scans at once
    per_scan = best["train_median"]
    waves = math.ceil(ESTIMATE_SCANS / slots)
    return [
        f"Estimate on paper for {ESTIMATE_SCANS:,} such scans on {ESTIMATE_MACHINES} machines "
        f"of {ESTIMATE_CORES} cores, from the best layout here per core "
        f"({best['workers']}x{best['threads']}: {core_seconds:.2g} core-seconds per scan, "
        f"start-up included): {ESTIMATE_SCANS} x {core_seconds:.2g} / "
        f"{ESTIMATE_MACHINES * ESTIMATE_CORES} = "
        f"{ESTIMATE_SCANS * core_seconds / (ESTIMATE_MACHINES * ESTIMATE_CORES) / 60:.2g} min "
        f"if the cores stay busy; in whole waves of {slots} scans at once, "
        f"{waves} x {per_scan:.1f} s (median training time per scan) = "
        f"{waves * per_scan / 60:.1f} min of training. It assumes a core of those machines is "
        f"as fast as one here ({cores} cores), the same layout per machine, and input files "
        "read from a shared file system at no cost.",
    ]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--scans", type=int, default=8, help="scans per layout (default 8)")
    parser.add_argument("--points", type=int, default=5000,
                        help="about how many points per scan (default 5000)")
    parser.add_argument("--noise", type=float, default=0.1,
                        help="noise, in grid spacings (default 0.1)")
    parser.add_argument("--layouts", type=layout, nargs="+", default=[(1, 2), (2, 1)],
                        metavar="WxT", help="worker x thread layouts (default: 1x2 2x1)")
    parser.add_argument("--preset", default="fast", choices=list(PRESETS))
    parser.add_argument("--epoch-fraction", type=float, default=1.0,
                        help="multiply the preset's epochs and refinement steps by this, to "
                             "check the script quickly (default 1: the preset as it is)")
    parser.add_argument("--out", type=Path, default=REPO / "BENCHMARKS.md")
    args = parser.parse_args(argv)
    if args.scans < 1 or args.points < 16 or not 0 < args.epoch_fraction <= 1:
        parser.error("need --scans >= 1, --points >= 16 and --epoch-fraction in (0, 1]")

    config = scaled_preset(args.preset, args.epoch_fraction)
    load_start = [round(x, 2) for x in os.getloadavg()]
    results = []
    with tempfile.TemporaryDirectory(prefix="bench_batch_") as tmp:
        scans = Path(tmp) / "scans"
        scans.mkdir()
        n_points = write_scans(scans, args.scans, args.points, args.noise)
        for workers, threads in args.layouts:
            print(f"bench_batch: {workers} worker(s) x {threads} thread(s)", file=sys.stderr)
            results.append(run_layout(scans, Path(tmp) / f"out_{workers}x{threads}", config,
                                      workers, threads))
    load_end = [round(x, 2) for x in os.getloadavg()]

    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    command = " ".join(argv if argv is not None else sys.argv[1:])
    lines = [
        "## `pcgeom batch`: scans per minute on a local Dask cluster",
        "",
        f"- date: {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC; "
        f"{platform.processor() or platform.machine()}, {cores} cores; torch "
        f"{torch.__version__}; load average at start {load_start}, at end {load_end} "
        "(above the core count means other work competed)",
        f"- command: `{' '.join(['python benchmarks/bench_batch.py', command]).strip()}`",
        f"- {args.scans} scans of {n_points} points: three peaks with Gaussian noise of "
        f"{args.noise} grid spacings, one seed each; preset `{args.preset}`"
        + (f" with epochs and refinement steps times {args.epoch_fraction}"
           if args.epoch_fraction != 1.0 else "") + ", free boundary, seed 0",
        "- wall time around `run_batch`: cluster start and stop included; each layout maps "
        "every scan (fresh output directory)",
        "",
        "| workers x torch threads | wall s | scans per minute | training s per scan, "
        "median | angle distortion, rad, median | flips, max |",
        "|---|---|---|---|---|---|",
    ]
    for r in results:
        lines.append(f"| {r['workers']} x {r['threads']} | {r['wall']:.0f} | "
                     f"{r['per_minute']:.2f} | {r['train_median']:.1f} | "
                     f"{r['angle_median']:.4f} | {r['flipped_max']} |")
    if len(results) > 1:
        first, last = results[0], results[-1]
        lines += ["", f"Speed-up of {last['workers']}x{last['threads']} over "
                      f"{first['workers']}x{first['threads']}: "
                      f"{last['per_minute'] / first['per_minute']:.2f}."]
    lines += ["", *estimate_lines(results, cores)]
    section = "\n".join(lines)
    write_section(args.out, "bench_batch", section)
    print(section)
    return 0


if __name__ == "__main__":
    sys.exit(main())
