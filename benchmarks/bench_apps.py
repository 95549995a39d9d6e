"""Benchmark ``pcgeom boundary`` and ``pcgeom reconstruct`` as a user runs them, beside
pymeshlab's ball pivoting and screened Poisson reconstructions of the same clouds.

For each surface of ``../shared/data`` (face_3holes_small_choi, face_human_choi,
peaks_7holes_choi; absent files are skipped), the reference mesh's faces are dropped, and each
of two inputs is benchmarked:

- **normals**: ``WORK/NAME_normals.ply``, the points with the reference mesh's oriented vertex
  normals (trimesh's area-weighted ones) as PLY ``nx ny nz``, as a scanner writes them; this
  is what a user with such a file gets by default (``pcgeom param`` uses a file's normals,
  ``--normals auto``);
- **bare**: the shared file itself, which has no normals (they are estimated and oriented by
  propagation; the map can fold where sheets touch).

For each input:

1. a free-boundary map: a ``--map NAME=PATH`` given on the command line (for the bare input),
   else ``WORK/NAME_INPUT_uv.npz`` when a previous run left it there, else
   ``python -m pcgeom param INPUT --preset fast --out WORK/NAME_INPUT_uv.npz --quiet --json``;
2. ``python -m pcgeom boundary INPUT --map MAP --out ... --quiet --json``: the loops, scored
   against the boundary of the reference mesh (precision and recall of boundary points, loop
   counts, true loops recovered one-to-one); again with ``--min-width 1`` (holes narrower on
   the surface than one point spacing dropped) and with ``--cloud-spacing --min-width 1``
   (triangles also judged in 3D against the cloud's spacing); neither is the default, see
   pcgeom.apps.boundary;
3. ``python -m pcgeom reconstruct INPUT --map MAP --target-vertices N --out ... --quiet
   --json``: the mesh, scored against the reference mesh;
4. for a surface with one boundary loop (a disk), also the map onto the disk
   (``pcgeom param INPUT --domain disk``) and ``pcgeom reconstruct INPUT --map DISK_MAP
   --domain disk``: the disk itself meshed and lifted.

Each command is a subprocess timed from the outside, so its time includes Python and torch
start-up (measured separately and reported). pymeshlab's filters are timed in this process,
filter calls only. Every reconstruction, pcgeom's and pymeshlab's, is scored the same way:
symmetric distance between the two surfaces (the mesh's vertices and an area-uniform sample
of its triangles to the reference triangles, and the same from the reference to the mesh,
exact point-to-triangle distances, libigl), over the cloud's bounding-box diagonal; the area
ratio to the reference (below 1: missing triangles; above 1: surface added); edge-manifold,
consistently oriented, boundary loops (:func:`pcgeom.apps.reconstruct.mesh_report`).

pymeshlab is an optional benchmark dependency::

    pip install torch==2.13.0 pymeshlab     # keep the torch pin in the same command

Without it, its rows say so. The section between ``<!-- bench_apps: begin -->`` and
``<!-- bench_apps: end -->`` of BENCHMARKS.md is replaced (benchmarks/sections.py).

    python benchmarks/bench_apps.py                                   # all three surfaces
    python benchmarks/bench_apps.py --surfaces peaks_7holes_choi --out /tmp/B.md
    python benchmarks/bench_apps.py --map face_human_choi=face_uv.npz
"""

from __future__ import annotations

import argparse
import datetime as _dt
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
DATA_DIR = REPO.parent / "shared" / "data"

# Benchmark this checkout's pcgeom: first on the path here and in every subprocess.
sys.path.insert(0, os.fspath(REPO))
SUBPROCESS_ENV = dict(os.environ)
SUBPROCESS_ENV["PYTHONPATH"] = os.pathsep.join(
    [os.fspath(REPO)] + ([os.environ["PYTHONPATH"]] if os.environ.get("PYTHONPATH") else []))

import numpy as np  # noqa: E402
from sections import write_section  # noqa: E402

from pcgeom.apps.reconstruct import mesh_report  # noqa: E402
from pcgeom.io import ParamResult, read_points  # noqa: E402

SURFACES = ("face_3holes_small_choi", "face_human_choi", "peaks_7holes_choi")
"""Surfaces, each ``DATA_DIR / (name + ".ply")``, in report order."""

TARGETS = {
    "face_3holes_small_choi": "4 loops; boundary precision and recall >= 0.95; reconstruction "
                              "Hausdorff <= 1% of the diagonal, edge-manifold, 4 loops",
    "face_human_choi": "1 loop; boundary precision and recall >= 0.95",
    "peaks_7holes_choi": "8 loops",
}
"""The issue's targets, quoted beside the measurements."""

SECTION = "bench_apps"

INPUTS = ("normals", "bare")
"""The two inputs of each surface, in report order (module docstring)."""


def log(msg: str) -> None:
    print(f"[bench_apps] {msg}", file=sys.stderr, flush=True)


# --------------------------------------------------------------------------- commands


def run_pcgeom(argv: list[str], timeout: float | None = None) -> tuple[dict | None, float, str]:
    """``python -m pcgeom ARGV --quiet --json`` as a subprocess: (its JSON or None, wall
    seconds, error line or "")."""
    cmd = [sys.executable, "-m", "pcgeom", *argv, "--quiet", "--json"]
    t0 = time.perf_counter()
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True, env=SUBPROCESS_ENV,
                              cwd=tempfile.gettempdir(), timeout=timeout)
    except subprocess.TimeoutExpired:
        return None, time.perf_counter() - t0, f"timed out after {timeout:g} s"
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        tail = " | ".join(proc.stderr.strip().splitlines()[-2:])
        return None, wall, f"exit {proc.returncode}: {tail}"
    try:
        return json.loads(proc.stdout.strip().splitlines()[-1]), wall, ""
    except (json.JSONDecodeError, IndexError):
        return None, wall, f"no JSON on stdout: {proc.stdout[-200:]!r}"


def measure_startup(repeats: int = 3) -> float:
    """Median wall time of ``python -c "import pcgeom.cli"``: the start-up in every command."""
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-c", "import pcgeom.cli"], check=True,
                       cwd=tempfile.gettempdir(), env=SUBPROCESS_ENV)
        times.append(time.perf_counter() - t0)
    return float(np.median(times))


# --------------------------------------------------------------------------- measures


def boundary_of(F: np.ndarray) -> tuple[np.ndarray, list[np.ndarray]]:
    """Vertices on the reference mesh's boundary (edges of one triangle) and its loops."""
    import igl

    E = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    edges, counts = np.unique(E, axis=0, return_counts=True)
    vertices = np.unique(edges[counts == 1])
    loops = [np.asarray(loop) for loop in igl.boundary_loop_all(np.ascontiguousarray(F))]
    return vertices, loops


def boundary_scores(found: list[list[int]], true_vertices: np.ndarray,
                    true_loops: list[np.ndarray]) -> dict:
    """Precision and recall of the detected boundary points, and how many true loops come out
    as exactly one detected loop each (a detected loop holding at least half of a true loop's
    points, and no two true loops sharing one)."""
    detected = np.unique(np.concatenate(found)) if found else np.zeros(0, dtype=np.int64)
    hit = np.intersect1d(detected, true_vertices)
    best = []
    for loop in true_loops:
        overlap = [len(np.intersect1d(loop, d)) for d in found] or [0]
        k = int(np.argmax(overlap))
        best.append(k if overlap[k] >= 0.5 * len(loop) else None)
    matched = [k for k in best if k is not None]
    recovered = sum(1 for k in matched if matched.count(k) == 1)
    return {
        "precision": len(hit) / len(detected) if len(detected) else None,
        "recall": len(hit) / len(true_vertices) if len(true_vertices) else None,
        "loops": len(found),
        "true_loops": len(true_loops),
        "recovered": recovered,
    }


def _area_sample(V: np.ndarray, F: np.ndarray, n: int, rng) -> np.ndarray:
    """``n`` points uniform by area on the triangles ``F``, plus the vertices they use."""
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    area = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)  # (M,)
    face = rng.choice(len(F), size=n, p=area / area.sum())
    r1, r2 = rng.random(n), rng.random(n)
    s = np.sqrt(r1)
    P = ((1 - s)[:, None] * a[face] + (s * (1 - r2))[:, None] * b[face]
         + (s * r2)[:, None] * c[face])  # (n, 3)
    return np.vstack([V[np.unique(F)], P])


def surface_scores(V: np.ndarray, F: np.ndarray, Vt: np.ndarray, Ft: np.ndarray, diag: float,
                   n: int = 50_000, seed: int = 0) -> dict:
    """Distances between the surface ``(V, F)`` and the reference ``(Vt, Ft)``, over
    ``diag``: ``hausdorff_rel`` (the largest of both directions), ``mean_rel`` (the mean of
    the two directions' means), ``to_true_rel`` (largest distance of the mesh to the
    reference: accuracy), ``from_true_rel`` (largest distance of the reference to the mesh:
    completeness); and ``area_ratio``."""
    import igl

    rng = np.random.default_rng(seed)
    V, Vt = np.ascontiguousarray(V, np.float64), np.ascontiguousarray(Vt, np.float64)
    F, Ft = np.ascontiguousarray(F, np.int64), np.ascontiguousarray(Ft, np.int64)
    d_to = np.sqrt(igl.point_mesh_squared_distance(_area_sample(V, F, n, rng), Vt, Ft)[0])
    d_from = np.sqrt(igl.point_mesh_squared_distance(_area_sample(Vt, Ft, n, rng), V, F)[0])

    def area(V_, F_):
        return 0.5 * float(np.linalg.norm(np.cross(V_[F_[:, 1]] - V_[F_[:, 0]],
                                                   V_[F_[:, 2]] - V_[F_[:, 0]]), axis=1).sum())

    return {
        "hausdorff_rel": float(max(d_to.max(), d_from.max()) / diag),
        "mean_rel": float(0.5 * (d_to.mean() + d_from.mean()) / diag),
        "to_true_rel": float(d_to.max() / diag),
        "from_true_rel": float(d_from.max() / diag),
        "area_ratio": area(V, F) / area(Vt, Ft),
    }


def score_mesh(V, F, P, Vt, Ft, diag) -> dict:
    """:func:`surface_scores` and the topology of :func:`mesh_report` of one mesh."""
    rep = mesh_report(V, F, P)
    return {**surface_scores(V, F, Vt, Ft, diag),
            **{k: rep[k] for k in ("n_vertices", "n_faces", "edge_manifold", "oriented",
                                   "n_boundary_loops", "min_angle_deg")}}


# --------------------------------------------------------------------------- pymeshlab


def meshlab_reconstructions(P: np.ndarray) -> list[dict]:
    """Ball pivoting (default radius: MeshLab's guess) and screened Poisson (normals from 10
    neighbours, depth 8), with MeshLab's defaults, each timed (filter calls only)."""
    try:
        import pymeshlab
    except ImportError:
        msg = "not installed (pip install torch==2.13.0 pymeshlab)"
        return [{"method": m, "error": msg} for m in ("ball pivoting", "screened Poisson")]

    def run(method: str, filters) -> dict:
        ms = pymeshlab.MeshSet()
        ms.add_mesh(pymeshlab.Mesh(vertex_matrix=np.ascontiguousarray(P)))
        t0 = time.perf_counter()
        try:
            filters(ms)
        except Exception as exc:  # report it and go on with the other method
            return {"method": method, "error": f"{type(exc).__name__}: {exc}"}
        seconds = time.perf_counter() - t0
        mesh = ms.current_mesh()
        V = np.asarray(mesh.vertex_matrix(), dtype=np.float64)
        F = np.asarray(mesh.face_matrix(), dtype=np.int64)
        if len(F) == 0:
            return {"method": method, "seconds": seconds, "error": "no triangles"}
        return {"method": method, "seconds": seconds, "V": V, "F": F}

    def poisson(ms):
        ms.compute_normal_for_point_clouds(k=10)
        ms.generate_surface_reconstruction_screened_poisson(depth=8)

    return [run("ball pivoting", lambda ms: ms.generate_surface_reconstruction_ball_pivoting()),
            run("screened Poisson", poisson)]


# --------------------------------------------------------------------------- one surface


def get_map(name: str, src: Path, given: Path | None, work: Path, domain: str | None = None
            ) -> dict:
    """The map of ``src`` (free boundary, or onto ``domain``): given, cached in ``work`` or
    computed (timed)."""
    if given is not None:
        return {"path": given, "how": f"given ({given.name})", "seconds": None}
    path = work / (f"{src.stem}_uv.npz" if domain is None else f"{src.stem}_{domain}_uv.npz")
    how = "pcgeom param --preset fast" + (f" --domain {domain}" if domain else "")
    if path.exists():
        return {"path": path, "how": f"{path.name}, reused from an earlier run",
                "seconds": None}
    log(f"{name}: {how} ({src.name}) ...")
    out, wall, error = run_pcgeom(["param", os.fspath(src), "--preset", "fast", "--out",
                                   os.fspath(path)] + (["--domain", domain] if domain else []))
    if error:
        return {"path": None, "how": how, "seconds": wall, "error": error}
    log(f"{name}: map in {wall:.0f} s, normals {out['normals']}")
    return {"path": path, "how": how, "seconds": wall, "train_seconds": out["seconds"],
            "normals": out["normals"]}


def bench_boundary(name: str, src: Path, map_path: str, extra: list[str], work: Path,
                   true_vertices, true_loops) -> dict:
    """``pcgeom boundary`` with ``extra`` arguments, scored."""
    loops_path = work / f"{src.stem}_loops.json"
    out, wall, error = run_pcgeom(["boundary", os.fspath(src), "--map", map_path, "--out",
                                   os.fspath(loops_path), *extra])
    row = {"args": " ".join(extra), "seconds": wall, "error": error}
    if not error:
        found = json.loads(loops_path.read_text())["loops"]
        row.update(boundary_scores(found, true_vertices, true_loops), n_dropped=out["n_dropped"])
    return row


def bench_reconstruct(label: str, src: Path, map_path: str, extra: list[str], work: Path,
                      target: int, size: str) -> dict:
    """``pcgeom reconstruct`` with ``extra`` arguments; the mesh read back (scored later)."""
    mesh_path = work / f"{src.stem}{'_' + extra[-1] if extra else ''}_mesh.ply"
    out, wall, error = run_pcgeom(["reconstruct", os.fspath(src), "--map", map_path,
                                   "--target-vertices", str(target), "--size", size,
                                   "--out", os.fspath(mesh_path), *extra])
    row = {"method": label, "seconds": wall, "error": error}
    if not error:
        mesh = read_points(mesh_path)
        row.update(V=mesh.points, F=mesh.faces)
    return row


def bench_input(name: str, kind: str, src: Path, args, work: Path, P, Ft, diag,
                true_vertices, true_loops) -> dict:
    """The map, boundary and reconstructions of one input of a surface."""
    given = args.given_maps.get(name) if kind == "bare" else None
    row = {"input": kind, "map": get_map(name, src, given, work)}
    if row["map"]["path"] is None:
        return row
    map_path = os.fspath(row["map"]["path"])
    made = ParamResult.load(map_path, n_points=len(P), against=os.fspath(src))
    row["map"].update(preset=made.preset, version=made.version,
                      normals=made.history[0].get("normals") if made.history else None)

    log(f"{name} ({kind}): pcgeom boundary ...")
    row["boundary"] = [bench_boundary(name, src, map_path, extra, work, true_vertices,
                                      true_loops)
                       for extra in ([], ["--min-width", "1"],
                                     ["--cloud-spacing", "--min-width", "1"])]
    target = args.target_vertices or len(P)
    log(f"{name} ({kind}): pcgeom reconstruct --target-vertices {target} ...")
    recon = [bench_reconstruct(f"pcgeom reconstruct ({args.size}, {target} vertices)", src,
                               map_path, [], work, target, args.size)]
    if len(true_loops) == 1 and not args.no_disk:
        disk = get_map(name, src, None, work, domain="disk")
        row["disk_map"] = disk
        if disk["path"] is not None:
            log(f"{name} ({kind}): pcgeom reconstruct --domain disk ...")
            recon.append(bench_reconstruct(
                f"pcgeom reconstruct --domain disk ({args.size}, {target} vertices)", src,
                os.fspath(disk["path"]), ["--domain", "disk"], work, target, args.size))
        else:
            recon.append({"method": "pcgeom reconstruct --domain disk", "seconds": None,
                          "error": f"the disk map failed: {disk['error']}"})
    for r in recon:
        _score(name, r, P, Ft, diag)
    row["reconstruction"] = recon
    return row


def _score(name: str, r: dict, P, Ft, diag) -> None:
    if "V" in r:
        r.update(score_mesh(r.pop("V"), r.pop("F"), P, P, Ft, diag))
        log(f"{name}: {r['method']}: Hausdorff {r['hausdorff_rel']:.4f} diag, "
            f"{r['n_boundary_loops']} loops, manifold {r['edge_manifold']}, "
            f"{r['seconds']:.1f} s")
    else:
        log(f"{name}: {r['method']}: FAILED: {r['error']}")


def bench_surface(name: str, args, work: Path) -> dict:
    src = DATA_DIR / f"{name}.ply"
    if not src.exists():
        return {"name": name, "skipped": f"{src} not found"}
    cloud = read_points(src)
    P, Ft = cloud.points, cloud.faces
    diag = float(np.linalg.norm(P.max(axis=0) - P.min(axis=0)))
    true_vertices, true_loops = boundary_of(Ft)
    row = {"name": name, "n_points": len(P), "n_faces": len(Ft), "diag": diag,
           "true_loops": len(true_loops), "inputs": []}
    for kind in INPUTS:
        if kind == "normals":
            import trimesh

            from pcgeom.io import write_ply_atomic

            path = work / f"{name}_normals.ply"
            normals = np.asarray(trimesh.Trimesh(P, Ft, process=False).vertex_normals)
            write_ply_atomic(path, P, normals=normals)
        else:
            path = src
        row["inputs"].append(bench_input(name, kind, path, args, work, P, Ft, diag,
                                         true_vertices, true_loops))
    row["meshlab"] = []
    if not args.no_meshlab:
        log(f"{name}: pymeshlab ball pivoting and screened Poisson ...")
        row["meshlab"] = meshlab_reconstructions(P)
        for r in row["meshlab"]:
            _score(name, r, P, Ft, diag)
    return row


# --------------------------------------------------------------------------- report


def _f(x, fmt: str) -> str:
    return "n/a" if x is None else format(x, fmt)


def _s(seconds: float) -> str:
    return f"{seconds:.2f}" if seconds < 10 else f"{seconds:.1f}"


def render(rows: list[dict], startup: float, argv: list[str], meta: dict) -> str:
    lines = [
        "## Boundary detection and surface reconstruction (`bench_apps.py`)",
        "",
        f"- date: {meta['date']}; {meta['machine']}; load average {meta['load_start']} at the "
        f"start, {meta['load_end']} at the end",
        "- command: `" + " ".join(["python benchmarks/bench_apps.py", *argv]) + "`",
        f"- versions: {meta['versions']}",
        f"- every pcgeom command is a subprocess timed from the outside: its time includes "
        f"Python and torch start-up, {startup:.1f} s here (`python -c \"import pcgeom.cli\"`, "
        "median of 3); pymeshlab is timed in-process, filter calls only",
        "- inputs: *normals*, the points with the reference mesh's oriented vertex normals as "
        "PLY nx ny nz (as a scanner writes them; `pcgeom param` uses a file's normals by "
        "default); *bare*, the shared file as it is, without normals (estimated by PCA and "
        "oriented by propagation; the map can fold where sheets touch)",
        "- boundary: the detected loops' points against the reference mesh's boundary "
        "vertices (precision, recall); \"recovered\": true loops that come out as one "
        "detected loop each (holding at least half of the true loop's points); "
        "`--min-width 1` also drops holes narrower on the surface than one point spacing "
        "(not the default: it drops true holes of a good map of peaks_7holes_choi); "
        "`--cloud-spacing` also removes triangles whose 3D circumradius exceeds the cloud's "
        "own spacing (not the default: it opens spurious holes where the sampling is "
        "anisotropic, face_human_choi); see pcgeom.apps.boundary",
        "- reconstruction: distances between the mesh and the reference mesh both ways (its "
        "vertices and 50 000 area-uniform points to the other's triangles, exact), over the "
        "cloud's bounding-box diagonal: Hausdorff (largest, both ways), mean (of the two "
        "directions' means), mesh -> reference (accuracy) and reference -> mesh "
        "(completeness); area over the reference's area",
        "",
    ]
    for row in rows:
        lines.append(f"### {row['name']}")
        lines.append("")
        if "skipped" in row:
            lines += [f"Skipped: {row['skipped']}.", ""]
            continue
        lines += [f"{row['n_points']} points (reference mesh: {row['n_faces']} triangles, "
                  f"{row['true_loops']} boundary loops); diagonal {row['diag']:.4g}. Target "
                  f"(issue 12): {TARGETS.get(row['name'], 'none')}. Inputs: "
                  + "; ".join(_input_line(r) for r in row["inputs"]) + ".", ""]
        lines += ["| `pcgeom boundary` | input | loops (true) | recovered | dropped | precision "
                  "| recall | time s |", "|---|---|---|---|---|---|---|---|"]
        for inp in row["inputs"]:
            if inp["map"].get("error"):
                lines.append(f"| map failed: {inp['map']['error']} | {inp['input']} |"
                             + " |" * 6)
                continue
            for b in inp["boundary"]:
                rule = "default rule" + (f", `{b['args']}`" if b["args"] else "")
                if b["error"]:
                    lines.append(f"| {rule}: failed: {b['error']} | {inp['input']} |"
                                 + " |" * 5 + f" {_s(b['seconds'])} |")
                    continue
                lines.append(f"| {rule} | {inp['input']} | {b['loops']} ({b['true_loops']}) | "
                             f"{b['recovered']}/{b['true_loops']} | {b['n_dropped']} | "
                             f"{_f(b['precision'], '.3f')} | {_f(b['recall'], '.3f')} | "
                             f"{_s(b['seconds'])} |")
        lines += ["", "| reconstruction | input | vertices | triangles | Hausdorff / diag | "
                  "mean / diag | mesh -> ref | ref -> mesh | area ratio | edge-manifold | "
                  "oriented | loops | min angle | time s |", "|---" * 14 + "|"]
        recon = [(inp["input"], r) for inp in row["inputs"] for r in inp.get("reconstruction", [])]
        recon += [("points only", r) for r in row["meshlab"]]
        for kind, r in recon:
            if "hausdorff_rel" not in r:
                t = _s(r["seconds"]) if r.get("seconds") is not None else ""
                lines.append(f"| {r['method']} | {kind} | failed: {r['error']} |" + " |" * 10
                             + f" {t} |")
                continue
            lines.append(
                f"| {r['method']} | {kind} | {r['n_vertices']} | {r['n_faces']} | "
                f"{r['hausdorff_rel']:.4f} | {r['mean_rel']:.5f} | {r['to_true_rel']:.4f} | "
                f"{r['from_true_rel']:.4f} | {r['area_ratio']:.3f} | "
                f"{'yes' if r['edge_manifold'] else 'no'} | {'yes' if r['oriented'] else 'no'}"
                f" | {r['n_boundary_loops'] if r['edge_manifold'] else 'n/a'} | "
                f"{r['min_angle_deg']:.1f} | {_s(r['seconds'])} |")
        lines.append("")
    return "\n".join(lines)


def _input_line(inp: dict) -> str:
    m = inp["map"]
    how = m["how"] + (f", {m['seconds']:.0f} s" if m.get("seconds") else "")
    if m.get("preset"):
        how += f" (preset {m['preset']}, pcgeom {m['version']})"
    if m.get("normals"):
        how += f", normals {m['normals']}"
    return f"{inp['input']}: free map by {how}"


def _load() -> str:
    try:
        return ", ".join(f"{x:.2f}" for x in os.getloadavg())
    except OSError:
        return "n/a"


def _versions() -> str:
    out = []
    for pkg in ("pcgeom", "torch", "gmsh", "libigl", "pymeshlab"):
        try:
            out.append(f"{pkg} {version(pkg)}")
        except PackageNotFoundError:
            out.append(f"{pkg} not installed" if pkg != "pcgeom" else "pcgeom (checkout)")
    return ", ".join(out)


def _map_arg(text: str) -> tuple[str, Path]:
    name, sep, path = text.partition("=")
    if not sep or name not in SURFACES or not path:
        raise argparse.ArgumentTypeError(f"expected NAME=PATH with NAME one of "
                                         f"{', '.join(SURFACES)}, got {text!r}")
    return name, Path(path).resolve()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--surfaces", nargs="+", choices=SURFACES, default=list(SURFACES))
    parser.add_argument("--map", dest="maps", action="append", type=_map_arg, default=[],
                        metavar="NAME=MAP.npz",
                        help="reuse a free-boundary map of a surface's bare input")
    parser.add_argument("--work", type=Path, default=REPO / "benchmarks" / "results" / "apps",
                        help="where maps (NAME_uv.npz, reused on the next run), loops and "
                             "meshes go (default: benchmarks/results/apps, not tracked)")
    parser.add_argument("--target-vertices", type=int, default=None, metavar="N",
                        help="pcgeom reconstruct's target (default: the cloud's point count)")
    parser.add_argument("--size", choices=("uniform", "adaptive"), default="uniform")
    parser.add_argument("--no-meshlab", action="store_true", help="skip pymeshlab's methods")
    parser.add_argument("--no-disk", action="store_true",
                        help="skip the disk map and its reconstruction (--domain disk)")
    parser.add_argument("--out", type=Path, default=REPO / "BENCHMARKS.md")
    parser.add_argument("--json", type=Path, help="also dump the measurements as JSON")
    argv = sys.argv[1:] if argv is None else argv
    args = parser.parse_args(argv)
    args.given_maps = dict(args.maps)
    args.work.mkdir(parents=True, exist_ok=True)

    meta = {"date": f"{_dt.datetime.now(_dt.timezone.utc):%Y-%m-%d %H:%M} UTC",
            "machine": f"{platform.machine()}, {os.cpu_count()} cores",
            "load_start": _load(), "versions": _versions()}
    startup = measure_startup()
    rows = [bench_surface(name, args, args.work) for name in args.surfaces]
    meta["load_end"] = _load()
    section = render(rows, startup, argv, meta)
    write_section(args.out, SECTION, section)
    if args.json:
        args.json.write_text(json.dumps({"meta": meta, "startup_s": startup, "rows": rows},
                                        default=os.fspath, indent=1))
    print(section)
    return 0


if __name__ == "__main__":
    sys.exit(main())
