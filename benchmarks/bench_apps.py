"""Benchmark ``pcgeom boundary`` and ``pcgeom reconstruct`` as a user runs them, beside
pymeshlab's ball pivoting and screened Poisson reconstructions of the same clouds.

Each surface of ``../shared/data`` twice: with the reference mesh's vertex normals (as a
scanner writes them) and bare. Its free map (``--map``, else one an earlier run left in
``--work``, else ``pcgeom param --preset fast``), ``pcgeom boundary`` under three rules
scored against the reference boundary, ``pcgeom reconstruct`` (and, for a disk-like surface,
``--domain disk``) scored by its distances to the reference mesh both ways: each a subprocess
timed from outside (harness.pcgeom_cli). pymeshlab (optional: ``pip install torch==2.13.0
pymeshlab``) is timed in process. Replaces the section ``bench_apps`` of BENCHMARKS.md.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import sys
from pathlib import Path

import harness as H
import numpy as np

SURFACES = ("face_3holes_small_choi", "face_human_choi", "peaks_7holes_choi")
"""Stems of ``../shared/data``, in report order."""

TARGETS = {  # the issue's, quoted beside the measurements
    "face_3holes_small_choi": "4 loops; boundary precision and recall >= 0.95; reconstruction "
                              "Hausdorff <= 1% of the diagonal, edge-manifold, 4 loops",
    "face_human_choi": "1 loop; boundary precision and recall >= 0.95",
    "peaks_7holes_choi": "8 loops",
}

BOUNDARY_RULES = ([], ["--min-width", "1"], ["--cloud-spacing", "--min-width", "1"])


def meshlab_meshes(P: np.ndarray) -> list[dict]:
    """Ball pivoting (MeshLab's radius guess) and screened Poisson (normals from 10
    neighbours, depth 8), MeshLab's defaults otherwise, each timed (filter calls only)."""
    try:
        import pymeshlab
    except ImportError:
        msg = "not installed (pip install torch==2.13.0 pymeshlab)"
        return [{"method": m, "error": msg} for m in ("ball pivoting", "screened Poisson")]

    def poisson(ms):
        ms.compute_normal_for_point_clouds(k=10)
        ms.generate_surface_reconstruction_screened_poisson(depth=8)

    rows = []
    for method, filters in (("ball pivoting",
                             lambda ms: ms.generate_surface_reconstruction_ball_pivoting()),
                            ("screened Poisson", poisson)):
        ms = pymeshlab.MeshSet()
        ms.add_mesh(pymeshlab.Mesh(vertex_matrix=np.ascontiguousarray(P)))
        try:
            _, seconds = H.timed(filters, ms)
        except Exception as exc:  # noqa: BLE001 - report it, go on with the other method
            rows.append({"method": method, "error": f"{type(exc).__name__}: {exc}"})
            continue
        F = np.asarray(ms.current_mesh().face_matrix(), dtype=np.int64)
        rows.append({"method": method, "seconds": seconds, "error": "" if len(F) else
                     "no triangles", "V": ms.current_mesh().vertex_matrix(), "F": F})
    return rows


def get_map(src: Path, given: Path | None, work: Path, domain: str = "free") -> dict:
    """The map of ``src``: given, left in ``work`` by an earlier run, or computed (timed)."""
    if given is not None:
        return {"path": given, "how": f"given ({given.name})", "seconds": None}
    path = work / (f"{src.stem}_uv.npz" if domain == "free" else f"{src.stem}_{domain}_uv.npz")
    how = "pcgeom param --preset fast" + (f" --domain {domain}" if domain != "free" else "")
    if path.exists():
        return {"path": path, "how": f"{path.name}, reused from an earlier run", "seconds": None}
    H.log(f"{how} ({src.name}) ...")
    run = H.pcgeom_cli(*H.param_args(src, path, domain=domain), check=False)
    return {"path": None if run["error"] else path, "how": how, "seconds": run["wall_s"],
            "error": run["error"]}


def bench_input(kind: str, src: Path, given, args, s: H.Surface, diag: float, disk: bool
                ) -> dict:
    """The map, boundary loops and reconstructions of one input of a surface."""
    from pcgeom.io import ParamResult, read_points

    row = {"input": kind, "map": get_map(src, given, args.work), "boundary": [],
           "reconstruction": []}
    if row["map"]["path"] is None:
        return row
    made = ParamResult.load(row["map"]["path"], n_points=len(s.V), against=os.fspath(src))
    row["map"].update(preset=made.preset, version=made.version,
                      normals=next((r.get("normals") for r in made.history
                                    if r.get("stage") != "denoise"), None))
    for extra in BOUNDARY_RULES:
        loops = args.work / f"{src.stem}_loops.json"
        run = H.pcgeom_cli("boundary", src, "--map", row["map"]["path"], "--out", loops, *extra,
                           check=False)
        row["boundary"].append(b := {"args": " ".join(extra), "seconds": run["wall_s"],
                                     "error": run["error"], "input": kind})
        if not run["error"]:
            b.update(H.boundary_scores(json.loads(loops.read_text())["loops"], s.F),
                     n_dropped=run["json"]["n_dropped"])
        H.log(f"{s.name} ({kind}): boundary {b['args']}: {b.get('loops', b['error'])} loops")
    target = args.target_vertices or len(s.V)
    maps = [("", row["map"])]
    if disk:
        maps.append((" --domain disk", get_map(src, None, args.work, "disk")))
    for flag, m in maps:
        r = {"method": f"pcgeom reconstruct{flag} ({args.size}, {target} vertices)",
             "input": kind, "seconds": None, "error": f"the disk map failed: {m.get('error')}"}
        if m["path"] is not None:
            mesh = args.work / f"{src.stem}{'_disk' if flag else ''}_mesh.ply"
            run = H.pcgeom_cli("reconstruct", src, "--map", m["path"], "--target-vertices",
                               target, "--size", args.size, "--out", mesh, *flag.split(),
                               check=False)
            r.update(seconds=run["wall_s"], error=run["error"])
            if not run["error"]:
                cloud = read_points(mesh)
                r.update(V=cloud.points, F=cloud.faces)
        row["reconstruction"].append(score(r, s, diag))
    return row


def score(r: dict, s: H.Surface, diag: float) -> dict:
    """The reconstruction ``r`` with :func:`harness.score_mesh` in place of its mesh."""
    V, F = r.pop("V", None), r.pop("F", None)
    if r["error"]:
        H.log(f"{s.name}: {r['method']}: FAILED: {r['error']}")
        return r
    r.update(H.score_mesh(V, F, s.V, s.F, diag))
    H.log(f"{s.name}: {r['method']}: Hausdorff {r['hausdorff_rel']:.4f} diag, "
          f"{r['n_boundary_loops']} loops, manifold {r['edge_manifold']}, {r['seconds']:.1f} s")
    return r


def bench_surface(name: str, args) -> dict:
    if not H.available(name):
        return {"name": name, "skipped": f"{H.data_file(name)} not found"}
    s = H.load_surface(name)
    diag = float(np.linalg.norm(s.V.max(axis=0) - s.V.min(axis=0)))
    true_loops = H.boundary_scores([], s.F)["true_loops"]
    disk = true_loops == 1 and not args.no_disk  # a disk-like surface: also onto the disk
    normals = H.write_with_normals(args.work / f"{name}_normals.ply", s.V, s.F)
    inputs = [bench_input("normals", normals, None, args, s, diag, disk),
              bench_input("bare", Path(s.src), args.given_maps.get(name), args, s, diag, disk)]
    return {"name": name, "n_points": len(s.V), "n_faces": len(s.F), "diag": diag,
            "true_loops": true_loops, "inputs": inputs,
            "meshlab": [] if args.no_meshlab else [{**score(r, s, diag), "input": "points only"}
                                                   for r in meshlab_meshes(s.V)]}


def _f(x, fmt: str) -> str:
    return "n/a" if x is None else format(x, fmt)


def _s(seconds: float | None) -> str:
    return "" if seconds is None else f"{seconds:.2f}" if seconds < 10 else f"{seconds:.1f}"


def _failed(cells: list[str], blanks: int, seconds=None) -> str:
    """A table row of a failed command: its first cells, blanks, then its time."""
    return "| " + " | ".join(cells) + " |" + " |" * blanks + f" {_s(seconds)} |"


def _rule(b: dict) -> str:
    return "default rule" + (f", `{b['args']}`" if b["args"] else "")


BOUNDARY_COLUMNS = [
    ("`pcgeom boundary`", _rule), ("input", "{input}"), ("loops (true)", "{loops} ({true_loops})"),
    ("recovered", "{recovered}/{true_loops}"), ("dropped", "{n_dropped}"),
    ("precision", lambda b: _f(b["precision"], ".3f")),
    ("recall", lambda b: _f(b["recall"], ".3f")), ("time s", lambda b: _s(b["seconds"]))]

RECONSTRUCTION_COLUMNS = [
    ("reconstruction", "{method}"), ("input", "{input}"), ("vertices", "{n_vertices}"),
    ("triangles", "{n_faces}"), ("Hausdorff / diag", "{hausdorff_rel:.4f}"),
    ("mean / diag", "{mean_rel:.5f}"), ("mesh -> ref", "{to_true_rel:.4f}"),
    ("ref -> mesh", "{from_true_rel:.4f}"), ("area ratio", "{area_ratio:.3f}"),
    ("edge-manifold", lambda r: "yes" if r["edge_manifold"] else "no"),
    ("oriented", lambda r: "yes" if r["oriented"] else "no"),
    ("loops", lambda r: r["n_boundary_loops"] if r["edge_manifold"] else "n/a"),
    ("min angle", "{min_angle_deg:.1f}"), ("time s", lambda r: _s(r["seconds"]))]


def _input_line(inp: dict) -> str:
    m = inp["map"]
    how = m["how"] + (f", {m['seconds']:.0f} s" if m.get("seconds") else "")
    how += f" (preset {m['preset']}, pcgeom {m['version']})" if m.get("preset") else ""
    return f"{inp['input']}: free map by {how}" + (f", normals {m['normals']}"
                                                   if m.get("normals") else "")


def render(rows: list[dict], startup: float, argv, meta: dict) -> str:
    lines = [
        "## Boundary detection and surface reconstruction (`bench_apps.py`)", "",
        *H.header(argv, meta["machine"],
                  f"load average {meta['load_start']} at the start, {meta['load_end']} at the end"),
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
        "(completeness); area over the reference's area", ""]
    for row in rows:
        lines += [f"### {row['name']}", ""]
        if "skipped" in row:
            lines += [f"Skipped: {row['skipped']}.", ""]
            continue
        boundary = []
        for inp in row["inputs"]:
            if inp["map"]["path"] is None:
                boundary.append(_failed([f"map failed: {inp['map']['error']}", inp["input"]], 5))
            boundary += [_failed([f"{_rule(b)}: failed: {b['error']}", b["input"]], 5,
                                 b["seconds"]) if b["error"] else b for b in inp["boundary"]]
        recon = [r for inp in row["inputs"] for r in inp["reconstruction"]] + row["meshlab"]
        recon = [_failed([r["method"], r["input"], f"failed: {r['error']}"], 10, r.get("seconds"))
                 if r["error"] else r for r in recon]
        lines += [f"{row['n_points']} points (reference mesh: {row['n_faces']} triangles, "
                  f"{row['true_loops']} boundary loops); diagonal {row['diag']:.4g}. Target "
                  f"(issue 12): {TARGETS.get(row['name'], 'none')}. Inputs: "
                  + "; ".join(_input_line(r) for r in row["inputs"]) + ".", "",
                  *H.table(BOUNDARY_COLUMNS, boundary), "",
                  *H.table(RECONSTRUCTION_COLUMNS, recon), ""]
    return "\n".join(lines)


def _map_arg(text: str) -> tuple[str, Path]:
    name, sep, path = text.partition("=")
    if not sep or name not in SURFACES or not path:
        raise argparse.ArgumentTypeError(f"expected NAME=PATH with NAME one of "
                                         f"{', '.join(SURFACES)}, got {text!r}")
    return name, Path(path).resolve()


def main(argv: list[str] | None = None) -> int:
    p = H.parser(__doc__, "also dump the measurements as JSON")
    p.add_argument("--surfaces", nargs="+", choices=SURFACES, default=list(SURFACES))
    p.add_argument("--map", dest="maps", action="append", type=_map_arg, default=[],
                   metavar="NAME=MAP.npz",
                   help="reuse a free-boundary map of a surface's bare input")
    p.add_argument("--work", type=Path, default=H.REPO / "benchmarks" / "results" / "apps",
                   help="where maps (NAME_uv.npz, reused on the next run), loops and meshes go "
                        "(default: benchmarks/results/apps, not tracked)")
    p.add_argument("--target-vertices", type=int, default=None, metavar="N",
                   help="pcgeom reconstruct's target (default: the cloud's point count)")
    p.add_argument("--size", choices=("uniform", "adaptive"), default="uniform")
    p.add_argument("--no-meshlab", action="store_true", help="skip pymeshlab's methods")
    p.add_argument("--no-disk", action="store_true",
                   help="skip the disk map and its reconstruction (--domain disk)")
    args = p.parse_args(argv)
    args.given_maps = dict(args.maps)
    args.work.mkdir(parents=True, exist_ok=True)

    def load() -> str:
        return ", ".join(f"{x:.2f}" for x in os.getloadavg())

    meta = {"date": H.now(), "machine": f"{platform.machine()}, {os.cpu_count()} cores",
            "load_start": load(),
            "versions": H.versions("pcgeom", "torch", "gmsh", "libigl", "pymeshlab")}
    startup = statistics.median(H.startup())
    rows = [bench_surface(name, args) for name in args.surfaces]
    meta["load_end"] = load()
    section = render(rows, startup, argv, meta)
    H.write_section(args.out, "bench_apps", section)
    if args.json:
        H.write_json(args.json, {"meta": meta, "startup_s": startup, "rows": rows})
    print(section)
    return 0


if __name__ == "__main__":
    sys.exit(main())
