"""Throughput of ``pcgeom batch``: the same scans on a local Dask cluster, split two ways.

Writes ``--scans`` noisy variants of three peaks (about ``--points`` points each, Gaussian
noise on every coordinate, one seed each, with the reference triangles so the rows carry the
angle distortion), then maps them with :func:`pcgeom.apps.batch.run_batch` once per layout
``WORKERSxTHREADS`` into a fresh directory, timed around the whole batch (cluster start and
stop included). Replaces the section ``bench_batch`` of BENCHMARKS.md, with a paper estimate
for 1,000 scans on 10 machines of 8 cores.

    python benchmarks/bench_batch.py --scans 2 --points 400 --epoch-fraction 0.05 --out /tmp/B.md
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import sys
import tempfile
from pathlib import Path

import harness as H
import numpy as np

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
    from pcgeom.examples import peaks_surface
    from pcgeom.io import write_ply_atomic

    V, F = peaks_surface("peaks3", n_side=max(4, round(math.sqrt(points))))
    spacing = 2.0 / (math.isqrt(len(V)) - 1)
    for k in range(n):
        rng = np.random.default_rng(k)
        write_ply_atomic(folder / f"peaks3_noisy{k:03d}.ply",
                         V + rng.normal(scale=noise * spacing, size=V.shape), F)
    return len(V)


def run_layout(scans: Path, out: Path, config, workers: int, threads: int) -> dict:
    from pcgeom.apps.batch import run_batch

    report, wall = H.timed(run_batch, [os.fspath(scans / "*.ply")], out, config=config,
                           workers=workers, threads_per_worker=threads, progress=True)
    if report.failed:
        raise SystemExit("bench_batch: scans failed: " + "; ".join(
            f"{r['name']}: {r['error']}" for r in report.rows if r["status"] == "error"))
    rows = report.rows
    return {"workers": workers, "threads": threads, "scans": len(rows), "wall": wall,
            "per_minute": 60.0 * len(rows) / wall,
            "train_median": H.median(rows, lambda r: float(r["seconds"])),
            "angle_median": H.median(rows, lambda r: float(r["angle_distortion_rad"])),
            "flipped_max": max(int(r["flipped"]) for r in rows)}


def estimate(results: list[dict], cores: int) -> str:
    """1,000 scans on 10 x 8 cores, from the layout with the best throughput per core."""
    best = max(results, key=lambda r: r["per_minute"] / (r["workers"] * r["threads"]))
    core_seconds = best["workers"] * best["threads"] * best["wall"] / best["scans"]
    slots = ESTIMATE_MACHINES * (ESTIMATE_CORES // best["threads"])  # scans at once
    waves, per_scan = math.ceil(ESTIMATE_SCANS / slots), best["train_median"]
    return (f"Estimate on paper for {ESTIMATE_SCANS:,} such scans on {ESTIMATE_MACHINES} "
            f"machines of {ESTIMATE_CORES} cores, from the best layout here per core "
            f"({best['workers']}x{best['threads']}: {core_seconds:.2g} core-seconds per scan, "
            f"start-up included): {ESTIMATE_SCANS} x {core_seconds:.2g} / "
            f"{ESTIMATE_MACHINES * ESTIMATE_CORES} = "
            f"{ESTIMATE_SCANS * core_seconds / (ESTIMATE_MACHINES * ESTIMATE_CORES) / 60:.2g} "
            f"min if the cores stay busy; in whole waves of {slots} scans at once, "
            f"{waves} x {per_scan:.1f} s (median training time per scan) = "
            f"{waves * per_scan / 60:.1f} min of training. It assumes a core of those machines "
            f"is as fast as one here ({cores} cores), the same layout per machine, and input "
            "files read from a shared file system at no cost.")


def main(argv=None) -> int:
    import torch

    from pcgeom.config import PRESETS

    p = H.parser(__doc__)
    p.add_argument("--scans", type=int, default=8, help="scans per layout (default 8)")
    p.add_argument("--points", type=int, default=5000,
                   help="about how many points per scan (default 5000)")
    p.add_argument("--noise", type=float, default=0.1,
                   help="noise, in grid spacings (default 0.1)")
    p.add_argument("--layouts", type=layout, nargs="+", default=[(1, 2), (2, 1)],
                   metavar="WxT", help="worker x thread layouts (default: 1x2 2x1)")
    p.add_argument("--preset", default="fast", choices=list(PRESETS))
    p.add_argument("--epoch-fraction", type=float, default=1.0,
                   help="multiply the preset's epochs and refinement steps by this, to check "
                        "the script quickly (default 1: the preset as it is)")
    args = p.parse_args(argv)
    if args.scans < 1 or args.points < 16 or not 0 < args.epoch_fraction <= 1:
        p.error("need --scans >= 1, --points >= 16 and --epoch-fraction in (0, 1]")
    config = H.scaled_preset(args.preset, args.epoch_fraction)
    load_start, results = H.loadavg(), []
    with tempfile.TemporaryDirectory(prefix="bench_batch_") as tmp:
        (scans := Path(tmp) / "scans").mkdir()
        n_points = write_scans(scans, args.scans, args.points, args.noise)
        for workers, threads in args.layouts:
            print(f"bench_batch: {workers} worker(s) x {threads} thread(s)", file=sys.stderr)
            results.append(run_layout(scans, Path(tmp) / f"out_{workers}x{threads}", config,
                                      workers, threads))
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    lines = [
        "## `pcgeom batch`: scans per minute on a local Dask cluster", "",
        *H.header(argv, f"{platform.processor() or platform.machine()}, {cores} cores",
                  f"torch {torch.__version__}", f"load average at start {load_start}, at end "
                  f"{H.loadavg()} (above the core count means other work competed)"),
        f"- {args.scans} scans of {n_points} points: three peaks with Gaussian noise of "
        f"{args.noise} grid spacings, one seed each; preset `{args.preset}`"
        + (f" with epochs and refinement steps times {args.epoch_fraction}"
           if args.epoch_fraction != 1.0 else "") + ", free boundary, seed 0",
        "- wall time around `run_batch`: cluster start and stop included; each layout maps "
        "every scan (fresh output directory)", "",
        *H.table([("workers x torch threads", "{workers} x {threads}"), ("wall s", "{wall:.0f}"),
                  ("scans per minute", "{per_minute:.2f}"),
                  ("training s per scan, median", "{train_median:.1f}"),
                  ("angle distortion, rad, median", "{angle_median:.4f}"),
                  ("flips, max", "{flipped_max}")], results)]
    if len(results) > 1:
        first, last = results[0], results[-1]
        lines += ["", f"Speed-up of {last['workers']}x{last['threads']} over "
                      f"{first['workers']}x{first['threads']}: "
                      f"{last['per_minute'] / first['per_minute']:.2f}."]
    section = "\n".join([*lines, "", estimate(results, cores)])
    H.write_section(args.out, "bench_batch", section)
    print(section)
    return 0


if __name__ == "__main__":
    sys.exit(main())
