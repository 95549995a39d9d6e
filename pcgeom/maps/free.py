"""The free-boundary conformal map of the local mesh: LSCM, then the conformal factor.

4. **LSCM** (Levy et al. 2002) on the local mesh (:mod:`pcgeom.maps.localmesh`, steps 1-3):
   minimize the conformal energy, the Dirichlet energy (cotangent weights) minus the signed
   area, with two far-apart points pinned. Points outside the mesh's largest connected part
   take the distance-weighted mean of the map at their nearest meshed points (they are
   counted); with the cloud's own normals, the affine fit to their same-sheet ones
   (:data:`pcgeom.maps.localmesh.PLACE_WITH_INPUT_NORMALS`). **Robust rounds**
   (``LocalMeshConfig.robust_rounds``, not in LSCM): a local
   mesh has triangles no surface map can keep conformal with the rest (where a fold bends
   within a spacing or two, across a crease's walls), and least squares spreads their error
   over the whole map. Each round solves again with every triangle's conformal energy
   weighted by ``max(1 / (1 + (d / s)^2), floor)`` (a Cauchy M-estimator, as in iteratively
   reweighted least squares), ``d`` how far from conformal the previous solve mapped it; the
   floor keeps every triangle in the energy, so none is left free to turn over. Measured in
   :class:`pcgeom.config.LocalMeshConfig`. **Normal rounds** (``LocalMeshConfig.
   normal_rounds``, a cloud without normals): where a fold bends within a spacing or two,
   PCA normals lean, the fans there take points of the wrong side of the bend, and the map
   turns some of the mesh's own triangles over. While it turns over more than
   ``normal_round_flips`` of them, the mesh's own vertex normals (an angle-weighted average
   of its triangles, :func:`pcgeom.maps.localmesh.mesh_normals`) replace the normals, and
   the mesh is built and mapped again; the map that turns over fewest is kept. **Upright
   mesh** (``LocalMeshConfig.facing``): the triangles that stand across their corners'
   normals (:func:`pcgeom.maps.localmesh.standing`: a sharp lip's corner cut, a bridge
   between a groove's walls) make handles no flat map holds; a cloud with normals has its
   mesh built without them; a bare one, when the mesh of the normals the rounds kept has
   one, has it built again without them and mapped again, and the map that turns over fewer
   of its own mesh's triangles (then distorts angles less on it) is kept (:func:`_upright`).
5. **Conformal factor.** ``l_i``, the inverse-lambda of LEG, is set so that LEG's
   ``(l_i + l_j) |u_i - u_j|`` matches ``|x_i - x_j|`` at the point's nearest neighbours.

Measured on face_human_choi (17k points, the mesh's oriented normals, evaluated on its true
triangles): 0.0229 rad mean angle distortion and no flipped triangle with 24 neighbours,
0.0276 rad and 0.24% flipped with 16, 0.0403 rad and 0.57% with 12; libigl's LSCM on the true
mesh gives 0.0195. With PCA normals oriented by propagation (:mod:`pcgeom.maps.normals`):
0.034 rad and 3.5% flipped.

:func:`free_map` is the map of a run with the free boundary: the local mesh, LSCM and, when
the config asks for it, a short refinement (:func:`pcgeom.maps.refine.refine`).
"""

from __future__ import annotations

import dataclasses
import time
import warnings

import numpy as np
import torch

from ..neighbours import find_outliers, voted_normals
from ..config import ParamConfig
from ..errors import InputError
from ..mesh import edge_ids, shape_quality
from ..progress import Progress
from ..train.data import TrainData
from ..train.objective import LOSS_TERMS, Objective
from ._sparse import fill_order, ordering_name, solver_name, spd_factor
from .bridges import shows_bridges
from .localmesh import (MIN_MESHED, STANDING_QUALITY, LocalMesh, _submesh, local_mesh,
                        mesh_cloud, mesh_flips, mesh_normals, place_rest, standing,
                        topology_record)
from .refine import refine

__all__ = ["lscm_free", "conformal_factor", "free_map", "free_start"]


def lscm_free(X: np.ndarray, mesh: LocalMesh, *, rounds: int = 0, scale: float = 0.02,
              floor: float = 0.1, stats: dict | None = None) -> np.ndarray:
    """Free-boundary LSCM of the mesh's main part; other points interpolated (step 4).

    ``rounds`` > 0: that many reweighted solves after the first (step 4's robust rounds):
    each triangle's conformal energy weighted by ``max(1 / (1 + (d / scale)^2), floor)``,
    ``d`` its distortion in the previous solve (:func:`_anticonformal`). Each is solved by
    conjugate gradients preconditioned with the plain system's factor: every triangle's
    energy is positive semi-definite, so ``floor Q <= Q_w <= Q`` and the preconditioned
    system's condition number is at most ``1 / floor`` (from the plain solution, 6
    iterations to 1e-10 on a 300k-point cloud; it stops at 1e-9), with no second factor in
    memory (whose fill would be larger: weights couple u and v along every inner edge, where
    plain LSCM couples them on the rim only). ``stats``, when given, receives
    ``downweighted`` (the triangles the last round weighted below 1/2, those the map before
    it kept furthest from conformal) and ``triangles``.

    Returns
    -------
    (N, 2) float64
        The map, centred on its mean and turned to its principal axes (the longer along u;
        a rotation, never a mirror), in the units of LSCM with the two pins one apart.
    """
    import igl
    import scipy.sparse as sp

    main, V, F = _submesh(X, mesh.faces, mesh.main)
    m = len(V)
    # Conformal energy 1/2 u^T (-L (+) -L) u - u^T A u, libigl's LSCM quadratic form.
    L = igl.cotmatrix(V, F)
    Q = sp.csr_matrix(-0.5 * sp.block_diag([L, L]) - igl.vector_area_matrix(F))
    # Pins: the point farthest from the centroid, and the point farthest from it.
    p0 = int(np.argmax(((V - V.mean(axis=0)) ** 2).sum(axis=1)))
    p1 = int(np.argmax(((V - V[p0]) ** 2).sum(axis=1)))
    fixed = np.array([p0, p1, m + p0, m + p1])
    values = np.array([0.0, 1.0, 0.0, 0.0])
    free = np.setdiff1d(np.arange(2 * m), fixed)
    rows = Q[free]
    del Q  # the factorization below is the peak of memory at a million points
    rhs = -(rows[:, fixed] @ values)
    Q_ff = rows[:, free].tocsc()
    del rows
    # Each vertex's two unknowns (u, v) ordered together, the pinned ones left out.
    unknown = np.full(2 * m, -1)
    unknown[free] = np.arange(len(free))
    order = fill_order(L, unknown.reshape(2, m).T)
    del L, unknown
    try:
        solve = spd_factor(Q_ff, order=order)
    except RuntimeError as err:  # SuperLU on a singular system: no unique map either
        raise InputError(DEGENERATE) from err
    del Q_ff
    z = solve(rhs)
    _check_finite(z)

    def whole(z_free):  # all 2m unknowns: the pins' values and the free ones
        x = np.empty(2 * m)
        x[fixed] = values
        x[free] = z_free
        return x

    for _ in range(rounds):
        flat = whole(z)
        d = _anticonformal(V, F, flat[:m], flat[m:])
        del flat
        # A triangle whose distortion is undefined (none on distinct points) gets the floor.
        weights = np.where(np.isfinite(d), np.maximum(1.0 / (1.0 + (d / scale) ** 2), floor),
                           floor)
        del d
        if stats is not None:
            stats.update(downweighted=int((weights < 0.5).sum()), triangles=len(F))
        form = _weighted_form(V, F, weights)
        del weights

        def apply(x_free, form=form):  # Q_w restricted to the free unknowns
            x = np.zeros(2 * m)
            x[free] = x_free
            return _apply_form(form, x)[free]

        pinned = np.zeros(2 * m)
        pinned[fixed] = values
        rhs = -_apply_form(form, pinned)[free]
        z = _preconditioned_cg(apply, rhs, solve, z)
        del form, pinned, rhs
        _check_finite(z)
    del solve, V, F
    flat = whole(z)
    U = np.full((len(X), 2), np.nan)
    U[main] = np.column_stack([flat[:m], flat[m:]])
    return _principal_pose(place_rest(X, U, mesh))


DEGENERATE = ("the local mesh of the cloud is degenerate (LSCM has no unique solution); try "
              "more neighbours or the 'networks' preset")
"""The message of the :class:`InputError` for a local mesh whose LSCM system is singular."""


def _check_finite(z: np.ndarray) -> None:
    if not np.isfinite(z).all():
        raise InputError(DEGENERATE)


def _preconditioned_cg(apply, b: np.ndarray, solve, x0: np.ndarray, rtol: float = 1e-9,
                       maxiter: int = 100) -> np.ndarray:
    """``A x = b`` by conjugate gradients, ``A`` given by its product ``apply(x)``,
    preconditioned with ``solve`` (an approximate inverse of ``A``), from ``x0``. ``rtol``
    1e-9 of the right-hand side's norm: a map far finer than its points' accuracy, and within
    reach of double precision on systems of millions of unknowns."""
    from scipy.sparse.linalg import LinearOperator, cg

    n = len(b)
    A = LinearOperator((n, n), matvec=apply, dtype=np.float64)
    M = LinearOperator((n, n), matvec=solve, dtype=np.float64)
    x, info = cg(A, b, x0=x0, rtol=rtol, maxiter=maxiter, M=M)
    if info != 0:
        import warnings

        warnings.warn(f"robust LSCM: conjugate gradients stopped after {maxiter} iterations "
                      "short of their tolerance; the map is the last iterate", stacklevel=3)
    return x


def _weighted_form(V: np.ndarray, F: np.ndarray, weights: np.ndarray) -> tuple:
    """LSCM's quadratic form with each triangle's conformal energy weighted, on the mesh's
    undirected edges ``lo < hi``: ``(lo, hi, C, S, D)``.

    Triangle ``t``'s conformal energy is its Dirichlet energy minus its signed area in the
    map, ``w_t (1/2 sum_e cot(theta_e) |u_a - u_b|^2 / 2 - A_t)``, ``theta_e`` the angle
    opposite edge ``e = (a, b)`` and ``A_t = 1/2 sum_(a -> b) (u_a v_b - u_b v_a)`` over its
    three edges as it turns. Summed per edge: ``C_e`` (the weighted half cotangents over
    2), ``S_e`` (the weighted area terms over 4, signed for ``lo -> hi``), and ``D_i`` (the
    sum of ``C_e`` at vertex ``i``). As a matrix (:func:`_apply_form`), with every weight 1,
    libigl's ``-1/2 (L (+) L) - vector_area_matrix`` (tests/test_maps_localmesh.py; the
    area terms of inner edges then cancel). Kept on edges, not as a sparse matrix: at a
    million points the matrix and its assembly would hold about a gigabyte beside the
    factor.
    """
    import igl

    m = len(V)
    # Column k's edge, opposite corner k, as the triangle turns: (a, b) rows, one array.
    ab = np.stack([F[:, [1, 2, 0]], F[:, [2, 0, 1]]], axis=-1).reshape(-1, 2)
    a, b = ab[:, 0], ab[:, 1]
    c = 0.5 * (igl.cotmatrix_entries(V, F) * weights[:, None]).ravel()
    q = np.repeat(0.25 * weights, 3) * np.where(a < b, 1.0, -1.0)
    inverse = edge_ids(ab)  # each undirected edge once
    n_edges = int(inverse.max(initial=-1)) + 1
    lo, hi = np.empty(n_edges, dtype=np.int64), np.empty(n_edges, dtype=np.int64)
    lo[inverse], hi[inverse] = np.minimum(a, b), np.maximum(a, b)
    del ab, a, b
    C = np.bincount(inverse, weights=c, minlength=n_edges)
    S = np.bincount(inverse, weights=q, minlength=n_edges)
    del inverse, c, q
    D = np.bincount(lo, weights=C, minlength=m) + np.bincount(hi, weights=C, minlength=m)
    return lo, hi, C, S, D


def _apply_form(form: tuple, x: np.ndarray) -> np.ndarray:
    """The form of :func:`_weighted_form` times ``x = (u, v)`` (2m,): for each edge,
    ``-C`` between its ends in each block and ``-S`` on ``(u_lo, v_hi)``, ``+S`` on
    ``(u_hi, v_lo)`` (both ways), ``D`` on the diagonal."""
    lo, hi, C, S, D = form
    m = len(D)
    u, v = x[:m], x[m:]
    yu = D * u - np.bincount(lo, weights=C * u[hi] + S * v[hi], minlength=m) \
        - np.bincount(hi, weights=C * u[lo] - S * v[lo], minlength=m)
    yv = D * v - np.bincount(lo, weights=C * v[hi] - S * u[hi], minlength=m) \
        - np.bincount(hi, weights=C * v[lo] + S * u[lo], minlength=m)
    return np.concatenate([yu, yv])


def _anticonformal(V: np.ndarray, F: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """How far each triangle's map is from conformal: ``|J_a| / |J_c|``, the anti-conformal
    over the conformal part of its Jacobian (0 for a similarity, 1 for a degenerate map,
    above 1 for a turned-over triangle). (M,)"""
    e1, e2 = V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]
    n = np.cross(e1, e2)
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
    x = e1 / np.maximum(np.linalg.norm(e1, axis=1, keepdims=True), 1e-300)
    y = np.cross(n, x)
    # The triangle in its own plane: p1 = (|e1|, 0), p2 = (e2.x, e2.y); the map's edges.
    p1, p2x, p2y = np.linalg.norm(e1, axis=1), (e2 * x).sum(axis=1), (e2 * y).sum(axis=1)
    f1 = np.column_stack([u[F[:, 1]] - u[F[:, 0]], v[F[:, 1]] - v[F[:, 0]]])
    f2 = np.column_stack([u[F[:, 2]] - u[F[:, 0]], v[F[:, 2]] - v[F[:, 0]]])
    det = np.maximum(p1 * p2y, 1e-300)
    # J = [f1 f2] [[p1, p2x], [0, p2y]]^-1
    j11, j21 = f1[:, 0] / p1, f1[:, 1] / p1
    j12 = (f2[:, 0] * p1 - f1[:, 0] * p2x) / det
    j22 = (f2[:, 1] * p1 - f1[:, 1] * p2x) / det
    conformal = np.hypot(j11 + j22, j21 - j12)
    anti = np.hypot(j11 - j22, j12 + j21)
    return anti / np.maximum(conformal, 1e-300)


def _principal_pose(U: np.ndarray) -> np.ndarray:
    """``U`` centred and rotated so that its principal axes are u and v (deterministic signs)."""
    U = U - U.mean(axis=0)
    _, _, Vt = np.linalg.svd(U, full_matrices=False)
    R = Vt.T  # columns: principal directions
    # Signs: the largest component of the first axis positive, then no mirror (det +1).
    R[:, 0] *= np.sign(R[np.argmax(np.abs(R[:, 0])), 0]) or 1.0
    if np.linalg.det(R) < 0:
        R[:, 1] = -R[:, 1]
    return U @ R


def conformal_factor(X: np.ndarray, U: np.ndarray, neighbours: int = 8) -> np.ndarray:
    """``l_i = median_j |x_i - x_j| / (2 |u_i - u_j|)`` over the nearest neighbours (step 5).

    LEG compares ``|x_i - x_j|`` with ``(l_i + l_j) |u_i - u_j|``; with this ``l`` they agree
    where the map is locally a similarity.
    """
    from scipy.spatial import cKDTree

    k = min(neighbours, len(X) - 1)
    _, nb = cKDTree(X).query(X, k + 1)
    d3 = np.linalg.norm(X[nb[:, 1:]] - X[:, None, :], axis=-1)
    d2 = np.linalg.norm(U[nb[:, 1:]] - U[:, None, :], axis=-1)
    ratio = d3 / np.maximum(d2, 1e-12 * max(float(d3.max()), 1e-300))
    return 0.5 * np.median(ratio, axis=1)


def mesh_for(Xn: np.ndarray, normals: np.ndarray | None, config: ParamConfig, *,
             progress: bool, outlier: np.ndarray | None = None, **where
             ) -> tuple[LocalMesh, np.ndarray, dict]:
    """The local mesh of the cloud as ``config.local_mesh`` sets it
    (:func:`pcgeom.maps.localmesh.mesh_cloud`; ``outlier``: its strays, when already found;
    ``where``: ``onto``, the planar domain's name, or ``closed=True``)."""
    settings = config.local_mesh
    outlier = find_outliers(Xn) if outlier is None else np.asarray(outlier, dtype=bool)
    return mesh_cloud(Xn, normals, settings.neighbours, settings.normal_neighbours,
                      progress=progress, normal_scales=settings.normal_scales,
                      normal_tolerance=settings.normal_tolerance, outlier=outlier, **where)


def free_start(Xn: np.ndarray, normals: np.ndarray | None, config: ParamConfig, *,
               progress: bool, outlier: np.ndarray | None = None, onto: str = "free"
               ) -> tuple[np.ndarray, LocalMesh, np.ndarray, dict]:
    """The local mesh of the cloud (:func:`pcgeom.maps.localmesh.mesh_cloud`; ``outlier``:
    its strays, when already found) and its free LSCM map: where every local-mesh map
    starts; a closed cloud is refused before any map (``onto``: the planar domain's name,
    :func:`pcgeom.maps.topology.require_open`). With estimated normals and a map that turns
    over more than
    ``LocalMeshConfig.normal_round_flips`` of its own triangles, the normal rounds follow
    (step 4 of the module's description); then, with estimated normals, the upright mesh
    (:func:`_upright`), the voted normals (:func:`_voted`), the second orientation
    (:func:`_arc_oriented`) and the mesh with its bridges cut (:func:`_cut`), each kept
    when its map scores better on its own mesh.

    Returns the map ``(N, 2)``, the mesh, the normals (estimated when ``normals`` is None)
    and the start of the history record (its ``seconds``: this step's; the map that goes on
    from here adds its own)."""
    t0 = time.perf_counter()
    settings = config.local_mesh
    outlier = find_outliers(Xn) if outlier is None else np.asarray(outlier, dtype=bool)
    facing = settings.facing or None
    mesh, normals, record = mesh_for(Xn, normals, config, progress=progress, outlier=outlier,
                                     onto=onto, facing=None if normals is None else facing)

    def solve(mesh: LocalMesh) -> tuple[np.ndarray, dict]:
        stats: dict = {}
        uv = lscm_free(Xn, mesh, rounds=settings.robust_rounds, scale=settings.robust_scale,
                       floor=settings.robust_floor, stats=stats)
        return uv, stats

    uv, robust = solve(mesh)
    record["normal_rounds"] = 0
    if record["normals"] == "estimated" and settings.normal_rounds > 0:
        uv, mesh, normals, robust = _normal_rounds(Xn, (uv, mesh, normals, robust), solve,
                                                   settings, outlier=outlier, record=record,
                                                   progress=progress)
    if record["normals"] == "estimated" and facing is not None:
        uv, mesh, robust = _upright(Xn, (uv, mesh, normals, robust), solve, settings,
                                    outlier=outlier, record=record)
    if record["normals"] == "estimated" and settings.vote:
        uv, mesh, normals, robust = _voted(Xn, (uv, mesh, normals, robust), solve, settings,
                                           outlier=outlier, record=record)
    if record["normals"] == "estimated" and ARC_ORIENT:
        uv, mesh, normals, robust = _arc_oriented(Xn, (uv, mesh, normals, robust), solve,
                                                  settings, outlier=outlier, record=record)
    if record["normals"] == "estimated" and CUT_ROUNDS:
        uv, mesh, normals, robust = _cut(Xn, (uv, mesh, normals, robust), solve, settings,
                                         outlier=outlier, record=record)
    if settings.uv_remesh:
        uv, mesh, robust = _uv_remeshed(Xn, (uv, mesh, normals, robust), solve,
                                        outlier=outlier, record=record)
    record["robust_rounds"] = settings.robust_rounds
    # Triangles the robust round weighted below 1/2 (None without a round).
    record["robust_downweighted"] = robust.get("downweighted")
    record["solver"] = solver_name()  # the sparse factorization that ran, and its ordering
    record["ordering"] = ordering_name()
    record["seconds"] = time.perf_counter() - t0
    return uv, mesh, normals, record


def _upright(Xn: np.ndarray, kept: tuple, solve, settings, *, outlier: np.ndarray,
             record: dict) -> tuple:
    """The local mesh of the kept normals built again without the triangles that stand
    across their corners' normals (``settings.facing``, :func:`pcgeom.maps.localmesh.standing`)
    and mapped, when the kept mesh has such a triangle: ``(uv, mesh, stats)`` of the better
    map (:func:`_map_score`: fewer flips of its own mesh, then the smaller angle distortion
    on it; the kept one on ties); ``kept``'s (``(uv, mesh, normals, stats)``) when the kept
    mesh has no standing triangle or the new mesh is no open surface. ``record`` receives
    ``standing`` (the kept mesh's standing triangles), ``upright`` (whether the new map was
    kept), ``upright_flips`` (the two maps' own flips, kept first) and, when kept,
    ``standing_cut`` (triangles the mesh lost) and the new mesh's ``faces``,
    ``boundary_edges``, ``unmeshed`` and topology."""
    uv, mesh, normals, stats = kept
    record.update(standing=_standing_count(Xn, mesh, normals, settings.facing), upright=False)
    if record["standing"] == 0:  # the build without them would make this very mesh
        return uv, mesh, stats
    upright = local_mesh(Xn, normals, settings.neighbours, exclude=outlier,
                         facing=settings.facing)
    if upright.main.mean() < MIN_MESHED or upright.looks_closed:
        return uv, mesh, stats
    uv_up, stats_up = solve(upright)
    before, after = _map_score(Xn, mesh, uv), _map_score(Xn, upright, uv_up)
    record["upright_flips"] = [before[0], after[0]]
    if after >= before:
        return uv, mesh, stats
    record.update(upright=True, standing_cut=mesh.n_faces - upright.n_faces,
                  faces=upright.n_faces, boundary_edges=upright.boundary_edges,
                  unmeshed=int((~upright.main).sum()), **topology_record(upright.topology))
    return uv_up, upright, stats_up


VOTE_TURN = np.radians(30.0)
"""A normal the vote turns by more than this is one it corrected (:func:`_voted`)."""

VOTE_SHARE = 0.005
"""The share of the points whose normal the vote must turn by :data:`VOTE_TURN` for the mesh
to be built again from the voted normals (:func:`_voted`): the deep-fold sheet with walls 1.5
spacings apart 1.2%, face_human_choi 1.3% (its voted mesh then leaves 252 more points out and
is not compared), the pleats, the grooves 2-3 spacings wide and the other shared surfaces
0-0.15% (no build)."""

VOTE_UNMESHED = 0.002
"""The share of the points a mesh of the voted normals (:func:`_voted`) may leave out of its
main part beyond those the kept mesh leaves out; more, and it is not compared (a mesh that
leaves a hard place out maps the rest better on its own triangles: face_human_choi's voted
mesh, 69 -> 321 points out, reads 20 -> 4 own flips but maps its true mesh at 0.0382 rad
against 0.0325)."""

VOTE_ROUNDS = 3
"""Rounds of the voted mesh's own vertex normals (:func:`pcgeom.maps.localmesh.mesh_normals`)
after the vote, each kept while its map scores better (:func:`_voted`): the vote mends the
walls, the mesh's normals then the groove's bottom, whose half circle is narrower than a
spacing and whose PCA plane stands across it."""

VOTE_ALLOW = 1e-4
"""The share of its own triangles a map of the voted normals may turn over without counting
against it (:func:`_voted`): one flip in ten thousand triangles is a sliver's rounding
(the deep-fold sheet, walls 1.5 spacings apart, 6000 points: the map whose own angle
distortion is 0.0075 against 0.0169 turns one of its 11900 triangles over)."""

VOTE_GAIN = 0.95
"""With as many counted flips, the map of the voted normals is kept only when its angle
distortion on its own mesh is at most this share of the kept map's."""


def _voted(Xn: np.ndarray, kept: tuple, solve, settings, *, outlier: np.ndarray,
           record: dict) -> tuple:
    """The local mesh built again from the kept normals voted again
    (:func:`pcgeom.neighbours.voted_normals`: where the plane of a point's own sheet holds
    clearly more of its neighbours than its normal's plane, as at a narrow groove's walls),
    with the upright rule (``settings.facing``), mapped, and rebuilt from its own normals for
    up to :data:`VOTE_ROUNDS` rounds while that maps better; done when the vote turns over
    :data:`VOTE_SHARE` of the normals. Returns ``(uv, mesh, normals, stats)`` of the better
    of that map and the kept one (:func:`_score_above`: own flips beyond
    :data:`VOTE_ALLOW`, then angle distortion on the own mesh, the new one needing
    :data:`VOTE_GAIN` of the kept one's), ``kept`` otherwise. ``record`` receives ``voted``
    (normals the vote turned), ``voted_kept``, ``voted_scores`` (each map's ``[flips,
    angle]``, the kept first) and, when kept, the new mesh's ``faces``, ``boundary_edges``,
    ``unmeshed`` and topology."""
    uv, mesh, normals, stats = kept
    inliers = np.flatnonzero(~outlier)
    found = voted_normals(Xn[inliers], normals[inliers])[0]
    turned = np.abs(np.einsum("nd,nd->n", found, normals[inliers])) < np.cos(VOTE_TURN)
    record.update(voted=int(turned.sum()), voted_kept=False)
    if turned.sum() < VOTE_SHARE * len(inliers):
        return kept
    voted = normals.copy()
    voted[inliers] = found
    best, scores = _rebuilt(Xn, voted, kept, solve, settings, outlier=outlier, bridges=False,
                            rounds=VOTE_ROUNDS)
    record["voted_scores"] = [list(s) for s in scores]
    if not _better(best, scores[0], VOTE_ALLOW * mesh.n_faces, VOTE_GAIN):
        return kept
    again = best[1]
    record.update(voted_kept=True, faces=again.n_faces, boundary_edges=again.boundary_edges,
                  unmeshed=int((~again.main).sum()), **topology_record(again.topology))
    return best[:4]


def _rebuilt(Xn: np.ndarray, normals: np.ndarray, kept: tuple, solve, settings, *,
             outlier: np.ndarray, bridges: bool, rounds: int, through: bool = False,
             source: tuple | None = None) -> tuple:
    """The local mesh built from ``normals`` (``bridges``: with its bridges cut,
    :func:`pcgeom.maps.localmesh.local_mesh`; the upright rule, ``settings.facing``),
    mapped, and rebuilt from its own vertex normals
    (:func:`pcgeom.maps.localmesh.mesh_normals`) for up to ``rounds`` rounds while each maps
    better on its own mesh (:func:`_score_above`, flips beyond :data:`VOTE_ALLOW` of the kept
    mesh's triangles, then angle). A mesh that looks closed ends the rounds; one that leaves
    :data:`VOTE_UNMESHED` more points out than the kept one (``kept``, ``(uv, mesh, normals,
    stats)``) is not compared and ends them too, unless ``through``: then its own normals
    start the next round (those of points whose normals its cut left out come back from
    their meshed neighbours'). ``source``: ``(mesh, its normals)`` whose own vertex normals
    the first round is built from instead of ``normals``. Returns the best ``(uv, mesh,
    normals, stats, score)`` (None when no mesh qualified) and the scores
    (:func:`_map_score`), the kept map's first."""
    uv, mesh, _, _ = kept
    limit = (~mesh.main).sum() + VOTE_UNMESHED * len(Xn)
    allow = VOTE_ALLOW * mesh.n_faces
    scores = [_map_score(Xn, mesh, uv)]
    best = None  # source: the mesh and normals the next round starts from
    for _ in range(1 + rounds):
        if source is not None:
            normals = mesh_normals(Xn, *source)
        again = local_mesh(Xn, normals, settings.neighbours, exclude=outlier, bridges=bridges,
                           facing=settings.facing or None)
        if again.looks_closed:
            break
        # A mesh that leaves more points out maps fewer hard places: no comparison.
        if (~again.main).sum() > limit:
            if not through:
                break
            source = (again, normals)
            continue
        uv_again, stats_again = solve(again)
        scores.append(_map_score(Xn, again, uv_again))
        if best is not None and _score_above(scores[-1], allow) >= _score_above(best[4], allow):
            break
        best, source = (uv_again, again, normals, stats_again, scores[-1]), (again, normals)
    return best, scores


def _better(best: tuple | None, score: tuple, allow: float, gain: float = 1.0) -> bool:
    """Whether :func:`_rebuilt`'s ``best`` maps better on its own mesh than ``score`` does
    on its (:func:`_score_above`; the kept one's angle times ``gain``)."""
    return best is not None and _score_above(best[4], allow) < _score_above(score, allow, gain)


ARC_ORIENT = True
"""A bare cloud whose kept local mesh has handles gets a second orientation
(:func:`_arc_oriented`). Measured side by side (``fast`` onto free, true triangles, one run
each, 2026-12-06): the lips sheet 11k bare seeds 1 / 2 0.0827 / 0.0662 rad, 2.82 / 5.21%
flipped -> 0.0656 / 0.0613, 1.98 / 2.54% (genus 9 / 13 -> 0 / 6); seed 0 not kept (its new
mesh leaves 49 points out, 26 before: over :data:`VOTE_UNMESHED`); face_human_choi bare
0.0325, 2.46% -> 0.0311, 2.06% (genus 2 -> 0); the pleats and the other shared open
surfaces have no handle: unchanged. Why: on the bare lips sheet 958 of the 1070 true
triangles the map turns over (seed 0) have a corner whose final normal points the wrong
way (476 points, in patches of up to 150 on the walls and bulbs), and the fans of a
wall turned over mix it with the facing wall (586 of the mesh's edges join the two walls):
those are the handles. With the signs of the PCA lines taken from the truth the same
pipeline maps at 1.10 / 1.26 / 1.51% flipped, and with bridges cut as well at 0.0432 /
0.0508 / 0.0355 rad, 0.92 / 1.18 / 0.93%."""


def _arc_oriented(Xn: np.ndarray, kept: tuple, solve, settings, *, outlier: np.ndarray,
                  record: dict) -> tuple:
    """When the kept mesh has handles (genus > 0): the kept normals re-signed as a whole
    (:func:`pcgeom.maps.normals.arc_signs`, which does not cross a thin gap the way a
    spanning tree does), the local mesh built again from them with its bridges cut
    (:func:`pcgeom.maps.localmesh.local_mesh` ``bridges=True``: on normals oriented across
    the gap the rule had nothing to cut), mapped, and kept when its map scores better on its
    own mesh (:func:`_score_above`, flips beyond :data:`VOTE_ALLOW`, then angle) without
    leaving :data:`VOTE_UNMESHED` more points out. ``record`` receives ``arc_turned``
    (normals turned), ``arc_kept``, ``arc_unmeshed`` and ``arc_scores`` (the two maps'
    ``[flips, angle]``, the kept first) when built, and, when kept, the new mesh's
    ``faces``, ``boundary_edges``, ``unmeshed`` and topology."""
    from ..neighbours import Neighbours
    from .normals import arc_signs

    uv, mesh, normals, stats = kept
    record.update(arc_turned=0, arc_kept=False)
    if mesh.topology is None or mesh.topology.genus <= 0:
        return kept
    inliers = np.flatnonzero(~outlier)
    nb = Neighbours.of(Xn[inliers], settings.normal_neighbours).first(
        settings.normal_neighbours)[1]
    sign = arc_signs(Xn[inliers], normals[inliers], nb)
    record["arc_turned"] = int((sign < 0).sum())
    if not (sign < 0).any():
        return kept
    turned = normals.copy()
    turned[inliers] *= sign[:, None]
    again = local_mesh(Xn, turned, settings.neighbours, exclude=outlier, bridges=True,
                       facing=settings.facing or None)
    limit = (~mesh.main).sum() + VOTE_UNMESHED * len(Xn)
    record["arc_unmeshed"] = int((~again.main).sum())
    if again.looks_closed or (~again.main).sum() > limit:
        return kept
    uv_again, stats_again = solve(again)
    allow = VOTE_ALLOW * mesh.n_faces
    scores = [_map_score(Xn, mesh, uv), _map_score(Xn, again, uv_again)]
    record["arc_scores"] = [list(s) for s in scores]
    if _score_above(scores[1], allow) >= _score_above(scores[0], allow):
        return kept
    record.update(arc_kept=True, faces=again.n_faces, boundary_edges=again.boundary_edges,
                  unmeshed=int((~again.main).sum()), **topology_record(again.topology))
    return uv_again, again, turned, stats_again


CUT_ROUNDS = 3
"""Rounds of the local mesh with its bridges cut, from its own vertex normals, after the
first built from the kept normals (:func:`_cut`); 0: no such mesh for a bare cloud.

Why (bare :func:`pcgeom.synthetic_folds.deep_folds`, uniformly sampled, walls 1.5 spacings
apart, 6000 points, seeds 0 / 1): the kept normals are no longer the trouble (24 / 39 points
over 30 degrees off, none turned), the mesh is: 37 / 55 of its edges join a groove's two
walls. Its mesh with the true normals maps at 0.0214 / 0.0195 rad, with its bridges cut at
0.0093 / 0.0095; the estimated normals' mesh with its bridges cut at 0.0185 / 0.0124, and
rebuilt once from its own vertex normals at 0.0105 / 0.0123 (exact map 0.0066). Where the
first cut mesh leaves points out (2500 points, seed 0: 26, the kept mesh 11), its own
normals bring them back in the next round (122 -> 28 normals over 30 degrees off).
Measured side by side (``fast``, bare, seed 0, true triangles, with the unmeshed points'
placement from their rings, :data:`pcgeom.maps.localmesh.PLACE_BY_RINGS`; off -> on, load
7-9 on 2 cores): those grooves 0.0185 rad, 20 flipped -> 0.0089, 7 (1.35x the exact map),
seed 1 0.0513, 46 -> 0.0112, 6; 2 / 3 spacings apart 0.0073 / 0.0053 -> 0.0069 / 0.0053
(seed 1 0.0070 / 0.0062 -> 0.0070 / 0.0059), 1 -> 2 / 0 flipped; evenly sampled 1.5 / 2
apart 0.0099, 8 -> 0.0077, 5 / 0.0030 -> 0.0029; the pleats 1.5 / 2 / 2.5 spacings wide
0.0155, 38 -> 0.0110, 1 / 0.0055 -> 0.0055 / 0.0036, 1 -> 0.0032, 0 (cloud seed 1: 0.0382,
90 -> 0.0353, 55 / 0.0102, 1 -> 0.0058, 0 / 0.0045 -> 0.0037); face_human_choi free 0.0310,
702 -> 0.0278, 628, onto the disk 0.0324, 714 -> 0.0315, 624; peaks_three_cgal free 0.0406
-> 0.0402; face_3holes_small_choi and peaks_7holes_choi, free and disk, the same. It costs a
mesh and a solve a round (at least one where the kept mesh shows a bridge,
:func:`pcgeom.maps.bridges.shows_bridges`; wall time 1.3-1.6x on face_human_choi)."""


def _cut(Xn: np.ndarray, kept: tuple, solve, settings, *, outlier: np.ndarray,
         record: dict) -> tuple:
    """The local mesh of the kept normals built again with its bridges cut
    (:func:`pcgeom.maps.localmesh.local_mesh` ``bridges=True``: lids of one-sided stars,
    triangles turned from their corners' normals, bridges whose cut lowers the genus), then
    from its own vertex normals for up to :data:`CUT_ROUNDS` rounds (:func:`_rebuilt`), and
    kept when its map scores better on its own mesh (:func:`_score_above`: flips beyond
    :data:`VOTE_ALLOW`, then angle) without leaving :data:`VOTE_UNMESHED` more points out.
    ``record`` receives ``cut_kept`` and ``cut_scores`` (each map's ``[flips, angle]``, the
    kept first) and, when kept, the new mesh's ``faces``, ``boundary_edges``, ``unmeshed``
    and topology. Not run on a kept mesh that shows no bridge
    (:func:`pcgeom.maps.bridges.shows_bridges`)."""
    uv, mesh, normals, stats = kept
    if not shows_bridges(Xn, normals, mesh.faces):
        record.update(cut_kept=False, cut_scores=[])
        return kept
    # The second orientation's kept mesh is this very build of these normals: its rounds
    # start from its own normals.
    again = record.get("arc_kept", False)
    best, scores = _rebuilt(Xn, normals, kept, solve, settings, outlier=outlier, bridges=True,
                            rounds=CUT_ROUNDS - again, through=True,
                            source=(mesh, normals) if again else None)
    record.update(cut_kept=False, cut_scores=[list(s) for s in scores])
    if not _better(best, scores[0], VOTE_ALLOW * mesh.n_faces):
        return kept
    again = best[1]
    record.update(cut_kept=True, faces=again.n_faces, boundary_edges=again.boundary_edges,
                  unmeshed=int((~again.main).sum()), **topology_record(again.topology))
    return best[:4]


def _uv_remeshed(Xn: np.ndarray, kept: tuple, solve, *, outlier: np.ndarray, record: dict
                 ) -> tuple:
    """:func:`pcgeom.maps.uvmesh.remeshed` (``LocalMeshConfig.uv_remesh``)."""
    from .uvmesh import remeshed

    return remeshed(Xn, kept, solve, outlier=outlier, record=record)


def _score_above(score: tuple, allow: float, gain: float = 1.0) -> tuple[float, float]:
    """A :func:`_map_score` ``(flips, angle)`` to compare: the flips beyond ``allow``, the
    angle times ``gain``."""
    return max(score[0] - allow, 0.0), gain * score[1]


def _standing_count(Xn: np.ndarray, mesh: LocalMesh, normals: np.ndarray, facing: float
                    ) -> int:
    """How many of the mesh's triangles of shape quality over
    :data:`pcgeom.maps.localmesh.STANDING_QUALITY` stand across their corners' normals
    (:func:`pcgeom.maps.localmesh.standing`): those a build with ``facing`` leaves out."""
    F = mesh.faces
    cross = np.cross(Xn[F[:, 1]] - Xn[F[:, 0]], Xn[F[:, 2]] - Xn[F[:, 0]])
    shaped = shape_quality(Xn, F, cross) > STANDING_QUALITY
    return int((standing(cross[shaped], normals[F[shaped]], facing)).sum())


def _map_score(Xn: np.ndarray, mesh: LocalMesh, uv: np.ndarray) -> tuple[int, float]:
    """``(flips, angle)``: the triangles of its own mesh the map turns over
    (:func:`pcgeom.maps.localmesh.mesh_flips`) and its mean absolute angle distortion on
    that mesh's main part (:func:`pcgeom.metrics.angle_distortion`)."""
    from ..metrics import angle_distortion

    F = mesh.faces[mesh.main[mesh.faces].all(axis=1)]
    return mesh_flips(Xn, mesh, uv)["count"], float(angle_distortion(Xn, F, uv).mean_abs)


NORMAL_ROUND_PATIENCE = 1
"""Normal rounds in a row that may turn over no fewer of their own triangles than the best
map so far before the rounds stop (:attr:`pcgeom.config.LocalMeshConfig.normal_rounds`)."""


def _normal_rounds(Xn: np.ndarray, first: tuple, solve, settings, *, outlier: np.ndarray,
                   record: dict, progress: bool) -> tuple:
    """Step 4's normal rounds: the local mesh rebuilt from its own vertex normals, and mapped
    again, while its map turns over more than ``settings.normal_round_flips`` of its
    triangles; the map that turns over fewest is kept (the first on ties).

    ``first`` is ``(uv, mesh, normals, stats)`` of the first map and so is the result;
    ``record`` receives ``normal_rounds`` (rounds made), ``normal_round_kept`` (0: the first
    map), ``own_flips`` (each map's count, :func:`pcgeom.maps.localmesh.mesh_flips`) and the
    kept mesh's ``faces``, ``boundary_edges`` and ``unmeshed``."""
    best = first
    counted = _own_flips(Xn, first[1], first[0])
    flips, faces = [counted["count"]], counted["faces"]
    kept, stale, mesh, normals = 0, 0, first[1], first[2]
    best_said: list = []
    if flips[0] <= settings.normal_round_flips * max(faces, 1):
        record.update(normal_rounds=0, normal_round_kept=0, own_flips=flips)
        return best
    with Progress(settings.normal_rounds, "normal rounds", enabled=progress,
                  unit="round") as bar:
        while (len(flips) <= settings.normal_rounds and stale < NORMAL_ROUND_PATIENCE
               and flips[kept] > settings.normal_round_flips * max(faces, 1)):
            normals = mesh_normals(Xn, mesh, normals)
            mesh = local_mesh(Xn, normals, settings.neighbours, exclude=outlier)
            # A map's warnings (its solver's) are said only if it is kept.
            with warnings.catch_warnings(record=True) as said:
                warnings.simplefilter("always")
                try:
                    if mesh.main.mean() < MIN_MESHED or mesh.looks_closed:
                        raise InputError("not one open surface")
                    uv, stats = solve(mesh)
                    counted = _own_flips(Xn, mesh, uv)
                except InputError:  # a degenerate mesh: this round counts as no better
                    counted = {"count": np.iinfo(np.int64).max, "faces": 0}
            flips.append(counted["count"])
            bar.update()
            if flips[-1] < flips[kept]:
                kept, stale, faces = len(flips) - 1, 0, counted["faces"]
                best, best_said = (uv, mesh, normals, stats), said
            else:
                stale += 1
    for w in best_said:
        warnings.warn(w.message, w.category, stacklevel=2)
    flips = [None if f == np.iinfo(np.int64).max else f for f in flips]
    record.update(normal_rounds=len(flips) - 1, normal_round_kept=kept, own_flips=flips)
    if kept:
        mesh = best[1]
        record.update(faces=mesh.n_faces, boundary_edges=mesh.boundary_edges,
                      unmeshed=int((~mesh.main).sum()), **topology_record(mesh.topology))
    return best


def _own_flips(Xn: np.ndarray, mesh: LocalMesh, uv: np.ndarray) -> dict:
    """:func:`pcgeom.maps.localmesh.mesh_flips` of the mesh with the smaller fans its repair
    dropped at pinched vertices put back (:attr:`LocalMesh.pinch_fans`): they are where the
    normals went wrong, which the normal rounds are to see."""
    if mesh.pinch_fans is not None and len(mesh.pinch_fans):
        mesh = dataclasses.replace(mesh, faces=np.concatenate([mesh.faces, mesh.pinch_fans]))
    return mesh_flips(Xn, mesh, uv)


def free_map(Xn: np.ndarray, normals: np.ndarray | None, config: ParamConfig, *,
             device: torch.device, dtype: torch.dtype, seed: int,
             progress: bool, outlier: np.ndarray | None = None, start: tuple | None = None,
             landmarks=()) -> tuple[np.ndarray, np.ndarray, dict]:
    """The free-boundary map of a run: LSCM of the local mesh, optionally refined.

    Parameters
    ----------
    Xn, normals, outlier
        As :func:`pcgeom.maps.localmesh.mesh_cloud`.
    config : ParamConfig
        Uses ``local_mesh`` and, when ``local_mesh.refine_steps > 0``, ``refine`` and
        ``weights``.
    start : tuple, optional
        :func:`free_start`'s result when the run has it already (then ``normals`` and
        ``outlier`` are not used).
    landmarks : sequence of ((n_k,) int, (m_k, 2) float64)
        Rows of ``Xn`` of each landmark set and its targets: the map is
        :func:`pcgeom.maps.free_landmarks.pinned_free` (pinned, or pulled with
        ``local_mesh.free_landmark_weight``), in the targets' frame, and not refined.

    Returns
    -------
    uv : (N, 2) float64
    lam_inv : (N,) float64
    record : dict
        The history record (:func:`pcgeom.maps.localmesh.mesh_cloud`'s, plus ``seconds``,
        ``solver`` (the sparse factorization that ran, :data:`pcgeom.maps._sparse.SOLVERS`),
        ``ordering`` (its fill-reducing order: ``"metis"``, ``"amd"`` or None),
        ``flips`` (:func:`pcgeom.maps.localmesh.mesh_flips`) and, when refined,
        ``refine_steps`` and the loss terms).

    Raises
    ------
    InputError
        As :func:`pcgeom.maps.localmesh.mesh_cloud`.
    """
    if start is None:
        start = free_start(Xn, normals, config, progress=progress, outlier=outlier)
    t0 = time.perf_counter()
    settings = config.local_mesh
    uv, mesh, normals, record = start
    if landmarks:
        from ..metrics import hausdorff
        from .free_landmarks import pinned_free

        uv, record["free_landmarks"] = pinned_free(
            Xn, mesh, uv, landmarks, weight=settings.free_landmark_weight,
            robust=(settings.robust_rounds, settings.robust_scale, settings.robust_floor))
        record["landmark_hausdorff"] = [hausdorff(uv[i], q) for i, q in landmarks]
    lam_inv = conformal_factor(Xn, uv)
    if settings.refine_steps > 0 and not landmarks:
        gen = torch.Generator(device="cpu")
        gen.manual_seed(seed)
        torch.manual_seed(seed)
        data = TrainData(torch.tensor(Xn, device=device, dtype=dtype), None, [], [], gen)
        U, lam, refined = refine(
            data, Xn,
            (torch.tensor(uv, device=device, dtype=dtype),
             torch.tensor(lam_inv, device=device, dtype=dtype)),
            Objective(config.weights, []),
            dataclasses.replace(config.refine, steps=settings.refine_steps),
            normals=normals, progress=progress,
        )
        uv, lam_inv = U.cpu().double().numpy(), lam.cpu().double().numpy()
        record["refine_steps"] = settings.refine_steps
        record.update({k: refined[k] for k in LOSS_TERMS if k in refined})
    record["flips"] = mesh_flips(Xn, mesh, uv)
    record["seconds"] += time.perf_counter() - t0
    return uv, lam_inv, record
