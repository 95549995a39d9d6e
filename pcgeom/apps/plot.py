"""Figures: a 2D map coloured by a per-point value, a parameter domain, per-stage loss curves,
angle histograms, detected boundary loops and the effect of the threshold h on them, and a
surface with a checkerboard in its map's coordinates.

matplotlib is imported inside each function (it is slow to import and only figures need it),
and figures are built with :class:`matplotlib.figure.Figure` on the Agg canvas, never through
``pyplot``: no global figure state, no GUI backend, safe in scripts, servers and tests.

Every PNG is written atomically (temporary file in the target directory, then ``os.replace``),
so an interrupted run never leaves a truncated image behind.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np

from ..io.atomic import write_atomic
from ..mesh import half_edges
from ..train.objective import LOSS_TERMS

__all__ = ["plot_map", "plot_sphere", "plot_domain", "plot_history", "plot_angle_histogram",
           "plot_boundary", "plot_boundary_h_sweep", "plot_checker"]


def _new_figure(figsize: tuple[float, float]):
    """A Figure attached to an Agg canvas (PNG output without pyplot or a display)."""
    try:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
    except ImportError as exc:
        raise ImportError("pcgeom.plot needs matplotlib: pip install 'matplotlib>=3.7'") from exc
    fig = Figure(figsize=figsize, dpi=120, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def _save_png_atomic(fig, path) -> Path:
    """Render ``fig`` as PNG to a temporary file beside ``path``, then rename it over ``path``."""
    path = Path(path)
    if path.suffix.lower() != ".png":
        got = repr(path.suffix) if path.suffix else "none"
        raise ValueError(f"path: {os.fspath(path)}: expected extension '.png', got {got}")
    # format= is required: the file object has no name to infer it from.
    write_atomic(path, lambda f: fig.savefig(f, format="png"))
    return path


def plot_map(U, path, values=None, domain=None, title: str | None = None) -> Path:
    """Scatter plot of a 2D map, optionally coloured by a per-point value.

    Parameters
    ----------
    U : (N, 2) array_like
        Mapped points.
    path : str or os.PathLike
        Output ``.png`` file, written atomically.
    values : (N,) array_like, optional
        Colour of each point (e.g. ``lambda_inv``), shown with a colourbar. Uniform colour when
        omitted.
    domain : pcgeom.domains.Domain, optional
        Target domain; a bounded domain's boundary loops (``domain.boundary_loops()``) are
        drawn as closed red curves.
    title : str, optional
        Axes title.

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    ValueError
        ``U`` not (N, 2) with N >= 1, ``values`` not (N,), non-finite coordinates, or a path
        without the ``.png`` extension.
    """
    U = np.asarray(U, dtype=np.float64)
    if U.ndim != 2 or U.shape[1] != 2 or len(U) == 0:
        raise ValueError(f"U: expected shape (N, 2) with N >= 1, got {U.shape}")
    if not np.isfinite(U).all():
        raise ValueError("U: contains NaN or inf")
    if values is not None:
        values = np.asarray(values, dtype=np.float64)
        if values.shape != (len(U),):
            raise ValueError(f"values: expected shape ({len(U)},), got {values.shape}")

    fig = _new_figure((6.0, 5.4))
    ax = fig.add_subplot()
    # Marker area shrinks with N so a dense cloud still shows its structure.
    size = float(np.clip(20000.0 / len(U), 1.0, 20.0))
    if values is None:
        ax.scatter(U[:, 0], U[:, 1], s=size, c="tab:blue", linewidths=0)
    else:
        sc = ax.scatter(U[:, 0], U[:, 1], s=size, c=values, cmap="viridis", linewidths=0)
        fig.colorbar(sc, ax=ax, shrink=0.85)
    if domain is not None and domain.bounded:
        _draw_loops(ax, domain)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("u")
    ax.set_ylabel("v")
    if title:
        ax.set_title(title)
    return _save_png_atomic(fig, path)


def plot_sphere(S, path, values=None, title: str | None = None,
                value_label: str | None = None, log: bool = False) -> Path:
    """A map onto the sphere in three panels: the northern hemisphere seen from above, the
    southern seen from below (both orthographic, as seen from outside), and the whole
    sphere in equirectangular coordinates (longitude ``atan2(y, x)``, latitude
    ``asin(z)``), the points coloured by ``values``.

    Parameters
    ----------
    S : (N, 3) array_like
        Unit vectors.
    path : str or os.PathLike
        Output ``.png`` file, written atomically.
    values : (N,) array_like, optional
        Colour of each point; NaN points are grey. Uniform colour when omitted.
    value_label : str, optional
        The colourbar's label.
    log : bool
        Colour by ``values`` on a logarithmic scale (positive values: a conformal factor).

    Raises
    ------
    ValueError
        ``S`` not (N, 3) with N >= 1 or not finite, ``values`` not (N,), or a path without
        the ``.png`` extension.
    """
    from matplotlib.colors import LogNorm
    from matplotlib.patches import Circle

    S = np.asarray(S, dtype=np.float64)
    if S.ndim != 2 or S.shape[1] != 3 or len(S) == 0:
        raise ValueError(f"S: expected shape (N, 3) with N >= 1, got {S.shape}")
    if not np.isfinite(S).all():
        raise ValueError("S: contains NaN or inf")
    S = S / np.maximum(np.linalg.norm(S, axis=1, keepdims=True), 1e-300)
    colour: dict = {"c": "tab:blue"}
    if values is not None:
        values = np.asarray(values, dtype=np.float64)
        if values.shape != (len(S),):
            raise ValueError(f"values: expected shape ({len(S)},), got {values.shape}")
        ok = np.isfinite(values) & ((values > 0) if log else True)
        lo, hi = (np.percentile(values[ok], [1, 99]) if ok.any() else (0.0, 1.0))
        hi = max(hi, lo * (1 + 1e-9) + 1e-12)
        norm = LogNorm(lo, hi) if log else None
        colour = {"c": np.where(ok, values, np.nan), "cmap": "viridis", "norm": norm,
                  "plotnonfinite": True, **({} if log else {"vmin": lo, "vmax": hi})}
    fig = _new_figure((9.0, 7.6))
    grid = fig.add_gridspec(2, 2, height_ratios=[1.0, 0.8])
    size = float(np.clip(40000.0 / len(S), 0.3, 20.0))
    views = ((S[:, 2] >= 0, S[:, 0], "north (z > 0), from above"),
             (S[:, 2] < 0, -S[:, 0], "south (z < 0), from below"))
    sc = None
    for k, (side, x, label) in enumerate(views):
        ax = fig.add_subplot(grid[0, k])
        c = colour if values is None else {**colour, "c": colour["c"][side]}
        sc = ax.scatter(x[side], S[side, 1], s=size, linewidths=0, rasterized=True, **c)
        ax.add_patch(Circle((0, 0), 1.0, fill=False, color="0.4", lw=0.8))
        ax.set_xlim(-1.05, 1.05)
        ax.set_ylim(-1.05, 1.05)
        ax.set_aspect("equal")
        ax.set_axis_off()
        ax.set_title(label, fontsize=9)
    ax = fig.add_subplot(grid[1, :])
    lon = np.degrees(np.arctan2(S[:, 1], S[:, 0]))
    lat = np.degrees(np.arcsin(np.clip(S[:, 2], -1.0, 1.0)))
    sc = ax.scatter(lon, lat, s=size, linewidths=0, rasterized=True, **colour)
    ax.set_xlim(-180, 180)
    ax.set_ylim(-90, 90)
    ax.set_aspect("equal")
    ax.set_xlabel("longitude (degrees)")
    ax.set_ylabel("latitude (degrees)")
    ax.set_title("equirectangular", fontsize=9)
    if values is not None:
        fig.colorbar(sc, ax=fig.axes, shrink=0.6, label=value_label)
    if title:
        fig.suptitle(title)
    return _save_png_atomic(fig, path)


def _draw_loops(ax, domain) -> None:
    """Each boundary loop of ``domain`` as a closed red curve."""
    for loop in domain.boundary_loops():
        loop = np.asarray(loop, dtype=np.float64)  # (k, 2), closed
        ax.plot(loop[:, 0], loop[:, 1], color="red", linewidth=1.2)


def plot_domain(domain, path, n: int = 2000, seed: int = 0, title: str | None = None) -> Path:
    """A parameter domain: its boundary loops over a light scatter of its sample.

    Parameters
    ----------
    domain : pcgeom.domains.Domain
        A bounded domain.
    path : str or os.PathLike
        Output ``.png`` file, written atomically.
    n : int
        Number of sample points drawn (``domain.sample(n, seed)``, what training uses).
    seed : int
        Sample seed.
    title : str, optional
        Axes title (default: the domain's spec and area).

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    ValueError
        The free boundary (no region to draw), ``n < 1``, or a path without the ``.png``
        extension.
    """
    if not domain.bounded:
        raise ValueError(f"domain {domain.name!r} has no region to draw")
    S = domain.sample(n, seed=seed)  # (n, 2); ValueError for a bad n
    if domain.closed:  # the sphere: its sample seen from both poles and equirectangular
        return plot_sphere(S, path, title=title or f"{domain.label}: area {domain.area:.2f}")
    fig = _new_figure((6.0, 5.4))
    ax = fig.add_subplot()
    size = float(np.clip(8000.0 / len(S), 0.5, 8.0))
    ax.scatter(S[:, 0], S[:, 1], s=size, c="tab:blue", alpha=0.35, linewidths=0)
    _draw_loops(ax, domain)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("u")
    ax.set_ylabel("v")
    ax.set_title(title if title is not None else
                 f"{domain.label}: area {domain.area:.4g}, "
                 f"{len(domain.boundary_loops())} boundary loop(s)")
    return _save_png_atomic(fig, path)


def _positive_or_nan(x) -> float:
    """A loss value usable on a log axis; zero, negative, missing or non-finite give NaN."""
    try:
        v = float(x)
    except (TypeError, ValueError):
        return math.nan
    return v if math.isfinite(v) and v > 0 else math.nan


def plot_history(history, path, title: str | None = None) -> Path:
    """Loss terms at the end of each stage of Algorithm 1, on a log scale.

    Parameters
    ----------
    history : list of dict
        One dict per stage, as in ``ParamResult.history``: ``"stage"`` and the loss terms
        ``"total"``, ``"leg"``, ``"hand"``, ``"landmarks"`` (missing keys are allowed). A term
        that is zero in every stage (e.g. ``hand`` with a free boundary) is left out, since a
        log axis cannot show it.
    path : str or os.PathLike
        Output ``.png`` file, written atomically.
    title : str, optional
        Axes title.

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    ValueError
        Empty history, a stage that is not a dict, or a path without the ``.png`` extension.
    """
    history = list(history)
    if not history:
        raise ValueError("history: expected at least one stage, got none")
    for i, row in enumerate(history):
        if not isinstance(row, dict):
            raise ValueError(f"history: stage {i} is a {type(row).__name__}, expected a dict")

    stages = np.arange(1, len(history) + 1)
    fig = _new_figure((6.4, 4.2))
    ax = fig.add_subplot()
    drawn = 0
    for term in LOSS_TERMS:
        y = np.array([_positive_or_nan(row.get(term)) for row in history])
        if np.isnan(y).all():
            continue
        ax.plot(stages, y, marker="o", label=term, linewidth=2.0 if term == "total" else 1.2)
        drawn += 1
    ax.set_yscale("log")
    ax.set_xticks(stages, [str(row.get("stage", s)) for row, s in zip(history, stages)])
    ax.set_xlabel("stage")
    ax.set_ylabel("loss at end of stage")
    ax.grid(True, which="both", alpha=0.3)
    if drawn:
        ax.legend()
    else:
        ax.text(0.5, 0.5, "no positive loss values", ha="center", va="center",
                transform=ax.transAxes)
    if title:
        ax.set_title(title)
    return _save_png_atomic(fig, path)


def _corner_values(values, name: str) -> np.ndarray:
    d = np.asarray(values, dtype=np.float64).ravel()
    if d.size == 0:
        raise ValueError(f"{name}: expected at least one value, got none")
    if not np.isfinite(d).all():
        raise ValueError(f"{name}: contains NaN or inf")
    return d


def plot_angle_histogram(per_corner, path, bins: int = 60, title: str | None = None,
                         others=None, label: str = "map") -> Path:
    """Histogram of per-corner absolute angle distortion, with its mean marked, optionally
    overlaid with other maps' histograms (e.g. the baselines) on the same bins.

    Parameters
    ----------
    per_corner : (M, 3) or (K,) array_like
        Absolute angle differences in radians, e.g. ``AngleReport.per_corner`` from
        :func:`pcgeom.metrics.angle_distortion`.
    path : str or os.PathLike
        Output ``.png`` file, written atomically.
    bins : int
        Number of histogram bins, spanning the values of every histogram drawn.
    title : str, optional
        Axes title.
    others : mapping of str to array_like, optional
        Label -> per-corner values of another map, drawn as an outline with its mean dashed
        (the map's mean is the red line).
        Shown as fractions of corners when given (maps of different meshes compare), as
        corner counts otherwise.
    label : str
        Legend label of ``per_corner`` when ``others`` are drawn.

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    ValueError
        No values, non-finite values, ``bins < 1``, or a path without the ``.png`` extension.
    """
    d = _corner_values(per_corner, "per_corner")
    if isinstance(bins, bool) or not isinstance(bins, (int, np.integer)) or bins < 1:
        raise ValueError(f"bins: expected a positive int, got {bins!r}")
    others = {str(k): _corner_values(v, f"others[{k!r}]") for k, v in (others or {}).items()}

    fig = _new_figure((6.4, 4.2))
    ax = fig.add_subplot()
    top = max([float(d.max())] + [float(v.max()) for v in others.values()])
    edges = np.linspace(0.0, top if top > 0 else 1.0, int(bins) + 1)
    density = bool(others)
    weights = (lambda v: np.full(v.size, 1.0 / v.size)) if density else (lambda v: None)
    mean = float(d.mean())
    ax.hist(d, bins=edges, weights=weights(d), color="tab:blue", alpha=0.6 if others else 0.85,
            label=f"{label} (mean {mean:.4f} rad)" if others else None)
    ax.axvline(mean, color="red", linewidth=1.2,
               label=None if others else f"mean {mean:.4f} rad")
    colours = ["black", "tab:green", "tab:purple", "tab:orange", "tab:brown"]
    for i, (other, v) in enumerate(others.items()):
        colour = colours[i % len(colours)]
        ax.hist(v, bins=edges, weights=weights(v), histtype="step", color=colour,
                linewidth=1.4, label=f"{other} (mean {float(v.mean()):.4f} rad)")
        ax.axvline(float(v.mean()), color=colour, linewidth=1.0, linestyle="--")
    ax.set_xlabel("|angle in 3D - angle in map| (rad)")
    ax.set_ylabel("fraction of triangle corners" if density else "triangle corners")
    ax.legend(fontsize="small" if others else None)
    if title:
        ax.set_title(title)
    return _save_png_atomic(fig, path)


def _check_map(U) -> np.ndarray:
    U = np.asarray(U, dtype=np.float64)
    if U.ndim != 2 or U.shape[1] != 2 or len(U) == 0:
        raise ValueError(f"U: expected shape (N, 2) with N >= 1, got {U.shape}")
    if not np.isfinite(U).all():
        raise ValueError("U: contains NaN or inf")
    return U


def _draw_boundary(ax, U: np.ndarray, found, legend: bool) -> None:
    """Kept triangles in light grey, removed ones faint orange, each loop in its own colour
    (outer loop black), dropped loops dotted grey."""
    from matplotlib.collections import LineCollection

    for tris, colour, alpha in ((found.triangles, "0.55", 0.5),
                                (found.removed, "tab:orange", 0.25)):
        if len(tris):
            segs = U[half_edges(tris)]
            ax.add_collection(LineCollection(segs, colors=colour, linewidths=0.3, alpha=alpha))
    size = float(np.clip(4000.0 / len(U), 0.3, 6.0))
    ax.scatter(U[:, 0], U[:, 1], s=size, c="0.3", linewidths=0)
    for loop in found.dropped:
        closed = U[np.append(loop, loop[0])]
        ax.plot(closed[:, 0], closed[:, 1], color="0.4", linewidth=0.8, linestyle=":")
    palette = ["tab:red", "tab:blue", "tab:green", "tab:purple", "tab:cyan", "tab:brown",
               "tab:pink", "tab:olive"]
    shown = 8  # legend entries; a map with dozens of loops would drown the axes
    for i, loop in enumerate(found.loops):
        closed = U[np.append(loop, loop[0])]
        colour = "black" if i == 0 else palette[(i - 1) % len(palette)]
        kind = "outer" if i == 0 else f"hole {i}" if found.areas[i] < 0 else f"island {i}"
        label = f"{kind}: {len(loop)} points" if i < shown else None
        ax.plot(closed[:, 0], closed[:, 1], color=colour, linewidth=1.4, label=label)
    if len(found.loops) > shown:
        ax.plot([], [], color="none", label=f"... {len(found.loops) - shown} more loops")
    ax.set_aspect("equal", adjustable="datalim")
    ax.autoscale_view()
    if legend and found.loops:
        ax.legend(fontsize="small", loc="best")


def _rule_text(found) -> str:
    rule = f"h = {found.h:.4g}" if found.h is not None else f"local rule, c = {found.c:g}"
    return f"{rule}: {len(found.loops)} loop(s), {len(found.dropped)} dropped"


def plot_boundary(U, found, path, title: str | None = None) -> Path:
    """The map with its detected boundary loops.

    Parameters
    ----------
    U : (N, 2) array_like
        The map the loops were detected on.
    found : pcgeom.apps.boundary.BoundaryLoops
        The result of :func:`pcgeom.apps.boundary.detect_boundary` on ``U``: loops coloured
        (outer loop black, holes in colours, dropped loops dotted), kept Delaunay triangles
        grey, removed ones faint orange.
    path : str or os.PathLike
        Output ``.png`` file, written atomically.
    title : str, optional
        Axes title (default: the rule and the loop count).

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    ValueError
        ``U`` not (N, 2) with N >= 1 or not finite, loops that index outside ``U``, or a path
        without the ``.png`` extension.
    """
    U = _check_map(U)
    rows = [found.triangles.ravel(), found.removed.ravel(), *found.loops, *found.dropped]
    top = max((int(r.max()) for r in rows if len(r)), default=-1)
    if top >= len(U):
        raise ValueError(f"found: refers to row {top} but U has {len(U)} rows")
    fig = _new_figure((6.4, 5.6))
    ax = fig.add_subplot()
    _draw_boundary(ax, U, found, legend=True)
    ax.set_xlabel("u")
    ax.set_ylabel("v")
    ax.set_title(title if title is not None else _rule_text(found))
    return _save_png_atomic(fig, path)


def plot_boundary_h_sweep(U, hs, path, title: str | None = None) -> Path:
    """The effect of the threshold h: one panel of detected loops per value.

    Too small an h removes triangles of the surface and opens spurious loops; too large an h
    keeps triangles across the holes and the concave parts of the rim, down to the convex
    hull as one loop. The default local rule (``None`` in ``hs``) needs no h.

    Parameters
    ----------
    U : (N, 2) array_like
        A free-boundary map.
    hs : sequence of float or None
        Thresholds, one panel each, in order; ``None`` draws the default local rule.
    path : str or os.PathLike
        Output ``.png`` file, written atomically.
    title : str, optional
        Figure title.

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    ValueError
        ``hs`` empty, a non-positive h, a bad ``U`` (``pcgeom.InputError``), or a path
        without the ``.png`` extension.
    """
    from .boundary import detect_boundary

    U = _check_map(U)
    hs = list(hs)
    if not hs:
        raise ValueError("hs: expected at least one threshold, got none")
    results = [detect_boundary(U, h) for h in hs]  # InputError for a bad h, before drawing
    cols = min(len(hs), 3)
    rows = -(-len(hs) // cols)
    fig = _new_figure((4.2 * cols, 3.8 * rows))
    for i, found in enumerate(results):
        ax = fig.add_subplot(rows, cols, i + 1)
        _draw_boundary(ax, U, found, legend=False)
        ax.set_title(_rule_text(found), fontsize="medium")
        ax.set_xticks([])
        ax.set_yticks([])
    if title:
        fig.suptitle(title)
    return _save_png_atomic(fig, path)


def _surface_frame(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """``V`` in its principal frame, least-variance axis up and the mesh's mean normal along
    +z, so that an open surface faces the viewer of a 3D axes. (K, 3)"""
    X = V - V.mean(axis=0)
    _, _, axes = np.linalg.svd(X, full_matrices=False)  # rows: most to least variance
    axes[2] = np.cross(axes[0], axes[1])  # right-handed
    normal = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]).sum(axis=0)
    if normal @ axes[2] < 0:
        axes[1:] *= -1  # half a turn about the first axis: still right-handed
    return X @ axes.T


def _draw_surface(ax, Y: np.ndarray, F: np.ndarray, rgb: np.ndarray) -> None:
    """Triangles ``Y[F]`` on a 3D axes with face colours ``rgb`` (M, 3) in [0, 1], lit by one
    light from the upper left (both sides alike) so that the shape reads."""
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    n = np.cross(Y[F[:, 1]] - Y[F[:, 0]], Y[F[:, 2]] - Y[F[:, 0]])  # (M, 3)
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
    light = np.array([-0.4, -0.5, 0.77])
    shade = 0.45 + 0.55 * np.abs(n @ (light / np.linalg.norm(light)))  # (M,)
    colours = np.clip(rgb * shade[:, None], 0.0, 1.0)
    # Edges in the faces' own colour close the hairline gaps between neighbouring faces.
    ax.add_collection3d(Poly3DCollection(Y[F], facecolors=colours, edgecolors=colours,
                                         linewidths=0.15))
    lo, hi = Y.min(axis=0), Y.max(axis=0)
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_zlim(lo[2], hi[2])
    extent = hi - lo
    ax.set_box_aspect(np.maximum(extent, 0.05 * extent.max()), zoom=1.1)  # true proportions
    ax.view_init(elev=50, azim=-70)
    ax.set_axis_off()


def plot_checker(V, F, uv, path, *, squares: int | None = None, values=None,
                 value_label: str = "angle distortion (rad)", title: str | None = None) -> Path:
    """The surface ``(V, F)`` with a checkerboard in its texture coordinates ``uv``: each
    triangle coloured by the checker parity under its centroid
    (:func:`pcgeom.apps.texture.checker_parity`, the colours of the texture image), and beside
    it, when ``values`` are given, the surface coloured by them (e.g. the angle distortion).

    Squares that stay squares on the surface show a conformal map, parallelograms a shear,
    squares of changing size the map's scale (its ``lambda``), overlapping squares a fold.

    Parameters
    ----------
    V : (K, 3) array_like
    F : (M, 3) array_like of int
    uv : (K, 2) array_like
        Texture coordinates in ``[0, 1]`` (:meth:`pcgeom.apps.texture.UVScaling.apply` of
        the map).
    path : str or os.PathLike
        Output ``.png`` file, written atomically.
    squares : int, optional
        Squares along the longer side of the map (default
        :data:`pcgeom.apps.texture.CHECKER_SQUARES`).
    values : (M,) array_like, optional
        One value per triangle for the second panel (NaN: grey).
    value_label : str
        The colour bar's label of ``values``.
    title : str, optional
        Figure title.

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    ValueError
        Bad shapes or non-finite coordinates, ``values`` not (M,), or a path without the
        ``.png`` extension.
    """
    from .texture import CHECKER_COLOURS, CHECKER_SQUARES, checker_parity

    V = np.asarray(V, dtype=np.float64)
    if V.ndim != 2 or V.shape[1] != 3 or len(V) < 3 or not np.isfinite(V).all():
        raise ValueError(f"V: expected finite coordinates of shape (K, 3), K >= 3, got {V.shape}")
    F = np.asarray(F, dtype=np.int64)
    if F.ndim != 2 or F.shape[1] != 3 or len(F) == 0 or F.min() < 0 or F.max() >= len(V):
        raise ValueError(f"F: expected shape (M, 3) with indices below {len(V)}, got {F.shape}")
    uv = _check_map(uv)
    if len(uv) != len(V):
        raise ValueError(f"uv: expected {len(V)} rows (one per vertex), got {len(uv)}")
    squares = CHECKER_SQUARES if squares is None else int(squares)
    if values is not None:
        values = np.asarray(values, dtype=np.float64)
        if values.shape != (len(F),):
            raise ValueError(f"values: expected shape ({len(F)},), got {values.shape}")

    Y = _surface_frame(V, F)
    fig = _new_figure((11.0, 5.2) if values is not None else (6.0, 5.2))
    ax = fig.add_subplot(1, 2 if values is not None else 1, 1, projection="3d")
    palette = np.asarray(CHECKER_COLOURS, dtype=np.float64) / 255.0
    _draw_surface(ax, Y, F, palette[checker_parity(uv, F, squares)])
    ax.set_title(f"checkerboard in the map ({squares} squares a side)")
    if values is not None:
        from matplotlib import colormaps
        from matplotlib.cm import ScalarMappable
        from matplotlib.colors import Normalize

        ax2 = fig.add_subplot(1, 2, 2, projection="3d")
        finite = values[np.isfinite(values)]
        norm = Normalize(0.0, float(np.percentile(finite, 99)) if finite.size else 1.0)
        rgb = colormaps["viridis"](norm(np.nan_to_num(values, nan=0.0)))[:, :3]
        rgb[~np.isfinite(values)] = 0.6
        _draw_surface(ax2, Y, F, rgb)
        fig.colorbar(ScalarMappable(norm=norm, cmap="viridis"), ax=ax2, shrink=0.7,
                     label="clipped at the 99th percentile")
        ax2.set_title(value_label)
    if title:
        fig.suptitle(title)
    return _save_png_atomic(fig, path)
