"""Side by side in one run: ``fast``, ``networks`` (the ``fast`` of 0.1.0) and the paper.

The paper preset takes hours on a CPU, so its schedule runs with every epoch count (E and
E_min) times ``--epoch-fraction``; everything else is section 6 exactly. Every stage's map
is scored on the surface's reference mesh (harness.score_map). A shared surface
(``--surface face_human_choi``) is mapped with the normals its file carries, as ``pcgeom
param`` does. Replaces the section ``bench_schedules`` of BENCHMARKS.md.

    python benchmarks/bench_schedules.py --epoch-fraction 0.02 --out /tmp/B.md
    python benchmarks/bench_schedules.py --surface face_human_choi --presets fast networks
"""

from __future__ import annotations

import os
import sys

import harness as H

PRESETS = ("fast", "networks", "paper")


def run(name: str, config, surf: H.Surface, device, seed: int) -> list[dict]:
    """Per-stage rows: the stage's history record, cumulative seconds (:func:`harness.clock`)
    and :func:`harness.score_map` of the stage's map."""
    import pcgeom

    rows: list[dict] = []
    elapsed = H.clock()

    def on_stage(record: dict, uv) -> None:
        rows.append({**record, **H.score_map(uv, surf.V, surf.F), "elapsed": elapsed()})
        H.log(f"{name} stage {record['stage']}: {rows[-1]['elapsed']:.0f} s, "
              f"{rows[-1]['rad']:.4f} rad, {rows[-1]['flipped']} flips")

    pcgeom.parametrize(surf.V, "free", config=config, device=device, seed=seed, progress=False,
                       on_stage=on_stage, normals=surf.normals)
    return rows


STAGE_COLUMNS = [  # the local-mesh map is one solve: no epochs, batch, sigma or steps
    ("stage", "{stage}"), ("epochs", lambda r: r.get("epochs", "–")),
    ("batch", lambda r: r.get("batch_points", "–")),
    ("sigma", lambda r: f"{r['sigma']:.3g}" if "sigma" in r else "–"),
    ("steps", lambda r: r.get("steps", "–")), ("cumulative s", "{elapsed:.0f}"),
    ("mean abs angle, rad", "{rad:.4f}"),
    ("flips", "{flipped} ({flip_pct:.2f}%)")]


def main(argv=None) -> int:
    import torch

    from pcgeom import get_preset
    from pcgeom.examples import EXAMPLES
    from pcgeom.train import resolve_device

    p = H.parser(__doc__)
    p.add_argument("--surface", default="peaks3",
                   help=f"a built-in example ({', '.join(EXAMPLES)}) or the stem of a PLY in "
                        "../shared/data (default: peaks3)")
    p.add_argument("--presets", nargs="+", default=list(PRESETS), choices=PRESETS)
    p.add_argument("--epoch-fraction", type=float, default=0.05,
                   help="multiply the paper's E and E_min by this (default 0.05)")
    p.add_argument("--seed", type=int, default=0)
    args = p.parse_args(argv)
    if not 0 < args.epoch_fraction <= 1:
        p.error(f"--epoch-fraction must be in (0, 1], got {args.epoch_fraction}")
    if not H.available(args.surface):
        p.error(f"--surface: {args.surface!r} is neither a built-in example nor a PLY in "
                f"{H.DATA_DIR}")
    surf, device = H.load_surface(args.surface), resolve_device("auto")
    configs = {"fast": get_preset("fast"), "networks": get_preset("networks"),
               "paper": H.scaled_preset("paper", args.epoch_fraction)}
    runs = {name: run(name, configs[name], surf, device, args.seed) for name in args.presets}
    titles = {"fast": "`fast` (the local-mesh map):",
              "networks": "`networks` (the `fast` of 0.1.0: two network stages, then the "
                          "refinement):",
              "paper": f"`paper` at {args.epoch_fraction:g} of its epochs:"}
    finals = ", ".join(f"`{name}` {rows[-1]['elapsed']:.0f} s" for name, rows in runs.items())
    if "fast" in runs and "paper" in runs:
        finals += (f" (paper / fast: "
                   f"{runs['paper'][-1]['elapsed'] / runs['fast'][-1]['elapsed']:.1f})")
    paper = configs["paper"].schedule
    lines = [
        "## The paper's schedule against `fast` and `networks`, stage by stage", "",
        *H.header(argv, f"{os.cpu_count()} cores, torch {torch.__version__} "
                  f"({torch.get_num_threads()} threads), device {device}",
                  f"one process, one after the other, seed {args.seed}"),
        f"- surface: {args.surface} ({len(surf.V)} points, free boundary, "
        f"{'no normals' if surf.normals is None else 'the file' + chr(39) + 's normals'}); "
        f"angle distortion on its {len(surf.F)} reference triangles after each stage",
        f"- `paper`: section 6 exactly but every epoch count times {args.epoch_fraction} "
        f"(E = {paper.epochs}, E_min = {paper.epochs_min}); the full schedule is 1/fraction "
        "times longer", ""]
    for name, rows in runs.items():
        lines += [titles[name], "", *H.table(STAGE_COLUMNS, rows), ""]
    section = "\n".join([*lines, f"Time to the final map, same run: {finals}."])
    H.write_section(args.out, "bench_schedules", section)
    print(section)
    return 0


if __name__ == "__main__":
    sys.exit(main())
