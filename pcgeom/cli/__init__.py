"""Command line: ``pcgeom <command>``, one module per command, each with ``main(argv=None)``.

The CLI parses arguments, calls the library and formats its results; it holds no logic of its
own. Bad input prints one line, ``pcgeom: error: ...``, on stderr and exits with status 2
before any work, leaving no output file.
"""

from __future__ import annotations

import argparse

from .._version import __version__
from . import batch, boundary, domains, evaluate, param, reconstruct
from ._common import Parser, add_command, run_command

__all__ = ["main", "build_parser", "COMMANDS"]

COMMANDS = (param, evaluate, boundary, reconstruct, batch, domains)
"""Command modules, in ``--help`` order."""

_EPILOG = """\
examples:
  pcgeom param --example peaks3 --out peaks3_uv.npz --plot peaks3_uv.png
  pcgeom param scan.ply --domain disk --out-ply scan_uv.ply --json
  pcgeom evaluate mesh.ply mesh_uv.npz
  pcgeom boundary scan.ply --map scan_uv.npz --out scan_loops.json --plot scan_loops.png
  pcgeom reconstruct scan.ply --map scan_uv.npz --target-vertices 5000 --out scan_mesh.ply
  pcgeom batch 'scans/*.ply' --out maps
  pcgeom domains show smile -o smile.png

Run 'pcgeom COMMAND --help' for the options of each command. Bad input prints one line
'pcgeom: error: ...' on stderr and exits with status 2 before any training.
"""


def build_parser() -> argparse.ArgumentParser:
    """The ``pcgeom`` argument parser (exposed for documentation and tests)."""
    parser = Parser(
        prog="pcgeom",
        description="Meshless low-distortion parametrization of 3D point clouds (HAND + LEG).",
        epilog=_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"pcgeom {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True,
                                parser_class=Parser)
    for command in COMMANDS:
        add_command(sub, command)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run ``pcgeom`` with ``argv`` (default: ``sys.argv[1:]``); returns the exit status."""
    return run_command(build_parser(), argv)
