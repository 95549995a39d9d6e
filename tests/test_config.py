"""Configuration as data (pcgeom.config): presets, validation at construction, dict round trips.

Every config rejects a bad value when it is built, with an InputError naming ``Class.field``
and, for a choice, the allowed values; ``config_from_dict`` inverts ``to_dict`` (also through
JSON, which is how results and checkpoints store the config).
"""

from __future__ import annotations

import dataclasses
import json

import pytest

from pcgeom.config import (
    PRESETS,
    BarrierConfig,
    InjectiveConfig,
    LocalMeshConfig,
    LossWeights,
    NetConfig,
    OptimizerConfig,
    ParamConfig,
    PullConfig,
    RefineConfig,
    ScheduleConfig,
    UntangleConfig,
    config_from_dict,
    get_preset,
    preset_name,
    with_denoise,
)
from pcgeom.errors import InputError

# --------------------------------------------------------------------------- presets


def test_paper_preset_holds_section_6():
    cfg = get_preset("paper")
    s = cfg.schedule
    assert (s.epochs, s.batch_points, s.batch_domain) == (10000, 1024, 1024)
    assert (s.sigma, s.alpha_initial, s.alpha_final) == (0.5, 2.0, 20.0)
    assert (s.sigma_min, s.alpha_max, s.epochs_min) == (0.001, 100.0, 1000)
    o = cfg.optimizer
    assert (o.name, o.lr, o.rmsprop_alpha, o.momentum) == ("rmsprop", 1e-4, 0.99, 0.9)
    assert (cfg.weights.leg, cfg.weights.domain, cfg.weights.landmarks) == (5.0, 1.0, 1.0)
    assert cfg.refine.steps == 0
    assert cfg.max_stages == 0
    assert cfg.param_net.init == cfg.lambda_net.init == "default"  # randomly initialized nets
    assert cfg.init_map == "random"  # section 6: random initialization
    assert cfg == ParamConfig()  # the defaults are the paper's


def test_unknown_preset_lists_the_choices():
    with pytest.raises(InputError, match=r"^unknown preset 'turbo'; choose one of: paper, fast, networks$"):
        get_preset("turbo")


def test_preset_overrides_replace_fields_and_leave_the_preset_alone():
    cfg = get_preset("paper", max_stages=3, refine=RefineConfig(steps=7))
    assert cfg.max_stages == 3 and cfg.refine.steps == 7
    assert cfg.schedule == PRESETS["paper"].schedule
    assert PRESETS["paper"].max_stages == 0 and PRESETS["paper"].refine.steps == 0
    with pytest.raises(InputError, match=r"^get_preset: unknown field\(s\) no_such_field; known: "):
        get_preset("paper", no_such_field=1)
    # An override is validated like any other value.
    with pytest.raises(InputError, match=r"^ParamConfig\.dtype: unknown value 'float16'"):
        get_preset("fast", dtype="float16")


def test_preset_name():
    assert preset_name(get_preset("fast")) == "fast"
    assert preset_name(get_preset("paper")) == "paper"
    assert preset_name(ParamConfig()) == "paper"
    assert preset_name(get_preset("fast", max_stages=3)) == "custom"
    assert preset_name(get_preset("paper", dtype="float64")) == "custom"
    # A preset but for --denoise is named after it (issue 39: "custom" though param printed
    # "preset fast").
    assert preset_name(with_denoise(get_preset("fast"), "off")) == "fast (denoise off)"
    assert preset_name(with_denoise(get_preset("fast"), 2)) == "fast (denoise 2)"
    assert preset_name(with_denoise(get_preset("networks"), "2.5")) == "networks (denoise 2.5)"
    assert preset_name(with_denoise(get_preset("fast"), "auto")) == "fast"  # fast's own
    assert preset_name(with_denoise(get_preset("fast", max_stages=3), "off")) == "custom"
    # Equality, not identity: a preset read back from JSON still has its name.
    back = ParamConfig.from_dict(json.loads(json.dumps(get_preset("fast").to_dict())))
    assert preset_name(back) == "fast"


@pytest.mark.parametrize(
    "obj, attr",
    [
        (ParamConfig(), "max_stages"),
        (ScheduleConfig(), "epochs"),
        (OptimizerConfig(), "lr"),
        (LossWeights(), "leg"),
        (RefineConfig(), "steps"),
        (NetConfig(), "width"),
    ],
)
def test_configs_are_frozen(obj, attr):
    with pytest.raises(dataclasses.FrozenInstanceError):
        setattr(obj, attr, 1)


# --------------------------------------------------------------------------- validation


@pytest.mark.parametrize(
    "make, message",
    [
        # choices: the message lists the allowed values
        (lambda: ParamConfig(dtype="float16"),
         "ParamConfig.dtype: unknown value 'float16'; choose one of: float32, float64"),
        (lambda: ParamConfig(init_map="pca"),
         "ParamConfig.init_map: unknown value 'pca'; choose one of: random, plane"),
        (lambda: OptimizerConfig(name="sgd"),
         "OptimizerConfig.name: unknown value 'sgd'; choose one of: rmsprop, adam"),
        (lambda: NetConfig(init="relu"),
         "NetConfig.init: unknown value 'relu'; choose one of: siren, default"),
        # counts
        (lambda: ScheduleConfig(epochs=-5), "ScheduleConfig.epochs: expected an int >= 1, got -5"),
        (lambda: ScheduleConfig(epochs=0), "ScheduleConfig.epochs: expected an int >= 1, got 0"),
        (lambda: ScheduleConfig(batch_points=64.0),
         "ScheduleConfig.batch_points: expected an int, got float"),
        (lambda: ScheduleConfig(batch_domain=True),
         "ScheduleConfig.batch_domain: expected an int, got bool"),
        (lambda: ScheduleConfig(epochs_min=0),
         "ScheduleConfig.epochs_min: expected an int >= 1, got 0"),
        (lambda: NetConfig(width=0), "NetConfig.width: expected an int >= 1, got 0"),
        (lambda: NetConfig(depth=0), "NetConfig.depth: expected an int >= 1, got 0"),
        (lambda: RefineConfig(steps=-1), "RefineConfig.steps: expected an int >= 0, got -1"),
        (lambda: RefineConfig(neighbours=0),
         "RefineConfig.neighbours: expected an int >= 1, got 0"),
        (lambda: RefineConfig(batch_domain="1024"),
         "RefineConfig.batch_domain: expected an int, got str"),
        (lambda: ParamConfig(domain_samples=0),
         "ParamConfig.domain_samples: expected an int >= 1, got 0"),
        (lambda: ParamConfig(max_stages=-1),
         "ParamConfig.max_stages: expected an int >= 0, got -1"),
        # positive numbers
        (lambda: ScheduleConfig(sigma=0.0),
         "ScheduleConfig.sigma: expected a positive finite number, got 0.0"),
        (lambda: ScheduleConfig(sigma=float("nan")),
         "ScheduleConfig.sigma: expected a positive finite number, got nan"),
        (lambda: ScheduleConfig(alpha_max=float("inf")),
         "ScheduleConfig.alpha_max: expected a positive finite number, got inf"),
        (lambda: NetConfig(w0=-5.0), "NetConfig.w0: expected a positive finite number, got -5.0"),
        (lambda: OptimizerConfig(lr=-1e-3),
         "OptimizerConfig.lr: expected a positive finite number, got -0.001"),
        (lambda: OptimizerConfig(momentum=-0.1),
         "OptimizerConfig.momentum: expected a non-negative finite number, got -0.1"),
        (lambda: LossWeights(leg=-1.0),
         "LossWeights.leg: expected a non-negative finite number, got -1.0"),
        (lambda: RefineConfig(alpha="100"),
         "RefineConfig.alpha: expected a positive finite number, got '100'"),
        (lambda: LocalMeshConfig(normal_scales=()),
         "LocalMeshConfig.normal_scales: expected a non-empty sequence of ints >= 3, got ()"),
        (lambda: LocalMeshConfig(normal_scales=(6, 2)),
         "LocalMeshConfig.normal_scales: expected a non-empty sequence of ints >= 3, "
         "got (6, 2)"),
        (lambda: LocalMeshConfig(normal_tolerance=1.5),
         "LocalMeshConfig.normal_tolerance: expected a number in [0, 1), got 1.5"),
        (lambda: LocalMeshConfig(robust_rounds=-1),
         "LocalMeshConfig.robust_rounds: expected an int >= 0, got -1"),
        (lambda: LocalMeshConfig(robust_rounds=1.0),
         "LocalMeshConfig.robust_rounds: expected an int, got float"),
        (lambda: LocalMeshConfig(robust_scale=0.0),
         "LocalMeshConfig.robust_scale: expected a positive finite number, got 0.0"),
        (lambda: LocalMeshConfig(robust_floor=0.0),
         "LocalMeshConfig.robust_floor: expected a number in (0, 1], got 0.0"),
        (lambda: LocalMeshConfig(robust_floor=True),
         "LocalMeshConfig.robust_floor: expected a number in (0, 1], got True"),
        (lambda: LocalMeshConfig(normal_rounds=-2),
         "LocalMeshConfig.normal_rounds: expected an int >= 0, got -2"),
        (lambda: LocalMeshConfig(normal_round_flips=1.0),
         "LocalMeshConfig.normal_round_flips: expected a number in [0, 1), got 1.0"),
        (lambda: LocalMeshConfig(normal_round_flips=False),
         "LocalMeshConfig.normal_round_flips: expected a number in [0, 1), got False"),
        (lambda: LocalMeshConfig(vote=1),
         "LocalMeshConfig.vote: expected a bool, got int"),
        (lambda: LocalMeshConfig(uv_remesh=1),
         "LocalMeshConfig.uv_remesh: expected a bool, got int"),
        # the barrier map's settings
        (lambda: UntangleConfig(theta=0.0),
         "UntangleConfig.theta: expected a positive finite number, got 0.0"),
        (lambda: UntangleConfig(method="bfgs"),
         "UntangleConfig.method: unknown value 'bfgs'; choose one of: newton, lbfgs"),
        (lambda: UntangleConfig(newton_steps=0),
         "UntangleConfig.newton_steps: expected an int >= 1, got 0"),
        (lambda: UntangleConfig(inner=2.5), "UntangleConfig.inner: expected an int, got float"),
        (lambda: UntangleConfig(rounds=0), "UntangleConfig.rounds: expected an int >= 1, got 0"),
        (lambda: UntangleConfig(decrease=1.0),
         "UntangleConfig.decrease: expected a number in (0, 1), got 1.0"),
        (lambda: UntangleConfig(tolerance=-1e-6),
         "UntangleConfig.tolerance: expected a positive finite number, got -1e-06"),
        (lambda: UntangleConfig(stop_when_unfolded=1),
         "UntangleConfig.stop_when_unfolded: expected True or False, got 1"),
        (lambda: UntangleConfig(local=-1), "UntangleConfig.local: expected an int >= 0, got -1"),
        (lambda: PullConfig(weight=float("nan")),
         "PullConfig.weight: expected a positive finite number, got nan"),
        (lambda: PullConfig(growth=0.5), "PullConfig.growth: expected a number >= 1, got 0.5"),
        (lambda: PullConfig(growth=-2.0),
         "PullConfig.growth: expected a positive finite number, got -2.0"),
        (lambda: InjectiveConfig(rim_angle=190.0),
         "InjectiveConfig.rim_angle: expected degrees in (0, 180], got 190.0"),
        (lambda: PullConfig(stages=0), "PullConfig.stages: expected an int >= 1, got 0"),
        (lambda: PullConfig(iterations=0), "PullConfig.iterations: expected an int >= 1, got 0"),
        (lambda: PullConfig(tolerance=0), "PullConfig.tolerance: expected a positive finite "
                                          "number, got 0"),
        (lambda: BarrierConfig(energy="arap"),
         "BarrierConfig.energy: unknown value 'arap'; choose one of: mips, root_mips, "
         "symmetric_dirichlet"),
        (lambda: BarrierConfig(power=0), "BarrierConfig.power: expected a positive finite "
                                         "number, got 0"),
        (lambda: BarrierConfig(method="adam"),
         "BarrierConfig.method: unknown value 'adam'; choose one of: newton, lbfgs"),
        (lambda: BarrierConfig(iterations=-1),
         "BarrierConfig.iterations: expected an int >= 0, got -1"),
        (lambda: BarrierConfig(patience=0), "BarrierConfig.patience: expected an int >= 1, got 0"),
        (lambda: BarrierConfig(memory=0), "BarrierConfig.memory: expected an int >= 1, got 0"),
        (lambda: BarrierConfig(refactor=0), "BarrierConfig.refactor: expected an int >= 1, got 0"),
        (lambda: BarrierConfig(landmark_rounds=0),
         "BarrierConfig.landmark_rounds: expected an int >= 1, got 0"),
        (lambda: BarrierConfig(max_fraction=1.5),
         "BarrierConfig.max_fraction: expected a number in (0, 1], got 1.5"),
        (lambda: BarrierConfig(slide="yes"), "BarrierConfig.slide: expected True or False, "
                                             "got 'yes'"),
        (lambda: BarrierConfig(blend=-0.1),
         "BarrierConfig.blend: expected a non-negative finite number, got -0.1"),
        (lambda: BarrierConfig(tolerance=-1.0),
         "BarrierConfig.tolerance: expected a non-negative finite number, got -1.0"),
        (lambda: BarrierConfig(cover=-1.0),
         "BarrierConfig.cover: expected a non-negative finite number, got -1.0"),
        (lambda: BarrierConfig(landmarks=float("inf")),
         "BarrierConfig.landmarks: expected a non-negative finite number, got inf"),
        (lambda: BarrierConfig(flip_guard=-0.01),
         "BarrierConfig.flip_guard: expected a non-negative finite number, got -0.01"),
        (lambda: InjectiveConfig(start="tutte"),
         "InjectiveConfig.start: unknown value 'tutte'; choose one of: auto, untangle, pull"),
        (lambda: InjectiveConfig(rim_angle=0),
         "InjectiveConfig.rim_angle: expected a positive finite number, got 0"),
        (lambda: InjectiveConfig(corner_angle=200.0),
         "InjectiveConfig.corner_angle: expected degrees in (0, 180], got 200.0"),
        (lambda: InjectiveConfig(scaffold=0.0),
         "InjectiveConfig.scaffold: expected a positive finite number, got 0.0"),
        (lambda: InjectiveConfig(follow_bend=1),
         "InjectiveConfig.follow_bend: expected True or False, got 1"),
        (lambda: InjectiveConfig(barrier={"energy": "mips"}),
         "InjectiveConfig.barrier: expected a BarrierConfig, got dict"),
        (lambda: InjectiveConfig(untangle=PullConfig()),
         "InjectiveConfig.untangle: expected a UntangleConfig, got PullConfig"),
        (lambda: InjectiveConfig(pull=None),
         "InjectiveConfig.pull: expected a PullConfig, got NoneType"),
        (lambda: ParamConfig(injective=BarrierConfig()),
         "ParamConfig.injective: expected a InjectiveConfig, got BarrierConfig"),
        # nested configs must be configs
        (lambda: ParamConfig(schedule={"epochs": 3}),
         "ParamConfig.schedule: expected a ScheduleConfig, got dict"),
        (lambda: ParamConfig(param_net=ScheduleConfig()),
         "ParamConfig.param_net: expected a NetConfig, got ScheduleConfig"),
    ],
)
def test_configs_reject_bad_values(make, message):
    with pytest.raises(InputError) as info:
        make()
    assert str(info.value) == message


def test_zero_is_allowed_where_it_means_off():
    assert RefineConfig(steps=0).steps == 0  # no refinement
    assert LocalMeshConfig(robust_rounds=0).robust_rounds == 0  # plain LSCM
    assert ParamConfig(max_stages=0).max_stages == 0  # all stages
    assert OptimizerConfig(momentum=0.0).momentum == 0.0
    assert LossWeights(domain=0.0, landmarks=0).domain == 0.0  # a term switched off


# --------------------------------------------------------------------------- dict round trips


@pytest.mark.parametrize("name", sorted(PRESETS))
def test_param_config_round_trips_through_dict_and_json(name):
    cfg = get_preset(name, dtype="float64")
    assert ParamConfig.from_dict(cfg.to_dict()) == cfg
    assert ParamConfig.from_dict(json.loads(json.dumps(cfg.to_dict()))) == cfg


@pytest.mark.parametrize("name", sorted(PRESETS))
def test_config_from_dict_round_trips_the_presets_through_json(name):
    cfg = PRESETS[name]
    back = config_from_dict(ParamConfig, json.loads(json.dumps(cfg.to_dict())))
    assert back == cfg
    assert isinstance(back.schedule, ScheduleConfig) and isinstance(back.param_net, NetConfig)
    # The generic function builds any config class from its own dict.
    sch = dataclasses.asdict(cfg.schedule)
    assert config_from_dict(ScheduleConfig, json.loads(json.dumps(sch))) == cfg.schedule


def test_config_from_dict_missing_keys_take_the_defaults():
    assert ParamConfig.from_dict({}) == ParamConfig()
    cfg = ParamConfig.from_dict({"max_stages": 2, "schedule": {"epochs": 50}})
    assert cfg == ParamConfig(max_stages=2, schedule=ScheduleConfig(epochs=50))
    assert cfg.schedule.sigma == ScheduleConfig().sigma  # the nested default too


def test_barrier_settings_ride_in_param_config_and_old_dicts_take_the_defaults():
    """The barrier map's settings are set through ParamConfig and saved with it; a dict
    written before they were (a result file of an older pcgeom) loads with the defaults."""
    cfg = get_preset("fast", injective=InjectiveConfig(barrier=BarrierConfig(energy="mips")))
    back = ParamConfig.from_dict(json.loads(json.dumps(cfg.to_dict())))
    assert back.injective.barrier.energy == "mips" and back == cfg
    assert back.injective_landmarks.barrier.landmarks == 1e4  # the landmarks map's own
    old = get_preset("fast").to_dict()
    del old["injective"], old["injective_landmarks"]
    loaded = ParamConfig.from_dict(old)
    assert loaded == get_preset("fast")
    assert loaded.injective == InjectiveConfig()
    assert loaded.injective_landmarks == InjectiveConfig(
        rim_angle=150.0, follow_bend=True, untangle=UntangleConfig(local=3),
        barrier=BarrierConfig(landmarks=1e4, cover=0.0, tolerance=1e-4,
                              refactor=2))
    part = ParamConfig.from_dict({"injective": {"barrier": {"iterations": 10}}})
    assert part.injective.barrier.iterations == 10
    assert part.injective.barrier.energy == "root_mips" and part.injective.start == "auto"
    with pytest.raises(InputError, match=r"^BarrierConfig\.energy: unknown value 'x'"):
        ParamConfig.from_dict({"injective": {"barrier": {"energy": "x"}}})


def test_config_from_dict_rejects_unknown_keys_listing_the_known_fields():
    known = ("denoise, disk_map, domain_map, domain_samples, dtype, free_map, init_map, injective, "
             "injective_landmarks, lambda_net, local_mesh, "
             "max_stages, optimizer, param_net, refine, schedule, weights")
    with pytest.raises(InputError) as info:
        ParamConfig.from_dict({"max_stage": 2, "seed": 0})
    assert str(info.value) == f"ParamConfig: unknown field(s) max_stage, seed; known: {known}"
    with pytest.raises(InputError) as info:
        ParamConfig.from_dict({"schedule": {"epoch": 3}})
    assert str(info.value) == (
        "ParamConfig.schedule: unknown field(s) epoch; known: alpha_final, alpha_initial, alpha_max, "
        "batch_domain, batch_points, drop_cross_sheet, epochs, epochs_min, max_steps_per_epoch, "
        "sigma, sigma_min")


def test_config_from_dict_rejects_bad_values_and_non_dicts():
    with pytest.raises(InputError, match=r"^ParamConfig\.dtype: unknown value 'float16'"):
        ParamConfig.from_dict({"dtype": "float16"})
    with pytest.raises(InputError, match=r"^OptimizerConfig\.name: unknown value 'sgd'"):
        ParamConfig.from_dict({"optimizer": {"name": "sgd"}})
    with pytest.raises(InputError, match=r"^ParamConfig\.schedule: expected a dict, got list$"):
        ParamConfig.from_dict({"schedule": [1, 2]})
    with pytest.raises(InputError, match=r"^ParamConfig: expected a dict, got str$"):
        config_from_dict(ParamConfig, "fast")
