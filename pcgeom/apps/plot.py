"""Figures: a 2D map coloured by a per-point value, a parameter domain, per-stage loss curves,
angle histograms.

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
from ..train.objective import LOSS_TERMS

__all__ = ["plot_map", "plot_domain", "plot_history", "plot_angle_histogram"]


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
    fig = _new_figure((6.0, 5.4))
    ax = fig.add_subplot()
    size = float(np.clip(8000.0 / len(S), 0.5, 8.0))
    ax.scatter(S[:, 0], S[:, 1], s=size, c="tab:blue", alpha=0.35, linewidths=0)
    _draw_loops(ax, domain)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("u")
    ax.set_ylabel("v")
    ax.set_title(title if title is not None else
                 f"{_short_spec(domain)}: area {domain.area:.4g}, "
                 f"{len(domain.boundary_loops())} boundary loop(s)")
    return _save_png_atomic(fig, path)


def _short_spec(domain, limit: int = 40) -> str:
    """The domain's spec, or its name when the spec is long (a polygon's coordinates)."""
    return domain.spec if len(domain.spec) <= limit else domain.name


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


def plot_angle_histogram(per_corner, path, bins: int = 60, title: str | None = None) -> Path:
    """Histogram of per-corner absolute angle distortion, with its mean marked.

    Parameters
    ----------
    per_corner : (M, 3) or (K,) array_like
        Absolute angle differences in radians, e.g. ``AngleReport.per_corner`` from
        :func:`pcgeom.metrics.angle_distortion`.
    path : str or os.PathLike
        Output ``.png`` file, written atomically.
    bins : int
        Number of histogram bins.
    title : str, optional
        Axes title.

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    ValueError
        No values, non-finite values, ``bins < 1``, or a path without the ``.png`` extension.
    """
    d = np.asarray(per_corner, dtype=np.float64).ravel()
    if d.size == 0:
        raise ValueError("per_corner: expected at least one value, got none")
    if not np.isfinite(d).all():
        raise ValueError("per_corner: contains NaN or inf")
    if isinstance(bins, bool) or not isinstance(bins, (int, np.integer)) or bins < 1:
        raise ValueError(f"bins: expected a positive int, got {bins!r}")

    fig = _new_figure((6.4, 4.2))
    ax = fig.add_subplot()
    ax.hist(d, bins=int(bins), color="tab:blue", alpha=0.85)
    mean = float(d.mean())
    ax.axvline(mean, color="red", linewidth=1.2, label=f"mean {mean:.4f} rad")
    ax.set_xlabel("|angle in 3D - angle in map| (rad)")
    ax.set_ylabel("triangle corners")
    ax.legend()
    if title:
        ax.set_title(title)
    return _save_png_atomic(fig, path)
