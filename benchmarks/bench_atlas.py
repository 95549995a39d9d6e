"""Seams and texture atlases (``--cut auto``) measured against issue 38's Done-means.

Surfaces: analytic tori (5k, 20k, 50k, with true triangles), the finger (a disk with a long
thin tube: its one free chart shrinks the tube; true triangles), pretzels of genus 2, 3 and 4
(implicit, no true triangles), the shared closed head and open surfaces. Each is mapped by
``parametrize(points, "free", cut="auto")`` in process, bare points (no normals), ``fast``.

Figures of the atlas (its local mesh, per corner): charts, slits and splits, flips, overlap
(the atlas triangles' area covered twice, shapely union, a fraction), scale-factor spread
(95th/5th percentile of ``sqrt(uv area / 3D area)``; the worst chart's beside it), seam length
over sqrt(area), atlas use, seconds (median of ``--repeats`` runs for the 50k rows). Where
the surface has true triangles: the mean angle error over the true triangles inside charts,
their flips, the share a seam crosses (left out), the spread over them, and libigl's LSCM on
the true mesh cut along the same seams (:func:`pcgeom.maps.atlas_eval.same_seams_lscm`).

    OMP_NUM_THREADS=1 python benchmarks/bench_atlas.py [--quick]
"""

from __future__ import annotations

import statistics
import sys
import time

import numpy as np

import harness
from pcgeom import parametrize
from pcgeom.io import read_points
from pcgeom.maps.atlas import overlap_area
from pcgeom.maps.atlas_eval import cut_map_report, same_seams_lscm
from pcgeom.synthetic_atlas import finger, pretzel
from pcgeom.synthetic_closed import closed_surface

SHARED = ("closed_david_head_choi", "face_3holes_small_choi", "peaks_7holes_choi",
          "face_human_choi", "peaks_three_cgal")


def run(name: str, kind: str, P, faces=None, repeats: int = 1) -> dict:
    """One surface: the atlas's figures, and where ``faces`` is given the true mesh's."""
    times, r, err = [], None, None
    for _ in range(repeats):
        t = time.perf_counter()
        try:
            r = parametrize(P, "free", cut="auto", progress=False)
        except Exception as e:  # noqa: BLE001 - a refusal is a row
            err = str(e).splitlines()[0]
            break
        times.append(time.perf_counter() - t)
    if err:
        harness.log(f"{name}: {err}")
        return {"surface": name, "kind": kind, "n": len(P), "error": err}
    rec = r.history[-1]
    U = r.corner_uv.reshape(-1, 2)
    row = {"surface": name, "kind": kind, "n": len(P), "genus": rec["seams"]["genus"],
           "loops": rec["seams"].get("boundary_loops", 0), "charts": rec["charts"],
           "slits": rec["seams"].get("slits", 0), "splits": rec["seams"].get("splits", 0),
           "tutte": rec["seams"].get("tutte", 0), "flips": rec["flips"]["count"],
           "overlap": overlap_area(U, np.arange(len(U)).reshape(-1, 3)),
           "spread": rec["stretch"], "chart_spread": rec["chart_stretch"],
           "seam": rec["seam_length"], "use": rec["atlas_use"], "packer": rec["packer"],
           "s": statistics.median(times), "runs": len(times)}
    if faces is not None:
        rep = cut_map_report(P, faces, r, overlap=False)
        base = same_seams_lscm(P, faces, r)
        row.update(rad=rep["mean_abs_angle_rad"], true_flips=rep["flipped"],
                   crossed=rep["seam_crossed_percent"], true_spread=rep["stretch"],
                   lscm=base["mean_abs_angle_rad"], lscm_flips=base["flipped"],
                   lscm_skipped=base["skipped"],
                   ratio=rep["mean_abs_angle_rad"] / max(base["mean_abs_angle_rad"], 1e-300))
    harness.log(f"{name} {len(P)}: {row}")
    return row


def surfaces(quick: bool):
    sizes = (5000,) if quick else (5000, 20000, 50000)
    for n in sizes:
        s = closed_surface("torus", n)
        yield f"torus {n // 1000}k", "genus 1, no limbs", s.points, s.faces, 3 if n >= 50000 else 1
    for n in (5000,) if quick else (5000, 20000):
        s = finger(n)
        yield f"finger {n // 1000}k", "open, a limb", s.points, s.faces, 1
    for g in (2, 3, 4):
        for n in (5000,) if quick else (5000, 20000):
            yield f"pretzel g{g} {n // 1000}k", f"genus {g}", pretzel(g, n), None, 1
    if not quick:
        yield "pretzel g4 50k", "genus 4", pretzel(4, 50000), None, 3
        for name in SHARED:
            path = harness.DATA_DIR / f"{name}.ply"
            if path.exists():
                c = read_points(path)
                yield name, "shared", c.points, c.faces, 1


def main(argv=None) -> int:
    p = harness.parser(__doc__, "the rows as JSON")
    p.add_argument("--quick", action="store_true", help="5k points only, no shared surfaces")
    args = p.parse_args(argv)
    t0 = time.perf_counter()
    rows = [run(name, kind, P, F, repeats) for name, kind, P, F, repeats in
            surfaces(args.quick)]
    ok = [r for r in rows if "error" not in r]
    lines = ["## Seams and texture atlases, `--cut auto` (`benchmarks/bench_atlas.py`)", ""]
    lines += harness.header(argv, f"load {harness.loadavg()}", "1 thread, in process, bare "
                            "points, fast")
    lines += ["", "The atlas (its local mesh, per corner; overlap: area covered twice, shapely "
              "union, a fraction):", ""]
    lines += harness.table([
        ("surface", "{surface}"), ("points", "{n}"), ("kind", "{kind}"),
        ("genus / loops", "{genus} / {loops}"), ("charts", "{charts}"),
        ("slits / splits / Tutte", "{slits} / {splits} / {tutte}"), ("flips", "{flips}"),
        ("overlap", "{overlap:.1e}"), ("spread (worst chart)", "{spread:.2f} ({chart_spread:.2f})"),
        ("seam / sqrt(A)", "{seam:.2f}"), ("atlas use", "{use:.2f}"),
        ("packer", "{packer}"), ("s", lambda r: f"{r['s']:.1f}" + (
            f" (median of {r['runs']})" if r["runs"] > 1 else ""))], ok)
    true = [r for r in ok if "rad" in r]
    lines += ["", "On the true triangles (those a seam crosses left out, their share given), "
              "beside libigl's LSCM on the true mesh cut along the same seams:", ""]
    lines += harness.table([
        ("surface", "{surface}"), ("rad inside charts", "{rad:.4f}"),
        ("libigl LSCM, same seams", "{lscm:.4f}"), ("ratio", "{ratio:.2f}"),
        ("flips (LSCM)", "{true_flips} ({lscm_flips})"), ("seam-crossed %", "{crossed:.2f}"),
        ("LSCM skipped", "{lscm_skipped}"),
        ("spread", "{true_spread:.2f}")], true)
    failed = [r for r in rows if "error" in r]
    if failed:
        lines += [""] + [f"- {r['surface']} ({r['n']} points): refused, `{r['error']}`"
                         for r in failed]
    lines += ["", f"({time.perf_counter() - t0:.0f} s in all.)"]
    harness.write_section(args.out, "bench_atlas", "\n".join(lines))
    if args.json:
        harness.write_json(args.json, rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
