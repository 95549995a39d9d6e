"""Benchmark landmarks (issue 40): targets a disk automorphism reaches, targets off it, many
landmarks on 14k points, the car's window lines, and pinned landmarks on the free boundary.

Each case runs ``pcgeom.parametrize`` as a user calls it, in a child process whose
``PYTHONPATH`` is this checkout, and, with ``--before DIR`` (a checkout of an earlier commit,
e.g. ``git worktree add /tmp/before fc526ce``), the same case in that checkout right after,
so that before and after are timed side by side under the same load. Landmark targets onto
the disk: the landmark-free disk map of the same code at the landmark points, moved by a
random disk automorphism ``z -> e^(it) (z - c) / (1 - conj(c) z)`` (``|c|`` up to
:data:`MAX_C`; landmark points drawn at random among those within :data:`INNER` of the centre), and for the second group moved again by :data:`OFF` in a random direction
(kept inside the disk). Angle error and flips on the true triangles; the landmark error is
the largest distance of a landmark point to its target. Free boundary: targets near libigl's
free LSCM of the true mesh (scaled to a unit box, moved by 0.03 at random), pinned by
pcgeom on the bare points and by ``igl.lscm(V, F, b, bc)`` on the true mesh.
Replaces the section ``bench_landmarks`` of BENCHMARKS.md.
"""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import harness as H
import numpy as np

MAX_C = 0.4
"""Largest ``|c|`` of the random automorphisms."""

INNER = 0.9
"""Landmark points are drawn among those this close to the centre in the landmark-free map."""

OFF = 0.05
"""Distance of the off-image targets from the automorphism's image."""

RATIO_REACH, RATIO_OFF, LANDMARK_MISS, FLIP_PCT, SECONDS_14K, FREE_RATIO = \
    1.1, 1.5, 0.005, 0.05, 20.0, 1.2
"""Issue 40's bounds."""


# --------------------------------------------------------------------------- the child


def _surface(name: str):
    if name.startswith("peaks3:"):
        from pcgeom.examples import peaks_surface

        return peaks_surface("peaks3", int(name.split(":")[1]))
    s = H.load_surface(name)
    return s.V, s.F


def _score(U, V, F, rows, Q) -> dict:
    from pcgeom.metrics import angle_distortion

    a = angle_distortion(V, F, U)
    return {"rad": a.mean_abs, "flipped": a.flipped, "flip_pct": 100.0 * a.flipped / len(F),
            "miss": float(np.abs(U[rows] - Q).max()) if rows is not None else None}


def _disk_case(job: dict) -> dict:
    import pcgeom

    V, F = _surface(job["surface"])
    free, t_free = H.timed(pcgeom.parametrize, V, "disk", progress=False)
    rng = np.random.default_rng(job["seed"])
    # Inside the surface: a rim point slides on the circle and cannot reach a target off it.
    inner = np.flatnonzero(np.linalg.norm(free.uv, axis=1) <= INNER)
    rows = rng.choice(inner, job["k"], replace=False)
    c = MAX_C * np.sqrt(rng.random()) * np.exp(2j * np.pi * rng.random())
    z = free.uv[rows, 0] + 1j * free.uv[rows, 1]
    w = np.exp(2j * np.pi * rng.random()) * (z - c) / (1 - np.conj(c) * z)
    if job["off"]:
        w = w + job["off"] * np.exp(2j * np.pi * rng.random(len(w)))
        w = np.where(np.abs(w) > 0.98, 0.98 * w / np.abs(w), w)
    Q = np.column_stack([w.real, w.imag])
    result, seconds = H.timed(pcgeom.parametrize, V, "disk", progress=False,
                              landmarks=[(V[[i]], Q[[j]]) for j, i in enumerate(rows)])
    base = _score(free.uv, V, F, None, None)
    return {**_score(result.uv, V, F, rows, Q), "wall_s": seconds, "free_rad": base["rad"],
            "free_flipped": base["flipped"], "free_s": t_free, "points": len(V),
            "bend": result.history[0].get("bend", "-")}


def _car_case(job: dict) -> dict:
    import pcgeom
    from pcgeom.io.landmarks import sample_polyline
    from pcgeom.metrics import hausdorff
    from pcgeom.synthetic import CAR_TARGET_LINES, CAR_TARGET_SPACING, car_shell

    V, F, edges = car_shell(job["points"], seed=job["seed"])
    targets = np.vstack([sample_polyline(line, CAR_TARGET_SPACING)
                         for line in CAR_TARGET_LINES])
    result, seconds = H.timed(pcgeom.parametrize, V, "car", progress=False,
                              landmarks=[(V[edges], targets)])
    return {**_score(result.uv, V, F, None, None), "wall_s": seconds, "points": len(V),
            "fit": hausdorff(result.uv[edges], targets), "landmarks": len(edges),
            "bend": result.history[0].get("bend", "-")}


def _free_case(job: dict) -> dict:
    import warnings

    import igl
    import pcgeom

    V, F = _surface(job["surface"])
    L0 = igl.lscm(V, F, np.array([0, len(V) - 1]), np.array([[0.0, 0.0], [1.0, 0.0]]))[0]
    rng = np.random.default_rng(job["seed"])
    rows = rng.choice(len(V), job["k"], replace=False)
    Q = (L0[rows] - L0.mean(axis=0)) / np.ptp(L0, axis=0).max()
    Q = Q + 0.03 * rng.standard_normal(Q.shape)
    if job.get("swap"):
        d = np.linalg.norm(Q[:, None] - Q[None], axis=2) + 9 * np.eye(len(Q))
        a, b = np.unravel_index(np.argmin(d), d.shape)
        Q[[a, b]] = Q[[b, a]]
    ref, t_ref = H.timed(lambda: igl.lscm(V, F, rows.astype(np.int64), Q)[0])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result, seconds = H.timed(pcgeom.parametrize, V, "free", progress=False,
                                  landmarks=[(V[[i]], Q[[j]]) for j, i in enumerate(rows)])
    said = [str(w.message) for w in caught if "landmarks on the free boundary" in str(w.message)]
    theirs = _score(ref, V, F, rows, Q)
    return {**_score(result.uv, V, F, rows, Q), "wall_s": seconds, "points": len(V),
            "igl_rad": theirs["rad"], "igl_flipped": theirs["flipped"], "igl_s": t_ref,
            "how": result.history[0].get("free_landmarks", {}).get("landmarks", "-"),
            "warning": said[0] if said else ""}


CASES = {"disk": _disk_case, "car": _car_case, "free": _free_case}


def worker(job: dict) -> None:
    # harness put this checkout first on sys.path: the tree asked for goes before it.
    sys.path.insert(0, os.environ["BENCH_TREE"])
    import pcgeom
    import torch

    assert Path(pcgeom.__file__).resolve().is_relative_to(Path(os.environ["BENCH_TREE"]))

    torch.set_num_threads(1)
    try:
        out = CASES[job["case"]](job)
    except Exception as exc:  # noqa: BLE001 - the before checkout may refuse a case
        out = {"error": f"{type(exc).__name__}: {str(exc).splitlines()[0][:160]}"}
    print("RESULT " + json.dumps(out, default=float))


# --------------------------------------------------------------------------- the parent


def run_job(tree: Path, job: dict) -> dict:
    env = {**os.environ, "BENCH_TREE": os.fspath(tree), "OMP_NUM_THREADS": "1",
           "MKL_NUM_THREADS": "1", "PYTHONWARNINGS": "ignore"}
    t = time.perf_counter()
    done = subprocess.run([sys.executable, os.fspath(Path(__file__).resolve()), "--worker",
                           json.dumps(job)], env=env, capture_output=True, text=True,
                          cwd=os.fspath(Path(__file__).resolve().parent))
    line = [x for x in done.stdout.splitlines() if x.startswith("RESULT ")]
    out = json.loads(line[-1][7:]) if line else {
        "error": f"exit {done.returncode}: {done.stderr.strip().splitlines()[-1:]}"}
    H.log(f"{tree.name} {job}: {time.perf_counter() - t:.0f} s "
          + ", ".join(f"{k} {v:.4g}" if isinstance(v, float) else f"{k} {v}"
                      for k, v in out.items() if k not in ("warning",)))
    return out


def med(runs, key):
    values = [r[key] for r in runs if key in r and r[key] is not None]
    return statistics.median(values) if values else None


def group(trees, jobs) -> list[dict]:
    """Each job in each tree, the trees one after the other per job."""
    rows = []
    for job in jobs:
        for label, tree, seeds in trees:
            runs = [run_job(tree, {**job, "seed": s}) for s in seeds]
            rows.append({"code": label, **job, "runs": runs})
    return rows


def main(argv=None) -> int:
    p = H.parser(__doc__)
    p.add_argument("--worker", help=argparse_hidden())
    p.add_argument("--before", type=Path, help="a checkout of the code to compare with")
    p.add_argument("--seeds", nargs="*", type=int, default=[0, 1, 2])
    p.add_argument("--before-seeds", nargs="*", type=int, default=[0])
    p.add_argument("--rows", type=Path, help="render the rows a run saved, running nothing")
    args = p.parse_args(argv)
    if args.worker:
        worker(json.loads(args.worker))
        return 0
    started = time.perf_counter()
    if args.rows:  # render again from a run's rows
        groups = json.loads(args.rows.read_text())
        H.write_section(args.out, "bench_landmarks", render(*groups, args, argv, started))
        return 0
    here = Path(__file__).resolve().parents[1]
    after = ("after", here, args.seeds)
    both = [after] + ([("before", args.before, args.before_seeds)] if args.before else [])
    surfaces = [s for s in ("face_3holes_small_choi", "peaks_three_cgal") if H.available(s)]
    reach = group(both, [{"case": "disk", "surface": s, "k": 4, "off": 0.0} for s in surfaces])
    off = group(both, [{"case": "disk", "surface": s, "k": 4, "off": OFF} for s in surfaces])
    big = group([after], [{"case": "disk", "surface": "peaks3:118", "k": k, "off": 0.0}
                          for k in (4, 20, 100)])
    big += group(both, [{"case": "disk", "surface": "peaks3:118", "k": 4, "off": OFF}])
    if H.available("face_human_choi"):
        big += group([("after", here, args.seeds[:1])],
                     [{"case": "disk", "surface": "face_human_choi", "k": k, "off": 0.0}
                      for k in (4, 100)])
    car = group(both, [{"case": "car", "points": 2500}])
    free = group([("after", here, args.seeds)],
                 [{"case": "free", "surface": s, "k": k}
                  for s in ["peaks3:76", *surfaces] for k in (4, 20)])
    free += group([("after", here, args.seeds[:1])],
                  [{"case": "free", "surface": "peaks3:40", "k": k, "swap": True}
                   for k in (6, 12)])
    rows = Path(tempfile.gettempdir()) / "bench_landmarks_rows.json"
    H.write_json(rows, [reach, off, big, car, free])
    H.log(f"rows in {rows} (--rows renders them again)")
    H.write_section(args.out, "bench_landmarks",
                    render(reach, off, big, car, free, args, argv, started))
    return 0


def argparse_hidden():
    import argparse

    return argparse.SUPPRESS


def _fmt(v, f=".4f"):
    return "-" if v is None else format(v, f)


def render(reach, off, big, car, free, args, argv, started) -> str:
    import platform

    def disk_table(rows):
        return H.table([
            ("surface", lambda r: f"{r['surface']} ({med(r['runs'], 'points')} points)"),
            ("landmarks", "{k}"), ("code", "{code}"), ("runs", lambda r: len(r["runs"])),
            ("angle, rad", lambda r: _fmt(med(r["runs"], "rad"))),
            ("landmark-free", lambda r: _fmt(med(r["runs"], "free_rad"))),
            ("ratio", lambda r: _fmt(_ratio(r), ".3f")),
            ("flipped", lambda r: _fmt(med(r["runs"], "flip_pct"), ".3f") + "%"),
            ("landmark miss", lambda r: _fmt(med(r["runs"], "miss"), ".2g")),
            ("bend", lambda r: "/".join(sorted({str(x.get("bend", "-")) for x in r["runs"]}))),
            ("wall s", lambda r: _fmt(med(r["runs"], "wall_s"), ".1f")),
            ("landmark-free s", lambda r: _fmt(med(r["runs"], "free_s"), ".1f"))], rows)

    return "\n".join([
        "## Landmarks (`benchmarks/bench_landmarks.py`)", "",
        *H.header(argv, f"{os.cpu_count()} cores, Python {platform.python_version()}",
                  f"load average at end {H.loadavg() or 'n/a'}",
                  f"{(time.perf_counter() - started) / 60:.0f} min"), "",
        "`fast`, bare points (no normals), one thread per process, medians over the runs "
        "(seeds); `before` is the checkout given by `--before`, run right after `after` for "
        "each case. Angle error and flips on the true triangles; the ratio is over the "
        "landmark-free disk map of the same code; landmark miss: the largest distance of a "
        "landmark point to its target; bend: how the map met them (`none`: the fitted disk "
        "automorphism alone, `linear`: its linear bend, `barrier`: the barrier map).", "",
        f"Targets a disk automorphism reaches (|c| up to {MAX_C}):", "", *disk_table(reach), "",
        f"The same targets moved {OFF} off that image:", "", *disk_table(off), "",
        "Many landmarks on 14k points (`peaks3` on a 118 x 118 grid, 13 924 points: no shared "
        "surface has 14k; face_human_choi, 17 157 points, beside it):", "", *disk_table(big),
        "",
        "The car shell (`pcgeom.synthetic.car_shell(2500)`) with its window edges as "
        "landmarks on the paper's lines (section 7.3); landmark fit is the Hausdorff distance "
        "of the mapped edges to the sampled lines:", "",
        *H.table([("code", "{code}"), ("runs", lambda r: len(r["runs"])),
                  ("angle, rad", lambda r: _fmt(med(r["runs"], "rad"))),
                  ("flipped", lambda r: _fmt(med(r["runs"], "flipped"), ".0f")),
                  ("landmark fit", lambda r: _fmt(med(r["runs"], "fit"))),
                  ("wall s", lambda r: _fmt(med(r["runs"], "wall_s"), ".1f"))], car), "",
        "Free boundary, landmarks pinned (`--domain free --landmarks`), against libigl's "
        "`lscm(V, F, b, bc)` with the same vertices pinned on the true mesh:", "",
        *H.table([("surface", lambda r: f"{r['surface']} ({med(r['runs'], 'points')})"),
                  ("pins", lambda r: f"{r['k']}" + (", two swapped" if r.get("swap") else "")),
                  ("runs", lambda r: len(r["runs"])),
                  ("pcgeom rad", lambda r: _fmt(med(r["runs"], "rad"))),
                  ("libigl rad", lambda r: _fmt(med(r["runs"], "igl_rad"))),
                  ("ratio", lambda r: _fmt(_free_ratio(r), ".3f")),
                  ("flipped (libigl)", lambda r: f"{_fmt(med(r['runs'], 'flipped'), '.0f')} "
                   f"({_fmt(med(r['runs'], 'igl_flipped'), '.0f')})"),
                  ("landmark miss", lambda r: _fmt(med(r["runs"], "miss"), ".2g")),
                  ("how", lambda r: "/".join(sorted({str(x.get("how")) for x in r["runs"]}))),
                  ("wall s", lambda r: _fmt(med(r["runs"], "wall_s"), ".1f"))], free), "",
        *[f"- warning, {r['surface']}, {r['k']} pins swapped: \"{r['runs'][0]['warning']}\""
          for r in free if r.get("swap") and r["runs"][0].get("warning")], "",
        "Issue 40's bounds (after):", "", *verdicts(reach, off, big, car, free)])


def _ratio(r):
    vals = [x["rad"] / x["free_rad"] for x in r["runs"] if "rad" in x and "free_rad" in x]
    return statistics.median(vals) if vals else None


def _free_ratio(r):
    vals = [x["rad"] / x["igl_rad"] for x in r["runs"] if "rad" in x and "igl_rad" in x]
    return statistics.median(vals) if vals else None


def _all(rows, pred) -> bool:
    runs = [x for r in rows if r["code"] == "after" for x in r["runs"]]
    return bool(runs) and all(pred(x) for x in runs)


def verdicts(reach, off, big, car, free) -> list[str]:
    def mark(ok):
        return "PASS" if ok else "FAIL"

    def disk(rows, bound, what):
        ok_ratio = _all(rows, lambda x: "rad" in x and x["rad"] <= bound * x["free_rad"])
        ok_miss = _all(rows, lambda x: "miss" in x and x["miss"] <= LANDMARK_MISS)
        ok_flip = _all(rows, lambda x: "flip_pct" in x and x["flip_pct"] < FLIP_PCT)
        worst = max((x["rad"] / x["free_rad"] for r in rows if r["code"] == "after"
                     for x in r["runs"] if "rad" in x), default=float("nan"))
        return (f"- {what}: every run within {bound}x the landmark-free angle (worst "
                f"{worst:.3f}x): {mark(ok_ratio)}; landmarks within {LANDMARK_MISS}: "
                f"{mark(ok_miss)}; under {FLIP_PCT}% flipped: {mark(ok_flip)}")

    lines = [disk(reach, RATIO_REACH, "targets an automorphism reaches"),
             disk(off, RATIO_OFF, f"targets {OFF} off that image")]
    peaks = [r for r in big if r["surface"] == "peaks3:118" and r["code"] == "after"]
    for r in peaks:
        s = med(r["runs"], "wall_s")
        lines.append(f"- 14k points, {r['k']} landmarks" + (f", {r['off']} off" if r["off"]
                     else "") + f": {s:.1f} s (<= {SECONDS_14K:g} s): "
                     f"{mark(s is not None and s <= SECONDS_14K)}")
    a = next((r for r in car if r["code"] == "after"), None)
    b = next((r for r in car if r["code"] == "before"), None)
    if a and b:
        # The same shells (the before seeds lead the after ones: --seeds 0 1 2, --before-seeds 0).
        same = a["runs"][:len(b["runs"])]
        ok = (med(same, "rad") <= med(b["runs"], "rad")
              and med(same, "flipped") <= med(b["runs"], "flipped")
              and med(same, "wall_s") < med(b["runs"], "wall_s"))
        lines.append(f"- the car, the same shells: {med(b['runs'], 'rad'):.4f} -> "
                     f"{med(same, 'rad'):.4f} rad, {med(b['runs'], 'flipped'):.0f} -> "
                     f"{med(same, 'flipped'):.0f} flipped, {med(b['runs'], 'wall_s'):.1f} -> "
                     f"{med(same, 'wall_s'):.1f} s: {mark(ok)}")
    plain = [r for r in free if not r.get("swap")]
    ok_ratio = all(x["rad"] <= FREE_RATIO * x["igl_rad"] for r in plain for x in r["runs"]
                   if "rad" in x)
    ok_flip = all(x["flipped"] == 0 for r in plain for x in r["runs"]
                  if "rad" in x and x["igl_flipped"] == 0)
    lines.append(f"- free boundary, pinned: every run within {FREE_RATIO}x libigl's pinned "
                 f"LSCM: {mark(ok_ratio)}; no flip where it has none: {mark(ok_flip)}")
    swapped = [r for r in free if r.get("swap")]
    if swapped:
        ok = all(x.get("warning") and x["flipped"] == 0 for r in swapped for x in r["runs"])
        lines.append(f"- two pins swapped: a warning that says so and what was done, no flip: "
                     f"{mark(ok)}")
    return lines


if __name__ == "__main__":
    sys.exit(main())
