"""Built-in analytic test surfaces: the paper's three-peaks and five-peaks height fields, and
the one table of Gaussian bumps every height field of pcgeom and its benchmarks is made of."""

from __future__ import annotations

import math

import numpy as np

__all__ = ["EXAMPLES", "BUMPS", "bump_height", "peaks_surface", "load_example"]

BUMPS = {
    "peaks3": ((0.55, -0.45, -0.35, 0.28), (0.45, 0.45, -0.25, 0.25), (0.5, 0.0, 0.45, 0.3)),
    "peaks5": (
        (0.5, -0.5, -0.5, 0.25),
        (0.4, 0.5, -0.5, 0.22),
        (0.45, -0.5, 0.5, 0.24),
        (0.4, 0.5, 0.5, 0.22),
        (0.5, 0.0, 0.0, 0.26),
    ),
    # pcgeom.synthetic.holey_heightfield's surface.
    "holey": (
        (0.45, -0.45, -0.35, 0.35),
        (0.35, 0.45, -0.30, 0.30),
        (0.40, 0.05, 0.45, 0.40),
        (-0.20, -0.55, 0.55, 0.30),
    ),
    # benchmarks/bench_scans.py's time-against-N rows (w^2 = 0.1 exactly).
    "scale": tuple((a, cx, cy, math.sqrt(0.1)) for a, cx, cy in (
        (0.5, -0.4, -0.3), (0.7, 0.3, 0.4), (0.4, 0.5, -0.5), (-0.3, -0.5, 0.5),
        (0.35, 0.0, 0.0))),
}
"""``(amplitude a, centre x, centre y, width w)`` of each Gaussian bump of the height fields
``z = sum_k a_k exp(-|p - c_k|^2 / w_k^2)`` over ``[-1, 1]^2``, by name: the examples
(``peaks3``, ``peaks5``), :func:`pcgeom.synthetic.holey_heightfield`'s (``holey``) and the
scale benchmark's (``scale``)."""
EXAMPLES = ("peaks3", "peaks5")


def bump_height(x, y, bumps) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The height field of ``bumps`` (rows of :data:`BUMPS`) at ``(x, y)`` (arrays of one
    shape) and its two partial derivatives, each of that shape:
    ``z = sum_k a_k g_k`` with ``g_k = exp(-((x - cx_k)^2 + (y - cy_k)^2) / w_k^2)``,
    ``z_x = sum_k -2 a_k g_k (x - cx_k) / w_k^2`` (and ``z_y`` alike)."""
    x, y = np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)
    z, zx, zy = np.zeros_like(x), np.zeros_like(x), np.zeros_like(x)
    for a, cx, cy, w in bumps:
        dx, dy = x - cx, y - cy
        g = a * np.exp(-(dx**2 + dy**2) / w**2)
        z += g
        zx += (-2.0 / w**2) * g * dx
        zy += (-2.0 / w**2) * g * dy
    return z, zx, zy


def peaks_surface(name: str = "peaks3", n_side: int = 76) -> tuple[np.ndarray, np.ndarray]:
    """A height field ``z = sum_k a_k exp(-|p - c_k|^2 / w_k^2)`` on a grid of ``[-1, 1]^2``.

    Parameters
    ----------
    name : {"peaks3", "peaks5"}
    n_side : int
        Grid points per side; 76 gives 5776 points, about the paper's 5809.

    Returns
    -------
    V : (n_side**2, 3) float64
        Points (row-major grid order).
    F : (2 (n_side-1)**2, 3) int64
        Reference triangulation, used only to evaluate distortion.
    """
    if name not in EXAMPLES:
        raise ValueError(f"unknown example {name!r}; choose one of: {', '.join(EXAMPLES)}")
    t = np.linspace(-1.0, 1.0, n_side)
    x, y = np.meshgrid(t, t, indexing="xy")
    z = bump_height(x, y, BUMPS[name])[0]
    V = np.column_stack([x.ravel(), y.ravel(), z.ravel()])
    idx = np.arange(n_side * n_side).reshape(n_side, n_side)
    a, b = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel()
    c, d = idx[1:, :-1].ravel(), idx[1:, 1:].ravel()
    # Alternate the diagonal so the mesh has no preferred direction.
    F = np.concatenate([np.column_stack([a, b, d]), np.column_stack([a, d, c])]).astype(np.int64)
    return V, F


def load_example(name: str) -> tuple[np.ndarray, np.ndarray]:
    """Points and reference faces of a built-in example by name (see :data:`EXAMPLES`)."""
    return peaks_surface(name)
