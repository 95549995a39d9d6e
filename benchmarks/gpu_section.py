"""Render the runs of ``gpu_runs.sh`` (a CUDA machine) as the "gpu" section of BENCHMARKS.md.

Usage: python benchmarks/gpu_section.py GPU_RUNS.jsonl ENV.txt [--out BENCHMARKS.md]

Each line of GPU_RUNS.jsonl is a ``pcgeom param --json`` summary with ``label`` and
``wall_s`` (the whole CLI process, timed from outside) added.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
from collections import defaultdict
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))  # this checkout's pcgeom, installed or not

from sections import write_section  # noqa: E402


def _group(label: str) -> str:
    """Runs of one surface and domain share a group: the label without its seed suffix."""
    return label.rsplit("_s", 1)[0]


def render(runs: list[dict], env: str) -> str:
    groups: dict[str, list[dict]] = defaultdict(list)
    for run in runs:
        groups[_group(run["label"])].append(run)
    lines = [
        "## `pcgeom param` on a GPU",
        "",
        f"- machine: {env.strip().splitlines()[0]}; {env.strip().splitlines()[-1]}",
        "- command: `bash benchmarks/gpu_runs.sh DATA OUT` then "
        "`python benchmarks/gpu_section.py OUT/gpu_runs.jsonl OUT/env.txt`",
        "- wall: the whole `pcgeom param --device cuda --quiet --json` process, timed from "
        "outside (start-up, CUDA initialisation, reading, training, evaluation, writing); "
        "training: the `seconds` the CLI reports. Medians over the seeds run.",
        "- angles and flips on the reference triangles (never used for training); domain "
        "Hausdorff: `pcgeom.metrics.domain_hausdorff` (exact outside the domain, 200 000 "
        "samples inside: resolution 0.004 on the unit disk). For comparison, libigl's harmonic "
        "disk map on the true meshes: 0.180 rad on peaks3, 0.115 rad on face_human_choi, "
        "no flips.",
        "",
        "| input | domain | seeds | points | mean abs angle, rad | flips | domain Hausdorff "
        "| training s | wall s |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for group in groups.values():
        first = group[0]
        ev = [r["evaluation"] for r in group if r.get("evaluation")]
        angle = flips = hd = "–"
        if ev:
            angle = f"{statistics.median(e['mean_abs_angle_rad'] for e in ev):.4f}"
            n_flips = statistics.median(e["flipped"] for e in ev)
            flips = f"{n_flips:.0f} ({100 * n_flips / ev[0]['n_faces']:.2f}%)"
        fits = [r["domain_hausdorff"] for r in group if r.get("domain_hausdorff") is not None]
        if fits:
            hd = f"{statistics.median(fits):.3f}"
        seeds = ", ".join(str(r["seed"]) for r in group)
        training = statistics.median(r["seconds"] for r in group)
        wall = statistics.median(r["wall_s"] for r in group)
        lines.append(f"| {Path(first['input']).name} | {first['domain']} | {seeds} | "
                     f"{first['n_points']} | {angle} | {flips} | {hd} | {training:.1f} | "
                     f"{wall:.1f} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="gpu_section.py", description=__doc__.splitlines()[0])
    p.add_argument("runs", type=Path, help="gpu_runs.jsonl written by gpu_runs.sh")
    p.add_argument("env", type=Path, help="env.txt written by gpu_runs.sh")
    p.add_argument("--out", type=Path, default=REPO / "BENCHMARKS.md")
    args = p.parse_args(argv)
    runs = [json.loads(line) for line in args.runs.read_text().splitlines() if line.strip()]
    failed = [r["label"] for r in runs if "rc" in r]
    if failed:
        print(f"gpu_section.py: runs failed: {', '.join(failed)}", file=sys.stderr)
        return 1
    section = render(runs, args.env.read_text())
    write_section(args.out, "gpu", section)
    print(section)
    return 0


if __name__ == "__main__":
    sys.exit(main())
