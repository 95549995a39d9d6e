"""A face with its eyes and mouth cut out onto the smiling face (paper 7.3, figure "fixedBdy
sophie noEyeMouth"): does each hole of the cloud land on one eye or the mouth?

The cloud is ``face_3holes_small_choi`` (5053 points, four boundary loops: the face's outline,
two eyes and the mouth). Its holes are found from the reference mesh's boundary loops
(``igl.boundary_loop_all``; the longest is the outline), used only to judge the map, never to
make it. The domain is pcgeom's ``smile`` (the unit disk minus two half-disk eyes and a
half-disk mouth).

A cloud hole *lands* on a domain hole when the closed polygon of its mapped boundary points
contains that domain hole (a point inside it, shapely's ``representative_point``) and no other
domain hole, and the matching is one to one. Per hole the script reports the domain hole it
lands on, the Hausdorff distance between its mapped loop and that hole's boundary, and whether
it encloses it.

Runs:

1. ``fast`` (the local mesh laid on the domain with its holes on the domain's holes, by
   :func:`pcgeom.maps.domain.harmonic_onto`, then the refinement), measured after each step:
   Hausdorff distance to the domain, angle distortion on the reference triangles, where the
   holes land.
2. With landmarks, as the paper matches landmarks (``--landmarks auto``: only when run 1 does
   not land every hole; ``always``, ``never``): each cloud hole's boundary points are one
   landmark set, matched to its domain hole's boundary (sampled every 0.01). The mouth (the
   longest hole) goes to the mouth; the eyes go to the eyes in the left-right order run 1
   put them in, so the landmarks keep run 1's orientation.

Writes ``face_smile.png`` and ``face_smile.json``::

    python examples/face_smile.py --out results/face_smile
    python examples/face_smile.py --out /tmp/s --quick
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import numpy as np  # noqa: E402

import _common  # noqa: E402
from pcgeom.apps.evaluate import (domain_holes, hole_landing, hole_landmarks,  # noqa: E402
                                   mesh_holes)

SURFACE = "face_3holes_small_choi.ply"


def main(argv=None) -> int:
    p = _common.parser(__doc__.splitlines()[0])
    p.add_argument("--landmarks", choices=("auto", "always", "never"), default="auto",
                   help="the landmark run: only when the first run does not land every hole "
                        "(auto), always, or never (default: auto)")
    p.add_argument("--points", type=int, default=None,
                   help="decimate the face to about this many points, its holes kept; 0: all "
                        "5053 (default: 0; 2000 with --quick)")
    args = p.parse_args(argv)
    path = _common.data_file(SURFACE)
    out = _common.out_dir(args.out)
    threads = _common.threads()

    import pcgeom

    cloud = pcgeom.read_points(path)
    V, F = cloud.points, cloud.faces
    normals = cloud.normals
    n_points = args.points if args.points is not None else (2000 if args.quick else 0)
    if n_points:
        V, F = _common.decimate(V, F, n_points)
        normals = None  # the file's belong to its own points
    smile = pcgeom.get_domain("smile")
    holes_idx = mesh_holes(V, F)
    targets = domain_holes(smile)
    # --quick runs twice (the test asks for both runs): fewer, cheaper refinement steps.
    config = (_common.tiny_config("fast", refine_steps=10, refine_batch_domain=256)
              if args.quick else pcgeom.get_preset("fast"))
    n_measure = 20_000 if args.quick else 200_000
    clock = _common.Clock()

    runs = {}
    _, stages, maps = _common.parametrize_by_stage(
        V, smile, config, faces=F, normals=normals, seed=args.seed, n_measure=n_measure,
        script="face_smile")
    for row, U in zip(stages, maps):
        row["landing"] = hole_landing(U, holes_idx, targets)
    runs["default"] = {"stages": stages, "maps": maps, "landmarks": None}
    first = stages[-1]["landing"]
    _common.log("face_smile", f"default run: every hole lands: {first['all_land']}")

    if args.landmarks == "always" or (args.landmarks == "auto" and not first["all_land"]):
        pairs, names = hole_landmarks(V, maps[-1], holes_idx, targets)
        _, lm_stages, lm_maps = _common.parametrize_by_stage(
            V, smile, config, faces=F, normals=normals, landmarks=pairs, seed=args.seed,
            n_measure=n_measure, script="face_smile")
        for row, U in zip(lm_stages, lm_maps):
            row["landing"] = hole_landing(U, holes_idx, targets)
        runs["landmarks"] = {"stages": lm_stages, "maps": lm_maps,
                             "landmarks": [{"cloud_hole": k, "n_points": len(P),
                                            "target": name, "n_targets": len(Q)}
                                           for k, ((P, Q), name) in
                                           enumerate(zip(pairs, names))]}

    _figure(out / "face_smile.png", runs, holes_idx, smile, len(V), args.quick)
    summary = {}
    for name, run in runs.items():
        last = run["stages"][-1]
        summary[name] = {"all_land": last["landing"]["all_land"],
                         "hausdorff": last["hausdorff"],
                         "mean_abs_angle_rad": last["mean_abs_angle_rad"],
                         "flipped_percent": last["flipped_percent"]}
    result = {
        "experiment": "face_smile",
        "surface": SURFACE,
        "n_points": len(V),
        "n_faces": len(F),
        "cloud_holes": [len(h) for h in holes_idx],
        "domain": smile.spec,
        "domain_holes": [t["name"] for t in targets],
        "preset": "fast (tiny budget)" if args.quick else "fast",
        "quick": args.quick,
        "seed": args.seed,
        "torch_threads": threads,
        "hausdorff_samples": n_measure,
        "runs": {name: {"landmarks": run["landmarks"],
                        "stages": _common.public_rows(run["stages"])}
                 for name, run in runs.items()},
        "summary": summary,
        "seconds": clock(),
        "figures": ["face_smile.png"],
    }
    _common.write_json(out / "face_smile.json", result)
    print("face_smile: " + "; ".join(
        f"{name}: holes land {s['all_land']}, H {s['hausdorff']:.4f}, "
        f"{s['mean_abs_angle_rad']:.4f} rad" for name, s in summary.items())
        + f" ({clock():.0f} s)")
    return 0


def _figure(path, runs, holes_idx, domain, n_points, quick) -> None:
    colours = ["tab:orange", "tab:green", "tab:purple", "tab:brown"]
    n_cols = max(len(r["stages"]) for r in runs.values())
    fig = _common.figure(3.4 * n_cols, 3.4 * len(runs))
    grid = np.atleast_2d(fig.subplots(len(runs), n_cols, squeeze=False))
    for row_axes, (name, run) in zip(grid, runs.items()):
        for ax, stage, U in zip(row_axes, run["stages"], run["maps"]):
            _common.scatter_map(ax, U, domain=domain)
            for k, loop in enumerate(holes_idx):
                L = U[np.append(loop, loop[0])]
                ax.plot(L[:, 0], L[:, 1], color=colours[k % len(colours)], linewidth=1.2)
            lands = stage["landing"]["all_land"]
            lm = stage.get("landmark_hausdorff")
            ax.set_title(f"{name}, stage {stage['stage']}: H {stage['hausdorff']:.3f}, "
                         f"{stage['mean_abs_angle_rad']:.3f} rad\nholes land: {lands}"
                         + (f", landmark H {max(lm):.3f}" if lm else ""), fontsize=8)
        for ax in row_axes[len(run["stages"]):]:
            ax.axis("off")
    fig.suptitle(f"{SURFACE} ({n_points} points) onto the smiling face; cloud holes in colour"
                 + (" (--quick budget)" if quick else ""))
    _common.save(fig, path)


if __name__ == "__main__":
    sys.exit(main())
