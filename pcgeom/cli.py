"""Command line: ``pcgeom param`` (map a point cloud to 2D) and ``pcgeom evaluate``.

The CLI parses arguments, calls the library and formats its results; it holds no logic of its
own. Every input is checked before any training starts (file readable and valid, output paths
writable with the right extension, domain/preset/device known). A bad input prints one line,
``pcgeom: error: <message>``, on stderr and exits with status 2, leaving no output file.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

import numpy as np

from pcgeom import __version__
from pcgeom.apps.evaluate import angle_distortion, domain_hausdorff
from pcgeom.domains import DOMAINS, get_domain
from pcgeom.examples import EXAMPLES, load_example
from pcgeom.io import (
    InputError,
    check_writable,
    read_points,
    save_npz_atomic,
    validate_points,
    write_ply_atomic,
)
from pcgeom.optim import PRESETS, get_preset, parametrize, resolve_device

__all__ = ["main", "build_parser"]

EXIT_OK = 0
EXIT_FAILURE = 1  # the run itself failed (I/O error, missing optional dependency)
EXIT_USAGE = 2  # bad arguments or input, detected before any work
EXIT_INTERRUPTED = 130

LOSS_TERMS = ("total", "leg", "hand", "landmarks")

_PARAM_EPILOG = """\
examples:
  pcgeom param --example peaks3 --out peaks3_uv.npz --plot peaks3_uv.png
      built-in three-peaks surface; also reports angle distortion against its mesh
  pcgeom param scan.ply --domain disk --out scan_uv.npz --out-ply scan_uv.ply
      map onto the unit disk; the PLY holds the mapped points (z = 0) and the input faces
  pcgeom param scan.xyz --preset paper --device cuda --seed 3 --quiet --json
      the paper's full schedule on a GPU; one JSON object on stdout for scripts
  pcgeom param scan.xyz --resume
      continue an interrupted run from scan_uv.ckpt (same input, preset and seed)

Faces in the input (PLY/OBJ/OFF/NPZ) are never used for training, only to report the
angle distortion of the result. The checkpoint <out stem>.ckpt is written after each
stage and removed after success.
"""

_MAIN_EPILOG = """\
examples:
  pcgeom param --example peaks3 --out peaks3_uv.npz --plot peaks3_uv.png
  pcgeom param scan.ply --domain disk --out-ply scan_uv.ply --json
  pcgeom evaluate mesh.ply mesh_uv.npz

Run 'pcgeom COMMAND --help' for the options of each command. Bad input prints one line
'pcgeom: error: ...' on stderr and exits with status 2 before any training.
"""

_EVALUATE_EPILOG = """\
examples:
  pcgeom evaluate mesh.ply mesh_uv.npz
  pcgeom evaluate mesh.obj mesh_uv.npz --plot angles.png --json

MAP.npz is a file written by 'pcgeom param' (key 'uv', one row per vertex of MESH).
"""


class _Parser(argparse.ArgumentParser):
    """argparse with the CLI's one-line error format."""

    def error(self, message: str):
        self.exit(EXIT_USAGE, f"pcgeom: error: {message} (see '{self.prog} --help')\n")


def _seed(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a non-negative integer, got {text!r}") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"expected a non-negative integer, got {value}")
    return value


def build_parser() -> argparse.ArgumentParser:
    """The ``pcgeom`` argument parser (exposed for documentation and tests)."""
    parser = _Parser(
        prog="pcgeom",
        description="Meshless low-distortion parametrization of 3D point clouds (HAND + LEG).",
        epilog=_MAIN_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"pcgeom {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True,
                                parser_class=_Parser)

    p = sub.add_parser(
        "param",
        help="map a 3D point cloud onto a 2D domain",
        description="Map a 3D point cloud sampled from an open surface onto a 2D domain.",
        epilog=_PARAM_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("input", nargs="?", metavar="INPUT",
                   help="point cloud: .ply .obj .off .xyz .txt .csv .npz (omit with --example)")
    p.add_argument("--example", metavar="NAME",
                   help=f"use a built-in surface instead of INPUT: {', '.join(EXAMPLES)}")
    p.add_argument("--domain", default="free", metavar="NAME",
                   help=f"parameter domain: {', '.join(DOMAINS)} (default: free boundary)")
    p.add_argument("--preset", default="fast", metavar="NAME",
                   help=f"training preset: {', '.join(PRESETS)} (default: fast)")
    p.add_argument("--device", default="auto", metavar="DEV",
                   help="auto, cpu or cuda (default: auto, CUDA when available)")
    p.add_argument("--seed", type=_seed, default=0, help="random seed (default: 0)")
    p.add_argument("--out", metavar="OUT.npz",
                   help="output map (default: <input stem>_uv.npz next to the input; "
                        "<example>_uv.npz in the current directory for --example)")
    p.add_argument("--out-ply", metavar="MAPPED.ply",
                   help="also write the mapped points (z = 0, input faces if any) as PLY")
    p.add_argument("--plot", metavar="MAP.png",
                   help="also draw the map coloured by lambda_inv")
    p.add_argument("--resume", action="store_true",
                   help="continue from the checkpoint <out stem>.ckpt if it exists")
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    p.add_argument("--json", action="store_true",
                   help="print one JSON object on stdout instead of a summary")
    p.set_defaults(run=_cmd_param)

    e = sub.add_parser(
        "evaluate",
        help="angle distortion and flips of a saved map on a reference mesh",
        description="Angle distortion and flipped triangles of a map written by 'pcgeom param', "
                    "measured on a mesh with one vertex per row of the map.",
        epilog=_EVALUATE_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    e.add_argument("mesh", metavar="MESH", help="reference mesh with faces: .ply .obj .off .npz")
    e.add_argument("map", metavar="MAP.npz", help="map written by 'pcgeom param'")
    e.add_argument("--plot", metavar="ANGLES.png", help="also draw the angle-error histogram")
    e.add_argument("--json", action="store_true",
                   help="print one JSON object on stdout instead of a summary")
    e.set_defaults(run=_cmd_evaluate)
    return parser


# --------------------------------------------------------------------------- param


def _load_input(args) -> tuple[np.ndarray, np.ndarray | None, str, Path]:
    """Points, faces, a display name and the default output path, from INPUT or --example."""
    if (args.input is None) == (args.example is None):
        raise InputError("give exactly one of INPUT or --example NAME")
    if args.example is not None:
        V, F = load_example(args.example)  # ValueError for an unknown name
        V = validate_points(V, name=args.example)
        return V, F, args.example, Path(f"{args.example}_uv.npz")
    cloud = read_points(args.input)
    src = Path(args.input)
    return cloud.points, cloud.faces, args.input, src.with_name(f"{src.stem}_uv.npz")


def _check_outputs(args, default_out: Path) -> dict[str, Path | None]:
    """All output paths, checked writable, distinct, and none of them the input."""
    outs = {
        "out": check_writable(args.out if args.out is not None else default_out, "npz"),
        "out_ply": check_writable(args.out_ply, "ply") if args.out_ply else None,
        "plot": check_writable(args.plot, "png") if args.plot else None,
    }
    outs["checkpoint"] = check_writable(outs["out"].with_suffix(".ckpt"), "ckpt")
    seen: dict[Path, str] = {}
    if args.input is not None:
        seen[Path(args.input).resolve()] = "INPUT"
    for key, path in outs.items():
        if path is None:
            continue
        resolved = path.resolve()
        if resolved in seen:
            raise InputError(f"{os.fspath(path)}: --{key.replace('_', '-')} is the same file "
                             f"as {seen[resolved]}")
        seen[resolved] = f"--{key.replace('_', '-')}"
    return outs


def _angle_report(V, F, uv) -> dict:
    rep = angle_distortion(V, F, uv)
    return {"mean_abs_angle_rad": rep.mean_abs, "flipped": rep.flipped, "n_faces": rep.n_faces}


def _cmd_param(args) -> int:
    # Everything that can be wrong with the request is checked here, before training.
    domain = get_domain(args.domain)
    config = get_preset(args.preset)
    device = resolve_device(args.device)
    points, faces, name, default_out = _load_input(args)
    outs = _check_outputs(args, default_out)

    result = parametrize(
        points,
        domain,
        config=config,
        device=device,
        seed=args.seed,
        checkpoint=outs["checkpoint"],
        resume=args.resume,
        progress=not args.quiet,
    )

    arrays = {
        "uv": result.uv,
        "lambda_inv": result.lambda_inv,
        "center": result.center,
        "scale": np.float64(result.scale),
        "config_json": json.dumps(result.config_dict()),
        "history_json": json.dumps(result.history),
    }
    if faces is not None:
        arrays["faces"] = faces
    save_npz_atomic(outs["out"], **arrays)
    if outs["out_ply"] is not None:
        mapped = np.column_stack([result.uv, np.zeros(len(result.uv))])  # (N, 3), z = 0
        write_ply_atomic(outs["out_ply"], mapped, faces)
    if outs["plot"] is not None:
        from pcgeom.plot import plot_map

        plot_map(result.uv, outs["plot"], values=result.lambda_inv, domain=domain,
                 title=f"{name}: {args.domain}, {args.preset} (colour: lambda_inv)")
    evaluation = _angle_report(points, faces, result.uv) if faces is not None else None
    outs["checkpoint"].unlink(missing_ok=True)

    final = result.history[-1] if result.history else {}
    summary = {
        "command": "param",
        "input": name,
        "out": os.fspath(outs["out"]),
        "out_ply": os.fspath(outs["out_ply"]) if outs["out_ply"] else None,
        "plot": os.fspath(outs["plot"]) if outs["plot"] else None,
        "n_points": int(len(result.uv)),
        "domain": args.domain,
        "preset": args.preset,
        "device": str(device),
        "seed": args.seed,
        "seconds": float(result.seconds),
        "loss": {k: float(final[k]) for k in LOSS_TERMS if k in final},
        "evaluation": evaluation,
        "domain_hausdorff": domain_hausdorff(result.uv, domain) if domain is not None else None,
    }
    if args.json:
        print(json.dumps(summary))
        return EXIT_OK
    written = [summary["out"]] + [summary[k] for k in ("out_ply", "plot") if summary[k]]
    print(f"{name}: {summary['n_points']} points -> {', '.join(written)}")
    print(f"preset {args.preset}, domain {args.domain}, device {summary['device']}, "
          f"seed {args.seed}: {summary['seconds']:.1f} s")
    print("final loss: " + ", ".join(f"{k} {v:.4g}" for k, v in summary["loss"].items()))
    if summary["domain_hausdorff"] is not None:
        print(f"Hausdorff distance of the map to the {args.domain} domain: "
              f"{summary['domain_hausdorff']:.4f}")
    if evaluation is not None:
        _print_angles(evaluation)
    return EXIT_OK


def _print_angles(ev: dict) -> None:
    pct = 100.0 * ev["flipped"] / ev["n_faces"]
    print(f"angle distortion: mean {ev['mean_abs_angle_rad']:.4f} rad over {ev['n_faces']} "
          f"triangles, {ev['flipped']} flipped ({pct:.2f}%)")


# --------------------------------------------------------------------------- evaluate


def _read_map(path: str, n_points: int, mesh_name: str) -> np.ndarray:
    """The ``uv`` array of a map file written by ``pcgeom param``, one row per mesh vertex."""
    p = Path(path)
    if p.suffix.lower() != ".npz":
        got = repr(p.suffix) if p.suffix else "none"
        raise InputError(f"{path}: map must have extension '.npz', got {got}")
    if not p.is_file():
        raise InputError(f"{path}: no such file")
    try:
        with np.load(p, allow_pickle=False) as archive:
            if "uv" not in archive.files:
                found = ", ".join(sorted(archive.files)) or "none"
                raise InputError(f"{path}: no 'uv' array (found: {found}); "
                                 "expected a map written by 'pcgeom param'")
            uv = archive["uv"]
    except InputError:
        raise
    except Exception as exc:  # zipfile.BadZipFile, OSError, ValueError, ...
        raise InputError(f"{path}: cannot parse: {' '.join(str(exc).split()) or type(exc).__name__}"
                         ) from None
    if uv.ndim != 2 or uv.shape[1] != 2:
        raise InputError(f"{path}: 'uv' must have shape (N, 2), got {uv.shape}")
    if len(uv) != n_points:
        raise InputError(f"{path}: map has {len(uv)} rows but {mesh_name} has {n_points} points")
    if not np.isfinite(uv).all():
        raise InputError(f"{path}: 'uv' contains NaN or inf")
    return uv.astype(np.float64)


def _cmd_evaluate(args) -> int:
    mesh = read_points(args.mesh)
    if mesh.faces is None:
        raise InputError(f"{args.mesh}: has no faces; evaluation needs a triangle mesh")
    uv = _read_map(args.map, len(mesh.points), args.mesh)
    plot = check_writable(args.plot, "png") if args.plot else None

    rep = angle_distortion(mesh.points, mesh.faces, uv)
    if plot is not None:
        from pcgeom.plot import plot_angle_histogram

        plot_angle_histogram(rep.per_corner, plot, title=f"{args.map} on {args.mesh}")
    ev = {"mean_abs_angle_rad": rep.mean_abs, "flipped": rep.flipped, "n_faces": rep.n_faces}
    if args.json:
        print(json.dumps({"command": "evaluate", "mesh": args.mesh, "map": args.map,
                          "n_points": int(len(uv)), "plot": args.plot, **ev}))
    else:
        print(f"{args.map} on {args.mesh}: {len(uv)} points")
        _print_angles(ev)
    return EXIT_OK


# --------------------------------------------------------------------------- entry point


def _fail(message: str, code: int) -> int:
    print(f"pcgeom: error: {' '.join(message.split())}", file=sys.stderr)
    return code


def main(argv: list[str] | None = None) -> int:
    """Run ``pcgeom`` with ``argv`` (default: ``sys.argv[1:]``); returns the exit status."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # --help, --version, or a usage error already printed
        return exc.code if isinstance(exc.code, int) else EXIT_USAGE
    try:
        return args.run(args)
    except ValueError as exc:  # InputError included: bad input, reported before training
        return _fail(str(exc), EXIT_USAGE)
    except KeyboardInterrupt:
        hint = (" (rerun with --resume to continue from the last finished stage)"
                if args.command == "param" else "")
        return _fail(f"interrupted{hint}", EXIT_INTERRUPTED)
    except (OSError, ImportError) as exc:
        return _fail(f"{type(exc).__name__}: {exc}", EXIT_FAILURE)


if __name__ == "__main__":
    sys.exit(main())
