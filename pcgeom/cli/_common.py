"""What every command shares: the parser class, exit codes, error reporting, output checks."""

from __future__ import annotations

import argparse
import os
import sys
import warnings
from pathlib import Path
from types import ModuleType

from ..errors import InputError

__all__ = ["EXIT_OK", "EXIT_FAILURE", "EXIT_USAGE", "EXIT_INTERRUPTED", "Parser", "int_at_least",
           "seed", "denoise_option", "add_denoise_option", "texture_spec", "add_texture_option",
           "texture_line", "distinct_paths", "add_output_options", "add_cloud_and_map",
           "load_free_map", "print_angles",
           "print_noise", "flip_places", "add_command", "standalone_parser", "run_command"]

EXIT_OK = 0
EXIT_FAILURE = 1  # the run itself failed (I/O error, missing optional dependency)
EXIT_USAGE = 2  # bad arguments or input, detected before any work
EXIT_INTERRUPTED = 130


class Parser(argparse.ArgumentParser):
    """argparse with the CLI's one-line error format and exit status 2."""

    def error(self, message: str):
        self.exit(EXIT_USAGE, f"pcgeom: error: {message} (see '{self.prog} --help')\n")


def int_at_least(minimum: int):
    """An argparse type: an int >= ``minimum`` (0: "non-negative", 1: "positive")."""
    what = {0: "a non-negative integer", 1: "a positive integer"}.get(
        minimum, f"an integer >= {minimum}")

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}") from None
        if value < minimum:
            raise argparse.ArgumentTypeError(f"expected {what}, got {value}")
        return value

    return parse


seed = int_at_least(0)
"""argparse type of ``--seed``: a non-negative int."""


def denoise_option(text: str) -> str:
    """argparse type of ``--denoise``: ``auto``, ``off`` or a positive strength, checked by
    :func:`pcgeom.config.denoise_config` (the value is kept as given)."""
    from ..config import denoise_config

    try:
        denoise_config(text)
    except InputError as exc:
        raise argparse.ArgumentTypeError(str(exc).removeprefix("denoise: ")) from None
    return text


def add_denoise_option(p: argparse.ArgumentParser) -> None:
    """``--denoise``, shared by the commands that map a cloud."""
    p.add_argument("--denoise", type=denoise_option, metavar="auto|off|STRENGTH",
                   help="fit the surface before the map: auto (denoise when the estimated "
                        "noise exceeds 0.2 spacings), off, or STRENGTH, the fit's Gaussian "
                        "width in spacings (median nearest-neighbour distances), always "
                        "applied; 3 is auto's (default: the preset's, auto for fast)")


def texture_spec(text: str):
    """An argparse type: a texture spec (:func:`pcgeom.apps.texture.parse_texture`)."""
    from ..apps.texture import parse_texture

    try:
        return parse_texture(text)
    except InputError as exc:
        raise argparse.ArgumentTypeError(str(exc).removeprefix("texture: ")) from None


def add_texture_option(p: argparse.ArgumentParser, mesh_option: str) -> None:
    """``--texture checker[:N]``: a checkerboard material for the OBJ of ``mesh_option``."""
    p.add_argument("--texture", type=texture_spec, metavar="checker[:N]",
                   help=f"also write a material and a checkerboard image of N x N squares "
                        f"(default 8) over the map beside the OBJ of {mesh_option} "
                        "(MESH.mtl, MESH_checker.png): open it in MeshLab or Blender to see "
                        "the map's distortion; needs an .obj")


def texture_line(summary: dict) -> str:
    """The human line for a mesh's texture coordinates (``uv_offset``, ``uv_scale``) and its
    texture files (``texture``, ``texture_files``)."""
    (x, y), scale = summary["uv_offset"], summary["uv_scale"]
    line = f"  texture coordinates: uv = (p - ({x:.6g}, {y:.6g})) / {scale:.6g}"
    if summary.get("texture_files"):
        line += f"; {summary['texture']}: " + ", ".join(summary["texture_files"].values())
    return line


def distinct_paths(inputs: dict[str, str | None], outputs: dict[str, Path | None]) -> None:
    """No output may be an input or another output (``InputError`` naming both options)."""
    seen: dict[Path, str] = {}
    for label, path in inputs.items():
        if path is not None:
            seen[Path(path).resolve()] = label
    for key, path in outputs.items():
        if path is None:
            continue
        option = f"--{key.replace('_', '-')}"
        resolved = path.resolve()
        if resolved in seen:
            raise InputError(f"{os.fspath(path)}: {option} is the same file as {seen[resolved]}")
        seen[resolved] = option


def add_output_options(p: argparse.ArgumentParser, out: str | None, out_help: str = "", *,
                       required: bool = False, short: bool = False, quiet: bool = True,
                       instead: str = "a summary") -> None:
    """The options of what a command writes and says, the same in every command: ``--out``
    (metavar ``out``, help ``out_help``; ``-o`` as well when ``short``; none when ``out`` is
    None), ``--quiet`` (when ``quiet``: no progress) and ``--json`` (one JSON object on stdout
    instead of ``instead``)."""
    if out is not None:
        p.add_argument(*(["-o"] if short else []), "--out", required=required, metavar=out,
                       help=out_help)
    if quiet:
        p.add_argument("--quiet", action="store_true",
                       help="no progress (bars on a terminal, a few lines in a log)")
    p.add_argument("--json", action="store_true",
                   help=f"print one JSON object on stdout instead of {instead}")


def add_cloud_and_map(p: argparse.ArgumentParser) -> None:
    """``INPUT`` and ``--map``: the arguments of the commands that work on a free-boundary map."""
    p.add_argument("input", metavar="INPUT",
                   help="point cloud: .ply .obj .off .xyz .txt .csv .npz .las .laz")
    p.add_argument("--map", metavar="MAP.npz",
                   help="free-boundary map of INPUT written by 'pcgeom param' (default: map "
                        "INPUT first, preset fast)")


def load_free_map(args, points, purpose: str, domain=None, hint: str = "",
                  closed_ok: bool = False, *, cut_ok: bool = False):
    """The ``ParamResult`` of ``args.map``, checked to be a free-boundary map of ``points``,
    or, with a bounded ``domain``, a map of ``points`` onto that very domain; with
    ``closed_ok`` and no ``domain``, a map onto a closed domain (the sphere) too; with
    ``cut_ok``, a cut map (``--cut auto``: an atlas) too.

    Raises
    ------
    InputError
        Anything ``ParamResult.load`` refuses, a map of another cloud with as many points
        (fingerprint), a cut map (``--cut auto``: seams), a map trained onto a bounded domain
        (``purpose`` needs a free one; ``hint`` ends the message), or, with ``domain``, a map onto
        another domain or a free
        map.
    """
    from ..cloud import fingerprint
    from ..io import ParamResult

    result = ParamResult.load(args.map, n_points=len(points), against=args.input)
    if result.fingerprint is not None and result.fingerprint != fingerprint(points):
        raise InputError(f"{args.map}: was made from another cloud than {args.input} "
                         "(same number of points, different coordinates)")
    if result.corner_uv is not None and not cut_ok:  # an atlas: uv jump across the seams
        raise InputError(f"{args.map}: is a cut map (--cut auto); {purpose} needs one chart "
                         "without seams (pcgeom param without --cut); the cut map's own mesh "
                         "with its atlas: pcgeom param --cut auto --out-mesh MESH.obj")
    trained = result.domain if result.domain is not None and result.domain.bounded else None
    if domain is not None and domain.bounded:
        if trained is None:
            raise InputError(f"{args.map}: is a free-boundary map, not a map onto "
                             f"{domain.label!r} (--domain); drop --domain, or map {args.input} "
                             f"with pcgeom param --domain {domain.spec}")
        if trained.to_dict() != domain.to_dict():
            raise InputError(f"{args.map}: was trained onto the domain {trained.label!r}, not "
                             f"{domain.label!r} (--domain)")
        return result
    if trained is not None and not (closed_ok and trained.closed):
        raise InputError(f"{args.map}: was trained onto the domain {trained.label!r}; "
                         f"{purpose} needs a free-boundary map (pcgeom param without --domain)"
                         + hint)
    return result


def print_angles(report: dict) -> None:
    """The human line for a map's angle distortion (``map_report`` keys)."""
    print(f"angle distortion: mean {report['mean_abs_angle_rad']:.4f} rad over "
          f"{report['n_faces']} triangles, {report['flipped']} flipped "
          f"({report['flipped_percent']:.2f}%){flip_places(report.get('flipped_where'))}")


def print_noise(record: dict | None) -> None:
    """The human line for a run's noise estimate and denoising (``ParamResult.denoise``)."""
    if not record or record.get("noise") is None:
        return
    done = (f"denoised (fit width {record['width']:.2f} spacings, points moved "
            f"{record['moved']:.2f} spacings on average, {record['seconds']:.1f} s)"
            if record["applied"] else "not denoised (--denoise STRENGTH to force it)")
    print(f"noise: {record['noise']:.3f} spacings estimated (std {record['noise_std']:.4g}, "
          f"spacing {record['spacing']:.4g}); {done}")


def flip_places(where: dict | None) -> str:
    """``": 3 on the rim, 1 near holes, 0 inside"``, or nothing without flips."""
    if not where or not sum(where.values()):
        return ""
    return (f": {where['rim']} on the rim, {where['hole']} near holes, "
            f"{where['inside']} inside")


def print_domain_fit(report: dict, label: str | None) -> None:
    """The human line for a map's fit to its bounded domain, named ``label`` (``map_report``
    keys): the mapped points' Hausdorff distance, and the mapped reference triangles' when the
    input had them."""
    if report["domain_hausdorff"] is None:
        return
    print(f"Hausdorff distance of the map to its domain ({label}): "
          f"{report['domain_hausdorff']:.4f} (points)"
          + ("" if report["surface_hausdorff"] is None
             else f", {report['surface_hausdorff']:.4f} (reference triangles)"))


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """Warnings as one line, ``pcgeom: warning: ...``, like the errors."""
    print(f"pcgeom: warning: {' '.join(str(message).split())}", file=sys.stderr)


def _fail(message: str, code: int) -> int:
    print(f"pcgeom: error: {' '.join(message.split())}", file=sys.stderr)
    return code


def add_command(sub, command: ModuleType) -> argparse.ArgumentParser:
    """Register a command module (``NAME``, ``HELP``, ``DESCRIPTION``, ``EPILOG``,
    ``configure``) as a subcommand."""
    p = sub.add_parser(command.NAME, help=command.HELP, description=command.DESCRIPTION,
                       epilog=command.EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    command.configure(p)
    p.set_defaults(interrupted_hint=getattr(command, "INTERRUPTED_HINT", ""))
    return p


def standalone_parser(command: ModuleType) -> Parser:
    """The parser of one command on its own (its ``main(argv)``), prog ``pcgeom NAME``."""
    p = Parser(prog=f"pcgeom {command.NAME}", description=command.DESCRIPTION,
               epilog=command.EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    command.configure(p)
    p.set_defaults(interrupted_hint=getattr(command, "INTERRUPTED_HINT", ""))
    return p


def run_command(parser: argparse.ArgumentParser, argv: list[str] | None) -> int:
    """Parse ``argv`` and run ``args.run(args)``, mapping failures to exit codes.

    ``ValueError`` (``InputError`` included): bad input, one line, status 2;
    ``OSError`` / ``ImportError``: status 1; Ctrl-C: status 130 with the command's
    ``INTERRUPTED_HINT``.
    """
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # --help, --version, or a usage error already printed
        return exc.code if isinstance(exc.code, int) else EXIT_USAGE
    try:
        with warnings.catch_warnings():
            warnings.showwarning = _show_warning
            return args.run(args)
    except ValueError as exc:
        return _fail(str(exc), EXIT_USAGE)
    except KeyboardInterrupt:
        return _fail(f"interrupted{args.interrupted_hint}", EXIT_INTERRUPTED)
    except (OSError, ImportError) as exc:
        return _fail(f"{type(exc).__name__}: {exc}", EXIT_FAILURE)
