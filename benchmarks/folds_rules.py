"""The normal-estimate rules of a bare cloud side by side (issue 39), for bench_folds.py.

Each rule maps every surface in this process with the ``fast`` preset, bare, as
``pcgeom.parametrize`` does, the rule put in place of today's for the run
(:func:`pcgeom.neighbours.adaptive_pca`'s ``rule``, the normal scales, and the noise estimate's
own-sheet test, :func:`pcgeom.denoise.own_sheet`); angle distortion and flips on the true
triangles. ``python benchmarks/folds_rules.py`` prints the table alone.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import sys
import warnings

import harness as H
import numpy as np

RULES = {
    "before (issue 25): 16 neighbours, noise read across sheets": ((16,), "flattest", False),
    "adaptive, flattest scale, noise read across sheets": (None, "flattest", False),
    "adaptive, flattest scale; noise on the own sheet": (None, "flattest", True),
    "adaptive, flattest one-sheeted scale; noise on the own sheet": (None, "one_sheet", True),
    "adaptive, flattest scale of the own sheet's points; noise on the own sheet": (
        None, "own_sheet", True),
    "smallest planar one-sheeted scale; noise on the own sheet": (None, "smallest_planar",
                                                                   True),
    "flattest scale, neighbours weighted by their normals' agreement; noise on the own sheet": (
        None, "consistent", True),
}
"""Name: (normal scales or None for the preset's, adaptive_pca rule, own-sheet noise)."""

DEEP_GAPS = (0.5, 1.0, 1.5, 2.0, 3.0)
PLEAT_GAPS = (1.5, 2.0, 2.5)
SHARED = ("face_3holes_small_choi", "face_human_choi", "peaks_7holes_choi", "peaks_three_cgal")


@contextlib.contextmanager
def rule_in_place(rule: str, own_sheet: bool):
    """``pcgeom.parametrize`` with ``rule`` for the normal scale and with or without the
    noise estimate's own-sheet test, for the duration."""
    import pcgeom.denoise as D
    import pcgeom.maps.localmesh as LM
    from pcgeom import neighbours as NB

    saved = LM.adaptive_pca, D.own_sheet
    LM.adaptive_pca = functools.partial(NB.adaptive_pca, rule=rule)
    if not own_sheet:
        D.own_sheet = lambda P, near=8: np.ones(P.shape[:2], dtype=bool)
    try:
        yield
    finally:
        LM.adaptive_pca, D.own_sheet = saved


def surfaces(points: int, seeds):
    """(case, V, F, exact uv or None) of every surface measured."""
    from pcgeom.synthetic import pleated_sheet
    from pcgeom.synthetic_folds import deep_folds

    for gap in DEEP_GAPS:
        for seed in seeds:
            s = deep_folds(points, gap=gap, seed=seed)
            yield f"deep folds, walls {gap:g} spacings apart", s.points, s.faces, s.uv_true
    for gap in PLEAT_GAPS:
        for seed in seeds:
            s = pleated_sheet(points, folds=4, gap=gap, seed=seed)
            yield f"pleat, sheets {gap:g} spacings apart", s.points, s.faces, s.uv_true
    for name in SHARED:
        if H.available(name):
            s = H.load_surface(name)
            yield name, s.V, s.F, None


def measure(points: int = 6000, seeds=(0,)) -> list[dict]:
    """One row per (surface, rule): medians over the seeds (synthetic surfaces)."""
    import pcgeom

    fast = pcgeom.get_preset("fast")
    runs: dict[tuple[str, str], list[dict]] = {}
    exact: dict[str, list[dict]] = {}
    for case, V, F, uv in surfaces(points, seeds):
        if uv is not None:
            exact.setdefault(case, []).append({"seed": 0, "wall_s": 0.0,
                                               **H.score_map(uv, V, F)})
        for name, (scales, rule, own) in RULES.items():
            config = fast if scales is None else dataclasses.replace(
                fast, local_mesh=dataclasses.replace(fast.local_mesh, normal_scales=scales))
            with rule_in_place(rule, own), warnings.catch_warnings():
                warnings.simplefilter("ignore")
                try:
                    result, seconds = H.timed(pcgeom.parametrize, V, config=config, seed=0,
                                              progress=False)
                    run = {"seed": 0, "wall_s": seconds, **H.score_map(result.uv, V, F)}
                except pcgeom.InputError as err:
                    run = {"seed": 0, "wall_s": float("nan"), "error": str(err)}
            runs.setdefault((case, name), []).append(run)
            H.log(f"{case} / {name}: {run.get('rad', run.get('error'))}")
    rows = []
    for (case, name), rs in runs.items():
        rows.append(H.summary(rs, case=case, rule=name, points=points))
    for case, rs in exact.items():
        rows.append(H.summary(rs, case=case, rule="the exact map (`uv_true`)"))
    order = list(dict.fromkeys(r["case"] for r in rows))
    return sorted(rows, key=lambda r: order.index(r["case"]))


VOTE_CASES = (("deep", "even", 1.5), ("deep", "even", 2.0), ("deep", "even", 3.0),
              ("deep", "uniform", 1.5), ("deep", "uniform", 2.0), ("deep", "uniform", 3.0),
              ("pleat", "", 1.5), ("pleat", "", 2.0), ("pleat", "", 2.5))
"""(kind, sampling, gap) of the synthetic surfaces of :func:`vote_rows`."""


def vote_surfaces(points: int, seeds):
    """(case, V, F, domains) of :func:`vote_rows`: the grooves and pleats (clouds of each
    seed, free map) and the shared surfaces (free and onto the disk)."""
    from pcgeom.synthetic import pleated_sheet
    from pcgeom.synthetic_folds import deep_folds

    for kind, sampling, gap in VOTE_CASES:
        for seed in seeds:
            if kind == "deep":
                s = deep_folds(points, gap=gap, sampling=sampling, seed=seed)
                name = f"deep folds{' (uniform)' if sampling == 'uniform' else ''}, walls {gap:g}"
            else:
                s = pleated_sheet(points, folds=4, gap=gap, seed=seed)
                name = f"pleat, sheets {gap:g} apart"
            yield f"{name}, cloud seed {seed}", s.points, s.faces, ("free",)
    for name in SHARED:
        if H.available(name):
            s = H.load_surface(name)
            yield name, s.V, s.F, ("free", "disk")


def vote_rows(points: int = 6000, seeds=(0, 1)) -> list[dict]:
    """Each surface mapped bare with ``fast`` and with ``fast`` less the vote
    (``LocalMeshConfig.vote = False``), one after the other in this process: angle, flips and
    wall seconds of each, and whether the voted mesh was kept."""
    import pcgeom

    fast = pcgeom.get_preset("fast")
    off = dataclasses.replace(fast, local_mesh=dataclasses.replace(fast.local_mesh,
                                                                   vote=False))
    cases = ((case, V, F, None, domains) for case, V, F, domains in vote_surfaces(points, seeds))
    return _off_on_rows(cases, ("vote off", "on"), off_config=off, kept="voted_kept")


def _off_on_rows(cases, labels: tuple[str, str], *, off_config=None,
                 off_context=contextlib.nullcontext, kept: str | None = None) -> list[dict]:
    """Each ``(case, V, F, normals, domains)`` of ``cases`` mapped onto each of its domains
    by ``fast``, one run ``"off"`` (``off_config`` in place of ``fast`` when given, inside
    ``off_context()``) and one ``"on"`` after it in this process: angle, flips and wall
    seconds of each, and, with ``kept``, the history's flag of that name (False when no
    record holds it). ``labels`` name the two runs in the log line."""
    import pcgeom

    fast = pcgeom.get_preset("fast")
    rows = []
    for case, V, F, N, domains in cases:
        for domain in domains:
            row = {"case": case, "domain": domain}
            for key in ("off", "on"):
                with warnings.catch_warnings(), (off_context() if key == "off"
                                                 else contextlib.nullcontext()):
                    warnings.simplefilter("ignore")
                    config = off_config if key == "off" and off_config is not None else fast
                    result, seconds = H.timed(pcgeom.parametrize, V, domain, config=config,
                                              seed=0, progress=False, normals=N)
                row[key] = {"wall_s": seconds, **H.score_map(result.uv, V, F)}
                if kept is not None:
                    record = next((r for r in result.history if kept in r), {})
                    row[key]["kept"] = record.get(kept, False)
            H.log(f"{case} {domain}: {labels[0]} {row['off']['rad']:.4f}, {labels[1]} "
                  f"{row['on']['rad']:.4f}")
            rows.append(row)
    return rows


def render_vote(rows) -> list[str]:
    return _side_by_side(rows, ("off", "on"), "angle, vote", [
        ("voted mesh kept", lambda r: "yes" if r["on"]["kept"] else "no")])


def _side_by_side(rows, names: tuple[str, str], angle: str, extra=()) -> list[str]:
    """The table of rows holding two runs of one surface, ``"off"`` and ``"on"``, headed by
    ``names`` (the angle columns by ``angle`` too): angle, flips, ``extra`` columns, wall
    seconds."""
    off, on = names
    return H.table([("surface", "{case}"), ("map", "{domain}"),
                    (f"{angle} {off}", lambda r: f"{r['off']['rad']:.4f}"),
                    (f"{angle} {on}", lambda r: f"{r['on']['rad']:.4f}"),
                    (f"flipped {off}", lambda r: _flips(r["off"])),
                    (f"flipped {on}", lambda r: _flips(r["on"])), *extra,
                    (f"wall s {off} / {on}", lambda r: f"{r['off']['wall_s']:.1f} / "
                                                      f"{r['on']['wall_s']:.1f}")], rows)


@contextlib.contextmanager
def cut_off():
    """``pcgeom.parametrize`` without the bare cloud's mesh with its bridges cut
    (``pcgeom.maps.free.CUT_ROUNDS`` 0) and with its unmeshed points placed from their nearest
    points in space (``pcgeom.maps.localmesh.PLACE_BY_RINGS`` off), for the duration."""
    import pcgeom.maps.free as FR
    import pcgeom.maps.localmesh as LM

    saved = FR.CUT_ROUNDS, LM.PLACE_BY_RINGS
    FR.CUT_ROUNDS, LM.PLACE_BY_RINGS = 0, False
    try:
        yield
    finally:
        FR.CUT_ROUNDS, LM.PLACE_BY_RINGS = saved


def cut_rows(points: int = 6000, seeds=(0, 1)) -> list[dict]:
    """Each surface of :func:`vote_surfaces` mapped bare with ``fast`` without and with the
    mesh with its bridges cut and the unmeshed points placed from their rings
    (:func:`cut_off`), one after the other in this process: angle, flips and wall seconds of
    each, and whether the cut mesh was kept."""
    cases = ((case, V, F, None, domains) for case, V, F, domains in vote_surfaces(points, seeds))
    return _off_on_rows(cases, ("cut off", "on"), off_context=cut_off, kept="cut_kept")


def render_cut(rows) -> list[str]:
    return _side_by_side(rows, ("before", "now"), "angle", [
        ("cut mesh kept", lambda r: "yes" if r["on"]["kept"] else "no")])


def _flips(run: dict) -> str:
    return f"{run['flipped']} ({run['flip_pct']:.2f}%)"


def _cell(row, key, fmt):
    if row.get("n_ok") == 0:
        return "failed: " + row["errors"][0][1][:40]
    return format(row[key], fmt)


def render(rows) -> list[str]:
    return H.table([("surface", "{case}"), ("rule", "{rule}"), ("runs", "{runs}"),
                    ("mean abs angle, rad", lambda r: _cell(r, "rad", ".4f")),
                    ("flipped", lambda r: _cell(r, "flip_pct", ".2f") + "%")], rows)


LID_CASES = (("deep", "uniform", 1.0), ("deep", "uniform", 1.5), ("deep", "uniform", 2.0),
             ("deep", "even", 1.0), ("deep", "even", 1.5), ("pleat", "", 1.5),
             ("pleat", "", 2.0), ("pleat", "", 2.5))
"""(kind, sampling, gap) of the synthetic surfaces of :func:`lid_rows`."""


@contextlib.contextmanager
def lids_kept():
    """``pcgeom.parametrize`` without the cut of one-sided stars' lids
    (:func:`pcgeom.maps.bridges.one_sided`), for the duration."""
    import pcgeom.maps.localmesh as LM

    saved = LM.one_sided
    LM.one_sided = lambda faces, fans, n, *a: np.zeros(len(faces), dtype=bool)
    try:
        yield
    finally:
        LM.one_sided = saved


def lid_rows(points: int = 6000, seeds=(0, 1)) -> list[dict]:
    """Each surface mapped with its normals by ``fast`` with the lids of one-sided stars kept
    (before) and cut (now), one after the other in this process: the grooves and pleats of
    each cloud seed (their true normals, free map), the shared surfaces with their reference
    mesh's vertex normals (free and onto the disk). Angle and flips on the true triangles."""
    import igl

    from pcgeom.synthetic import pleated_sheet
    from pcgeom.synthetic_folds import deep_folds

    def cases():
        for kind, sampling, gap in LID_CASES:
            for seed in seeds:
                if kind == "deep":
                    s = deep_folds(points, gap=gap, sampling=sampling, seed=seed)
                    name = f"deep folds ({sampling}), walls {gap:g}"
                else:
                    s = pleated_sheet(points, folds=4, gap=gap, seed=seed)
                    name = f"pleat, sheets {gap:g} apart"
                yield f"{name}, cloud seed {seed}", s.points, s.faces, s.normals, ("free",)
        for name in SHARED:
            if H.available(name):
                s = H.load_surface(name)
                N = igl.per_vertex_normals(np.ascontiguousarray(s.V, dtype=np.float64),
                                           np.ascontiguousarray(s.F, dtype=np.int64))
                yield name, s.V, s.F, N, ("free", "disk")

    return _off_on_rows(cases(), ("lids kept", "cut"), off_context=lids_kept)


def render_lids(rows) -> list[str]:
    return _side_by_side(rows, ("kept", "cut"), "angle, lids")


if __name__ == "__main__":
    p = H.parser(__doc__)
    p.add_argument("--seeds", nargs="*", type=int, default=[0])
    p.add_argument("--points", type=int, default=6000)
    args = p.parse_args()
    print("\n".join(render(measure(args.points, args.seeds))))
    sys.exit(0)
