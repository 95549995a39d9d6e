"""Algorithm 1 of the paper (multi-stage training of the two networks), presets, refinement.

A run is: normalize the cloud, train the parametrization net ``f`` and the
inverse-lambda net ``l`` stage by stage with Algorithm 1 (the batch doubles, the
epochs halve, sigma shrinks by sqrt 2, alpha ramps and doubles, with caps), then,
in the ``fast`` preset only, refine the per-point map on local LEG pairs.

Normalization: the cloud is translated so its centroid is at the origin and
scaled so the farthest point is at distance 1 (``X_n = (X - center) / scale``).
Sigma and alpha are in these units, and the returned map is that of ``X_n``
(``f(X_n)``, refined when the preset refines); the transform ``center, scale``
is returned with it.
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import torch

from .domains import Domain
from .io import deduplicate, normalize, validate_points, write_atomic
from .losses import hand, landmark_hand, leg, leg_pairs
from .nets import LambdaInvNet, NetConfig, ParamNet

__all__ = [
    "ScheduleConfig",
    "OptimizerConfig",
    "LossWeights",
    "RefineConfig",
    "ParamConfig",
    "Stage",
    "ParamResult",
    "PRESETS",
    "get_preset",
    "stage_plan",
    "resolve_device",
    "parametrize",
]


@dataclass(frozen=True)
class ScheduleConfig:
    """Algorithm 1's initial hyperparameters and bounds (defaults: paper, section 6)."""

    epochs: int = 10000
    """E, epochs of the first stage; halved after each stage (Alg. 1, line 17)."""
    batch_points: int = 1024
    """B_X, cloud points per mini-batch; doubled after each stage up to |X| (line 18)."""
    batch_domain: int = 1024
    """B_W, domain samples per mini-batch; doubled up to |W| (line 19)."""
    sigma: float = 0.5
    """LEG kernel width of the first stage; divided by sqrt 2 each stage (line 14)."""
    alpha_initial: float = 2.0
    """HAND sharpness at the start of the first stage (line 6)."""
    alpha_final: float = 20.0
    """HAND sharpness at the end of the first stage; doubled each stage (line 16)."""
    sigma_min: float = 0.001
    """Lower bound on sigma (line 14)."""
    alpha_max: float = 100.0
    """Upper bound on alpha_final (line 16)."""
    epochs_min: int = 1000
    """Lower bound on E (line 17)."""


@dataclass(frozen=True)
class OptimizerConfig:
    """Optimizer of the networks (paper, section 6: RMSprop, alpha 0.99, lr 1e-4, momentum 0.9)."""

    name: str = "rmsprop"
    """``"rmsprop"`` or ``"adam"``."""
    lr: float = 1e-4
    """Learning rate."""
    rmsprop_alpha: float = 0.99
    """RMSprop smoothing constant."""
    momentum: float = 0.9
    """RMSprop momentum (ignored by Adam)."""


@dataclass(frozen=True)
class LossWeights:
    """beta in eq. (optim problem overall); paper, section 6: (5, 1, 1)."""

    leg: float = 5.0
    """beta_1, LEG."""
    domain: float = 1.0
    """beta_2, HAND to the domain sample W."""
    landmarks: float = 1.0
    """beta_3, HAND of each landmark set to its target."""


@dataclass(frozen=True)
class RefineConfig:
    """Per-point refinement after the networks (not in the paper; ``steps = 0`` disables it).

    The networks give a smooth, unfolded map but cannot resolve it to the point
    spacing in a short budget (DESIGN.md: a 3 x 128 sine net regressed onto an
    LSCM map reproduces it only to 0.04-0.09 rad). The refinement optimizes
    each point's image ``y_i`` and ``l_i`` directly, starting from the networks'
    values, on LEG restricted to each point's ``neighbours`` nearest neighbours
    with ``sigma = sigma_spacing * h`` (``h``: mean nearest-neighbour distance),
    plus HAND of all points against a random batch of the domain sample when a
    domain is given. A kernel a few spacings
    wide keeps pairs at distances of order sigma, where LEG's signal is.
    """

    steps: int = 0
    """Adam steps (0: no refinement, as in the paper)."""
    neighbours: int = 32
    """Nearest neighbours per point whose pairs enter LEG."""
    sigma_spacing: float = 3.0
    """sigma in units of the mean nearest-neighbour spacing."""
    lr_spacing: float = 0.05
    """Adam step on the map, in units of the median mapped neighbour distance."""
    lr_lambda: float = 2e-3
    """Adam step on log l_i."""
    batch_domain: int = 1024
    """Domain samples per HAND evaluation during refinement (against all points)."""
    alpha: float = 100.0
    """HAND sharpness during refinement."""


@dataclass(frozen=True)
class ParamConfig:
    """Everything that defines a run; saved with every result."""

    schedule: ScheduleConfig = ScheduleConfig()
    optimizer: OptimizerConfig = OptimizerConfig()
    weights: LossWeights = LossWeights()
    param_net: NetConfig = NetConfig(width=128, depth=3, init="default", w0=1.0)
    """Parametrization net f: R^3 -> R^2."""
    lambda_net: NetConfig = NetConfig(width=64, depth=2, init="default", w0=1.0)
    """Inverse-lambda net l: R^3 -> R_{>0}."""
    domain_samples: int = 8192
    """|W|, the size of the sample of the parameter domain."""
    max_stages: int = 0
    """Stop Algorithm 1 after this many stages (0: run until B_X = |X|, as the paper)."""
    init_map: str = "random"
    """``"random"``: randomly initialized nets (paper, section 6); ``"plane"``: the
    parametrization net starts as the projection onto the cloud's best-fit plane
    (a trainable linear term, see :class:`pcgeom.nets.ParamNet`)."""
    refine: RefineConfig = RefineConfig()
    dtype: str = "float32"
    """Torch dtype of training, ``"float32"`` or ``"float64"``."""

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)

    @staticmethod
    def from_dict(d: dict) -> "ParamConfig":
        return ParamConfig(
            schedule=ScheduleConfig(**d["schedule"]),
            optimizer=OptimizerConfig(**d["optimizer"]),
            weights=LossWeights(**d["weights"]),
            param_net=NetConfig(**d["param_net"]),
            lambda_net=NetConfig(**d["lambda_net"]),
            domain_samples=d["domain_samples"],
            max_stages=d["max_stages"],
            init_map=d["init_map"],
            refine=RefineConfig(**d["refine"]),
            dtype=d["dtype"],
        )


PRESETS: dict[str, ParamConfig] = {
    # Section 6 exactly: E = 10000, B = 1024, sigma 0.5, alpha 2 -> 20, caps
    # (0.001, 100, 1000), RMSprop(alpha 0.99, lr 1e-4, momentum 0.9), beta (5, 1, 1),
    # randomly initialized sine networks, all stages until the batch is the cloud.
    "paper": ParamConfig(),
    # Everyday use: Adam at 1e-3 on SIREN-initialized nets, the parametrization net
    # starting from the best-fit-plane projection, for two short stages (sigma
    # 0.5 -> 0.35, batches 1024 -> 2048) to get a smooth unfolded map, then the
    # per-point refinement on local LEG pairs.
    "fast": ParamConfig(
        schedule=ScheduleConfig(
            epochs=120, sigma=0.5, alpha_initial=2.0, alpha_final=20.0, epochs_min=30
        ),
        optimizer=OptimizerConfig(name="adam", lr=1e-3),
        param_net=NetConfig(width=128, depth=3, init="siren", w0=5.0),
        lambda_net=NetConfig(width=64, depth=2, init="siren", w0=5.0),
        max_stages=2,
        init_map="plane",
        refine=RefineConfig(steps=1000),
    ),
}


def get_preset(name: str, **overrides) -> ParamConfig:
    """A named preset, optionally with top-level fields replaced (``dataclasses.replace``)."""
    if name not in PRESETS:
        raise ValueError(f"unknown preset {name!r}; choose one of: {', '.join(PRESETS)}")
    return dataclasses.replace(PRESETS[name], **overrides)


@dataclass(frozen=True)
class Stage:
    """One stage of Algorithm 1 as it will run."""

    index: int
    epochs: int
    batch_points: int
    batch_domain: int
    sigma: float
    alpha_initial: float
    alpha_final: float
    steps_per_epoch: int

    def alpha(self, epoch: int) -> float:
        """alpha during epoch ``epoch`` (0-based): linear from alpha_initial to alpha_final (lines 6, 11)."""
        if self.epochs <= 1:
            return self.alpha_initial
        return self.alpha_initial + epoch * (self.alpha_final - self.alpha_initial) / (self.epochs - 1)


def stage_plan(n_points: int, n_domain: int, schedule: ScheduleConfig, max_stages: int = 0) -> list[Stage]:
    """The sequence of stages Algorithm 1 runs for a cloud of ``n_points``.

    Stages continue until the stage whose batch is the whole cloud has run
    (lines 3-5). A first batch larger than the cloud is clamped to it, as line
    18 would clamp it. ``max_stages > 0`` truncates the plan.
    """
    E = schedule.epochs
    bx = min(schedule.batch_points, n_points)
    bw = min(schedule.batch_domain, n_domain) if n_domain else 0
    sigma, a0, a1 = schedule.sigma, schedule.alpha_initial, schedule.alpha_final
    stages = []
    while True:
        last = bx == n_points
        stages.append(Stage(len(stages), E, bx, bw, sigma, a0, a1, math.ceil(n_points / bx)))
        if last or (max_stages and len(stages) >= max_stages):
            return stages
        sigma = max(sigma / math.sqrt(2.0), schedule.sigma_min)
        a0, a1 = a1, min(2.0 * a1, schedule.alpha_max)
        E = max(E // 2, schedule.epochs_min)
        bx = min(2 * bx, n_points)
        bw = min(2 * bw, n_domain) if n_domain else 0


def resolve_device(name: str) -> torch.device:
    """``"auto"`` (CUDA when present), ``"cpu"`` or ``"cuda"``."""
    if name not in ("auto", "cpu", "cuda"):
        raise ValueError(f"unknown device {name!r}; choose one of: auto, cpu, cuda")
    if name == "cuda" and not torch.cuda.is_available():
        raise ValueError("--device cuda requested but CUDA is not available")
    if name == "auto":
        return torch.device("cuda" if torch.cuda.is_available() else "cpu")
    return torch.device(name)


@dataclass
class ParamResult:
    """A finished parametrization (NumPy arrays, one row per input point)."""

    uv: np.ndarray
    """(N, 2) float64 map of the normalized cloud, in the input's row order."""
    lambda_inv: np.ndarray
    """(N,) float64 inverse conformal factor l(x_i)."""
    center: np.ndarray
    """(3,) translation of the normalization."""
    scale: float
    """Scale of the normalization: ``X_n = (X - center) / scale``."""
    config: ParamConfig
    history: list[dict] = field(default_factory=list)
    """One record per stage: schedule values, seconds and every loss term."""
    seconds: float = 0.0

    def config_dict(self) -> dict:
        return self.config.to_dict()


# --------------------------------------------------------------------------- helpers


def _make_optimizer(params, cfg: OptimizerConfig) -> torch.optim.Optimizer:
    if cfg.name == "rmsprop":
        return torch.optim.RMSprop(params, lr=cfg.lr, alpha=cfg.rmsprop_alpha, momentum=cfg.momentum)
    if cfg.name == "adam":
        return torch.optim.Adam(params, lr=cfg.lr)
    raise ValueError(f"unknown optimizer {cfg.name!r}; choose one of: rmsprop, adam")


def _initial_plane(Xn: np.ndarray, init_map: str, W: torch.Tensor | None) -> torch.Tensor | None:
    """The (2, 3) linear term of the parametrization net for ``init_map``, or None."""
    if init_map == "random":
        return None
    if init_map != "plane":
        raise ValueError(f"unknown init_map {init_map!r}; choose one of: random, plane")
    _, _, vt = np.linalg.svd(Xn - Xn.mean(axis=0), full_matrices=False)
    plane = vt[:2]  # (2, 3): the two principal directions
    if W is not None:
        # Scale the projected cloud to the domain sample's extent. The projection is
        # centred at the origin, as the registered domains are; HAND moves it otherwise.
        extent = np.linalg.norm(Xn @ plane.T, axis=1).max()
        reach = np.linalg.norm(W.cpu().double().numpy(), axis=1).max()
        plane = plane * (reach / extent)
    return torch.tensor(plane, dtype=torch.float32)


def _fingerprint(points: np.ndarray) -> str:
    return hashlib.sha1(np.ascontiguousarray(points, dtype=np.float64).tobytes()).hexdigest()


def _save_checkpoint(path: Path, state: dict) -> None:
    write_atomic(path, lambda f: torch.save(state, f))


def _prepare_landmarks(landmarks, center, scale, device, dtype):
    """Normalize landmark points like the cloud; targets stay in domain units."""
    pts, tgts = [], []
    for k, (p, q) in enumerate(landmarks):
        p = np.asarray(p, dtype=np.float64)
        q = np.asarray(q, dtype=np.float64)
        if p.ndim != 2 or p.shape[1] != 3 or len(p) == 0:
            raise ValueError(f"landmark set {k}: expected points of shape (n, 3), got {p.shape}")
        if q.ndim != 2 or q.shape[1] != 2 or len(q) == 0:
            raise ValueError(f"landmark target {k}: expected points of shape (m, 2), got {q.shape}")
        if not (np.isfinite(p).all() and np.isfinite(q).all()):
            raise ValueError(f"landmark pair {k}: contains NaN or inf")
        pts.append(torch.tensor((p - center) / scale, device=device, dtype=dtype))
        tgts.append(torch.tensor(q, device=device, dtype=dtype))
    return pts, tgts


class _Progress:
    """A tqdm bar per stage on stderr, or nothing."""

    def __init__(self, enabled: bool) -> None:
        self.enabled = enabled

    def bar(self, total: int, desc: str):
        if not self.enabled:
            return None
        from tqdm.auto import tqdm

        return tqdm(total=total, desc=desc, leave=False, dynamic_ncols=True)


# --------------------------------------------------------------------------- main entry


def parametrize(
    points: np.ndarray,
    domain: Domain | None = None,
    *,
    config: ParamConfig | None = None,
    landmarks: Sequence[tuple[np.ndarray, np.ndarray]] = (),
    device: str | torch.device = "auto",
    seed: int = 0,
    checkpoint: str | Path | None = None,
    resume: bool = False,
    progress: bool = True,
    on_stage: Callable[[dict, np.ndarray], None] | None = None,
) -> ParamResult:
    """Parametrize a point cloud onto ``domain`` (free boundary when None).

    Solves eq. (optim problem overall) with Algorithm 1:
    ``beta_1 LEG(f, l, X u P) + beta_2 HAND(f(X), W) + beta_3 sum_k HAND(f(P_k), Q_k)``.

    Parameters
    ----------
    points : (N, 3) float
        The cloud; checked with :func:`pcgeom.io.validate_points` before any work
        (:class:`pcgeom.io.InputError` on bad input). Duplicate points are trained
        once and get the same output row.
    domain : Domain or None
        Parameter domain; None for the free-boundary map (LEG only).
    config : ParamConfig
        Defaults to the ``fast`` preset.
    landmarks : sequence of ((n_k, 3), (m_k, 2)) pairs
        Landmark points on the surface (same frame as ``points``) and their target
        sets in the domain; sizes may differ.
    device : "auto", "cpu", "cuda" or torch.device
    seed : int
        Seeds torch and the samplers; a run is repeatable on one device.
    checkpoint : path, optional
        Written after every stage; with ``resume=True`` a run continues from it.
    progress : bool
        tqdm bars on stderr.
    on_stage : callable, optional
        Called after every stage (and the refinement) with the stage's history
        record and the current map, (N, 2) float64 in the input's row order: for
        per-stage curves of quality measures the optimizer does not know about.

    Returns
    -------
    ParamResult
    """
    t_start = time.perf_counter()
    config = config if config is not None else get_preset("fast")
    dev = device if isinstance(device, torch.device) else resolve_device(device)
    dtype = {"float32": torch.float32, "float64": torch.float64}[config.dtype]
    P = validate_points(points)
    unique, inverse = deduplicate(P)
    Xn_np, center, scale = normalize(unique)
    n = len(Xn_np)
    X = torch.tensor(Xn_np, device=dev, dtype=dtype)
    lm_points, lm_targets = _prepare_landmarks(landmarks, center, scale, dev, dtype)
    if lm_points and domain is None:
        raise ValueError("landmarks need a parameter domain; use --domain disk (or another domain)")
    W = None
    if domain is not None:
        W = torch.tensor(domain.sample(config.domain_samples, seed=seed), device=dev, dtype=dtype)
    stages = stage_plan(n, 0 if W is None else len(W), config.schedule, config.max_stages)

    torch.manual_seed(seed)
    gen = torch.Generator(device="cpu").manual_seed(seed)
    f = ParamNet(config.param_net, plane=_initial_plane(Xn_np, config.init_map, W)).to(dev, dtype)
    l = LambdaInvNet(config.lambda_net).to(dev, dtype)
    opt = _make_optimizer(list(f.parameters()) + list(l.parameters()), config.optimizer)
    history: list[dict] = []
    start_stage = 0
    ckpt = Path(checkpoint) if checkpoint is not None else None
    fingerprint = _fingerprint(P)
    if ckpt is not None and resume and ckpt.exists():
        # On the CPU: the RNG states must be CPU ByteTensors (set_state rejects CUDA ones);
        # load_state_dict copies the weights and optimizer state onto ``dev``.
        state = torch.load(ckpt, map_location="cpu", weights_only=False)
        if state["fingerprint"] != fingerprint or state["config"] != config.to_dict() or state["seed"] != seed:
            raise ValueError(f"{ckpt}: checkpoint is from a different input, config or seed; delete it to start over")
        f.load_state_dict(state["f"])
        l.load_state_dict(state["l"])
        opt.load_state_dict(state["opt"])
        gen.set_state(state["gen"])
        torch.set_rng_state(state["torch_rng"])
        history = state["history"]
        start_stage = state["next_stage"]

    bars = _Progress(progress)
    for stage in stages[start_stage:]:
        record = _run_stage(stage, len(stages), X, W, lm_points, lm_targets, f, l, opt, config, gen, bars)
        history.append(record)
        if on_stage is not None:
            with torch.no_grad():
                on_stage(record, f(X).cpu().double().numpy()[inverse])
        if ckpt is not None:
            _save_checkpoint(
                ckpt,
                {
                    "f": f.state_dict(),
                    "l": l.state_dict(),
                    "opt": opt.state_dict(),
                    "gen": gen.get_state(),
                    "torch_rng": torch.get_rng_state(),
                    "history": history,
                    "next_stage": stage.index + 1,
                    "fingerprint": fingerprint,
                    "config": config.to_dict(),
                    "seed": seed,
                },
            )

    with torch.no_grad():
        uv = f(X)
        lam = l(X)
    if config.refine.steps > 0:
        uv, lam, record = _refine(Xn_np, X, uv, lam, W, lm_points, lm_targets, config, gen, bars)
        history.append(record)
        if on_stage is not None:
            on_stage(record, uv.cpu().double().numpy()[inverse])
    uv_np = uv.detach().cpu().double().numpy()[inverse]
    lam_np = lam.detach().cpu().double().numpy()[inverse]
    return ParamResult(
        uv=uv_np,
        lambda_inv=lam_np,
        center=center,
        scale=float(scale),
        config=config,
        history=history,
        seconds=time.perf_counter() - t_start,
    )


def _run_stage(stage, n_stages, X, W, lm_points, lm_targets, f, l, opt, config, gen, bars) -> dict:
    """Lines 6-13 of Algorithm 1 for one stage; returns the stage's history record."""
    t0 = time.perf_counter()
    beta = config.weights
    n = len(X)
    P_all = torch.cat(lm_points) if lm_points else None
    # Only the terms this run computes, as in the refinement record: a 0.0 for an
    # unused term would read as a perfect fit.
    last: dict[str, float] = {}
    n_steps = 0
    bar = bars.bar(stage.epochs, f"stage {stage.index + 1}/{n_stages}")
    for epoch in range(stage.epochs):
        alpha = stage.alpha(epoch)
        for _ in range(stage.steps_per_epoch):
            idx = torch.randperm(n, generator=gen)[: stage.batch_points].to(X.device)
            xb = X[idx] if P_all is None else torch.cat([X[idx], P_all])
            yb = f(xb)
            terms = {"leg": leg(xb, yb, l(xb), stage.sigma)}
            total = beta.leg * terms["leg"]
            if W is not None:
                widx = torch.randperm(len(W), generator=gen)[: stage.batch_domain].to(X.device)
                terms["hand"] = hand(yb[: stage.batch_points], W[widx], alpha)
                total = total + beta.domain * terms["hand"]
            if P_all is not None:
                # The landmarks' images are the tail of the LEG batch (eq. optim problem overall).
                mapped = torch.split(yb[stage.batch_points :], [len(p) for p in lm_points])
                terms["landmarks"] = landmark_hand(mapped, lm_targets, alpha)
                total = total + beta.landmarks * terms["landmarks"]
            opt.zero_grad(set_to_none=True)
            total.backward()
            opt.step()
            terms["total"] = total
            n_steps += 1
        # Reading a loss value synchronizes a GPU: once per epoch, the last step's terms.
        last = {k: float(v.detach()) for k, v in terms.items()}
        if bar is not None:
            bar.update(1)
            bar.set_postfix({k: f"{v:.3g}" for k, v in last.items()} | {"alpha": f"{alpha:.3g}"})
    if bar is not None:
        bar.close()
    return {
        "stage": stage.index + 1,
        "kind": "network",
        "epochs": stage.epochs,
        "steps": n_steps,
        "sigma": stage.sigma,
        "alpha_initial": stage.alpha_initial,
        "alpha_final": stage.alpha_final,
        "batch_points": stage.batch_points,
        "batch_domain": stage.batch_domain,
        "seconds": time.perf_counter() - t0,
        **{k: last[k] for k in last},
    }


def _refine(Xn_np, X, uv0, lam0, W, lm_points, lm_targets, config, gen, bars):
    """Per-point refinement on local LEG pairs (see :class:`RefineConfig`)."""
    from scipy.spatial import cKDTree

    t0 = time.perf_counter()
    rc = config.refine
    beta = config.weights
    n = len(Xn_np)
    k = min(rc.neighbours, n - 1)
    tree = cKDTree(Xn_np)
    dist, nb = tree.query(Xn_np, k + 1)
    spacing = float(dist[:, 1].mean())
    sigma = rc.sigma_spacing * spacing
    dev = X.device
    i = torch.arange(n, device=dev).repeat_interleave(k)
    j = torch.as_tensor(nb[:, 1:].reshape(-1), device=dev)
    with torch.no_grad():
        mapped_spacing = float((uv0[i] - uv0[j]).norm(dim=-1).median())
    U = uv0.detach().clone().requires_grad_(True)
    log_l = lam0.detach().clamp_min(1e-12).log().clone().requires_grad_(True)
    opt = torch.optim.Adam(
        [{"params": [U], "lr": rc.lr_spacing * mapped_spacing}, {"params": [log_l], "lr": rc.lr_lambda}]
    )
    lm_index = [torch.as_tensor(tree.query(p.cpu().double().numpy())[1], device=dev) for p in lm_points]
    last = {}
    bar = bars.bar(rc.steps, "refine")
    for step in range(rc.steps):
        terms = {"leg": leg_pairs(X, U, log_l.exp(), sigma, i, j)}
        total = beta.leg * terms["leg"]
        if W is not None:
            # All points every step: HAND on a random subset would move only that
            # subset's points and tear them from their neighbours.
            widx = torch.randperm(len(W), generator=gen)[: min(rc.batch_domain, len(W))].to(dev)
            terms["hand"] = hand(U, W[widx], rc.alpha)
            total = total + beta.domain * terms["hand"]
        if lm_index:
            terms["landmarks"] = landmark_hand([U[ix] for ix in lm_index], lm_targets, rc.alpha)
            total = total + beta.landmarks * terms["landmarks"]
        opt.zero_grad(set_to_none=True)
        total.backward()
        opt.step()
        terms["total"] = total
        # Reading a loss value synchronizes a GPU: only for the bar and the record.
        if step == rc.steps - 1 or (bar is not None and step % 50 == 0):
            last = {key: float(v.detach()) for key, v in terms.items()}
        if bar is not None:
            bar.update(1)
            if step % 50 == 0:
                bar.set_postfix({key: f"{v:.3g}" for key, v in last.items()})
    if bar is not None:
        bar.close()
    record = {
        "stage": "refine",
        "kind": "refine",
        "epochs": 1,
        "steps": rc.steps,
        "sigma": sigma,
        "alpha_initial": rc.alpha,
        "alpha_final": rc.alpha,
        "batch_points": n,
        "batch_domain": 0 if W is None else min(rc.batch_domain, len(W)),
        "seconds": time.perf_counter() - t0,
        **last,
    }
    return U.detach(), log_l.detach().exp(), record
