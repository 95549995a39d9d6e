"""``pcgeom evaluate``: angle distortion and flips of a saved map on a reference mesh, beside
libigl's LSCM and harmonic disk map of the same mesh."""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

from ..apps.evaluate import PLOT_FILES, evaluate_map

NO_HISTORY_REASON = "a local-mesh map, as preset fast makes, or a bare uv file"
from ..errors import InputError
from ..io import ParamResult, check_writable, read_points
from ._common import (EXIT_OK, add_output_options, distinct_paths, print_angles,
                      print_domain_fit, run_command, standalone_parser)

__all__ = ["configure", "run", "main"]

NAME = "evaluate"
HELP = "angle distortion and flips of a saved map on a reference mesh, beside baselines"
DESCRIPTION = ("Angle distortion (mean, median, 95th percentile, maximum) and flipped "
               "triangles of a map written by 'pcgeom param', measured on a mesh with one "
               "vertex per row of the map, beside libigl's LSCM and harmonic disk map of the "
               "same mesh (timed); a map onto the sphere beside the spherical conformal map "
               "of the same mesh.")
EPILOG = f"""\
examples:
  pcgeom evaluate mesh.ply mesh_uv.npz
  pcgeom evaluate mesh.obj mesh_uv.npz --plot figures/ --json
      writes figures/{PLOT_FILES['angles']} (the map's angle histogram over the baselines'),
      figures/{PLOT_FILES['map']} (the map coloured by angle distortion),
      figures/{PLOT_FILES['checker']} (the mesh with a checkerboard in the map's
      coordinates, beside it coloured by angle distortion) and
      figures/{PLOT_FILES['history']} (the loss terms per stage, for a map trained in stages)
  pcgeom evaluate statue.ply statue_uv.npz --plot figures/
      a map onto the sphere: figures/{PLOT_FILES['map']} and
      figures/{PLOT_FILES['sphere_factor']} (the sphere and an equirectangular picture)
  pcgeom evaluate mesh.ply mesh_uv.npz --plot angles.png --no-baselines
      a .png path writes the angle histogram only

MAP.npz is a file written by 'pcgeom param' (pcgeom.ParamResult), one row per vertex of MESH.
The Hausdorff distance of the map to its domain is reported for a bounded domain (of the mapped
points, and of the mesh's mapped triangles), and that of each landmark set to its targets for
a map trained with landmarks (its last stage's record).
The baselines need a mesh with a boundary; on a closed mesh they are reported as not run.
A map onto the sphere (--domain sphere) is measured on its chord triangles (the mesh's
triangles with the mapped unit vectors as corners; flipped: turned against the centre), with
its conformal factor, beside the spherical conformal map of MESH itself; its figures are the
sphere coloured by angle distortion ({PLOT_FILES['map']}) and by the conformal factor
({PLOT_FILES['sphere_factor']}), each with an equirectangular picture.
"""


def configure(p) -> None:
    """Add ``evaluate``'s arguments to ``p``."""
    p.add_argument("mesh", metavar="MESH", help="reference mesh with faces: .ply .obj .off .npz")
    p.add_argument("map", metavar="MAP.npz", help="map written by 'pcgeom param'")
    p.add_argument("--plot", metavar="DIR",
                   help="write the figures into DIR (created if absent); a path ending in "
                        ".png writes the angle histogram only")
    p.add_argument("--no-baselines", action="store_true",
                   help="do not run libigl's LSCM and harmonic disk map on MESH")
    add_output_options(p, None, quiet=False)
    p.set_defaults(run=run)


def _plot_target(text: str) -> tuple[Path, bool]:
    """``--plot``'s path and whether it is a single PNG (else a directory), checked early."""
    path = Path(text)
    if path.is_dir():
        if not os.access(path, os.W_OK | os.X_OK):
            raise InputError(f"{text}: plot directory is not writable")
        return path, False
    if path.suffix.lower() == ".png":
        return check_writable(path, "png"), True
    if path.suffix:
        raise InputError(f"{text}: --plot takes a directory or a .png file, got "
                         f"{path.suffix!r}")
    if path.exists():
        raise InputError(f"{text}: --plot takes a directory, got a file")
    parent = path.parent
    if not parent.is_dir():
        raise InputError(f"{text}: plot directory's parent {os.fspath(parent)!r} does not exist")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise InputError(f"{text}: plot directory's parent {os.fspath(parent)!r} is not "
                         "writable")
    return path, False


def _angles_line(figures: dict) -> str:
    return (f"median {figures['median_abs_angle_rad']:.4f}, 95th percentile "
            f"{figures['p95_abs_angle_rad']:.4f}, max {figures['max_abs_angle_rad']:.4f} rad")


def run(args) -> int:
    """Run ``pcgeom evaluate`` on parsed arguments; returns the exit status."""
    mesh = read_points(args.mesh)
    if mesh.faces is None:
        raise InputError(f"{args.mesh}: has no faces; evaluation needs a triangle mesh")
    plot, single_png = _plot_target(args.plot) if args.plot else (None, False)
    if single_png:
        distinct_paths({"MESH": args.mesh, "MAP.npz": args.map}, {"plot": plot})
    result = ParamResult.load(args.map, n_points=len(mesh.points), against=args.mesh)
    if result.corner_uv is not None:
        return _run_cut(args, mesh, result)

    evaluation = evaluate_map(result.uv, mesh.points, mesh.faces, result.domain,
                              result.history, baselines=() if args.no_baselines else None)
    report = evaluation.report
    plots = None
    if plot is not None:
        from ..apps.evaluate import plot_angle_histograms, plot_evaluation

        title = f"{Path(args.map).name} on {Path(args.mesh).name}"
        if single_png:
            plots = {"angles": plot_angle_histograms(evaluation, plot, title=title)}
        else:
            plots = plot_evaluation(evaluation, plot, title=title)
        plots = {k: os.fspath(v) if v is not None else None for k, v in plots.items()}
    if args.json:
        print(json.dumps({"command": "evaluate", "mesh": args.mesh, "map": args.map,
                          "plot": args.plot, "plots": plots,
                          "domain": result.domain.spec if result.domain else None,
                          "preset": result.preset, "seed": result.seed,
                          "version": result.version, **report}))
        return EXIT_OK
    made = (f" (pcgeom {result.version}, preset {result.preset}, seed {result.seed})"
            if result.config is not None else "")
    print(f"{args.map} on {args.mesh}: {report['n_points']} points{made}")
    print_domain_fit(report, result.domain.label if result.domain else None)
    if report["landmark_hausdorff"] is not None:
        print("Hausdorff distance of each landmark set to its targets: "
              + ", ".join(f"{d:.4f}" for d in report["landmark_hausdorff"]))
    print_angles(report)
    print(f"  {_angles_line(report)}")
    factor = report.get("conformal_factor")
    if factor is not None and factor["median"] is not None:
        print(f"conformal factor (per vertex, 1: the surface's share of area): 5th percentile "
              f"{factor['p5']:.3f}, median {factor['median']:.3f}, 95th {factor['p95']:.3f} "
              f"(spread {factor['spread']:.2f}x)")
    if report["baselines"]:
        print("baselines on the same mesh:")
    for name, base in report["baselines"].items():
        if base["error"] is not None:
            print(f"  {base['label']}: not run ({base['error']})")
            continue
        print(f"  {base['label']}: {base['seconds']:.2f} s, mean "
              f"{base['mean_abs_angle_rad']:.4f}, {_angles_line(base)}, "
              f"{base['flipped']} flipped ({base['flipped_percent']:.2f}%)")
    if plots:
        print("figures: " + ", ".join(v for v in plots.values() if v is not None))
        if "history" in plots and plots["history"] is None:
            print(f"  no {PLOT_FILES['history']}: the map records no loss per stage "
                  f"({NO_HISTORY_REASON})")
    return EXIT_OK


def _run_cut(args, mesh, result) -> int:
    """``evaluate`` of a cut map (``--cut auto``): the true triangles inside charts, those a
    seam crosses, the scale factor's spread, seams, overlap (no baselines); ``--plot``: the
    atlas figure (a PNG, or ``atlas.png`` in a directory)."""
    from ..maps.atlas_eval import cut_map_report

    report = cut_map_report(mesh.points, mesh.faces, result)
    if args.plot:
        from ..apps.plot_atlas import plot_atlas

        target, single = _plot_target(args.plot)
        if not single:
            target.mkdir(exist_ok=True)
            target = target / "atlas.png"
        plot_atlas(mesh.points, result.mesh_faces, result.corner_uv, target,
                   title=f"{Path(args.map).name} on {Path(args.mesh).name}")
        report["plots"] = {"atlas": os.fspath(target)}
    if args.json:
        print(json.dumps({"command": "evaluate", "mesh": args.mesh, "map": args.map,
                          "domain": "atlas", "preset": result.preset, "seed": result.seed,
                          "version": result.version, **report}))
        return EXIT_OK
    print(f"{args.map} on {args.mesh}: a cut map ({report['charts']} chart(s), atlas use "
          f"{report['atlas_use']:.2f} of the unit square)")
    print(f"inside charts: {report['n_faces']} of {report['n_true_faces']} true triangles; "
          f"{report['seam_crossed']} ({report['seam_crossed_percent']:.2f}%) crossed by a "
          "seam, left out")
    print_angles(report)
    print(f"  {_angles_line(report)}")
    print(f"scale-factor spread (95th / 5th percentile): {report['stretch']:.2f}; seam length "
          f"{report['seam_length']:.2f} x sqrt(area); overlap {report['overlap']:.2g} of the "
          "charts' area")
    if args.plot:
        print(f"figure: {report['plots']['atlas']}")
    return EXIT_OK


def main(argv: list[str] | None = None) -> int:
    """``pcgeom evaluate`` on its own: ``main(["mesh.ply", "mesh_uv.npz"])``."""
    return run_command(standalone_parser(sys.modules[__name__]), argv)
