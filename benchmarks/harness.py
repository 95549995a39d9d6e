"""What the benchmark scripts share: run pcgeom as a user does, score, write BENCHMARKS.md.

Running: :func:`pcgeom_cli` (``python -m pcgeom ARGS --quiet --json`` as a subprocess timed
from outside, with its peak memory), :func:`param_runs` (``pcgeom param`` once per seed, each
map file scored), :func:`startup`, :func:`timed`, :func:`clock`. Surfaces:
:func:`load_surface`, :func:`write_with_normals`, :func:`planar_triangles`. Scores:
:func:`score_map` (``map_report`` on the reference triangles), :func:`score_file` (of a map
file), :func:`reference` (a baseline map), :func:`score_mesh` (a reconstructed mesh against
the reference), :func:`boundary_scores` (detected boundary loops), :func:`distances`,
:func:`summary` (medians, min and max). Report: :func:`header`, :func:`table`,
:func:`write_section` (one marked section of BENCHMARKS.md, atomically), :func:`write_head`
(the part above the sections), :func:`write_json`.

Importing it puts this checkout first on ``sys.path`` and on every subprocess's
``PYTHONPATH`` (Dask workers included), so the pcgeom measured is this one, installed or not.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import json
import os
import shlex
import statistics
import subprocess
import sys
import tempfile
import time
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import NamedTuple

REPO = Path(__file__).resolve().parent.parent
DATA_DIR = REPO.parent / "shared" / "data"
BENCHMARKS_MD = REPO / "BENCHMARKS.md"
sys.path.insert(0, os.fspath(REPO))
os.environ["PYTHONPATH"] = os.pathsep.join(
    [os.fspath(REPO)] + ([os.environ["PYTHONPATH"]] if os.environ.get("PYTHONPATH") else []))

SECTIONS = ("bench_schedules", "gpu", "bench_apps", "bench_apps_strays", "bench_apps_loops",
            "bench_batch", "bench_scans",
            "bench_scans_large", "bench_scans_denoise", "bench_domains", "bench_domain_maps",
            "bench_folds", "bench_folds_cortex", "bench_scans_small", "bench_sphere", "bench_reconstruct_sphere",
            "bench_topology", "bench_bridges", "bench_atlas", "bench_landmarks")
"""The marked sections of BENCHMARKS.md, in file order; bench_param.py writes the top."""

FIGURES = ("rad", "flipped", "flip_pct", "hausdorff", "surface_h", "wall_s", "train_s",
           "rss_gb")
"""The run figures :func:`summary` takes the median, min and max of."""


def log(msg: str) -> None:
    print(f"[{Path(sys.argv[0]).stem}] {msg}", file=sys.stderr, flush=True)


# --------------------------------------------------------------------------- running


_SPAWN = ("import json, os, sys, time; t = time.perf_counter(); "
          "pid = os.posix_spawn(sys.argv[2], sys.argv[2:], os.environ); "
          "_, s, u = os.wait4(pid, 0); "
          "json.dump([time.perf_counter() - t, u.ru_maxrss, os.waitstatus_to_exitcode(s), "
          "u.ru_utime + u.ru_stime], open(sys.argv[1], 'w'))")
"""Run ``argv[2:]``, then write its wall seconds, peak RSS (KiB), exit code and CPU seconds
(user and system) to ``argv[1]``.
A small process in between, because a child's ``ru_maxrss`` starts at its parent's RSS."""


def pcgeom_cli(*args, check: bool = True) -> dict:
    """``python -m pcgeom ARGS --quiet --json``, timed around the whole process: its
    ``json`` summary, ``wall_s``, its CPU seconds ``cpu_s`` (what the wall time would be on
    an idle machine, the process being single-threaded), its peak RSS ``rss_gb``, and
    ``error`` ("" when it succeeded; raised as RuntimeError when ``check``)."""
    cmd = [sys.executable, "-m", "pcgeom", *map(str, args), "--quiet", "--json"]
    with tempfile.TemporaryDirectory() as tmp:
        out, err, stats = (Path(tmp) / name for name in ("stdout", "stderr", "stats.json"))
        with out.open("w") as so, err.open("w") as se:
            subprocess.run([sys.executable, "-c", _SPAWN, stats, *cmd], stdout=so, stderr=se,
                           cwd=tempfile.gettempdir(), check=True)
        wall, rss_kib, code, cpu = json.loads(stats.read_text())
        stdout, stderr = out.read_text(), err.read_text()
    run = {"json": None, "wall_s": wall, "cpu_s": cpu, "rss_gb": rss_kib / 1e6, "error": ""}
    if code != 0:
        run["error"] = f"exit {code}: " + " | ".join(stderr.strip().splitlines()[-3:])
    else:
        try:
            run["json"] = json.loads(stdout.strip().splitlines()[-1])
        except (json.JSONDecodeError, IndexError):
            run["error"] = f"no JSON on stdout: {stdout[-200:]!r}"
    if run["error"] and check:
        raise RuntimeError(f"{shlex.join(cmd)}: {run['error']}")
    return run


def param_args(src, out, *, preset: str = "fast", domain: str = "free", seed: int = 0,
               landmarks=None) -> list:
    """The arguments of ``pcgeom param``; ``src`` is a file or ``example:NAME``."""
    src = os.fspath(src)
    where = ["--example", src[len("example:"):]] if src.startswith("example:") else [src]
    return ["param", *where, "--preset", preset, "--domain", domain, "--seed", seed,
            "--out", out, *(["--landmarks", landmarks] if landmarks is not None else [])]


def param_runs(src, V, F, work: Path, seeds=(0,), *, check: bool = True, **options) -> list:
    """``pcgeom param SRC`` once per seed (``options``: preset, domain, landmarks), each map
    file scored on ``(V, F)``: dicts of the seed, map file, ``wall_s``, ``train_s`` (the
    CLI's own seconds), ``rss_gb``, device, normals and :func:`score_map`'s figures, or an
    ``error``."""
    name = Path(os.fspath(src)).name
    tag = f"{options.get('preset', 'fast')}_{options.get('domain', 'free')}" + (
        "_landmarks" if options.get("landmarks") else "")
    runs = []
    for seed in seeds:
        out = work / f"{Path(name).stem}_{tag}_{seed}_uv.npz"
        run = pcgeom_cli(*param_args(src, out, seed=seed, **options), check=check)
        if run["error"]:
            log(f"{name} {tag} seed {seed}: FAILED: {run['error']}")
            runs.append({"seed": seed, "wall_s": run["wall_s"], "error": run["error"]})
            continue
        summary = run["json"]
        runs.append(r := {"seed": seed, "out": out, "wall_s": run["wall_s"],
                          "rss_gb": run["rss_gb"], "train_s": summary["seconds"],
                          "device": summary["device"], "normals": summary["normals"],
                          **score_file(out, V, F)})
        log(f"{name} {tag} seed {seed}: {r['wall_s']:.1f} s, {r['rad']:.4f} rad, {r['flipped']} "
            "flips" + (f", H {r['hausdorff']:.4f}" if r["hausdorff"] is not None else ""))
    return runs


def startup(repeats: int = 3) -> list[float]:
    """Wall times of ``python -c "import pcgeom.cli"``: the start-up inside every CLI run."""
    return [timed(subprocess.run, [sys.executable, "-c", "import pcgeom.cli"], check=True,
                  cwd=tempfile.gettempdir())[1] for _ in range(repeats)]


def timed(fn, *args, **kwargs):
    """``(fn(*args, **kwargs), seconds)``, timed in this process."""
    t0 = time.perf_counter()
    result = fn(*args, **kwargs)
    return result, time.perf_counter() - t0


def clock():
    """A function that gives the seconds since :func:`clock` was called (wall, this process):
    for figures taken along a run, such as each stage's cumulative time."""
    t0 = time.perf_counter()
    return lambda: time.perf_counter() - t0


def scaled_preset(name: str, fraction: float):
    """The preset with its epoch counts (E, E_min) and refinement steps times ``fraction``."""
    from dataclasses import replace

    from pcgeom import get_preset

    config = get_preset(name)
    if fraction == 1.0:
        return config
    s = config.schedule
    return get_preset(name, schedule=replace(s, epochs=max(1, round(s.epochs * fraction)),
                                             epochs_min=max(1, round(s.epochs_min * fraction))),
                      refine=replace(config.refine,
                                     steps=max(0, round(config.refine.steps * fraction))))


# --------------------------------------------------------------------------- surfaces


class Surface(NamedTuple):
    """A reference mesh: points ``V``, triangles ``F`` (only ever used to score), the file's
    normals, and what to give ``pcgeom param`` (a path, or ``example:NAME``)."""

    name: str
    V: object
    F: object
    normals: object
    src: str


def data_file(name: str) -> Path:
    return DATA_DIR / f"{name}.ply"


def available(name: str) -> bool:
    """A built-in example, or a file of ``../shared/data`` that is there."""
    from pcgeom.examples import EXAMPLES

    return name in EXAMPLES or data_file(name).is_file()


def load_surface(name: str) -> Surface:
    """A built-in example (``peaks3``) or ``../shared/data/NAME.ply``, which must have faces."""
    from pcgeom.examples import EXAMPLES, load_example
    from pcgeom.io import read_points

    if name in EXAMPLES:
        return Surface(name, *load_example(name), None, f"example:{name}")
    cloud = read_points(data_file(name))
    if cloud.faces is None:
        raise ValueError(f"{data_file(name)}: has no faces; the benchmark needs a reference mesh")
    return Surface(name, cloud.points, cloud.faces, cloud.normals, os.fspath(data_file(name)))


def planar_triangles(X, max_angle_deg: float = 170.0):
    """The true triangles of a height field's points ``X`` (N, 3): the Delaunay triangulation
    of their ``(x, y)``, without its slivers along the square's sides (an angle of
    ``max_angle_deg`` or more), which have no orientation to speak of (the maps' own flip
    counts leave them out too). (M, 3) int."""
    import numpy as np
    from scipy.spatial import Delaunay

    P = np.asarray(X, dtype=np.float64)[:, :2]
    F = Delaunay(P).simplices
    widest = np.zeros(len(F))
    for k in range(3):
        a, b = P[F[:, (k + 1) % 3]] - P[F[:, k]], P[F[:, (k + 2) % 3]] - P[F[:, k]]
        cos = (a * b).sum(axis=1) / (np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1))
        widest = np.maximum(widest, np.degrees(np.arccos(np.clip(cos, -1.0, 1.0))))
    return F[widest < max_angle_deg]


def mesh_normals(V, F):
    """Oriented vertex normals of the mesh (trimesh's area-weighted ones), (N, 3) float64."""
    import numpy as np
    import trimesh

    return np.asarray(trimesh.Trimesh(V, F, process=False).vertex_normals, dtype=np.float64)


def write_with_normals(path: Path, V, F, faces: bool = False) -> Path:
    """The points with the mesh's vertex normals as PLY ``nx ny nz``, as a scanner writes
    them (with the faces too when ``faces``)."""
    from pcgeom.io import write_ply_atomic

    write_ply_atomic(path, V, F if faces else None, normals=mesh_normals(V, F))
    return path


# --------------------------------------------------------------------------- scores


def score_map(U, V, F, domain=None) -> dict:
    """The figures the tables show of ``map_report(U, domain, V, F)`` (``domain`` a name or a
    Domain; a bounded one adds the Hausdorff distances of the points and of the surface)."""
    from pcgeom import get_domain
    from pcgeom.apps.evaluate import map_report

    rep = map_report(U, get_domain(domain) if isinstance(domain, str) else domain, V, F)
    return {"rad": rep["mean_abs_angle_rad"], "flipped": rep["flipped"],
            "n_faces": rep["n_faces"], "flip_pct": rep["flipped_percent"],
            "hausdorff": rep["domain_hausdorff"], "surface_h": rep["surface_hausdorff"]}


def score_file(path, V, F, *, on_domain: bool = True) -> dict:
    """:func:`score_map` of a map file, on the domain it records (``on_domain=False``: the
    angles and flips only, no Hausdorff distances), with the sparse ``solver`` and its
    ``ordering`` that its history names ("-" when none)."""
    from pcgeom.io import ParamResult

    result = ParamResult.load(path, n_points=len(V))
    record = next((r for r in result.history if "solver" in r), {})
    return {**score_map(result.uv, V, F, result.domain if on_domain else None),
            "solver": record.get("solver") or "-", "ordering": record.get("ordering") or "-"}


def distances(P, V, F):
    """Each point's distance to the triangle mesh ``(V, F)`` (exact, libigl), (K,)."""
    import igl
    import numpy as np

    return np.sqrt(igl.point_mesh_squared_distance(
        np.ascontiguousarray(P, np.float64), np.ascontiguousarray(V, np.float64),
        np.ascontiguousarray(F, np.int64))[0])


def _areas(V, F):
    import numpy as np

    return 0.5 * np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]),
                                axis=1)  # (M,)


def _area_sample(V, F, n: int, rng):
    """``n`` points uniform by area on the triangles ``F``, plus the vertices they use."""
    import numpy as np

    area = _areas(V, F)
    face = rng.choice(len(F), size=n, p=area / area.sum())
    s, r2 = np.sqrt(rng.random(n)), rng.random(n)
    P = ((1 - s)[:, None] * V[F[face, 0]] + (s * (1 - r2))[:, None] * V[F[face, 1]]
         + (s * r2)[:, None] * V[F[face, 2]])  # (n, 3)
    return np.vstack([V[np.unique(F)], P])


def score_mesh(V, F, P, Ft, diag: float, n: int = 50_000, seed: int = 0) -> dict:
    """Distances between the mesh ``(V, F)`` and the reference ``(P, Ft)`` over ``diag``
    (:func:`distances` of area samples): ``hausdorff_rel`` (both ways), ``mean_rel`` (the two
    directions' means averaged), ``to_true_rel`` (accuracy), ``from_true_rel``
    (completeness); ``area_ratio``; and the topology of
    :func:`pcgeom.apps.reconstruct.mesh_report`."""
    import numpy as np

    from pcgeom.apps.reconstruct import mesh_report

    rep, rng = mesh_report(V, F, P), np.random.default_rng(seed)
    V, Vt = np.asarray(V, np.float64), np.asarray(P, np.float64)
    F, Ft = np.asarray(F, np.int64), np.asarray(Ft, np.int64)
    d_to = distances(_area_sample(V, F, n, rng), Vt, Ft)
    d_from = distances(_area_sample(Vt, Ft, n, rng), V, F)
    return {"hausdorff_rel": float(max(d_to.max(), d_from.max()) / diag),
            "mean_rel": float(0.5 * (d_to.mean() + d_from.mean()) / diag),
            "to_true_rel": float(d_to.max() / diag), "from_true_rel": float(d_from.max() / diag),
            "area_ratio": float(_areas(V, F).sum() / _areas(Vt, Ft).sum()),
            **{k: rep[k] for k in ("n_vertices", "n_faces", "edge_manifold", "oriented",
                                   "n_boundary_loops", "min_angle_deg")}}


def boundary_scores(found: list[list[int]], F) -> dict:
    """Precision and recall of the detected boundary points against the reference mesh's
    (vertices of edges of one triangle), and how many of its loops come out as exactly one
    detected loop each (one holding at least half of its points, shared by no other)."""
    import igl
    import numpy as np

    E = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    edges, counts = np.unique(E, axis=0, return_counts=True)
    true_vertices = np.unique(edges[counts == 1])
    true_loops = [np.asarray(loop) for loop in igl.boundary_loop_all(np.ascontiguousarray(F))]
    detected = np.unique(np.concatenate(found)) if found else np.zeros(0, dtype=np.int64)
    hit = np.intersect1d(detected, true_vertices)
    best = []
    for loop in true_loops:
        overlap = [len(np.intersect1d(loop, d)) for d in found] or [0]
        k = int(np.argmax(overlap))
        best.append(k if overlap[k] >= 0.5 * len(loop) else None)
    matched = [k for k in best if k is not None]
    return {"precision": len(hit) / len(detected) if len(detected) else None,
            "recall": len(hit) / len(true_vertices) if len(true_vertices) else None,
            "loops": len(found), "true_loops": len(true_loops),
            "recovered": sum(1 for k in matched if matched.count(k) == 1)}


def reference(fn, V, F, domain: str = "free") -> dict:
    """A baseline map ``fn(V, F)`` timed in this process (map only) and scored; a failure
    comes back in ``error``, so that the other rows go on."""
    try:
        U, seconds = timed(fn, V, F)
        return {"seed": None, "wall_s": seconds, **score_map(U, V, F, domain)}
    except Exception as exc:  # noqa: BLE001 - map_report refuses a map with NaN, libigl fails
        return {"seed": None, "wall_s": 0.0, "error": f"{type(exc).__name__}: {exc}"}


def median(rows, key):
    """The median of ``row[key]`` (or ``key(row)``) over ``rows``."""
    return statistics.median(key(r) if callable(key) else r[key] for r in rows)


def summary(runs: list[dict], **extra) -> dict:
    """Over the successful runs, each of :data:`FIGURES` as its median, ``_min`` and ``_max``
    (None where no run has it); run counts, seeds, the first run's ``n_faces`` and
    ``normals``, the devices and the failures; then ``extra``."""
    ok = [r for r in runs if not r.get("error")]
    out = {"runs": len(runs), "n_ok": len(ok), "seeds": [r["seed"] for r in runs],
           "n_faces": ok[0].get("n_faces") if ok else None,
           "normals": ok[0].get("normals") if ok else None,
           "devices": sorted({r["device"] for r in ok if r.get("device")}),
           "errors": [(r["seed"], r["error"]) for r in runs if r.get("error")]}
    for key in FIGURES:
        values = [r[key] for r in ok if r.get(key) is not None]
        out.update({key: statistics.median(values) if values else None,
                    f"{key}_min": min(values, default=None),
                    f"{key}_max": max(values, default=None)})
    return {**out, **extra}


# --------------------------------------------------------------------------- report


def now() -> str:
    return f"{_dt.datetime.now(_dt.timezone.utc):%Y-%m-%d %H:%M} UTC"


def loadavg() -> list[float] | None:
    """The load average (1, 5, 15 min); above the core count, other work competed."""
    try:
        return [round(x, 2) for x in os.getloadavg()]
    except OSError:
        return None


def cpu_model() -> str:
    import platform

    try:
        with open("/proc/cpuinfo") as fh:
            return next(line.split(":", 1)[1].strip() for line in fh
                        if line.startswith("model name"))
    except (OSError, StopIteration):
        return platform.processor() or platform.machine()


def versions(*packages: str) -> str:
    """``"torch 2.13.0, pymeshlab not installed"``; a pcgeom checkout that is not installed
    reads ``pcgeom (checkout)``."""
    out = []
    for pkg in packages:
        try:
            out.append(f"{pkg} {version(pkg)}")
        except PackageNotFoundError:
            out.append("pcgeom (checkout)" if pkg == "pcgeom" else f"{pkg} not installed")
    return ", ".join(out)


def command(argv) -> str:
    """The command line that ran this script (``argv`` None: this process's own)."""
    argv = sys.argv[1:] if argv is None else argv
    return " ".join(["python", f"benchmarks/{Path(sys.argv[0]).name}", *map(shlex.quote, argv)])


def header(argv, *facts: str) -> list[str]:
    """A section's first bullets: ``- date: NOW; FACTS...`` and ``- command: `...```."""
    return [f"- date: {'; '.join([now(), *facts])}", f"- command: `{command(argv)}`"]


def parser(doc: str, json_help: str | None = None) -> argparse.ArgumentParser:
    """A script's parser (the first line of ``doc`` as its description) with ``--out``, and
    ``--json`` when ``json_help`` says what it writes."""
    p = argparse.ArgumentParser(description=doc.splitlines()[0])
    p.add_argument("--out", type=Path, default=BENCHMARKS_MD,
                   help="the report (default: BENCHMARKS.md at the repository root)")
    if json_help:
        p.add_argument("--json", type=Path, metavar="FILE", help=json_help)
    return p


def table(columns, rows) -> list[str]:
    """A markdown table: ``columns`` are ``(header, cell)`` pairs, ``cell`` a format string
    filled from a row (a dict) or a function of the row; a row that is a string is a line as
    it is (a failure)."""
    lines = ["| " + " | ".join(head for head, _ in columns) + " |", "|" + "---|" * len(columns)]
    for row in rows:
        cells = [str(cell(row)) if callable(cell) else cell.format_map(row)
                 for _, cell in columns] if isinstance(row, dict) else None
        lines.append(row if cells is None else "| " + " | ".join(cells) + " |")
    return lines


def find_section(text: str, name: str) -> str | None:
    """The section ``name`` of ``text``, from ``<!-- NAME: begin -->`` to ``<!-- NAME: end
    -->`` included; None without them."""
    begin, end = f"<!-- {name}: begin -->", f"<!-- {name}: end -->"
    if begin in text and end in text:
        return text[text.index(begin): text.index(end) + len(end)]
    return None


def carry_sections(old_text: str, new_text: str) -> str:
    """``new_text`` followed by every section of :data:`SECTIONS` found in ``old_text``."""
    kept = [s for s in (find_section(old_text, name) for name in SECTIONS) if s]
    return "\n\n".join([new_text.rstrip("\n"), *kept]) + "\n"


def write_head(path: Path, text: str) -> None:
    """Replace the part of the file at ``path`` above its sections (bench_param.py's) with
    ``text``, keeping every section of :data:`SECTIONS`, atomically."""
    old = path.read_text(encoding="utf-8") if path.exists() else ""
    write_text(path, carry_sections(old, text))
    log(f"wrote the head of {path}")


def write_text(path: Path, text: str) -> None:
    """Replace the file at ``path`` with ``text`` in one step."""
    from pcgeom.io import write_atomic

    path.parent.mkdir(parents=True, exist_ok=True)
    write_atomic(path, lambda fh: fh.write(text.encode("utf-8")))


def write_json(path: Path, data) -> None:
    """``data`` as JSON (paths as strings, NumPy scalars as numbers), atomically."""
    write_text(path, json.dumps(data, indent=1, default=lambda x: os.fspath(x)
                                if isinstance(x, os.PathLike) else x.item()) + "\n")


def write_section(path: Path, name: str, body: str) -> None:
    """Replace (or append) the section ``name`` of the file at ``path``, atomically."""
    text = path.read_text(encoding="utf-8") if path.exists() else "# Benchmarks\n"
    section = f"<!-- {name}: begin -->\n{body.strip()}\n<!-- {name}: end -->"
    old = find_section(text, name)
    write_text(path, text.replace(old, section) if old
               else text.rstrip("\n") + "\n\n" + section + "\n")
    log(f"wrote the {name} section of {path}")
