"""The free-boundary conformal map of the local mesh: LSCM, then the conformal factor.

4. **LSCM** (Levy et al. 2002) on the local mesh (:mod:`pcgeom.maps.localmesh`, steps 1-3):
   minimize the conformal energy, the Dirichlet energy (libigl's cotangent matrix) minus the
   signed area (libigl's ``vector_area_matrix``), with two far-apart points pinned. Points
   outside the mesh's largest connected part take the distance-weighted mean of the map at
   their nearest meshed points (they are counted).
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

import numpy as np
import torch

from ..config import ParamConfig
from ..errors import InputError
from ..train.data import TrainData
from ..train.objective import LOSS_TERMS, Objective
from ._sparse import fill_order, ordering_name, solver_name, spd_factor
from .localmesh import LocalMesh, _interpolate_rest, _submesh, mesh_cloud, mesh_flips
from .refine import refine

__all__ = ["lscm_free", "conformal_factor", "free_map", "free_start"]


def lscm_free(X: np.ndarray, mesh: LocalMesh) -> np.ndarray:
    """Free-boundary LSCM of the mesh's main part; other points interpolated (step 4).

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
    del L, V, F, unknown
    z = spd_factor(Q_ff, order=order)(rhs)
    if not np.isfinite(z).all():
        raise InputError("the local mesh of the cloud is degenerate (LSCM has no unique "
                         "solution); try more neighbours or the 'networks' preset")
    flat = np.empty(2 * m)
    flat[fixed] = values
    flat[free] = z
    U = np.full((len(X), 2), np.nan)
    U[main] = np.column_stack([flat[:m], flat[m:]])
    return _principal_pose(_interpolate_rest(X, U, mesh.main))



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


def free_start(Xn: np.ndarray, normals: np.ndarray | None, config: ParamConfig, *,
               progress: bool, outlier: np.ndarray | None = None
               ) -> tuple[np.ndarray, LocalMesh, np.ndarray, dict]:
    """The local mesh of the cloud (:func:`pcgeom.maps.localmesh.mesh_cloud`; ``outlier``:
    its strays, when already found) and its free LSCM map: where every local-mesh map
    starts.

    Returns the map ``(N, 2)``, the mesh, the normals (estimated when ``normals`` is None)
    and the start of the history record."""
    settings = config.local_mesh
    mesh, normals, record = mesh_cloud(Xn, normals, settings.neighbours,
                                       settings.normal_neighbours, progress=progress,
                                       normal_scales=settings.normal_scales,
                                       normal_tolerance=settings.normal_tolerance,
                                       outlier=outlier)
    uv = lscm_free(Xn, mesh)
    record["solver"] = solver_name()  # the sparse factorization that ran, and its ordering
    record["ordering"] = ordering_name()
    return uv, mesh, normals, record


def free_map(Xn: np.ndarray, normals: np.ndarray | None, config: ParamConfig, *,
             device: torch.device, dtype: torch.dtype, seed: int,
             progress: bool, outlier: np.ndarray | None = None
             ) -> tuple[np.ndarray, np.ndarray, dict]:
    """The free-boundary map of a run: LSCM of the local mesh, optionally refined.

    Parameters
    ----------
    Xn, normals, outlier
        As :func:`pcgeom.maps.localmesh.mesh_cloud`.
    config : ParamConfig
        Uses ``local_mesh`` and, when ``local_mesh.refine_steps > 0``, ``refine`` and
        ``weights``.

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
    t0 = time.perf_counter()
    settings = config.local_mesh
    uv, mesh, normals, record = free_start(Xn, normals, config, progress=progress,
                                           outlier=outlier)
    lam_inv = conformal_factor(Xn, uv)
    if settings.refine_steps > 0:
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
    record["seconds"] = time.perf_counter() - t0
    return uv, lam_inv, record
