"""A chart's scale-factor spread brought within a bound without a seam: a local/global map whose
triangles each aim at their own similarity with its scale clamped into a band.

A conformal map of a disk cut from a surface of high genus shrinks some parts far more than
others (a genus-4 pretzel cut along its shortest cut graph: LSCM's spread, the 95th over the
5th percentile of the per-triangle scale factor ``sqrt(uv area / 3D area)``, 20-30), although
the angles it keeps would allow an even texel density if a little of them were given up.
:func:`bound_scale` gives them up where that pays, by the local/global iteration of Liu et al.
("A local/global approach to mesh parameterization", SGP 2008) with a scale-clamped target:

1. **Local.** Each triangle's Jacobian ``J_t`` (from its 3D triangle laid flat to its image)
   has the nearest rotation ``R_t`` and the scale ``s_t = sqrt(det J_t)``; its target is
   ``L_t = clip(s_t, m / sqrt(T), m sqrt(T)) R_t``, ``m`` the geometric mean of the current 5th
   and 95th percentiles of ``s`` and ``T`` the band (:data:`BAND` times the bound). A triangle
   inside the band aims at its own similarity (no angle is lost); only the most shrunk and
   the most stretched are asked to change size.
2. **Global.** ``min_U sum_t A_t |J_t(U) - L_t|^2``: one Poisson system (the cotangent
   Laplacian, one vertex held), factored once (:func:`pcgeom.maps._sparse.spd_factor`), solved
   for the two coordinates every round.

The map may turn a few triangles over (where the chart's boundary pinches): they are unfolded
locally (:func:`pcgeom.maps.injective.untangle` on the triangles within :data:`RINGS` rings of
them, the rest held). The caller keeps the result only when it is within the bound and costs
little in angle (:data:`ANGLE_COST`): on a long limb, whose conformal factor falls
exponentially along it, a slit to its tip is the better answer.

Where the chart shrinks most (between corners of the cut graph), its free boundary may cross
itself in small lobes, under LSCM as under the bounded map. :func:`onto_outline` makes such a
map one-to-one without a seam: the barrier map onto the outline of the region the map covers,
the boundary sliding along it.

The plain iteration's error falls ever slower as the mesh is refined (the global step
spreads a change of the targets a few triangles per round), so after a fixed number of
rounds a fine mesh's map is further from the fixed point and costs more angle: the rounds
are Anderson-accelerated (:data:`ANDERSON`). Measured on the genus-4 pretzel, its one chart
cut along the short cut graph, bound 10, 30 rounds, mean ``|log(s1/s2)|`` over LSCM's:

=========  ============  ==================  ===================
points     LSCM spread   plain (spread)      accelerated (spread)
=========  ============  ==================  ===================
5k         26.3          1.00x (7.97)        0.91x (5.56)
20k        21.8          1.26x (7.51)        1.07x (5.56)
50k        28.8          1.47x (7.60)        1.08x (5.56)
=========  ============  ==================  ===================

(plain, 90 rounds: 0.92x, 1.06x, 1.18x.) On a small, evenly curved chart the plain rounds
have converged by 30 and the accelerated ones end a little off (the spherical cap of the
tests, 700 points, bound 3: 1.63x and 1.66x).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ..mesh import signed_areas

__all__ = ["bound_scale", "unfold_locally", "conformal_distortion", "BAND", "FOLDS", "ROUNDS",
           "RINGS", "ANGLE_COST", "ANDERSON", "onto_outline", "OUTLINE_STEPS",
           "covered_outline"]

BAND = 0.8
"""The band of target scale factors spans this fraction of the bound. Accelerated, the
spread settles well inside it (genus-4 pretzel 5k-50k: 5.56 for a band of 8); a band at
the bound (1.0) leaves its 20k chart's outline step failing: see :data:`ANGLE_COST`."""

ROUNDS = 30
"""Local/global rounds, Anderson-accelerated (:data:`ANDERSON`)."""

ANDERSON = 5
"""Rounds whose residuals Anderson's acceleration (Walker and Ni 2011; for local/global maps
Peng et al., "Anderson acceleration for geometry optimization and physics simulation",
SIGGRAPH 2018) combines into the next map, kept when it lowers the energy
``sum_t A_t |J_t - L_t|^2`` of the round before (else the plain global step, the history
dropped); 0: the plain rounds. Measured: the module's table."""

RINGS = 3
"""Rings of triangles around a folded one freed to unfold it."""

FOLDS = 0.005
"""A bounded map that turns over more than this share of its triangles is dropped before they
are unfolded (unfolding is the costly part: on the finger, 20k points, 10 of the 16 s the two
rejected tries took)."""

ANGLE_COST = 1.3
"""A bounded map (or one made one-to-one by :func:`onto_outline`) is kept when its mean
conformal distortion (:func:`conformal_distortion`) is at most this many times the conformal
map's (issue 38 allows 1.5x libigl's LSCM on the same seams, measured on the true triangles:
this leaves a margin for the difference). Genus-4 pretzel, its one chart: 5k, bounded 0.91x,
onto its outline 1.01x; 20k 1.07x and 1.18x; 50k bounded 1.08x, its boundary crossing itself
over 1.7e-3 of its area (more than :data:`pcgeom.maps.charts.PINCH`: split). With the band
at the bound (``BAND = 1``) the 50k chart's lobes cover 8.7e-4, but its barrier map onto
the outline took 122 s (one core, under load) and left a peeled rim triangle turned over,
and the 20k chart's failed too (split: seams 4.48 -> 5.15 sqrt(A)): not kept."""

OUTLINE_STEPS = 15
"""Steps of the barrier descent in :func:`onto_outline` (genus-4 pretzel 5k, one chart: 15
steps 3.4 s, 1.16x LSCM's conformal distortion; to convergence, 44 steps, 6.8 s, 1.14x)."""


def _frames(P: np.ndarray, F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per triangle, the inverse of its edge matrix laid flat (2, 2), and its area."""
    e1 = P[F[:, 1]] - P[F[:, 0]]
    e2 = P[F[:, 2]] - P[F[:, 0]]
    nrm = np.cross(e1, e2)
    area = 0.5 * np.linalg.norm(nrm, axis=1)
    x = e1 / np.maximum(np.linalg.norm(e1, axis=1), 1e-300)[:, None]
    y = np.cross(nrm / np.maximum(2.0 * area, 1e-300)[:, None], x)
    D = np.stack([np.c_[(e1 * x).sum(1), (e1 * y).sum(1)],
                  np.c_[(e2 * x).sum(1), (e2 * y).sum(1)]], axis=2)
    return np.linalg.inv(D), area


def _jacobians(U: np.ndarray, F: np.ndarray, Dinv: np.ndarray) -> np.ndarray:
    Ds = np.stack([U[F[:, 1]] - U[F[:, 0]], U[F[:, 2]] - U[F[:, 0]]], axis=2)
    return Ds @ Dinv


def conformal_distortion(P: np.ndarray, U: np.ndarray, F: np.ndarray) -> float:
    """The area-weighted mean of ``|log(s1 / s2)|`` over the triangles of the map ``U`` of
    ``(P, F)`` (``s1 >= s2`` the singular values of each Jacobian): 0 for a conformal map."""
    Dinv, area = _frames(P, F)
    s = np.linalg.svd(_jacobians(U, F, Dinv), compute_uv=False)
    d = np.abs(np.log(np.maximum(s[:, 0], 1e-300) / np.maximum(s[:, 1], 1e-300)))
    return float((d * area).sum() / max(float(area.sum()), 1e-300))


def _gradient(F: np.ndarray, Dinv: np.ndarray, n: int) -> sp.csr_matrix:
    """(2m, n): row ``2t + k`` gives the ``k``-th component of the gradient of a function
    on triangle ``t`` (its 2D frame)."""
    m = len(F)
    rows, cols, vals = [], [], []
    for k in range(2):
        r = 2 * np.arange(m) + k
        c1, c2 = Dinv[:, 0, k], Dinv[:, 1, k]
        rows += [r, r, r]
        cols += [F[:, 0], F[:, 1], F[:, 2]]
        vals += [-(c1 + c2), c1, c2]
    return sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                         shape=(2 * m, n))


def unfold_locally(P: np.ndarray, F: np.ndarray, U: np.ndarray) -> np.ndarray:
    """``U`` with its folded triangles unfolded by :func:`untangle` on the triangles within
    :data:`RINGS` rings of them, the vertices around held."""
    from .injective import untangle

    bad = signed_areas(U, F) <= 0
    if not bad.any():
        return U
    free = np.zeros(len(P), dtype=bool)
    free[F[bad].ravel()] = True
    for _ in range(RINGS):
        free[F[free[F].any(axis=1)].ravel()] = True
    rows = np.flatnonzero(free[F].any(axis=1))
    used, Fs = np.unique(F[rows], return_inverse=True)
    Fs = Fs.reshape(-1, 3)
    held = np.flatnonzero(~free[used])
    W, _ = untangle(P[used], Fs, U[used], held)
    out = U.copy()
    out[used] = W
    return out


def bound_scale(P: np.ndarray, F: np.ndarray, U0: np.ndarray, bound: float, *,
                rounds: int = ROUNDS, unfold: bool = True) -> np.ndarray:
    """The map ``U0`` of the disk ``(P, F)`` moved towards a scale-factor spread within
    ``BAND * bound`` (steps 1-2 of the module), folds unfolded locally (``unfold``; else
    left for the caller, :func:`unfold_locally`); the caller checks the result (flips,
    spread, angle, boundary)."""
    from ._sparse import spd_factor

    Dinv, area = _frames(P, F)
    n = len(P)
    G = _gradient(F, Dinv, n)
    W = sp.diags(np.repeat(area, 2))
    GtW = (G.T @ W).tocsr()
    L = (GtW @ G).tocsc()
    solve = spd_factor(L[1:, 1:])
    link = L[1:, 0].toarray().ravel()
    half = np.sqrt(BAND * float(bound))

    def local(U: np.ndarray) -> tuple[np.ndarray, float]:
        """The targets ``L_t`` of the map ``U`` (step 1) and its energy against them."""
        J = _jacobians(U, F, Dinv)
        A, S, Bt = np.linalg.svd(J)
        turn = np.linalg.det(A @ Bt) < 0
        A[turn, :, 1] *= -1.0  # the nearest rotation, never a mirror
        R = A @ Bt
        s = np.sqrt(S[:, 0] * S[:, 1])
        lo, hi = np.percentile(s, [5, 95])
        mid = np.sqrt(lo * hi)
        T = np.clip(s, mid / half, mid * half)[:, None, None] * R
        return T, float((area * ((J - T) ** 2).sum(axis=(1, 2))).sum())

    def step(T: np.ndarray, U: np.ndarray) -> np.ndarray:
        """The global step (2) towards the targets ``T``."""
        b = GtW @ np.column_stack([T[:, 0, :].ravel(), T[:, 1, :].ravel()])
        out = U.copy()
        out[1:] = solve(b[1:] - np.outer(link, U[0]))
        return out

    U = np.asarray(U0, dtype=np.float64).copy()
    T, energy = local(U)
    xs: list[np.ndarray] = []
    gs: list[np.ndarray] = []
    for _ in range(rounds):
        G1 = step(T, U)
        xs, gs = (xs + [U.ravel()])[-ANDERSON - 1:], (gs + [G1.ravel()])[-ANDERSON - 1:]
        if len(xs) > 1:  # Anderson's extrapolation from the last rounds' residuals
            res = np.array(gs) - np.array(xs)
            gamma = np.linalg.lstsq(np.diff(res, axis=0).T, res[-1], rcond=None)[0]
            X = (gs[-1] - np.diff(np.array(gs), axis=0).T @ gamma).reshape(U.shape)
            TX, eX = local(X)
            if eX < energy:
                U, T, energy = X, TX, eX
                continue
            xs, gs = [], []  # it did not lower the energy: the plain step, history dropped
        U = G1
        T, energy = local(U)
    return unfold_locally(P, F, U) if unfold else U


def onto_outline(P: np.ndarray, F: np.ndarray, U0: np.ndarray, *, steps: int = OUTLINE_STEPS
                 ) -> np.ndarray | None:
    """A map of the disk ``(P, F)`` whose boundary ``U0`` crosses itself, made one-to-one: the
    barrier map (:func:`pcgeom.maps.injective.injective_map`, ``steps`` steps of its descent)
    onto the outer outline of the region ``U0``'s triangles cover (shapely's union: a simple
    polygon), its boundary sliding along that outline from where ``U0`` has it. The lobes
    that cross are pulled inside; the rest keeps ``U0``'s shape and so its scale. None when
    the barrier map fails or folds."""
    from ..config import BarrierConfig, InjectiveConfig
    from ..mesh import boundary_loops, shoelace
    from .injective import injective_map

    loop = np.asarray(boundary_loops(F)[0])
    if shoelace(U0[loop]) < 0:
        loop = loop[::-1]
    ring = covered_outline(U0, F, largest=True)
    config = InjectiveConfig(barrier=BarrierConfig(iterations=steps))
    try:  # the boundary at its nearest points on the outline, when they are in order
        U, info = injective_map(P, F, U0, [loop], [ring], config=config)
    except ValueError:
        loop, start = _on_ring(U0, loop, ring)
        try:
            U, info = injective_map(P, F, start, [loop], [ring], config=config)
        except ValueError:
            return None
    return U if info.get("flipped_all", 1) == 0 and not (signed_areas(U, F) <= 0).any() else None


def covered_outline(U: np.ndarray, F: np.ndarray, *, largest: bool = False
                    ) -> np.ndarray | None:
    """The outer outline of the region the triangles ``U[F]`` cover (shapely's union of
    them): (k + 1, 2), closed (its first point again last), counter-clockwise. The outline a
    barrier map slides a crossing boundary onto (:func:`onto_outline`,
    :func:`pcgeom.maps.chart_lobes.unfold_lobes`). Where the region falls in several parts:
    the largest one's outline (``largest``), else None."""
    import shapely

    from ..mesh import shoelace

    region = shapely.unary_union(shapely.polygons(np.concatenate([U[F], U[F][:, :1]], axis=1)))
    if region.geom_type != "Polygon":
        if not largest:
            return None
        region = max(region.geoms, key=lambda g: g.area)
    ring = np.asarray(region.exterior.coords)
    return ring[::-1] if shoelace(ring[:-1]) < 0 else ring


def _on_ring(U: np.ndarray, loop: np.ndarray, ring: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``loop`` (rolled to start at its vertex nearest ``ring``) and ``U`` with the loop's
    vertices moved onto ``ring`` in order: each at the arc length of its nearest ring point,
    made non-decreasing along the loop (a vertex whose nearest point lies behind its
    predecessor's, inside a lobe the outline cut off, is spread evenly with the others of its
    run up to the next one in order)."""
    import shapely

    line = shapely.LineString(ring)
    L = float(line.length)
    loop = np.roll(loop, -int(np.argmin(shapely.distance(line, shapely.points(U[loop])))))
    t = np.asarray(shapely.line_locate_point(line, shapely.points(U[loop])), dtype=np.float64)
    offset = float(t[0])
    t = np.r_[(t - offset) % L, L]
    t[0] = 0.0
    t = np.maximum.accumulate(t)
    k = len(loop)
    i = 0
    while i < k:
        j = i + 1
        while j < k and t[j] <= t[i]:
            j += 1
        t[i:j] = t[i] + (t[j] - t[i]) * np.arange(j - i) / (j - i)
        i = j
    out = U.copy()
    out[loop] = shapely.get_coordinates(shapely.line_interpolate_point(line, (t[:k] + offset) % L))
    return loop, out
