"""``parametrize``: prepare the cloud, choose the map (:func:`choose_map`), make it, return a
result.

A run is: validate, deduplicate and normalize the cloud, then one of the maps of
:data:`MAPS`: the local mesh's free LSCM map, its conformal disk map, the local mesh laid on
the domain and refined (all three without training), or the paper's method: the
parametrization net ``f`` and the inverse-lambda net ``l`` trained stage by stage with
Algorithm 1 (the batch doubles, the epochs halve, sigma shrinks by sqrt 2, alpha ramps and
doubles, with caps), then, when the config refines, the per-point map refined on local LEG
pairs.

Normalization: the cloud is translated so its centroid is at the origin and scaled so the
farthest point is at distance 1 (``X_n = (X - center) / scale``). Sigma and alpha are in these
units, and the returned map is that of ``X_n``; the transform ``center, scale`` is returned
with it.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
import torch

from .._version import __version__
from ..cloud import deduplicate, fingerprint, normalize, validate_normals, validate_points
from ..config import ParamConfig, get_preset
from ..denoise import denoise_points
from ..domains import Disk, Domain, get_domain
from ..errors import InputError
from ..io.points import PointCloud
from ..io.results import ParamResult
from ..neighbours import Neighbours, find_outliers
from ..progress import log
from ..train.checkpoint import load_checkpoint, save_checkpoint
from ..train.data import TrainData
from ..train.device import resolve_device
from ..train.objective import Objective
from ..train.plan import stage_plan
from .atlas import MAX_STRETCH, atlas_map, check_cut
from .disk import disk_map
from .domain import domain_map, resolve_domain
from .free import free_map, free_start, mesh_for
from .networks import build_networks, run_network_stage
from .refine import refine
from .sphere import sphere_map
from .topology import require_open

__all__ = ["parametrize", "choose_map", "MAPS"]

MAPS = {
    "free": "the free LSCM map of the local mesh (pcgeom.maps.free), no training",
    "disk": "the conformal disk map: free map, then the Riemann map (pcgeom.maps.disk)",
    "domain": "onto a domain without holes, the disk map composed with its inverse Riemann "
              "map (pcgeom.maps.riemann); onto a domain with holes, or with landmarks, the "
              "barrier map that folds nothing (pcgeom.maps.domain, pcgeom.maps.injective); "
              "where a domain hole gets no hole of the cloud, "
              "the local mesh laid on the domain, then refined",
    "networks": "Algorithm 1's network stages, then the refinement (pcgeom.maps.networks)",
    "atlas": "cut='auto': seams open the local mesh into a disk, mapped without a fold and "
             "packed into the unit square (pcgeom.maps.atlas)",
    "sphere": "onto the sphere, a closed genus-0 cloud: the spherical conformal map of its "
              "closed local mesh (pcgeom.maps.sphere)",
}
"""The maps a run can make, by the name :func:`choose_map` gives."""

SPHERE_LANDMARKS = ("landmarks are not built for --domain sphere: map the closed cloud without "
                    "--landmarks")
"""The message of the :class:`InputError` for landmarks onto the sphere."""

SPHERE_NETWORKS = ("--domain sphere is mapped by the fast preset's local mesh only; the networks "
                   "and paper presets train planar maps: use --preset fast")
"""The message of the :class:`InputError` for a network preset onto the sphere."""

_DTYPES = {"float32": torch.float32, "float64": torch.float64}


def _landmark_tensors(landmarks, center, scale, device, dtype):
    """Landmark points normalized like the cloud, targets as given (domain units)."""
    points, targets = [], []
    for k, (p, q) in enumerate(landmarks):
        p = np.asarray(p, dtype=np.float64)
        q = np.asarray(q, dtype=np.float64)
        if p.ndim != 2 or p.shape[1] != 3 or len(p) == 0:
            raise InputError(f"landmark set {k}: expected points of shape (n, 3), got {p.shape}")
        if q.ndim != 2 or q.shape[1] != 2 or len(q) == 0:
            raise InputError(f"landmark target {k}: expected points of shape (m, 2), got {q.shape}")
        if not (np.isfinite(p).all() and np.isfinite(q).all()):
            raise InputError(f"landmark pair {k}: contains NaN or inf")
        points.append(torch.tensor((p - center) / scale, device=device, dtype=dtype))
        targets.append(torch.tensor(q, device=device, dtype=dtype))
    return points, targets


FREE_LANDMARKS = ("landmarks on the free boundary are built for the local-mesh map only: use "
                  "--preset fast, or a parameter domain (--domain disk)")
"""The message of the :class:`InputError` for landmarks on the free boundary with the
networks."""


def _nearest_rows(Xn: np.ndarray, points, targets) -> list:
    """Each landmark set as the rows of ``Xn`` nearest its points, with its targets (NumPy)."""
    if not points:
        return []
    from scipy.spatial import cKDTree

    tree = cKDTree(Xn)
    return [(tree.query(p.cpu().double().numpy())[1], q.cpu().double().numpy())
            for p, q in zip(points, targets)]


def choose_map(domain: Domain, config: ParamConfig, landmarks: bool) -> str:
    """Which map of :data:`MAPS` makes a run onto ``domain`` with ``config``.

    The free boundary: ``config.free_map`` (with landmarks: ``"localmesh"`` only). A disk without
    landmarks: ``config.disk_map`` (laid and refined when ``local_mesh.disk_refine``). Any other
    bounded domain, and any
    domain with landmarks: ``config.domain_map``. The sphere: ``"sphere"``.

    Raises
    ------
    InputError
        The sphere with landmarks, or with a config whose maps are the networks (the
        ``networks`` and ``paper`` presets): neither is built for it; landmarks on the free
        boundary with the networks.
    """
    if domain.closed:
        if landmarks:
            raise InputError(SPHERE_LANDMARKS)
        if "networks" in (config.free_map, config.disk_map, config.domain_map):
            raise InputError(SPHERE_NETWORKS)
        return "sphere"
    if not domain.bounded:
        if landmarks and config.free_map != "localmesh":
            raise InputError(FREE_LANDMARKS)
        return "free" if config.free_map == "localmesh" else "networks"
    if isinstance(domain, Disk) and not landmarks:
        if config.disk_map != "localmesh":
            return "networks"
        return "domain" if config.local_mesh.disk_refine else "disk"
    return "domain" if config.domain_map == "localmesh" else "networks"


def parametrize(
    points,
    domain: Domain | str | dict = "free",
    *,
    config: ParamConfig | None = None,
    landmarks: Sequence[tuple[np.ndarray, np.ndarray]] = (),
    device: str | torch.device = "auto",
    seed: int = 0,
    checkpoint: str | Path | None = None,
    resume: bool = False,
    progress: bool = True,
    on_stage: Callable[[dict, np.ndarray], None] | None = None,
    normals=None,
    cut: str = "none",
    max_stretch: float = MAX_STRETCH,
) -> ParamResult:
    """Parametrize a point cloud onto ``domain``.

    Solves eq. (optim problem overall) with Algorithm 1:
    ``beta_1 LEG(f, l, X u P) + beta_2 HAND(f(X), W) + beta_3 sum_k HAND(f(P_k), Q_k)``.

    Parameters
    ----------
    points : (N, 3) array_like, or PointCloud
        The cloud; checked with :func:`pcgeom.cloud.validate_points` before any work
        (:class:`pcgeom.errors.InputError` on bad input), unless it is a
        :class:`pcgeom.io.PointCloud` (:func:`pcgeom.read_points`' result), which was checked
        when it was built and brings its normals. Duplicate points are trained once and get
        the same output row.
    domain : Domain, str or dict
        Parameter domain or its spec (:func:`pcgeom.domains.get_domain`); ``"free"`` (the
        default) for the free-boundary map (LEG only).
    config : ParamConfig
        Defaults to the ``fast`` preset. It chooses the map: the free boundary by
        ``free_map``, a disk without landmarks by ``disk_map``, any other domain or landmarks
        by ``domain_map`` (``"networks"``: Algorithm 1's stages, then ``refine``;
        ``"localmesh"``: :func:`pcgeom.maps.domain.domain_map`, the Riemann map onto a domain
        without holes, the barrier map onto one with holes or with landmarks).
    landmarks : sequence of ((n_k, 3), (m_k, 2)) pairs
        Landmark points on the surface (same frame as ``points``) and their target sets in
        the domain; sizes may differ. Needs a bounded domain.
    device : "auto", "cpu", "cuda" or torch.device
    seed : int
        Seeds torch, the mini-batches and the domain sample; a run is repeatable on one
        device.
    checkpoint : path, optional
        Written after every network stage (the local-mesh maps have none); with
        ``resume=True`` a run continues from it.
    progress : bool
        Progress on stderr: bars on a terminal, a few lines in a log (:mod:`pcgeom.progress`).
    on_stage : callable, optional
        Called after every stage (and the refinement) with the stage's history record and
        the current map, (N, 2) float64 in the input's row order: for per-stage curves of
        quality measures the optimizer does not know about.
    normals : (N, 3) array_like, optional
        Oriented normals, one per row of ``points`` (checked with
        :func:`pcgeom.cloud.validate_normals`; for a PointCloud, used instead of its own).
        They keep the two sheets of a surface that doubles back apart: the local-mesh map
        builds its fans from same-sheet neighbours, the network stages give LEG pairs whose
        normals disagree weight 0 (when ``config.schedule.drop_cross_sheet``, as in
        ``networks`` and ``fast``), and the refinement drops those pairs from its neighbour
        lists. Without them, the local-mesh map estimates and orients normals
        (:mod:`pcgeom.maps.normals`), and the map may fold where sheets touch.
    cut : "none" or "auto"
        ``"auto"`` (onto ``free`` only): seams that open the cloud's local mesh into a disk
        (any genus, closed or open without handles), a map that turns no triangle over,
        packed into ``[0, 1]^2`` (:func:`pcgeom.maps.atlas.atlas_map`); the result has
        ``chart`` and ``corner_uv``.
    max_stretch : float
        The bound (> 1) on a chart's scale-factor spread (95th over 5th percentile) for
        ``cut="auto"``: a chart over it gets slits and is split into charts
        (:mod:`pcgeom.maps.charts`); a cloud one chart holds within it gets no seam.

    Returns
    -------
    ParamResult
        With the domain, seed, version and input fingerprint it was made with, and for the
        local-mesh maps the triangles of the local mesh they were built on (``mesh_faces``).

    Warns
    -----
    UserWarning
        The map turns over triangles of the cloud's local mesh (the count and where: on the
        rim, near holes, inside; the history's ``flips``).
    """
    t_start = time.perf_counter()
    config = config if config is not None else get_preset("fast")
    domain = get_domain(domain)
    dev = resolve_device(device)
    dtype = _DTYPES[config.dtype]
    if isinstance(points, PointCloud):  # checked when it was built
        P = points.points
        normals = points.normals if normals is None else validate_normals(normals, len(P))
    else:
        P = validate_points(points)
        normals = validate_normals(normals, len(P))
    unique, inverse = deduplicate(P)
    # The first row of each distinct point: it keeps its normal, and it stands for it in the
    # local mesh's faces.
    first = np.full(len(unique), len(P))
    np.minimum.at(first, inverse, np.arange(len(P)))
    if normals is not None:
        normals = normals[first]
    Xn, center, scale = normalize(unique)
    max_stretch = check_cut(cut, max_stretch, domain.name)
    kind = choose_map(domain, config, bool(landmarks))
    if cut == "auto":
        if landmarks:
            raise InputError("--cut auto does not take landmarks")
        kind = "atlas"
    # What a checkpoint must share with this run to be resumed, checked before any work: a
    # checkpoint of a run with another preset or setting is refused as one of another seed
    # is (a run whose map writes no checkpoint at all cannot be the one it came from).
    identity = {"fingerprint": fingerprint(P), "config": config.to_dict(), "seed": seed,
                "domain": domain.to_dict(),
                "normals": None if normals is None else fingerprint(normals),
                "landmarks": [[fingerprint(p), fingerprint(q)] for p, q in landmarks]}
    ckpt = Path(checkpoint) if checkpoint is not None else None
    state = load_checkpoint(ckpt, identity) if ckpt is not None and resume and ckpt.exists() \
        else None
    lm_points, lm_targets = _landmark_tensors(landmarks, center, scale, dev, dtype)
    log(f"{len(P)} points onto {domain.label}: the {kind} map", enabled=progress)
    raw, (Xn, denoised, outlier) = Xn, _denoise(Xn, normals, config, lm_points)
    # The record in input units; it is the run's first stage when it moved the points.
    denoised.update({k: denoised[k] * scale for k in ("noise_std", "spacing")
                     if denoised[k] is not None})
    if denoised["applied"]:
        log(f"noise {denoised['noise']:.2f} spacings: the map is made of the fitted surface "
            f"(points moved {denoised['moved']:.2f} spacings on average)", enabled=progress)

    def result(uv, lam_inv, history, mesh=None, faces=None, atlas=None) -> ParamResult:
        """The run's result, rows back in the input's order (duplicates included), with the
        local mesh's main part (``mesh``), or the triangles ``faces`` (rows of ``Xn``: the
        sphere map's closed mesh), as input rows; a warning when the map turns over
        triangles of the cloud's local mesh."""
        if mesh is not None:
            faces = mesh.faces[mesh.main[mesh.faces].all(axis=1)]
        _warn_flips(history[-1].get("flips") if history else None)
        return ParamResult(
            uv=np.asarray(uv, dtype=np.float64)[inverse],
            lambda_inv=np.asarray(lam_inv, dtype=np.float64)[inverse],
            center=center, scale=float(scale), config=config, domain=domain, seed=seed,
            history=([denoised] if denoised["applied"] else []) + list(history),
            seconds=time.perf_counter() - t_start,
            fingerprint=fingerprint(P), version=__version__,
            denoise=denoised if config.denoise.mode != "off" else None,
            fitted=(Xn * scale + center)[inverse] if denoised["applied"] else None,
            mesh_faces=None if faces is None else first[faces],
            chart=None if atlas is None else atlas["chart"][inverse],
            corner_uv=None if atlas is None else atlas["corner_uv"],
        )

    def report(record: dict, U) -> None:
        if on_stage is not None:
            on_stage(record, _numpy(U)[inverse])

    start, decided = None, {}
    if kind in ("free", "disk", "domain"):
        # The local mesh and its free map, where every local-mesh map starts.
        start = free_start(Xn, normals, config, progress=progress, outlier=outlier,
                           onto=domain.label)
    if kind == "free":
        uv, lam_inv, record = free_map(Xn, normals, config, device=dev, dtype=dtype, seed=seed,
                                       progress=progress, start=start,
                                       landmarks=_nearest_rows(Xn, lm_points, lm_targets))
        report(record, uv)
        return result(uv, lam_inv, [record], start[1])
    if kind == "atlas":
        atlas = atlas_map(Xn, normals, config, progress=progress, outlier=outlier,
                          max_stretch=max_stretch)
        report(atlas["record"], atlas["uv"])
        return result(atlas["uv"], atlas["lambda_inv"], [atlas["record"]],
                      faces=atlas["faces"], atlas=atlas)
    if kind == "sphere":
        uv, lam_inv, record, faces = sphere_map(Xn, normals, config, progress=progress,
                                                outlier=outlier,
                                                raw=raw if denoised["applied"] else None,
                                                noise=denoised["noise"])
        report(record, uv)
        return result(uv, lam_inv, [record], faces=faces)
    if kind == "disk":
        uv, lam_inv, record = disk_map(Xn, normals, config, domain, progress=progress,
                                       start=start)
        report(record, uv)
        return result(uv, lam_inv, [record], start[1])
    if kind == "domain" and getattr(domain, "auto", False):
        # The domain depends on the surface: the local mesh first, then the domain's sample.
        domain, decided = resolve_domain(domain, Xn, start)
        start[3].update(decided)
        log(f"{domain.label} (its inner radius from the surface)", enabled=progress)
    W = None
    if domain.bounded:
        W = torch.tensor(domain.sample(config.domain_samples, seed=seed), device=dev, dtype=dtype)
    gen = torch.Generator(device="cpu")
    data = TrainData(torch.tensor(Xn, device=dev, dtype=dtype), W, lm_points, lm_targets, gen,
                     None if normals is None else torch.tensor(normals, device=dev, dtype=dtype))
    objective = Objective(config.weights, lm_targets)
    torch.manual_seed(seed)
    gen.manual_seed(seed)
    if kind == "domain":
        U, lam_inv, history = domain_map(Xn, normals, config, domain, data, objective,
                                         progress=progress, on_stage=report, start=start)
        return result(_numpy(U), _numpy(lam_inv), history, start[1])
    _refuse_closed(Xn, normals, config, domain, outlier)
    stages = stage_plan(len(Xn), data.n_domain, config.schedule, config.max_stages)
    nets = build_networks(config, Xn, domain, data)
    history: list[dict] = []
    start_stage = 0
    if state is not None:
        nets.load_state_dict(state["networks"])
        gen.set_state(state["gen"])
        torch.set_rng_state(state["torch_rng"])
        history = state["history"]
        start_stage = state["next_stage"]

    for stage in stages[start_stage:]:
        record = run_network_stage(stage, nets, data, objective, n_stages=len(stages),
                                   progress=progress)
        history.append(record)
        # The checkpoint first: a callback that fails or is interrupted loses no training.
        if ckpt is not None:
            save_checkpoint(ckpt, {
                "networks": nets.state_dict(),
                "gen": gen.get_state(),
                "torch_rng": torch.get_rng_state(),
                "history": history,
                "next_stage": stage.index + 1,
                **identity,
            })
        if on_stage is not None:
            with torch.no_grad():
                report(record, nets.param_net(data.X))

    with torch.no_grad():
        U = nets.param_net(data.X)
        lam_inv = nets.lambda_net(data.X)
    if config.refine.steps > 0:
        U, lam_inv, record = refine(data, Xn, (U, lam_inv), objective, config.refine,
                                    normals=normals, progress=progress)
        history.append(record)
        report(record, U)
    return result(_numpy(U), _numpy(lam_inv), history)


def _refuse_closed(Xn: np.ndarray, normals, config: ParamConfig, domain: Domain,
                   outlier: np.ndarray) -> None:
    """The networks build no local mesh, so a closed cloud would get a planar map that folds
    without a word: its local mesh is built for its topology alone, and a closed one is refused
    as on the local-mesh maps (:func:`pcgeom.maps.topology.require_open`). A cloud the local
    mesh cannot take (too few points, not one surface) goes on to the networks as before."""
    try:
        mesh = mesh_for(Xn, normals, config, progress=False, outlier=outlier, onto=None)[0]
    except InputError:
        return
    require_open(mesh.topology, domain.label)


def _denoise(Xn: np.ndarray, normals, config: ParamConfig, lm_points: list) -> tuple:
    """:func:`pcgeom.denoise.denoise_points` of the normalized cloud; landmark points (in
    place) move with their nearest cloud point, so that each still acts through the point it
    named. Returns the points, the record and, when the points did not move, their strays
    (:func:`pcgeom.neighbours.find_outliers`, for the local mesh), else None."""
    if config.denoise.mode == "off":
        return Xn, denoise_points(Xn, config.denoise, normals)[1], None
    # One neighbour query for the strays and the noise estimate.
    knn = Neighbours.of(Xn, max(16, config.denoise.noise_neighbours - 1))
    outlier = find_outliers(Xn, knn=knn)
    fitted, record = denoise_points(Xn, config.denoise, normals, outlier=outlier, knn=knn)
    del knn
    if record["applied"] and lm_points:
        from scipy.spatial import cKDTree

        tree, shift = cKDTree(Xn), fitted - Xn
        for k, p in enumerate(lm_points):
            nearest = tree.query(p.cpu().double().numpy())[1]
            lm_points[k] = p + torch.as_tensor(shift[nearest], device=p.device, dtype=p.dtype)
    return fitted, record, None if record["applied"] else outlier


def _warn_flips(flips: dict | None) -> None:
    if flips and flips["count"]:
        import warnings

        warnings.warn(f"the map turns over {flips['count']} of the {flips['faces']} triangles "
                      f"of the cloud's local mesh ({100 * flips['count'] / flips['faces']:.2f}%: "
                      f"{flips['rim']} on the rim, {flips['hole']} near holes, "
                      f"{flips['inside']} inside)", stacklevel=3)


def _numpy(A) -> np.ndarray:
    """A map or lambda, tensor or array, as float64 NumPy."""
    if isinstance(A, torch.Tensor):
        return A.detach().cpu().double().numpy()
    return np.asarray(A, dtype=np.float64)
