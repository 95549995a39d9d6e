"""``pcgeom batch``: map many scans on a Dask cluster, one result per scan, resumable."""

from __future__ import annotations

import argparse
import json
import os
import sys
import warnings

from ..apps.batch import SUMMARY_COLUMNS, run_batch
from ..config import PRESETS, get_preset
from ..domains import DOMAINS, get_domain
from ..errors import InputError
from ..io import SUPPORTED_EXTENSIONS
from ._common import (EXIT_FAILURE, EXIT_OK, add_output_options, int_at_least, run_command,
                      seed, standalone_parser)

__all__ = ["configure", "run", "main"]

NAME = "batch"
INTERRUPTED_HINT = " (rerun the same command to continue: finished scans are skipped)"
HELP = "map many scans on a Dask cluster, resumable, one result per scan"
DESCRIPTION = ("Map many point clouds with the same domain, preset and seed, one Dask task per "
               "scan, on a local cluster or an existing Dask scheduler. A rerun skips every "
               "scan whose map is up to date.")
EPILOG = f"""\
examples:
  pcgeom batch 'scans/*.ply' --out maps --workers 2 --threads-per-worker 1 --boundary --json
      a local Dask cluster of two worker processes, one scan at a time each with one torch
      thread; also each scan's boundary loops NAME_loops.json; one JSON object on stdout

Without --workers the local cluster has one single-threaded worker process per core.

INPUT may also be @LIST, a text file with one path or pattern per line. On a running Dask
cluster add --scheduler tcp://HOST:8786: the client sends each worker paths and settings
only, so every worker needs pcgeom (same torch pin) and the same paths (docs/batch.md).

Each scan NAME (the input's file stem) gets DIR/NAME_uv.npz (pcgeom.ParamResult.load), the
optional NAME_loops.json and NAME_mesh.ply, and a row in DIR/summary.csv:
{', '.join(SUMMARY_COLUMNS)}.
A scan is skipped when its map exists and was made from the same points, preset, domain and
seed. A scan that fails gets its one-line error in its row and the others go on; the exit
status is then 1. Each scan's warnings are printed as one line each, 'pcgeom: warning: NAME:
...' (not with --quiet). An unreachable --scheduler is refused (exit 2) before DIR is made.
A scan whose worker dies is retried on another worker; a map trained in
stages resumes from its last stage checkpoint, kept in DIR/.checkpoints/.
"""


def configure(p: argparse.ArgumentParser) -> None:
    """Add ``batch``'s arguments to ``p``."""
    p.add_argument("inputs", nargs="+", metavar="INPUT",
                   help=f"point cloud files ({' '.join(SUPPORTED_EXTENSIONS)}), glob patterns "
                        "(quote them), or @LIST: a text file with one path or pattern per line")
    add_output_options(p, "DIR", "output directory (created if missing)", required=True)
    p.add_argument("--domain", default="free", metavar="SPEC",
                   help=f"parameter domain: {', '.join(n for n in DOMAINS if n != 'polygon')}, "
                        "NAME:VALUES, PATH.json or PATH.png, as in 'pcgeom param' (default: free "
                        "boundary)")
    p.add_argument("--preset", default="fast", metavar="NAME",
                   help=f"training preset: {', '.join(PRESETS)} (default: fast)")
    p.add_argument("--seed", type=seed, default=0, help="random seed (default: 0)")
    p.add_argument("--boundary", action="store_true",
                   help="also write the boundary loops NAME_loops.json (free boundary only)")
    p.add_argument("--reconstruct", action="store_true",
                   help="also write a remeshed surface NAME_mesh.ply (free boundary only; "
                        "needs gmsh on every worker)")
    p.add_argument("--target-vertices", type=int_at_least(3), metavar="N",
                   help="about how many vertices each mesh gets (with --reconstruct; "
                        "default: 5000)")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="address of a running Dask scheduler, e.g. tcp://head:8786 (default: "
                        "start a local cluster)")
    p.add_argument("--workers", type=int_at_least(1), metavar="N",
                   help="worker processes of the local cluster (default: cores // T)")
    p.add_argument("--threads-per-worker", type=int_at_least(1), default=1, metavar="T",
                   help="torch threads of each scan's task (default: 1)")
    p.add_argument("--retries", type=int_at_least(0), default=2, metavar="R",
                   help="retries of a scan after an error that is not bad input, or after "
                        "its worker died (default: 2)")
    p.set_defaults(run=run)


def run(args) -> int:
    """Run ``pcgeom batch`` on parsed arguments; returns the exit status."""
    # Every check on the request happens in run_batch before any cluster starts.
    if args.target_vertices is not None and not args.reconstruct:
        raise InputError("--target-vertices needs --reconstruct")
    if args.workers is not None and args.scheduler is not None:
        raise InputError("--workers applies to the local cluster; the cluster at --scheduler "
                         "has its own workers")
    if args.quiet:  # the scans' warnings ("NAME: ...", one line each) too
        warnings.simplefilter("ignore", UserWarning)
    report = run_batch(args.inputs, args.out, domain=get_domain(args.domain),
                       config=get_preset(args.preset), seed=args.seed, boundary=args.boundary,
                       reconstruct=args.reconstruct,
                       target_vertices=args.target_vertices or 5000, scheduler=args.scheduler,
                       workers=args.workers, threads_per_worker=args.threads_per_worker,
                       retries=args.retries, progress=not args.quiet)
    status = EXIT_FAILURE if report.failed else EXIT_OK
    if args.json:
        print(json.dumps({
            "command": "batch",
            "out": os.fspath(args.out),
            "summary": os.fspath(report.summary),
            "dashboard": report.dashboard,
            "preset": args.preset,
            "domain": args.domain,
            "seed": args.seed,
            "n_scans": len(report.rows),
            **{f"n_{k}": v for k, v in report.counts.items()},
            "scans": report.rows,
        }))
        return status
    counts = report.counts
    print(f"{len(report.rows)} scan(s): {counts['ok']} mapped, {counts['skipped']} up to date, "
          f"{counts['error']} failed -> {os.fspath(report.summary)}")
    for row in report.rows:
        if row["status"] == "error":
            print(f"  {row['name']}: {row['error']}")
    return status


def main(argv: list[str] | None = None) -> int:
    """``pcgeom batch`` on its own: ``main(["scans/*.ply", "--out", "maps"])``."""
    return run_command(standalone_parser(sys.modules[__name__]), argv)
