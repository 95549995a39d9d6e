"""Configuration as data: frozen dataclasses, validated when built, and the named presets.

Every field's default is the paper's (section 6) unless its documentation says otherwise, and
every config round-trips through plain dicts (:meth:`ParamConfig.to_dict`,
:func:`config_from_dict`), which is how it is saved with each result and checkpoint.

A bad value raises :class:`pcgeom.errors.InputError` (a ``ValueError``) when the config is
constructed, naming the field and the allowed values, never a ``KeyError`` later in training.
"""

from __future__ import annotations

import dataclasses
import math
import typing
from dataclasses import dataclass

from ..errors import InputError
from ._checks import _choice, _count, _positive
from .barrier import (ENERGIES, LANDMARKS_INJECTIVE, SOLVERS, STARTS, BarrierConfig,
                      InjectiveConfig, PullConfig, UntangleConfig)

__all__ = [
    "with_landmark_weight",
    "NetConfig",
    "ScheduleConfig",
    "OptimizerConfig",
    "LossWeights",
    "RefineConfig",
    "LocalMeshConfig",
    "DenoiseConfig",
    "InjectiveConfig",
    "UntangleConfig",
    "PullConfig",
    "BarrierConfig",
    "ENERGIES",
    "STARTS",
    "SOLVERS",
    "ParamConfig",
    "PRESETS",
    "get_preset",
    "preset_name",
    "denoise_config",
    "with_denoise",
    "config_from_dict",
]

OPTIMIZERS = ("rmsprop", "adam")
DTYPES = ("float32", "float64")
INIT_MAPS = ("random", "plane")
REFINE_HAND_BACKENDS = ("auto", "dense", "chunked", "knn")
FREE_MAPS = ("networks", "localmesh")
DISK_MAPS = ("networks", "localmesh")
DOMAIN_MAPS = ("networks", "localmesh")
NET_INITS = ("siren", "default")


# --------------------------------------------------------------------------- configs


@dataclass(frozen=True)
class NetConfig:
    """Architecture and initialization of one sine-activated MLP (:mod:`pcgeom.nets`)."""

    width: int = 128
    """Hidden units per layer (paper, Figure "neural net arch": fully connected)."""
    depth: int = 3
    """Number of hidden (sine) layers."""
    init: str = "siren"
    """``"siren"``: Sitzmann et al.'s initialization with frequency ``w0``;
    ``"default"``: PyTorch's default Linear initialization and plain ``sin``,
    which is what the paper's "randomly initialized" networks use."""
    w0: float = 5.0
    """SIREN frequency of the first layer (``sin(w0 * (W x + b))``) on inputs in
    the unit ball; 5 reproduced a fine map best in our measurements (DESIGN.md)."""

    def __post_init__(self) -> None:
        _choice("NetConfig", "init", self.init, NET_INITS)
        _count("NetConfig", "width", self.width)
        _count("NetConfig", "depth", self.depth)
        _positive("NetConfig", "w0", self.w0)


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
    max_steps_per_epoch: int = 0
    """Cap on the mini-batches per epoch (not in the paper; 0: no cap, Algorithm 1's
    ceil(|X| / B_X), so a stage's time grows linearly with |X|). With a cap the networks learn
    the smooth map from a sample of the cloud each epoch."""
    drop_cross_sheet: bool = False
    """When the cloud has oriented normals, give the LEG pairs whose normals disagree
    (``n_i . n_j <= 0``: the two sheets of a surface that doubles back) weight 0 in the
    network stages (not in the paper: False)."""

    def __post_init__(self) -> None:
        for name in ("epochs", "batch_points", "batch_domain", "epochs_min"):
            _count("ScheduleConfig", name, getattr(self, name))
        _count("ScheduleConfig", "max_steps_per_epoch", self.max_steps_per_epoch, allow_zero=True)
        if not isinstance(self.drop_cross_sheet, bool):
            raise InputError(f"ScheduleConfig.drop_cross_sheet: expected a bool, "
                             f"got {type(self.drop_cross_sheet).__name__}")
        for name in ("sigma", "alpha_initial", "alpha_final", "sigma_min", "alpha_max"):
            _positive("ScheduleConfig", name, getattr(self, name))


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

    def __post_init__(self) -> None:
        _choice("OptimizerConfig", "name", self.name, OPTIMIZERS)
        _positive("OptimizerConfig", "lr", self.lr)
        _positive("OptimizerConfig", "rmsprop_alpha", self.rmsprop_alpha)
        _positive("OptimizerConfig", "momentum", self.momentum, allow_zero=True)


@dataclass(frozen=True)
class LossWeights:
    """beta in eq. (optim problem overall); paper, section 6: (5, 1, 1)."""

    leg: float = 5.0
    """beta_1, LEG."""
    domain: float = 1.0
    """beta_2, HAND to the domain sample W."""
    landmarks: float = 1.0
    """beta_3, HAND of each landmark set to its target."""

    def __post_init__(self) -> None:
        for name in ("leg", "domain", "landmarks"):
            _positive("LossWeights", name, getattr(self, name), allow_zero=True)


@dataclass(frozen=True)
class RefineConfig:
    """Per-point refinement after the networks (not in the paper; ``steps = 0`` disables it).

    The networks give a smooth, unfolded map but cannot resolve it to the point
    spacing in a short budget (DESIGN.md: a 3 x 128 sine net regressed onto an
    LSCM map reproduces it only to 0.04-0.09 rad). The refinement optimizes
    each point's image ``y_i`` and ``l_i`` directly, starting from the networks'
    values, on LEG restricted to each point's ``neighbours`` nearest neighbours
    with ``sigma = sigma_spacing * h`` (``h``: mean nearest-neighbour distance),
    plus HAND of all points against a random batch of the domain sample when the
    domain is bounded. A kernel a few spacings wide keeps pairs at distances of
    order sigma, where LEG's signal is.
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
    hand_backend: str = "auto"
    """HAND of all points against the domain batch (:data:`pcgeom.losses.HAND_BACKENDS`):
    ``"auto"`` is ``"dense"`` while N x batch_domain is small
    (:data:`pcgeom.maps.refine.DENSE_HAND_MAX`) and the O(N) ``"knn"`` above; or a backend
    by name."""
    hand_neighbours: int = 8
    """k of the ``"knn"`` HAND: candidates per soft-min."""
    local_steps: bool = False
    """Scale each point's Adam step by its own median mapped distance to its neighbours in
    the start map, relative to the median over all points (False: the same step everywhere).
    Adam's steps are about ``lr`` per coordinate wherever the gradient is, so where the start
    map shrinks the surface (a conformal map near a protruding rim) equal steps fold it."""

    def __post_init__(self) -> None:
        _count("RefineConfig", "steps", self.steps, allow_zero=True)
        _count("RefineConfig", "neighbours", self.neighbours)
        _count("RefineConfig", "batch_domain", self.batch_domain)
        _choice("RefineConfig", "hand_backend", self.hand_backend, REFINE_HAND_BACKENDS)
        _count("RefineConfig", "hand_neighbours", self.hand_neighbours)
        if not isinstance(self.local_steps, bool):
            raise InputError(f"RefineConfig.local_steps: expected a bool, "
                             f"got {type(self.local_steps).__name__}")
        for name in ("sigma_spacing", "lr_spacing", "lr_lambda", "alpha"):
            _positive("RefineConfig", name, getattr(self, name))


DOMAIN_METHODS = ("injective", "harmonic")
"""The values of :attr:`LocalMeshConfig.domain_method`."""


@dataclass(frozen=True)
class LocalMeshConfig:
    """The local-mesh map of the free boundary (not in the paper; :mod:`pcgeom.maps.localmesh`).

    Same-sheet tangent fans of each point's neighbours, merged into a manifold mesh, then
    LSCM. Used when :attr:`ParamConfig.free_map` is ``"localmesh"`` and the domain is free.
    """

    neighbours: int = 24
    """Nearest neighbours each tangent fan is built from (face_human_choi with its normals:
    0.0403 rad with 12, 0.0276 with 16, 0.0229 with 24, 0.0303 with 32)."""
    normal_neighbours: int = 16
    """Neighbours of each point in the graph that orients estimated normals (a cloud without
    normals)."""
    normal_scales: tuple[int, ...] = (6, 8, 12, 16, 24)
    """Neighbour counts of the neighbourhood PCA (the surface test, and the normals of a cloud
    without them): each point's is the largest whose neighbours lie within
    :attr:`normal_tolerance` as flat as at its flattest (:func:`pcgeom.neighbours.adaptive_pca`).
    A pleated sheet whose sheets lie 2 spacings apart (:func:`pcgeom.synthetic.pleated_sheet`,
    6000 points, bare): 16 neighbours 0.174 rad, 2.9% flipped; these 0.0131, no flip (LSCM on
    its true mesh 0.0020: the folds, one spacing in radius, and the rim keep the rest); 2.5
    spacings: 0.058, 0.23% -> 0.0135, none; 1.5 spacings fail the surface test with 16 and
    map at 0.28 rad, 3.6% flipped with these. face_human_choi bare: 0.0380 -> 0.0364 rad,
    3.45% -> 2.61% flipped."""
    normal_tolerance: float = 0.03
    """How much more surface variation than its flattest scale a point's chosen scale may
    have. Smaller suits clean folds, larger noisy scans (the pleat at 2 spacings, earlier
    sampling: 0.01: 0.0099 rad, but face_human_choi 0.058; 0.03: 0.0114, 0.036; 0.06: 0.0128,
    0.032)."""
    robust_rounds: int = 1
    """Reweighted solves of the free LSCM after the first (:func:`pcgeom.maps.free.lscm_free`):
    each triangle's conformal energy weighted by ``max(1 / (1 + (d / robust_scale)^2),
    robust_floor)``, ``d`` how far from conformal the previous solve mapped it (anti-conformal
    over conformal part of its Jacobian). Triangles the local mesh got wrong (across a fold's
    bend, a crease's walls) cannot be mapped conformally with the rest, and plain LSCM spreads
    their error over the whole map. 0: plain LSCM. Measured (bare, ``fast``, angle distortion
    on the true triangles, 0 -> 1 round): the pleat of :func:`pcgeom.synthetic.pleated_sheet`
    with sheets 2 / 2.5 / 3 spacings apart 0.0131 / 0.0135 / 0.0144 -> 0.0100 / 0.0100 /
    0.0104 rad, no flip either way; face_human_choi 0.0364 -> 0.0342 (892 -> 885 flipped),
    peaks_three_cgal 0.0474 -> 0.0413, peaks_7holes_choi 0.0327 -> 0.0296, peaks3 0.0079 ->
    0.0070, face_3holes_small_choi 0.0107 -> 0.0103 (flips unchanged); the pleat at 1.5
    spacings, whose local mesh bridges its sheets, stays broken (0.2969 -> 0.2977 rad, 380 ->
    388 flipped; :attr:`normal_rounds` rebuild that mesh). A second round gains little
    (0.0097, 0.0097, 0.0100, 0.0340, 0.0398, 0.0292) for one more preconditioned
    conjugate-gradient solve."""
    robust_scale: float = 0.02
    """The distortion ``d`` at which a triangle's weight halves (:attr:`robust_rounds`):
    0.02, an angle off by about 0.04 rad. 0.01 / 0.05 (3 rounds): the pleat at 2 spacings
    0.0099 / 0.0094, face_human_choi 0.0347 / 0.0325 but 2.63% flipped instead of 2.59%."""
    robust_floor: float = 0.1
    """The smallest weight (:attr:`robust_rounds`). Without one, a triangle far from
    conformal is free to turn over: 3 rounds, no floor, map the pleat at 2 spacings at 0.0062
    rad but turn over 0.09% of peaks_7holes_choi's triangles (none with 0.1) and twice as
    many of peaks_three_cgal's."""
    normal_rounds: int = 6
    """Rounds of normals from the local mesh itself (:func:`pcgeom.maps.free.free_start`, a
    cloud without normals only): while the free map turns over more than
    :attr:`normal_round_flips` of the local mesh's own triangles, the mesh's vertex normals
    (each triangle weighted by its angle there) replace the estimated ones, the mesh is built
    again from them and mapped again; the map that turns over fewest is kept, and the rounds
    stop at the first that does no better. A mesh's normals average its triangles around
    the point, which PCA normals at a fold's bend (a spacing or two in radius) do not: on the
    pleat of :func:`pcgeom.synthetic.pleated_sheet` with sheets 1.5 spacings apart, 90th
    percentile normal error 21.5 -> 11.1 -> 9.9 degrees over two rounds (seed 0). Measured
    (bare, ``fast``, on the true triangles): that pleat, seeds 0-3, 0.2718 / 0.3243 / 0.2886
    / 0.2971 rad, 3.10 / 4.46 / 4.11 / 3.02% flipped -> 0.0525 / 0.0878 / 0.0417 / 0.0381 rad,
    0.27 / 0.77 / 0.74 / 0.33% (3-4 rounds); face_human_choi 0.0341 -> 0.0331 rad, 2.58% ->
    2.51% flipped (2 rounds: 2.5 s instead of 1.1). Going on after a round that does no
    better finds more at times (that pleat, seed 1: 0.0579 rad, 0.47% after 6 rounds;
    face_human_choi 0.0312, 2.41% after 3 rounds, 3.0 s). A map that turns over none (pleats
    2 spacings apart and more, every height field, face_3holes_small_choi,
    peaks_7holes_choi) runs none, and there the rounds would not help: forced on the pleats
    2-3 spacings apart, 0.0124-0.0137 rad where the first map has 0.0096-0.0106.
    0: none."""
    normal_round_flips: float = 0.001
    """The share of its own triangles (:func:`pcgeom.maps.localmesh.mesh_flips`) the free map
    may turn over before :attr:`normal_rounds` start, and at which they stop: 0.1%, the share
    the benchmarks hold a map that does not fold to (peaks_three_cgal's 3 of 3668 run none)."""
    facing: float = 0.2
    """The free map's local mesh keeps no triangle that stands across its corners' normals:
    none whose normal has ``|cos| <= facing`` with a corner's normal line (about 78 degrees
    apart; :func:`pcgeom.maps.localmesh.standing`). Such triangles cut the corner of a sharp
    lip or bridge a narrow groove's walls, and make handles no flat map can hold. A cloud with
    normals: its mesh is built so; without: when the mesh of the normals the
    :attr:`normal_rounds` kept has such a triangle, it is built again so (the rounds read the
    flips of the whole mesh) and its map kept if it turns over fewer of its own triangles,
    then distorts angles less on its own mesh. 0: off. Measured (bare, ``fast``, seed 0, on
    the true triangles, 0 -> 0.2):
    :func:`pcgeom.synthetic_folds.deep_folds` (6000 points) with walls 1.5 / 2 / 3 spacings
    apart 0.0217 / 0.0113 / 0.0134 -> 0.0178 / 0.0029 / 0.0022 rad (its exact map 0.0061 /
    0.0054 / 0.0045; local-mesh genus 1 / 7 / 3 -> 1 / 0 / 0), uniformly sampled 0.0937 /
    0.0342 / 0.0117 rad, 1.39 / 0.68 / 0.22% flipped -> 0.0876 / 0.0217 / 0.0086, 1.37 / 0.48
    / 0.06%; the pleats 1.5 / 2 / 2.5 spacings apart 0.0261 / 0.0100 / 0.0102 -> 0.0251 /
    0.0055 / 0.0036; face_human_choi 0.0333 rad, 2.49% -> 0.0325, 2.46% (onto the disk 0.0344,
    2.38% -> 0.0341, 2.45%: more flips there); peaks_three_cgal 0.0413, 0.22% -> 0.0406,
    0.00%; face_3holes_small_choi 0.0103 -> 0.0101, peaks_7holes_choi 0.0296 -> 0.0295 (no
    flip either way). 0.3 maps the uniform grooves 2
    spacings apart better (0.0123 rad, 0.23%) but a noisy range scan of a head
    (tests/test_scans.py) at 0.0821 rad, 40 flipped, against 0.0713 and 3 (0.2: 0.0708, 3).
    It costs one more mesh and solve where the kept mesh has a standing triangle (every
    shared surface bare: face_human_choi's free map 1.2-1.4x the time)."""
    vote: bool = True
    """A bare cloud's normals voted again where two walls face each other a spacing or two
    apart (:func:`pcgeom.neighbours.voted_normals`) and, when that turns 0.5% of them by more
    than 30 degrees, the local mesh built again from them and from its own normals
    (:func:`pcgeom.maps.free._voted`), its map kept if it scores better on its own mesh
    without leaving more points out. Measured (bare, ``fast``, on the true triangles, off ->
    on): :func:`pcgeom.synthetic_folds.deep_folds` (6000 points) with walls 1.5 spacings
    apart 0.0187 -> 0.0099 rad (its exact map 0.0061), uniformly sampled 0.0688 rad, 1.19%
    flipped -> 0.0380, 0.93%, 2 spacings apart 0.0201, 0.45% -> 0.0109, 0.17%; the pleat 1.5
    spacings apart 0.0251 -> 0.0154 rad; grooves 2-3 spacings wide, the pleats 2-2.5 apart and
    the shared surfaces, free and onto the disk, unchanged. False: off."""
    uv_remesh: bool = False
    """The local mesh built again from its free map (:mod:`pcgeom.maps.uvmesh`: a Delaunay
    triangulation of the points in the map's plane, kept where its triangles are short in
    space and face their normals, repaired, grown into the slits where the first map folded),
    mapped, and kept when it has fewer boundary loops, maps better on its own mesh and leaves
    at most 2% more points out (:func:`pcgeom.maps.uvmesh.remeshed`). Measured (``fast``,
    on the true triangles, off -> on, one run each, load 7-8, main be093d9, 2026-12-06):
    with the clouds' normals, peaks_three_cgal 6 -> 4 boundary loops (true 1), 0.0404 ->
    0.0377 rad, 1.9x the CPU; the lips sheet (11k, walls 0.75 spacings apart) 19 -> 13,
    0.0273 -> 0.0241 rad, 0.73 -> 0.72% flipped, 1.7x; face_human_choi (18 loops, its eyes'
    slits now filled by the repair), peaks_7holes_choi, face_3holes_small_choi and the pleats
    not kept (no fewer loops, or no better map on its own mesh), 1.2-1.4x the CPU. Bare,
    where the first map folds over flaps (face_human_choi 2% flipped, the lips) or the new
    map scores worse (the pleats), it is not kept: every shared surface's free and disk map
    the same, 1.0-1.15x the CPU; nine holed sheets (6000 points, uniform/grid/scan, seeds
    2-4): holes kept 34 -> 34, false loops 7 -> 3. Off by default for that cost: issue 36
    asks the same times within 1.2x, and on the shared surfaces it is kept on
    peaks_three_cgal alone."""
    refine_steps: int = 0
    """Steps of the LEG refinement (:class:`RefineConfig`, same-sheet pairs) after LSCM.
    0: none. Measured on face_human_choi from a 0.040 rad local-mesh map: 300 steps raise it to
    0.051 rad, so it is off by default."""
    disk_refine: bool = False
    """Refine the conformal disk map too (``ParamConfig.disk_map = "localmesh"``, no
    landmarks), with :attr:`domain_refine`: HAND spreads the points more evenly over the
    disk at a cost in angles, and pulls the rim off the circle. Measured (angle, flips,
    Hausdorff to the disk of the mapped points, and of the mapped true triangles; 2 CPU cores,
    bench_domains): three peaks 0.0167 rad, 0, 0.0248, 0.0001 -> 0.0258, 0, 0.0246, 0.0205
    (42 s); face_human_choi with its normals 0.0253, 28, 0.066, 0.0007 -> 0.068, 492, 0.043,
    0.027 (92 s); bare 0.0392, 1192, 0.063, 0.0007 -> 0.063, 1172, 0.040, 0.029. Off: angles,
    folds and a surface that fills the disk first (an area-preserving map of the face would
    still leave its points 0.030 apart from the disk, its own sampling gaps)."""
    domain_refine: RefineConfig = RefineConfig(steps=1000, batch_domain=8192, hand_backend="knn",
                                               local_steps=True)
    """The refinement after the first map onto a domain (``ParamConfig.domain_map =
    "localmesh"``): LEG on local pairs, HAND of all points onto the domain sample and the
    landmark terms. HAND against the whole sample (``batch_domain`` at least
    ``ParamConfig.domain_samples``) by the O(N) ``"knn"`` backend: a random batch each step
    shakes the map. face_3holes_small_choi onto ``smile`` from the harmonic map (0.296 rad):
    0.100 rad and 41 s for 1000 steps against the whole sample, 0.167 rad and 58 s for 300
    steps against batches of 1024 (dense); with ``local_steps`` 0.098 rad, 443 flips instead
    of 478."""

    domain_method: str = "injective"
    """How the map onto a domain other than the disk is made (:mod:`pcgeom.maps.domain`).
    ``"injective"``: onto a simply connected domain without landmarks, the conformal disk map
    composed with the domain's inverse Riemann map (:mod:`pcgeom.maps.riemann`), which does
    not fold, and no refinement (three peaks onto the square: 0.041 rad, 19 flips, the mapped
    surface 0.038 from the square -> 0.012 rad, 2 flips, 0.006); with landmarks, that map
    then the barrier map with the landmark term (:func:`pcgeom.maps.domain.landmarks_onto`,
    :attr:`ParamConfig.injective_landmarks`); onto a domain with holes, the harmonic layout
    made a bijection by the barrier map (:func:`pcgeom.maps.domain.injective_onto`,
    :attr:`ParamConfig.injective`), no refinement, unless a domain hole gets no hole of the
    cloud (then as ``"harmonic"``). ``"harmonic"``: the harmonic layout with holes on holes
    (:func:`pcgeom.maps.domain.harmonic_onto`), then :attr:`domain_refine`, which may fold."""
    free_landmark_weight: float = 0.0
    """Landmarks on the free boundary (:func:`pcgeom.maps.free_landmarks.pinned_free`): 0
    pins each landmark vertex on its target (LSCM with pinned vertices, as libigl's
    ``lscm(V, F, b, bc)``); a weight ``w > 0`` pulls them instead, ``w`` times the mean
    cotangent weight per pair beside LSCM's energy (``--landmark-weight``). Pins that would
    turn triangles over are pulled, with a warning."""

    def __post_init__(self) -> None:
        _positive("LocalMeshConfig", "free_landmark_weight", self.free_landmark_weight,
                  allow_zero=True)
        if self.domain_method not in DOMAIN_METHODS:
            raise InputError(f"LocalMeshConfig.domain_method: expected one of "
                             f"{', '.join(DOMAIN_METHODS)}, got {self.domain_method!r}")
        for name in ("neighbours", "normal_neighbours"):
            _count("LocalMeshConfig", name, getattr(self, name))
            if getattr(self, name) < 3:
                raise InputError(f"LocalMeshConfig.{name}: expected an int >= 3, "
                                 f"got {getattr(self, name)}")
        scales = self.normal_scales
        if (not isinstance(scales, (tuple, list)) or not scales
                or any(isinstance(k, bool) or not isinstance(k, int) or k < 3
                       for k in scales)):
            raise InputError(f"LocalMeshConfig.normal_scales: expected a non-empty sequence of "
                             f"ints >= 3, got {scales!r}")
        object.__setattr__(self, "normal_scales", tuple(int(k) for k in scales))
        if (isinstance(self.normal_tolerance, bool)
                or not isinstance(self.normal_tolerance, (int, float))
                or not 0 <= self.normal_tolerance < 1):
            raise InputError(f"LocalMeshConfig.normal_tolerance: expected a number in [0, 1), "
                             f"got {self.normal_tolerance!r}")
        _count("LocalMeshConfig", "refine_steps", self.refine_steps, allow_zero=True)
        _count("LocalMeshConfig", "robust_rounds", self.robust_rounds, allow_zero=True)
        _count("LocalMeshConfig", "normal_rounds", self.normal_rounds, allow_zero=True)
        if (isinstance(self.facing, bool) or not isinstance(self.facing, (int, float))
                or not 0 <= self.facing < 1):
            raise InputError(f"LocalMeshConfig.facing: expected a number in [0, 1), "
                             f"got {self.facing!r}")
        if (isinstance(self.normal_round_flips, bool)
                or not isinstance(self.normal_round_flips, (int, float))
                or not 0 <= self.normal_round_flips < 1):
            raise InputError(f"LocalMeshConfig.normal_round_flips: expected a number in [0, 1), "
                             f"got {self.normal_round_flips!r}")
        _positive("LocalMeshConfig", "robust_scale", self.robust_scale)
        if (isinstance(self.robust_floor, bool) or not isinstance(self.robust_floor, (int, float))
                or not 0 < self.robust_floor <= 1):
            raise InputError(f"LocalMeshConfig.robust_floor: expected a number in (0, 1], "
                             f"got {self.robust_floor!r}")
        if not isinstance(self.uv_remesh, bool):
            raise InputError(f"LocalMeshConfig.uv_remesh: expected a bool, "
                             f"got {type(self.uv_remesh).__name__}")
        if not isinstance(self.vote, bool):
            raise InputError(f"LocalMeshConfig.vote: expected a bool, "
                             f"got {type(self.vote).__name__}")
        if not isinstance(self.disk_refine, bool):
            raise InputError(f"LocalMeshConfig.disk_refine: expected a bool, "
                             f"got {type(self.disk_refine).__name__}")
        if not isinstance(self.domain_refine, RefineConfig):
            raise InputError(f"LocalMeshConfig.domain_refine: expected a RefineConfig, "
                             f"got {type(self.domain_refine).__name__}")


DENOISE_MODES = ("auto", "off", "on")
"""The values of :attr:`DenoiseConfig.mode`."""


@dataclass(frozen=True)
class DenoiseConfig:
    """Fit the surface before the map (not in the paper; :mod:`pcgeom.denoise`).

    The cloud's noise level is estimated (the residual of local quadric fits, in spacings:
    median nearest-neighbour distances in the tangent plane), each point is moved onto a
    weighted quadric fitted to its neighbours, and the map is made of the moved points; each
    input point keeps its row. Defaults measured on face_3holes_small_choi with depth noise
    (Gaussian along the normal) of 0.5 mean edge lengths, no normals, judged on the clean mesh:
    0.174 rad -> 0.064 rad (README, "Noisy scans").
    """

    mode: str = "off"
    """``"off"``: map the points as they are (the paper); ``"auto"``: denoise when the
    estimated noise exceeds :attr:`threshold`; ``"on"``: always."""
    width: float = 3.0
    """Gaussian width of each fit's weights, in spacings: at least this, and
    :attr:`width_per_noise` times the estimated noise. On face_3holes_small_choi with depth
    noise 0.5 (LSCM of the true connectivity on the moved points): 1 -> 0.090 rad,
    2 -> 0.068, 3 -> 0.063, 4 -> 0.062; on the clean points 0.0094 -> 0.0110 at 3."""
    width_per_noise: float = 5.0
    """The width grows with the noise: ``max(width, width_per_noise * noise)`` (noise in
    spacings). With depth noise 1.0 (estimated 0.98) on face_3holes_small_choi, the map's
    angle distortion at widths 2 / 3 / 5: 0.251 / 0.199 / 0.181 rad; at 0.25 (estimated
    0.34): 0.0266 / 0.0266 / 0.0279. 0: the width is :attr:`width` exactly (``--denoise
    STRENGTH``)."""
    threshold: float = 0.2
    """``"auto"`` denoises when the estimated noise std (fits of :attr:`noise_neighbours`)
    exceeds this many spacings. Clean surfaces read 0.005 (three peaks), 0.012
    (face_3holes_small_choi), 0.029 (face_human_choi), 0.044 (peaks_7holes_choi, 1850
    points), 0.094 (three peaks on a 16 x 16 grid), 0.155 (12 x 12); depth noise of 0.25 mean
    edge lengths on the two faces reads 0.32 and 0.47."""
    neighbours: int = 96
    """Points each fit may use (the Gaussian weights decide how much each counts)."""
    noise_neighbours: int = 16
    """Points of each quadric fit of the noise estimate that decides ``"auto"``; the level
    reported, and the fits' width, come from fits of twice as many. Small fits read a
    coarsely sampled clean surface as less noisy (three peaks on a 16 x 16 grid: 0.094
    spacings with 16, 0.247 with 32; 12 x 12: 0.155, 0.402); large ones under-read strong
    noise less (depth noise of 1 mean edge on face_3holes_small_choi: 0.70 of the true std
    with 16, 0.82 with 32)."""

    def __post_init__(self) -> None:
        _choice("DenoiseConfig", "mode", self.mode, DENOISE_MODES)
        _positive("DenoiseConfig", "width", self.width)
        _positive("DenoiseConfig", "width_per_noise", self.width_per_noise, allow_zero=True)
        _positive("DenoiseConfig", "threshold", self.threshold, allow_zero=True)
        for name in ("neighbours", "noise_neighbours"):
            _count("DenoiseConfig", name, getattr(self, name))
            if getattr(self, name) < 12:
                raise InputError(f"DenoiseConfig.{name}: expected an int >= 12, "
                                 f"got {getattr(self, name)}")


@dataclass(frozen=True)
class ParamConfig:
    """Everything that defines a run; saved with every result and checkpoint."""

    schedule: ScheduleConfig = ScheduleConfig()
    """Algorithm 1's stages."""
    optimizer: OptimizerConfig = OptimizerConfig()
    """Optimizer of the two networks."""
    weights: LossWeights = LossWeights()
    """beta_1, beta_2, beta_3."""
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
    """Per-point refinement after the networks (``steps = 0``: none, as the paper)."""
    dtype: str = "float32"
    """Torch dtype of training, ``"float32"`` or ``"float64"``."""
    free_map: str = "networks"
    """How the free-boundary map is made: ``"networks"``, Algorithm 1 (paper), or
    ``"localmesh"``, LSCM on a manifold mesh of same-sheet tangent fans
    (:class:`LocalMeshConfig`). Bounded domains: ``disk_map`` and ``domain_map``."""
    disk_map: str = "networks"
    """How a map onto a disk without landmarks is made: ``"networks"`` (paper) or
    ``"localmesh"``, the local-mesh map made conformal onto the disk
    (:func:`pcgeom.maps.disk.conformal_disk`)."""
    domain_map: str = "networks"
    """How a map onto any other bounded domain, or with landmarks, is made: ``"networks"``
    (paper) or ``"localmesh"`` (:func:`pcgeom.maps.domain.domain_map`): onto a domain without
    holes the disk map composed with the domain's inverse Riemann map, onto a domain with
    holes or with landmarks the barrier map (:attr:`injective`, :attr:`injective_landmarks`),
    as :attr:`LocalMeshConfig.domain_method` says."""
    local_mesh: LocalMeshConfig = LocalMeshConfig()
    """Settings of the ``"localmesh"`` maps."""
    denoise: DenoiseConfig = DenoiseConfig()
    """Fit the surface before the map (off: the paper maps the points as they are)."""
    injective: InjectiveConfig = InjectiveConfig()
    """The barrier map of ``domain_map = "localmesh"`` onto a domain with holes
    (:func:`pcgeom.maps.domain.injective_onto`)."""
    injective_landmarks: InjectiveConfig = LANDMARKS_INJECTIVE
    """The barrier map of ``domain_map = "localmesh"`` with landmarks onto a domain without
    holes (:func:`pcgeom.maps.domain.landmarks_onto`);
    :data:`pcgeom.config.barrier.LANDMARKS_INJECTIVE` by default."""

    def __post_init__(self) -> None:
        _count("ParamConfig", "domain_samples", self.domain_samples)
        _count("ParamConfig", "max_stages", self.max_stages, allow_zero=True)
        _choice("ParamConfig", "init_map", self.init_map, INIT_MAPS)
        _choice("ParamConfig", "dtype", self.dtype, DTYPES)
        _choice("ParamConfig", "free_map", self.free_map, FREE_MAPS)
        _choice("ParamConfig", "disk_map", self.disk_map, DISK_MAPS)
        _choice("ParamConfig", "domain_map", self.domain_map, DOMAIN_MAPS)
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            expected = _field_types(ParamConfig)[f.name]
            if dataclasses.is_dataclass(expected) and not isinstance(value, expected):
                raise InputError(f"ParamConfig.{f.name}: expected a {expected.__name__}, "
                                 f"got {type(value).__name__}")

    def to_dict(self) -> dict:
        """Plain nested dict (JSON-serializable: tuples as lists, so that it equals its JSON
        round trip); :func:`config_from_dict` inverts it."""
        return _plain(dataclasses.asdict(self))

    @classmethod
    def from_dict(cls, data: dict) -> "ParamConfig":
        """The config a :meth:`to_dict` dict describes (see :func:`config_from_dict`)."""
        return config_from_dict(cls, data)


def _plain(value):
    """``value`` with every tuple a list, recursively (what JSON gives back)."""
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    return value


def _field_types(cls) -> dict[str, type]:
    """Resolved annotations of a dataclass (``from __future__ import annotations`` makes them
    strings)."""
    return typing.get_type_hints(cls)


def config_from_dict(cls, data: dict, where: str | None = None):
    """Build the dataclass ``cls`` from a nested dict, recursing into dataclass fields.

    Missing keys take the field's default (so files written before a field existed still
    load); unknown keys are an error, as is a value the config rejects.

    ``where`` names the place in messages (default: the class name; nested fields read
    ``ParamConfig.schedule``).

    Raises
    ------
    InputError
        ``data`` is not a dict, has keys ``cls`` does not know, or holds an invalid value.
    """
    where = where or cls.__name__
    if not isinstance(data, dict):
        raise InputError(f"{where}: expected a dict, got {type(data).__name__}")
    types = _field_types(cls)
    names = {f.name for f in dataclasses.fields(cls)}
    unknown = sorted(set(data) - names)
    if unknown:
        raise InputError(f"{where}: unknown field(s) {', '.join(unknown)}; "
                         f"known: {', '.join(sorted(names))}")
    kwargs = {}
    for name, value in data.items():
        if dataclasses.is_dataclass(types[name]):
            value = config_from_dict(types[name], value, f"{where}.{name}")
        kwargs[name] = value
    try:
        return cls(**kwargs)
    except TypeError as exc:
        raise InputError(f"{where}: {exc}") from None


# --------------------------------------------------------------------------- presets


_FAST_NETWORKS = ParamConfig(
    # At most 8 steps per epoch: the three peaks (5776 points: 6 and 3 steps) train as before,
    # a 100k-point cloud no longer takes 98 steps per epoch. drop_cross_sheet stays off until
    # measured: on face_human_choi 29% of all pairs (28% kernel-weighted) have n_i . n_j <= 0
    # because the face wraps around, not because of a second sheet.
    schedule=ScheduleConfig(epochs=120, sigma=0.5, alpha_initial=2.0, alpha_final=20.0,
                            epochs_min=30, max_steps_per_epoch=8),
    optimizer=OptimizerConfig(name="adam", lr=1e-3),
    param_net=NetConfig(width=128, depth=3, init="siren", w0=5.0),
    lambda_net=NetConfig(width=64, depth=2, init="siren", w0=5.0),
    max_stages=2,
    init_map="plane",
    refine=RefineConfig(steps=1000),
)

PRESETS: dict[str, ParamConfig] = {
    # Section 6 exactly: E = 10000, B = 1024, sigma 0.5, alpha 2 -> 20, caps
    # (0.001, 100, 1000), RMSprop(alpha 0.99, lr 1e-4, momentum 0.9), beta (5, 1, 1),
    # randomly initialized sine networks, all stages until the batch is the cloud.
    "paper": ParamConfig(),
    # Everyday use: the free boundary by the local-mesh map (LSCM on same-sheet tangent fans:
    # seconds, and it unfolds where a scan doubles back), the disk by the same made
    # conformal onto it, domains without holes by that map composed with their inverse
    # Riemann map, domains with holes and landmarks by the barrier map (maps.domain).
    # Noisy scans are fitted first (DenoiseConfig, "auto": clean ones are left as they are).
    "fast": dataclasses.replace(_FAST_NETWORKS, free_map="localmesh", disk_map="localmesh",
                                domain_map="localmesh", denoise=DenoiseConfig(mode="auto")),
    # The networks for everyday use: Adam at 1e-3 on SIREN-initialized nets, the
    # parametrization net starting from the best-fit-plane projection, for two short stages
    # (sigma 0.5 -> 0.35, batches 1024 -> 2048) to get a smooth unfolded map, then the
    # per-point refinement on local LEG pairs. It was `fast` before the local-mesh map.
    "networks": _FAST_NETWORKS,
}
"""Named configs. ``paper`` is section 6 exactly; ``fast`` is the everyday default;
``networks`` is ``fast`` with the networks for the free boundary too (the ``fast`` of 0.1.0)."""


def get_preset(name: str, **overrides) -> ParamConfig:
    """A named preset, optionally with top-level fields replaced (``dataclasses.replace``).

    Raises
    ------
    InputError
        Unknown name (the message lists the presets) or an invalid override.
    """
    if name not in PRESETS:
        raise InputError(f"unknown preset {name!r}; choose one of: {', '.join(PRESETS)}")
    fields = {f.name for f in dataclasses.fields(ParamConfig)}
    unknown = sorted(set(overrides) - fields)
    if unknown:
        raise InputError(f"get_preset: unknown field(s) {', '.join(unknown)}; "
                         f"known: {', '.join(sorted(fields))}")
    return dataclasses.replace(PRESETS[name], **overrides)


def preset_name(config: ParamConfig) -> str:
    """The name of the preset equal to ``config``; of one it equals but for ``--denoise
    VALUE`` (:func:`with_denoise`), the name and that value, e.g. ``"fast (denoise off)"``
    or ``"fast (denoise 2)"``; else ``"custom"``."""
    exact = next((name for name, preset in PRESETS.items() if preset == config), None)
    if exact is not None:
        return exact
    for name, preset in PRESETS.items():
        if dataclasses.replace(config, denoise=preset.denoise) != preset:
            continue
        d = config.denoise
        value = d.mode if d.mode in ("auto", "off") else f"{d.width:g}"
        if with_denoise(preset, value) == config:
            return f"{name} (denoise {value})"
    return "custom"


DENOISE_OPTION = "auto, off or a positive number (the fit's width in spacings)"
"""What ``--denoise`` accepts, for messages."""


def denoise_config(value, base: DenoiseConfig | None = None) -> DenoiseConfig:
    """The :class:`DenoiseConfig` of ``--denoise VALUE``.

    Parameters
    ----------
    value : str or float
        ``"auto"`` or ``"off"`` (the mode), or a strength: a positive number, the Gaussian
        width of the surface fits in spacings (:attr:`DenoiseConfig.width`, whatever the
        noise), always applied.
    base : DenoiseConfig, optional
        The config whose other fields are kept (a preset's); default ``DenoiseConfig()``.

    Raises
    ------
    InputError
        Anything else; the message says what is accepted.
    """
    base = base if base is not None else DenoiseConfig()
    if isinstance(value, str) and value.strip().lower() in ("auto", "off"):
        return dataclasses.replace(base, mode=value.strip().lower())
    try:
        width = float(value)
    except (TypeError, ValueError):
        width = math.nan
    if isinstance(value, bool) or not (math.isfinite(width) and width > 0):
        raise InputError(f"denoise: expected {DENOISE_OPTION}, got {value!r}")
    return dataclasses.replace(base, mode="on", width=width, width_per_noise=0.0)


def with_landmark_weight(config: ParamConfig, value=None) -> ParamConfig:
    """``config`` with ``--landmark-weight VALUE`` (:attr:`LocalMeshConfig.free_landmark_weight`);
    None keeps it as it is."""
    if value is None:
        return config
    return dataclasses.replace(config, local_mesh=dataclasses.replace(
        config.local_mesh, free_landmark_weight=float(value)))


def with_denoise(config: ParamConfig, value=None) -> ParamConfig:
    """``config`` with ``--denoise VALUE`` (:func:`denoise_config` on its own denoise
    settings); None keeps it as it is."""
    if value is None:
        return config
    return dataclasses.replace(config, denoise=denoise_config(value, config.denoise))
