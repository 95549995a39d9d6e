"""A human face onto the unit disk: Hausdorff distance and angle distortion stage by stage
(paper 7.3, figure "fixedBdy sophie").

The cloud is ``face_human_choi`` (17157 points) decimated by quadric edge collapse to about
6000 (``--points``; 0 keeps all), so that the networks run in minutes on two CPU cores; its
faces are used only to measure angles, and to give the cloud the mesh's vertex normals, as a
scanner writes them (the file has none). Three maps of that cloud are made and measured the
same way:

- the ``networks`` preset (HAND + LEG, Algorithm 1's two stages, then the per-point
  refinement, cut to ``--refine-steps`` 300 of the preset's 1000: onto a domain each step
  also costs HAND of every point against 1024 domain samples), measured after every stage:
  the paper's curves of Hausdorff distance and mean absolute angle distortion against stages;
- the ``fast`` preset's disk map (the free map followed by the Riemann map of its region onto the disk, one step);
- libigl's harmonic disk map on the true mesh (needs the mesh and its boundary), for scale.

Writes ``face_disk.png`` (maps, curves, histograms) and ``face_disk.json``::

    python examples/face_disk.py --out results/face_disk        # minutes
    python examples/face_disk.py --out /tmp/f --quick           # tiny networks budget
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import numpy as np  # noqa: E402

import _common  # noqa: E402

SURFACE = "face_human_choi.ply"


def main(argv=None) -> int:
    p = _common.parser(__doc__.splitlines()[0])
    p.add_argument("--points", type=int, default=None,
                   help="decimate the face to about this many points; 0: all 17157 "
                        "(default: 6000; 1500 with --quick)")
    p.add_argument("--refine-steps", type=int, default=300,
                   help="refinement steps of the networks preset (its own: 1000; default: 300)")
    args = p.parse_args(argv)
    path = _common.data_file(SURFACE)
    out = _common.out_dir(args.out)
    threads = _common.threads()

    import pcgeom
    from pcgeom.apps.baselines import harmonic_disk
    from pcgeom.metrics import angle_distortion, domain_hausdorff, surface_hausdorff

    cloud = pcgeom.read_points(path)
    n_points = args.points if args.points is not None else (1500 if args.quick else 6000)
    V, F = (cloud.points, cloud.faces) if n_points <= 0 else \
        _common.decimate(cloud.points, cloud.faces, n_points)
    # The mesh's vertex normals, as a scanner writes them with its points (the file has none):
    # they keep the two sheets apart where the face doubles back (eyelids, lips, nostrils).
    import trimesh

    normals = np.asarray(trimesh.Trimesh(V, F, process=False).vertex_normals, dtype=np.float64)
    disk = pcgeom.get_domain("disk")
    n_measure = 20_000 if args.quick else 200_000
    clock = _common.Clock()

    import dataclasses

    networks = _common.tiny_config("networks") if args.quick else pcgeom.get_preset("networks")
    if not args.quick:
        networks = dataclasses.replace(
            networks, refine=dataclasses.replace(networks.refine, steps=args.refine_steps))
    _, stages, stage_maps = _common.parametrize_by_stage(
        V, disk, networks, faces=F, normals=normals, seed=args.seed,
        n_measure=n_measure, script="face_disk")
    networks_s = clock()

    def measured(U, seconds):
        a = angle_distortion(V, F, U)
        return {"hausdorff": domain_hausdorff(U, disk, n=n_measure),
                "surface_hausdorff": surface_hausdorff(U, F, disk, n=n_measure),
                "mean_abs_angle_rad": a.mean_abs, "flipped": a.flipped,
                "flipped_percent": 100.0 * a.flipped / a.n_faces, "seconds": seconds,
                "per_corner": a.per_corner}

    t0 = clock()
    fast = pcgeom.parametrize(V, disk, config=pcgeom.get_preset("fast"), normals=normals,
                              seed=args.seed, progress=False)
    fast_row = measured(fast.uv, clock() - t0)
    t0 = clock()
    U_harm = harmonic_disk(V, F)
    harm_row = measured(U_harm, clock() - t0)
    _common.log("face_disk", f"fast: {_short(fast_row)}; harmonic: {_short(harm_row)}")

    # Figure: the maps after each stage, fast and harmonic; the curves; the histograms.
    shown = [(f"networks, stage {r['stage']}", U, r) for r, U in zip(stages, stage_maps)]
    shown += [("fast (local mesh, disk)", fast.uv, fast_row),
              ("harmonic (libigl, true mesh)", U_harm, harm_row)]
    fig = _common.figure(3.0 * len(shown), 6.4)
    grid = fig.subplots(2, len(shown))
    for ax, (name, U, r) in zip(grid[0], shown):
        _common.scatter_map(ax, U, domain=disk, title=f"{name}\nH {r['hausdorff']:.3f}, "
                            f"angle {r['mean_abs_angle_rad']:.3f} rad")
    labels = [str(r["stage"]) for r in stages]
    ax = grid[1, 0]
    ax.plot(labels, [r["hausdorff"] for r in stages], marker="o", label="networks, points")
    ax.plot(labels, [r["surface_hausdorff"] for r in stages], marker="s", linestyle=":",
            color="tab:blue", label="networks, surface")
    ax.axhline(fast_row["hausdorff"], color="tab:green", linestyle="--", label="fast, points")
    ax.axhline(fast_row["surface_hausdorff"], color="tab:green", linestyle=":",
               label="fast, surface")
    ax.set_xlabel("stage")
    ax.set_ylabel("Hausdorff distance to the disk")
    ax.legend(fontsize=8)
    ax = grid[1, 1]
    ax.plot(labels, [r["mean_abs_angle_rad"] for r in stages], marker="o", label="networks")
    ax.axhline(fast_row["mean_abs_angle_rad"], color="tab:green", linestyle="--", label="fast")
    ax.axhline(harm_row["mean_abs_angle_rad"], color="tab:red", linestyle=":",
               label="harmonic")
    ax.set_xlabel("stage")
    ax.set_ylabel("mean abs angle distortion, rad")
    ax.legend(fontsize=8)
    ax = grid[1, 2]
    bins = np.linspace(0, 0.6, 61)
    for name, _, r in shown:
        ax.hist(r["per_corner"].ravel(), bins=bins, histtype="step", density=True,
                label=name.replace("networks, ", ""))
    ax.set_yscale("log")
    ax.set_xlabel("abs angle distortion, rad")
    ax.legend(fontsize=7)
    for ax in grid[1, 3:]:
        ax.axis("off")
    fig.suptitle(f"{SURFACE} ({len(V)} points) onto the unit disk; networks: "
                 f"{networks.refine.steps} refinement steps"
                 + (" (--quick budget)" if args.quick else ""))
    _common.save(fig, out / "face_disk.png")

    result = {
        "experiment": "face_disk",
        "surface": SURFACE,
        "n_points": len(V),
        "n_faces": len(F),
        "quick": args.quick,
        "seed": args.seed,
        "torch_threads": threads,
        "hausdorff_samples": n_measure,
        "normals": "the mesh's vertex normals (trimesh)",
        "decimated_from": len(cloud.points) if len(V) != len(cloud.points) else None,
        "networks": {"preset": "networks (tiny budget)" if args.quick else
                     f"networks, {networks.refine.steps} refinement steps",
                     "seconds": networks_s, "stages": _common.public_rows(stages)},
        "fast": {k: v for k, v in fast_row.items() if k != "per_corner"},
        "harmonic_true_mesh": {k: v for k, v in harm_row.items() if k != "per_corner"},
        "seconds": clock(),
        "figures": ["face_disk.png"],
    }
    _common.write_json(out / "face_disk.json", result)
    first, last = stages[0], stages[-1]
    print(f"face_disk: networks stage {first['stage']} -> {last['stage']}: Hausdorff "
          f"{first['hausdorff']:.4f} -> {last['hausdorff']:.4f}, angle "
          f"{first['mean_abs_angle_rad']:.4f} -> {last['mean_abs_angle_rad']:.4f} rad; "
          f"fast: {_short(fast_row)}; harmonic: {_short(harm_row)} ({clock():.0f} s)")
    return 0


def _short(row: dict) -> str:
    return (f"H {row['hausdorff']:.4f} (surface {row['surface_hausdorff']:.4f}), "
            f"{row['mean_abs_angle_rad']:.4f} rad, {row['flipped']} flips")


if __name__ == "__main__":
    sys.exit(main())
