"""Parameter domains (pcgeom.domains)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

from pcgeom.domains import DOMAINS, Disk, Domain, FreeBoundary, get_domain
from pcgeom.errors import InputError
from pcgeom.metrics import hausdorff


def _dense_disk_reference(h: float = 0.01) -> np.ndarray:
    """Hexagonal grid of spacing h clipped to the unit disk, plus the circle: independent of
    the sampler under test. (K, 2)"""
    rows = []
    for i, y in enumerate(np.arange(-1.0, 1.0 + h, h * np.sqrt(3) / 2)):
        x = np.arange(-1.0, 1.0 + h, h) + (h / 2 if i % 2 else 0.0)
        rows.append(np.column_stack([x, np.full_like(x, y)]))
    grid = np.vstack(rows)
    grid = grid[np.linalg.norm(grid, axis=1) <= 1.0]
    theta = np.linspace(0.0, 2 * np.pi, 1000, endpoint=False)
    return np.vstack([grid, np.column_stack([np.cos(theta), np.sin(theta)])])


def test_disk_sample_inside():
    S = Disk().sample(3000, seed=5)
    assert S.shape == (3000, 2) and S.dtype == np.float64
    assert Disk().contains(S).all()
    assert np.linalg.norm(S, axis=1).max() < 1.0


@pytest.mark.parametrize("n", [500, 2000])
def test_disk_sample_covers_the_disk(n):
    S = Disk().sample(n)
    spacing = np.sqrt(np.pi / n)
    # Measured 1.00 x spacing for the Vogel spiral; i.i.d. uniform samples give about 2.1-2.3x.
    assert hausdorff(S, _dense_disk_reference()) < 1.2 * spacing


def test_disk_sample_has_no_clumps():
    n = 2000
    S = Disk().sample(n, seed=3)
    nearest, _ = cKDTree(S).query(S, k=2)
    # Measured 0.87 x spacing; i.i.d. uniform samples reach 0.02x.
    assert nearest[:, 1].min() > 0.7 * np.sqrt(np.pi / n)


def test_disk_sample_deterministic_per_seed():
    d = Disk()
    np.testing.assert_array_equal(d.sample(777, seed=4), d.sample(777, seed=4))
    np.testing.assert_array_equal(d.sample(777), d.sample(777, seed=0))
    assert not np.allclose(d.sample(777, seed=4), d.sample(777, seed=5))


def test_disk_boundary_on_circle():
    B = Disk().boundary(64)
    assert B.shape == (64, 2)
    np.testing.assert_allclose(np.linalg.norm(B, axis=1), 1.0, rtol=0, atol=1e-15)
    steps = np.linalg.norm(np.diff(np.vstack([B, B[:1]]), axis=0), axis=1)
    np.testing.assert_allclose(steps, 2 * np.sin(np.pi / 64))  # evenly spaced
    x, y = B[:, 0], B[:, 1]
    signed_area = 0.5 * np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y)
    assert signed_area > 0  # counter-clockwise
    assert Disk().contains(B).all()


def test_disk_with_center_and_radius():
    d = Disk(center=(2.0, -1.0), radius=0.5)
    S = d.sample(400)
    np.testing.assert_allclose(S.mean(axis=0), [2.0, -1.0], atol=0.01)
    assert d.contains(S).all() and not Disk().contains(S).any()
    np.testing.assert_allclose(np.linalg.norm(d.boundary(10) - [2.0, -1.0], axis=1), 0.5)
    assert d.area == pytest.approx(np.pi / 4)
    assert Disk().area == pytest.approx(np.pi)


def test_disk_contains():
    inside = Disk().contains([[0.0, 0.0], [0.6, 0.8], [0.7, 0.7], [0.8, 0.61], [-2.0, 0.0]])
    np.testing.assert_array_equal(inside, [True, True, True, False, False])
    with pytest.raises(ValueError, match=r"P: expected shape \(K, 2\), got \(3, 3\)"):
        Disk().contains(np.zeros((3, 3)))


def test_disk_argument_errors():
    with pytest.raises(ValueError, match="radius: expected a positive finite number, got -1"):
        Disk(radius=-1.0)
    with pytest.raises(ValueError, match="center: expected two finite numbers"):
        Disk(center=(0.0, 0.0, 0.0))
    with pytest.raises(ValueError, match="n: expected a positive count, got 0"):
        Disk().sample(0)
    with pytest.raises(TypeError, match="n: expected an int, got float"):
        Disk().boundary(10.0)


def test_get_domain():
    free = get_domain("free")
    assert isinstance(free, FreeBoundary) and isinstance(free, Domain)
    assert free == FreeBoundary() and free.name == "free"
    disk = get_domain("disk")
    assert isinstance(disk, Disk) and isinstance(disk, Domain)
    assert disk == Disk() and disk.name == "disk"
    assert get_domain(disk) is disk  # a Domain is returned as is
    assert list(DOMAINS) == ["free", "disk"]
    assert DOMAINS == {"free": FreeBoundary, "disk": Disk}


def test_get_domain_short_spec_sets_the_spec_args():
    assert Disk.spec_args == ("radius",) and FreeBoundary.spec_args == ()
    assert get_domain("disk:0.5") == Disk(radius=0.5)
    assert get_domain("disk: 2") == Disk(radius=2.0)


SPEC_DOMAINS = [Disk(), Disk(radius=0.5), Disk(center=(1.0, 2.0)),
                Disk(center=(-1.5, 0.25), radius=3.0), FreeBoundary()]

@pytest.mark.parametrize("domain", SPEC_DOMAINS, ids=repr)
def test_domain_dict_round_trips(domain):
    import json

    assert get_domain(domain.to_dict()) == domain
    assert get_domain(json.loads(json.dumps(domain.to_dict()))) == domain  # as files store it


@pytest.mark.parametrize("domain", SPEC_DOMAINS, ids=repr)
def test_domain_spec_round_trips(domain):
    # Includes the JSON form Domain.spec falls back to when a centre changed.
    assert get_domain(domain.spec) == domain


def test_domain_to_dict_and_spec_values():
    assert Disk().to_dict() == {"name": "disk", "center": [0.0, 0.0], "radius": 1.0}
    assert FreeBoundary().to_dict() == {"name": "free"}
    assert Disk().spec == "disk" and FreeBoundary().spec == "free"
    assert Disk(radius=0.5).spec == "disk:0.5"
    # A changed centre is not a spec_arg: the spec is the JSON of to_dict.
    assert Disk(center=(1.0, 2.0)).spec == '{"name": "disk", "center": [1.0, 2.0], "radius": 1.0}'


@pytest.mark.parametrize(
    "spec, match",
    [
        ("x", r"^unknown domain 'x'; choose one of: free, disk$"),
        ("square", r"^unknown domain 'square'; choose one of: free, disk$"),
        ("square:2", r"^unknown domain 'square'; choose one of: free, disk$"),
        ("disk:a", r"^domain 'disk:a': expected numbers after 'disk:'$"),
        ("disk:1,2", r"^domain 'disk:1,2': disk takes radius; got 2 value\(s\)$"),
        ("free:1", r"^domain 'free:1': free takes no values; got 1 value\(s\)$"),
        ("disk:-1", r"^domain 'disk:-1': radius: expected a positive finite number, got -1\.0$"),
        ({"name": "disk", "radius": 2.0, "colour": "red"},
         r"^domain disk: unknown parameter\(s\) colour; known: center, radius$"),
        ({"name": "free", "radius": 1.0},
         r"^domain free: unknown parameter\(s\) radius; known: none$"),
        ({"radius": 1.0}, r"^domain \{'radius': 1.0\}: no 'name'; choose one of: free, disk$"),
        ({"name": "disk", "center": [1.0]},
         r"^domain 'disk': center: expected two finite numbers, got \(1\.0,\)$"),
    ],
)
def test_bad_domain_specs(spec, match):
    with pytest.raises(InputError, match=match):
        get_domain(spec)


def test_get_domain_rejects_other_types():
    with pytest.raises(TypeError, match=r"expected a name, a dict or a Domain, got NoneType "
                                        r"\(the free boundary is 'free'\)"):
        get_domain(None)
    with pytest.raises(TypeError, match=r"^domain: expected a name, a dict or a Domain, got int$"):
        get_domain(3)


def test_free_boundary_has_no_region():
    free = FreeBoundary()
    assert free.bounded is False and Disk().bounded is True
    assert free.sample(100).shape == (0, 2) and free.sample(100, seed=3).shape == (0, 2)
    assert free.boundary(10).shape == (0, 2)
    P = np.random.default_rng(0).normal(size=(50, 2)) * 1e3
    assert free.contains(P).shape == (50,) and free.contains(P).all()
    assert free.area == np.inf
    np.testing.assert_array_equal(free.centroid, [0.0, 0.0])
    with pytest.raises(ValueError, match=r"P: expected shape \(K, 2\), got \(3, 3\)"):
        free.contains(np.zeros((3, 3)))
    with pytest.raises(ValueError, match="n: expected a positive count, got 0"):
        free.sample(0)


def test_disk_centroid_is_its_centre():
    np.testing.assert_array_equal(Disk(center=(3.0, -2.0)).centroid, [3.0, -2.0])
    np.testing.assert_array_equal(Disk().centroid, [0.0, 0.0])
