"""The ``"localmesh"`` maps as a run: normals, the local mesh, LSCM, then the disk or an
optional refinement."""

from __future__ import annotations

import dataclasses
import time

import numpy as np
import torch

from ..cloud import find_outliers, local_pca, surface_variation
from ..config import ParamConfig
from ..domainmap import align_onto, harmonic_onto
from ..domains import Disk, Domain
from ..errors import InputError
from ..localmesh import conformal_disk, conformal_factor, local_mesh, lscm_free
from ..losses import landmark_hand
from ..metrics import hausdorff
from ..normals import orient_normals
from .data import TrainData
from .objective import LOSS_TERMS, Objective
from .refine import refine

__all__ = ["localmesh_map", "localmesh_domain_map", "CLOSED_SURFACE", "MIN_MESHED",
           "NOT_A_SURFACE"]

MIN_MESHED = 0.5
"""The smallest share of the points the local mesh's main part must hold."""

MAX_VARIATION = 0.15
"""Largest median surface variation (:func:`pcgeom.cloud.surface_variation`) of a surface;
a volume of random points gives about 0.19 (16 neighbours), a smooth scan below 0.01, and
face_human_choi with noise of half its mean edge length 0.12."""

NOT_A_SURFACE = ("the cloud does not look like one sampled surface (its points fill a volume, "
                 "or most are strays); check the input")

CLOSED_SURFACE = (
    "the cloud looks like a closed surface (its local mesh has no boundary), and a closed "
    "surface has no planar map without a cut: cut it open first (remove a cap or a strip of "
    "points)"
)
"""The message of the :class:`InputError` for a closed surface."""


def _free_local_map(Xn: np.ndarray, normals: np.ndarray | None, config: ParamConfig, *,
                    progress: bool):
    """Outliers, the surface test, normals, the local mesh and its free LSCM map.

    Returns the map, the mesh, the normals (estimated when ``normals`` is None) and the start
    of the history record."""
    settings = config.local_mesh
    outlier = find_outliers(Xn)
    inliers = np.flatnonzero(~outlier)
    # One neighbourhood PCA serves the surface test and, without normals, their estimate.
    values, vectors = local_pca(Xn[inliers], settings.normal_neighbours)
    if np.median(surface_variation(values)) > MAX_VARIATION:
        raise InputError(NOT_A_SURFACE)
    source = "input"
    if normals is None:
        source = "estimated"
        normals = np.zeros_like(Xn)  # outliers' rows stay zero: no pair and no fan uses them
        normals[inliers] = orient_normals(Xn[inliers], np.ascontiguousarray(vectors[:, :, 0]),
                                          settings.normal_neighbours)
    mesh = local_mesh(Xn, normals, settings.neighbours, exclude=outlier, progress=progress)
    meshed = float(mesh.main.mean())
    if meshed < MIN_MESHED:
        raise InputError(f"only {100 * meshed:.0f}% of the points fit one local mesh: "
                         + NOT_A_SURFACE)
    if mesh.looks_closed:
        raise InputError(CLOSED_SURFACE)
    uv = lscm_free(Xn, mesh)
    record = {"stage": "localmesh", "kind": "localmesh", "normals": source,
              "neighbours": settings.neighbours, "faces": mesh.n_faces,
              "boundary_edges": mesh.boundary_edges, "outliers": int(outlier.sum()),
              "unmeshed": int((~mesh.main).sum())}
    return uv, mesh, normals, record


def localmesh_map(Xn: np.ndarray, normals: np.ndarray | None, config: ParamConfig,
                  domain: Domain, *, device: torch.device, dtype: torch.dtype, seed: int,
                  progress: bool) -> tuple[np.ndarray, np.ndarray, dict]:
    """The map of the normalized cloud by :mod:`pcgeom.localmesh`: free, or onto a disk.

    Parameters
    ----------
    Xn : (N, 3) float64
        Normalized distinct points.
    normals : (N, 3) float64 or None
        Their oriented unit normals; None: estimated (PCA) and oriented by propagation.
    config : ParamConfig
        Uses ``local_mesh`` and, for the free boundary when ``local_mesh.refine_steps > 0``,
        ``refine`` and ``weights``.
    domain : FreeBoundary or Disk
        A disk gets the free map followed by the Riemann map of its region
        (:func:`pcgeom.localmesh.conformal_disk`), scaled and moved to its radius and centre.

    Returns
    -------
    uv : (N, 2) float64
    lam_inv : (N,) float64
    record : dict
        The history record: ``stage`` and ``kind`` ``"localmesh"``, ``normals`` (``"input"``
        or ``"estimated"``), ``faces``, ``boundary_edges``, ``unmeshed`` (points outside the
        mesh's main part, outliers included, placed by interpolation from their nearest meshed
        points), ``outliers`` (stray points, :func:`pcgeom.cloud.find_outliers`), ``seconds``.

    Raises
    ------
    InputError
        The cloud samples a closed surface (:data:`CLOSED_SURFACE`), or less than
        :data:`MIN_MESHED` of it fits one local mesh.
    """
    t0 = time.perf_counter()
    settings = config.local_mesh
    uv, mesh, normals, record = _free_local_map(Xn, normals, config, progress=progress)
    if isinstance(domain, Disk):
        uv = np.asarray(domain.center) + domain.radius * conformal_disk(Xn, mesh, uv)
        record.update(onto=domain.spec, seconds=time.perf_counter() - t0)
        return uv, conformal_factor(Xn, uv), record
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
    record["seconds"] = time.perf_counter() - t0
    return uv, lam_inv, record


def localmesh_domain_map(Xn: np.ndarray, normals: np.ndarray | None, config: ParamConfig,
                         domain: Domain, data: TrainData, objective: Objective, *,
                         progress: bool, on_stage=None
                         ) -> tuple[torch.Tensor, torch.Tensor, list[dict]]:
    """The local mesh laid on a bounded domain, holes on holes, then refined.

    :func:`pcgeom.domainmap.harmonic_onto` gives the first map, or for a disk the conformal
    disk map turned by :func:`pcgeom.domainmap.align_onto` (the landmarks, when any, help
    choose the alignment); :func:`pcgeom.train.refine.refine` with
    ``config.local_mesh.domain_refine`` then optimizes it on LEG (local pairs), HAND onto the
    domain sample ``data.W`` and the landmark terms.

    Parameters
    ----------
    Xn, normals, config
        As :func:`localmesh_map`.
    domain : Domain
        Bounded, one connected region.
    data : TrainData
        The run's tensors: the cloud, the domain sample, the landmarks.
    objective : Objective
        The run's objective (its weights and landmark targets).
    on_stage : callable, optional
        Called with each history record and the map after it, (N, 2) float64.

    Returns
    -------
    U : (N, 2) tensor
    lam_inv : (N,) tensor
    records : list of dict
        The ``"localmesh"`` record (as :func:`localmesh_map`'s, plus ``onto``, the holes of
        the mesh and of the domain, how many were paired, the alignment's ``mirror`` and
        ``rotation_deg``, and, when there are landmarks, the landmark HAND term
        ``landmarks`` at the refinement's alpha and ``landmark_hausdorff`` of the first map),
        then the refinement's when it has steps.
    """
    from scipy.spatial import cKDTree

    t0 = time.perf_counter()
    uv, mesh, normals, record = _free_local_map(Xn, normals, config, progress=progress)
    tree = cKDTree(Xn)
    # Each landmark point acts through its nearest cloud point, as in the refinement.
    marks = [(tree.query(p.cpu().double().numpy())[1], q.cpu().double().numpy())
             for p, q in zip(data.landmark_points, data.landmark_targets)]
    if isinstance(domain, Disk):
        # The conformal disk map is the better start (three peaks, refined: 0.026 rad and no
        # flip from it, 0.045 rad and 261 flips from the harmonic map); the landmarks choose
        # its turn.
        disk = np.asarray(domain.center) + domain.radius * conformal_disk(Xn, mesh, uv)
        U0, info = align_onto(Xn, mesh, disk, domain, landmarks=marks)
    else:
        U0, info = harmonic_onto(Xn, mesh, uv, domain, landmarks=marks)
    record.update(onto=domain.spec, **info)
    refine_config = config.local_mesh.domain_refine
    if marks:
        # The landmark term as the refinement will weigh it (its alpha), and the exact fit.
        with torch.no_grad():
            term = landmark_hand([torch.as_tensor(U0[i]) for i, _ in marks],
                                 [torch.as_tensor(q) for _, q in marks], refine_config.alpha)
        record["landmarks"] = float(term)
        record["landmark_hausdorff"] = [hausdorff(U0[i], q) for i, q in marks]
    record["seconds"] = time.perf_counter() - t0
    records = [record]
    if on_stage is not None:
        on_stage(record, U0)
    U = torch.tensor(U0, device=data.X.device, dtype=data.X.dtype)
    lam_inv = torch.tensor(conformal_factor(Xn, U0), device=data.X.device, dtype=data.X.dtype)
    if refine_config.steps > 0:
        U, lam_inv, refined = refine(data, Xn, (U, lam_inv), objective, refine_config,
                                     normals=normals, progress=progress)
        records.append(refined)
        if on_stage is not None:
            on_stage(refined, U.cpu().double().numpy())
    return U, lam_inv, records
