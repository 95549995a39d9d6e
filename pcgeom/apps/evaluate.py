"""Evaluate a map: the report ``pcgeom param`` and ``pcgeom evaluate`` print.

Wraps :mod:`pcgeom.metrics` (one implementation of each measure) into one plain dict per map,
the same for a fresh result and for a map file read back with ``ParamResult.load``.
:func:`evaluate_map` adds the classical baselines on the same reference mesh (libigl's LSCM
and harmonic disk map, timed) and :func:`plot_evaluation` draws the figures of
``pcgeom evaluate --plot DIR``. Onto a domain with holes, :func:`hole_landing` tells where each
hole of the surface (:func:`mesh_holes`) lands among the domain's (:func:`domain_holes`), and
:func:`hole_landmarks` pairs them as landmarks.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..domains import Domain
from ..errors import _one_line
from ..metrics import (AngleReport, angle_distortion, area_factor, domain_hausdorff,
                       surface_hausdorff)
from .baselines import BASELINES, SPHERE_BASELINES

__all__ = ["map_report", "angle_figures", "factor_figures", "landmark_hausdorff",
           "EVALUATION_BASELINES", "SPHERE_EVALUATION_BASELINES", "BaselineRun", "run_baselines",
           "Evaluation", "evaluate_map", "vertex_angle_distortion", "PLOT_FILES", "has_losses",
           "plot_evaluation", "plot_angle_histograms", "mesh_holes", "domain_holes",
           "hole_landing", "hole_landmarks", "HOLE_TARGET_SPACING"]

ANGLE_KEYS = ("mean_abs_angle_rad", "median_abs_angle_rad", "p95_abs_angle_rad",
              "max_abs_angle_rad", "flipped", "n_faces", "flipped_percent", "flipped_where")
"""The keys of :func:`angle_figures`, in report order."""

EVALUATION_BASELINES = ("lscm", "harmonic_disk")
"""The baselines :func:`evaluate_map` runs by default: the mesh-based maps of
:data:`pcgeom.apps.baselines.BASELINES`."""

SPHERE_EVALUATION_BASELINES = ("sphere_conformal",)
"""The baselines :func:`evaluate_map` runs by default for a map onto the sphere: a
spherical conformal map of the reference mesh itself (the stereographic method or
conformalized mean curvature flow, whichever is better there)
(:data:`pcgeom.apps.baselines.SPHERE_BASELINES`)."""

_ALL_BASELINES = {**BASELINES, **SPHERE_BASELINES}

PLOT_FILES = {"angles": "angle_histogram.png", "map": "map_angle_distortion.png",
              "checker": "surface_checker.png", "history": "history.png",
              "sphere_factor": "sphere_conformal_factor.png"}
"""The figures :func:`plot_evaluation` writes into its directory, by key (a sphere map: ``map``
is the sphere coloured by angle distortion, ``sphere_factor`` by the conformal factor, each
with its equirectangular picture; ``checker`` is not drawn)."""


def angle_figures(angles: AngleReport | None) -> dict:
    """The angle keys of a report (:data:`ANGLE_KEYS`): mean, median, 95th percentile and
    maximum absolute angle distortion over all triangle corners (radians, see
    :class:`pcgeom.metrics.AngleReport`), flipped triangles, their count and percentage, and
    where they are (``flipped_where``: ``rim``, ``hole``, ``inside``,
    :func:`pcgeom.metrics.flip_locations`).
    All None when ``angles`` is None (no reference faces)."""
    if angles is None:
        return dict.fromkeys(ANGLE_KEYS)
    return {"mean_abs_angle_rad": angles.mean_abs, "median_abs_angle_rad": angles.median_abs,
            "p95_abs_angle_rad": angles.p95_abs, "max_abs_angle_rad": angles.max_abs,
            "flipped": angles.flipped, "n_faces": angles.n_faces,
            "flipped_percent": 100.0 * angles.flipped / angles.n_faces,
            "flipped_where": angles.where}


def landmark_hausdorff(history) -> list[float] | None:
    """The exact Hausdorff distance of each landmark set to its targets (domain units), as
    the last stage of training recorded it (``history[-1]["landmark_hausdorff"]``, from
    :func:`pcgeom.train.objective.landmark_fit`); None for a run without landmarks or a map
    without history."""
    if not history:
        return None
    last = history[-1]
    value = last.get("landmark_hausdorff") if isinstance(last, dict) else None
    return None if value is None else [float(d) for d in value]


def _report(U: np.ndarray, domain: Domain | None, angles: AngleReport | None,
            history, F=None, V=None) -> dict:
    report = {"n_points": int(len(U)), **angle_figures(angles), "domain_hausdorff": None,
              "surface_hausdorff": None, "landmark_hausdorff": landmark_hausdorff(history)}
    if domain is not None and domain.bounded and not domain.closed:
        report["domain_hausdorff"] = domain_hausdorff(U, domain)
        if F is not None:
            report["surface_hausdorff"] = surface_hausdorff(U, F, domain)
    if U.shape[1] == 3 and angles is not None and V is not None:
        report["conformal_factor"] = factor_figures(area_factor(V, F, U))
    return report


def factor_figures(factor: np.ndarray) -> dict:
    """The spread of a conformal factor (:func:`pcgeom.metrics.area_factor`, per vertex):
    its 5th, 50th and 95th percentiles and ``spread``, the 95th over the 5th."""
    f = factor[np.isfinite(factor) & (factor > 0)]
    if not len(f):
        return {"p5": None, "median": None, "p95": None, "spread": None}
    p5, p50, p95 = (float(x) for x in np.percentile(f, [5, 50, 95]))
    return {"p5": p5, "median": p50, "p95": p95, "spread": p95 / p5}


def map_report(U, domain: Domain | None = None, V=None, F=None, history=None) -> dict:
    """Quality figures of a map, as plain data (JSON-ready).

    Parameters
    ----------
    U : (N, 2) array_like
        The map; (N, 3) unit vectors onto the sphere.
    domain : Domain, optional
        Its parameter domain; a bounded planar one adds ``domain_hausdorff``, and with faces
        ``surface_hausdorff``; a sphere map with faces adds ``conformal_factor``
        (:func:`factor_figures`).
    V, F : (N, 3) and (M, 3) array_like, optional
        Reference mesh (one vertex per row of ``U``); adds the angle distortion and flips.
    history : list of dict, optional
        ``ParamResult.history``; a run with landmarks adds ``landmark_hausdorff``.

    Returns
    -------
    dict
        ``n_points``; when faces are given, :func:`angle_figures` (``mean_abs_angle_rad``,
        ``median_abs_angle_rad``, ``p95_abs_angle_rad``, ``max_abs_angle_rad``, ``flipped``,
        ``n_faces``, ``flipped_percent``); ``domain_hausdorff`` when the domain is bounded:
        the mapped points' Hausdorff distance to its region
        (:func:`pcgeom.metrics.domain_hausdorff`), and with faces ``surface_hausdorff``, the
        mapped triangles' (:func:`pcgeom.metrics.surface_hausdorff`, without the floor the
        cloud's own sampling gaps put under the first);
        ``landmark_hausdorff`` (one distance per landmark set) when the history records one.
        Keys whose measure does not apply are None.
    """
    U = np.asarray(U, dtype=np.float64)
    angles = angle_distortion(V, F, U) if F is not None else None
    return _report(U, domain, angles, history, F, V)


@dataclass(frozen=True)
class BaselineRun:
    """One baseline map of the reference mesh, timed and measured (:func:`run_baselines`)."""

    name: str
    """Key in :data:`pcgeom.apps.baselines.BASELINES`."""
    label: str
    """What it is, for people."""
    seconds: float | None
    """Wall time of the map itself (not of its measurement); None when it failed."""
    angles: AngleReport | None
    """Its angle distortion on the mesh; None when it failed."""
    error: str | None = None
    """One line saying why the baseline could not run (e.g. a closed mesh), else None."""

    def to_dict(self) -> dict:
        """JSON-ready: ``label``, ``seconds``, ``error`` and :func:`angle_figures`."""
        return {"label": self.label, "seconds": self.seconds, "error": self.error,
                **angle_figures(self.angles)}


def run_baselines(V, F, names=EVALUATION_BASELINES) -> list[BaselineRun]:
    """Map the reference mesh ``(V, F)`` with each named baseline, timing it, and measure it.

    A baseline that cannot handle the mesh (``ValueError``: no boundary loop, for example)
    gives a run with its ``error`` set instead of stopping the others.

    Parameters
    ----------
    V : (N, 3) array_like
    F : (M, 3) array_like of int
    names : sequence of str
        Keys of :data:`pcgeom.apps.baselines.BASELINES` or ``SPHERE_BASELINES``.

    Returns
    -------
    list of BaselineRun
        In the order of ``names``.

    Raises
    ------
    ValueError
        An unknown name (the message lists the known ones).
    ImportError
        libigl is not installed.
    """
    names = list(names)
    unknown = [n for n in names if n not in _ALL_BASELINES]
    if unknown:
        raise ValueError(f"baselines: unknown {unknown[0]!r}; expected some of "
                         f"{', '.join(_ALL_BASELINES)}")
    runs = []
    for name in names:
        label, _, _, method = _ALL_BASELINES[name]
        t0 = time.perf_counter()
        try:
            U = method(V, F)
        except ValueError as exc:
            runs.append(BaselineRun(name, label, None, None, _one_line(exc)))
            continue
        seconds = time.perf_counter() - t0
        runs.append(BaselineRun(name, label, seconds, angle_distortion(V, F, U)))
    return runs


@dataclass(frozen=True)
class Evaluation:
    """A map measured on its reference mesh, beside the baselines (:func:`evaluate_map`)."""

    report: dict
    """:func:`map_report`'s keys plus ``baselines``: name -> :meth:`BaselineRun.to_dict`."""
    angles: AngleReport
    """The map's angle distortion (per corner: the histograms and the coloured map)."""
    baselines: tuple[BaselineRun, ...]
    uv: np.ndarray
    """(N, 2) the map."""
    faces: np.ndarray
    """(M, 3) the reference triangles."""
    domain: Domain | None = None
    history: list = field(default_factory=list)
    """``ParamResult.history`` (empty for a bare ``uv`` file)."""
    points: np.ndarray | None = None
    """(N, 3) the reference mesh's vertices (the surface of the ``checker`` figure)."""


def evaluate_map(U, V, F, domain: Domain | None = None, history=None,
                 baselines=None) -> Evaluation:
    """Everything ``pcgeom evaluate`` reports on a map ``U`` of the mesh ``(V, F)``.

    Parameters
    ----------
    U : (N, 2) array_like
        The map, one row per vertex.
    V : (N, 3) array_like
    F : (M, 3) array_like of int
        The reference mesh.
    domain : Domain, optional
        The map's domain (``ParamResult.domain``).
    history : list of dict, optional
        ``ParamResult.history``.
    baselines : sequence of str, optional
        Baselines run on ``(V, F)`` (:func:`run_baselines`); empty for none. Default:
        :data:`SPHERE_EVALUATION_BASELINES` for a sphere map, else
        :data:`EVALUATION_BASELINES`.

    Returns
    -------
    Evaluation
    """
    U = np.asarray(U, dtype=np.float64)
    if baselines is None:
        baselines = SPHERE_EVALUATION_BASELINES if U.shape[1] == 3 else EVALUATION_BASELINES
    angles = angle_distortion(V, F, U)
    report = _report(U, domain, angles, history, F, V)
    runs = tuple(run_baselines(V, F, baselines))
    report["baselines"] = {run.name: run.to_dict() for run in runs}
    return Evaluation(report, angles, runs, U, np.asarray(F, dtype=np.int64), domain,
                      list(history or []), points=np.asarray(V, dtype=np.float64))


def vertex_angle_distortion(F, per_corner, n_vertices: int) -> np.ndarray:
    """Per-vertex angle distortion: the mean of ``per_corner`` over the corners at each vertex.

    Parameters
    ----------
    F : (M, 3) array_like of int
    per_corner : (M, 3) array_like
        ``AngleReport.per_corner``.
    n_vertices : int

    Returns
    -------
    (n_vertices,) float64
        NaN at a vertex of no triangle.
    """
    F = np.asarray(F, dtype=np.int64)
    d = np.asarray(per_corner, dtype=np.float64)
    if d.shape != F.shape:
        raise ValueError(f"per_corner: expected shape {F.shape} (one value per corner of F), "
                         f"got {d.shape}")
    total = np.bincount(F.ravel(), weights=d.ravel(), minlength=n_vertices)  # (n,)
    count = np.bincount(F.ravel(), minlength=n_vertices)  # (n,)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(count > 0, total / count, np.nan)


def _baseline_histograms(evaluation: Evaluation) -> dict:
    return {run.label: run.angles.per_corner for run in evaluation.baselines
            if run.angles is not None}


def has_losses(history) -> bool:
    """Whether some stage of ``history`` recorded a positive loss term (``LOSS_TERMS``):
    the network stages do; a local-mesh map's record (preset ``fast``) does not."""
    from ..train.objective import LOSS_TERMS

    return any(isinstance(row, dict) and isinstance(row.get(term), (int, float))
               and row[term] > 0 for row in history or () for term in LOSS_TERMS)


def plot_evaluation(evaluation: Evaluation, out_dir, title: str | None = None,
                    squares: int | None = None) -> dict:
    """The figures of ``pcgeom evaluate --plot DIR``, written into ``out_dir`` (created if
    absent; its parent must exist), atomically, named as in :data:`PLOT_FILES`:

    - ``angles``: the map's per-corner angle distortion histogram, the baselines'
      histograms overlaid on the same bins;
    - ``map``: the map coloured by angle distortion (per vertex, the mean over its corners;
      :func:`vertex_angle_distortion`), the domain's boundary in red when bounded;
    - ``checker``: the reference surface with a checkerboard of ``squares`` squares in the
      map's coordinates (:func:`pcgeom.apps.plot.plot_checker`, the map scaled into the unit
      square as ``pcgeom reconstruct`` writes its texture coordinates), beside the surface
      coloured by angle distortion per triangle (the mean of its corners); None for an
      evaluation without the mesh's vertices;
    - ``history``: the loss terms at the end of each stage; None (no file) for a map without
      a stage that recorded a loss (:func:`has_losses`: a bare ``uv`` file, or a local-mesh
      map such as preset ``fast``'s, whose history holds no loss: the figure would be empty).

    Returns
    -------
    dict
        Key of :data:`PLOT_FILES` -> the Path written, or None when the figure does not
        apply (``sphere_factor`` only for a sphere map).
    """
    from .plot import plot_angle_histogram, plot_checker, plot_history, plot_map
    from .texture import uv_scaling

    out_dir = Path(out_dir)
    out_dir.mkdir(exist_ok=True)
    prefix = f"{title}: " if title else ""
    n = len(evaluation.uv)
    per_vertex = vertex_angle_distortion(evaluation.faces, evaluation.angles.per_corner, n)
    written = {
        "angles": plot_angle_histogram(
            evaluation.angles.per_corner, out_dir / PLOT_FILES["angles"],
            title=f"{prefix}angle distortion", others=_baseline_histograms(evaluation)),
        "map": None,
        "checker": None,
        "history": None,
    }
    if evaluation.uv.shape[1] == 3:
        _plot_sphere_evaluation(evaluation, out_dir, prefix, per_vertex, written)
    else:
        written["map"] = plot_map(evaluation.uv, out_dir / PLOT_FILES["map"], values=per_vertex,
                                  domain=evaluation.domain,
                                  title=f"{prefix}angle distortion per vertex (rad)")
        if evaluation.points is not None:
            written["checker"] = plot_checker(
                evaluation.points, evaluation.faces,
                uv_scaling(evaluation.uv).apply(evaluation.uv),
                out_dir / PLOT_FILES["checker"], squares=squares,
                values=evaluation.angles.per_corner.mean(axis=1),
                value_label="angle distortion per triangle (rad)", title=title)
    if has_losses(evaluation.history):
        written["history"] = plot_history(evaluation.history, out_dir / PLOT_FILES["history"],
                                          title=f"{prefix}loss per stage")
    return written


def _plot_sphere_evaluation(evaluation: Evaluation, out_dir: Path, prefix: str,
                            per_vertex: np.ndarray, written: dict) -> None:
    """:func:`plot_evaluation`'s figures of a sphere map, into ``written``: the sphere
    coloured by angle distortion (``map``) and by the conformal factor (``sphere_factor``),
    each with its equirectangular picture."""
    from .plot import plot_sphere

    written["map"] = plot_sphere(evaluation.uv, out_dir / PLOT_FILES["map"], values=per_vertex,
                                 title=f"{prefix}angle distortion per vertex",
                                 value_label="radians")
    written["sphere_factor"] = None
    if evaluation.points is not None:
        written["sphere_factor"] = plot_sphere(
            evaluation.uv, out_dir / PLOT_FILES["sphere_factor"],
            values=area_factor(evaluation.points, evaluation.faces, evaluation.uv),
            title=f"{prefix}conformal factor (mapped over surface area share, square root)",
            value_label="conformal factor", log=True)


def plot_angle_histograms(evaluation: Evaluation, path, title: str | None = None) -> Path:
    """Only the ``angles`` figure of :func:`plot_evaluation`, at ``path`` (a ``.png``)."""
    from .plot import plot_angle_histogram

    return plot_angle_histogram(evaluation.angles.per_corner, path, title=title,
                                others=_baseline_histograms(evaluation))


# --------------------------------------------------------------------------- holes

HOLE_TARGET_SPACING = 0.01
"""Spacing of :func:`hole_landmarks`' targets along each domain hole's boundary."""


def mesh_holes(V, F) -> list[np.ndarray]:
    """The holes of a mesh: its boundary loops but the longest (the outline), longest first.

    Returns
    -------
    list of (k,) int64 vertex indices, each in loop order
    """
    import igl

    loops = [np.asarray(loop, dtype=np.int64)
             for loop in igl.boundary_loop_all(np.ascontiguousarray(F))]

    def length(loop):
        P = V[loop]
        return float(np.linalg.norm(P - np.roll(P, -1, axis=0), axis=1).sum())

    loops.sort(key=length, reverse=True)
    return loops[1:]


def domain_holes(domain) -> list[dict]:
    """The domain's holes: name (``left eye``, ``right eye``, ``mouth`` for the smile, else
    ``hole k``), closed ring (k, 2) and a point inside each."""
    import shapely

    polygons = getattr(domain.geometry, "geoms", [domain.geometry])
    rings = [np.asarray(r.coords) for p in polygons for r in p.interiors]
    holes = []
    for k, ring in enumerate(rings):
        poly = shapely.Polygon(ring)
        inside = np.asarray(poly.representative_point().coords[0])
        name = f"hole {k}"
        if domain.name == "smile":
            names = {"left eye": domain.EYE_CENTERS[0], "right eye": domain.EYE_CENTERS[1],
                     "mouth": domain.MOUTH_CENTER}
            c = np.asarray(poly.centroid.coords[0])
            name = min(names, key=lambda n: np.linalg.norm(c - np.asarray(names[n])))
        holes.append({"name": name, "ring": ring, "inside": inside})
    return holes


def hole_landing(U, holes_idx, targets) -> dict:
    """Where each hole of the surface (:func:`mesh_holes`) lands under the map ``U``.

    Parameters
    ----------
    U : (N, 2) map
    holes_idx : list of (k,) loop vertex indices (the cloud's holes)
    targets : list of dicts from :func:`domain_holes`

    Returns
    -------
    dict
        ``holes``: per cloud hole, the domain hole its loop is nearest to (mean distance of its
        mapped points to that hole's boundary), the names of the domain holes its mapped loop
        encloses, the Hausdorff distance to the nearest hole's boundary and ``lands`` (it
        encloses exactly that hole); ``all_land``: every cloud hole lands and no two on the
        same domain hole.
    """
    import shapely

    from ..io.landmarks import sample_polyline
    from ..metrics import hausdorff

    rings = [sample_polyline(t["ring"], 0.005) for t in targets]
    rows = []
    for k, loop in enumerate(holes_idx):
        L = U[loop]  # (k, 2) mapped loop, in loop order
        poly = shapely.Polygon(L).buffer(0)  # a folded loop becomes valid (its outline)
        encloses = [t["name"] for t in targets
                    if poly.contains(shapely.Point(*t["inside"]))]
        lines = [shapely.LineString(t["ring"]) for t in targets]
        mean_d = [float(np.mean(shapely.distance(shapely.points(L), line))) for line in lines]
        j = int(np.argmin(mean_d))
        rows.append({
            "cloud_hole": k,
            "n_points": int(len(loop)),
            "nearest": targets[j]["name"],
            "mean_distance": mean_d[j],
            "hausdorff": hausdorff(L, rings[j]),
            "encloses": encloses,
            "lands": encloses == [targets[j]["name"]],
        })
    names = [r["nearest"] for r in rows]
    all_land = all(r["lands"] for r in rows) and len(set(names)) == len(names)
    return {"holes": rows, "all_land": bool(all_land)}


def hole_landmarks(V, U, holes_idx, targets) -> tuple[list, list[str]]:
    """Landmark pairs: each cloud hole's loop points -> its domain hole's boundary.

    The longest cloud hole (the first) goes to the largest domain hole (the mouth); the others
    to the others in the order of their mapped centroids' x under ``U``.
    """
    import shapely

    from ..io.landmarks import sample_polyline

    by_area = sorted(range(len(targets)), key=lambda j: -shapely.Polygon(targets[j]["ring"]).area)
    big, rest = by_area[0], sorted(by_area[1:], key=lambda j: targets[j]["inside"][0])
    others = sorted(range(1, len(holes_idx)), key=lambda k: U[holes_idx[k]][:, 0].mean())
    assign = {0: big, **dict(zip(others, rest))}
    pairs, names = [], []
    for k, loop in enumerate(holes_idx):
        t = targets[assign[k]]
        pairs.append((V[loop], sample_polyline(t["ring"], HOLE_TARGET_SPACING)))
        names.append(t["name"])
    return pairs, names
