"""Benchmark maps of closed genus-0 clouds onto the sphere (`--domain sphere`, issue 37).

Part 1, as a user runs it: ``pcgeom param CLOUD.xyz --domain sphere`` (bare points, ``fast``)
on the analytic closed surfaces of :func:`pcgeom.synthetic_closed.closed_surface` (5k and 50k
points, noise 0 and 0.25 spacings, each sampling) and the shared closed david head (bare, and
with depth noise of 0.25 edges judged on its clean mesh), timed
from outside with its peak memory; one 200k run. Each map is judged on the true triangles of
the clean surface (chord triangles: angle distortion, and flips by orientation against the
centre), beside the mesh anchor: the better of the stereographic method as Choi et al. publish
it and conformalized mean curvature flow on the true triangulation of the same input points
(:func:`pcgeom.apps.baselines.sphere_conformal`, issue 37 item 3).

Part 2, the method against the alternatives, in this process, on true meshes and on the
cloud's own local mesh (closed as ``--domain sphere`` closes it): pcgeom's choice, its linear
method (the weights clamped positive where they turn a triangle over, which makes the planar
step bijective; the south-pole correction from both poles), conformalized mean curvature flow
(Kazhdan et al. 2012) followed by the radial projection, Choi, Lam and Lui's linear method as
published (cotangent weights as they are, one correction), the weights always clamped, and
without the south-pole correction. Replaces the section ``bench_sphere`` of BENCHMARKS.md.
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import harness as H
import numpy as np

SHAPES = ("sphere", "ellipsoid", "bumpy", "peanut")
SAMPLINGS = ("uniform", "grid")
ANGLE_CAP = 0.05
"""Largest mean angle distortion on smooth genus-0 shapes, radians (issue 37)."""
FLIP_CAP = 0.1
"""Largest share of true triangles turned over, percent (issue 37)."""
TIME_CAPS = {50_000: (60.0, 2.0), 200_000: (240.0, None)}
"""Seconds and GB allowed at these sizes (issue 37)."""
HEAD_NOISE = 0.25
"""Depth noise of the noisy david head (mean edges along its mesh's normals, as
``bench_scans.depth_noisy``): a scan's detail, where the denoiser's narrow normals are the
better ones."""


def _score(S, V, F) -> dict:
    from pcgeom.metrics import angle_distortion

    a = angle_distortion(V, F, S)
    return {"rad": a.mean_abs, "flipped": a.flipped, "flip_pct": 100.0 * a.flipped / a.n_faces}


def cloud_row(case: str, points, clean, faces, work: Path) -> dict:
    """``pcgeom param`` on the bare points; scored on the clean true mesh, beside the anchor
    (the method on the true triangulation of the same points)."""
    from pcgeom.apps.baselines import sphere_conformal
    from pcgeom.io import ParamResult

    src = work / f"{case.replace(' ', '_').replace(',', '')}.xyz"
    np.savetxt(src, points)
    out = src.with_name(src.stem + "_uv.npz")
    run = H.pcgeom_cli("param", src, "--domain", "sphere", "--out", out, check=False)
    which: dict = {}
    anchor, seconds = H.timed(lambda: sphere_conformal(points, faces, stats=which))
    row = {"case": case, "n": len(points), "anchor_s": seconds, "anchor_method": which["method"],
           **{f"anchor_{k}": v for k, v in _score(anchor, clean, faces).items()}}
    # The ideal: the method on the clean true mesh (the same as the anchor without noise).
    row["clean_rad"] = (row["anchor_rad"] if np.array_equal(points, clean)
                        else _score(sphere_conformal(clean, faces), clean, faces)["rad"])
    if run["error"]:
        H.log(f"{case}: FAILED {run['error']}")
        return {**row, "error": run["error"].split("error: ")[-1], "wall_s": run["wall_s"]}
    result = ParamResult.load(out, n_points=len(points))
    S = result.uv
    row.update(_score(S, clean, faces), wall_s=run["wall_s"], cpu_s=run["cpu_s"],
               rss_gb=run["rss_gb"],
               method=result.history[-1].get("method", "-"),
               seconds=run["json"]["seconds"], error="")
    H.log(f"{case}: {row['rad']:.4f} rad ({row['flipped']} flipped), anchor "
          f"{row['anchor_rad']:.4f}, {row['wall_s']:.1f} s, {row['rss_gb']:.2f} GB")
    return row


def method_rows(case: str, V, F, clean) -> list[dict]:
    """Each method on the mesh ``(V, F)``, judged on the clean true mesh ``clean`` (vertices
    and faces; the mesh may be the cloud's local mesh over the same points)."""
    import pcgeom.maps.sphere as SM

    methods = [("pcgeom: the better on its own mesh of the two below",
                lambda: SM.best_sphere_map(V, F)[0]),
               ("linear: cotangent weights clamped positive only where they turn a triangle "
                "over, the correction from both poles", lambda: SM.spherical_conformal(V, F)),
               ("conformalized mean curvature flow, 40 steps", lambda: SM.cmcf(V, F)),
               ("Choi et al. as published (cotangent weights as they are, one correction)",
                lambda: SM.spherical_conformal(V, F, clamp="never", poles=1)),
               ("linear, weights always clamped positive",
                lambda: SM.spherical_conformal(V, F, clamp="always")),
               ("linear, no south-pole correction",
                lambda: SM.spherical_conformal(V, F, correct=False))]
    rows = []
    for label, fn in methods:
        S, seconds = H.timed(fn)
        rows.append({"case": case, "method": label, "seconds": seconds,
                     **_score(S, *clean)})
        H.log(f"{case}: {label}: {rows[-1]['rad']:.4f} rad, {rows[-1]['flipped']} flipped")
    return rows


def local_closed_mesh(points):
    """The closed local mesh ``--domain sphere`` maps (over the normalized points), or None
    when the cloud is refused."""
    from pcgeom import get_preset
    from pcgeom.cloud import normalize
    from pcgeom.errors import InputError
    from pcgeom.maps.localmesh import mesh_cloud
    from pcgeom.maps.sphere import closed_mesh, outward

    settings = get_preset("fast").local_mesh
    Xn = normalize(points)[0]
    mesh, _, _ = mesh_cloud(Xn, None, settings.neighbours, settings.normal_neighbours,
                            progress=False, normal_scales=settings.normal_scales,
                            normal_tolerance=settings.normal_tolerance, closed=True)
    try:
        index, F, _ = closed_mesh(Xn, mesh)
    except InputError as err:
        return None, str(err)
    return (index, outward(Xn[index], F)), None


def run_all(args, work: Path) -> tuple[list, list]:
    from pcgeom.io import read_points
    from pcgeom.synthetic_closed import closed_surface

    rows, methods = [], []
    for n, noise in ((5000, 0.0), (5000, 0.25), (50_000, 0.0)):
        if n not in args.sizes:
            continue
        for sampling in args.samplings:
            for shape in args.shapes:
                seeds = range(args.noise_seeds) if noise else (0,)
                for seed in seeds:
                    s = closed_surface(shape, n, sampling=sampling, noise=noise, seed=seed)
                    case = f"{shape}, {sampling}, noise {noise:g}"
                    row = cloud_row(case + (f", seed {seed}" if seed else ""), s.points,
                                    s.clean_points, s.faces, work)
                    rows.append({**row, "cloud": case, "seed": seed})
    david = H.DATA_DIR / "closed_david_head_choi.ply"
    if david.exists():
        from bench_scans import depth_noisy

        mesh = read_points(david)
        rows.append(cloud_row("closed_david_head_choi", mesh.points, mesh.points, mesh.faces,
                              work))
        for seed in range(args.head_noise_seeds):
            noisy = depth_noisy(mesh.points, mesh.faces, HEAD_NOISE, seed)[0]
            case = f"closed_david_head_choi, depth noise {HEAD_NOISE:g}"
            row = cloud_row(case + (f", seed {seed}" if seed else ""), noisy, mesh.points,
                            mesh.faces, work)
            rows.append({**row, "cloud": case, "seed": seed, "capped": False})
    for sampling in args.large_sampling if args.large else ():
        s = closed_surface("bumpy", args.large, sampling=sampling)
        rows.append(cloud_row(f"bumpy, {sampling}, noise 0 ({args.large // 1000}k)",
                              s.points, s.clean_points, s.faces, work))
    if args.no_methods:
        return rows, methods
    # Part 2.
    cases = [(f"{shape}, {sampling}, 5k", closed_surface(shape, 5000, sampling=sampling))
             for sampling in ("uniform", "grid") for shape in SHAPES]
    for case, s in cases:
        methods += method_rows(f"{case}: true mesh", s.clean_points, s.faces,
                               (s.clean_points, s.faces))
        found, error = local_closed_mesh(s.points)
        if found is None:
            H.log(f"{case}: local mesh refused: {error}")
            continue
        index, F = found
        # The local mesh's vertices are the normalized points: judge on the true mesh's
        # triangles among them (every point is in the mesh for these clouds).
        if len(index) == len(s.points):
            methods += method_rows(f"{case}: local mesh", s.points[index], F,
                                   (s.clean_points, s.faces))
    if david.exists():
        mesh = read_points(david)
        methods += method_rows("closed_david_head_choi: true mesh", mesh.points, mesh.faces,
                               (mesh.points, mesh.faces))
    return rows, methods


def _cell(row, key, fmt):
    value = row.get(key)
    return "-" if value is None else format(value, fmt)


def verdicts(rows) -> list[str]:
    lines = []
    for r in rows:
        if r.get("error"):
            lines.append(f"- {r['case']} ({r['n']} points): FAILED: {r['error']}")
            continue
        # Equal to the shown digits counts as equal (the david head's local mesh is its true
        # mesh: the two maps agree to 1e-6 rad).
        # The cap is for smooth shapes: a scan with depth noise is held to its anchor only.
        capped = r.get("capped", True)
        ok_angle = (round(r["rad"], 4) <= round(r["anchor_rad"], 4)
                    and (r["rad"] <= ANGLE_CAP or not capped))
        ok_flip = r["flip_pct"] < FLIP_CAP
        time_cap, mem_cap = TIME_CAPS.get(r["n"], (None, None))
        extra = ""
        if time_cap is not None:
            # The CPU seconds: the wall time of a loaded machine is the other processes' too.
            ok_time = r["cpu_s"] <= time_cap and (mem_cap is None or r["rss_gb"] <= mem_cap)
            extra = (f"; {r['cpu_s']:.1f} CPU s ({r['wall_s']:.1f} s wall), "
                     f"{r['rss_gb']:.2f} GB (<= {time_cap:g} s"
                     + (f", {mem_cap:g} GB" if mem_cap else "") + f"): "
                     + ("PASS" if ok_time else "FAIL"))
        lines.append(f"- {r['case']} ({r['n']} points): {r['rad']:.4f} rad against the anchor's "
                     f"{r['anchor_rad']:.4f} (<= it" + (f" and <= {ANGLE_CAP}" if capped else "")
                     + "): "
                     f"{'PASS' if ok_angle else 'FAIL'}; flipped {r['flip_pct']:.3f}% "
                     f"(< {FLIP_CAP}%): {'PASS' if ok_flip else 'FAIL'}{extra}")
    return lines


def seed_lines(rows) -> list[str]:
    """The noisy clouds over their seeds: flips of each draw and their median."""
    import statistics

    by_cloud: dict = {}
    for r in rows:
        if "noise 0.25" in r.get("cloud", "") and not r.get("error"):
            by_cloud.setdefault(r["cloud"], []).append(r)
    if not any(len(v) > 1 for v in by_cloud.values()):
        return []
    lines = ["### Noisy clouds over the noise's draws", "",
             "The same clouds with other seeds of `closed_surface` (the points and the noise "
             "drawn again): true triangles turned over by pcgeom's map / by the anchor, and "
             "the mean angle error.", "",
             "| cloud | seeds | flipped, each seed | median % | anchor flipped | rad, each seed |",
             "|---|---|---|---|---|---|"]
    verdict = []
    for cloud, rs in by_cloud.items():
        median = statistics.median(r["flip_pct"] for r in rs)
        lines.append(f"| {cloud} | {', '.join(str(r['seed']) for r in rs)} | "
                     f"{', '.join(str(r['flipped']) for r in rs)} | {median:.3f} | "
                     f"{', '.join(str(r['anchor_flipped']) for r in rs)} | "
                     f"{', '.join(format(r['rad'], '.4f') for r in rs)} |")
        verdict.append(f"- {cloud}: median {median:.3f}% of true triangles flipped over "
                       f"{len(rs)} draws, most {max(r['flip_pct'] for r in rs):.3f}% "
                       f"(< {FLIP_CAP}%): the median {'PASS' if median < FLIP_CAP else 'FAIL'}, "
                       f"{sum(r['flip_pct'] >= FLIP_CAP for r in rs)} of {len(rs)} draws over")
    return lines + [""] + verdict


def render(rows, methods, argv) -> str:
    import os
    import platform

    return "\n".join([
        "## Closed surfaces onto the sphere (`benchmarks/bench_sphere.py`)", "",
        *H.header(argv, f"{os.cpu_count()} cores, Python {platform.python_version()}",
                  f"load average at end {H.loadavg() or 'n/a'}"), "",
        "`pcgeom param CLOUD.xyz --domain sphere` (bare points, `fast`, the CLI timed from "
        "outside with its peak memory; CPU s: its user and system seconds, what the wall "
        "time is on an idle machine, since it runs one thread; the time targets read them, "
        "the machine being shared) on `pcgeom.synthetic_closed.closed_surface(shape, n, "
        "sampling=, noise=)` and the shared closed david head (bare, and with depth noise of "
        f"{HEAD_NOISE:g} mean edges along its mesh's normals, `bench_scans.depth_noisy`, "
        "judged on its clean mesh). Angle distortion of the chord "
        "triangles (the true triangles with the mapped unit vectors as corners) against the "
        "clean true surface; flipped: turned against the centre. The anchor (issue 37 item 3) "
        "is the better of the stereographic method as Choi et al. publish it and "
        "conformalized mean curvature flow (40 steps), each on the true triangulation of the "
        "same points (with their noise), judged the same way, as the planar noise rows judge "
        "LSCM on the noisy mesh; the clean anchor, the same on the clean true mesh, is the "
        "ideal a noisy cloud cannot quite reach. pcgeom's method: the column says which of "
        "its two maps (linear, flow) it kept on its own mesh. "
        "A failed row is the one-line refusal the user gets.", "",
        *H.table([("cloud", "{case}"), ("points", "{n}"),
                  ("mean abs angle, rad", lambda r: r["error"][:90] if r.get("error")
                   else _cell(r, "rad", ".4f")),
                  ("flipped (% of true)", lambda r: "-" if r.get("error")
                   else f"{r['flipped']} ({r['flip_pct']:.3f}%)"),
                  ("kept", lambda r: r.get("method", "-")),
                  ("anchor on the true mesh, rad", lambda r: _cell(r, "anchor_rad", ".4f")
                   + f" ({r['anchor_method']})"),
                  ("anchor flipped", "{anchor_flipped}"),
                  ("anchor on the clean mesh, rad", lambda r: _cell(r, "clean_rad", ".4f")),
                  ("wall s", lambda r: _cell(r, "wall_s", ".1f")),
                  ("CPU s", lambda r: _cell(r, "cpu_s", ".1f")),
                  ("peak GB", lambda r: _cell(r, "rss_gb", ".2f"))],
                [r for r in rows if not r.get("seed")]), "",
        *verdicts([r for r in rows if not r.get("seed")]), "",
        *seed_lines(rows), "",
        "### The method against the alternatives (in process)", "",
        "On the true meshes and on the cloud's local mesh as `--domain sphere` closes it; "
        "angle distortion on the clean true triangles, flips of them, seconds of the map "
        "alone.", "",
        *H.table([("mesh", "{case}"), ("method", "{method}"), ("rad", "{rad:.4f}"),
                  ("flipped", "{flipped}"), ("seconds", "{seconds:.2f}")], methods),
    ])


def main(argv=None) -> int:
    p = H.parser(__doc__)
    p.add_argument("--shapes", nargs="*", default=list(SHAPES))
    p.add_argument("--samplings", nargs="*", default=list(SAMPLINGS))
    p.add_argument("--sizes", nargs="*", type=int, default=[5000, 50_000])
    p.add_argument("--large", type=int, default=200_000,
                   help="points of the one large run (0: none)")
    p.add_argument("--large-sampling", nargs="*", default=list(SAMPLINGS), choices=SAMPLINGS,
                   help="its samplings (default: both)")
    p.add_argument("--noise-seeds", type=int, default=3,
                   help="seeds of each noisy cloud (0, 1, ...; default 3): the noise's draw "
                        "decides most of the flips")
    p.add_argument("--head-noise-seeds", type=int, default=2,
                   help="seeds of the david head with depth noise (default 2; 0: none)")
    p.add_argument("--no-methods", action="store_true",
                   help="skip part 2 (the methods on true and local meshes)")
    args = p.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        rows, methods = run_all(args, Path(tmp))
    H.write_section(args.out, "bench_sphere", render(rows, methods, argv))
    return 0


if __name__ == "__main__":
    sys.exit(main())
