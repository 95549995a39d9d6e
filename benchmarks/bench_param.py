"""Benchmark ``pcgeom param`` as a user runs it, against mesh-based and meshless baselines.

For each surface this runs the CLI (``python -m pcgeom.cli param ... --quiet --json``) as a
subprocess once per seed and times it from the outside, so the wall time includes Python and
torch start-up, reading the input and writing the map, exactly what a user waits for. The
quality numbers (mean absolute angle distortion, flipped triangles) come from the CLI's own
``evaluation``, measured on the surface's reference mesh, which training never sees.

Baselines, timed in this process (map computation only) and scored with the same
:func:`pcgeom.apps.evaluate.angle_distortion`:

- LSCM with two pinned boundary vertices on the TRUE mesh (libigl);
- a harmonic map onto the unit disk on the TRUE mesh, its boundary loop pinned to the circle;
- what a user does today without a mesh: project the cloud onto its best-fit (PCA) plane,
  Delaunay-triangulate the projection (scipy), LSCM on that mesh; the resulting map is then
  scored on the TRUE mesh's faces.

The report is written atomically to BENCHMARKS.md (default: at the repository root) and,
optionally, as JSON. Progress goes to stderr. See benchmarks/README.md.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import json
import os
import platform
import shlex
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
DATA_DIR = REPO.parent / "shared" / "data"

# Benchmark this checkout's pcgeom, installed or not: first on the path here and in every
# subprocess (PYTHONPATH), so an older installed copy cannot be measured by mistake.
sys.path.insert(0, os.fspath(REPO))
SUBPROCESS_ENV = dict(os.environ)
SUBPROCESS_ENV["PYTHONPATH"] = os.pathsep.join(
    [os.fspath(REPO)] + ([os.environ["PYTHONPATH"]] if os.environ.get("PYTHONPATH") else []))

# name -> file in DATA_DIR, or None for a built-in example (``--example NAME``)
SURFACES: dict[str, str | None] = {
    "peaks3": None,
    "face_human_choi": "face_human_choi.ply",
}

# The target stated in the issue; checked only where it applies (peaks3, fast, free boundary).
TARGET = {"surface": "peaks3", "preset": "fast", "domain": "free",
          "mean_abs_rad": 0.03, "flip_pct": 1.0, "wall_s": 120.0}
TARGET_TEXT = "fast on three peaks, free boundary: <= 0.03 rad, < 1% flips, <= 120 s"

# Quoted from /work/shared/DESIGN.md ("Quality and speed: how they are measured"); NOT measured
# by this script. (surface, method, needs mesh?, mean abs angle, flips, time)
DESIGN_ANCHORS = [
    ("three peaks (analytic)", "LSCM, two pinned vertices (libigl 2.6.3)", "yes", "0.011",
     "", ""),
    ("face_human_choi", "LSCM, two pinned vertices (libigl 2.6.3)", "yes", "0.020", "", ""),
    ("(same meshes)", "harmonic map onto the disk", "yes (+ boundary)", "about 0.11", "", ""),
    ("published", "free-boundary conformal parametrization of point clouds",
     "ordered boundary", "about 0.02", "", ""),
    ("published", "neural point-cloud method", "no", "0.04-0.12", "",
     "about 18 min per shape on a GPU"),
    ("three peaks (5.8k points)", "plain reference implementation of the paper, 5% of its "
     "epochs, 4 stages", "no", "0.026", "19", "about 18 min on two CPU cores"),
    ("face_human_choi", "PCA plane + Delaunay + LSCM", "no", "0.27", "7.6%", ""),
    ("face_human_choi", "best classical meshless pipeline (tangent-plane Delaunay fans "
     "merged, then LSCM)", "no", "0.047", "3.7%", "about 3 s"),
]


def log(msg: str) -> None:
    print(f"[bench] {msg}", file=sys.stderr, flush=True)


# --------------------------------------------------------------------------- data


@dataclass
class Run:
    """One measurement of one method on one surface."""

    seed: int | None
    wall_s: float
    mean_abs_rad: float | None = None
    flipped: int | None = None
    n_faces: int | None = None
    domain_hausdorff: float | None = None
    train_s: float | None = None  # the CLI's own "seconds" (training only)
    device: str | None = None
    error: str | None = None


@dataclass
class MethodResult:
    method: str
    needs_mesh: str
    runs: list[Run] = field(default_factory=list)


@dataclass
class SurfaceResult:
    name: str
    n_points: int | None = None
    n_faces: int | None = None
    methods: list[MethodResult] = field(default_factory=list)
    note: str | None = None


def load_surface(name: str) -> tuple[np.ndarray, np.ndarray, str | None]:
    """Reference vertices, faces and the input file (None for a built-in example)."""
    fname = SURFACES[name]
    if fname is None:
        from pcgeom.examples import load_example

        V, F = load_example(name)
        return V, F, None
    from pcgeom.io import read_points

    path = DATA_DIR / fname
    cloud = read_points(path)
    if cloud.faces is None:
        raise ValueError(f"{path}: has no faces; the benchmark needs a reference mesh")
    return cloud.points, cloud.faces, os.fspath(path)


# --------------------------------------------------------------------------- pcgeom CLI


def run_cli(name: str, input_path: str | None, preset: str, domain: str, seed: int,
            workdir: Path) -> Run:
    """One ``pcgeom param`` subprocess, timed from the outside."""
    out = workdir / f"{name}_{preset}_{domain}_s{seed}_uv.npz"
    src = ["--example", name] if input_path is None else [input_path]
    cmd = [sys.executable, "-m", "pcgeom.cli", "param", *src, "--preset", preset,
           "--domain", domain, "--seed", str(seed), "--out", os.fspath(out), "--quiet", "--json"]
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, cwd=workdir, env=SUBPROCESS_ENV)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        tail = " | ".join(proc.stderr.strip().splitlines()[-3:])
        return Run(seed=seed, wall_s=wall, error=f"exit {proc.returncode}: {tail}")
    try:
        summary = json.loads(proc.stdout.strip().splitlines()[-1])
    except (json.JSONDecodeError, IndexError):
        return Run(seed=seed, wall_s=wall, error=f"no JSON on stdout: {proc.stdout[-200:]!r}")
    run = Run(seed=seed, wall_s=wall, train_s=summary.get("seconds"),
              device=summary.get("device"))
    ev = summary.get("evaluation")
    if ev is None:
        run.error = "the CLI reported no evaluation (input without faces?)"
    else:
        run.mean_abs_rad = ev["mean_abs_angle_rad"]
        run.flipped = ev["flipped"]
        run.n_faces = ev["n_faces"]
    if domain != "free":
        from pcgeom.apps.evaluate import domain_hausdorff
        from pcgeom.domains import get_domain

        with np.load(out, allow_pickle=False) as archive:
            run.domain_hausdorff = domain_hausdorff(archive["uv"], get_domain(domain))
    return run


def measure_startup(repeats: int) -> list[float]:
    """Wall times of ``python -c "import pcgeom.cli"``: the start-up inside every CLI run."""
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-c", "import pcgeom.cli"], check=True,
                       cwd=tempfile.gettempdir(), env=SUBPROCESS_ENV)
        times.append(time.perf_counter() - t0)
    return times


# --------------------------------------------------------------------------- baselines


def _igl():
    try:
        import igl
    except ImportError as exc:
        raise ImportError("the baselines need libigl: pip install 'libigl>=2.6'") from exc
    return igl


def lscm_two_pins(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """LSCM with the boundary vertices ``bnd[0]`` and ``bnd[len // 2]`` pinned to (0,0), (1,0)."""
    igl = _igl()
    bnd = igl.boundary_loop(F)
    b = np.array([bnd[0], bnd[len(bnd) // 2]], dtype=np.int64)
    bc = np.array([[0.0, 0.0], [1.0, 0.0]])
    uv, _ = igl.lscm(V, F, b, bc)
    return uv


def harmonic_disk(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Harmonic map with the boundary loop on the unit circle (arc-length spacing)."""
    igl = _igl()
    bnd = igl.boundary_loop(F)
    # map_vertices_to_circle's binding asks for F-ordered float64 V and int32 bnd.
    bc = igl.map_vertices_to_circle(np.asfortranarray(V), np.ascontiguousarray(bnd, np.int32))
    return igl.harmonic(V, F, bnd.astype(np.int64), np.ascontiguousarray(bc), 1)


def pca_delaunay_lscm(V: np.ndarray) -> np.ndarray:
    """The meshless map a user builds today: best-fit plane, Delaunay, LSCM. Uses points only.

    Points that Delaunay leaves out (duplicates) take the map of their nearest kept point.
    """
    from scipy.spatial import Delaunay, cKDTree

    centred = V - V.mean(axis=0)
    _, _, vt = np.linalg.svd(centred, full_matrices=False)
    P = centred @ vt[:2].T  # (N, 2) coordinates in the best-fit plane
    tri = Delaunay(P)
    Fd = tri.simplices.astype(np.int64)
    used = np.unique(Fd)
    remap = np.full(len(V), -1, dtype=np.int64)
    remap[used] = np.arange(len(used))
    uv_used = lscm_two_pins(np.ascontiguousarray(V[used]), remap[Fd])
    uv = np.empty((len(V), 2))
    uv[used] = uv_used
    missing = np.setdiff1d(np.arange(len(V)), used)
    if len(missing):
        _, nn = cKDTree(V[used]).query(V[missing], k=1)
        uv[missing] = uv_used[nn]
    return uv


BASELINES = [
    ("LSCM, 2 pinned vertices (libigl, true mesh)", "yes", "free",
     lambda V, F: lscm_two_pins(V, F)),
    ("harmonic disk map (libigl, true mesh)", "yes (+ boundary)", "disk",
     lambda V, F: harmonic_disk(V, F)),
    ("PCA plane + Delaunay + LSCM (points only)", "no", "free",
     lambda V, F: pca_delaunay_lscm(V)),
]


def run_baseline(fn, V, F, domain_name: str, with_hausdorff: bool) -> Run:
    from pcgeom.apps.evaluate import angle_distortion, domain_hausdorff
    from pcgeom.domains import get_domain

    t0 = time.perf_counter()
    try:
        uv = fn(V, F)
    except Exception as exc:  # report and go on: one failing baseline must not stop the rest
        return Run(seed=None, wall_s=time.perf_counter() - t0,
                   error=f"{type(exc).__name__}: {exc}")
    wall = time.perf_counter() - t0
    if not np.isfinite(uv).all():
        return Run(seed=None, wall_s=wall, error="map contains NaN or inf")
    rep = angle_distortion(V, F, uv)
    run = Run(seed=None, wall_s=wall, mean_abs_rad=rep.mean_abs, flipped=rep.flipped,
              n_faces=rep.n_faces)
    if with_hausdorff and domain_name == "disk":
        run.domain_hausdorff = domain_hausdorff(uv, get_domain("disk"))
    return run


# --------------------------------------------------------------------------- report


def _ok(runs: list[Run]) -> list[Run]:
    return [r for r in runs if r.error is None]


def _med(values):
    values = [v for v in values if v is not None]
    return statistics.median(values) if values else None


def stats(res: MethodResult) -> dict:
    ok = _ok(res.runs)
    out = {"n_runs": len(res.runs), "n_ok": len(ok)}
    if not ok:
        return out
    ang = [r.mean_abs_rad for r in ok]
    flips = [r.flipped for r in ok]
    pct = [100.0 * r.flipped / r.n_faces for r in ok]
    out.update(
        mean_abs_median=statistics.median(ang), mean_abs_min=min(ang), mean_abs_max=max(ang),
        flips_median=statistics.median(flips), flips_min=min(flips), flips_max=max(flips),
        flip_pct_median=statistics.median(pct), flip_pct_max=max(pct),
        wall_median=statistics.median(r.wall_s for r in ok),
        train_median=_med(r.train_s for r in ok),
        hausdorff_median=_med(r.domain_hausdorff for r in ok),
        hausdorff_min=min((r.domain_hausdorff for r in ok if r.domain_hausdorff is not None),
                          default=None),
        hausdorff_max=max((r.domain_hausdorff for r in ok if r.domain_hausdorff is not None),
                          default=None),
        devices=sorted({r.device for r in ok if r.device}),
    )
    return out


def _spread(med, lo, hi, fmt: str, n: int) -> str:
    if n == 1 or lo == hi:
        return format(med, fmt)
    return f"{format(med, fmt)} [{format(lo, fmt)}–{format(hi, fmt)}]"


def target_verdict(surface: SurfaceResult, preset: str, domain: str) -> list[str]:
    """Lines saying PASS/FAIL against the issue's target, or why it does not apply."""
    if (surface.name, preset, domain) != (TARGET["surface"], TARGET["preset"], TARGET["domain"]):
        return []
    pc = surface.methods[0]
    s = stats(pc)
    if not s.get("n_ok"):
        return [f"**Target** ({TARGET_TEXT}): **FAIL** (no successful run)."]
    checks = [
        ("mean angle distortion", s["mean_abs_median"], f"{s['mean_abs_median']:.4f} rad",
         s["mean_abs_median"] <= TARGET["mean_abs_rad"], "<= 0.03 rad"),
        ("flipped triangles", s["flip_pct_median"], f"{s['flip_pct_median']:.2f}%",
         s["flip_pct_median"] < TARGET["flip_pct"], "< 1%"),
        ("wall time", s["wall_median"], f"{s['wall_median']:.1f} s",
         s["wall_median"] <= TARGET["wall_s"], "<= 120 s"),
    ]
    verdict = "PASS" if all(c[3] for c in checks) else "FAIL"
    lines = [f"**Target** ({TARGET_TEXT}), on the medians of {s['n_ok']} run(s): **{verdict}**", ""]
    for label, _, shown, passed, want in checks:
        lines.append(f"- {label}: {shown} (want {want}): {'PASS' if passed else 'FAIL'}")
    worst_ok = (s["mean_abs_max"] <= TARGET["mean_abs_rad"]
                and s["flip_pct_max"] < TARGET["flip_pct"]
                and max(r.wall_s for r in _ok(pc.runs)) <= TARGET["wall_s"])
    if s["n_ok"] > 1:
        lines.append(f"- every seed within the target: {'yes' if worst_ok else 'no'}")
    if s["n_ok"] < s["n_runs"]:
        lines.append(f"- {s['n_runs'] - s['n_ok']} run(s) failed (see below)")
    return lines


def surface_table(surface: SurfaceResult, domain: str) -> list[str]:
    disk = domain != "free"
    head = ["method", "needs mesh?", "mean abs angle distortion, rad: median [min–max]",
            "flips: count (%)", "wall time, median s"]
    if disk:
        head.append("domain Hausdorff (disk)")
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for m in surface.methods:
        s = stats(m)
        if not s.get("n_ok"):
            cells = [m.method, m.needs_mesh, "failed", "", ""] + ([""] if disk else [])
            lines.append("| " + " | ".join(cells) + " |")
            continue
        n = s["n_ok"]
        ang = _spread(s["mean_abs_median"], s["mean_abs_min"], s["mean_abs_max"], ".4f", n)
        nf = _ok(m.runs)[0].n_faces
        fl = _spread(s["flips_median"], s["flips_min"], s["flips_max"], "g", n)
        flips = f"{fl} ({100.0 * s['flips_median'] / nf:.2f}%)"
        cells = [m.method, m.needs_mesh, ang, flips, f"{s['wall_median']:.2f}"]
        if disk:
            h = s["hausdorff_median"]
            cells.append("n/a" if h is None else
                         _spread(h, s["hausdorff_min"], s["hausdorff_max"], ".4f", n))
        lines.append("| " + " | ".join(cells) + " |")
    return lines


def cpu_model() -> str:
    try:
        with open("/proc/cpuinfo") as fh:
            for line in fh:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def environment() -> dict:
    import torch

    import pcgeom

    try:
        from importlib.metadata import version

        igl_version = version("libigl")
    except Exception:
        igl_version = "unknown"
    return {
        "cpu": cpu_model(),
        "cores": os.cpu_count(),
        "python": platform.python_version(),
        "torch": torch.__version__,
        "torch_threads": torch.get_num_threads(),
        "cuda_available": bool(torch.cuda.is_available()),
        "pcgeom": pcgeom.__version__,
        "pcgeom_path": os.fspath(Path(pcgeom.__file__).parent),
        "libigl": igl_version,
        "LD_PRELOAD": os.environ.get("LD_PRELOAD", ""),
        "OMP_NUM_THREADS": os.environ.get("OMP_NUM_THREADS", ""),
        "load_average_start": _loadavg(),
    }


def _loadavg() -> list[float] | None:
    try:
        return [round(x, 2) for x in os.getloadavg()]
    except OSError:
        return None


def render(results: list[SurfaceResult], env: dict, args, command: str, date: str,
           startup: list[float], skipped: list[str]) -> str:
    L = ["# Benchmarks: `pcgeom param`", ""]
    L += [f"- date: {date}",
          f"- machine: {env['cpu']}, {env['cores']} cores; Python {env['python']}, "
          f"torch {env['torch']} ({env['torch_threads']} threads"
          f"{', CUDA available' if env['cuda_available'] else ''}), pcgeom {env['pcgeom']}, "
          f"libigl {env['libigl']}",
          f"- pcgeom benchmarked from: `{env['pcgeom_path']}`",
          f"- LD_PRELOAD: `{env['LD_PRELOAD'] or '(none)'}`, OMP_NUM_THREADS: "
          f"`{env['OMP_NUM_THREADS'] or '(unset)'}`",
          f"- load average (1, 5, 15 min) at start: {env['load_average_start']}, at end: "
          f"{env.get('load_average_end')} (above the core count means other work competed)",
          f"- command: `{command}`",
          f"- preset `{args.preset}`, domain `{args.domain}`, {args.repeats} repeat(s), "
          f"seeds {', '.join(str(s) for s in range(args.repeats))}", ""]
    if skipped:
        L += [f"Skipped: {'; '.join(skipped)}.", ""]

    for surf in results:
        L.append(f"## {surf.name}")
        L.append("")
        if surf.note:
            L += [surf.note, ""]
            continue
        L += [f"{surf.n_points} points, {surf.n_faces} reference triangles (used only to "
              "evaluate the pcgeom and PCA rows, and as the input of the true-mesh rows).", ""]
        L += surface_table(surf, args.domain)
        L.append("")
        pc = stats(surf.methods[0])
        if pc.get("n_ok") and pc.get("train_median") is not None:
            dev = ", ".join(pc["devices"]) or "unknown"
            L += [f"pcgeom device: {dev}; training time reported by the CLI (median): "
                  f"{pc['train_median']:.1f} s of the {pc['wall_median']:.1f} s wall time.", ""]
        for m in surf.methods:
            for r in m.runs:
                if r.error:
                    seed = f" seed {r.seed}" if r.seed is not None else ""
                    L.append(f"- FAILED: {m.method}{seed}: {r.error}")
        verdict = target_verdict(surf, args.preset, args.domain)
        if verdict:
            L += ([""] if L[-1] else []) + verdict
        L.append("")

    su = statistics.median(startup)
    L += ["## Notes", "",
          f"- The `{args.preset}` wall time is measured around the whole subprocess "
          "`python -m pcgeom.cli param ... --quiet --json`, as a user waits for it: it includes "
          "Python/torch start-up, reading the input, evaluation and writing the map. Start-up "
          f"alone (`python -c \"import pcgeom.cli\"`, median of {len(startup)}): {su:.2f} s.",
          "- Baseline times are the map computation only, in this process (no start-up, no "
          "evaluation); they are deterministic, so min = max for their quality.",
          "- pcgeom rows use the points only; its reported quality is measured by the CLI on "
          "the reference triangles. The PCA row also uses the points only and is evaluated on "
          "the TRUE faces, not on its own Delaunay triangles.",
          "- peaks3 is a height field over a square: its projection onto the best-fit plane is "
          "one-to-one, so the PCA + Delaunay + LSCM row there is about as good as having the "
          "mesh; on surfaces that fold over their plane (the face) it is not.",
          "- Flips: triangles whose orientation in the map differs from the majority "
          "(`pcgeom.apps.evaluate.angle_distortion`).",
          "- Timings on shared machines are noisy: compare medians, and ratios measured in the "
          "same run.",
          f"- Target from the issue: \"{TARGET_TEXT}\" (checked on the pcgeom row of peaks3 "
          "when run with `--preset fast --domain free`).", ""]

    L += ["## Anchors quoted from DESIGN.md (not measured here)", "",
          "| surface | method | needs mesh? | mean abs angle, rad | flips | time |",
          "|---|---|---|---|---|---|"]
    for row in DESIGN_ANCHORS:
        L.append("| " + " | ".join(c or "–" for c in row) + " |")
    L.append("")
    return "\n".join(L)


def write_text(path: Path, text: str, keep_section: bool = False) -> None:
    """Write ``text`` atomically; with ``keep_section``, carry over the section that
    ``bench_schedules.py`` keeps in the same file between its markers."""
    from bench_schedules import BEGIN, END

    from pcgeom.io import write_atomic

    if keep_section and path.exists():
        old = path.read_text(encoding="utf-8")
        if BEGIN in old and END in old:
            text = text.rstrip("\n") + "\n\n" + old[old.index(BEGIN): old.index(END) + len(END)] + "\n"
    path.parent.mkdir(parents=True, exist_ok=True)
    write_atomic(path, lambda fh: fh.write(text.encode("utf-8")))


# --------------------------------------------------------------------------- main


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="bench_param.py",
        description="Benchmark 'pcgeom param' (CLI, as a user runs it) against LSCM and "
                    "harmonic maps on the true mesh and a PCA + Delaunay + LSCM meshless "
                    "baseline; writes BENCHMARKS.md.",
        epilog="example: python benchmarks/bench_param.py --repeats 3\n"
               "quick check: python benchmarks/bench_param.py --repeats 1 --surfaces peaks3 "
               "--out /tmp/BENCHMARKS.md",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--surfaces", nargs="+", choices=list(SURFACES), default=list(SURFACES),
                   metavar="NAME", help=f"surfaces to run: {', '.join(SURFACES)} (default: all; "
                   f"files are looked up in {DATA_DIR})")
    p.add_argument("--repeats", type=int, default=3,
                   help="CLI runs per surface, seeds 0..N-1; also the timing repeats of the "
                        "baselines (default: 3)")
    p.add_argument("--preset", choices=["fast", "paper"], default="fast",
                   help="pcgeom preset (default: fast; 'paper' takes hours on a CPU)")
    p.add_argument("--domain", choices=["free", "disk"], default="free",
                   help="pcgeom domain (default: free); 'disk' also reports the domain "
                        "Hausdorff distance")
    p.add_argument("--out", type=Path, default=REPO / "BENCHMARKS.md",
                   help="report file (default: %(default)s)")
    p.add_argument("--json", type=Path, metavar="RESULTS.json",
                   help="also write every measurement as JSON")
    return p


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if args.repeats < 1:
        build_parser().error(f"--repeats: expected >= 1, got {args.repeats}")
    if args.preset == "paper":
        log("WARNING: --preset paper runs the paper's full schedule; on a CPU each run takes "
            "hours")
    argv_used = sys.argv[1:] if argv is None else argv
    command = "python benchmarks/bench_param.py " + " ".join(shlex.quote(a) for a in argv_used)
    date = _dt.datetime.now().astimezone().strftime("%Y-%m-%d %H:%M %Z")
    env = environment()
    log(f"{env['cpu']}, {env['cores']} cores, torch {env['torch']} "
        f"({env['torch_threads']} threads)")

    log("measuring start-up: python -c 'import pcgeom.cli'")
    startup = measure_startup(max(3, args.repeats))
    log(f"start-up median {statistics.median(startup):.2f} s")

    results: list[SurfaceResult] = []
    skipped: list[str] = []
    with tempfile.TemporaryDirectory(prefix="pcgeom_bench_") as tmp:
        workdir = Path(tmp)
        for name in args.surfaces:
            fname = SURFACES[name]
            if fname is not None and not (DATA_DIR / fname).is_file():
                msg = f"{name}: {DATA_DIR / fname} not found"
                log(f"skipping {msg}")
                skipped.append(msg)
                results.append(SurfaceResult(name, note=f"Skipped: {DATA_DIR / fname} not "
                                             "found."))
                continue
            V, F, input_path = load_surface(name)
            surf = SurfaceResult(name, n_points=len(V), n_faces=len(F))
            results.append(surf)

            pc = MethodResult(f"pcgeom `{args.preset}` ({args.domain} boundary, CLI)"
                              if args.domain == "free" else
                              f"pcgeom `{args.preset}` (disk, CLI)", "no")
            surf.methods.append(pc)
            for seed in range(args.repeats):
                log(f"{name}: pcgeom {args.preset} {args.domain} seed {seed} "
                    f"({seed + 1}/{args.repeats}) ...")
                run = run_cli(name, input_path, args.preset, args.domain, seed, workdir)
                pc.runs.append(run)
                if run.error:
                    log(f"{name}: seed {seed} FAILED after {run.wall_s:.1f} s: {run.error}")
                else:
                    log(f"{name}: seed {seed}: {run.wall_s:.1f} s wall, "
                        f"{run.mean_abs_rad:.4f} rad, {run.flipped} flips"
                        + (f", Hausdorff {run.domain_hausdorff:.4f}"
                           if run.domain_hausdorff is not None else ""))

            for label, needs, dom, fn in BASELINES:
                m = MethodResult(label, needs)
                surf.methods.append(m)
                for _ in range(args.repeats):
                    m.runs.append(run_baseline(fn, V, F, dom, args.domain != "free"))
                s = stats(m)
                if s.get("n_ok"):
                    log(f"{name}: {label}: {s['mean_abs_median']:.4f} rad, "
                        f"{s['flips_median']:g} flips, {s['wall_median']:.2f} s")
                else:
                    log(f"{name}: {label}: FAILED: {m.runs[0].error}")

    env["load_average_end"] = _loadavg()
    text = render(results, env, args, command, date, startup, skipped)
    write_text(args.out, text, keep_section=True)
    log(f"wrote {args.out}")
    if args.json is not None:
        payload = {
            "date": date, "command": command, "environment": env,
            "preset": args.preset, "domain": args.domain, "repeats": args.repeats,
            "startup_s": startup, "target": TARGET,
            "surfaces": [
                {"name": s.name, "n_points": s.n_points, "n_faces": s.n_faces, "note": s.note,
                 "methods": [{"method": m.method, "needs_mesh": m.needs_mesh,
                              "summary": stats(m), "runs": [asdict(r) for r in m.runs]}
                             for m in s.methods]}
                for s in results
            ],
        }
        write_text(args.json, json.dumps(payload, indent=1) + "\n")
        log(f"wrote {args.json}")
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
