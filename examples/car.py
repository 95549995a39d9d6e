"""A car-like shell onto the car domain, then with the side windows' upper edges as landmarks
(paper 7.3 figure "fixedBdy car" and 7.4 figure "ldmkMatch car").

The shell is built analytically (:func:`pcgeom.synthetic.car_shell`): a roof, bonnet and boot on top and two
sides hanging from them, open underneath, with the wheel arches cut out of the sides' lower
edges. It is the image of pcgeom's ``car`` domain under a bending that is not conformal: in
the cabin the sides are tall (0.4), on the bonnet and boot short (0.1-0.2), and the roof is
0.58 wide where the domain's middle band is 0.5. So the map onto the domain must stretch the
shell unevenly, and the edges where the roof meets the side windows, the curves ``|y| = 0.32,
-0.55 <= x <= 0.45`` of the construction, do not fall on the domain's window lines by
themselves.

Landmarks as in the paper: the points on the upper edges of the two side windows (134, 67 per
side) are ONE landmark set, matched to 400 target points on the two lines
``[-0.5, 0.5] x {-0.25, 0.25}`` (200 each), with no correspondence given between the two
edges and the two lines.

Both runs use ``fast`` (the local mesh laid on the domain, then the per-point refinement;
the landmarks help choose the first map's turn and enter the refinement), measured after each
step: Hausdorff distance to the domain, angle distortion on the construction's triangles
(used only to measure), and the landmark Hausdorff distance (recorded by the history in the
landmark run; computed from the map in the other).

Writes ``car.png``, ``car.json`` and the inputs as a user would pass them to the CLI,
``car_shell.ply`` (points and faces) and ``car_landmarks.json``::

    python examples/car.py --out results/car
    python examples/car.py --out /tmp/c --quick
    pcgeom param results/car/car_shell.ply --domain car --landmarks results/car/car_landmarks.json
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import numpy as np  # noqa: E402

import _common  # noqa: E402
from pcgeom.synthetic import CAR_TARGET_LINES, CAR_TARGET_SPACING, car_shell  # noqa: E402


def main(argv=None) -> int:
    p = _common.parser(__doc__.splitlines()[0])
    p.add_argument("--points", type=int, default=None,
                   help="domain samples of the shell (default: 2500; 1500 with --quick)")
    args = p.parse_args(argv)
    out = _common.out_dir(args.out)
    threads = _common.threads()

    import pcgeom
    from pcgeom.io import write_ply_atomic
    from pcgeom.io.landmarks import sample_polyline
    from pcgeom.metrics import hausdorff

    V, F, edges = car_shell(args.points or (1500 if args.quick else 2500), seed=args.seed)
    targets = np.vstack([sample_polyline(line, CAR_TARGET_SPACING)
                         for line in CAR_TARGET_LINES])
    write_ply_atomic(out / "car_shell.ply", V, F)
    marks = [{"indices": edges.tolist(), "polylines": CAR_TARGET_LINES,
              "spacing": CAR_TARGET_SPACING}]
    (out / "car_landmarks.json").write_text(json.dumps(marks) + "\n")
    car = pcgeom.get_domain("car")
    config = (_common.tiny_config("fast", refine_steps=200) if args.quick
              else pcgeom.get_preset("fast"))
    n_measure = 20_000 if args.quick else 200_000
    clock = _common.Clock()

    def landmark_fit(U):
        # One landmark set: the two window edges against the two lines, as one set.
        return {"landmark_fit": hausdorff(U[edges], targets)}

    runs = {}
    for name, landmarks in (("without landmarks", ()), ("with landmarks", [(V[edges], targets)])):
        _, stages, maps = _common.parametrize_by_stage(
            V, car, config, faces=F, landmarks=landmarks, seed=args.seed, n_measure=n_measure,
            script="car", extra=landmark_fit)
        runs[name] = {"stages": stages, "maps": maps}

    _figure(out / "car.png", runs, edges, targets, car, len(V), args.quick)
    summary = {name: {k: run["stages"][-1][k] for k in
                      ("landmark_fit", "hausdorff", "mean_abs_angle_rad", "flipped_percent")}
               for name, run in runs.items()}
    result = {
        "experiment": "car",
        "n_points": len(V),
        "n_faces": len(F),
        "n_landmarks": len(edges),
        "n_targets": len(targets),
        "domain": car.spec,
        "preset": "fast (tiny budget)" if args.quick else "fast",
        "quick": args.quick,
        "seed": args.seed,
        "torch_threads": threads,
        "hausdorff_samples": n_measure,
        "landmark_fit": "Hausdorff distance between the mapped window edges (one set of "
                        f"{len(edges)}) and the {len(targets)} targets, from the map",
        "runs": {name: {"stages": _common.public_rows(run["stages"])}
                 for name, run in runs.items()},
        "summary": summary,
        "seconds": clock(),
        "inputs": ["car_shell.ply", "car_landmarks.json"],
        "figures": ["car.png"],
    }
    _common.write_json(out / "car.json", result)
    print("car: " + "; ".join(
        f"{name}: landmark H {s['landmark_fit']:.4f}, H {s['hausdorff']:.4f}, "
        f"{s['mean_abs_angle_rad']:.4f} rad" for name, s in summary.items())
        + f" ({clock():.0f} s)")
    return 0


def _figure(path, runs, edges, targets, domain, n_points, quick) -> None:
    n_cols = max(len(r["stages"]) for r in runs.values()) + 1
    fig = _common.figure(3.4 * n_cols, 3.0 * len(runs))
    grid = fig.subplots(len(runs), n_cols, squeeze=False)
    for row_axes, (name, run) in zip(grid, runs.items()):
        for ax, stage, U in zip(row_axes, run["stages"], run["maps"]):
            _common.scatter_map(ax, U, domain=domain)
            ax.scatter(targets[:, 0], targets[:, 1], s=2, c="tab:orange", linewidths=0)
            ax.scatter(U[edges, 0], U[edges, 1], s=4, c="deeppink", linewidths=0)
            ax.set_title(f"{name}, stage {stage['stage']}\nlandmark H "
                         f"{stage['landmark_fit']:.3f}, H {stage['hausdorff']:.3f}, "
                         f"{stage['mean_abs_angle_rad']:.3f} rad", fontsize=8)
        ax = row_axes[-1]
        labels = [str(s["stage"]) for s in run["stages"]]
        for key, label in (("landmark_fit", "landmark Hausdorff"), ("hausdorff", "domain "
                           "Hausdorff"), ("mean_abs_angle_rad", "angle, rad")):
            ax.plot(labels, [s[key] for s in run["stages"]], marker="o", label=label)
        ax.set_xlabel("stage")
        ax.legend(fontsize=7)
        ax.set_title(name, fontsize=8)
    fig.suptitle(f"car shell ({n_points} points) onto the car domain; window edges pink, "
                 "targets orange" + (" (--quick budget)" if quick else ""))
    _common.save(fig, path)


if __name__ == "__main__":
    sys.exit(main())
