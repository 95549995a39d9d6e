"""The barrier map's settings (:func:`pcgeom.maps.injective.injective_map`): frozen, validated
when built, nested in :class:`pcgeom.config.ParamConfig` (``injective``,
``injective_landmarks``) and saved with every result."""

from __future__ import annotations

from dataclasses import dataclass

from ..errors import InputError
from ..mesh import RIM_ANGLE_DEG
from ._checks import _choice, _count, _flag, _fraction, _positive

__all__ = ["InjectiveConfig", "UntangleConfig", "PullConfig", "BarrierConfig", "ENERGIES",
           "STARTS", "SOLVERS", "LANDMARKS_INJECTIVE"]

ENERGIES = ("mips", "root_mips", "symmetric_dirichlet")
"""Barrier energies of step 4 (:mod:`pcgeom.maps.injective`)."""

STARTS = ("auto", "untangle", "pull")
"""Flip-free starts of step 3: ``"untangle"``, ``"pull"`` (Tutte's embedding, the loops pulled
onto their rings), ``"auto"``: untangle, and pull when that leaves a fold."""

SOLVERS = ("newton", "lbfgs")
"""Minimizers of steps 3 and 4: projected Newton, or L-BFGS."""


@dataclass(frozen=True)
class UntangleConfig:
    """Step 3 (:func:`pcgeom.maps.injective.untangle`): Garanzha et al. 2021."""

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

    def __post_init__(self) -> None:
        _positive("UntangleConfig", "theta", self.theta)
        _choice("UntangleConfig", "method", self.method, SOLVERS)
        for name in ("newton_steps", "inner", "rounds"):
            _count("UntangleConfig", name, getattr(self, name))
        _fraction("UntangleConfig", "decrease", self.decrease)
        _positive("UntangleConfig", "tolerance", self.tolerance)
        _flag("UntangleConfig", "stop_when_unfolded", self.stop_when_unfolded)
        _count("UntangleConfig", "local", self.local, allow_zero=True)


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

    def __post_init__(self) -> None:
        _positive("PullConfig", "weight", self.weight)
        _positive("PullConfig", "growth", self.growth)
        if self.growth < 1:
            raise InputError(f"PullConfig.growth: expected a number >= 1, got {self.growth!r}")
        _count("PullConfig", "stages", self.stages)
        _count("PullConfig", "iterations", self.iterations)
        _positive("PullConfig", "tolerance", self.tolerance)


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
    """The first trial step is at most this fraction of
    :func:`pcgeom.maps.injective.max_feasible_step`."""
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
    (:mod:`pcgeom.maps.injective.landmarks`): along target curves sampled evenly (a landmark
    file's polylines), each piece of landmark points spread along its curve by arc length;
    other targets paired with the nearest landmark point both ways (a Chamfer distance). The car
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

    def __post_init__(self) -> None:
        _choice("BarrierConfig", "energy", self.energy, ENERGIES)
        _positive("BarrierConfig", "power", self.power)
        _choice("BarrierConfig", "method", self.method, SOLVERS)
        _count("BarrierConfig", "iterations", self.iterations, allow_zero=True)
        for name in ("patience", "memory", "refactor", "landmark_rounds"):
            _count("BarrierConfig", name, getattr(self, name))
        _fraction("BarrierConfig", "max_fraction", self.max_fraction, closed=True)
        _flag("BarrierConfig", "slide", self.slide)
        for name in ("blend", "tolerance", "cover", "landmarks", "flip_guard"):
            _positive("BarrierConfig", name, getattr(self, name), allow_zero=True)


@dataclass(frozen=True)
class InjectiveConfig:
    """:func:`pcgeom.maps.injective.injective_map`'s settings: the barrier map onto a domain
    with holes (:attr:`pcgeom.config.ParamConfig.injective`) or with landmarks
    (:attr:`pcgeom.config.ParamConfig.injective_landmarks`)."""

    start: str = "auto"
    """One of :data:`STARTS`."""
    rim_angle: float = RIM_ANGLE_DEG
    """Rim triangles whose 3D angle opposite their boundary edge is wider than this,
    degrees, are dropped, their third vertex joining the rim (:func:`pcgeom.mesh.peel_rim`);
    180: none."""
    corner_angle: float = 20.0
    """A ring turning by more than this at a point, degrees, has a corner there, and the
    nearest loop vertex is pinned to it (the smile's eyes and mouth turn by 90; its arcs by
    0.7 at each point)."""
    scaffold: float = 1.0
    """Weight of the fans that fill the holes paired with no ring (step 2), against the
    mesh's own triangles. face_human_choi with a hole, onto ``annulus:0.3`` (its local mesh
    has 47 small holes where eyelids and lips close): 0.01 lets them open wide, 0.048 rad;
    1: 0.044 rad."""
    follow_bend: bool = False
    """In :func:`pcgeom.maps.domain.landmarks_onto`, the rows on no triangle of the cleaned
    mesh (off the local mesh's main part, or tips of dropped triangles) move with the map from
    its start (:func:`pcgeom.maps.follow.follow_rest`: where the piecewise linear map from the
    start takes them), instead of being laid anew at the mean of their neighbours in the
    map: they follow the bend towards the landmarks and keep their side of every edge.
    peaks_three_cgal, four landmarks 0.05 off a disk automorphism's image (bench_landmarks'
    seed 0): 2 true triangles turned over -> 0. Off by default: there the start is a
    harmonic map that may fold, with no layout worth keeping."""
    untangle: UntangleConfig = UntangleConfig()
    """Step 3."""
    pull: PullConfig = PullConfig()
    """The ``"pull"`` start."""
    barrier: BarrierConfig = BarrierConfig()
    """Step 4."""

    def __post_init__(self) -> None:
        _choice("InjectiveConfig", "start", self.start, STARTS)
        for name in ("rim_angle", "corner_angle"):
            value = getattr(self, name)
            _positive("InjectiveConfig", name, value)
            if value > 180:
                raise InputError(f"InjectiveConfig.{name}: expected degrees in (0, 180], "
                                 f"got {value!r}")
        _positive("InjectiveConfig", "scaffold", self.scaffold)
        _flag("InjectiveConfig", "follow_bend", self.follow_bend)
        for name, cls in (("untangle", UntangleConfig), ("pull", PullConfig),
                          ("barrier", BarrierConfig)):
            if not isinstance(getattr(self, name), cls):
                raise InputError(f"InjectiveConfig.{name}: expected a {cls.__name__}, "
                                 f"got {type(getattr(self, name)).__name__}")


LANDMARKS_INJECTIVE = InjectiveConfig(rim_angle=150.0, follow_bend=True,
                                      untangle=UntangleConfig(local=3),
                                      barrier=BarrierConfig(landmarks=1e4, cover=0.0,
                                                            tolerance=1e-4, refactor=2))
"""The barrier map with landmarks (:func:`pcgeom.maps.domain.landmarks_onto`): the conformal
start folds a few triangles, mended where they are; the landmark term weighs 1e4, and the
uncovered-area term is off. Measured on the car shell with its window edges (2500 points;
angle and flips on the true triangles, then the window edges' Hausdorff distance to their
targets, the surface's to the domain): the conformal start 0.028 rad, 4 flips, 0.129, 0.038;
landmarks 1e3: 0.077 rad, 19 flips, 0.040, 0.195; 1e4 without the cover term: 0.045 rad, 6
flips, 0.023, 0.085 (with it, 1: 0.050, 8, 0.024, 0.153: the rim slides away from the
arches); the landmarks paired along the target lines by arc length, 1e4: 0.0455 rad, 5 flips
(the disk map of the same cloud: 5), 0.011, 0.096. The tolerance 1e-4 (not 1e-5): 14k points
of the three peaks onto the disk, four point landmarks 0.05 off a conformal image of the
landmark-free map, stop after 35 steps, not 188, at 1.308x the landmark-free angle error, not
1.306x. ``refactor=2`` (each Hessian and its factor serve two Newton steps), side by side
against 1: that case (seeds 1, 2) 19.1 and 18.0 s -> 13.6 and 13.4 s at 1.358x and 1.487x
-> 1.344x and 1.466x, 3 and 4 -> 3 and 5 true triangles flipped of 27k; the car 29.0 ->
24.6 s at the same 0.0429 rad and 4 flips; face_3holes_small_choi (3 seeds) the same angles
to 0.002x and flips. ``rim_angle=150`` (the disk map's own
:data:`pcgeom.maps.disk.RELEASE_ANGLE_DEG`; rim triangles of 120 to 150 degrees are kept, not
peeled onto the ring): peaks_three_cgal's true rim triangles of 136 and 142 degrees, peeled,
put their apex on the ring between the other corners, where the barrier map cannot keep it
inside the chord: four landmarks 0.05 off (bench_landmarks' seed 1) turned 2 of its 3671 true
triangles over, 0.0670 rad; with 150 none, 0.0664 (180: none, 0.0668)."""
