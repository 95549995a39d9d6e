"""The figure of a cut map (``--cut auto``): the atlas in the unit square with its charts
coloured and the seams red, beside the surface with the same colours and the seams drawn on
it (``pcgeom param --cut auto --plot``, ``pcgeom evaluate --plot`` of a cut map)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from ..mesh import half_edges

__all__ = ["plot_atlas", "cut_mesh", "seam_edges"]


def cut_mesh(mesh_faces, corner_uv) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The atlas as a mesh: its vertices (one per point and atlas position) as ``origin``
    (K,) point rows and ``uv`` (K, 2), its triangles ``Fc`` (M, 3), and each triangle's chart
    ``chart`` (M,) (the connected parts of the atlas, largest first)."""
    F = np.asarray(mesh_faces, dtype=np.int64)
    C = np.asarray(corner_uv, dtype=np.float64).reshape(-1, 2)
    keys, inverse = np.unique(np.column_stack([F.reshape(-1, 1).astype(np.float64), C]),
                              axis=0, return_inverse=True)
    Fc = inverse.reshape(-1, 3)
    k = len(keys)
    A = sp.coo_matrix((np.ones(2 * len(Fc)), (np.r_[Fc[:, 0], Fc[:, 1]],
                                               np.r_[Fc[:, 1], Fc[:, 2]])), shape=(k, k))
    _, label = connected_components(A, directed=False)
    face_label = label[Fc[:, 0]]
    order = np.argsort(-np.bincount(face_label))
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    return keys[:, 0].astype(np.int64), keys[:, 1:], Fc, rank[face_label]


def seam_edges(mesh_faces, Fc, origin) -> np.ndarray:
    """The atlas's boundary edges that are seams (not the surface's own rim), as pairs of
    atlas vertices (S, 2)."""
    F = np.asarray(mesh_faces, dtype=np.int64)
    he = half_edges(Fc)
    n = int(origin.max()) + 1

    def unpaired(E, m):
        key = np.minimum(E[:, 0], E[:, 1]) * m + np.maximum(E[:, 0], E[:, 1])
        _, inv, counts = np.unique(key, return_inverse=True, return_counts=True)
        return counts[inv] == 1

    open_c = unpaired(he, int(Fc.max()) + 1)
    rim = unpaired(half_edges(F), n)  # same row order: corner for corner
    return he[open_c & ~rim]


def plot_atlas(P, mesh_faces, corner_uv, path, *, title: str | None = None) -> Path:
    """A PNG of the atlas (charts coloured, seams red, the unit square black) beside the
    surface ``P[mesh_faces]`` in the same colours, seams red on it."""
    from matplotlib import colormaps
    from matplotlib.collections import LineCollection, PolyCollection
    from mpl_toolkits.mplot3d.art3d import Line3DCollection

    from .plot import _draw_surface, _new_figure, _save_png_atomic, _surface_frame

    P = np.asarray(P, dtype=np.float64)
    F = np.asarray(mesh_faces, dtype=np.int64)
    origin, U, Fc, chart = cut_mesh(F, corner_uv)
    seams = seam_edges(F, Fc, origin)
    rgb = np.asarray(colormaps["tab20"](chart % 20))[:, :3]
    fig = _new_figure((12, 5.6))
    ax = fig.add_subplot(1, 2, 1)
    ax.add_collection(PolyCollection(U[Fc], facecolors=rgb, edgecolors="none"))
    ax.add_collection(LineCollection(U[seams], colors="crimson", linewidths=0.8))
    ax.plot([0, 1, 1, 0, 0], [0, 0, 1, 1, 0], color="k", lw=0.8)
    ax.set_xlim(-0.02, 1.02)
    ax.set_ylim(-0.02, 1.02)
    ax.set_aspect("equal")
    ax.set_title(f"atlas: {chart.max() + 1} chart(s), seams red")
    ax3 = fig.add_subplot(1, 2, 2, projection="3d")
    ax3.computed_zorder = False  # the seams over the surface (those behind it too)
    Y = _surface_frame(P, F)
    _draw_surface(ax3, Y, F, rgb)
    ax3.add_collection3d(Line3DCollection(Y[origin[seams]], colors="crimson", linewidths=1.0,
                                           zorder=5))
    ax3.set_title("the surface: charts coloured, seams red")
    if title:
        fig.suptitle(title)
    return _save_png_atomic(fig, path)
