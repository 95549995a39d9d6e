"""The local mesh's topology (pcgeom.maps.topology), side by side with today's mesh in one run.

"today" is the same code with the repair replaced by its measurement alone and no mesh built
again from the map (the local mesh as before the topology work: its faces unchanged), run
interleaved with the repaired one.

1. Closed analytic surfaces (pcgeom.synthetic_closed: sphere, bumpy, peanut, torus; uniform,
   grid and scan samplings; 2k and 20k points, noise 0 and 0.25 spacings along the normals;
   50k for three, 200k once), bare: genus, boundary loops and Euler characteristic of the
   local mesh before and after, and whether a planar domain is refused (today: fewer
   boundary edges than sqrt(N) / 2; now: the repaired mesh is closed).
2. Open sheets with round holes of 1-5 spacings (pcgeom.synthetic_sheets.holed_sheet) on
   three samplings: the holes kept (a loop round each), false loops.
3. The lips sheet (walls 0.75 spacings apart, pcgeom.synthetic_sheets.lips_sheet), bare and
   with its normals: the free map against libigl's LSCM on its true mesh.
4. The pleats (pcgeom.synthetic.pleated_sheet, gap 1.5) and every shared open surface:
   free and disk maps, bare (free also with the mesh's normals), angle, flips and seconds
   and CPU seconds (medians of two interleaved runs each; the CPU seconds are what the wall
   would be on an idle machine, the runs being single-threaded, and their ratio is the one
   to judge on a loaded machine); the shared closed head refused, its mesh's topology.
"""

from __future__ import annotations

import statistics
import sys
import time
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import harness  # noqa: E402
import numpy as np  # noqa: E402

SHARED_OPEN = ("face_human_choi", "face_3holes_small_choi", "peaks_7holes_choi",
               "peaks_three_cgal")
HEAD = "closed_david_head_choi"


def _today_repair(X, normals, faces, *, exclude=None, spacing=None, dropped=None, cloud=None):
    """The repair's measurement alone: today's faces, their topology."""
    from pcgeom.maps import topology as tp

    faces = np.asarray(faces, dtype=np.int64)
    m = tp.measure(faces)
    return faces, tp.Topology(
        closed=m["boundary_loops"] == 0 and m["faces"] > 0, genus=m["genus"],
        boundary_loops=m["boundary_loops"], euler=m["euler"], components=m["components"],
        vertices=m["vertices"], faces=m["faces"], pinched=m["pinched"], pinches_split=0,
        pinches_repaired=0, holes_filled=0, spans_cut=0, bridges_cut=0, euler_before=m["euler"],
        boundary_loops_before=m["boundary_loops"], genus_before=m["genus"])


class Variant:
    """``with Variant("today"):`` runs pcgeom with today's local mesh (no repair, no mesh
    built again from the map)."""

    def __init__(self, name: str):
        self.name = name

    def __enter__(self):
        from pcgeom.maps import free, localmesh

        self._saved = localmesh.repair, free._uv_remeshed
        if self.name == "today":
            localmesh.repair = _today_repair
            free._uv_remeshed = _today_remesh
        return self

    def __exit__(self, *exc):
        from pcgeom.maps import free, localmesh

        localmesh.repair, free._uv_remeshed = self._saved


def _today_remesh(Xn, kept, solve, **_):
    """Today's free map: no mesh built again from the map (pcgeom.maps.uvmesh)."""
    return kept[0], kept[1], kept[3]


def _mesh(X, normals=None):
    """The local mesh of ``X`` as a run makes it (normalized, no refusal): its record and the
    seconds it took."""
    from pcgeom.cloud import normalize
    from pcgeom.config import get_preset
    from pcgeom.maps.localmesh import mesh_cloud

    s = get_preset("fast").local_mesh
    Xn, _, _ = normalize(np.asarray(X, dtype=np.float64))
    t0 = time.perf_counter()
    mesh, _, record = mesh_cloud(Xn, normals, s.neighbours, s.normal_neighbours, progress=False,
                                 normal_scales=s.normal_scales,
                                 normal_tolerance=s.normal_tolerance, onto=None)
    return mesh, record, time.perf_counter() - t0


def closed_rows(quick: bool) -> list[dict]:
    from pcgeom.synthetic_closed import closed_surface

    cases = []
    for name in ("sphere", "bumpy", "peanut", "torus"):
        for sampling in ("uniform", "grid", "scan"):
            for noise in (0.0, 0.25):
                for n in ((2000,) if quick else (2000, 20000)):
                    cases.append((name, sampling, noise, n))
    if not quick:
        cases += [("bumpy", s, 0.0, 50000) for s in ("uniform", "grid", "scan")]
        cases.append(("bumpy", "uniform", 0.25, 200000))
    rows = []
    for name, sampling, noise, n in cases:
        s = closed_surface(name, n, sampling=sampling, noise=noise, seed=1)
        with Variant("today"):
            mesh0, _, sec0 = _mesh(s.points)
        mesh1, _, sec1 = _mesh(s.points)
        t0, t1 = mesh0.topology, mesh1.topology
        old_refused = mesh0.boundary_edges < 0.5 * np.sqrt(len(mesh0.main))
        rows.append({"shape": name, "sampling": sampling, "noise": noise, "n": n,
                     "genus": s.genus, "euler0": t0.euler, "loops0": t0.boundary_loops,
                     "genus0": t0.genus, "refused0": "yes" if old_refused else "**no**",
                     "euler1": t1.euler, "loops1": t1.boundary_loops, "genus1": t1.genus,
                     "refused1": "yes" if t1.closed else "**no**",
                     "right": "yes" if t1.closed and t1.genus == s.genus else "**no**",
                     "filled": t1.holes_filled, "s0": sec0, "s1": sec1})
        harness.log(f"closed {name} {sampling} {noise} {n}: loops {t0.boundary_loops} -> "
                    f"{t1.boundary_loops}, genus {t0.genus} -> {t1.genus}, euler {t0.euler} -> "
                    f"{t1.euler}; {sec0:.1f} / {sec1:.1f} s")
    return rows


def _holes_kept(sheet, faces) -> tuple[int, int]:
    """How many of the sheet's holes have a boundary loop of ``faces`` round them, and how
    many loops are neither the rim (the longest) nor round a hole."""
    import igl

    from pcgeom.mesh import main_faces

    F = main_faces(faces)
    split, index = igl.split_nonmanifold(np.ascontiguousarray(F, dtype=np.int64))
    loops = [index[np.asarray(l)] for l in igl.boundary_loop_all(split)]
    if not loops:
        return 0, 0
    rim = max(range(len(loops)), key=lambda k: len(loops[k]))
    P = sheet.params
    side = P.max(axis=0)
    # The holes' centres, as holed_sheet places them.
    k = sheet.boundary_loops - 1
    centres = np.column_stack([side[0] * (0.2 + 0.6 * (np.arange(k) % 3) / 2.0),
                               side[1] * (0.25 + 0.5 * (np.arange(k) // 3))])
    kept = np.zeros(k, dtype=bool)
    false = 0
    for j, loop in enumerate(loops):
        if j == rim:
            continue
        c = P[loop].mean(axis=0)
        d = np.linalg.norm(centres - c, axis=1)
        near = np.flatnonzero(d < 6.0 * sheet.spacing)
        if len(near):
            kept[near[np.argmin(d[near])]] = True
        else:
            false += 1
    return int(kept.sum()), false


def holed_rows() -> list[dict]:
    from pcgeom.synthetic_sheets import holed_sheet

    rows = []
    for sampling in ("uniform", "grid", "scan"):
        s = holed_sheet(6000, sampling=sampling, seed=2)
        out = {"sampling": sampling, "n": len(s.points), "holes": s.boundary_loops - 1}
        for tag, variant in (("0", "today"), ("1", "repair")):
            with Variant(variant):
                mesh, _, _ = _mesh(s.points)
            kept, false = _holes_kept(s, mesh.faces)
            t = mesh.topology
            out.update({f"loops{tag}": t.boundary_loops, f"genus{tag}": t.genus,
                        f"euler{tag}": t.euler, f"kept{tag}": kept, f"false{tag}": false})
        rows.append(out)
        harness.log(f"holed {sampling}: kept {out['kept0']} -> {out['kept1']} of {out['holes']},"
                    f" false {out['false0']} -> {out['false1']}")
    return rows


def _map(X, F, domain="free", normals=None):
    from pcgeom import parametrize
    from pcgeom.metrics import angle_distortion

    t0, c0 = time.perf_counter(), time.process_time()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = parametrize(X, domain, normals=normals, progress=False)
    seconds, cpu = time.perf_counter() - t0, time.process_time() - c0
    a = angle_distortion(X, F, result.uv)
    record = next(h for h in result.history if h.get("kind") == "localmesh")
    return {"rad": a.mean_abs, "flipped": a.flipped, "pct": 100 * a.flipped / a.n_faces,
            "s": seconds, "cpu": cpu, "genus": record.get("genus"), "loops": record.get("boundary_loops"),
            "topology": record.get("topology")}


def map_rows(surfaces, repeats: int) -> list[dict]:
    """Each surface's maps, today and repaired interleaved ``repeats`` times: medians."""
    rows = []
    for name, X, F, N, maps in surfaces:
        for domain, with_normals in maps:
            runs = {"today": [], "repair": []}
            for _ in range(repeats):
                for variant in ("today", "repair"):
                    with Variant(variant):
                        runs[variant].append(_map(X, F, domain, N if with_normals else None))
            row = {"surface": name, "domain": domain,
                   "normals": "mesh" if with_normals else "bare"}
            for tag, variant in (("0", "today"), ("1", "repair")):
                r = runs[variant]
                row.update({f"rad{tag}": statistics.median(x["rad"] for x in r),
                            f"pct{tag}": statistics.median(x["pct"] for x in r),
                            f"s{tag}": statistics.median(x["s"] for x in r),
                            f"cpu{tag}": statistics.median(x["cpu"] for x in r),
                            f"genus{tag}": r[0]["genus"], f"loops{tag}": r[0]["loops"]})
                if variant == "repair":
                    t = r[0]["topology"]
                    row.update(euler0=t["euler_before"], euler1=t["euler"])
            row["ratio"] = row["s1"] / row["s0"]
            row["cpu_ratio"] = row["cpu1"] / row["cpu0"]
            rows.append(row)
            harness.log(f"{name} {domain} {row['normals']}: {row['rad0']:.4f} -> {row['rad1']:.4f}"
                        f" rad, {row['pct0']:.2f} -> {row['pct1']:.2f}% flipped, "
                        f"{row['s0']:.1f} -> {row['s1']:.1f} s")
    return rows


def lips_rows() -> list[dict]:
    from pcgeom.apps.baselines import lscm
    from pcgeom.metrics import angle_distortion
    from pcgeom.synthetic_sheets import lips_sheet

    s = lips_sheet(11000, gap=0.75)
    ref = angle_distortion(s.points, s.faces, lscm(s.points, s.faces))
    rows = map_rows([("lips_sheet 0.75", s.points, s.faces, s.normals,
                      (("free", False), ("free", True)))], repeats=1)
    for r in rows:
        r.update(lscm=ref.mean_abs, lscm_pct=100 * ref.flipped / ref.n_faces)
    return rows


def shared_surfaces():
    from pcgeom.synthetic import pleated_sheet

    out = []
    p = pleated_sheet(6000, folds=4, gap=1.5)
    out.append(("pleated_sheet 1.5", p.points, p.faces, p.normals,
                (("free", False), ("disk", False))))
    for name in SHARED_OPEN:
        if not harness.available(name):
            continue
        surf = harness.load_surface(name)
        N = harness.mesh_normals(surf.V, surf.F)
        out.append((name, surf.V, surf.F, N, (("free", False), ("free", True), ("disk", False))))
    return out


def head_row() -> dict | None:
    from pcgeom import InputError, parametrize

    if not harness.available(HEAD):
        return None
    surf = harness.load_surface(HEAD)
    try:
        parametrize(surf.V, progress=False)
        message = "**not refused**"
    except InputError as err:
        message = str(err)
    with Variant("today"):
        mesh0, _, _ = _mesh(surf.V)
    mesh1, _, _ = _mesh(surf.V)
    t0, t1 = mesh0.topology, mesh1.topology
    return {"message": message, "euler0": t0.euler, "loops0": t0.boundary_loops,
            "genus0": t0.genus, "euler1": t1.euler, "loops1": t1.boundary_loops,
            "genus1": t1.genus, "closed": t1.closed}


def main(argv=None) -> None:
    p = harness.parser(__doc__, "the figures as JSON")
    p.add_argument("--quick", action="store_true", help="2k closed clouds only, one map run")
    args = p.parse_args(argv)
    t0 = time.perf_counter()
    closed = closed_rows(args.quick)
    holed = holed_rows()
    lips = lips_rows()
    maps = map_rows(shared_surfaces(), repeats=1 if args.quick else 2)
    head = head_row()
    lines = ["## The local mesh's topology (bench_topology)", "",
             *harness.header(argv, f"load {harness.loadavg()}", harness.cpu_model(),
                             harness.versions("numpy", "scipy", "libigl")),
             "- today: the same run with the repair replaced by its measurement and no mesh "
             "built again from the map (the local mesh as before); genus, loops and Euler "
             "characteristic of the mesh's largest part, pinched vertices split (libigl).", "",
             "### Closed analytic surfaces, bare points (refused on planar domains?)", ""]
    lines += harness.table([
        ("shape", "{shape}"), ("sampling", "{sampling}"), ("noise", "{noise}"), ("n", "{n}"),
        ("true genus", "{genus}"),
        ("today: Euler / loops / genus", "{euler0} / {loops0} / {genus0}"),
        ("today refused", "{refused0}"),
        ("now: Euler / loops / genus", "{euler1} / {loops1} / {genus1}"),
        ("now refused", "{refused1}"), ("genus right", "{right}"), ("holes filled", "{filled}"),
        ("mesh s today / now", "{s0:.1f} / {s1:.1f}")], closed)
    ok = sum(r["right"] == "yes" for r in closed)
    lines += ["", f"Refused with the right genus: {ok} of {len(closed)} now; refused today: "
              f"{sum(r['refused0'] == 'yes' for r in closed)} of {len(closed)}.", "",
              "### Open sheets with round holes of radius 1, 2, 3, 4, 5 spacings", ""]
    lines += harness.table([
        ("sampling", "{sampling}"), ("n", "{n}"),
        ("today: Euler / loops / genus", "{euler0} / {loops0} / {genus0}"),
        ("today: holes kept / false loops", "{kept0} / {false0}"),
        ("now: Euler / loops / genus", "{euler1} / {loops1} / {genus1}"),
        ("now: holes kept / false loops", "{kept1} / {false1}")], holed)
    lines += ["", "### Maps, today and now (medians of interleaved runs; angle on the true "
              "triangles)", ""]
    lines += harness.table([
        ("surface", "{surface}"), ("domain", "{domain}"), ("normals", "{normals}"),
        ("rad today / now", "{rad0:.4f} / {rad1:.4f}"),
        ("flipped % today / now", "{pct0:.2f} / {pct1:.2f}"),
        ("s today / now", "{s0:.1f} / {s1:.1f} ({ratio:.2f}x)"),
        ("CPU s today / now", "{cpu0:.1f} / {cpu1:.1f} ({cpu_ratio:.2f}x)"),
        ("Euler before / after", "{euler0} / {euler1}"),
        ("loops today / now", "{loops0} / {loops1}"),
        ("genus today / now", "{genus0} / {genus1}")], lips + maps)
    if lips:
        lines += ["", f"The lips sheet's true mesh, libigl LSCM: {lips[0]['lscm']:.4f} rad, "
                  f"{lips[0]['lscm_pct']:.2f}% flipped (the goal: within 1.5x, under 0.1%)."]
    if head:
        lines += ["", f"{HEAD}: refused with `{head['message']}`; its local mesh today Euler "
                  f"{head['euler0']}, {head['loops0']} loops, genus {head['genus0']}; now "
                  f"{head['euler1']}, {head['loops1']} loops, genus {head['genus1']} (closed: "
                  f"{head['closed']})."]
    lines += ["", f"({time.perf_counter() - t0:.0f} s in all.)"]
    harness.write_section(args.out, "bench_topology", "\n".join(lines))
    if args.json:
        harness.write_json(args.json, {"closed": closed, "holed": holed, "lips": lips,
                                       "maps": maps, "head": head})


if __name__ == "__main__":
    main()
