"""Benchmark real-scan conditions: normals or none, noise, and the time-versus-N curve.

``pcgeom param`` as a user runs it (harness.param_runs), scored on the reference triangles it
never sees, on inputs written from each reference mesh: with its vertex normals (as a scanner
writes them) and bare; with Gaussian noise of :data:`NOISE_EDGES` mean edge lengths (scored
against the noisy points on the true connectivity, beside libigl's LSCM on that noisy mesh);
with depth noise of :data:`DEPTH_NOISE` mean edge lengths along the normals, bare, mapped
with ``--denoise off`` and ``auto`` and judged on the clean mesh, the clean clouds the same
way, and ``pcgeom reconstruct`` of a noisy face against the clean mesh; and five bumps over a
square of N points (uniform random and a jittered grid), for time and peak memory against N,
free and onto the disk, optionally beside an earlier version (``--baseline``), drawn to
``benchmarks/figures/<stem>_time_vs_n.png`` (or next to an ``--out`` elsewhere). Replaces
the section ``--section`` (default ``bench_scans``) of BENCHMARKS.md.
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import harness as H
import numpy as np

NOISE_EDGES = 0.25
"""Noise level, in mean edge lengths (the issue's)."""

DEPTH_NOISE = (0.25, 0.5, 1.0)
"""Depth noise levels (Gaussian along the clean mesh's vertex normals), in mean edge lengths."""

DENOISE_TARGETS = {  # (surface, depth noise) -> (max rad, max flipped %), issue 25
    ("face_3holes_small_choi", 0.5): (0.04, 0.1),
    ("face_human_choi", 0.5): (0.04, 0.1),
}

TARGETS = {  # (surface, input kind, preset) -> (max rad, max flipped %, max seconds)
    ("face_human_choi", "normals", "fast"): (0.025, 0.1, 60.0),
    ("face_human_choi", "bare", "fast"): (0.047, 3.7, None),
    ("peaks3", "bare", "fast"): (0.01, 0.0, 30.0),
}


def quality_rows(names, presets, repeats, work: Path, slow_names=()) -> list[dict]:
    """Per surface, input (with normals, bare) and preset; presets other than ``fast``
    (minutes each) run once, and only on ``slow_names``."""
    from pcgeom.apps.baselines import lscm

    rows = []
    for name in names:
        s = H.load_surface(name)
        inputs = {"normals": H.write_with_normals(work / f"{name}_normals.ply", s.V, s.F),
                  "bare": work / f"{name}_bare.xyz"}
        np.savetxt(inputs["bare"], s.V)
        for kind, preset in ((k, p) for k in inputs for p in presets):
            if preset == "fast" or name in slow_names:
                runs = H.param_runs(inputs[kind], s.V, s.F, work,
                                    range(repeats if preset == "fast" else 1), preset=preset)
                rows.append(H.summary(runs, surface=name, points=len(s.V), input=kind,
                                      preset=preset))
        rows.append(H.summary([H.reference(lscm, s.V, s.F)], surface=name, points=len(s.V),
                              input="true mesh", preset="libigl LSCM", normals="-"))
    return rows


def disk_rows(names, presets, work: Path, slow_names=()) -> list[dict]:
    """Onto the unit disk, the input with its normals, beside libigl's harmonic map."""
    from pcgeom.apps.baselines import harmonic_disk

    rows = []
    for name in names:
        s = H.load_surface(name)
        src = H.write_with_normals(work / f"{name}_normals.ply", s.V, s.F)
        rows += [H.summary(H.param_runs(src, s.V, s.F, work, preset=preset, domain="disk"),
                           surface=name, preset=preset)
                 for preset in presets if preset == "fast" or name in slow_names]
        rows.append(H.summary([H.reference(harmonic_disk, s.V, s.F, "disk")], surface=name,
                              preset="libigl harmonic (true mesh)", wall_s=float("nan")))
    return rows


def noise_rows(names, work: Path, seed: int = 0) -> list[dict]:
    from pcgeom.apps.baselines import lscm

    rows = []
    for name in names:
        V, F = (s := H.load_surface(name)).V, s.F
        edges = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
        mean_edge = float(np.linalg.norm(V[edges[:, 0]] - V[edges[:, 1]], axis=1).mean())
        Vn = V + np.random.default_rng(seed).normal(scale=NOISE_EDGES * mean_edge, size=V.shape)
        src = H.write_with_normals(work / f"{name}_noise.ply", Vn, F)
        (run,), ref = H.param_runs(src, Vn, F, work), H.reference(lscm, Vn, F)
        # Triangles the noise itself turned over (against the clean surface's normal): a map
        # that keeps the noise's tangential part flips them.
        cross = np.cross(Vn[F[:, 1]] - Vn[F[:, 0]], Vn[F[:, 2]] - Vn[F[:, 0]])
        folded = float((np.einsum("md,md->m", cross, H.mesh_normals(V, F)[F].sum(axis=1)) < 0)
                       .mean() * 100)
        rows.append({**run, "surface": name, "folded_pct": folded, "lscm_rad": ref["rad"],
                     "lscm_flip_pct": ref["flip_pct"], "ratio": run["rad"] / ref["rad"]})
    return rows


def depth_noisy(V, F, level: float, seed: int = 0):
    """``V`` moved along the clean mesh's vertex normals by Gaussian noise of ``level`` mean
    edge lengths (a range scanner's depth noise), and that noise's std."""
    edges = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    std = level * float(np.linalg.norm(V[edges[:, 0]] - V[edges[:, 1]], axis=1).mean())
    noise = np.random.default_rng(seed).normal(scale=std, size=(len(V), 1))
    return V + H.mesh_normals(V, F) * noise, std


def denoise_rows(names, work: Path, levels=DEPTH_NOISE, seed: int = 0) -> list[dict]:
    """Bare clouds with depth noise, mapped by ``pcgeom param --denoise off`` and ``auto``,
    every map judged on the clean mesh (each input point's uv on the clean triangles), beside
    libigl's LSCM on the noisy mesh (judged the same way)."""
    from pcgeom.apps.baselines import lscm

    rows = []
    for name in names:
        V, F = (s := H.load_surface(name)).V, s.F
        for level in levels:
            Vn, std = depth_noisy(V, F, level, seed)
            src = work / f"{name}_depth{level}.xyz"
            np.savetxt(src, Vn)
            row = {"surface": name, "points": len(V), "level": level}
            for mode in ("off", "auto"):
                out = work / f"{name}_depth{level}_{mode}_uv.npz"
                run = H.pcgeom_cli(*H.param_args(src, out), "--denoise", mode, check=False)
                if run["error"]:  # the map refuses the noisy cloud: not a surface
                    H.log(f"{name}, depth noise {level}, {mode}: {run['error']}")
                    row.update({f"{mode}_rad": float("nan"), f"{mode}_flip": float("nan"),
                                f"{mode}_s": run["wall_s"], f"{mode}_error": run["error"]})
                    continue
                score = H.score_file(out, V, F)
                record = run["json"]["denoise"] or {}
                row.update({f"{mode}_rad": score["rad"], f"{mode}_flip": score["flip_pct"],
                            f"{mode}_s": run["wall_s"]})
                if mode == "auto":
                    row.update(noise=record.get("noise"), applied=record.get("applied"),
                               noise_ratio=record.get("noise_std", float("nan")) / std)
            U, seconds = H.timed(lscm, Vn, F)
            score = H.score_map(U, V, F)
            row.update(lscm_rad=score["rad"], lscm_flip=score["flip_pct"], lscm_s=seconds)
            rows.append(row)
            H.log(f"{name}, depth noise {level}: off {row['off_rad']:.4f} rad, auto "
                  f"{row['auto_rad']:.4f} rad ({row['auto_flip']:.2f}%), LSCM {row['lscm_rad']:.4f}")
    return rows


def clean_denoise_rows(names, work: Path, repeats: int = 3) -> list[dict]:
    """Clean bare clouds with ``--denoise off`` and ``auto``: quality and time (medians)."""
    rows = []
    for name in names:
        s = H.load_surface(name)
        src = work / f"{name}_clean.xyz"
        np.savetxt(src, s.V)
        row = {"surface": name, "points": len(s.V)}
        for mode in ("off", "auto"):
            runs = []
            for k in range(repeats):
                out = work / f"{name}_clean_{mode}_uv.npz"
                run = H.pcgeom_cli(*H.param_args(src, out), "--denoise", mode)
                runs.append({"wall_s": run["wall_s"], **H.score_file(out, s.V, s.F),
                             "noise": (run["json"]["denoise"] or {}).get("noise"),
                             "applied": (run["json"]["denoise"] or {}).get("applied")})
            row.update({f"{mode}_rad": runs[0]["rad"], f"{mode}_flip": runs[0]["flip_pct"],
                        f"{mode}_s": H.median(runs, "wall_s")})
            if mode == "auto":
                row.update(noise=runs[0]["noise"], applied=runs[0]["applied"])
        rows.append(row)
        H.log(f"{name} clean: off {row['off_rad']:.4f}, auto {row['auto_rad']:.4f} rad, "
              f"{row['off_s']:.1f} / {row['auto_s']:.1f} s")
    return rows


def reconstruct_rows(names, work: Path, level: float = 0.5, seeds=(0, 1, 2)) -> list[dict]:
    """``pcgeom reconstruct`` of bare clouds with depth noise, ``--denoise off`` and
    ``auto``: distances from the mesh's vertices to the clean mesh, and from the clean mesh's
    vertices to the mesh, in units of the noise's std."""
    import trimesh

    rows = []
    for name in names:
        V, F = (s := H.load_surface(name)).V, s.F
        for seed in seeds:
            Vn, std = depth_noisy(V, F, level, seed)
            src = work / f"{name}_depth{level}_{seed}.xyz"
            np.savetxt(src, Vn)
            row = {"surface": name, "level": level, "seed": seed,
                   "points_max": float(H.distances(Vn, V, F).max() / std)}
            for mode in ("off", "auto"):
                out = work / f"{name}_depth{level}_{seed}_{mode}.ply"
                run = H.pcgeom_cli("reconstruct", src, "--out", out, "--denoise", mode,
                                   check=False)
                if run["error"]:
                    row[f"{mode}_error"] = run["error"]
                    continue
                m = trimesh.load(out, process=False)
                to_clean = H.distances(m.vertices, V, F) / std
                from_clean = H.distances(V, m.vertices, m.faces) / std
                row.update({f"{mode}_max": float(to_clean.max()),
                            f"{mode}_mean": float(to_clean.mean()),
                            f"{mode}_back": float(from_clean.max()),
                            f"{mode}_loops": run["json"]["n_boundary_loops"],
                            f"{mode}_s": run["wall_s"]})
            rows.append(row)
            H.log(f"reconstruct {name} depth {level} seed {seed}: off max "
                  f"{row.get('off_max', float('nan')):.2f} std, auto max "
                  f"{row.get('auto_max', float('nan')):.2f} std")
    return rows


def denoise_verdicts(rows) -> list[str]:
    lines = []
    for (name, level), (rad, flip) in DENOISE_TARGETS.items():
        for r in rows:
            if (r["surface"], r["level"]) == (name, level):
                ok = r["auto_rad"] <= rad and r["auto_flip"] < flip  # NaN: refused
                lines.append(f"- {name}, depth noise {level}, bare, `--denoise auto`: "
                             f"{r['auto_rad']:.4f} rad, {r['auto_flip']:.2f}% flipped; want "
                             f"<= {rad} rad, < {flip}% flipped: **{'PASS' if ok else 'MISS'}**")
    return lines


SAMPLINGS = ("uniform", "grid")
"""Uniform random points, and a grid jittered by a tenth of its step (a range scan's rows)."""

SCALE_TARGETS = {"time_1m": 180.0, "rss_1m": 3.0, "time_300k": 30.0, "slope": 1.1,
                 "disk_time_1m": 240.0, "disk_rss_1m": 3.0}
"""Issue 26's targets (2 cores, ``fast``): seconds and GB at 1M points, seconds at 300k, the
slope of log time against log N from 100k to 1M, and the disk at 1M."""


def heightfield(n: int, sampling: str = "uniform", seed: int = 0) -> np.ndarray:
    """``n`` points (about, for the grid) of the five-bump height field over [-1, 1]^2
    (:data:`pcgeom.examples.BUMPS`, ``"scale"``)."""
    from pcgeom.examples import BUMPS, bump_height

    rng = np.random.default_rng(seed)
    if sampling == "grid":
        side = int(round(np.sqrt(n)))
        g = np.linspace(-1.0, 1.0, side)
        xy = np.stack(np.meshgrid(g, g), axis=-1).reshape(-1, 2)
        xy = xy + rng.uniform(-0.1, 0.1, xy.shape) * (g[1] - g[0])
    else:
        xy = rng.uniform(-1.0, 1.0, (n, 2))
    return np.column_stack([xy, bump_height(xy[:, 0], xy[:, 1], BUMPS["scale"])[0]])


def scale_rows(sizes, work: Path, samplings=SAMPLINGS, domain: str = "free",
               tree: Path | None = None, version: str = "this") -> list[dict]:
    """``pcgeom param`` (``fast``) of each sampling and size: wall and CLI seconds, peak
    RSS, angles and flips on the true triangles. ``tree``: a pcgeom source tree to run
    instead of this one (``version`` names it in the rows)."""
    import os

    rows = []
    for sampling in samplings:
        for n in sizes:
            src = work / f"heightfield_{sampling}_{n}.xyz"
            X = heightfield(n, sampling)
            if not src.exists():
                np.savetxt(src, X, fmt="%.9f")
            out = work / f"heightfield_{sampling}_{n}_{domain}_{version}_uv.npz"
            saved = os.environ["PYTHONPATH"]
            if tree is not None:
                os.environ["PYTHONPATH"] = os.fspath(tree)
            try:
                run = H.pcgeom_cli(*H.param_args(src, out, domain=domain), check=False)
            finally:
                os.environ["PYTHONPATH"] = saved
            row = {"sampling": sampling, "points": len(X), "domain": domain,
                   "version": version, **run}
            if run["error"]:
                row.update(train_s=float("nan"), rad=float("nan"), flipped=-1,
                           solver="-", ordering="-")
            else:
                row.update(train_s=run["json"]["seconds"],
                           **H.score_file(out, X, H.planar_triangles(X), on_domain=False))
            out.unlink(missing_ok=True)
            rows.append(row)
            H.log(f"{sampling} {n} {domain} ({version}): {row['wall_s']:.1f} s, "
                  f"{row['rss_gb']:.2f} GB, {row['rad']:.4f} rad, {row['flipped']} flipped"
                  + (f" [{run['error']}]" if run["error"] else ""))
    return rows


def small_rows(names, work: Path, tree: Path, repeats: int = 3) -> list[dict]:
    """Small clouds (the shared surfaces, bare) by this version and by the one in ``tree``,
    runs interleaved (this, before, this, ...) so that both meet the same machine load:
    median wall seconds, angles and flips on the true triangles."""
    import os

    rows = []
    for name in names:
        s = H.load_surface(name)
        src = work / f"{name}_small_bare.xyz"
        np.savetxt(src, s.V)
        runs = {"this": [], "before": []}
        for k in range(repeats):
            for version in runs:
                saved = os.environ["PYTHONPATH"]
                if version == "before":
                    os.environ["PYTHONPATH"] = os.fspath(tree)
                out = work / f"{name}_small_{version}_{k}_uv.npz"
                try:
                    run = H.pcgeom_cli(*H.param_args(src, out))
                finally:
                    os.environ["PYTHONPATH"] = saved
                runs[version].append({**run, **H.score_file(out, s.V, s.F)})
        for version, done in runs.items():
            rows.append({"surface": name, "points": len(s.V), "version": version,
                         "runs": len(done), "wall_s": H.median(done, "wall_s"),
                         "rss_gb": H.median(done, "rss_gb"), "rad": done[0]["rad"],
                         "flipped": done[0]["flipped"]})
        ratio = rows[-2]["wall_s"] / rows[-1]["wall_s"]
        H.log(f"{name}: this {rows[-2]['wall_s']:.1f} s, before {rows[-1]['wall_s']:.1f} s "
              f"({ratio:.2f}x)")
    return rows


def slope(rows, sampling: str, domain: str = "free", lo: int = 100_000,
          hi: int = 1_000_000) -> float | None:
    """The slope of log wall time against log N between the rows nearest ``lo`` and ``hi``
    points (None without both)."""
    mine = [r for r in rows if r["sampling"] == sampling and r["domain"] == domain
            and r["version"] == "this" and not r["error"]]
    if len(mine) < 2:
        return None
    a = min(mine, key=lambda r: abs(np.log(r["points"] / lo)))
    b = min(mine, key=lambda r: abs(np.log(r["points"] / hi)))
    if a is b:
        return None
    return float(np.log(b["wall_s"] / a["wall_s"]) / np.log(b["points"] / a["points"]))


def scale_verdicts(rows) -> list[str]:
    """Issue 26's targets against the rows of this version."""
    def near(sampling, n, domain="free"):
        found = [r for r in rows if r["sampling"] == sampling and r["domain"] == domain
                 and r["version"] == "this" and abs(np.log(r["points"] / n)) < 0.05]
        return found[0] if found else None

    T, lines = SCALE_TARGETS, []
    for sampling in SAMPLINGS:
        for n, domain, secs, gb in ((1_000_000, "free", T["time_1m"], T["rss_1m"]),
                                    (300_000, "free", T["time_300k"], None),
                                    (1_000_000, "disk", T["disk_time_1m"], T["disk_rss_1m"])):
            r = near(sampling, n, domain)
            if r is None:
                continue
            ok = not r["error"] and r["wall_s"] <= secs and (gb is None or r["rss_gb"] <= gb)
            lines.append(f"- {sampling}, {r['points']} points, {domain}: {r['wall_s']:.1f} s, "
                         f"{r['rss_gb']:.2f} GB; want <= {secs:.0f} s"
                         + (f", <= {gb} GB" if gb else "")
                         + f": **{'PASS' if ok else 'MISS'}**")
        k = slope(rows, sampling)
        if k is not None:
            lines.append(f"- {sampling}, slope of log time against log N from 100k to 1M: "
                         f"{k:.2f}; want <= {T['slope']}: "
                         f"**{'PASS' if k <= T['slope'] else 'MISS'}**")
    return lines


def plot_scale(rows, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4), dpi=100)
    styles = {("free", "this"): "o-", ("disk", "this"): "s--", ("free", "before"): "x:"}
    for (domain, version), style in styles.items():
        for sampling, colour in zip(SAMPLINGS, ("tab:blue", "tab:orange")):
            mine = sorted((r for r in rows if (r["domain"], r["version"], r["sampling"])
                           == (domain, version, sampling) and not r["error"]),
                          key=lambda r: r["points"])
            if len(mine) < 2:
                continue
            k = slope(rows, sampling, domain) if version == "this" else None
            label = f"{sampling}, {domain}" + ("" if version == "this" else f" ({version})")
            if k:  # from the size nearest 100k to the largest
                lo = min(mine, key=lambda r: abs(np.log(r["points"] / 100_000)))["points"]
                label += f", slope {k:.2f} ({lo // 1000}k-{mine[-1]['points'] // 1000}k)"
            ax.loglog([r["points"] for r in mine], [r["wall_s"] for r in mine], style,
                      color=colour, label=label)
    n = np.array([r["points"] for r in rows], dtype=float)
    if len(n):
        top = max(r["wall_s"] for r in rows if r["points"] == n.max())
        grid = np.array([n.min(), n.max()])
        ax.loglog(grid, grid * top / n.max(), "k:", lw=0.8, label="linear in N")
    ax.set_xlabel("points")
    ax.set_ylabel("wall seconds, whole CLI (2 CPU cores)")
    ax.legend(fontsize=7)
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)
    plt.close(fig)


def verdicts(rows) -> list[str]:
    lines = []
    for (name, kind, preset), (rad, flip, secs) in TARGETS.items():
        for r in rows:
            if (r["surface"], r["input"], r["preset"]) != (name, kind, preset):
                continue
            ok = r["rad"] <= rad and r["flip_pct"] <= flip and (not secs or r["wall_s"] <= secs)
            lines.append(f"- {name} ({kind}, `{preset}`): {r['rad']:.4f} rad, "
                         f"{r['flip_pct']:.2f}% flipped, {r['wall_s']:.1f} s; want <= {rad} rad, "
                         f"<= {flip}% flipped" + (f", <= {secs:.0f} s" if secs else "")
                         + f": **{'PASS' if ok else 'MISS'}**")
            break
    return lines


def _rad(row, mode) -> str:
    return "refused (not a surface)" if row.get(f"{mode}_error") else f"{row[mode + '_rad']:.4f}"


def _flip(row, mode) -> str:
    return "-" if row.get(f"{mode}_error") else f"{row[mode + '_flip']:.2f}%"


def render_denoise(depth, clean, recon) -> list[str]:
    out = []
    if depth:
        out += ["Depth noise (Gaussian along the clean mesh's vertex normals, in mean edge "
                "lengths), bare clouds, `fast`, each input point's uv judged on the clean "
                "mesh's triangles; `--denoise off` is the map of the noisy points, `auto` "
                "fits the surface first when the estimated noise exceeds 0.2 spacings "
                "(spacing: median nearest-neighbour distance in the tangent plane, about "
                "0.5-0.8 mean edge lengths); LSCM is libigl's on the noisy mesh, judged the "
                "same way.", "",
                *H.table([("surface", "{surface}"), ("noise, edges", "{level}"),
                          ("estimated, spacings", lambda r: f"{r.get('noise') or 0:.2f}"),
                          ("estimate / true std",
                           lambda r: f"{r.get('noise_ratio', float('nan')):.2f}"),
                          ("off, rad", lambda r: _rad(r, "off")),
                          ("flipped", lambda r: _flip(r, "off")),
                          ("auto, rad", lambda r: _rad(r, "auto")),
                          ("flipped", lambda r: _flip(r, "auto")),
                          ("LSCM noisy mesh, rad", "{lscm_rad:.4f}"),
                          ("flipped", "{lscm_flip:.2f}%"),
                          ("wall s off / auto", "{off_s:.1f} / {auto_s:.1f}")], depth),
                "", *denoise_verdicts(depth), ""]
    if clean:
        out += ["Clean bare clouds, `--denoise off` and `auto` (auto estimates the noise and "
                "leaves a clean cloud as it is; wall time the median of 3 runs):", "",
                *H.table([("surface", "{surface}"), ("points", "{points}"),
                          ("estimated noise, spacings", lambda r: f"{r['noise']:.3f}"),
                          ("denoised", "{applied}"),
                          ("off, rad", "{off_rad:.4f}"), ("flipped", "{off_flip:.2f}%"),
                          ("auto, rad", "{auto_rad:.4f}"), ("flipped", "{auto_flip:.2f}%"),
                          ("wall s off / auto", "{off_s:.1f} / {auto_s:.1f}")], clean), ""]
    if recon:
        out += ["`pcgeom reconstruct` of bare clouds with depth noise (defaults, 5000 "
                "vertices): the largest and mean distance from the mesh's vertices to the "
                "clean mesh, and the largest from the clean mesh's vertices to the mesh (the "
                "rim: the detected loops run inside the clean rim), in units of the noise's "
                "std; the noisy points themselves lie up to the 'points' column from it.", "",
                *H.table([("surface", "{surface}"), ("seed", "{seed}"),
                          ("points, max", "{points_max:.2f}"),
                          ("off: mesh max", lambda r: f"{r.get('off_max', float('nan')):.2f}"),
                          ("mean", lambda r: f"{r.get('off_mean', float('nan')):.2f}"),
                          ("clean to mesh", lambda r: f"{r.get('off_back', float('nan')):.2f}"),
                          ("loops", lambda r: r.get("off_loops", "-")),
                          ("auto: mesh max", lambda r: f"{r.get('auto_max', float('nan')):.2f}"),
                          ("mean", lambda r: f"{r.get('auto_mean', float('nan')):.2f}"),
                          ("clean to mesh", lambda r: f"{r.get('auto_back', float('nan')):.2f}"),
                          ("loops", lambda r: r.get("auto_loops", "-"))], recon), ""]
    return out


TITLES = {
    "bench_scans": "normals, noise, size",
    "bench_scans_large": "the largest clouds",
    "bench_scans_denoise": "depth noise and denoising",
    "bench_scans_small": "small clouds, before and after",
}
"""The heading of each section this script writes (``--section``), after "Real-scan
conditions: "."""


def render(quality, disk, noise, scale, argv, plot: str | None, depth=(), clean=(),
           recon=(), small=(), *, section: str = "bench_scans") -> str:
    import os
    import platform

    title = TITLES.get(section, section)
    out = [f"## Real-scan conditions: {title} (`benchmarks/bench_scans.py`)", "",
           *H.header(argv, f"{os.cpu_count()} cores, Python {platform.python_version()}",
                     f"load average at end {H.loadavg() or 'n/a'}"), "",
           "`fast` maps the free boundary with the local mesh (same-sheet tangent fans merged "
           "into a manifold, LSCM); `networks` is the `fast` of 0.1.0 (two network stages and "
           "the LEG refinement). Wall time is the whole CLI subprocess (start-up included), "
           "median over the runs; angle distortion and flips are on the reference triangles.",
           ""]
    if quality:
        out += [*H.table([("surface", "{surface}"), ("points", "{points}"),
                          ("input", "{input} (normals: {normals})"), ("method", "`{preset}`"),
                          ("runs", "{runs}"), ("mean abs angle, rad", "{rad:.4f}"),
                          ("flipped", "{flip_pct:.2f}%"), ("wall s", "{wall_s:.1f}")], quality),
                "", *verdicts(quality), ""]
    if disk:
        out += ["Onto the unit disk, the input with its normals (one run each: both are "
                "deterministic on one machine); Hausdorff distance from the disk to the mapped "
                "points:", "",
                *H.table([("surface", "{surface}"), ("method", "`{preset}`"),
                          ("mean abs angle, rad", "{rad:.4f}"), ("flipped", "{flip_pct:.2f}%"),
                          ("Hausdorff to the disk", "{hausdorff:.4f}"),
                          ("wall s", "{wall_s:.1f}")], disk), ""]
    if noise:
        out += [f"Noise: Gaussian, {NOISE_EDGES} mean edge lengths on every coordinate; scored "
                "against the noisy points on the true connectivity, beside libigl's LSCM on "
                "that noisy mesh (target: within 1.5x of it, < 0.5% flipped).", "",
                *H.table([("surface", "{surface}"), ("pcgeom `fast`, rad", "{rad:.4f}"),
                          ("flipped", "{flip_pct:.2f}%"),
                          ("turned over by the noise itself", "{folded_pct:.2f}%"),
                          ("LSCM on the noisy mesh, rad", "{lscm_rad:.4f}"),
                          ("flipped", "{lscm_flip_pct:.2f}%"), ("ratio", "{ratio:.2f}"),
                          ("wall s", "{wall_s:.1f}")], noise),
                "", "A triangle the noise turned over (its normal against the clean surface's) "
                "is flipped by any map that keeps the noise's tangential part; LSCM avoids it "
                "only because it is solved on that very mesh.", ""]
    out += render_denoise(depth, clean, recon)
    if scale:
        this = [r for r in scale if r["version"] == "this"]
        before = [r for r in scale if r["version"] != "this"]
        out += ["Time and peak memory against N: the five-bump height field over [-1, 1]^2, "
                "uniform random points and a grid jittered by a tenth of its step, no "
                "normals, `fast`, the whole CLI (start-up, reading and writing included); "
                "angles and flips on the true triangles (the Delaunay triangulation of "
                "(x, y), without its slivers along the sides: an angle of 170 degrees or more); "
                "`solver` and `ordering` as the run's history records them.", "",
                *H.table([("sampling", "{sampling}"), ("domain", "{domain}"),
                          ("points", "{points}"), ("wall s", "{wall_s:.1f}"),
                          ("pcgeom s", "{train_s:.1f}"), ("peak RSS, GB", "{rss_gb:.2f}"),
                          ("mean abs angle, rad", "{rad:.4f}"), ("flipped", "{flipped}"),
                          ("solver", "{solver} ({ordering})")], this),
                "", *scale_verdicts(scale)]
        if before:
            out += ["", "The same runs, side by side in this run, of the version named "
                    "`before` (`--baseline`):", "",
                    *H.table([("sampling", "{sampling}"), ("domain", "{domain}"),
                              ("points", "{points}"), ("version", "{version}"),
                              ("wall s", "{wall_s:.1f}"), ("peak RSS, GB", "{rss_gb:.2f}"),
                              ("mean abs angle, rad", "{rad:.4f}"),
                              ("flipped", "{flipped}"), ("solver", "{solver}")],
                             sorted(before + [r for r in this if any(
                                 (b["sampling"], b["points"], b["domain"])
                                 == (r["sampling"], r["points"], r["domain"])
                                 for b in before)],
                                 key=lambda r: (r["sampling"], r["points"], r["version"])))]
        if plot is not None:
            out += ["", f"![time against N]({plot})"]
    if small:
        out += ["", "Small clouds, bare, `fast`, this version and `before` (`--baseline`) "
                "interleaved in one run (medians of the runs; angles and flips on the true "
                "triangles, the first run's):", "",
                *H.table([("surface", "{surface}"), ("points", "{points}"),
                          ("version", "{version}"), ("runs", "{runs}"),
                          ("wall s", "{wall_s:.1f}"), ("peak RSS, GB", "{rss_gb:.2f}"),
                          ("mean abs angle, rad", "{rad:.4f}"), ("flipped", "{flipped}")],
                         small)]
    return "\n".join(out)


def main(argv=None) -> int:
    p = H.parser(__doc__)
    p.add_argument("--surfaces", nargs="*",
                   default=["face_human_choi", "peaks3", "face_3holes_small_choi",
                            "peaks_7holes_choi"])
    p.add_argument("--presets", nargs="*", default=["fast", "networks"])
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--slow-surfaces", nargs="*", default=["face_human_choi", "peaks3"],
                   help="surfaces on which presets other than fast (minutes each) also run")
    p.add_argument("--disk", nargs="*", default=["peaks3", "face_human_choi"])
    p.add_argument("--noise", nargs="*", default=["face_human_choi", "face_3holes_small_choi"])
    p.add_argument("--depth-noise", nargs="*",
                   default=["face_human_choi", "face_3holes_small_choi"],
                   help="surfaces given depth noise of 0.25 / 0.5 / 1.0 mean edge lengths, "
                        "mapped with --denoise off and auto")
    p.add_argument("--clean-denoise", nargs="*",
                   default=["peaks3", "face_3holes_small_choi", "face_human_choi",
                            "peaks_7holes_choi"],
                   help="clean bare clouds mapped with --denoise off and auto")
    p.add_argument("--reconstruct-noise", nargs="*", default=["face_3holes_small_choi"],
                   help="surfaces reconstructed from depth noise 0.5, --denoise off and auto")
    p.add_argument("--sizes", nargs="*", type=int,
                   default=[5_000, 20_000, 50_000, 100_000, 300_000, 1_000_000])
    p.add_argument("--samplings", nargs="*", default=list(SAMPLINGS), choices=SAMPLINGS)
    p.add_argument("--disk-sizes", nargs="*", type=int, default=[1_000_000],
                   help="sizes also mapped onto the disk")
    p.add_argument("--baseline", type=Path,
                   help="a pcgeom source tree (e.g. a git worktree of an earlier commit) run "
                        "side by side at --baseline-sizes")
    p.add_argument("--baseline-sizes", nargs="*", type=int, default=[100_000, 300_000])
    p.add_argument("--baseline-surfaces", nargs="*",
                   default=["peaks3", "face_3holes_small_choi", "face_human_choi"],
                   help="small clouds (bare) also run side by side with --baseline")
    p.add_argument("--section", default="bench_scans",
                   help="the marked section of --out to replace (bench_scans_large for a run "
                        "of the largest sizes alone: --surfaces --noise --disk --sizes 1000000 "
                        "--depth-noise --clean-denoise --reconstruct-noise; "
                        "bench_scans_denoise for the denoising rows alone: --surfaces --noise "
                        "--disk --sizes)")
    args = p.parse_args(argv)
    available = [s for s in args.surfaces if H.available(s)]
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        quality = quality_rows(available, args.presets, args.repeats, work, args.slow_surfaces)
        disk = disk_rows([s for s in args.disk if s in available], args.presets, work,
                         args.slow_surfaces)
        noise = noise_rows([s for s in args.noise if H.data_file(s).is_file()], work)
        depth = denoise_rows([s for s in args.depth_noise if H.data_file(s).is_file()], work)
        clean = clean_denoise_rows([s for s in args.clean_denoise if H.available(s)], work)
        recon = reconstruct_rows([s for s in args.reconstruct_noise if H.data_file(s).is_file()],
                                 work)
        scale = scale_rows(args.sizes, work, args.samplings) if args.sizes else []
        if args.disk_sizes:
            scale += scale_rows(args.disk_sizes, work, args.samplings, domain="disk")
        if args.baseline is not None and args.baseline_sizes:
            scale += scale_rows(args.baseline_sizes, work, args.samplings,
                                tree=args.baseline.resolve(), version="before")
        small = []
        if args.baseline is not None:
            small = small_rows([s for s in args.baseline_surfaces if H.available(s)], work,
                               args.baseline.resolve())
    plot = None
    if len(scale) > 1:  # the repository's figures for its BENCHMARKS.md, else next to --out
        home = args.out.resolve().parent
        folder = H.REPO / "benchmarks" / "figures" if home == H.REPO else home
        stem = "scans" if args.section == "bench_scans" else args.section
        plot_scale(scale, folder / f"{stem}_time_vs_n.png")
        plot = (folder / f"{stem}_time_vs_n.png").relative_to(home).as_posix()
    H.write_section(args.out, args.section,
                    render(quality, disk, noise, scale, argv, plot, depth, clean, recon,
                           small, section=args.section))
    return 0


if __name__ == "__main__":
    sys.exit(main())
