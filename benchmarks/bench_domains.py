"""Benchmark the domain targets of issue 11: the disk, the smiling face and the car.

Every pcgeom row runs the CLI as a user would (``python -m pcgeom param INPUT --domain D
--quiet --json``) in a subprocess, timed from the outside (start-up, reading, training,
evaluation and writing included). Angle distortion and flips come from the CLI's own report
on the input's reference triangles (never used for training), the Hausdorff distance to the
domain from :func:`pcgeom.metrics.domain_hausdorff` (the mapped points; exact outside, 200 000
samples inside) and :func:`pcgeom.metrics.surface_hausdorff` (the mapped reference triangles,
the paper's ``d_H(f(M), Omega)``, without the floor of the cloud's own sampling gaps).

- Three peaks (the built-in ``peaks3``) and ``face_human_choi`` onto the disk with ``fast``,
  seeds 0, 1, 2 (medians), beside libigl's harmonic disk map on the true mesh
  (:func:`pcgeom.apps.baselines.harmonic_disk`, scored by the same ``map_report``). The face
  runs twice: the file as it is (no normals: they are estimated) and with the mesh's vertex
  normals, as a scanner writes them.
- ``face_3holes_small_choi`` onto ``smile`` (``fast``: the local mesh laid on the domain,
  holes on holes, then refined), the same seeds: whether each hole of the cloud lands on one
  eye or the mouth (``examples/face_smile.py``'s test, on the map file the CLI wrote), the
  Hausdorff distance and the angle distortion. When the holes do not all land, a second run
  with the holes' boundary points as landmarks onto the domain's hole boundaries.
- The analytic car shell of ``examples/car.py`` onto ``car``, the same seeds, without and with
  the window-edge landmarks (134 points to 400 targets): landmark Hausdorff, domain Hausdorff,
  angle.
- ``--compare networks`` adds the smile and the car by another preset (first seed only), in
  the same run.

The three groups (disk, smile, car) run as three concurrent streams of subprocesses
(``--streams 1`` for one after the other): the smile and car runs take many minutes each on
two shared cores. Run it with ``OMP_NUM_THREADS=1`` so the streams do not oversubscribe the
cores; the section records the setting and the load average.

The section ``bench_domains`` of BENCHMARKS.md is replaced.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
DATA_DIR = REPO.parent / "shared" / "data"
sys.path.insert(0, os.fspath(REPO))
sys.path.insert(0, os.fspath(REPO / "examples"))
ENV = dict(os.environ)
ENV["PYTHONPATH"] = os.pathsep.join(
    [os.fspath(REPO)] + ([os.environ["PYTHONPATH"]] if os.environ.get("PYTHONPATH") else []))

import numpy as np  # noqa: E402
from sections import write_section  # noqa: E402

TARGETS = {
    # surface -> (max Hausdorff to the disk, max rad, max flips, max wall s), issue 11
    "peaks3": (0.01, 0.06, 0, 120.0),
    "face_human_choi": (0.02, 0.08, None, None),
}


def log(msg: str) -> None:
    print(f"[bench_domains] {msg}", file=sys.stderr, flush=True)


def run_param(src, domain: str, out: Path, seed: int = 0, preset: str = "fast",
              landmarks: Path | None = None) -> dict:
    """One CLI run: wall seconds and its JSON summary. ``src`` is a path or ``example:NAME``."""
    src = os.fspath(src)
    where = ["--example", src.split(":", 1)[1]] if src.startswith("example:") else [src]
    cmd = [sys.executable, "-m", "pcgeom", "param", *where, "--preset", preset, "--domain",
           domain, "--seed", str(seed), "--out", os.fspath(out), "--quiet", "--json"]
    if landmarks is not None:
        cmd += ["--landmarks", os.fspath(landmarks)]
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, env=ENV, text=True)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)}: exit {proc.returncode}: {proc.stderr.strip()[-300:]}")
    summary = json.loads(proc.stdout.strip().splitlines()[-1])
    ev = summary["evaluation"] or {}
    log(f"{Path(src).name} -> {domain} seed {seed}{' +landmarks' if landmarks else ''}: "
        f"{wall:.1f} s, H {summary['domain_hausdorff']:.4f}, "
        f"{ev.get('mean_abs_angle_rad', float('nan')):.4f} rad")
    return {"wall_s": wall, "summary": summary, "out": out, "seed": seed}


def _row(name: str, method: str, runs: list[dict], needs_mesh: str) -> dict:
    ev = [r["summary"]["evaluation"] for r in runs]
    return {
        "surface": name, "method": method, "needs_mesh": needs_mesh, "runs": len(runs),
        "rad": statistics.median(e["mean_abs_angle_rad"] for e in ev),
        "rad_range": (min(e["mean_abs_angle_rad"] for e in ev),
                      max(e["mean_abs_angle_rad"] for e in ev)),
        "flipped": statistics.median(e["flipped"] for e in ev),
        "flipped_max": max(e["flipped"] for e in ev),
        "n_faces": ev[0]["n_faces"],
        "hausdorff": statistics.median(r["summary"]["domain_hausdorff"] for r in runs),
        "hausdorff_max": max(r["summary"]["domain_hausdorff"] for r in runs),
        "surface_h": statistics.median(r["summary"]["surface_hausdorff"] for r in runs),
        "surface_h_max": max(r["summary"]["surface_hausdorff"] for r in runs),
        "wall_s": statistics.median(r["wall_s"] for r in runs),
        "train_s": statistics.median(r["summary"]["seconds"] for r in runs),
    }


def refined_row(name: str, src, mesh, kind: str, seed: int) -> dict:
    """``fast`` with ``LocalMeshConfig.disk_refine`` (Python only), one seed, in this
    process: the conformal disk map refined with HAND onto the disk sample."""
    import dataclasses

    import pcgeom
    from pcgeom.apps.evaluate import map_report
    from pcgeom.examples import load_example

    fast = pcgeom.get_preset("fast")
    config = dataclasses.replace(fast, local_mesh=dataclasses.replace(fast.local_mesh,
                                                                      disk_refine=True))
    src = os.fspath(src)
    if src.startswith("example:"):
        points, normals = load_example(src.split(":", 1)[1])[0], None
    else:
        cloud = pcgeom.read_points(src)
        points, normals = cloud.points, cloud.normals
    t0 = time.perf_counter()
    result = pcgeom.parametrize(points, "disk", config=config, seed=seed, progress=False,
                                normals=normals)
    seconds = time.perf_counter() - t0
    rep = map_report(result.uv, pcgeom.get_domain("disk"), *mesh)
    log(f"{name} ({kind}) disk_refine seed {seed}: {seconds:.1f} s, "
        f"H {rep['domain_hausdorff']:.4f}, {rep['mean_abs_angle_rad']:.4f} rad")
    return _report_row(name, f"pcgeom `fast` + `disk_refine` ({kind}; in process)", "no", rep,
                       seconds, train_s=seconds)


def _report_row(name: str, method: str, needs_mesh: str, rep: dict, seconds: float, *,
                train_s: float | None) -> dict:
    """A one-run disk row from a :func:`pcgeom.apps.evaluate.map_report`."""
    return {"surface": name, "method": method, "needs_mesh": needs_mesh, "runs": 1,
            "rad": rep["mean_abs_angle_rad"], "rad_range": None, "flipped": rep["flipped"],
            "flipped_max": rep["flipped"], "n_faces": rep["n_faces"],
            "hausdorff": rep["domain_hausdorff"], "hausdorff_max": rep["domain_hausdorff"],
            "surface_h": rep["surface_hausdorff"], "surface_h_max": rep["surface_hausdorff"],
            "wall_s": seconds, "train_s": train_s}


def disk_rows(seeds, work: Path, refine: bool = True) -> list[dict]:
    from pcgeom import get_domain, read_points
    from pcgeom.apps.baselines import harmonic_disk
    from pcgeom.apps.evaluate import map_report
    from pcgeom.examples import load_example
    from pcgeom.io import write_ply_atomic

    disk = get_domain("disk")
    rows = []
    inputs = [("peaks3", "example:peaks3", load_example("peaks3"), "no normals")]
    face = DATA_DIR / "face_human_choi.ply"
    if face.exists():
        cloud = read_points(face)
        inputs.append(("face_human_choi", face, (cloud.points, cloud.faces),
                       "no normals"))
        import trimesh

        normals = np.asarray(trimesh.Trimesh(cloud.points, cloud.faces, process=False)
                             .vertex_normals, dtype=np.float64)
        with_normals = work / "face_human_choi_normals.ply"
        write_ply_atomic(with_normals, cloud.points, cloud.faces, normals=normals)
        inputs.append(("face_human_choi", with_normals, (cloud.points, cloud.faces),
                       "the mesh's vertex normals"))
    else:
        log(f"{face} is missing: face_human_choi left out")
    for name, src, (V, F), kind in inputs:
        runs = [run_param(src, "disk", work / f"{name}_{len(rows)}_{s}.npz", seed=s)
                for s in seeds]
        rows.append(_row(name, f"pcgeom `fast` ({kind})", runs, "no"))
        if refine:
            rows.append(refined_row(name, src, (V, F), kind, seeds[0]))
        if kind == "no normals":
            t0 = time.perf_counter()
            U = harmonic_disk(V, F)
            seconds = time.perf_counter() - t0
            rep = map_report(U, disk, V, F)
            rows.append(_report_row(name, "harmonic disk map (libigl, true mesh)",
                                    "yes (+ boundary)", rep, seconds, train_s=None))
    return rows


def smile_rows(seeds, work: Path, landmarks: bool = True, presets=("fast",)) -> list[dict]:
    from face_smile import cloud_holes, domain_holes, hole_landmarks, landing

    from pcgeom import ParamResult, get_domain, read_points

    src = DATA_DIR / "face_3holes_small_choi.ply"
    if not src.exists():
        log(f"{src} is missing: the smile rows are left out")
        return []
    cloud = read_points(src)
    smile = get_domain("smile")
    holes, targets = cloud_holes(cloud.points, cloud.faces), domain_holes(smile)
    rows = []

    def row(runs, method):
        maps = [ParamResult.load(run["out"]).uv for run in runs]
        lands = [landing(U, holes, targets) for U in maps]
        evs = [run["summary"]["evaluation"] for run in runs]
        rows.append({"method": method, "seeds": [run["seed"] for run in runs],
                     "landing": lands[0], "all_land": [land["all_land"] for land in lands],
                     "wall_s": statistics.median(run["wall_s"] for run in runs),
                     "hausdorff": statistics.median(run["summary"]["domain_hausdorff"]
                                                    for run in runs),
                     "surface_h": statistics.median(run["summary"]["surface_hausdorff"]
                                                    for run in runs),
                     "rad": statistics.median(e["mean_abs_angle_rad"] for e in evs),
                     "flipped": statistics.median(e["flipped"] for e in evs),
                     "n_faces": evs[0]["n_faces"]})
        return maps[0], lands[0]

    for preset in presets:
        runs = [run_param(src, "smile", work / f"smile_{preset}_{s}.npz", seed=s, preset=preset)
                for s in (seeds if preset == "fast" else seeds[:1])]
        U, land = row(runs, f"pcgeom `{preset}`")
        if landmarks and not land["all_land"]:
            pairs, names = hole_landmarks(cloud.points, U, holes, targets)
            marks = work / f"smile_landmarks_{preset}.json"
            marks.write_text(json.dumps([{"points": P.tolist(), "targets": Q.tolist()}
                                         for P, Q in pairs]))
            row([run_param(src, "smile", work / f"smile_lm_{preset}.npz", seed=seeds[0],
                           preset=preset, landmarks=marks)],
                f"pcgeom `{preset}`, hole boundaries as landmarks (" + ", ".join(names) + ")")
    return rows


def car_rows(seeds, n: int, work: Path, presets=("fast",)) -> list[dict]:
    from car import TARGET_LINES, TARGET_SPACING, car_shell

    from pcgeom import ParamResult
    from pcgeom.io import write_ply_atomic
    from pcgeom.io.landmarks import sample_polyline
    from pcgeom.metrics import hausdorff

    V, F, edges = car_shell(n, seed=0)
    shell = work / "car_shell.ply"
    write_ply_atomic(shell, V, F)
    marks = work / "car_landmarks.json"
    marks.write_text(json.dumps([{"indices": edges.tolist(), "polylines": TARGET_LINES,
                                  "spacing": TARGET_SPACING}]))
    targets = np.vstack([sample_polyline(line, TARGET_SPACING) for line in TARGET_LINES])
    rows = []
    for preset in presets:
        for method, lm in ((f"pcgeom `{preset}`", None),
                           (f"pcgeom `{preset}`, window-edge landmarks", marks)):
            runs = [run_param(shell, "car", work / f"car_{len(rows)}_{s}.npz", seed=s,
                              preset=preset, landmarks=lm)
                    for s in (seeds if preset == "fast" else seeds[:1])]
            fits = [hausdorff(ParamResult.load(run["out"]).uv[edges], targets) for run in runs]
            evs = [run["summary"]["evaluation"] for run in runs]
            rows.append({"method": method, "points": len(V), "landmarks": len(edges),
                         "targets": len(targets), "seeds": [run["seed"] for run in runs],
                         "landmark_fit": statistics.median(fits),
                         "hausdorff": statistics.median(run["summary"]["domain_hausdorff"]
                                                        for run in runs),
                         "surface_h": statistics.median(run["summary"]["surface_hausdorff"]
                                                        for run in runs),
                         "rad": statistics.median(e["mean_abs_angle_rad"] for e in evs),
                         "flipped": statistics.median(e["flipped"] for e in evs),
                         "n_faces": evs[0]["n_faces"],
                         "wall_s": statistics.median(run["wall_s"] for run in runs)})
    return rows


def verdicts(rows) -> list[str]:
    out = []
    for name, (h_max, rad_max, flips_max, wall_max) in TARGETS.items():
        for r in rows:
            if r["surface"] != name or not r["method"].startswith("pcgeom"):
                continue
            checks = [f"Hausdorff of the mapped points {r['hausdorff']:.4f} (want <= {h_max}): "
                      f"{'PASS' if r['hausdorff'] <= h_max else 'FAIL'}",
                      f"of the mapped surface {r['surface_h']:.4f} in the worst seed "
                      f"{r['surface_h_max']:.4f} (want <= {h_max}): "
                      f"{'PASS' if r['surface_h_max'] <= h_max else 'FAIL'}",
                      f"angle {r['rad']:.4f} rad (want <= {rad_max}): "
                      f"{'PASS' if r['rad'] <= rad_max else 'FAIL'}"]
            if flips_max is not None:
                checks.append(f"flips {r['flipped_max']} in the worst seed (want "
                              f"<= {flips_max}): "
                              f"{'PASS' if r['flipped_max'] <= flips_max else 'FAIL'}")
            if wall_max is not None:
                checks.append(f"wall {r['wall_s']:.1f} s (want <= {wall_max:g} s): "
                              f"{'PASS' if r['wall_s'] <= wall_max else 'FAIL'}")
            out.append(f"- {name}, {r['method']}: " + "; ".join(checks))
    return out


def floors(disk) -> list[str]:
    """What no map of the clouds can beat: the covering radius of their points on the disk,
    and the gap a conformal rim leaves."""
    import math

    from pcgeom import read_points
    from pcgeom.examples import load_example

    lines = ["What bounds the Hausdorff distance of the points to the disk (the surface's "
             "has no such floor): the points of a map cannot cover it better "
             "than N points in the densest arrangement (a hexagonal grid, covering radius "
             "sqrt(2 pi / (sqrt 3 N)) / sqrt 3), and a map whose rim lies on the circle leaves "
             "the arc between two rim points uncovered unless the rim triangles are crushed:"]
    for name in dict.fromkeys(r["surface"] for r in disk):
        if name == "peaks3":
            V, F = load_example("peaks3")
        else:
            path = DATA_DIR / f"{name}.ply"
            if not path.exists():
                continue
            cloud = read_points(path)
            V, F = cloud.points, cloud.faces
        import igl

        n, rim = len(V), len(igl.boundary_loop(np.ascontiguousarray(F)))
        cover = math.sqrt(2 * math.pi / (math.sqrt(3) * n)) / math.sqrt(3)
        h_max = TARGETS.get(name, (None,))[0]
        lines.append(f"- {name}: {n} points, covering radius at best {cover:.4f}"
                     + (f" (target {h_max}: " + ("not ruled out" if cover <= h_max else
                                                  "out of reach for any map") + ")"
                        if h_max is not None else "")
                     + f"; {rim} rim vertices, an arc of 2 pi / {rim} between two evenly spread "
                       f"ones, half a chord {math.sin(math.pi / rim):.4f}; "
                     + "an area-preserving map keeps the cloud's own gaps: "
                       f"{_own_gap(V, F):.4f} (the largest distance from its surface to its "
                       "points, scaled by sqrt(pi / area))")
    return lines


def _own_gap(V: np.ndarray, F: np.ndarray, n: int = 400_000) -> float:
    """The largest gap of the cloud ``V`` on its own surface (``n`` area-uniform samples of
    the true triangles, seed 0), scaled to a unit disk of the surface's area: the Hausdorff
    distance to the disk of a map that preserves area exactly. A conformal map, which
    stretches some parts more than others, leaves larger gaps."""
    import trimesh
    from scipy.spatial import cKDTree

    surface = trimesh.Trimesh(V, F, process=False)
    samples, _ = trimesh.sample.sample_surface(surface, n, seed=0)
    gap, _ = cKDTree(V).query(samples)
    return float(gap.max() * np.sqrt(np.pi / surface.area))


def args_streams(args) -> str:
    """The ``--streams`` value in a command line (default 3)."""
    return args[args.index("--streams") + 1] if "--streams" in args else "3"


def render(disk, smile, car, args, started: float) -> str:
    import platform

    import torch

    load = os.getloadavg() if hasattr(os, "getloadavg") else None
    out = ["## Domains: the disk, the smiling face and the car (`benchmarks/bench_domains.py`)",
           "",
           f"- date: {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}; {os.cpu_count()} "
           f"cores, Python {platform.python_version()}, torch {torch.__version__}; "
           f"OMP_NUM_THREADS={os.environ.get('OMP_NUM_THREADS', '(unset)')}, "
           f"{args_streams(args)} concurrent stream(s); "
           f"{(time.time() - started) / 60:.0f} min in all; load average at end "
           f"{[round(x, 2) for x in load] if load else 'n/a'}"
           + (" (above the core count: other work competed, and wall times are inflated)"
              if load and max(load) > (os.cpu_count() or 1) else ""),
           f"- command: `python benchmarks/bench_domains.py {' '.join(args)}`".rstrip(),
           "- wall: the whole `python -m pcgeom param ... --quiet --json` subprocess; angles "
           "and flips on the reference triangles (never used for training); Hausdorff: "
           "`pcgeom.metrics.domain_hausdorff` between the mapped points and the domain "
           "(exact outside the domain, 200 000 samples inside: resolution about 0.004 on the "
           "unit disk); surface Hausdorff: `pcgeom.metrics.surface_hausdorff` between the "
           "mapped reference triangles and the domain, the paper's `d_H(f(M), Omega)` (its "
           "HAND theorem), which has no floor from the cloud's own sampling gaps (same "
           "resolution)", ""]
    if disk:
        out += ["Onto the unit disk, `fast` (the free map followed by the Riemann map of its "
                "region onto the disk; "
                "deterministic on one machine), medians over the seeds:", "",
                "| surface | method | needs mesh? | runs | mean abs angle, rad [min-max] | "
                "flips, median (worst) | Hausdorff of the points to the disk, median (worst) | "
                "of the surface, median (worst) | wall s |",
                "|---|---|---|---|---|---|---|---|---|"]
        for r in disk:
            rng = (f" [{r['rad_range'][0]:.4f}-{r['rad_range'][1]:.4f}]"
                   if r["rad_range"] else "")
            out.append(f"| {r['surface']} | {r['method']} | {r['needs_mesh']} | {r['runs']} | "
                       f"{r['rad']:.4f}{rng} | {r['flipped']:g} ({r['flipped_max']}) of "
                       f"{r['n_faces']} | {r['hausdorff']:.4f} ({r['hausdorff_max']:.4f}) | "
                       f"{r['surface_h']:.4f} ({r['surface_h_max']:.4f}) | "
                       f"{r['wall_s']:.1f} |")
        out += ["", "Targets (issue 11, on the medians):", "", *verdicts(disk), "",
                *floors(disk), ""]
    if smile:
        out += ["`face_3holes_small_choi` (5053 points, three holes) onto `smile` (`fast`: the "
                "local mesh laid on the domain, its holes on the domain's holes, then refined; "
                "medians over the seeds). A hole *lands* when the closed polygon of its "
                "mapped boundary points encloses one domain hole and no other, one to one "
                "(`examples/face_smile.py`, `landing`):", "",
                "| method | seeds | every hole lands, per seed | holes, first seed: nearest "
                "domain hole (encloses; Hausdorff of the mapped loop to its boundary) | "
                "Hausdorff to the domain, points (surface) | mean abs angle, rad | flips | "
                "wall s |", "|---|---|---|---|---|---|---|---|"]
        for r in smile:
            holes = "; ".join(f"{h['nearest']} ({', '.join(h['encloses']) or 'none'}; "
                              f"{h['hausdorff']:.3f})" for h in r["landing"]["holes"])
            lands = ", ".join("yes" if a else "NO" for a in r["all_land"])
            out.append(f"| {r['method']} | {' '.join(map(str, r['seeds']))} | {lands} | "
                       f"{holes} | {r['hausdorff']:.4f} ({r['surface_h']:.4f}) | "
                       f"{r['rad']:.4f} | {r['flipped']:g} "
                       f"of {r['n_faces']} | {r['wall_s']:.1f} |")
        out += ["", "Target (issue 11): every hole lands: " + (
            "PASS" if all(all(r["all_land"]) for r in smile if r["method"] == "pcgeom `fast`")
            else "FAIL") + " (`fast`, every seed)", ""]
    if car:
        r0 = car[0]
        out += [f"The analytic car shell of `examples/car.py` ({r0['points']} points) onto "
                f"`car`, medians over the seeds: landmark fit is the Hausdorff distance "
                f"between the {r0['landmarks']} mapped window-edge points (one set) and the "
                f"{r0['targets']} targets on [-0.5, 0.5] x {{-0.25, 0.25}}:", "",
                "| method | seeds | landmark Hausdorff | Hausdorff to the domain, points "
                "(surface) | mean abs angle, rad | flips | wall s |",
                "|---|---|---|---|---|---|---|"]
        for r in car:
            out.append(f"| {r['method']} | {' '.join(map(str, r['seeds']))} | "
                       f"{r['landmark_fit']:.4f} | {r['hausdorff']:.4f} "
                       f"({r['surface_h']:.4f}) | {r['rad']:.4f} | "
                       f"{r['flipped']:g} of {r['n_faces']} | {r['wall_s']:.1f} |")
        out.append("")
    return "\n".join(out)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seeds", nargs="*", type=int, default=[0, 1, 2],
                   help="seeds of the disk runs (default: 0 1 2)")
    p.add_argument("--skip", nargs="*", default=[], choices=["disk", "smile", "car"])
    p.add_argument("--car-points", type=int, default=2500,
                   help="domain samples of the car shell (examples/car.py; default: 2500)")
    p.add_argument("--smile-landmarks", choices=("auto", "never"), default="auto",
                   help="auto: a second smile run with the holes as landmarks when the first "
                        "does not land every hole (default: auto)")
    p.add_argument("--compare", nargs="*", default=[], metavar="PRESET",
                   help="also run the smile and the car with these presets, first seed only "
                        "(e.g. networks: the networks of the paper; tens of minutes a run)")
    p.add_argument("--no-refine", action="store_true",
                   help="leave out the disk rows with LocalMeshConfig.disk_refine")
    p.add_argument("--streams", type=int, default=3,
                   help="groups (disk, smile, car) run at once (default: 3)")
    p.add_argument("--out", type=Path, default=REPO / "BENCHMARKS.md")
    p.add_argument("--json", type=Path, help="also write the rows as JSON")
    args = p.parse_args(argv)
    started = time.time()
    from concurrent.futures import ThreadPoolExecutor

    with tempfile.TemporaryDirectory() as tmp, ThreadPoolExecutor(args.streams) as pool:
        work = Path(tmp)
        presets = ("fast", *args.compare)
        jobs = {"smile": lambda: smile_rows(args.seeds, work, args.smile_landmarks == "auto",
                                            presets),
                "car": lambda: car_rows(args.seeds, args.car_points, work, presets),
                "disk": lambda: disk_rows(args.seeds, work, not args.no_refine)}
        futures = {name: pool.submit(job) for name, job in jobs.items()
                   if name not in args.skip}
        rows = {name: futures[name].result() if name in futures else [] for name in jobs}
        disk, smile, car = rows["disk"], rows["smile"], rows["car"]
    if args.json:
        args.json.write_text(json.dumps({"disk": disk, "smile": smile, "car": car}, indent=2,
                                        default=float))
    write_section(args.out, "bench_domains",
                  render(disk, smile, car, argv if argv is not None else sys.argv[1:], started))
    log(f"wrote the bench_domains section of {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
