"""Maps of a triangle mesh onto a planar domain that never fold.

A map ``U`` of a mesh ``(V, F)`` onto a domain is a bijection when every triangle keeps its
orientation (positive signed area: the faces counter-clockwise) and each boundary loop of the
mesh runs once, in order, around the domain ring it is paired with (outer ring
counter-clockwise, holes clockwise): the degree of the map is then 1 inside the domain and 0
outside, so every point of the domain is covered by exactly one triangle.
:func:`injective_map` gets there from a start that may fold, such as
:func:`pcgeom.maps.domain.harmonic_onto`'s harmonic map, whose loops are laid on their rings:

1. **Clean** the mesh of what no flip-free planar map can hold (triangles are dropped, never
   points: a dropped triangle's vertices are mapped all the same): two fans meeting at a vertex
   (:func:`pcgeom.mesh.one_fan`), rim slivers (:func:`pcgeom.mesh.peel_rim`), handles (:func:`_cut_handles`). The
   local mesh of a bare cloud has all three: face_3holes_small_choi 43 vertices with two
   fans; face_human_choi with a hole, 10 handles where the estimated normals join the
   eyelids' or lips' sheets.
2. **Scaffold.** Each hole of the mesh paired with no ring is filled by a fan to a virtual
   vertex: with it every loop is bounded by triangles or a ring, so a free hole cannot fold
   over the rest of the map either (its fan must stay positive too).
3. **Untangle** (:func:`untangle`; Garanzha, Kaporin, Kudryavtseva, Protais, Ray, Sokolov,
   "Foldover-free maps in 50 lines of code", SIGGRAPH 2021). With the paired loops held on
   their rings, minimize over the other vertices

   ``E_eps(U) = sum_t A_t [(1 - theta) tr(J_t^T J_t) + theta (det(J_t)^2 + 1)] / chi(det J_t, eps)``

   with ``chi(D, eps) = (D + sqrt(eps^2 + D^2)) / 2``, a positive stand-in for ``det J``
   (``-> D`` as ``eps -> 0`` where ``D > 0``, ``eps^2 / (4 |D|)`` where ``D < 0``). ``J_t`` is
   the Jacobian from the triangle's reference shape (its 3D triangle laid flat, scaled so
   that the reference areas sum to the map's area) to its image, ``A_t`` the reference area.
   ``E_eps`` is smooth for ``eps > 0``; projected Newton (or the paper's L-BFGS) minimizes it,
   then ``eps`` decreases by the paper's rule until no triangle has ``det J <= 0``. A loop
   vertex no flip-free map can hold on its ring (a hole's ear: three consecutive vertices on
   a ring that bends away from the triangle) moves freely (:func:`_release`). When that does
   not unfold everything, the start is Tutte's embedding (:func:`tutte_fill`, flip-free by
   Tutte's theorem) with the loops pulled onto their rings under the barrier of step 4.
4. **Barrier.** From the flip-free map, lower the angle distortion with an energy that is
   infinite at zero area, ``sum_t A_t e(J_t)`` with ``s1 >= s2`` the singular values of
   ``J_t`` and ``K = s1/s2 + s2/s1 = tr(J^T J) / det J``:

   - ``"mips"`` (conformal AMIPS/MIPS): ``e = K``; 2 exactly for a similarity, its minimum;
   - ``"root_mips"`` (default): ``e = (K - 2 + delta^2)^p + b (K - 2)``, ``p = 1/2``,
     ``b = 0.1``: about ``|log(s1/s2)|``, the measure of the angles, for moderate
     distortion, still infinite at zero area;
   - ``"symmetric_dirichlet"``: ``e = s1^2 + s2^2 + s1^-2 + s2^-2``; 4 for an isometry.

   The vertices of the paired loops slide along their rings (each by its arc length, on a
   smooth curve through the ring's points, one-sided at its corners; a vertex is pinned on
   each corner: :class:`_Rings`), the others move freely. Projected Newton picks a direction
   (Teran et al. 2005: each triangle's Hessian with its negative eigenvalues cut); the step
   never crosses a zero area: per triangle ``det J(x + a d)`` is a quadratic in ``a``
   (Smith and Schaefer, "Bijective parameterization with free boundaries", SIGGRAPH 2015),
   the step starts below its smallest positive root over all triangles
   (:func:`max_feasible_step`) and backtracks until the energy decreases (Armijo), every
   triangle is positive and every loop is still in order along its ring. A term for the area
   of the domain the loops' polygons leave uncovered keeps the loop vertices from bunching
   (the energy is blind to where they sit on the ring). Every iterate, not only the last, is a
   bijection onto the region bounded by the loops' polygons inscribed in their rings.

Every iterate of step 4 is flip-free; the guarantee covers the cleaned mesh, whose loop
vertices are on their rings except the released ones (kept near the domain by a penalty,
not a barrier).

Measured (2 CPU cores, one thread), judged on the true triangles of the files, the mapped
surface's distance to the domain by :func:`pcgeom.metrics.surface_hausdorff`; the start (the
free map and :func:`pcgeom.maps.domain.harmonic_onto`) takes 2.7 s more:

=============================================  ========  =======  =======  ======
face_3holes_small_choi (5053 points, bare)     angle     flipped  surface  time
onto ``smile``
=============================================  ========  =======  =======  ======
harmonic start                                 0.296     4.35%    0.109
untangled (step 3 only)                        0.323     0.041%   0.018    3.6 s
``"root_mips"`` (default)                      0.054     0.031%   0.025    16 s
``"mips"``                                     0.152     0.010%   0.027    11 s
``"symmetric_dirichlet"``                      0.278     0.041%   0.026    6 s
=============================================  ========  =======  =======  ======

The local mesh itself never folds; the true triangles that do are the other diagonal of a
local-mesh quad the distortion made non-convex (``BarrierConfig.flip_guard`` keeps every
quad convex, at twice the time). face_human_choi with a hole cut around its nose (16k
points) onto ``annulus:0.3``, with the mesh's normals: harmonic 0.255 rad, 8.1%; this map
0.044 rad, 0.125% (flips where cleaning dropped triangles), 0.079 from the domain, 87 s.
The same bare cloud (10 handles in its local mesh) is not mapped: untangling leaves folds,
the pulled Tutte start leaves 129 loop vertices off their rings, 3.9% of the true triangles
fold, 250 s.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass, field

import numpy as np

from ..mesh import (RIM_ANGLE_DEG, boundary_loops, half_edges, main_faces, one_fan,
                    opposite_corners, peel_rim, shoelace, signed_areas, unique_edges)

__all__ = ["flipped", "signed_areas", "reference_triangles", "conformal_energy",
           "max_feasible_step", "untangle", "tutte_fill", "injective_map", "InjectiveConfig",
           "UntangleConfig", "PullConfig", "BarrierConfig", "ENERGIES", "STARTS"]

ENERGIES = ("mips", "root_mips", "symmetric_dirichlet")
"""Barrier energies of step 4 (see the module)."""

STARTS = ("auto", "untangle", "pull")
"""Flip-free starts of step 3: ``"untangle"``, ``"pull"`` (Tutte's embedding, the loops pulled
onto their rings), ``"auto"``: untangle, and pull when that leaves a fold."""

_ROOT_DELTA = 0.05
"""``delta`` of ``"root_mips"``: smooth where the map is a similarity (``K = 2``)."""


@dataclass(frozen=True)
class UntangleConfig:
    """Step 3 (:func:`untangle`): Garanzha et al. 2021."""

    theta: float = 1.0 / 128
    """Weight of the area term ``(det^2 + 1) / chi`` against the shape term ``tr / chi``
    (the paper's theta)."""
    method: str = "newton"
    """``"newton"``: projected Newton for each value of eps (``newton_steps`` at most);
    ``"lbfgs"``: scipy's ``L-BFGS-B`` (``inner`` iterations at most), as the paper."""
    newton_steps: int = 5
    """Projected Newton steps per value of eps."""
    inner: int = 200
    """L-BFGS iterations per value of eps (``method="lbfgs"``)."""
    rounds: int = 40
    """At most this many values of eps (with ``decrease`` 0.5, eps is at its floor, 1e-10,
    long before)."""
    decrease: float = 0.5
    """Least relative decrease of ``chi(min det, eps)`` from one value of eps to the next
    (the paper: 0.1). face_3holes_small_choi onto the smile from the harmonic map: 51 values
    and 28 s with 0.1 and L-BFGS, 10 values and 2.3 s with 0.5 and Newton."""
    tolerance: float = 1e-6
    """With ``stop_when_unfolded`` False: stop once nothing is folded and the energy changed
    by less than this fraction."""
    stop_when_unfolded: bool = True
    """Stop at the first value of eps that leaves nothing folded (step 4 lowers the
    distortion)."""
    local: int = 0
    """0: every vertex off the held loops moves. ``k > 0``: a start with few folds (the
    conformal map of :mod:`pcgeom.maps.riemann`) is mended where it folds: only the vertices
    within ``k`` edges of a folded triangle move, the rest of the map is kept; when that
    leaves a fold, every vertex moves."""


@dataclass(frozen=True)
class PullConfig:
    """The ``"pull"`` start: from Tutte's embedding, the paired loops pulled onto their rings
    by ``w mean_i |u_i - q_i|^2 / A`` under the barrier, ``w`` growing."""

    weight: float = 1.0
    """First ``w``, against the barrier energy per area."""
    growth: float = 10.0
    """``w`` is multiplied by this after each stage."""
    stages: int = 12
    """At most this many values of ``w``."""
    iterations: int = 60
    """Steps per stage."""
    tolerance: float = 1e-4
    """Done when every pulled vertex is this close to its place, relative to the square root
    of the map's area."""


@dataclass(frozen=True)
class BarrierConfig:
    """Step 4: a barrier energy under the feasible line search."""

    energy: str = "root_mips"
    """One of :data:`ENERGIES`."""
    power: float = 0.5
    """``p`` of ``"root_mips"``. face_3holes_small_choi onto the smile (150 steps, ``b =
    0``): 0.5: 0.049 rad, 0.092% of the true triangles flipped; 0.6: 0.055, 0.072%; 0.75:
    0.086, 0.031%."""
    blend: float = 0.1
    """``b`` of ``"root_mips"``: some MIPS, so that the distortion does not gather in a few
    triangles (300 steps, ``p = 1/2``: 0: 0.048 rad, 0.092%; 0.07: 0.052, 0.062%; 0.1: 0.053,
    0.031%)."""
    method: str = "newton"
    """``"newton"``: projected Newton (one sparse solve a step); ``"lbfgs"``: L-BFGS with
    ``memory`` pairs (ten times the steps on the smile)."""
    iterations: int = 200
    """At most this many steps."""
    tolerance: float = 1e-5
    """Stop when the energy fell by less than this fraction over ``patience`` steps."""
    patience: int = 5
    """Steps over which ``tolerance`` is judged."""
    memory: int = 10
    """Pairs ``(s, y)`` L-BFGS keeps."""
    refactor: int = 1
    """Newton: the Hessian is assembled and factored every this many steps, the steps in
    between reuse the last factor (a descent direction all the same)."""
    max_fraction: float = 0.9
    """The first trial step is at most this fraction of :func:`max_feasible_step`."""
    slide: bool = True
    """The paired loops slide along their rings (False: they stay where step 3 left them)."""
    cover: float = 1.0
    """Weight ``mu`` of the uncovered area, ``mu sum_k (|R_k| - |S_k|) / A`` (``R_k``: the
    signed area of ring ``k``, ``S_k``: that of its loop's polygon, ``A``: the map's). Without
    it the loop vertices bunch and long chords cut across holes (the smile's mouth: the loop
    polygon covered 0.118 of the ring's 0.393; the surface 0.25 from the domain); too strong,
    it drags the rim's triangles along the rings. face_3holes_small_choi onto the smile
    (angle, flipped true triangles, surface to domain): 10: 0.054 rad, 0.031%, 0.025; 3:
    0.050, 0.010%, 0.022; 2: 0.0496, 0.010%, 0.027; 1: 0.048, 0.021%, 0.028. The same face
    Loop-subdivided (19.9k points): 10: 0.0259, 5 flips, 0.0035; 2: 0.0252, 1, 0.0044; 1:
    0.0241, 1, 0.0084."""
    landmarks: float = 1000.0
    """Weight ``w`` of the landmark term ``w mean |u - q|^2 / A`` (``A`` the map's area) over
    pairs of landmark points ``u`` and targets ``q``, renewed ``landmark_rounds`` times
    (:func:`_landmark_pairs`): along target curves sampled evenly (a landmark file's
    polylines), each piece of landmark points spread along its curve by arc length; other
    targets paired with the nearest landmark point both ways (a Chamfer distance). The car
    with its window edges (2500 points, from the conformal map onto the car; landmark
    Hausdorff): nearest-target pairs, 100: 0.036, 1000: 0.012 from the layout, 1e4: 0.023
    from the conformal map (the ends of the edges 0.023 short of the lines' ends whatever the
    weight); by arc length, 1000: 0.014, 1e4: 0.011."""
    landmark_rounds: int = 5
    """Rounds of the descent, each with the landmark pairs renewed from the map so far (the
    steps are shared among them)."""
    flip_guard: float = 0.0
    """Weight of the triangles of every interior edge's other diagonal, taken as barriers
    too (0: none): every quad of two triangles stays convex, so a mesh of the same points
    that differs by edge flips (the true mesh of a scan) does not fold either. Twice the
    time; on the smile 0.01: 0.052 rad, 0.041% (150 steps)."""


@dataclass(frozen=True)
class InjectiveConfig:
    """:func:`injective_map`'s settings."""

    start: str = "auto"
    """One of :data:`STARTS`."""
    rim_angle: float = RIM_ANGLE_DEG
    """Rim triangles whose 3D angle opposite their boundary edge is wider than this,
    degrees, are dropped, their third vertex joining the rim (:func:`pcgeom.mesh.peel_rim`); 180: none."""
    corner_angle: float = 20.0
    """A ring turning by more than this at a point, degrees, has a corner there, and the
    nearest loop vertex is pinned to it (the smile's eyes and mouth turn by 90; its arcs by
    0.7 at each point)."""
    scaffold: float = 1.0
    """Weight of the fans that fill the holes paired with no ring (step 2), against the
    mesh's own triangles. face_human_choi with a hole, onto ``annulus:0.3`` (its local mesh
    has 47 small holes where eyelids and lips close): 0.01 lets them open wide, 0.048 rad;
    1: 0.044 rad."""
    untangle: UntangleConfig = field(default_factory=UntangleConfig)
    pull: PullConfig = field(default_factory=PullConfig)
    barrier: BarrierConfig = field(default_factory=BarrierConfig)


# --------------------------------------------------------------------------- geometry


def _as_mesh(V, F, U=None) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Validated ``V (n, 2|3)``, ``F (m, 3)`` and ``U (n, 2)``."""
    V = np.asarray(V, dtype=np.float64)
    if V.ndim != 2 or V.shape[1] not in (2, 3):
        raise ValueError(f"V: expected shape (n, 3) or (n, 2), got {V.shape}")
    F = np.asarray(F)
    if F.ndim != 2 or F.shape[1] != 3 or len(F) == 0:
        raise ValueError(f"F: expected shape (m, 3) with m >= 1, got {F.shape}")
    if not np.issubdtype(F.dtype, np.integer):
        raise TypeError(f"F: expected integer indices, got dtype {F.dtype}")
    F = F.astype(np.int64)
    if F.min() < 0 or F.max() >= len(V):
        raise ValueError(f"F: indices must lie in [0, {len(V)}), got [{F.min()}, {F.max()}]")
    if not np.isfinite(V).all():
        raise ValueError("V: contains NaN or inf")
    if U is not None:
        U = np.asarray(U, dtype=np.float64)
        if U.shape != (len(V), 2):
            raise ValueError(f"U0: expected shape ({len(V)}, 2) (one row per row of V), "
                             f"got {U.shape}")
        if not np.isfinite(U).all():
            raise ValueError("U0: contains NaN or inf")
    return V, F, U


def _not_positive(U: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Mask of the triangles folded or flat in ``U``: signed area at most ``1e-9`` of their
    longest edge squared (collinear corners, up to rounding)."""
    e = np.stack([U[F[:, 1]] - U[F[:, 0]], U[F[:, 2]] - U[F[:, 1]], U[F[:, 0]] - U[F[:, 2]]])
    return signed_areas(U, F) <= 1e-9 * (e ** 2).sum(axis=2).max(axis=0)


def flipped(U, F) -> int:
    """Triangles of ``U[F]`` whose signed area is ``<= 0`` (faces counter-clockwise in a
    correct map).

    Unlike :func:`pcgeom.metrics.angle_distortion`'s count, a mirrored map counts every
    triangle: orientation is part of the claim.

    Parameters
    ----------
    U : (n, 2) array_like
        The map.
    F : (m, 3) array_like of int
        Triangles, indices into ``U``.

    Returns
    -------
    int
    """
    return int((signed_areas(U, F) <= 0).sum())


def reference_triangles(V, F, check: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """Each 3D triangle laid flat by an isometry: its area and barycentric gradients.

    Triangle ``t`` with corners ``v_0, v_1, v_2`` gets the 2D corners ``p_0 = 0``,
    ``p_1 = (|e_1|, 0)``, ``p_2 = (e_2 . a, e_2 . b)`` (``e_k = v_k - v_0``, ``a = e_1 /
    |e_1|``, ``b`` the unit vector of the plane orthogonal to ``a``). The Jacobian of a map
    ``u`` on it is ``J = [u_1 - u_0, u_2 - u_0] G`` with ``G = [p_1, p_2]^-1``.

    Parameters
    ----------
    V : (n, 3) or (n, 2) float64
    F : (m, 3) int64

    Returns
    -------
    area : (m,) float64
        Reference areas.
    G : (m, 2, 2) float64
        ``[p_1, p_2]^-1``.

    Raises
    ------
    ValueError
        A triangle of zero area.
    """
    V = np.asarray(V, dtype=np.float64)
    if V.shape[1] == 2:
        V = np.column_stack([V, np.zeros(len(V))])
    e1 = V[F[:, 1]] - V[F[:, 0]]  # (m, 3)
    e2 = V[F[:, 2]] - V[F[:, 0]]
    l1 = np.linalg.norm(e1, axis=1)
    n = np.cross(e1, e2)
    twice = np.linalg.norm(n, axis=1)
    bad = np.flatnonzero(twice <= 1e-14 * np.maximum(l1, 1e-300) ** 2)
    if not check:
        twice = np.maximum(twice, 1e-300)
        l1 = np.maximum(l1, 1e-300)
    elif len(bad):
        raise ValueError(f"V, F: {len(bad)} triangle(s) of zero area (first: face {bad[0]}); "
                         "the reference shapes need proper triangles")
    x2 = np.einsum("md,md->m", e2, e1) / l1
    y2 = twice / l1
    # [p1 p2] = [[l1, x2], [0, y2]]; its inverse:
    G = np.zeros((len(F), 2, 2))
    G[:, 0, 0] = 1.0 / l1
    G[:, 0, 1] = -x2 / (l1 * y2)
    G[:, 1, 1] = 1.0 / y2
    return 0.5 * twice, G


def conformal_energy(V, F, U, energy: str = "mips", *, power: float = 0.5,
                     blend: float = 0.0) -> float:
    """A barrier energy of the map ``U`` per unit reference area, ``sum_t A_t e(J_t) /
    sum_t A_t`` (see the module).

    ``"mips"``: ``e = s1/s2 + s2/s1``, 2 exactly for a similarity (the minimum);
    ``"root_mips"``: ``e = (s1/s2 + s2/s1 - 2 + delta^2)^p + b (s1/s2 + s2/s1 - 2)``;
    ``"symmetric_dirichlet"``: ``e = s1^2 + s2^2 + s1^-2 + s2^-2``, 4 for an isometry.
    ``inf`` when a triangle is folded or flat.

    Parameters
    ----------
    V : (n, 3) or (n, 2) float64
        The mesh (the reference shapes).
    F : (m, 3) int64
    U : (n, 2) float64
        The map.
    energy : str
        One of :data:`ENERGIES`.
    power, blend : float
        ``p`` and ``b`` of ``"root_mips"``.

    Returns
    -------
    float
    """
    _check_energy(energy)
    V, F, U = _as_mesh(V, F, U)
    area, G = reference_triangles(V, F)
    value, _ = _barrier(_jacobians(U, F, G), area, energy, power, blend)
    return value / float(area.sum())


def _check_energy(energy: str) -> None:
    if energy not in ENERGIES:
        raise ValueError(f"energy: expected one of {', '.join(map(repr, ENERGIES))}, "
                         f"got {energy!r}")


def max_feasible_step(U, F, D) -> float:
    """The largest ``a`` such that no triangle's signed area reaches zero on ``U + s D``,
    ``0 <= s < a`` (Smith and Schaefer 2015, section 4).

    For a triangle, ``2 area(U + a D) = c + b a + q a^2`` with ``c = (u_1 - u_0) x (u_2 -
    u_0)``, ``b = (u_1 - u_0) x (d_2 - d_0) + (d_1 - d_0) x (u_2 - u_0)``, ``q = (d_1 - d_0) x
    (d_2 - d_0)``; the answer is the smallest positive root over all triangles (``inf`` if
    none). The triangles are assumed positive at ``a = 0``.

    Parameters
    ----------
    U : (n, 2) float64
        A map with every triangle positive.
    F : (m, 3) int64
    D : (n, 2) float64
        The direction.

    Returns
    -------
    float
    """
    U, D = np.asarray(U, dtype=np.float64), np.asarray(D, dtype=np.float64)
    u1, u2 = U[F[:, 1]] - U[F[:, 0]], U[F[:, 2]] - U[F[:, 0]]
    d1, d2 = D[F[:, 1]] - D[F[:, 0]], D[F[:, 2]] - D[F[:, 0]]

    def cross(a, b):
        return a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]

    c = cross(u1, u2)
    b = cross(u1, d2) + cross(d1, u2)
    q = cross(d1, d2)
    roots = np.full(len(F), np.inf)
    # Nearly linear: q a^2 negligible against b a over the scale of the root -c/b.
    small = np.abs(q) * c <= 1e-12 * b ** 2
    lin = small & (b < 0)
    roots[lin] = -c[lin] / b[lin]
    quad = ~small
    disc = b[quad] ** 2 - 4 * q[quad] * c[quad]
    ok = disc >= 0
    sq = np.sqrt(np.where(ok, disc, 0.0))
    # Stable roots: r1 = (-b - sign(b) sq) / 2q, r2 = c / (q r1) = 2c / (-b - sign(b) sq).
    s = np.where(b[quad] >= 0, 1.0, -1.0)
    t = -0.5 * (b[quad] + s * sq)
    with np.errstate(divide="ignore", invalid="ignore"):
        r1 = np.where(ok, t / q[quad], np.inf)
        r2 = np.where(ok & (t != 0), c[quad] / t, np.inf)
    r1 = np.where(r1 > 0, r1, np.inf)
    r2 = np.where(r2 > 0, r2, np.inf)
    roots[quad] = np.minimum(r1, r2)
    return float(roots.min())


def _jacobians(U: np.ndarray, F: np.ndarray, G: np.ndarray) -> np.ndarray:
    """``J_t = [u_1 - u_0, u_2 - u_0] G_t``, (m, 2, 2)."""
    D = np.stack([U[F[:, 1]] - U[F[:, 0]], U[F[:, 2]] - U[F[:, 0]]], axis=2)  # (m, 2, 2)
    return D @ G


def _scatter(dJ: np.ndarray, F: np.ndarray, G: np.ndarray, n: int) -> np.ndarray:
    """Gradient on the vertices ``(n, 2)`` of a function of the Jacobians, given its
    gradient ``dJ (m, 2, 2)`` with respect to them (chain rule through :func:`_jacobians`)."""
    dD = dJ @ np.swapaxes(G, 1, 2)  # (m, 2, 2): columns for u_1 and u_2
    g1, g2 = dD[:, :, 0], dD[:, :, 1]
    out = np.zeros((n, 2))
    for c in range(2):
        out[:, c] = (np.bincount(F[:, 1], g1[:, c], n) + np.bincount(F[:, 2], g2[:, c], n)
                     - np.bincount(F[:, 0], g1[:, c] + g2[:, c], n))
    return out


def _det_cof(J: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``det J`` (m,) and its gradient, the cofactor matrix (m, 2, 2)."""
    det = J[:, 0, 0] * J[:, 1, 1] - J[:, 0, 1] * J[:, 1, 0]
    cof = np.empty_like(J)
    cof[:, 0, 0], cof[:, 1, 1] = J[:, 1, 1], J[:, 0, 0]
    cof[:, 0, 1], cof[:, 1, 0] = -J[:, 1, 0], -J[:, 0, 1]
    return det, cof


# --------------------------- energies, their gradients and projected Hessians


def _barrier(J: np.ndarray, area: np.ndarray, energy: str, power: float = 0.5,
             blend: float = 0.0) -> tuple[float, np.ndarray]:
    """A barrier energy (see the module) and its gradient w.r.t. the Jacobians; ``inf``
    when a triangle has ``det J <= 0``."""
    det, cof = _det_cof(J)
    if (det <= 0).any():
        return math.inf, np.zeros_like(J)
    tr = (J ** 2).sum(axis=(1, 2))
    if energy in ("mips", "root_mips"):
        e = tr / det
        dJ = (2.0 / det)[:, None, None] * J - (tr / det ** 2)[:, None, None] * cof
        if energy == "root_mips":
            q = np.maximum(e - 2.0, 0.0) + _ROOT_DELTA ** 2
            e, dJ = (q ** power + blend * (e - 2.0),
                     (power * q ** (power - 1.0) + blend)[:, None, None] * dJ)
    else:  # symmetric Dirichlet: tr(J^T J) (1 + 1 / det^2), as tr(J^-T J^-1) = tr / det^2
        inv2 = 1.0 / det ** 2
        e = tr * (1.0 + inv2)
        dJ = (2.0 * (1.0 + inv2))[:, None, None] * J - (2.0 * tr * inv2 / det)[:, None, None] * cof
    return float(area @ e), area[:, None, None] * dJ


_K = np.array([[0.0, 0.0, 0.0, 1.0], [0.0, 0.0, -1.0, 0.0], [0.0, -1.0, 0.0, 0.0],
               [1.0, 0.0, 0.0, 0.0]])
"""The Hessian of ``det J`` in ``vec J = (J00, J01, J10, J11)``."""


def _project_psd(H: np.ndarray) -> np.ndarray:
    """Each symmetric ``H[t]`` with its negative eigenvalues set to zero (projected Newton,
    Teran et al. 2005)."""
    bad = ~np.isfinite(H).all(axis=(1, 2))
    if bad.any():  # overflow where a triangle is (nearly) flat: its curvature is unknown
        H = H.copy()
        H[bad] = 0.0
    w, Q = np.linalg.eigh(H)
    return (Q * np.maximum(w, 0.0)[:, None, :]) @ np.swapaxes(Q, 1, 2)


def _barrier_hessian(J: np.ndarray, area: np.ndarray, energy: str, power: float = 0.5,
                     blend: float = 0.0) -> np.ndarray:
    """The area-weighted, PSD-projected Hessian of the barrier energy in ``vec J``,
    (m, 4, 4); ``j = vec J``, ``c = vec cof J``, ``K`` the Hessian of ``det``:

    - MIPS ``tr / det``: ``2 I / det - 2 (j c^T + c j^T) / det^2 + 2 tr c c^T / det^3
      - tr K / det^2``;
    - symmetric Dirichlet ``tr (1 + det^-2)``: ``2 (1 + det^-2) I - 4 (j c^T + c j^T) /
      det^3 + 6 tr c c^T / det^4 - 2 tr K / det^3``.
    """
    det, cof = _det_cof(J)
    j = J.reshape(-1, 4)
    c = cof.reshape(-1, 4)
    tr = (j ** 2).sum(axis=1)
    jc = j[:, :, None] * c[:, None, :]
    sym = jc + np.swapaxes(jc, 1, 2)
    cc = c[:, :, None] * c[:, None, :]
    eye = np.eye(4)[None]
    if energy in ("mips", "root_mips"):
        H = ((2.0 / det)[:, None, None] * eye - (2.0 / det ** 2)[:, None, None] * sym
             + (2.0 * tr / det ** 3)[:, None, None] * cc - (tr / det ** 2)[:, None, None] * _K)
        if energy == "root_mips":
            g = (2.0 / det)[:, None] * j - (tr / det ** 2)[:, None] * c
            q = np.maximum(tr / det - 2.0, 0.0) + _ROOT_DELTA ** 2
            H = ((power * q ** (power - 1.0) + blend)[:, None, None] * H
                 + (power * (power - 1.0) * q ** (power - 2.0))[:, None, None]
                 * (g[:, :, None] * g[:, None, :]))
    else:
        H = ((2.0 * (1.0 + det ** -2))[:, None, None] * eye
             - (4.0 / det ** 3)[:, None, None] * sym
             + (6.0 * tr / det ** 4)[:, None, None] * cc
             - (2.0 * tr / det ** 3)[:, None, None] * _K)
    return area[:, None, None] * _project_psd(H)


def _chi(D: np.ndarray, eps: float) -> tuple[np.ndarray, np.ndarray]:
    """``chi(D, eps) = (D + sqrt(eps^2 + D^2)) / 2`` and its derivative in ``D``."""
    r = np.sqrt(eps * eps + D * D)
    return 0.5 * (D + r), 0.5 * (1.0 + D / r)


def _untangle_energy(J: np.ndarray, area: np.ndarray, eps: float, theta: float
                     ) -> tuple[float, np.ndarray]:
    """Garanzha et al.'s ``E_eps`` (see the module) and its gradient w.r.t. the Jacobians."""
    det, cof = _det_cof(J)
    tr = (J ** 2).sum(axis=(1, 2))
    chi, dchi = _chi(det, eps)
    if (chi <= 0).any():  # eps^2 / 4|D| underflows where D << -eps: a trial step too far
        return math.inf, np.zeros_like(J)
    num = (1.0 - theta) * tr + theta * (det * det + 1.0)
    e = num / chi
    # d e / dJ = [(1 - theta) 2 J + theta 2 det cof] / chi - num dchi cof / chi^2
    dJ = ((2.0 * (1.0 - theta)) / chi)[:, None, None] * J + (
        (2.0 * theta * det) / chi - num * dchi / chi ** 2)[:, None, None] * cof
    return float(area @ e), area[:, None, None] * dJ


def _untangle_hessian(J: np.ndarray, area: np.ndarray, eps: float, theta: float
                      ) -> np.ndarray:
    """The area-weighted, PSD-projected Hessian of Garanzha et al.'s ``E_eps`` in ``vec J``,
    (m, 4, 4): ``f = N / chi`` with ``N = (1 - theta) tr + theta (det^2 + 1)``,
    ``H = H_N / chi - (g_N g_chi^T + g_chi g_N^T) / chi^2 - N H_chi / chi^2
    + 2 N g_chi g_chi^T / chi^3``."""
    det, cof = _det_cof(J)
    j = J.reshape(-1, 4)
    c = cof.reshape(-1, 4)
    tr = (j ** 2).sum(axis=1)
    chi, dchi = _chi(det, eps)
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        # chi ~ eps^2 / 4|D| underflows for folded triangles when eps is small: their
        # Hessians overflow and are dropped by the projection.
        return area[:, None, None] * _project_psd(
            _untangle_hessian_raw(j, c, det, tr, chi, dchi, eps, theta))


def _untangle_hessian_raw(j, c, det, tr, chi, dchi, eps, theta) -> np.ndarray:
    """:func:`_untangle_hessian` before the projection and the areas."""
    d2chi = 0.5 * eps * eps / (eps * eps + det * det) ** 1.5
    N = (1.0 - theta) * tr + theta * (det * det + 1.0)
    gN = 2.0 * (1.0 - theta) * j + (2.0 * theta * det)[:, None] * c
    cc = c[:, :, None] * c[:, None, :]
    HN = 2.0 * (1.0 - theta) * np.eye(4)[None] + 2.0 * theta * (
        cc + det[:, None, None] * _K)
    gchi = dchi[:, None] * c
    Hchi = d2chi[:, None, None] * cc + dchi[:, None, None] * _K
    cross = gN[:, :, None] * gchi[:, None, :]
    H = (HN / chi[:, None, None] - (cross + np.swapaxes(cross, 1, 2)) / (chi ** 2)[:, None, None]
         - (N / chi ** 2)[:, None, None] * Hchi
         + (2.0 * N / chi ** 3)[:, None, None] * gchi[:, :, None] * gchi[:, None, :])
    return H


class _Assembly:
    """Sums the triangles' ``6 x 6`` Hessians into the sparse ``(2n, 2n)`` Hessian in the
    vertex coordinates ``(u_0x, u_0y, u_1x, ...)``; the sparsity pattern is built once."""

    def __init__(self, F: np.ndarray, n: int):
        idx = (2 * F[:, :, None] + np.arange(2)[None, None, :]).reshape(-1, 6)  # (m, 6)
        rows = np.broadcast_to(idx[:, :, None], (len(F), 6, 6)).ravel()
        cols = np.broadcast_to(idx[:, None, :], (len(F), 6, 6)).ravel()
        unique, self.slot = np.unique(rows * (2 * n) + cols, return_inverse=True)
        self.slot = self.slot.ravel()
        self.rows, self.cols = unique // (2 * n), unique % (2 * n)
        self.shape = (2 * n, 2 * n)

    def __call__(self, H4: np.ndarray, B: np.ndarray):
        """``sum_t B_t^T H_t B_t`` for the Hessians ``H4`` in ``vec J`` (m, 4, 4) and
        ``B_t = d vec J_t / du`` (:func:`_jacobian_matrices`)."""
        import scipy.sparse as sp

        H6 = np.swapaxes(B, 1, 2) @ H4 @ B  # (m, 6, 6)
        data = np.bincount(self.slot, H6.ravel(), minlength=len(self.rows))
        return sp.csr_matrix((data, (self.rows, self.cols)), shape=self.shape)


def _jacobian_matrices(G: np.ndarray) -> np.ndarray:
    """``B_t = d vec J_t / d(u_0x, u_0y, u_1x, u_1y, u_2x, u_2y)``, (m, 4, 6):
    ``dJ_rc / du_kr = w_k[c]`` with ``w_1 = G[0]``, ``w_2 = G[1]``, ``w_0 = -w_1 - w_2``."""
    w = np.stack([-(G[:, 0] + G[:, 1]), G[:, 0], G[:, 1]], axis=1)  # (m, 3, 2)
    B = np.zeros((len(G), 4, 6))
    for r in range(2):
        for c in range(2):
            B[:, 2 * r + c, r::2] = w[:, :, c]
    return B


# --------- variables: free vertices, and loop vertices sliding on their rings


class _Rings:
    """Loops sliding on their rings: each vertex by its unwrapped arc length ``t``.

    A ring is followed through its points by a cubic Hermite curve whose tangent at a point is
    the direction from the point before to the point after (one-sided at a corner, a turn
    sharper than ``corner``): smooth between corners, so a sliding vertex meets no kink to
    park on (on the polyline itself an optimizer parks vertices at its points, where the
    step's first-order model breaks). On arcs sampled from circles the curve is closer to
    the circle than the polyline; on straight sides it is the side."""

    def __init__(self, loops: list[np.ndarray], rings: list[np.ndarray], U: np.ndarray,
                 t: list[np.ndarray] | None = None, corner: float = math.radians(20.0)):
        """Arc lengths ``t`` as given (unwrapped, increasing), else those of the nearest
        ring points to ``U``."""
        self.loops = loops
        self.rings, self.cum, self.length, self.t, self.ends = [], [], [], [], []
        for k, (loop, ring) in enumerate(zip(loops, rings)):
            if not np.allclose(ring[0], ring[-1]):
                ring = np.vstack([ring, ring[:1]])
            seg = np.linalg.norm(np.diff(ring, axis=0), axis=1)
            ring = ring[np.concatenate([[True], seg > 0])]
            ring[-1] = ring[0]
            cum = np.concatenate([[0.0], np.cumsum(seg[seg > 0])])
            L = float(cum[-1])
            self.rings.append(ring)
            self.cum.append(cum)
            self.length.append(L)
            self.ends.append(self._tangents(ring, corner))
            if t is not None:
                self.t.append(np.asarray(t[k], dtype=np.float64))
                continue
            s = self._project(ring, cum, U[loop])
            gaps = np.diff(np.concatenate([s, s[:1] + L])) % L
            if (gaps > 0).all() and abs(gaps.sum() - L) <= 1e-9 * L:
                self.t.append(s[0] + np.concatenate([[0.0], np.cumsum(gaps[:-1])]))
                continue
            # A start laid on the ring by interpolation (the conformal map's rim near a
            # corner) can swap a few neighbours: the longest run in order keeps its arc
            # lengths, the others are spread between them by their place in the loop.
            u = (s - s[0]) % L
            keep = _increasing(u)
            if len(keep) < 0.8 * len(loop):
                raise ValueError(f"loops[{k}]: its vertices are not in order along rings[{k}] "
                                 "(once around, in the ring's direction: outer ring "
                                 "counter-clockwise, holes clockwise)")
            at = np.concatenate([keep, [len(loop)]])
            self.t.append(s[0] + np.interp(np.arange(len(loop)), at,
                                           np.concatenate([u[keep], [L]])))

    @staticmethod
    def _tangents(ring: np.ndarray, corner: float) -> tuple[np.ndarray, np.ndarray]:
        """Unit tangents at the start and the end of each segment, (r, 2) each."""
        P = ring[:-1]
        e = np.diff(ring, axis=0)
        e = e / np.linalg.norm(e, axis=1, keepdims=True)  # segment i: P[i] -> P[i + 1]
        before = np.roll(e, 1, axis=0)  # the segment ending at P[i]
        turn = np.abs(np.arctan2(before[:, 0] * e[:, 1] - before[:, 1] * e[:, 0],
                                 (before * e).sum(axis=1)))
        mid = np.roll(P, -1, axis=0) - np.roll(P, 1, axis=0)
        mid = mid / np.maximum(np.linalg.norm(mid, axis=1, keepdims=True), 1e-300)
        sharp = (turn > corner)[:, None]
        start = np.where(sharp, e, mid)  # at P[i], leaving along segment i
        end = np.roll(np.where(sharp, before, mid), -1, axis=0)  # at P[i + 1], arriving
        return start, end

    @staticmethod
    def _project(ring, cum, P) -> np.ndarray:
        """Arc length of the nearest point of the closed polyline ``ring`` to each of ``P``."""
        a, ab = ring[:-1], np.diff(ring, axis=0)  # (r, 2) segments
        w = P @ ab.T - (a * ab).sum(axis=1)[None]
        s = np.clip(w / (ab ** 2).sum(axis=1)[None], 0.0, 1.0)  # (k, r)
        d = ((a[None] + s[..., None] * ab[None] - P[:, None]) ** 2).sum(axis=2)
        j = np.argmin(d, axis=1)
        return cum[j] + s[np.arange(len(P)), j] * (cum[j + 1] - cum[j])

    def positions(self, k: int, t: np.ndarray
                  ) -> tuple[np.ndarray, tuple[np.ndarray, np.ndarray]]:
        """Points at arc lengths ``t`` on ring ``k``, and their first and second
        derivatives in ``t``."""
        ring, cum = self.rings[k], self.cum[k]
        m0, m1 = self.ends[k]
        s = np.mod(t, self.length[k])
        j = np.clip(np.searchsorted(cum, s, side="right") - 1, 0, len(cum) - 2)
        h = (cum[j + 1] - cum[j])[:, None]
        u = (s - cum[j])[:, None] / h
        p0, p1, a0, a1 = ring[j], ring[j + 1], h * m0[j], h * m1[j]
        u2, u3 = u * u, u * u * u
        P = ((2 * u3 - 3 * u2 + 1) * p0 + (u3 - 2 * u2 + u) * a0 + (3 * u2 - 2 * u3) * p1
             + (u3 - u2) * a1)
        dP = ((6 * u2 - 6 * u) * p0 + (3 * u2 - 4 * u + 1) * a0 + (6 * u - 6 * u2) * p1
              + (3 * u2 - 2 * u) * a1) / h
        d2P = ((12 * u - 6) * p0 + (6 * u - 4) * a0 + (6 - 12 * u) * p1
               + (6 * u - 2) * a1) / h ** 2
        return P, (dP, d2P)

    def in_order(self, k: int, t: np.ndarray) -> bool:
        """The loop's vertices strictly increase along the ring and stay within one turn."""
        return not len(t) or bool((np.diff(t) > 0).all() and t[-1] - t[0] < self.length[k])


class _Layout:
    """A map as a vector of variables: the ``free`` vertices by their coordinates, the
    vertices of ``rings``' loops by their arc lengths, the others held where ``U`` has them."""

    def __init__(self, U: np.ndarray, free: np.ndarray, rings: _Rings | None):
        self.U = U.copy()
        self.free = free
        self.rings = rings
        self.loops = rings.loops if rings is not None else []
        self.nf = 2 * len(free)
        self.z0 = np.concatenate([U[free].ravel()] + (rings.t if rings is not None else []))

    def unpack(self, z: np.ndarray) -> tuple[np.ndarray, list]:
        """The map ``(n, 2)`` and, for each loop, the first and second derivatives of its
        vertices in their arc lengths."""
        W = self.U.copy()
        W[self.free] = z[:self.nf].reshape(-1, 2)
        frames, at = [], self.nf
        for k, loop in enumerate(self.loops):
            W[loop], frame = self.rings.positions(k, z[at:at + len(loop)])
            frames.append(frame)
            at += len(loop)
        return W, frames

    def pull(self, gU: np.ndarray, frames: list) -> np.ndarray:
        """A gradient on the vertices ``(n, 2)`` as a gradient in the variables."""
        parts = [gU[self.free].ravel()]
        parts += [(gU[loop] * T).sum(axis=1) for loop, (T, _) in zip(self.loops, frames)]
        return np.concatenate(parts)

    def push(self, d: np.ndarray, frames: list) -> np.ndarray:
        """A step in the variables as a displacement of the vertices ``(n, 2)``: exact for
        the free vertices, to first order for the sliding ones."""
        D = np.zeros_like(self.U)
        D[self.free] = d[:self.nf].reshape(-1, 2)
        at = self.nf
        for loop, (T, _) in zip(self.loops, frames):
            D[loop] = d[at:at + len(loop), None] * T
            at += len(loop)
        return D

    def matrix(self, frames: list):
        """The sparse ``(2n, nz)`` derivative of the vertex coordinates in the variables."""
        import scipy.sparse as sp

        n = len(self.U)
        rows = [2 * self.free, 2 * self.free + 1]
        cols = [np.arange(0, self.nf, 2), np.arange(1, self.nf, 2)]
        vals = [np.ones(len(self.free)), np.ones(len(self.free))]
        at = self.nf
        for loop, (T, _) in zip(self.loops, frames):
            q = at + np.arange(len(loop))
            rows += [2 * loop, 2 * loop + 1]
            cols += [q, q]
            vals += [T[:, 0], T[:, 1]]
            at += len(loop)
        return sp.csr_matrix((np.concatenate(vals),
                              (np.concatenate(rows), np.concatenate(cols))),
                             shape=(2 * n, at))

    def curvature(self, gU: np.ndarray, frames: list) -> np.ndarray:
        """The term ``g . d2x/dt2`` each sliding variable adds to the Hessian's diagonal
        (the ring's bending), cut at zero; zero for the free variables."""
        out = [np.zeros(self.nf)]
        out += [np.maximum((gU[loop] * C).sum(axis=1), 0.0)
                for loop, (_, C) in zip(self.loops, frames)]
        return np.concatenate(out)

    def in_order(self, z: np.ndarray) -> bool:
        at = self.nf
        for k, loop in enumerate(self.loops):
            if not self.rings.in_order(k, z[at:at + len(loop)]):
                return False
            at += len(loop)
        return True


def _scaled_reference(V: np.ndarray, F: np.ndarray, U: np.ndarray,
                      weights: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Reference areas (times ``weights``) and ``G``, the references scaled so that their
    areas sum to the map's signed area (``det J = 1`` on average)."""
    area, G = reference_triangles(V, F, check=False)
    target = float(signed_areas(U, F).sum())
    if target <= 0:
        raise ValueError("U0: the triangles' signed areas sum to <= 0: the faces run "
                         "clockwise in the map (reverse F) or the fixed loops are misplaced")
    scale = math.sqrt(area.sum() / target)  # reference lengths are divided by it
    area = area / scale ** 2
    return (area if weights is None else area * weights), G * scale


# -------------------------------------------------------------------- solvers


def _newton_factor(H):
    """The solve of the sparse PSD ``H`` (the variables' Hessian), shifted by a tiny multiple
    of its mean diagonal where the projection left it singular."""
    import scipy.sparse as sp

    from ._sparse import spd_factor

    shift = 1e-9 * max(float(H.diagonal().mean()), 1e-300)
    return spd_factor((H + shift * sp.identity(H.shape[0], format="csr")).tocsc())


def _newton_step(H, g: np.ndarray) -> np.ndarray:
    """``-H^-1 g`` (:func:`_newton_factor`)."""
    return -_newton_factor(H)(g)


def _newton_minimize(fun, hessian, z: np.ndarray, eps: float, steps: int
                     ) -> tuple[np.ndarray, float, int, int]:
    """Projected Newton on the smooth ``fun(z, eps)`` (value, gradient), Armijo
    backtracking; stops when a step lowers the value by less than 1e-9 of it. Returns ``z``,
    the value, the steps and the evaluations."""
    E, g = fun(z, eps)
    evaluations, it = 1, 0
    for it in range(1, steps + 1):
        d = _newton_step(hessian(z, eps), g)
        slope = float(g @ d)
        if slope >= 0:
            d, slope = -g, -float(g @ g)
        a = 1.0
        for _ in range(40):
            E_new, g_new = fun(z + a * d, eps)
            evaluations += 1
            if math.isfinite(E_new) and E_new <= E + 1e-4 * a * slope:
                break
            a *= 0.5
        else:
            break
        z, drop = z + a * d, E - E_new
        E, g = E_new, g_new
        if drop < 1e-9 * abs(E):
            break
    return z, E, it, evaluations


def _lbfgs_direction(g: np.ndarray, S: list, Y: list) -> np.ndarray:
    """``-H g`` by the L-BFGS two-loop recursion (Nocedal and Wright, Algorithm 7.4)."""
    q = g.copy()
    alphas = []
    for s, y in reversed(list(zip(S, Y))):
        rho = 1.0 / (y @ s)
        a = rho * (s @ q)
        alphas.append((rho, a))
        q -= a * y
    if S:
        q *= (S[-1] @ Y[-1]) / (Y[-1] @ Y[-1])
    for (s, y), (rho, a) in zip(zip(S, Y), reversed(alphas)):
        q += s * (a - rho * (y @ q))
    return -q


def _descend(V: np.ndarray, F: np.ndarray, layout: _Layout, config: BarrierConfig,
             area_G: tuple[np.ndarray, np.ndarray], *, pull=None, cover=None, outside=None
             ) -> tuple[np.ndarray, dict]:
    """Step 4 on the variables of ``layout``: the barrier energy, every step short of a zero
    area and accepted only when the loops stay in order. ``area_G``: the weighted reference
    areas and ``G`` of ``F``.

    ``pull = (index, targets, weight)`` adds ``weight mean_i |u_i - q_i|^2 / A`` for the
    vertices ``index``; ``cover = (loops, ring areas)`` the uncovered area
    (:attr:`BarrierConfig.cover`); ``outside = (index, region)`` ``cover sum_i d_i^2 / A``,
    ``d_i`` the distance of vertex ``index[i]`` to the shapely ``region`` (0 inside)."""
    import scipy.sparse as sp
    import shapely

    if config.method not in ("newton", "lbfgs"):
        raise ValueError(f"config.method: expected 'newton' or 'lbfgs', got {config.method!r}")
    n = len(V)
    z = layout.z0.copy()
    W, frames = layout.unpack(z)
    area, G = area_G
    total = float(area.sum())
    m = len(F)
    if config.flip_guard > 0:
        # Each interior edge's other diagonal, where the start has it positive: the quads of
        # two triangles stay convex. Not those nearly flat at the start (three vertices on
        # one straight side of a ring stay flat): det J > 1e-4.
        alt = _other_diagonals(F)
        alt_area, alt_G = reference_triangles(V, alt, check=False)
        scale = math.sqrt(float(reference_triangles(V, F, check=False)[0].sum()) / total)
        keep = signed_areas(W, alt) > 1e-4 * alt_area / scale ** 2
        F = np.vstack([F, alt[keep]])
        area = np.concatenate([area, config.flip_guard * alt_area[keep] / scale ** 2])
        G = np.concatenate([G, alt_G[keep] * scale])

    def fun(z):
        W, frames = layout.unpack(z)
        value, dJ = _barrier(_jacobians(W, F, G), area, config.energy, config.power,
                             config.blend)
        if not math.isfinite(value):
            return value, None, W, frames, None
        value /= total
        gU = _scatter(dJ, F, G, n) / total
        if pull is not None:
            index, targets, weight = pull
            r = W[index] - targets
            c = weight / (len(index) * total)
            value += c * float((r ** 2).sum())
            np.add.at(gU, index, 2.0 * c * r)
        if cover is not None:
            c = config.cover / total
            for loop, ring_area in zip(*cover):
                P = W[loop]
                nxt, prv = np.roll(P, -1, axis=0), np.roll(P, 1, axis=0)
                S = 0.5 * float((P[:, 0] * nxt[:, 1] - P[:, 1] * nxt[:, 0]).sum())
                sign = 1.0 if ring_area > 0 else -1.0
                value += c * sign * (ring_area - S)
                # dS/du_i = (y_(i+1) - y_(i-1), x_(i-1) - x_(i+1)) / 2 (the shoelace)
                dS = 0.5 * np.column_stack([nxt[:, 1] - prv[:, 1], prv[:, 0] - nxt[:, 0]])
                np.add.at(gU, loop, -c * sign * dS)
        if outside is not None:
            index, region = outside
            P = W[index]
            out = ~shapely.contains_xy(region, P[:, 0], P[:, 1])
            if out.any():
                near = shapely.get_coordinates(shapely.shortest_line(
                    region.boundary, shapely.points(P[out])))[1::2]  # (k, 2) on the boundary
                r = P[out] - near
                c = config.cover / total
                value += c * float((r ** 2).sum())
                np.add.at(gU, index[out], 2.0 * c * r)
        return value, layout.pull(gU, frames), W, frames, gU

    assemble, B = _Assembly(F, n), _jacobian_matrices(G)

    def hessian(W, frames, gU):
        # The uncovered area's Hessian is indefinite and left out (a Gauss-Newton model).
        H4 = _barrier_hessian(_jacobians(W, F, G), area, config.energy, config.power,
                              config.blend) / total
        H = assemble(H4, B)
        if pull is not None:
            index, _, weight = pull
            diag = np.zeros(2 * n)
            np.add.at(diag, 2 * index, 2.0 * weight / (len(index) * total))
            np.add.at(diag, 2 * index + 1, 2.0 * weight / (len(index) * total))
            H = H + sp.diags(diag)
        if outside is not None:
            index, _ = outside
            diag = np.zeros(2 * n)
            diag[2 * index] = diag[2 * index + 1] = 2.0 * config.cover / total
            H = H + sp.diags(diag)
        P = layout.matrix(frames)
        return (P.T @ H @ P + sp.diags(layout.curvature(gU, frames))).tocsr()

    newton = config.method == "newton"
    E, g, W, frames, gU = fun(z)
    if not math.isfinite(E):
        raise ValueError("a folded or flat triangle where the barrier starts")
    E_start = E
    S, Y = [], []
    history = [E]
    evaluations, it, steps_cut = 1, 0, 0
    solve, age = None, 0
    for it in range(1, config.iterations + 1):
        if newton:
            if solve is None or age >= config.refactor:
                solve, age = _newton_factor(hessian(W, frames, gU)), 0
            d, age = -solve(g), age + 1
        else:
            d = _lbfgs_direction(g, S, Y)
        if not float(g @ d) < 0 or (not newton and not S):
            if not float(g @ d) < 0:  # not a descent direction: restart from the gradient
                S, Y = [], []
                d = -g
            # A first step of 1e-3 of the map's size, where no curvature is known yet.
            d = d * (1e-3 * math.sqrt(total) / max(np.abs(d).max(), 1e-300))
        slope = float(g @ d)
        amax = max_feasible_step(W, F, layout.push(d, frames))
        a = min(1.0, config.max_fraction * amax)
        steps_cut += amax <= 1.0
        accepted = False
        for _ in range(60):
            z_new = z + a * d
            if layout.in_order(z_new):
                E_new, g_new, W_new, frames_new, gU_new = fun(z_new)
                evaluations += 1
                if math.isfinite(E_new) and E_new <= E + 1e-4 * a * slope:
                    accepted = True
                    break
            a *= 0.5
        if not accepted:
            if newton and age > 1:  # a Hessian some steps old: try the current one
                solve = None
                continue
            break
        s, y = z_new - z, g_new - g
        if s @ y > 1e-12 * math.sqrt((s @ s) * (y @ y)):
            S.append(s)
            Y.append(y)
            if len(S) > config.memory:
                S.pop(0)
                Y.pop(0)
        z, E, g, W, frames, gU = z_new, E_new, g_new, W_new, frames_new, gU_new
        history.append(E)
        if it >= config.patience and history[-config.patience - 1] - E < config.tolerance * E:
            break
    det = _det_cof(_jacobians(W, F, G))[0][:m]
    info = {"energy": config.energy, "energy_start": E_start, "energy_end": E,
            "iterations": it, "evaluations": evaluations, "steps_cut": int(steps_cut),
            "min_det": float(det.min()), "min_area": float(signed_areas(W, F[:m]).min()),
            "flipped": flipped(W, F[:m]), "in_order": layout.in_order(z),
            "guarded_quads": len(F) - m, "history": history[::10]}
    at, info["t"] = layout.nf, []
    for loop in layout.loops:  # where each sliding vertex ended, along its ring
        info["t"].append(z[at:at + len(loop)].copy())
        at += len(loop)
    return W, info


# --------------------------------------------------- step 3: flip-free starts


def _untangle(V: np.ndarray, F: np.ndarray, layout: _Layout, config: UntangleConfig,
              weights: np.ndarray | None = None) -> tuple[np.ndarray, dict]:
    """Step 3 on the variables of ``layout``."""
    from scipy.optimize import minimize

    if config.method not in ("newton", "lbfgs"):
        raise ValueError(f"config.method: expected 'newton' or 'lbfgs', got {config.method!r}")
    t0 = time.perf_counter()
    n = len(V)
    W, _ = layout.unpack(layout.z0)
    area, G = _scaled_reference(V, F, W, weights)
    total = float(area.sum())
    start_flips = flipped(W, F)

    def fun(z, eps):
        W, frames = layout.unpack(z)
        value, dJ = _untangle_energy(_jacobians(W, F, G), area, eps, config.theta)
        return value / total, layout.pull(_scatter(dJ, F, G, n), frames) / total

    def min_det(z):
        return float(_det_cof(_jacobians(layout.unpack(z)[0], F, G))[0].min())

    assemble, B = _Assembly(F, n), _jacobian_matrices(G)

    def hessian(z, eps):
        W, frames = layout.unpack(z)
        H4 = _untangle_hessian(_jacobians(W, F, G), area, eps, config.theta) / total
        P = layout.matrix(frames)
        return (P.T @ assemble(H4, B) @ P).tocsr()

    z = layout.z0.copy()
    det_min = min_det(z)
    eps = math.sqrt(1e-12 + 0.04 * min(det_min, 0.0) ** 2)  # the paper's first eps
    energy = fun(z, eps)[0]
    iterations = evaluations = rounds = 0
    for rounds in range(1, config.rounds + 1):
        if not len(z):
            break
        if config.method == "newton":
            z, value, nit, nfev = _newton_minimize(fun, hessian, z, eps, config.newton_steps)
        else:
            res = minimize(fun, z, args=(eps,), jac=True, method="L-BFGS-B",
                           options={"maxiter": config.inner, "gtol": 1e-12, "ftol": 1e-13})
            z, value, nit, nfev = res.x, float(res.fun), int(res.nit), int(res.nfev)
        iterations += nit
        evaluations += nfev
        previous, energy = energy, value
        det_min = min_det(z)
        change = abs(previous - energy) / max(abs(energy), 1e-300)
        if det_min > 0 and (change < config.tolerance or config.stop_when_unfolded):
            break
        # The paper's schedule: chi(min det, eps_new) = (1 - sigma) chi(min det, eps).
        least = config.decrease
        sigma = max(1.0 - energy / previous, least) if previous > 0 else least
        mu = (1.0 - sigma) * float(_chi(np.array(det_min), eps)[0])
        eps = 2.0 * math.sqrt(mu * (mu - det_min)) if det_min < mu else 1e-10
    W, _ = layout.unpack(z)
    info = {"rounds": rounds, "iterations": iterations, "evaluations": evaluations,
            "eps": eps, "energy": energy, "min_det": det_min, "flipped": flipped(W, F),
            "flipped_start": start_flips, "seconds": time.perf_counter() - t0}
    return W, info


def untangle(V, F, U0, fixed, fixed_uv=None, *, weights=None,
             config: UntangleConfig = UntangleConfig()) -> tuple[np.ndarray, dict]:
    """Unfold a map with some vertices held (Garanzha et al. 2021; step 3 of the module).

    Minimizes ``E_eps(U) = sum_t w_t A_t [(1 - theta) tr(J_t^T J_t) + theta (det(J_t)^2 +
    1)] / chi(det J_t, eps)``, ``chi(D, eps) = (D + sqrt(eps^2 + D^2)) / 2``, over the
    vertices not held, for decreasing eps, until no triangle has ``det J <= 0``.

    Parameters
    ----------
    V : (n, 3) or (n, 2) float64
        The mesh; its triangles, laid flat, are the reference shapes.
    F : (m, 3) int64
        Triangles, counter-clockwise in the map sought.
    U0 : (n, 2) float64
        The start; may fold.
    fixed : (k,) int
        Vertices that do not move (the loops paired with a ring).
    fixed_uv : (k, 2) float64, optional
        Where they are held, in the order of ``fixed``; default ``U0[fixed]``.
    weights : (m,) float64, optional
        ``w_t``; default 1.
    config : UntangleConfig

    Returns
    -------
    U : (n, 2) float64
    info : dict
        ``rounds`` (values of eps), ``iterations`` (Newton steps or L-BFGS iterations, all
        rounds), ``evaluations``, ``eps`` (the last), ``energy`` (``E_eps`` per reference
        area, the last), ``min_det`` (smallest ``det J``, references scaled to the map's
        area), ``flipped`` (:func:`flipped` of ``U``: 0 on success), ``flipped_start``,
        ``seconds``.

    Raises
    ------
    ValueError
        Wrong shapes, indices out of range, a degenerate reference triangle, faces that run
        clockwise in the start.
    """
    V, F, U0 = _as_mesh(V, F, U0)
    n = len(V)
    reference_triangles(V, F)  # raises on a flat reference triangle
    fixed = np.asarray(fixed, dtype=np.int64).ravel()
    if len(fixed) and (fixed.min() < 0 or fixed.max() >= n):
        raise ValueError(f"fixed: indices must lie in [0, {n}), got [{fixed.min()}, "
                         f"{fixed.max()}]")
    U = U0.copy()
    if fixed_uv is not None:
        fixed_uv = np.asarray(fixed_uv, dtype=np.float64)
        if fixed_uv.shape != (len(fixed), 2):
            raise ValueError(f"fixed_uv: expected shape ({len(fixed)}, 2) (one row per "
                             f"fixed vertex), got {fixed_uv.shape}")
        U[fixed] = fixed_uv
    if weights is not None:
        weights = np.asarray(weights, dtype=np.float64)
        if weights.shape != (len(F),) or not (weights > 0).all():
            raise ValueError(f"weights: expected ({len(F)},) positive values, got shape "
                             f"{weights.shape}")
    used = np.zeros(n, dtype=bool)
    used[F.ravel()] = True
    used[fixed] = False
    return _untangle(V, F, _Layout(U, np.flatnonzero(used), None), config, weights)


def tutte_fill(V, F, outer, outer_uv) -> np.ndarray:
    """Tutte's embedding with mean-value weights (Floater 2003), every hole filled.

    Each boundary loop of ``F`` other than ``outer`` gets a virtual vertex at its 3D centroid
    and a fan of triangles to it, so the mesh is a disk; the loop ``outer`` is held at
    ``outer_uv`` and every other vertex is the weighted mean of its neighbours,
    ``sum_j w_ij (u_j - u_i) = 0`` with ``w_ij = (tan(a_ij / 2) + tan(b_ij / 2)) / |x_j -
    x_i|`` (``a_ij, b_ij``: the 3D angles at ``x_i`` beside the edge ``ij``). The weights are
    positive, so when ``outer_uv`` is a convex polygon (in order, counter-clockwise) no
    triangle folds (Tutte 1963, Floater 2003).

    Parameters
    ----------
    V : (n, 3) float64
    F : (m, 3) int64
        Consistently oriented; one connected part.
    outer : (k,) int
        The loop held.
    outer_uv : (k, 2) float64
        Where it is held.

    Returns
    -------
    (n, 2) float64
    """
    import scipy.sparse as sp
    from scipy.sparse.linalg import splu

    V = np.asarray(V, dtype=np.float64)
    if V.shape[1] == 2:
        V = np.column_stack([V, np.zeros(len(V))])
    n = len(V)
    outer = np.asarray(outer, dtype=np.int64)
    taken = set(outer.tolist())
    points, faces = [V], [F]
    for loop in boundary_loops(F):
        if loop[0] in taken:
            continue
        c = n + sum(len(p) for p in points[1:])
        points.append(V[loop].mean(axis=0, keepdims=True))
        loop = np.asarray(loop)
        # The loop runs along F's boundary edges (a -> b); the fan holds b -> a.
        faces.append(np.column_stack([np.roll(loop, -1), loop, np.full(len(loop), c)]))
    X = np.vstack(points)
    T = np.vstack(faces)
    N = len(X)
    rows, cols, vals = [], [], []
    for q in range(3):
        i, j, k = T[:, q], T[:, (q + 1) % 3], T[:, (q + 2) % 3]
        e1, e2 = X[j] - X[i], X[k] - X[i]
        l1, l2 = np.linalg.norm(e1, axis=1), np.linalg.norm(e2, axis=1)
        cos = np.clip((e1 * e2).sum(axis=1) / np.maximum(l1 * l2, 1e-300), -1.0, 1.0)
        half = np.tan(0.5 * np.arccos(cos))  # the angle at i, shared by edges ij and ik
        rows += [i, i]
        cols += [j, k]
        vals += [half / np.maximum(l1, 1e-300), half / np.maximum(l2, 1e-300)]
    Wm = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                       shape=(N, N))
    L = sp.diags(np.asarray(Wm.sum(axis=1)).ravel()) - Wm
    used = np.zeros(N, dtype=bool)
    used[T.ravel()] = True
    used[outer] = False
    free = np.flatnonzero(used)
    U = np.zeros((N, 2))
    U[outer] = outer_uv
    A = L[free][:, free].tocsc()
    U[free] = splu(A).solve(np.asarray(-(L[free][:, outer] @ outer_uv)))
    return U[:n]


def _convex(ring: np.ndarray) -> bool:
    """The closed polyline turns one way only (collinear points allowed)."""
    P = ring[:-1] if np.allclose(ring[0], ring[-1]) else ring
    e = np.roll(P, -1, axis=0) - P
    turn = e[:, 0] * np.roll(e[:, 1], -1) - e[:, 1] * np.roll(e[:, 0], -1)
    scale = np.abs(turn).max()
    return bool((turn >= -1e-12 * scale).all() or (turn <= 1e-12 * scale).all())


def _pull_onto(V: np.ndarray, F: np.ndarray, U: np.ndarray, weights: np.ndarray,
               held: np.ndarray, index: np.ndarray, targets: np.ndarray,
               config: PullConfig, barrier: BarrierConfig) -> tuple[np.ndarray, dict]:
    """From the flip-free ``U``, pull the vertices ``index`` towards ``targets`` under the
    barrier, the pull's weight growing, until every one is within ``config.tolerance``
    (relative to the square root of the map's area) or ``config.stages`` weights are spent."""
    used = np.zeros(len(V), dtype=bool)
    used[F.ravel()] = True
    used[held] = False
    free = np.flatnonzero(used)
    area_G = _scaled_reference(V, F, U, weights)
    size = math.sqrt(float(signed_areas(U, F).sum()))
    steps = dataclasses.replace(barrier, iterations=config.iterations, flip_guard=0.0)
    weight = config.weight
    iterations, stages, gap = 0, 0, math.inf
    for stages in range(1, config.stages + 1):
        U, info = _descend(V, F, _Layout(U, free, None), steps, area_G,
                           pull=(index, targets, weight))
        iterations += info["iterations"]
        gap = float(np.linalg.norm(U[index] - targets, axis=1).max()) / size
        if gap < config.tolerance:
            break
        weight *= config.growth
    return U, {"stages": stages, "iterations": iterations, "weight": weight, "gap": gap}


# -------------------------------------------------------------------- the map


def injective_map(V, F, U0, loops, rings, *, landmarks=(),
                  config: InjectiveConfig = InjectiveConfig()) -> tuple[np.ndarray, dict]:
    """A bijection of the mesh onto the domain bounded by ``rings``, low in angle distortion
    (steps 1-4 of the module).

    Parameters
    ----------
    V : (n, 3) float64
        The mesh's vertices; its 3D triangles are the reference shapes.
    F : (m, 3) int64
        Triangles, consistently oriented, one connected part. When they run clockwise in
        ``U0`` (a mirrored start: the signed areas sum below zero), they are reversed.
    U0 : (n, 2) float64
        The start, each paired loop's vertices on (or near) its ring, in order; may fold.
    loops : sequence of (k_i,) int
        Boundary loops of ``F`` paired with a ring, each in the ring's direction.
    rings : sequence of (r_i, 2) float64
        Closed polylines (the last point may repeat the first), one for each loop: the
        domain's outer ring counter-clockwise, its holes clockwise
        (:meth:`pcgeom.domains.Domain.boundary_loops`).
    landmarks : sequence of ((k_j,) int, (m_j, 2) float64)
        Vertices of each landmark set and the points they should cover: step 4 adds the
        term of :attr:`BarrierConfig.landmarks`, which the barrier keeps from folding
        anything.
    config : InjectiveConfig

    Returns
    -------
    U : (n, 2) float64
        The map. Every triangle of the cleaned mesh is positive; a vertex on none of them
        (the tip of a dropped triangle) sits at the mean of its neighbours.
    info : dict
        What cleaning did: ``reversed``, ``pinched``, ``peeled``, ``handles`` (triangles
        dropped for each reason), ``joined`` (vertices each paired loop gained), ``corners``
        (vertices pinned on ring corners), ``scaffold`` (holes filled); ``start`` (its method
        and that method's info), ``flipped_start`` (folded triangles in ``U0``), ``released``
        (loop vertices off their ring); step 4's ``energy``, ``energy_start``,
        ``energy_end`` (per area), ``iterations``, ``evaluations``, ``steps_cut`` (steps the
        feasible step shortened), ``min_det``, ``min_area``, ``flipped`` (0: the cleaned
        mesh), ``in_order``, ``history`` (energy every 10 steps); ``flipped_all`` (on every
        triangle of ``F``, dropped ones included), ``faces`` (the cleaned mesh's triangles,
        every one positive in ``U``), ``free_loops_simple``, ``seconds``.

    Raises
    ------
    ValueError
        Wrong shapes, not one ring per loop, a loop out of order along its ring, a flat
        reference triangle, or no flip-free start found.
    """
    t0 = time.perf_counter()
    _check_energy(config.barrier.energy)
    if config.start not in STARTS:
        raise ValueError(f"config.start: expected one of {', '.join(map(repr, STARTS))}, "
                         f"got {config.start!r}")
    V, F, U0 = _as_mesh(V, F, U0)
    if V.shape[1] == 2:
        V = np.column_stack([V, np.zeros(len(V))])
    n = len(V)
    loops = [np.asarray(loop, dtype=np.int64).ravel() for loop in loops]
    rings = [np.asarray(r, dtype=np.float64) for r in rings]
    if len(loops) != len(rings) or not loops:
        raise ValueError(f"loops, rings: expected one ring per loop, at least one, got "
                         f"{len(loops)} loops and {len(rings)} rings")
    for k, (loop, ring) in enumerate(zip(loops, rings)):
        if len(loop) < 3 or loop.min() < 0 or loop.max() >= n:
            raise ValueError(f"loops[{k}]: expected at least 3 indices in [0, {n}), got "
                             f"{len(loop)} in [{loop.min(initial=0)}, {loop.max(initial=0)}]")
        if ring.ndim != 2 or ring.shape[1] != 2 or len(ring) < 3 or not np.isfinite(ring).all():
            raise ValueError(f"rings[{k}]: expected finite points of shape (r, 2) with r >= 3, "
                             f"got {ring.shape}")
    reference_triangles(V, F)  # raises on a flat reference triangle
    reverse = float(signed_areas(U0, F).sum()) < 0
    F_all = F[:, ::-1].copy() if reverse else F
    corner = math.radians(config.corner_angle)

    # Step 1: clean; the loops follow the cleaned rim, each vertex at an arc length.
    F, pinched = one_fan(F_all)
    F, peeled = peel_rim(V, F, math.radians(config.rim_angle))
    F, handles = _cut_handles(V, F)
    U = U0.copy()
    loops, ts, joined = _rebuild_loops(V, F, _Rings(loops, rings, U))
    slide = _Rings(loops, rings, U, t=ts, corner=corner)
    pinned = _pin_corners(slide, corner)
    for k, loop in enumerate(loops):
        U[loop] = slide.positions(k, slide.t[k])[0]
    index = np.concatenate(loops)

    # Step 2: the holes paired with no ring filled by fans.
    m_mesh = len(F)  # the fans follow the mesh's own triangles
    V, F, U = _scaffold(V, F, U, loops)
    weights = np.ones(len(F))
    weights[m_mesh:] = config.scaffold

    # Step 3: a flip-free start.
    flipped_start = flipped(U, F)
    start: dict = {"method": "given"}
    if flipped_start and config.start in ("auto", "untangle"):
        hold = np.setdiff1d(index, _release(U, F, loops, rings))
        used = np.zeros(len(V), dtype=bool)
        used[F.ravel()] = True
        used[hold] = False
        untangled = {"flipped": 1}
        if config.untangle.local > 0:
            near = _near_folds(U, F, config.untangle.local) & used
            U_try, untangled = _untangle(V, F, _Layout(U, np.flatnonzero(near), None),
                                         config.untangle, weights)
            untangled["local"] = int(near.sum())
        if untangled["flipped"]:
            U_try, untangled = _untangle(V, F, _Layout(U, np.flatnonzero(used), None),
                                         config.untangle, weights)
        start = {"method": "untangle", **untangled}
        if not untangled["flipped"]:
            U = U_try
        elif config.start == "untangle":
            raise ValueError(f"U0: {untangled['flipped']} triangle(s) still folded after "
                             "untangling; try config.start='pull'")
    if flipped(U, F):
        U, pulled = _pull_start(V, F, U, weights, loops, rings, slide, index, config)
        start = {"method": "pull", "untangle": start if start["method"] != "given" else None,
                 **pulled}

    # Step 4: the loop vertices onto their rings where nothing folds, then the barrier.
    t_all = [slide._project(slide.rings[k], slide.cum[k], U[loop])
             for k, loop in enumerate(loops)]
    moved = _snap(F, U, index, np.vstack([slide.positions(k, t)[0]
                                          for k, t in enumerate(t_all)]))
    released = index[~moved]
    sliding, ts = [], []
    for k, (loop, t) in enumerate(zip(loops, t_all)):
        keep = ~np.isin(loop, released) & ~np.isin(loop, pinned)
        loop, t = loop[keep], t[keep]
        # A start that moved loop vertices (the pull, a released ear) may leave two of them
        # crossed along the ring: the longest run in order slides, the others are released.
        u = (t - t[0]) % slide.length[k] if len(t) else t
        order = _increasing(u) if len(t) else np.zeros(0, dtype=np.int64)
        released = np.concatenate([released, np.delete(loop, order)])
        sliding.append(loop[order])
        ts.append(t[0] + u[order] if len(t) else t)
    slide = _Rings(sliding, rings, U, t=ts, corner=corner)
    used = np.zeros(len(V), dtype=bool)
    used[F.ravel()] = True
    used[np.concatenate(sliding)] = False
    used[pinned] = False
    outside = None
    if len(released):
        # A released vertex pays for leaving the domain: config.barrier.cover times its
        # squared distance to it, per area (a wall in the line search stalls Newton's steps,
        # which keep pointing out).
        outside = (released, _region(rings))

    layout = _Layout(U, np.flatnonzero(used), slide if config.barrier.slide else None)
    cover = None
    if config.barrier.slide and config.barrier.cover > 0:
        # The polygons through the vertices on the rings: a released vertex would only earn
        # area by going deeper into the domain (``outside`` keeps it from leaving it).
        cover = ([loop[~np.isin(loop, released)] for loop in loops],
                 [shoelace(r) for r in rings])
    reference = _scaled_reference(V, F, U, weights)
    marks = [(np.asarray(i, dtype=np.int64).ravel(), np.asarray(q, dtype=np.float64))
             for i, q in landmarks]
    if not marks:
        U, info = _descend(V, F, layout, config.barrier, reference, outside=outside,
                           cover=cover)
    else:
        rounds = max(1, config.barrier.landmark_rounds)
        per_round = dataclasses.replace(config.barrier,
                                        iterations=max(1, config.barrier.iterations // rounds))
        iterations = 0
        for _ in range(rounds):
            pull = _landmark_pairs(V, U, marks, config.barrier.landmarks)
            U, info = _descend(V, F, layout, per_round, reference, pull=pull,
                               outside=outside, cover=cover)
            iterations += info["iterations"]
            if config.barrier.slide:
                slide.t = info.pop("t")
            layout = _Layout(U, layout.free, slide if config.barrier.slide else None)
        info["iterations"] = iterations
    info.pop("t", None)
    info["flipped"] = flipped(U, F[:m_mesh])
    U = _place_dropped(U[:n], F[:m_mesh], F_all)
    info.update(reversed=reverse, pinched=pinched, peeled=peeled, handles=handles,
                joined=joined, corners=len(pinned), scaffold=len(V) - n, start=start,
                flipped_start=flipped_start, released=len(released),
                flipped_all=flipped(U, F_all), faces=F[:m_mesh],
                seconds=time.perf_counter() - t0)
    info["free_loops_simple"] = _free_loops_simple(U, F[:m_mesh], loops)
    return U, info


def _pull_start(V, F, U, weights, loops, rings, slide, index, config: InjectiveConfig
                ) -> tuple[np.ndarray, dict]:
    """The ``"pull"`` start: Tutte's embedding with the outer loop on its ring (on a circle
    of its area when the ring is not convex), then every paired loop pulled to its place."""
    targets = U[index].copy()
    outer = loops[0]
    convex = _convex(rings[0])
    if convex:
        outer_uv = U[outer]
    else:  # a circle of the ring's area, the loop spread as on the ring
        angle = 2 * np.pi * (slide.t[0] - slide.t[0][0]) / slide.length[0]
        radius = math.sqrt(abs(shoelace(rings[0])) / np.pi)
        centre = np.asarray(_region(rings).centroid.coords[0])
        outer_uv = centre + radius * np.column_stack([np.cos(angle), np.sin(angle)])
    U = tutte_fill(V, F, outer, outer_uv)
    if flipped(U, F):
        raise ValueError(f"Tutte's embedding folds {flipped(U, F)} triangle(s): the cleaned "
                         "mesh is not a disk with holes")
    held = outer if convex else np.zeros(0, dtype=np.int64)
    U, pulled = _pull_onto(V, F, U, weights, held, index, targets, config.pull, config.barrier)
    return U, {"outer_convex": convex, **pulled}


def _near_folds(U: np.ndarray, F: np.ndarray, k: int) -> np.ndarray:
    """Mask of the vertices within ``k`` edges of a folded or flat triangle of ``U``."""
    near = np.zeros(len(U), dtype=bool)
    near[F[_not_positive(U, F)].ravel()] = True
    for _ in range(k):
        near[F[near[F].any(axis=1)].ravel()] = True
    return near


def _landmark_pairs(V: np.ndarray, U: np.ndarray, marks: list, weight: float):
    """The landmark term's pairs for :func:`_descend`'s ``pull``.

    Where a set's targets are curves sampled evenly (:func:`_target_curves`, as a landmark
    file's ``polylines`` are), its points are paired along them by arc length
    (:func:`_curve_pairs`): each curve's points, ordered by where they project on it, are
    spread over its whole length in proportion to their 3D spacing, so the ends reach the
    curve's ends and no stretch of it is left uncovered. Other targets pair each landmark
    point with its nearest target and each target with its nearest landmark point (the two
    halves of a Chamfer distance)."""
    from scipy.spatial import cKDTree

    index, targets = [], []
    for i, q in marks:
        curves = _target_curves(q)
        if curves:
            # Each piece of the landmark points (near one another on the surface) follows
            # the curve nearest to it on average; the targets of a curve no piece follows
            # pull as a Chamfer distance would.
            pieces = _pieces(V[i])
            trees = [cKDTree(q[a:b]) for a, b in curves]
            owner = np.array([np.argmin([np.mean(tree.query(U[i[p]])[0]) for tree in trees])
                              for p in pieces])
            left = np.ones(len(q), dtype=bool)
            for c, (a, b) in enumerate(curves):
                mine = np.concatenate([pieces[k] for k in np.flatnonzero(owner == c)]
                                      + [np.zeros(0, dtype=np.int64)])
                if len(mine):
                    index.append(i[mine])
                    targets.append(_curve_pairs(V[i[mine]], U[i[mine]], q[a:b]))
                    left[a:b] = False
            if left.any():
                index.append(i[cKDTree(U[i]).query(q[left])[1]])
                targets.append(q[left])
            continue
        index.append(i)
        targets.append(q[cKDTree(q).query(U[i])[1]])
        index.append(i[cKDTree(U[i]).query(q)[1]])
        targets.append(q)
    return np.concatenate(index), np.vstack(targets), weight


def _pieces(P: np.ndarray, reach: float = 2.5) -> list[np.ndarray]:
    """The connected pieces of the points ``P``: two points are joined when closer than
    ``reach`` times the median distance of a point to its nearest other point."""
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    if len(P) < 2:
        return [np.arange(len(P))]
    tree = cKDTree(P)
    spacing = float(np.median(tree.query(P, k=2)[0][:, 1]))
    graph = tree.sparse_distance_matrix(tree, reach * max(spacing, 1e-300),
                                        output_type="coo_matrix")
    count, label = connected_components(graph, directed=False)
    return [np.flatnonzero(label == c) for c in range(count)]


def _target_curves(q: np.ndarray, tolerance: float = 0.05) -> list[tuple[int, int]]:
    """The runs ``q[a:b]`` (at least 4 points) whose consecutive points are evenly spaced:
    no gap wider than ``1 + tolerance`` times the run's median gap, and at most a tenth of
    them narrower than ``1 - tolerance`` times it (the chords across a polyline's corners).
    Scattered targets make no run."""
    if len(q) < 4:
        return []
    gaps = np.linalg.norm(np.diff(q, axis=0), axis=1)
    runs, a = [], 0
    while a < len(gaps):
        h = gaps[a]
        b = a
        # Extend while the gaps stay within the tolerance of the run's first full gap.
        while b < len(gaps) and 0 < gaps[b] <= (1 + tolerance) * h:
            b += 1
        g = gaps[a:b]
        if b - a >= 3 and h > 0 and np.mean(g < (1 - tolerance) * h) <= 0.1:
            runs.append((a, b + 1))
            a = b + 1
        else:
            a += 1
    return runs


def _curve_pairs(P: np.ndarray, u: np.ndarray, curve: np.ndarray) -> np.ndarray:
    """Targets on ``curve`` (an evenly sampled polyline, closed when its ends are within two
    of its gaps) for the points ``P`` (3D) mapped to ``u``: ordered by their projection on
    the curve, then spread along it by their cumulative 3D distance."""
    seg = np.linalg.norm(np.diff(curve, axis=0), axis=1)
    cum = np.concatenate([[0.0], np.cumsum(seg)])
    length = cum[-1]
    closed = len(curve) > 3 and np.linalg.norm(curve[-1] - curve[0]) <= 2 * np.median(seg)
    s = _Rings._project(curve, cum, u)  # arc length of each point's nearest on the curve
    order = np.argsort(s, kind="stable")
    if len(order) == 1:
        spread = s[order]
    else:
        step = np.linalg.norm(np.diff(P[order], axis=0), axis=1)
        if closed:
            step = np.append(step, np.linalg.norm(P[order[0]] - P[order[-1]]))
        share = np.concatenate([[0.0], np.cumsum(step)]) / max(step.sum(), 1e-300)
        if closed:  # turned along the loop to move the points least
            spread = share[:-1] * length
            turn = np.angle(np.mean(np.exp(2j * np.pi * (s[order] - spread) / length)))
            spread = (spread + turn * length / (2 * np.pi)) % length
        else:
            spread = share * length
    out = np.empty((len(P), 2))
    out[order] = np.column_stack([np.interp(spread, cum, curve[:, 0]),
                                  np.interp(spread, cum, curve[:, 1])])
    return out


def _snap(F: np.ndarray, U: np.ndarray, index: np.ndarray, targets: np.ndarray
          ) -> np.ndarray:
    """Move the vertices ``index`` onto ``targets`` where that folds nothing: all at once
    when the straight path is clear (:func:`max_feasible_step` > 1), else without the
    vertices of the triangles that would fold, until it is. Returns the mask of ``index``
    that moved (``U`` is updated)."""
    moved = np.ones(len(index), dtype=bool)
    for _ in range(len(index) + 1):
        D = np.zeros_like(U)
        D[index[moved]] = targets[moved] - U[index[moved]]
        after = U + D
        # Flat counts as folded: three loop vertices laid on a straight side of a ring make
        # a triangle of zero area up to rounding, which no barrier can start from.
        bad = np.flatnonzero(_not_positive(after, F))
        if not len(bad) and max_feasible_step(U, F, D) > 1.0 - 1e-6:
            U[index[moved]] = targets[moved]
            return moved
        if not len(bad):  # the path crosses zero and comes back: take the worst triangles
            mid = U + 0.5 * D
            bad = np.flatnonzero(signed_areas(mid, F) <= 0)
        stuck = np.isin(index, F[bad].ravel())
        if not (stuck & moved).any():
            break
        moved &= ~stuck
    return np.zeros(len(index), dtype=bool)


# ------------------------------------------- step 1: cleaning, loops, corners


def _genus(F: np.ndarray) -> int:
    """Handles of the vertex-manifold, connected mesh ``F``: ``(2 - chi - b) / 2`` with
    ``chi = V - E + F`` and ``b`` its boundary loops."""
    edges = unique_edges(F)
    chi = len(np.unique(F)) - len(edges) + len(F)
    return (2 - chi - len(boundary_loops(F))) // 2


def _cut_handles(V: np.ndarray, F: np.ndarray, rounds: int = 30) -> tuple[np.ndarray, int]:
    """Drop triangles until the mesh has no handle: where the local mesh joins two sheets by
    a bridge (closed eyelids or lips without normals: face_human_choi's has 10 handles), no
    flip-free planar map exists. Tutte's embedding of the mesh with its holes filled (on a
    circle) folds where the handles are; those triangles and the ones around them go, and
    the mesh's largest part is kept, until no handle is left. Returns the faces kept and how
    many were dropped."""
    dropped = 0
    for _ in range(rounds):
        if _genus(F) <= 0:
            break
        outer = np.asarray(max(boundary_loops(F), key=lambda loop: np.linalg.norm(
            V[np.roll(loop, -1)] - V[loop], axis=1).sum()))
        step = np.linalg.norm(V[np.roll(outer, -1)] - V[outer], axis=1)
        angle = 2 * np.pi * np.concatenate([[0.0], np.cumsum(step)[:-1]]) / step.sum()
        U = tutte_fill(V, F, outer, np.column_stack([np.cos(angle), np.sin(angle)]))
        # A handle shows as folded triangles, or as a vertex its triangles wind around more
        # than once (angles summing above 2 pi, every triangle positive: on face_human_choi
        # with a hole, at the rim of small holes).
        bad = (signed_areas(U, F) <= 0) | (_angle_sums(U, F)[F] > 2.05 * np.pi).any(axis=1)
        if not bad.any():
            break
        near = np.zeros(int(F.max()) + 1, dtype=bool)
        near[F[bad].ravel()] = True
        drop = near[F].any(axis=1)  # the folded triangles and their neighbours
        before = len(F)
        F, _ = one_fan(main_faces(F[~drop]))
        F = main_faces(F)
        dropped += before - len(F)
    return F, dropped


def _angle_sums(U: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Sum of the unsigned angles of the triangles ``U[F]`` at each vertex, (n,)."""
    sums = np.zeros(len(U))
    for q in range(3):
        a = U[F[:, (q + 1) % 3]] - U[F[:, q]]
        b = U[F[:, (q + 2) % 3]] - U[F[:, q]]
        angle = np.arctan2(np.abs(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]), (a * b).sum(axis=1))
        sums += np.bincount(F[:, q], angle, minlength=len(U))
    return sums


def _rebuild_loops(V: np.ndarray, F: np.ndarray, slide: _Rings
                   ) -> tuple[list[np.ndarray], list[np.ndarray], list[int]]:
    """The boundary loops of the cleaned faces ``F`` matched to the paired loops of
    ``slide`` (the ones sharing most vertices), each vertex with an arc length on its ring:
    a shared vertex keeps its own, the others are spaced between the shared ones as their
    3D distances along the loop are.

    Returns the matched loops (in the order of ``slide``'s), their arc lengths (unwrapped,
    increasing) and, for each, how many of its vertices are new to it.

    Raises
    ------
    ValueError
        A paired loop has no boundary loop left sharing at least three of its vertices.
    """
    t_of = []
    for k, loop in enumerate(slide.loops):
        t_of.append(dict(zip(loop.tolist(), (slide.t[k] % slide.length[k]).tolist())))
    candidates = [np.asarray(loop, dtype=np.int64) for loop in boundary_loops(F)]
    loops, ts, new = [], [], []
    for k in range(len(slide.loops)):
        shared = [sum(v in t_of[k] for v in c.tolist()) for c in candidates]
        best = int(np.argmax(shared)) if candidates else -1
        if best < 0 or shared[best] < 3:
            raise ValueError(f"loops[{k}]: no boundary loop of the cleaned mesh shares three "
                             "of its vertices")
        loop = candidates[best]
        L = slide.length[k]
        known = np.array([v in t_of[k] for v in loop.tolist()])
        # Anchors: the longest run of shared vertices in order along the ring (a rerouted
        # loop can visit a few of them in another order), tried from a few starts.
        best_anchor = None
        for start in np.flatnonzero(known)[:: max(1, int(known.sum()) // 8)]:
            order = np.roll(np.arange(len(loop)), -int(start))
            idx = order[known[order]]
            u = np.array([(t_of[k][int(loop[i])] - t_of[k][int(loop[start])]) % L
                          for i in idx])
            keep = _increasing(u)
            if best_anchor is None or len(keep) > len(best_anchor[1]):
                best_anchor = (int(start), idx[keep], u[keep])
        start, anchor_idx, anchor_u = best_anchor
        loop = np.roll(loop, -start)
        anchors = (anchor_idx - start) % len(loop)
        t0 = t_of[k][int(loop[0])]
        t = np.full(len(loop), np.nan)
        t[anchors] = t0 + anchor_u
        step = np.linalg.norm(V[np.roll(loop, -1)] - V[loop], axis=1)  # (k,) i -> i + 1
        s = np.concatenate([[0.0], np.cumsum(step)])  # 3D arc length, closing vertex last
        at = np.concatenate([anchors, [len(loop)]])
        tv = np.concatenate([t[anchors], [t0 + L]])
        t = np.interp(s[:len(loop)], s[at], tv)
        loops.append(loop)
        ts.append(t)
        new.append(int((~known).sum()))
    return loops, ts, new


def _increasing(u: np.ndarray) -> np.ndarray:
    """Indices of a longest strictly increasing subsequence of ``u`` that starts at ``u[0]``
    (patience sorting)."""
    import bisect

    tails: list[float] = []
    tail_index: list[int] = []
    parent = np.full(len(u), -1)
    for i, x in enumerate(u.tolist()):
        if i and x <= u[0]:
            continue
        j = bisect.bisect_left(tails, x)
        if j == len(tails):
            tails.append(x)
            tail_index.append(i)
        else:
            tails[j] = x
            tail_index[j] = i
        parent[i] = tail_index[j - 1] if j else -1
    out = [tail_index[-1]]
    while parent[out[-1]] >= 0:
        out.append(int(parent[out[-1]]))
    return np.asarray(out[::-1])


def _pin_corners(slide: _Rings, angle: float) -> np.ndarray:
    """Put a loop vertex on each corner of its ring (a turn sharper than ``angle``): the
    nearer of the two around it, unless it is taken. Updates ``slide.t``; returns the
    vertices pinned.

    A sliding vertex cannot pass a corner: the tangent its step follows ends there. And a
    corner no vertex holds is cut off by a chord."""
    pinned = []
    for k, loop in enumerate(slide.loops):
        ring, cum, L = slide.rings[k], slide.cum[k], slide.length[k]
        e = np.diff(ring, axis=0)  # (r, 2) segments; ring[-1] == ring[0]
        nxt = np.roll(e, -1, axis=0)
        turn = np.arctan2(e[:, 0] * nxt[:, 1] - e[:, 1] * nxt[:, 0], (e * nxt).sum(axis=1))
        corners = cum[1:][np.abs(turn) > angle] % L  # arc length of each sharp vertex
        t = slide.t[k]
        u = (t - t[0]) % L  # increasing from 0
        taken = set()
        for c in corners.tolist():
            cu = (c - t[0]) % L
            i = int(np.searchsorted(u, cu, side="right")) - 1  # u[i] <= cu < u[i + 1]
            j = (i + 1) % len(t)
            nearer = [i, j] if cu - u[i] <= ((u[j] if j else L) - cu) else [j, i]
            for q in nearer:
                if q not in taken:
                    taken.add(q)
                    lo = u[q - 1] if q > 0 else (u[-1] - L)
                    hi = u[q + 1] if q + 1 < len(u) else L
                    if lo < cu < hi:
                        u[q] = cu
                    elif lo < cu - L < hi:
                        u[q] = cu - L
                    else:
                        taken.discard(q)
                        continue
                    break
        slide.t[k] = t[0] + u - (u[0] if 0 in taken else 0.0)
        pinned.extend(loop[sorted(taken)].tolist())
    return np.asarray(pinned, dtype=np.int64)


def _scaffold(V: np.ndarray, F: np.ndarray, U: np.ndarray, paired: list[np.ndarray]
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Fill each boundary loop of ``F`` that is not in ``paired`` with a fan to a new vertex
    at its centroid (in 3D and in the map). Returns the vertices, faces and map with the new
    vertices appended (rows ``len(V):``) and the fans after ``F``."""
    taken = set(np.concatenate(paired).tolist())
    points, faces, maps = [V], [F], [U]
    n = len(V)
    for loop in boundary_loops(F):
        if loop[0] in taken:
            continue
        loop = np.asarray(loop)
        c = n + len(points) - 1
        points.append(V[loop].mean(axis=0, keepdims=True))
        maps.append(U[loop].mean(axis=0, keepdims=True))
        # The loop runs along F's boundary edges (a -> b); the fan holds b -> a.
        faces.append(np.column_stack([np.roll(loop, -1), loop, np.full(len(loop), c)]))
    return np.vstack(points), np.vstack(faces), np.vstack(maps)


def _release(U: np.ndarray, F: np.ndarray, loops: list[np.ndarray], rings: list[np.ndarray]
             ) -> np.ndarray:
    """Vertices of the loops that must leave their ring for a flip-free map to exist.

    - **Chords.** An interior edge between two vertices of one loop whose segment leaves the
      domain (a chord of a hole, as every hole's ear has: three consecutive vertices on a
      ring bent away from the triangle) cuts off the loop's arc between them; the part of
      the mesh it bounds cannot fit between the chord and the ring. The vertices strictly
      inside the shorter arc leave the ring (for an ear: its tip).
    - **Triangles.** A triangle whose three corners stay on rings and which is not positive
      there can never turn positive: its corner with the largest angle (the nearest to its
      opposite side) leaves, until none is left.
    """
    import shapely

    n = len(U)
    on = np.zeros(n, dtype=bool)
    loop_of = np.full(n, -1)
    position = np.zeros(n, dtype=np.int64)
    for k, loop in enumerate(loops):
        on[loop] = True
        loop_of[loop] = k
        position[loop] = np.arange(len(loop))
    region = _region(rings)
    shapely.prepare(region)
    edges, counts = unique_edges(F, return_counts=True)
    p, q = edges[counts == 2].T  # interior edges
    same = on[p] & on[q] & (loop_of[p] == loop_of[q])
    p, q = p[same], q[same]
    # Ring vertices are a chord apart along straight segments: far above this tolerance.
    tol = 1e-9 * math.sqrt(abs(region.area))
    out = np.zeros(len(p), dtype=bool)
    for t in (0.25, 0.5, 0.75):
        P = U[p] * (1 - t) + U[q] * t
        pts = shapely.points(P)
        out |= ~shapely.contains_xy(region, P[:, 0], P[:, 1]) & (
            shapely.distance(region, pts) > tol)
    off = np.zeros(n, dtype=bool)
    for a, b in zip(p[out].tolist(), q[out].tolist()):
        loop = loops[loop_of[a]]
        i, j = sorted((position[a], position[b]))
        inner, outer = loop[i + 1:j], np.concatenate([loop[j + 1:], loop[:i]])
        off[inner if len(inner) <= len(outer) else outer] = True
    on &= ~off
    while True:
        bad = np.flatnonzero(on[F].all(axis=1) & _not_positive(U, F))
        if not len(bad):
            break
        T = U[F[bad]]  # (b, 3, 2)
        cosines = []
        for c in range(3):
            e = T[:, (c + 1) % 3] - T[:, c]
            f = T[:, (c + 2) % 3] - T[:, c]
            cosines.append((e * f).sum(axis=1) / np.maximum(
                np.linalg.norm(e, axis=1) * np.linalg.norm(f, axis=1), 1e-300))
        corner = np.argmin(np.stack(cosines, axis=1), axis=1)  # the largest angle
        on[F[bad, corner]] = False
        off[F[bad, corner]] = True
    return np.flatnonzero(off)


def _other_diagonals(F: np.ndarray) -> np.ndarray:
    """For each interior edge ``ab`` of ``F`` (triangles ``abc`` and ``bad``), the two
    triangles of its quad split by the other diagonal, ``adc`` and ``dbc`` (oriented as
    ``F``), (2e, 3)."""
    e = half_edges(F)
    opposite = opposite_corners(F)
    n = int(F.max()) + 1
    code = e[:, 0] * n + e[:, 1]
    order = np.argsort(code)
    twin = np.searchsorted(code[order], e[:, 1] * n + e[:, 0])
    twin = np.clip(twin, 0, len(e) - 1)
    found = code[order][twin] == e[:, 1] * n + e[:, 0]
    i = np.flatnonzero(found & (e[:, 0] < e[:, 1]))
    j = order[twin[i]]
    a, b, c, d = e[i, 0], e[i, 1], opposite[i], opposite[j]
    ok = c != d
    a, b, c, d = a[ok], b[ok], c[ok], d[ok]
    return np.vstack([np.column_stack([a, d, c]), np.column_stack([d, b, c])])


def _place_dropped(U: np.ndarray, F: np.ndarray, F_all: np.ndarray) -> np.ndarray:
    """Vertices of ``F_all`` on no triangle of ``F`` (the tips of dropped triangles) at the
    mean of their neighbours in ``F_all`` that are placed, repeated outwards."""
    placed = np.zeros(len(U), dtype=bool)
    placed[F.ravel()] = True
    edges = half_edges(F_all)
    edges = np.concatenate([edges, edges[:, ::-1]])
    U = U.copy()
    for _ in range(100):
        todo = np.flatnonzero(~placed & np.isin(np.arange(len(U)), F_all.ravel()))
        if not len(todo):
            break
        use = edges[np.isin(edges[:, 0], todo) & placed[edges[:, 1]]]
        if not len(use):
            break
        count = np.bincount(use[:, 0], minlength=len(U))
        for c in range(2):
            total = np.bincount(use[:, 0], U[use[:, 1], c], minlength=len(U))
            U[count > 0, c] = total[count > 0] / count[count > 0]
        placed |= count > 0
    return U


def _region(rings: list[np.ndarray]):
    """The shapely polygon the rings bound: the ring of largest area outside, the rest
    holes."""
    import shapely

    areas = [abs(shoelace(r)) for r in rings]
    outer = int(np.argmax(areas))
    return shapely.Polygon(rings[outer], [r for k, r in enumerate(rings) if k != outer])


def _free_loops_simple(U: np.ndarray, F: np.ndarray, paired: list[np.ndarray]) -> bool:
    """Every boundary loop of ``F`` not in ``paired`` is a simple polygon in ``U``."""
    import shapely

    taken = set(np.concatenate(paired).tolist()) if paired else set()
    for loop in boundary_loops(F):
        if loop[0] in taken:
            continue
        if not shapely.LinearRing(U[loop]).is_simple:
            return False
    return True
