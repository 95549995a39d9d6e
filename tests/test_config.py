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
    LocalMeshConfig,
    LossWeights,
    NetConfig,
    OptimizerConfig,
    ParamConfig,
    RefineConfig,
    ScheduleConfig,
    config_from_dict,
    get_preset,
    preset_name,
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


def test_config_from_dict_rejects_unknown_keys_listing_the_known_fields():
    known = ("denoise, disk_map, domain_map, domain_samples, dtype, free_map, init_map, lambda_net, "
             "local_mesh, "
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
