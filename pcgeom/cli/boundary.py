"""``pcgeom boundary``: the boundary loops of a point cloud, from its free-boundary map."""

from __future__ import annotations

import argparse
import json
import os
import sys

import numpy as np

from ..apps.boundary import DEFAULT_MIN_LOOP, DEFAULT_MIN_WIDTH, detect_boundary
from ..config import get_preset
from ..errors import InputError
from ..io import check_writable, read_points
from ..io.atomic import write_atomic
from ..maps import parametrize
from .param import NORMALS_CHOICES, _map_record, _normals_used
from ._common import (EXIT_OK, add_cloud_and_map, add_output_options, distinct_paths,
                      load_free_map, run_command, standalone_parser)

__all__ = ["configure", "run", "main"]

NAME = "boundary"
HELP = "boundary loops of a point cloud (outer rim and holes)"
DESCRIPTION = ("Detect the boundary loops of a point cloud (its outer rim and its holes) on its "
               "free-boundary map: Delaunay triangulation of the map, triangles that span gaps "
               "removed, boundary edges ordered into loops.")
EPILOG = f"""\
examples:
  pcgeom boundary scan.ply --out scan_loops.json
      maps the cloud first (free boundary, preset fast), then detects its loops
  pcgeom boundary scan.ply --map scan_uv.npz --out scan_loops.json --plot scan_loops.png
      reuses a map written by 'pcgeom param scan.ply' (no --domain): the same loops as
      without --map, since both map the cloud the same way (its normals included)
  pcgeom boundary scan.ply --map scan_uv.npz --h 0.02 --out loops.json --quiet --json
      the paper's rule: remove every triangle with an edge longer than 0.02 (map units; pick
      2-3 times the map's point spacing, docs/choosing_parameters.md)
  pcgeom boundary scan.ply --map scan_uv.npz --min-width 1 --out loops.json
      also drop holes narrower on the surface than one point spacing (sampling gaps of an
      unevenly sampled scan; a true hole only ~3 spacings across goes too)
  pcgeom boundary scan.ply --map scan_uv.npz --every-loop --out loops.json
      every loop of the map's rule, none judged or set apart as a sampling gap (the default
      judges each: face_human_choi bare 22 loops -> 1, peaks_7holes_choi 3 -> its 8)

LOOPS.json holds {{"loops": [[i0, i1, ...], ...], "h": ..., ...}}: each loop as rows of INPUT
(from 0), outer loop first (counter-clockwise in the map), then the holes by size. Without
--h, triangles are judged against the local point spacing of the map, which needs no scale
(see pcgeom.apps.boundary). Without --map the cloud is mapped as 'pcgeom param INPUT' maps it
(preset fast, seed 0, the file's normals unless --normals ignore).
Loops of fewer than {DEFAULT_MIN_LOOP} points are dropped as sampling gaps. Each loop is judged
by its evidence in 3D (its own largest empty circle against the widest the sampling leaves
around it, its roundness, its rim's normals; pcgeom.apps.loop_kinds) and gets a kind (outer,
hole) and a confidence in [0, 1]; loops the evidence calls gaps of the sampling are spanned by
the surface and listed apart ("gaps", "gap_evidence"); --every-loop keeps every loop of the
map's rule instead (as --h does).
Each hole's width on the surface (its 3D inradius estimate over the local point spacing) is
reported; --min-width drops the narrower ones. Faces in INPUT never make loops (they shape the
map only, as in 'pcgeom param').
"""


def _positive_float(text: str) -> float:
    """argparse type of ``--h``: a finite number > 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive number, got {text!r}") from None
    if not np.isfinite(value) or value <= 0:
        raise argparse.ArgumentTypeError(f"expected a positive number, got {text!r}")
    return value


def _non_negative_float(text: str) -> float:
    """argparse type of ``--min-width``: a finite number >= 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a non-negative number, got {text!r}") from None
    if not np.isfinite(value) or value < 0:
        raise argparse.ArgumentTypeError(f"expected a non-negative number, got {text!r}")
    return value


def add_hole_options(p: argparse.ArgumentParser) -> None:
    """``--min-width`` and ``--cloud-spacing``, shared with ``pcgeom reconstruct``."""
    p.add_argument("--min-width", type=_non_negative_float, default=DEFAULT_MIN_WIDTH,
                   metavar="W",
                   help="drop holes narrower on the surface than W local point spacings "
                        f"(default: {DEFAULT_MIN_WIDTH:g}, keep every hole)")
    p.add_argument("--cloud-spacing", action="store_true",
                   help="also open holes that the map shrank, judging each triangle in 3D "
                        "against the cloud's own point spacing (for evenly sampled clouds; "
                        "see pcgeom.apps.boundary); the judged loops of the default always "
                        "cast their candidates so, this applies with --h or --every-loop")


def add_normals_option(p: argparse.ArgumentParser) -> None:
    """``--normals auto|ignore`` of the commands that map the cloud themselves without
    ``--map`` (shared with ``pcgeom reconstruct``)."""
    p.add_argument("--normals", choices=NORMALS_CHOICES, default="auto",
                   help="without --map: auto: map with the file's oriented normals (PLY nx ny "
                        "nz, NPZ 'normals', six-column XYZ, LAS) when it has them, as 'pcgeom "
                        "param' does; ignore: do not read them (default: auto)")


def read_cloud(args):
    """INPUT as ``pcgeom param`` reads it to map it (its normals unless ``--normals
    ignore``), or without normals when ``--map`` gives the map; ``--normals`` with ``--map``
    is refused."""
    if args.map is not None and args.normals != "auto":
        raise InputError("--normals applies only without --map (when the cloud is mapped "
                         "here); a map's normals were chosen by 'pcgeom param --normals'")
    # validated: finite, >= 10 distinct, a surface
    return read_points(args.input, normals=args.map is None and args.normals == "auto")


def configure(p: argparse.ArgumentParser) -> None:
    """Add ``boundary``'s arguments to ``p``."""
    add_cloud_and_map(p)
    p.add_argument("--h", type=_positive_float, metavar="H",
                   help="remove every triangle with an edge longer than H in the map (the "
                        "paper's rule; default: a rule from the local point spacing)")
    add_hole_options(p)
    p.add_argument("--every-loop", action="store_true",
                   help="keep every loop of the map's rule as it comes (no evidence, no kinds, "
                        "sampling gaps not set apart)")
    add_normals_option(p)
    add_output_options(p, "LOOPS.json", "the loops, as JSON", required=True)
    p.add_argument("--plot", metavar="LOOPS.png",
                   help="also draw the map with the loops and the removed triangles")
    p.set_defaults(run=run)


def run(args) -> int:
    """Run ``pcgeom boundary`` on parsed arguments; returns the exit status."""
    # Everything that can be wrong with the request is checked before any training.
    cloud = read_cloud(args)
    points = cloud.points
    out = check_writable(args.out, "json")
    plot = check_writable(args.plot, "png") if args.plot else None
    distinct_paths({"INPUT": args.input, "--map": args.map}, {"out": out, "plot": plot})
    if args.map is not None:
        result = load_free_map(args, points, "boundary detection")
    else:
        # As 'pcgeom param INPUT' maps it, so that --map of that map gives the same loops.
        result = parametrize(cloud, "free", config=get_preset("fast"), seed=0,
                             progress=not args.quiet)

    # A denoised map was made of the fitted points: the holes' widths are measured on them.
    surface = result.fitted if result.fitted is not None else points
    found = detect_boundary(result.uv, h=args.h, points=surface, min_width=args.min_width,
                            cloud_spacing=args.cloud_spacing, kinds=not args.every_loop)
    document = {**found.to_dict(), "input": args.input, "n_points": len(points)}
    write_atomic(out, lambda f: f.write(json.dumps(document).encode("utf-8")))
    if plot is not None:
        from ..apps.plot import plot_boundary

        plot_boundary(result.uv, found, plot, title=f"{args.input}: {len(found.loops)} loop(s)")

    summary = {
        "command": "boundary",
        "input": args.input,
        "map": args.map,
        "out": os.fspath(out),
        "plot": os.fspath(plot) if plot else None,
        "n_points": len(points),
        "h": found.h,
        "c": found.c,
        "min_loop": found.min_loop,
        "min_width": found.min_width,
        "cloud_spacing": bool(args.cloud_spacing),
        "n_loops": len(found.loops),
        "loop_points": [len(loop) for loop in found.loops],
        "hole_widths": found.to_dict()["widths"],
        "n_dropped": len(found.dropped),
        "kinds": found.kinds(),
        "confidence": (None if found.evidence is None
                       else [e["confidence"] for e in found.evidence]),
        "n_gaps": len(found.gaps),
        # "input", "estimated" or "none": the normals the map was made with (of a --map: as
        # its history records them, None when it does not)
        "normals": (_normals_used(result.history, cloud.normals is not None) if args.map is None
                    else _map_record(result.history).get("normals")),
        "mapped_seconds": None if args.map is not None else float(result.seconds),
    }
    if args.json:
        print(json.dumps(summary))
        return EXIT_OK
    rule = (f"h = {found.h:g}" if found.h is not None
            else f"local spacing rule, c = {found.c:g}")
    print(f"{args.input}: {len(points)} points, {len(found.loops)} boundary loop(s) ({rule}) "
          f"-> {summary['out']}" + (f", {summary['plot']}" if plot else ""))
    evidence = found.evidence or [None] * len(found.loops)
    for i, (loop, area, width, kind, ev) in enumerate(zip(found.loops, found.areas, found.widths,
                                                           found.kinds(), evidence)):
        wide = f", {width:.1f} spacings wide" if area < 0 else ""
        sure = (f", empty circle {ev['empty_ratio']:.2f} x the sampling's, confidence "
                f"{ev['confidence']:.2f}" if ev is not None and kind != "outer" else "")
        print(f"  loop {i + 1} ({kind}): {len(loop)} points{wide}{sure}")
    if found.gaps:
        print(f"  {len(found.gaps)} sampling gap(s) set apart (spanned by the surface; "
              f"'gaps' in {summary['out']})")
    if found.dropped:
        narrower = (f" or holes narrower than {found.min_width:g} spacings" if found.min_width
                    else "")
        print(f"  {len(found.dropped)} loop(s) of fewer than {found.min_loop} points{narrower} "
              "dropped")
    return EXIT_OK


def main(argv: list[str] | None = None) -> int:
    """``pcgeom boundary`` on its own: ``main(["scan.ply", "--out", "loops.json"])``."""
    return run_command(standalone_parser(sys.modules[__name__]), argv)
