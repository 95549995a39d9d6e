"""Draw the figures of docs/choosing_parameters.md with pcgeom's own functions.

    python docs/make_figures.py            # writes docs/fig_*.png, prints the measured figures
    python docs/make_figures.py --only fig_checker.png   # one of them

About two minutes on two CPU cores: the README's picture (`pcgeom param --example peaks3`,
seconds), three network-only maps of a 900-point three-peaks patch (one stage of the
`networks` preset from a random start, for three sigma), a few HAND evaluations, and the
boundary loops of a holed patch for several h, and the README's reconstructed scan with its
checkerboard (face_3holes_small_choi from ../shared/data, skipped when absent), and the closed
david head mapped onto the sphere (closed_david_head_choi, skipped when absent). The printed
figures are the ones docs/choosing_parameters.md and the README quote. PNGs are stored with a
128-colour palette to keep the repository small.
"""

from __future__ import annotations

import argparse
import dataclasses
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import torch  # noqa: E402

from pcgeom import get_domain, get_preset, parametrize  # noqa: E402
from pcgeom.apps.plot import plot_boundary_h_sweep  # noqa: E402
from pcgeom.examples import peaks_surface  # noqa: E402
from pcgeom.losses.hand import hand, modified_hausdorff  # noqa: E402
from pcgeom.metrics import angle_distortion  # noqa: E402

DOCS = Path(__file__).resolve().parent
N_SIDE = 30
"""Three-peaks patches of 30 x 30 = 900 points: seconds per map."""
DPI = 100


def shrink_png(path: Path, max_width: int = 1000) -> None:
    """Rewrite ``path`` with a 128-colour palette (and at most ``max_width`` pixels wide)."""
    from PIL import Image

    with Image.open(path) as im:
        im = im.convert("RGB")
        if im.width > max_width:
            im = im.resize((max_width, round(im.height * max_width / im.width)), Image.LANCZOS)
        im.quantize(colors=128, method=Image.Quantize.MEDIANCUT).save(path, optimize=True)


def readme_picture(path: Path) -> None:
    """The README's picture: exactly what its first command draws."""
    import tempfile

    from pcgeom import cli

    with tempfile.TemporaryDirectory() as tmp:
        code = cli.main(["param", "--example", "peaks3", "--out", str(Path(tmp) / "uv.npz"),
                         "--plot", str(path), "--quiet"])
    assert code == 0, code


def sigma_theory(path: Path) -> None:
    """The LEG theorem's constant (sigma^2 exp((1 + r_f)^2 R^2 / sigma^2))^2 against sigma / R."""
    s = np.linspace(0.35, 4, 400)  # sigma / R
    fig, ax = plt.subplots(figsize=(5.5, 3.2))
    for r_f in (0.0, 0.5):
        c = (s**2 * np.exp((1 + r_f) ** 2 / s**2)) ** 2  # in units of R^4
        ax.plot(s, c, label=f"r_f = {r_f}: minimum at sigma = {1 + r_f:g} R")
        ax.axvline(1 + r_f, ls=":", c=ax.lines[-1].get_color())
    ax.set_yscale("log")
    ax.set_xlabel("sigma / R (R: longest edge of the triangulation)")
    ax.set_ylabel("constant in front of LEG (R^4)")
    ax.set_title("LEG bounds angle distortion best at sigma ~ R", fontsize=10)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=DPI)
    plt.close(fig)


def sigma_sweep(path: Path, V: np.ndarray, F: np.ndarray) -> list[dict]:
    """One network stage (``networks``, random start, no refinement) for three LEG sigma."""
    base = get_preset("networks")
    rows = []
    for sigma in (0.03, 0.5, 3.0):
        config = get_preset(
            "networks",
            schedule=dataclasses.replace(base.schedule, epochs=60, epochs_min=30,
                                         batch_points=256, sigma=sigma),
            max_stages=1, init_map="random", refine=dataclasses.replace(base.refine, steps=0),
        )
        t0 = time.perf_counter()
        res = parametrize(V, "free", config=config, seed=0, progress=False)
        rep = angle_distortion(V, F, res.uv)
        rows.append({"sigma": sigma, "uv": res.uv, "rep": rep,
                     "seconds": time.perf_counter() - t0})
        print(f"network stage, sigma = {sigma:g}: {rep.mean_abs:.4f} rad, "
              f"{rep.flipped} flipped of {rep.n_faces}, {rows[-1]['seconds']:.0f} s")
    from matplotlib.colors import LogNorm

    norm = LogNorm(1e-3, 1.5)
    fig, axes = plt.subplots(1, len(rows), figsize=(4 * len(rows), 3.9))
    for ax, row in zip(axes, rows):
        err = row["rep"].per_corner.mean(axis=1)  # (M,) per triangle
        tpc = ax.tripcolor(row["uv"][:, 0], row["uv"][:, 1], F, facecolors=err, cmap="magma",
                           norm=norm)
        ax.set_aspect("equal")
        ax.set_xticks([])
        ax.set_yticks([])
        ax.set_title(f"sigma = {row['sigma']:g}\n{row['rep'].mean_abs:.3f} rad, "
                     f"{row['rep'].flipped} flipped", fontsize=10)
    fig.colorbar(tpc, ax=axes, shrink=0.8, label="mean |angle error| per triangle (rad)")
    fig.savefig(path, dpi=DPI)
    plt.close(fig)
    return rows


def alpha_curve(path: Path) -> list[tuple[float, float]]:
    """HAND of a map that misses the unit disk, against alpha, beside the exact distance."""
    disk = get_domain("disk")
    W = torch.as_tensor(disk.sample(2000, seed=0), dtype=torch.float64)  # (M, 2)
    # A map that misses the disk: an ellipse 1.3 x 0.8, shifted by 0.1.
    Y = torch.as_tensor(disk.sample(1500, seed=1), dtype=torch.float64)
    Y = Y * torch.tensor([1.3, 0.8], dtype=torch.float64) + torch.tensor([0.1, 0.0],
                                                                          dtype=torch.float64)
    exact = float(modified_hausdorff(Y, W))
    alphas = np.geomspace(1, 1000, 25)
    values = [float(hand(Y, W, float(a))) for a in alphas]
    fig, ax = plt.subplots(figsize=(5.5, 3.2))
    ax.plot(alphas, values, "o-", ms=3, label="HAND(Y, W), alpha")
    ax.axhline(exact, c="k", ls=":", label=f"modified Hausdorff distance {exact:.3f}")
    for a in (2, 20, 100):
        ax.axvline(a, c="grey", lw=0.6)
    ax.set_xscale("log")
    ax.set_xlabel("alpha (map units: 1 / distance)")
    ax.set_ylabel("distance")
    ax.set_title("HAND reaches the Hausdorff distance as alpha grows\n"
                 "(grey: the paper's 2, 20 and cap 100)", fontsize=10)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=DPI)
    plt.close(fig)
    picked = [(a, v) for a, v in zip(alphas, values) if a in (1.0, 1000.0)]
    for a in (2, 20, 100):
        print(f"alpha = {a}: HAND {float(hand(Y, W, float(a))):.3f} (exact {exact:.3f})")
    return picked


def h_sweep(path: Path) -> None:
    """Boundary loops of a holed patch's free map for several h, and the default rule."""
    from scipy.spatial import cKDTree

    from pcgeom.apps.boundary import detect_boundary

    V, _ = peaks_surface("peaks3", n_side=N_SIDE)
    keep = np.ones(len(V), bool)
    for (cx, cy), r in [((-0.45, 0.35), 0.25), ((0.4, -0.4), 0.2)]:
        keep &= np.hypot(V[:, 0] - cx, V[:, 1] - cy) > r
    V = V[keep]
    res = parametrize(V, "free", config=get_preset("fast"), seed=0, progress=False)
    spacing = float(np.median(cKDTree(res.uv).query(res.uv, k=2)[0][:, 1]))
    hs = [1.2 * spacing, 1.6 * spacing, 2.5 * spacing, 6 * spacing, 20 * spacing, None]
    for h in hs:
        n = len(detect_boundary(res.uv, h).loops)
        label = "default rule" if h is None else f"h = {h / spacing:.1f} spacings"
        print(f"{label}: {n} loops (true: 3)")
    plot_boundary_h_sweep(res.uv, hs, path, title="a patch with two holes: loops for several h")


def denoise_figure(path: Path) -> list[dict]:
    """``--denoise``: a slice of the three peaks with depth noise before and after the fit,
    and the angle distortion of the map (on the clean triangles) against the noise level."""
    import dataclasses as dc

    import trimesh

    from pcgeom.config import DenoiseConfig

    V, F = peaks_surface("peaks3")
    normals = np.asarray(trimesh.Trimesh(V, F, process=False).vertex_normals)
    edges = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    mean_edge = float(np.linalg.norm(V[edges[:, 0]] - V[edges[:, 1]], axis=1).mean())
    rows, shown = [], None
    for level in (0.25, 0.5, 1.0):
        noise = np.random.default_rng(0).normal(scale=level * mean_edge, size=(len(V), 1))
        noisy = V + normals * noise
        row = {"level": level}
        for mode in ("off", "auto"):
            config = dc.replace(get_preset("fast"), denoise=DenoiseConfig(mode=mode))
            result = parametrize(noisy, config=config, progress=False)
            row[mode] = angle_distortion(V, F, result.uv).mean_abs
            if mode == "auto":
                row["noise"] = result.denoise["noise"]
                if level == 0.5:
                    shown = (noisy, result.fitted)
        rows.append(row)
        print(f"depth noise {level} mean edges (estimated {row['noise']:.2f} spacings): "
              f"off {row['off']:.4f} rad, auto {row['auto']:.4f} rad")
    fig, (ax0, ax1) = plt.subplots(1, 2, figsize=(10, 3.6), dpi=DPI,
                                   gridspec_kw={"width_ratios": [1.6, 1]})
    noisy, fitted = shown
    band = np.abs(V[:, 1] - V[np.argmax(V[:, 2]), 1]) < 0.5 * mean_edge  # through the top
    ax0.plot(V[band, 0], V[band, 2], "_", ms=6, color="C3", label="clean")
    ax0.plot(noisy[band, 0], noisy[band, 2], ".", ms=4, color="0.6", label="noisy (0.5 edges)")
    ax0.plot(fitted[band, 0], fitted[band, 2], ".", ms=4, color="C0", label="fitted (auto)")
    ax0.set_title("a slice through the highest peak")
    ax0.set_xlabel("x")
    ax0.set_ylabel("z")
    ax0.legend(fontsize=8, loc="upper left")
    levels = [r["level"] for r in rows]
    ax1.plot(levels, [r["off"] for r in rows], "o-", color="0.5", label="--denoise off")
    ax1.plot(levels, [r["auto"] for r in rows], "o-", color="C0", label="--denoise auto")
    ax1.set_xlabel("depth noise, mean edge lengths")
    ax1.set_ylabel("mean |angle error|, rad (clean mesh)")
    ax1.set_title("three peaks, fast, bare")
    ax1.legend(fontsize=8)
    ax1.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return rows


def normals_figure(path: Path) -> list[dict]:
    """A bare cloud's normals at a fold: one neighbourhood size (16) against each point's own
    scale (``LocalMeshConfig.normal_scales``), on pleated sheets whose facing sheets lie a
    couple of spacings apart; the normals' errors and the maps' angles."""
    import dataclasses as dc

    from pcgeom.neighbours import adaptive_pca, local_pca
    from pcgeom.config import LocalMeshConfig
    from pcgeom.synthetic import pleated_sheet

    fast = get_preset("fast")
    fixed = dc.replace(fast, local_mesh=dc.replace(fast.local_mesh, normal_scales=(16,),
                                                   normal_rounds=0))
    rows, shown = [], None
    for gap in (1.5, 2.0, 2.5, 3.0):
        sheet = pleated_sheet(6000, 4, gap)
        X, N = sheet.points, sheet.normals
        off = {}
        for name, normals in (("16", local_pca(X, 16)[1][:, :, 0]),
                              ("adaptive", adaptive_pca(X, LocalMeshConfig().normal_scales)[1])):
            cos = np.abs(np.einsum("nd,nd->n", normals, N))
            off[name] = np.degrees(np.arccos(np.clip(cos, 0.0, 1.0)))
        row = {"gap": gap}
        for name, config in (("16", fixed), ("adaptive", fast)):
            try:
                result = parametrize(X, config=config, progress=False)
                rep = angle_distortion(X, sheet.faces, result.uv)
                row[name] = (rep.mean_abs, 100.0 * rep.flipped / rep.n_faces)
            except ValueError as err:  # refused as not a surface
                row[name] = (float("nan"), float("nan"))
                print(f"gap {gap}, {name}: {err}")
            row[name + "_off30"] = 100.0 * float((off[name] > 30.0).mean())
        rows.append(row)
        print(f"gap {gap} spacings: normals > 30 deg off: 16 {row['16_off30']:.1f}%, adaptive "
              f"{row['adaptive_off30']:.1f}%; map 16 {row['16'][0]:.4f} rad "
              f"({row['16'][1]:.2f}% flipped), adaptive {row['adaptive'][0]:.4f} rad "
              f"({row['adaptive'][1]:.2f}%)")
        if gap == 2.0:
            shown = (X, off)
    X, off = shown
    band = np.abs(X[:, 1] - np.median(X[:, 1])) < 0.02
    fig, axes = plt.subplots(1, 3, figsize=(12, 3.6), dpi=DPI, layout="constrained",
                             gridspec_kw={"width_ratios": [1, 1, 1.1]})
    for ax, name, title in ((axes[0], "16", "16 neighbours"),
                            (axes[1], "adaptive", "own scale (6-24)")):
        points = ax.scatter(X[band, 0], X[band, 2], c=off[name][band], s=6, cmap="magma_r",
                            vmin=0, vmax=90)
        ax.set_title(f"{title}: {100 * (off[name] > 30).mean():.1f}% > 30 deg", fontsize=10)
        ax.set_aspect("equal")
        ax.set_xlabel("x")
        ax.set_ylabel("z")
    fig.colorbar(points, ax=axes[:2], label="normal error, deg", shrink=0.8)
    gaps = [r["gap"] for r in rows]
    ax = axes[2]
    ax.plot(gaps, [r["16"][0] for r in rows], "o-", color="0.5", label="16 neighbours")
    ax.plot(gaps, [r["adaptive"][0] for r in rows], "o-", color="C0", label="own scale")
    ax.set_yscale("log")
    ax.set_xlabel("facing sheets apart, spacings")
    ax.set_ylabel("mean |angle error|, rad")
    ax.set_title("bare pleat (6000 points), fast; 16 neighbours\nrefuse 1.5 spacings as not "
                 "a surface", fontsize=10)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3, which="both")
    fig.suptitle("A slice across the folds of a pleat whose sheets lie 2 spacings apart, "
                 "coloured by each normal's error", fontsize=9)
    fig.savefig(path)
    plt.close(fig)
    return rows


def robust_figure(path: Path) -> list[dict]:
    """Robust LSCM (``LocalMeshConfig.robust_rounds``): the weights its round gives the local
    mesh of a bare pleat, and the map's angle error on the true triangles before and after."""
    import dataclasses as dc

    from pcgeom.cloud import normalize
    from pcgeom.maps.free import _anticonformal, free_start, lscm_free
    from pcgeom.maps.localmesh import _submesh
    from pcgeom.synthetic import pleated_sheet

    fast = get_preset("fast")
    plain = dc.replace(fast, local_mesh=dc.replace(fast.local_mesh, robust_rounds=0))
    sheet = pleated_sheet(6000, 4, 2.5)
    X, st = sheet.points, sheet.uv_true
    Xn = normalize(X)[0]
    _, mesh, _, _ = free_start(Xn, None, plain, progress=False)
    U0 = lscm_free(Xn, mesh)
    main, V, F = _submesh(Xn, mesh.faces, mesh.main)
    d = _anticonformal(V, F, U0[main, 0], U0[main, 1])
    settings = fast.local_mesh
    weights = np.maximum(1.0 / (1.0 + (d / settings.robust_scale) ** 2), settings.robust_floor)
    faces = main[F]  # rows of the cloud
    errors = {}
    for name, config in (("plain LSCM", plain), ("one robust round", fast)):
        rep = angle_distortion(X, sheet.faces, parametrize(X, config=config, progress=False).uv)
        errors[name] = (rep, rep.per_corner.mean(axis=1))
        print(f"pleat 2.5 spacings, bare, {name}: {rep.mean_abs:.4f} rad, {rep.flipped} flipped")
    print(f"robust weights: {100 * (weights < 0.5).mean():.1f}% of the local mesh's "
          f"{len(F)} triangles below 0.5, {100 * (weights <= settings.robust_floor).mean():.1f}% "
          "at the floor")
    fig, axes = plt.subplots(1, 3, figsize=(13, 4.6), dpi=DPI, layout="constrained")
    art = axes[0].tripcolor(st[:, 0], st[:, 1], faces, facecolors=weights, cmap="viridis",
                            vmin=0, vmax=1)
    fig.colorbar(art, ax=axes[0], label="weight", shrink=0.8)
    axes[0].set_title("local mesh: weights of the robust round", fontsize=10)
    top = max(float(np.percentile(e[1], 99)) for e in errors.values())
    for ax, (name, (rep, per)) in zip(axes[1:], errors.items()):
        art = ax.tripcolor(st[:, 0], st[:, 1], sheet.faces, facecolors=per, cmap="magma_r",
                           vmin=0, vmax=top)
        ax.set_title(f"{name}: {rep.mean_abs:.4f} rad", fontsize=10)
    fig.colorbar(art, ax=axes[1:], label="true triangle's mean |angle error|, rad", shrink=0.8)
    for ax in axes:
        ax.set_aspect("equal")
        ax.set_xlabel("arc length across the folds")
    axes[0].set_ylabel("along the folds")
    fig.suptitle("A bare pleat, sheets 2.5 spacings apart (6000 points), drawn unrolled: the "
                 "folds are the four vertical bands", fontsize=10)
    fig.savefig(path)
    plt.close(fig)
    return [{"name": k, "mean_abs": v[0].mean_abs, "flipped": v[0].flipped}
            for k, v in errors.items()]


def normal_rounds_figure(path: Path) -> list[dict]:
    """Normal rounds (``LocalMeshConfig.normal_rounds``): a bare pleat whose sheets lie 1.5
    spacings apart, its map's angle error on the true triangles without and with the rounds
    (flipped triangles marked), and how many of its own triangles each round's map turns
    over."""
    import dataclasses as dc

    from pcgeom.metrics import flipped_mask
    from pcgeom.synthetic import pleated_sheet

    fast = get_preset("fast")
    none = dc.replace(fast, local_mesh=dc.replace(fast.local_mesh, normal_rounds=0))
    sheet = pleated_sheet(6000, 4, 1.5)
    X, st = sheet.points, sheet.uv_true
    maps, rows, signed = {}, [], {}
    for name, config in (("without normal rounds", none), ("with them (default)", fast)):
        result = parametrize(X, config=config, progress=False)
        rep = angle_distortion(X, sheet.faces, result.uv)
        maps[name] = (rep, result.history[0])
        F, U = sheet.faces, result.uv
        e1, e2 = U[F[:, 1]] - U[F[:, 0]], U[F[:, 2]] - U[F[:, 0]]
        signed[name] = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
        rows.append({"name": name, "mean_abs": rep.mean_abs, "flipped": rep.flipped})
        print(f"pleat 1.5 spacings, bare, {name}: {rep.mean_abs:.4f} rad, {rep.flipped} of "
              f"{rep.n_faces} flipped; own flips per round {result.history[0].get('own_flips')}")
    fig, axes = plt.subplots(1, 3, figsize=(13, 4.4), dpi=DPI, layout="constrained",
                             gridspec_kw={"width_ratios": [1, 1, 0.7]})
    top = float(np.percentile(maps["without normal rounds"][0].per_corner.mean(axis=1), 95))
    for ax, (name, (rep, _)) in zip(axes[:2], maps.items()):
        per = rep.per_corner.mean(axis=1)
        art = ax.tripcolor(st[:, 0], st[:, 1], sheet.faces, facecolors=per, cmap="magma_r",
                           vmin=0, vmax=top)
        flipped = flipped_mask(signed[name])
        centre = st[sheet.faces[flipped]].mean(axis=1)
        ax.scatter(centre[:, 0], centre[:, 1], s=4, c="tab:cyan", label="flipped")
        ax.set_title(f"{name}: {rep.mean_abs:.4f} rad, {100 * rep.flipped / rep.n_faces:.2f}% "
                     "flipped", fontsize=10)
        ax.set_aspect("equal")
        ax.set_xlabel("arc length across the folds")
    axes[0].set_ylabel("along the folds")
    fig.colorbar(art, ax=axes[:2], label="true triangle's mean |angle error|, rad", shrink=0.8)
    flips = maps["with them (default)"][1]["own_flips"]
    kept = maps["with them (default)"][1]["normal_round_kept"]
    colours = ["tab:green" if r == kept else "tab:gray" for r in range(len(flips))]
    axes[2].bar(range(len(flips)), [f if f is not None else 0 for f in flips], color=colours)
    axes[2].set_yscale("log")
    axes[2].annotate("kept", (kept, flips[kept]), ha="center", va="bottom", fontsize=9)
    axes[2].set_xlabel("round (0: the PCA normals)")
    axes[2].set_ylabel("local-mesh triangles the map turns over")
    axes[2].set_title("each round's map, on its own mesh", fontsize=10)
    fig.suptitle("A bare pleat, sheets 1.5 spacings apart (6000 points), drawn unrolled",
                 fontsize=10)
    fig.savefig(path)
    plt.close(fig)
    return rows


def checker_picture(path: Path, data: Path) -> None:
    """The README's reconstructed scan with its checkerboard: the commands the README shows
    (``pcgeom reconstruct`` of face_3holes_small_choi with ``--texture checker:16``), the OBJ
    read back with trimesh and drawn with its texture coordinates, beside the angle distortion
    of the mesh's map per triangle. Skipped when the shared surface is absent."""
    import tempfile

    import trimesh

    from pcgeom import cli
    from pcgeom.apps.plot import plot_checker

    scan = data / "face_3holes_small_choi.ply"
    if not scan.exists():
        print(f"{path.name}: skipped, {scan} is absent")
        return
    with tempfile.TemporaryDirectory() as tmp:
        mesh_path = Path(tmp) / "face_mesh.obj"
        code = cli.main(["reconstruct", str(scan), "--target-vertices", "6000", "--texture",
                         "checker:16", "--out", str(mesh_path), "--quiet"])
        assert code == 0, code
        mesh = trimesh.load(mesh_path, process=False)
        V, F, uv = mesh.vertices, mesh.faces, mesh.visual.uv
    angles = angle_distortion(V, F, uv)  # angles: the same in uv as in the map
    print(f"{path.name}: {len(V)} vertices, {len(F)} triangles; angle distortion of the "
          f"mesh's map: mean {angles.mean_abs:.4f} rad, {angles.flipped} flipped")
    plot_checker(V, F, uv, path, squares=16, values=angles.per_corner.mean(axis=1),
                 value_label="angle distortion per triangle (rad)",
                 title="face_3holes_small_choi reconstructed (pcgeom reconstruct --texture "
                       "checker:16)")


def sphere_picture(path: Path, data: Path) -> None:
    """The README's sphere: the closed david head mapped from its bare points onto the sphere
    (``pcgeom param --domain sphere``, its faces only to judge), drawn by ``pcgeom evaluate
    --plot`` coloured by the conformal factor, with its equirectangular picture. Skipped when
    the shared surface is absent."""
    import shutil
    import tempfile

    from pcgeom import cli
    from pcgeom.apps.evaluate import PLOT_FILES

    head = data / "closed_david_head_choi.ply"
    if not head.exists():
        print(f"{path.name}: skipped, {head} is absent")
        return
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "head_uv.npz"
        assert cli.main(["param", str(head), "--domain", "sphere", "--out", str(out),
                         "--quiet"]) == 0
        assert cli.main(["evaluate", str(head), str(out), "--plot", str(Path(tmp) / "figs"),
                         "--json"]) == 0
        shutil.copyfile(Path(tmp) / "figs" / PLOT_FILES["sphere_factor"], path)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(DOCS), help="folder of the PNGs (default: docs/)")
    parser.add_argument("--data", default=str(DOCS.parent.parent / "shared" / "data"),
                        help="folder of the shared test surfaces (default: ../shared/data)")
    parser.add_argument("--only", metavar="NAME.png",
                        help="draw this figure only (e.g. fig_checker.png)")
    args = parser.parse_args(argv)
    out = Path(args.out)
    torch.manual_seed(0)
    start = time.perf_counter()
    V, F = peaks_surface("peaks3", n_side=N_SIDE)
    figures = {
        "peaks3_uv.png": readme_picture,
        "fig_sigma_theory.png": sigma_theory,
        "fig_sigma.png": lambda path: sigma_sweep(path, V, F),
        "fig_alpha.png": alpha_curve,
        "fig_h.png": h_sweep,
        "fig_denoise.png": denoise_figure,
        "fig_normals.png": normals_figure,
        "fig_robust.png": robust_figure,
        "fig_normal_rounds.png": normal_rounds_figure,
        "fig_checker.png": lambda path: checker_picture(path, Path(args.data)),
        "fig_sphere.png": lambda path: sphere_picture(path, Path(args.data)),
    }
    if args.only is not None:
        figures = {args.only: figures[args.only]}
    for name, draw in figures.items():
        draw(out / name)
        if (out / name).exists():
            shrink_png(out / name)
    print(f"done in {time.perf_counter() - start:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
