"""The results file (pcgeom.io.results.ParamResult): save / load round trip and load errors.

A map file holds plain arrays and JSON strings only, so it loads with ``allow_pickle=False``;
files written before the domain, seed and version were stored still load, with a warning.
"""

from __future__ import annotations

import json
import os
import re
import warnings

import numpy as np
import pytest

from pcgeom import __version__
from pcgeom.config import get_preset
from pcgeom.domains import Annulus, Disk, FreeBoundary, PolygonDomain, Smile
from pcgeom.errors import InputError
from pcgeom.io import ParamResult

N = 40


def _result(**changes) -> ParamResult:
    """A result whose every field differs from its default, with non-round values."""
    rng = np.random.default_rng(3)
    fields = dict(
        uv=rng.normal(size=(N, 2)),
        lambda_inv=rng.uniform(0.1, 2.0, size=N),
        center=np.array([0.1, -2.5, 3.0]) * np.pi,
        scale=1.0 / 3.0,
        config=get_preset("fast", max_stages=3, dtype="float64"),
        domain=Disk(center=(1.0, -2.0), radius=0.5),
        seed=12345,
        history=[
            {"stage": 1, "kind": "network", "sigma": 0.5, "leg": 0.012, "total": 0.06},
            {"stage": "refine", "kind": "refine", "steps": 300, "leg": 1e-5, "hand": 0.07},
        ],
        seconds=12.75,
        fingerprint="3f786850e387550fdab836ed7e6dc881de23001b",
        version="9.8.7",
        faces=rng.integers(0, N, size=(25, 3)),
    )
    fields.update(changes)
    return ParamResult(**fields)


def _assert_same(a: ParamResult, b: ParamResult) -> None:
    np.testing.assert_array_equal(a.uv, b.uv)
    np.testing.assert_array_equal(a.lambda_inv, b.lambda_inv)
    np.testing.assert_array_equal(a.center, b.center)
    if a.faces is None:
        assert b.faces is None
    else:
        np.testing.assert_array_equal(a.faces, b.faces)
        assert b.faces.dtype == np.int64
    assert b.uv.dtype == b.lambda_inv.dtype == b.center.dtype == np.float64
    assert (a.scale, a.config, a.domain, a.seed, a.history, a.seconds, a.fingerprint,
            a.version) == (b.scale, b.config, b.domain, b.seed, b.history, b.seconds,
                           b.fingerprint, b.version)
    assert type(a.domain) is type(b.domain)


def _rewrite(path, **replace) -> None:
    """Rewrite a saved map with some arrays replaced (value None: the key removed)."""
    with np.load(path, allow_pickle=False) as archive:
        arrays = {key: archive[key] for key in archive.files}
    for key, value in replace.items():
        if value is None:
            arrays.pop(key)
        else:
            arrays[key] = value
    np.savez(path, **arrays)


# --------------------------------------------------------------------------- round trip


@pytest.mark.parametrize(
    "changes",
    [
        {},
        {"domain": Disk()},
        {"domain": FreeBoundary(), "faces": None},
        {"seed": 0, "fingerprint": None},
        {"seed": None, "domain": None, "history": []},
        {"domain": Annulus(inner=0.4)},
        {"domain": Smile()},
        # A user polygon: the file stores its coordinates, not the path it was read from.
        {"domain": PolygonDomain(shell=((0, 0), (2, 0), (2, 1), (0, 1)),
                                 holes=(((0.5, 0.25), (1, 0.25), (1, 0.75)),))},
    ],
    ids=["off-centre-disk", "unit-disk", "free-no-faces", "seed-0-no-fingerprint", "unknowns",
         "annulus", "smile", "polygon"],
)
def test_save_load_round_trips_every_field(tmp_path, changes):
    res = _result(**changes)
    path = res.save(tmp_path / "map.npz")
    assert path == tmp_path / "map.npz"
    assert sorted(os.listdir(tmp_path)) == ["map.npz"]  # atomic: no temporary file left
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a current file loads without a warning
        back = ParamResult.load(path)
    _assert_same(res, back)
    assert ParamResult.load(str(path), n_points=N).seed == res.seed


def test_defaults_and_preset():
    res = ParamResult(uv=np.zeros((3, 2)), lambda_inv=np.ones(3), center=np.zeros(3), scale=1.0,
                      config=get_preset("fast"))
    assert res.version == __version__
    assert (res.domain, res.seed, res.fingerprint, res.faces) == (None, None, None, None)
    assert res.history == [] and res.seconds == 0.0
    assert res.preset == "fast"
    assert _result().preset == "custom"
    assert _result(config=get_preset("paper")).preset == "paper"


def test_file_holds_plain_arrays_only(tmp_path):
    path = _result().save(tmp_path / "map.npz")
    with np.load(path, allow_pickle=False) as archive:
        arrays = {key: archive[key] for key in archive.files}
    assert set(arrays) == {"uv", "lambda_inv", "center", "scale", "config_json", "history_json",
                           "domain_json", "seed", "version", "fingerprint", "seconds", "faces"}
    assert all(a.dtype != object for a in arrays.values())
    assert json.loads(str(arrays["domain_json"])) == {"name": "disk", "center": [1.0, -2.0],
                                                      "radius": 0.5}
    assert json.loads(str(arrays["config_json"])) == get_preset(
        "fast", max_stages=3, dtype="float64").to_dict()


def test_save_checks_the_path(tmp_path):
    with pytest.raises(InputError, match=r"map\.npy: output must have extension '\.npz'"):
        _result().save(tmp_path / "map.npy")
    with pytest.raises(InputError, match=r"output directory '.*missing' does not exist"):
        _result().save(tmp_path / "missing" / "map.npz")
    assert os.listdir(tmp_path) == []


# --------------------------------------------------------------------------- old files


def test_old_format_loads_with_a_warning(tmp_path):
    res = _result()
    path = tmp_path / "old.npz"
    np.savez(path, uv=res.uv, lambda_inv=res.lambda_inv, center=res.center,
             scale=np.float64(res.scale), config_json=np.str_(json.dumps(res.config.to_dict())),
             history_json=np.str_(json.dumps(res.history)))
    with pytest.warns(UserWarning, match=r"old\.npz: written by an older pcgeom.*; "
                                         r"unknown: domain, seed, version$"):
        old = ParamResult.load(path)
    np.testing.assert_array_equal(old.uv, res.uv)
    np.testing.assert_array_equal(old.lambda_inv, res.lambda_inv)
    np.testing.assert_array_equal(old.center, res.center)
    assert (old.scale, old.config, old.history) == (res.scale, res.config, res.history)
    assert (old.domain, old.seed, old.version) == (None, None, "unknown")
    assert (old.fingerprint, old.faces, old.seconds) == (None, None, 0.0)


def test_a_file_from_before_the_barrier_settings_loads_with_their_defaults(tmp_path):
    """Result files written before ParamConfig held the barrier map's settings (``injective``,
    ``injective_landmarks``) load, those settings at their defaults."""
    res = _result()
    res.save(tmp_path / "map.npz")
    arrays = dict(np.load(tmp_path / "map.npz", allow_pickle=False))
    config = json.loads(str(arrays["config_json"]))
    del config["injective"], config["injective_landmarks"]
    arrays["config_json"] = np.str_(json.dumps(config))
    np.savez(tmp_path / "before.npz", **arrays)
    old = ParamResult.load(tmp_path / "before.npz")
    assert old.config == res.config
    assert old.config.injective.barrier.energy == "root_mips"


def test_bare_uv_file_loads_with_a_warning_and_cannot_be_saved_back(tmp_path):
    """A map from another tool (only ``uv``) loads for evaluation; everything else is unknown."""
    uv = np.random.default_rng(4).normal(size=(N, 2))
    np.savez(tmp_path / "other.npz", uv=uv)
    with pytest.warns(UserWarning, match=r"other\.npz: .*unknown: lambda_inv, center, scale, "
                                         r"config, history, domain, seed, version$"):
        bare = ParamResult.load(tmp_path / "other.npz", n_points=N)
    np.testing.assert_array_equal(bare.uv, uv)
    assert (bare.lambda_inv, bare.center, bare.scale, bare.config) == (None, None, None, None)
    assert bare.history == [] and bare.preset == "unknown" and bare.version == "unknown"
    with pytest.raises(ValueError, match="cannot be saved as a results file"):
        bare.save(tmp_path / "back.npz")
    assert sorted(os.listdir(tmp_path)) == ["other.npz"]


def test_one_unnamed_array_loads_as_bare_uv(tmp_path):
    """Issue 39: np.savez(path, uv) stores 'arr_0', which was refused (no 'uv' array)."""
    uv = np.random.default_rng(5).normal(size=(N, 2))
    np.savez(tmp_path / "unnamed.npz", uv)
    with pytest.warns(UserWarning, match=r"unnamed\.npz: .*unknown: lambda_inv"):
        bare = ParamResult.load(tmp_path / "unnamed.npz", n_points=N)
    np.testing.assert_array_equal(bare.uv, uv)
    np.savez(tmp_path / "two.npz", uv, uv)  # arr_0 and arr_1: which is the map is unknown
    with pytest.raises(InputError, match=r"two\.npz: no 'uv' array \(found: arr_0, arr_1\)"):
        ParamResult.load(tmp_path / "two.npz")
    np.savez(tmp_path / "flat.npz", uv.ravel())  # one unnamed array, of the wrong shape
    with pytest.raises(InputError, match=r"flat\.npz: 'uv' must have shape \(N, 2\)"):
        ParamResult.load(tmp_path / "flat.npz")


# --------------------------------------------------------------------------- load errors


def test_load_rejects_a_wrong_extension_and_a_missing_file(tmp_path):
    _result().save(tmp_path / "map.npz")
    os.replace(tmp_path / "map.npz", tmp_path / "map.npy")
    with pytest.raises(InputError, match=r"^.*map\.npy: map must have extension '\.npz', "
                                         r"got '\.npy'$"):
        ParamResult.load(tmp_path / "map.npy")
    with pytest.raises(InputError, match=r"map: map must have extension '\.npz', got none$"):
        ParamResult.load(tmp_path / "map")
    with pytest.raises(InputError, match=r"^.*nothere\.npz: no such file$"):
        ParamResult.load(tmp_path / "nothere.npz")


def test_load_rejects_a_file_that_is_not_a_map(tmp_path):
    np.savez(tmp_path / "cloud.npz", points=np.zeros((20, 3)), faces=np.zeros((2, 3), int))
    match = (r"cloud\.npz: no 'uv' array \(found: faces, points\); "
             r"expected a map written by 'pcgeom param'$")
    with pytest.raises(InputError, match=match):
        ParamResult.load(tmp_path / "cloud.npz")
    (tmp_path / "junk.npz").write_bytes(b"PK not really a zip")
    with pytest.raises(InputError, match=r"junk\.npz: cannot parse: "):
        ParamResult.load(tmp_path / "junk.npz")


@pytest.mark.parametrize(
    "replace, n_points, match",
    [
        ({"uv": np.zeros((N, 3))}, None, r"'uv' must have shape \(N, 2\), got \(40, 3\)$"),
        ({"uv": np.zeros(2 * N)}, None, r"'uv' must have shape \(N, 2\), got \(80,\)$"),
        ({}, N + 1, r"map has 40 rows but the cloud has 41 points$"),
        ({"uv": np.full((N, 2), np.nan)}, None, r"'uv' contains NaN or inf$"),
        ({"uv": np.r_[np.zeros((N - 1, 2)), [[np.inf, 0.0]]]}, N, r"'uv' contains NaN or inf$"),
        ({"lambda_inv": np.ones(N - 1)}, None,
         r"'lambda_inv' must have shape \(40,\), got \(39,\)$"),
        ({"config_json": np.str_("{not json")}, None,
         r"cannot parse its config, history or domain: "),
        ({"config_json": np.str_('{"dtype": "float16"}')}, None,
         r"cannot parse its config, history or domain: ParamConfig\.dtype: unknown value"),
        ({"faces": np.array([[0, 1, N]])}, None,
         r"faces reference vertex indices 0\.\.40 but there are 40 points$"),
    ],
    ids=["uv-3-columns", "uv-flat", "row-count", "nan", "inf", "lambda-shape", "bad-json",
         "bad-config", "bad-faces"],
)
def test_load_rejects_bad_contents(tmp_path, replace, n_points, match):
    path = _result().save(tmp_path / "map.npz")
    _rewrite(path, **replace)
    with pytest.raises(InputError, match=re.escape(str(path)) + ": " + match):
        ParamResult.load(path, n_points=n_points)


def test_load_refuses_pickled_objects(tmp_path):
    path = _result().save(tmp_path / "map.npz")
    _rewrite(path, history_json=np.array([{"stage": 1}], dtype=object))
    with pytest.raises(InputError, match=r"map\.npz: cannot parse: .*allow_pickle"):
        ParamResult.load(path)


def test_load_rejects_an_unknown_domain(tmp_path):
    path = _result().save(tmp_path / "map.npz")
    _rewrite(path, domain_json=np.str_('{"name": "hexagon", "side": 2}'))
    with pytest.raises(InputError, match=r"unknown domain 'hexagon'; choose one of: free, disk, "
                                         r"square, rect, annulus, smile, car, sphere, PATH\.json"):
        ParamResult.load(path)
