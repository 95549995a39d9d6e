"""Built-in analytic test surfaces: the paper's three-peaks and five-peaks height fields."""

from __future__ import annotations

import numpy as np

__all__ = ["EXAMPLES", "peaks_surface", "load_example"]

# (amplitude, centre x, centre y, width) of each Gaussian bump on [-1, 1]^2.
_BUMPS = {
    "peaks3": [(0.55, -0.45, -0.35, 0.28), (0.45, 0.45, -0.25, 0.25), (0.5, 0.0, 0.45, 0.3)],
    "peaks5": [
        (0.5, -0.5, -0.5, 0.25),
        (0.4, 0.5, -0.5, 0.22),
        (0.45, -0.5, 0.5, 0.24),
        (0.4, 0.5, 0.5, 0.22),
        (0.5, 0.0, 0.0, 0.26),
    ],
}
EXAMPLES = tuple(_BUMPS)


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
    if name not in _BUMPS:
        raise ValueError(f"unknown example {name!r}; choose one of: {', '.join(EXAMPLES)}")
    t = np.linspace(-1.0, 1.0, n_side)
    x, y = np.meshgrid(t, t, indexing="xy")
    z = np.zeros_like(x)
    for a, cx, cy, w in _BUMPS[name]:
        z += a * np.exp(-((x - cx) ** 2 + (y - cy) ** 2) / w**2)
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
