"""``pcgeom domains``: list the parameter domains, or draw one."""

from __future__ import annotations

import json
import sys

from ..domains import DOMAINS, MASK_SUFFIXES, PolygonDomain, get_domain
from ..errors import InputError
from ..io import check_writable
from ._common import (EXIT_OK, add_output_options, int_at_least, run_command, seed,
                      standalone_parser)

__all__ = ["configure", "run", "main"]

NAME = "domains"
HELP = "list the parameter domains, or draw one"
DESCRIPTION = ("List the built-in parameter domains (name, spec arguments, area), or draw one "
               "with 'show'. Any listed name, NAME:VALUES, PATH.json or PATH.png (a mask) is "
               "a valid 'pcgeom param --domain' value.")
EPILOG = """\
examples:
  pcgeom domains
      one line per domain: name, spec arguments, area, description
  pcgeom domains --json
      the same as one JSON object for scripts
  pcgeom domains show smile -o smile.png
      the smiling face's four boundary loops over a light scatter of its sample
  pcgeom domains show annulus:0.4 -o ring.png --n 5000
  pcgeom domains show room.json -o room.png
      a polygon with holes: {"type": "Polygon", "coordinates": [outer ring, hole rings...]}
  pcgeom domains show shape.png -o shape_domain.png
      a binary image mask: its white pixels (holes included)
  pcgeom domains show annulus:auto -o ring.png
      a ring whose inner radius a map takes from the cloud (drawn at 0.5 here)
"""


AUTO_NOTE = ("inner radius drawn at {inner:g}: a map takes it from the cloud (the surface's "
             "own hole)")
MASK_LINE = ("A binary image mask from PATH.png (or .bmp .tif .gif .jpg): its white pixels, "
             "holes included, scaled to a longer side of 2.")


def configure(p) -> None:
    """Add ``domains``' arguments to ``p``."""
    p.add_argument("action", nargs="?", choices=("list", "show"), default="list",
                   metavar="ACTION", help="list (default) or show")
    p.add_argument("spec", nargs="?", metavar="SPEC",
                   help="with show: a domain, e.g. car, rect:2, annulus:0.4, PATH.json or "
                        "PATH.png")
    add_output_options(p, "OUT.png", "with show: the figure to write", short=True, quiet=False,
                       instead="text")
    p.add_argument("--n", type=int_at_least(1), default=2000,
                   help="with show: sample points drawn (default: 2000)")
    p.add_argument("--seed", type=seed, default=0, help="with show: sample seed (default: 0)")
    p.set_defaults(run=run)


def _entries() -> list[dict]:
    """One record per registered domain: name, spec arguments, default area, description."""
    rows = []
    for name, cls in DOMAINS.items():
        try:
            area = cls().area
        except ValueError:  # a domain with no default (a user polygon)
            area = None
        rows.append({
            "name": name,
            "spec_args": list(cls.spec_args),
            "area": area if area is None or area != float("inf") else None,
            "bounded": cls.bounded,
            "description": (cls.__doc__ or "").strip().splitlines()[0],
        })
    return rows


def _list(args) -> int:
    if args.spec is not None or args.out is not None:
        raise InputError("'pcgeom domains' lists the domains; to draw one: "
                         "pcgeom domains show SPEC -o OUT.png")
    rows = _entries()
    if args.json:
        print(json.dumps({"command": "domains", "domains": rows,
                          "files": [{"spec": "PATH.json", "name": PolygonDomain.name},
                                    {"spec": "PATH.png", "name": PolygonDomain.name,
                                     "suffixes": list(MASK_SUFFIXES), "description": MASK_LINE}]}))
        return EXIT_OK
    # A polygon is given by its file, never by its name; a mask is a file too.
    shown = {r["name"]: "PATH.json" if r["name"] == PolygonDomain.name
             else r["name"] + (":" + ",".join(r["spec_args"]) if r["spec_args"] else "")
             for r in rows}
    lines = [(shown[r["name"]], "-" if r["area"] is None else f"{r['area']:.4f}",
              r["description"]) for r in rows]
    lines.append(("PATH.png", "-", MASK_LINE))
    width = max(len(line[0]) for line in lines)
    for spec, area, description in lines:
        print(f"{spec:<{width}}  area {area:>6}  {description}")
    return EXIT_OK


def _show(args) -> int:
    if args.spec is None:
        raise InputError("show needs a domain: pcgeom domains show SPEC -o OUT.png")
    if args.out is None:
        raise InputError("show needs an output file: -o OUT.png")
    domain = get_domain(args.spec)
    out = check_writable(args.out, "png")
    if not domain.bounded:
        raise InputError(f"domain {domain.spec!r} has no region to draw")
    from ..apps.plot import plot_domain

    # annulus:auto: a map takes its inner radius from the cloud; the figure shows a stand-in.
    note = AUTO_NOTE.format(inner=domain.inner) if getattr(domain, "auto", False) else None
    plot_domain(domain, out, n=args.n, seed=args.seed,
                title=None if note is None else f"{args.spec}: {note}")
    loops = domain.boundary_loops()
    if args.json:
        print(json.dumps({"command": "domains show", "domain": domain.spec, "out": args.out,
                          "area": domain.area, "centroid": domain.centroid.tolist(),
                          "boundary_loops": len(loops), "n": args.n, "note": note}))
    else:
        print(f"{args.spec}: area {domain.area:.4f}, {len(loops)} boundary loop(s) -> {args.out}"
              + ("" if note is None else f" ({note})"))
    return EXIT_OK


def run(args) -> int:
    """Run ``pcgeom domains`` on parsed arguments; returns the exit status."""
    return _show(args) if args.action == "show" else _list(args)


def main(argv: list[str] | None = None) -> int:
    """``pcgeom domains`` on its own: ``main(["show", "car", "-o", "car.png"])``."""
    return run_command(standalone_parser(sys.modules[__name__]), argv)
