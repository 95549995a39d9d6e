"""Render the runs of ``gpu_runs.sh`` (a CUDA machine) as the "gpu" section of BENCHMARKS.md.

Usage: python benchmarks/gpu_section.py GPU_RUNS.jsonl ENV.txt [--out BENCHMARKS.md]

Each line of GPU_RUNS.jsonl is a ``pcgeom param --json`` summary with ``label`` and
``wall_s`` (the whole CLI process, timed from outside) added.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections import defaultdict
from pathlib import Path

import harness as H


def row(group: list[dict]) -> dict:
    """Medians over the seeds of one surface and domain."""
    ev = [r["evaluation"] for r in group if r.get("evaluation")]
    fits = [r["domain_hausdorff"] for r in group if r.get("domain_hausdorff") is not None]
    flips = H.median(ev, "flipped") if ev else None
    return {"input": Path(group[0]["input"]).name, "domain": group[0]["domain"],
            "seeds": ", ".join(str(r["seed"]) for r in group), "points": group[0]["n_points"],
            "angle": f"{H.median(ev, 'mean_abs_angle_rad'):.4f}" if ev else "–",
            "flips": f"{flips:.0f} ({100 * flips / ev[0]['n_faces']:.2f}%)" if ev else "–",
            "hd": f"{H.median(fits, lambda h: h):.3f}" if fits else "–",
            "training": H.median(group, "seconds"), "wall": H.median(group, "wall_s")}


def render(runs: list[dict], env: str) -> str:
    groups: dict[str, list[dict]] = defaultdict(list)
    for run in runs:  # one group per surface and domain: the label without its seed suffix
        groups[run["label"].rsplit("_s", 1)[0]].append(run)
    env_lines = env.strip().splitlines()
    return "\n".join([
        "## `pcgeom param` on a GPU", "",
        f"- machine: {env_lines[0]}; {env_lines[-1]}",
        "- command: `bash benchmarks/gpu_runs.sh DATA OUT` then "
        "`python benchmarks/gpu_section.py OUT/gpu_runs.jsonl OUT/env.txt`",
        "- wall: the whole `pcgeom param --device cuda --quiet --json` process, timed from "
        "outside (start-up, CUDA initialisation, reading, training, evaluation, writing); "
        "training: the `seconds` the CLI reports. Medians over the seeds run.",
        "- angles and flips on the reference triangles (never used for training); domain "
        "Hausdorff: `pcgeom.metrics.domain_hausdorff` (exact outside the domain, 200 000 "
        "samples inside: resolution 0.004 on the unit disk). For comparison, libigl's harmonic "
        "disk map on the true meshes: 0.180 rad on peaks3, 0.115 rad on face_human_choi, "
        "no flips.", "",
        *H.table([("input", "{input}"), ("domain", "{domain}"), ("seeds", "{seeds}"),
                  ("points", "{points}"), ("mean abs angle, rad", "{angle}"),
                  ("flips", "{flips}"), ("domain Hausdorff", "{hd}"),
                  ("training s", "{training:.1f}"), ("wall s", "{wall:.1f}")],
                 [row(group) for group in groups.values()])])


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="gpu_section.py", description=__doc__.splitlines()[0])
    p.add_argument("runs", type=Path, help="gpu_runs.jsonl written by gpu_runs.sh")
    p.add_argument("env", type=Path, help="env.txt written by gpu_runs.sh")
    p.add_argument("--out", type=Path, default=H.BENCHMARKS_MD)
    args = p.parse_args(argv)
    runs = [json.loads(line) for line in args.runs.read_text().splitlines() if line.strip()]
    failed = [r["label"] for r in runs if "rc" in r]
    if failed:
        print(f"gpu_section.py: runs failed: {', '.join(failed)}", file=sys.stderr)
        return 1
    section = render(runs, args.env.read_text())
    H.write_section(args.out, "gpu", section)
    print(section)
    return 0


if __name__ == "__main__":
    sys.exit(main())
