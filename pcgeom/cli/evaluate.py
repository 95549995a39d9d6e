"""``pcgeom evaluate``: angle distortion and flips of a saved map on a reference mesh."""

from __future__ import annotations

import json
import sys

from ..apps.evaluate import map_report
from ..errors import InputError
from ..io import ParamResult, check_writable, read_points
from ._common import EXIT_OK, print_angles, run_command, standalone_parser

__all__ = ["configure", "run", "main"]

NAME = "evaluate"
HELP = "angle distortion and flips of a saved map on a reference mesh"
DESCRIPTION = ("Angle distortion and flipped triangles of a map written by 'pcgeom param', "
               "measured on a mesh with one vertex per row of the map.")
EPILOG = """\
examples:
  pcgeom evaluate mesh.ply mesh_uv.npz
  pcgeom evaluate mesh.obj mesh_uv.npz --plot angles.png --json

MAP.npz is a file written by 'pcgeom param' (pcgeom.ParamResult), one row per vertex of MESH.
"""


def configure(p) -> None:
    """Add ``evaluate``'s arguments to ``p``."""
    p.add_argument("mesh", metavar="MESH", help="reference mesh with faces: .ply .obj .off .npz")
    p.add_argument("map", metavar="MAP.npz", help="map written by 'pcgeom param'")
    p.add_argument("--plot", metavar="ANGLES.png", help="also draw the angle-error histogram")
    p.add_argument("--json", action="store_true",
                   help="print one JSON object on stdout instead of a summary")
    p.set_defaults(run=run)


def run(args) -> int:
    """Run ``pcgeom evaluate`` on parsed arguments; returns the exit status."""
    mesh = read_points(args.mesh)
    if mesh.faces is None:
        raise InputError(f"{args.mesh}: has no faces; evaluation needs a triangle mesh")
    plot = check_writable(args.plot, "png") if args.plot else None
    result = ParamResult.load(args.map, n_points=len(mesh.points), against=args.mesh)

    report = map_report(result.uv, result.domain, mesh.points, mesh.faces)
    if plot is not None:
        from ..apps.plot import plot_angle_histogram
        from ..metrics import angle_distortion

        per_corner = angle_distortion(mesh.points, mesh.faces, result.uv).per_corner
        plot_angle_histogram(per_corner, plot, title=f"{args.map} on {args.mesh}")
    if args.json:
        print(json.dumps({"command": "evaluate", "mesh": args.mesh, "map": args.map,
                          "plot": args.plot,
                          "domain": result.domain.spec if result.domain else None,
                          "preset": result.preset, "seed": result.seed,
                          "version": result.version, **report}))
    else:
        made = (f" (pcgeom {result.version}, preset {result.preset}, seed {result.seed})"
                if result.config is not None else "")
        print(f"{args.map} on {args.mesh}: {report['n_points']} points{made}")
        if report["domain_hausdorff"] is not None:
            print(f"Hausdorff distance of the map to the {result.domain.spec} domain: "
                  f"{report['domain_hausdorff']:.4f}")
        print_angles(report)
    return EXIT_OK


def main(argv: list[str] | None = None) -> int:
    """``pcgeom evaluate`` on its own: ``main(["mesh.ply", "mesh_uv.npz"])``."""
    return run_command(standalone_parser(sys.modules[__name__]), argv)
