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

STRAY_SHARE = 0.01
"""Strays of the ``--strays`` clouds, as a share of the surface points (issue 39 item 4)."""

STRAY_DEPTH = 0.5
"""Their depth noise (Gaussian along the clean mesh's vertex normals), in mean edge lengths."""

STRAY_KINDS = ("box", "near", "none")
"""The stray models of :func:`stray_cloud` (``none``: the depth noise alone)."""

SLIVER_DEG = 10.0
"""A triangle with an angle under this many degrees is a sliver."""

POISSON_TRIM = 2.0
"""Screened Poisson's triangles with a corner farther than this many mean edge lengths from
the cloud are trimmed (the surface it invents away from the points)."""


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


# --------------------------------------------------------------------------- strays


def stray_cloud(V, F, kind: str, seed: int) -> tuple[np.ndarray, float]:
    """The surface with depth noise of :data:`STRAY_DEPTH` mean edge lengths and
    :data:`STRAY_SHARE` strays: ``box``, uniform in the bounding box enlarged by a fifth, at
    least 4 edge lengths off the surface (as :func:`pcgeom.synthetic.holey_heightfield`);
    ``near``, a surface point moved 3 to 20 edge lengths along its normal, either way (a
    scanner's mixed pixels); ``none``, the depth noise alone. Returns the cloud (surface
    points first) and the edge length."""
    from scipy.spatial import cKDTree

    rng = np.random.default_rng(seed)
    E = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    spacing = float(np.linalg.norm(V[E[:, 0]] - V[E[:, 1]], axis=1).mean())
    N = H.mesh_normals(V, F)
    noisy = V + N * rng.normal(scale=STRAY_DEPTH * spacing, size=(len(V), 1))
    n = round(STRAY_SHARE * len(V)) if kind != "none" else 0
    if kind == "none":
        strays = np.zeros((0, 3))
    elif kind == "box":
        low, high = V.min(axis=0), V.max(axis=0)
        margin, tree, strays = 0.2 * (high - low), cKDTree(V), np.zeros((0, 3))
        while len(strays) < n:
            cand = rng.uniform(low - margin, high + margin, (4 * n, 3))
            strays = np.vstack([strays, cand[tree.query(cand)[0] > 4 * spacing]])[:n]
    else:
        at = rng.choice(len(V), n, replace=False)
        off = rng.choice([-1.0, 1.0], (n, 1)) * rng.uniform(3.0, 20.0, (n, 1)) * spacing
        strays = V[at] + N[at] * off
    return np.vstack([noisy, strays]), spacing


def stray_score(V, F, s: H.Surface, diag: float) -> dict:
    """Mesh -> true surface distances over ``diag`` (its vertices and 50 000 area samples):
    largest and mean; the sliver share; vertices and boundary loops."""
    import igl

    from pcgeom.apps.reconstruct import mesh_report

    V, F = np.asarray(V, np.float64), np.asarray(F, np.int64)
    samples = H._area_sample(V, F, 50_000, np.random.default_rng(0))
    d = H.distances(np.vstack([V, samples]), s.V, s.F) / diag
    angles = []
    for k in range(3):
        a, b = V[F[:, (k + 1) % 3]] - V[F[:, k]], V[F[:, (k + 2) % 3]] - V[F[:, k]]
        cos = (a * b).sum(1) / np.maximum(np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1),
                                          1e-300)
        angles.append(np.degrees(np.arccos(np.clip(cos, -1.0, 1.0))))
    rep = mesh_report(V, F, V)
    return {"max_rel": float(d.max()), "mean_rel": float(d.mean()),
            "sliver_pct": 100.0 * float((np.min(angles, axis=0) < SLIVER_DEG).mean()),
            "n_vertices": len(V), "loops": len(igl.boundary_loop_all(F)) if rep["edge_manifold"]
            else None}


def meshlab_strays(P: np.ndarray, spacing: float) -> list[dict]:
    """Ball pivoting and screened Poisson (depth 8, normals from 10 neighbours) trimmed at
    :data:`POISSON_TRIM` edge lengths from the cloud, timed in process."""
    from scipy.spatial import cKDTree

    rows = []
    for r in meshlab_meshes(P):
        if r.get("error") or r["method"] != "screened Poisson":
            rows.append(r)
            continue
        far = cKDTree(P).query(r["V"])[0] > POISSON_TRIM * spacing
        F = r["F"][~far[r["F"]].any(axis=1)]
        used, F = np.unique(F, return_inverse=True)
        rows.append({**r, "method": f"screened Poisson, trimmed at {POISSON_TRIM:g} spacings",
                     "V": r["V"][used], "F": F.reshape(-1, 3)})
    return rows


def strays_rows(args) -> list[dict]:
    """``pcgeom reconstruct`` (defaults) of each surface's stray clouds, this tree and
    ``--baseline``'s side by side, beside MeshLab's."""
    import trimesh

    rows = []
    for name in args.strays:
        s = H.load_surface(name)
        diag = float(np.linalg.norm(s.V.max(axis=0) - s.V.min(axis=0)))
        for kind in STRAY_KINDS:
            for seed in args.seeds:
                P, spacing = stray_cloud(s.V, s.F, kind, seed)
                src = args.work / f"{name}_strays_{kind}_{seed}.xyz"
                np.savetxt(src, P)
                trees = [("pcgeom reconstruct", None)]
                if args.baseline is not None:
                    trees.insert(0, ("pcgeom reconstruct, before", args.baseline))
                for method, tree in trees:
                    out = args.work / f"{src.stem}_mesh.ply"
                    old = os.environ.get("PYTHONPATH")
                    os.environ["PYTHONPATH"] = os.fspath(tree or H.REPO)
                    try:
                        run = H.pcgeom_cli("reconstruct", src, "--out", out, check=False)
                    finally:
                        os.environ.pop("PYTHONPATH") if old is None else os.environ.update(
                            PYTHONPATH=old)
                    row = {"surface": name, "kind": kind, "seed": seed, "method": method,
                           "seconds": run["wall_s"], "error": run["error"]}
                    if not run["error"]:
                        m = trimesh.load(out, process=False)
                        row.update(stray_score(m.vertices, m.faces, s, diag))
                    rows.append(row)
                if not args.no_meshlab:
                    for r in meshlab_strays(P, spacing):
                        row = {"surface": name, "kind": kind, "seed": seed, "method": r["method"],
                               "seconds": r.get("seconds"), "error": r.get("error", "")}
                        if not row["error"]:
                            row.update(stray_score(r["V"], r["F"], s, diag))
                        rows.append(row)
                for r in rows[-4:]:
                    H.log(f"{name} {kind} {seed} {r['method']}: max {r.get('max_rel', 0):.4f} "
                          f"mean {r.get('mean_rel', 0):.5f} slivers {r.get('sliver_pct', 0):.2f}%")
    return rows


def render_strays(rows: list[dict], argv, meta: dict) -> str:
    """The medians over seeds of each surface, stray kind and method."""
    groups: dict = {}
    for r in rows:
        groups.setdefault((r["surface"], r["kind"], r["method"]), []).append(r)
    table = []
    for (name, kind, method), runs in groups.items():
        ok = [r for r in runs if not r["error"]]
        if not ok:
            table.append(f"| {name} | {kind} | {method} | failed: {runs[0]['error']} |")
            continue
        med = {k: statistics.median(r[k] for r in ok)
               for k in ("max_rel", "mean_rel", "sliver_pct", "n_vertices", "seconds")}
        table.append({"surface": name, "kind": kind, "method": method, "runs": len(ok),
                      "max": f"{med['max_rel']:.4f} ({min(r['max_rel'] for r in ok):.4f}-"
                             f"{max(r['max_rel'] for r in ok):.4f})",
                      "mean": f"{med['mean_rel']:.5f}", "sliver": f"{med['sliver_pct']:.2f}",
                      "V": f"{med['n_vertices']:.0f}", "s": f"{med['seconds']:.1f}",
                      "loops": "/".join(str(r["loops"]) for r in ok)})
    columns = [("surface", "{surface}"), ("strays", "{kind}"), ("method", "{method}"),
               ("seeds", "{runs}"), ("max / diag (range)", "{max}"), ("mean / diag", "{mean}"),
               ("slivers %", "{sliver}"), ("vertices", "{V}"), ("loops", "{loops}"),
               ("time s", "{s}")]
    return side_section(
        "Reconstruction of scans with strays (`bench_apps.py --strays`)", argv, meta, [
            f"- clouds: each shared surface's vertices with depth noise of {STRAY_DEPTH} mean "
            f"edge lengths (Gaussian along the clean mesh's vertex normals) and "
            f"{STRAY_SHARE:.0%} strays: *box*, uniform in the bounding box enlarged by a fifth, "
            "at least 4 edge lengths off the surface; *near*, surface points moved 3 to 20 edge "
            "lengths along their normals; *none*, the depth noise alone (seeds as listed, "
            "medians over them)",
            "- pcgeom: `pcgeom reconstruct CLOUD --out MESH` with its defaults (preset fast, "
            "`--denoise auto`, as many target vertices as the default 5000), a subprocess timed "
            "from outside; *before*: the same command on the tree given as `--baseline`, in the "
            "same run",
            f"- MeshLab (pymeshlab, in process): ball pivoting (its radius guess); screened "
            f"Poisson at depth 8 with normals from 10 neighbours, its triangles with a corner "
            f"farther than {POISSON_TRIM:g} mean edge lengths from the cloud removed",
            "- distances from the mesh (its vertices and 50 000 area samples) to the true mesh, "
            f"over its bounding-box diagonal; slivers: triangles with an angle under "
            f"{SLIVER_DEG:g} degrees; loops: the mesh's boundary loops per seed (the face has 4)",
            "- target (issue 39 item 4): max <= 0.01, mean no worse than before, slivers <= 1%"],
        columns, table)


def side_section(title: str, argv, meta: dict, notes: list[str], columns, table) -> str:
    """A section of ``--strays`` or ``--loops``: its title, the run's date, command and
    versions, the notes, and the table."""
    return "\n".join([
        f"## {title}", "",
        f"- date: {meta['date']}; {meta['machine']}; load average {meta['load_start']} at the "
        f"start, {meta['load_end']} at the end",
        f"- command: `python benchmarks/bench_apps.py {' '.join(map(str, argv))}`",
        f"- versions: {meta['versions']}", *notes, "", *H.table(columns, table), ""])


# --------------------------------------------------------------------------- loops


LOOP_SURFACES = ("face_3holes_small_choi", "face_human_choi", "peaks_7holes_choi",
                 "peaks_three_cgal")
"""The shared open surfaces of ``--loops``."""

SHEET_RADII = (1.0, 2.0, 3.0, 4.0, 5.0)
"""Hole radii (spacings) of the synthetic sheets of ``--loops``."""


def _true_boundary(F) -> tuple[np.ndarray, list[np.ndarray]]:
    import igl

    loops = [np.asarray(loop) for loop in igl.boundary_loop_all(np.ascontiguousarray(F))]
    return np.concatenate(loops), loops


def loop_scores(doc: dict, F) -> dict:
    """Of a ``pcgeom boundary`` JSON against the true mesh ``F``: loops, holes, holes that are
    not (holding less than half of every true hole's points), gaps, true holes recovered (a
    kept loop holds at least half of a true hole's points), precision and recall."""
    _, true_loops = _true_boundary(F)
    kinds = doc.get("kinds") or ["outer" if i == 0 or a > 0 else "hole"
                                 for i, a in enumerate(doc["areas"])]
    holes = [np.asarray(loop) for loop, k in zip(doc["loops"], kinds) if k == "hole"]
    true_holes = sorted(true_loops, key=len)[:-1]  # the rim is the longest
    found = [any(len(np.intersect1d(t, h)) >= 0.5 * len(t) for h in holes) for t in true_holes]
    return {**H.boundary_scores(doc["loops"], F), "holes": len(holes),
            "false_holes": sum(1 for h in holes if not any(
                len(np.intersect1d(t, h)) >= 0.5 * len(t) for t in true_holes)),
            "gaps": len(doc.get("gaps") or []), "holes_found": sum(found),
            "true_holes": len(true_holes), "found": found}


def loop_rows(args) -> list[dict]:
    """``pcgeom boundary`` of the shared surfaces (normals, bare) and of holed sheets (bare),
    before (``--baseline``, with ``--map``) and now (with and without ``--map``)."""
    from pcgeom.io import write_ply_atomic
    from pcgeom.synthetic_sheets import holed_sheet

    cases = []
    for name in args.loops:
        if H.available(name):
            s = H.load_surface(name)
            bare = args.work / f"{name}.ply"
            write_ply_atomic(bare, s.V, None)
            cases += [(name, "normals", H.write_with_normals(args.work / f"{name}_normals.ply",
                                                              s.V, s.F), s.F),
                      (name, "bare", bare, s.F)]
    for sampling in args.sheet_samplings:
        sheet = holed_sheet(6000, radii=SHEET_RADII, sampling=sampling, seed=0)
        src = args.work / f"holed_{sampling}.xyz"
        np.savetxt(src, sheet.points)
        cases.append((f"holed sheet, {sampling}", "bare", src, sheet.faces))
    rows = []
    for name, kind, src, F in cases:
        m = get_map(src, None, args.work)
        if m["path"] is None:
            rows.append({"surface": name, "input": kind, "error": m.get("error")})
            continue
        runs = [("before", args.baseline, ["--map", m["path"]]), ("now", None, ["--map", m["path"]])]
        if not args.no_unmapped:
            runs.append(("now, no --map", None, []))
        docs = {}
        for label, tree, extra in runs:
            if label == "before" and tree is None:
                continue
            out = args.work / f"{src.stem}_{label.replace(' ', '').replace(',', '_')}.json"
            old = os.environ.get("PYTHONPATH")
            os.environ["PYTHONPATH"] = os.fspath(tree or H.REPO)
            try:
                run = H.pcgeom_cli("boundary", src, *extra, "--out", out, check=False)
            finally:
                os.environ.pop("PYTHONPATH") if old is None else os.environ.update(
                    PYTHONPATH=old)
            row = {"surface": name, "input": kind, "version": label, "seconds": run["wall_s"],
                   "error": run["error"]}
            if not run["error"]:
                docs[label] = json.loads(out.read_text())
                row.update(loop_scores(docs[label], F))
            rows.append(row)
            H.log(f"{name} ({kind}) {label}: {row.get('loops')} loops, {row.get('holes')} holes "
                  f"({row.get('false_holes')} false), {row.get('gaps')} gaps, recall "
                  f"{row.get('recall')}")
        if "now" in docs and "now, no --map" in docs:
            rows[-1]["same_loops"] = docs["now"]["loops"] == docs["now, no --map"]["loops"]
    return rows


def render_loops(rows: list[dict], argv, meta: dict) -> str:
    def cell(r, key, fmt="{}"):
        return fmt.format(r[key]) if r.get(key) is not None else "-"

    columns = [("surface", "{surface}"), ("input", "{input}"), ("version", "{version}"),
               ("loops (true)", lambda r: f"{cell(r, 'loops')} ({cell(r, 'true_loops')})"),
               ("holes", lambda r: cell(r, "holes")),
               ("true holes found", lambda r: f"{cell(r, 'holes_found')}/{cell(r, 'true_holes')}"
                + (" (" + " ".join("y" if f else "n" for f in r["found"]) + ")"
                   if r.get("found") and r["surface"].startswith("holed") else "")),
               ("holes that are not", lambda r: cell(r, "false_holes")),
               ("gaps apart", lambda r: cell(r, "gaps")),
               ("precision", lambda r: cell(r, "precision", "{:.3f}")),
               ("recall", lambda r: cell(r, "recall", "{:.3f}")),
               ("same loops as with --map", lambda r: {True: "yes", False: "**no**"}.get(
                   r.get("same_loops"), "")),
               ("time s", lambda r: cell(r, "seconds", "{:.1f}"))]
    table = [r if not r.get("error") else f"| {r['surface']} | {r['input']} | "
             f"{r.get('version', '')} | failed: {r['error']} |" for r in rows]
    return side_section(
        "Boundary loops a QC script can trust (`bench_apps.py --loops`)", argv, meta, [
            "- each cloud mapped once by `pcgeom param --preset fast` (seed 0); `pcgeom "
            "boundary CLOUD --map MAP` *before* (the tree given as `--baseline`, in the same "
            "run) and *now*; *now, no --map*: `pcgeom boundary CLOUD`, which maps the cloud "
            "itself (its loops compared with the row above)",
            "- inputs: the shared surfaces with their reference mesh's vertex normals "
            "(*normals*) and without (*bare*); holed sheets "
            "(`pcgeom.synthetic_sheets.holed_sheet`, 6000 points, holes of radius "
            f"{', '.join(f'{r:g}' for r in SHEET_RADII)} spacings, smallest first in the y/n "
            "list; samplings uniform, grid: rows jittered by a quarter, scan: density falling "
            "4x across), bare",
            "- holes: loops of kind `hole` (before: the clockwise loops); *true holes found*: a "
            "hole holds at least half of a true hole's points; *holes that are not*: holes that "
            "hold less than half of every true hole's points (until 2026-12-05 09:00: fewer "
            "than half of their own points on the true boundary, which called found holes "
            "false once their loops walk through the notches of their rims: the holed sheets' "
            "reference triangles are clipped at their edges' midpoints, so their notch points "
            "are inside); precision and recall of the kept loops' points against the true "
            "boundary vertices",
            "- targets (issue 39 item 3): same loops with and without `--map`; face_human_choi "
            "with normals 1 outer loop, no hole; bare, every true hole found, recall >= 0.95, at "
            "most 2 holes that are not; peaks_7holes_choi its 8 loops"],
        columns, table)


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
    p.add_argument("--strays", nargs="*", metavar="NAME",
                   help="instead: reconstructions of these surfaces with depth noise and 1%% "
                        "strays beside MeshLab's (section bench_apps_strays)")
    p.add_argument("--seeds", nargs="*", type=int, default=[0, 1, 2])
    p.add_argument("--loops", nargs="*", metavar="NAME",
                   help="instead: pcgeom boundary's loops, kinds and gaps on these surfaces "
                        "and on holed sheets (section bench_apps_loops)")
    p.add_argument("--sheet-samplings", nargs="*", default=["uniform", "grid", "scan"])
    p.add_argument("--no-unmapped", action="store_true",
                   help="with --loops: skip the runs without --map")
    p.add_argument("--baseline", type=Path,
                   help="with --strays or --loops: a pcgeom source tree run side by side "
                        "as 'before'")
    args = p.parse_args(argv)
    args.given_maps = dict(args.maps)
    args.work.mkdir(parents=True, exist_ok=True)

    def load() -> str:
        return ", ".join(f"{x:.2f}" for x in os.getloadavg())

    meta = {"date": H.now(), "machine": f"{platform.machine()}, {os.cpu_count()} cores",
            "load_start": load(),
            "versions": H.versions("pcgeom", "torch", "gmsh", "libigl", "pymeshlab")}
    if args.loops is not None:
        args.loops = args.loops or list(LOOP_SURFACES)
    for chosen, rows_of, render_of, name in (
            (args.loops, loop_rows, render_loops, "bench_apps_loops"),
            (args.strays, strays_rows, render_strays, "bench_apps_strays")):
        if chosen is None:
            continue
        rows = rows_of(args)
        meta["load_end"] = load()
        section = render_of(rows, sys.argv[1:] if argv is None else argv, meta)
        H.write_section(args.out, name, section)
        if args.json:
            H.write_json(args.json, {"meta": meta, "rows": rows})
        print(section)
        return 0
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
