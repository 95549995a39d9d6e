"""Parameter domains (pcgeom.domains)."""

from __future__ import annotations

import re

import numpy as np
import pytest
from scipy.spatial import cKDTree

from pcgeom.domains import (
    DOMAINS,
    Annulus,
    Car,
    Disk,
    Domain,
    FreeBoundary,
    PolygonDomain,
    Rect,
    ShapelyDomain,
    Smile,
    Sphere,
    Square,
    get_domain,
)
from pcgeom.errors import InputError
from pcgeom.metrics import domain_hausdorff, hausdorff

# The registry, in order, as error messages list it.
_NAMES = "free, disk, square, rect, annulus, smile, car, sphere, polygon"  # dict specs' names
# Every spec that works: a polygon by its file, never by its name (issue 39).
_ALL = (r"free, disk, square, rect, annulus, smile, car, sphere, PATH\.json \(a polygon with "
        r"holes\) or PATH\.png \(a binary mask\)")


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
    assert list(DOMAINS) == ["free", "disk", "square", "rect", "annulus", "smile", "car",
                             "sphere", "polygon"]
    assert DOMAINS == {"free": FreeBoundary, "disk": Disk, "square": Square, "rect": Rect,
                       "annulus": Annulus, "smile": Smile, "car": Car, "sphere": Sphere,
                       "polygon": PolygonDomain}


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
        ("x", rf"^unknown domain 'x'; choose one of: {_ALL}$"),
        ("hexagon", rf"^unknown domain 'hexagon'; choose one of: {_ALL}$"),
        ("hexagon:2", rf"^unknown domain 'hexagon'; choose one of: {_ALL}$"),
        ("disk:a", r"^domain 'disk:a': expected numbers after 'disk:'$"),
        ("disk:1,2", r"^domain 'disk:1,2': disk takes radius; got 2 value\(s\)$"),
        ("free:1", r"^domain 'free:1': free takes no values; got 1 value\(s\)$"),
        ("disk:-1", r"^domain 'disk:-1': radius: expected a positive finite number, got -1\.0$"),
        ({"name": "disk", "radius": 2.0, "colour": "red"},
         r"^domain disk: unknown parameter\(s\) colour; known: center, radius$"),
        ({"name": "free", "radius": 1.0},
         r"^domain free: unknown parameter\(s\) radius; known: none$"),
        ({"radius": 1.0}, rf"^domain \{{'radius': 1.0\}}: no 'name'; choose one of: {_NAMES}$"),
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


# --------------------------------------------------------------------------- shaped domains

BUILT_IN = [Disk(), Square(), Rect(), Annulus(), Smile(), Car()]
"""One of each bounded built-in domain, default parameters."""

HOLED = PolygonDomain(shell=((0.0, 0.0), (3.0, 0.0), (3.0, 1.0), (0.0, 1.0)),
                      holes=(((1.0, 0.3), (2.0, 0.3), (1.5, 0.7)),))
"""A user polygon: a 3 x 1 rectangle with a triangular hole."""

SAMPLED = BUILT_IN + [Square(side=0.5), Rect(aspect=5.0), Annulus(inner=0.4), HOLED]


def _reference_region(domain):
    """The region as a shapely polygon, for counting: circles from shapely's own buffer (not
    the code under test), the domain's polygon otherwise (the polygon is the definition)."""
    import shapely

    if isinstance(domain, Disk):
        return shapely.Point(domain.center).buffer(domain.radius, quad_segs=256)
    if isinstance(domain, Annulus):
        disk = shapely.Point(0.0, 0.0).buffer(domain.outer, quad_segs=256)
        return disk.difference(shapely.Point(0.0, 0.0).buffer(domain.inner, quad_segs=256))
    return domain.geometry


@pytest.mark.parametrize("domain", SAMPLED, ids=lambda d: d.spec[:20])
def test_sample_is_area_uniform(domain):
    """Counts in a 6 x 6 grid of cells intersected with the region match n x cell area / area.

    Each count lies within 5 binomial sigmas of its expectation, and the mean squared z-score
    is far below the 1 of independent uniform points (the sampler has low discrepancy).
    """
    import shapely

    n = 4000
    S = domain.sample(n, seed=1)
    region = _reference_region(domain)
    xmin, ymin, xmax, ymax = region.bounds
    xs, ys = np.linspace(xmin, xmax, 7), np.linspace(ymin, ymax, 7)
    z = []
    for x0, x1 in zip(xs[:-1], xs[1:]):
        for y0, y1 in zip(ys[:-1], ys[1:]):
            p = shapely.box(x0, y0, x1, y1).intersection(region).area / region.area
            if p < 1e-3:
                continue
            count = np.count_nonzero((S[:, 0] >= x0) & (S[:, 0] < x1)
                                     & (S[:, 1] >= y0) & (S[:, 1] < y1))
            sigma = np.sqrt(n * p * (1 - p))
            assert abs(count - n * p) <= 5 * sigma + 1, (x0, y0, count, n * p)
            z.append((count - n * p) / sigma)
    assert len(z) >= 16
    # Measured over every domain here, seeds 0-4, n = 1000 and 4000: mean z^2 <= 0.26 and
    # |z| <= 1.62; i.i.d. uniform points: mean z^2 about 1, |z| up to 3.9.
    assert np.mean(np.square(z)) < 0.4


@pytest.mark.parametrize("domain", SAMPLED, ids=lambda d: d.spec[:20])
def test_sample_is_inside_without_clumps(domain):
    n = 2000
    S = domain.sample(n, seed=3)
    assert S.shape == (n, 2) and S.dtype == np.float64
    assert (domain.signed_distance(S) < 0).all()  # strictly inside
    assert domain.contains(S).all()
    nearest, _ = cKDTree(S).query(S, k=2)
    # Measured 0.55-0.86 x sqrt(area / n) over these domains (n = 300-8192, seeds 0-3);
    # i.i.d. uniform points reach about 0.02x at this n.
    assert nearest[:, 1].min() > 0.45 * np.sqrt(domain.area / n)


@pytest.mark.parametrize("domain", SAMPLED[1:], ids=lambda d: d.spec[:20])
def test_shaped_sample_is_deterministic_and_a_prefix(domain):
    np.testing.assert_array_equal(domain.sample(500, seed=4), domain.sample(500, seed=4))
    assert not np.allclose(domain.sample(500, seed=4), domain.sample(500, seed=5))
    # The first n points of one sequence: a larger sample extends a smaller one, whatever the
    # chunks it was generated in.
    np.testing.assert_array_equal(domain.sample(10000, seed=2)[:300], domain.sample(300, seed=2))


@pytest.mark.parametrize("domain", SAMPLED, ids=lambda d: d.spec[:20])
def test_area_and_centroid_match_the_sample(domain):
    S = domain.sample(20000, seed=0)
    np.testing.assert_allclose(S.mean(axis=0), domain.centroid, atol=0.01)
    assert domain.area == pytest.approx(_reference_region(domain).area, rel=1e-4)


def test_built_in_areas_and_sizes():
    assert Square().area == 4.0 and Square(side=1.5).area == pytest.approx(2.25)
    np.testing.assert_allclose(Square().geometry.bounds, [-1, -1, 1, 1])
    r = Rect(aspect=4.0)
    assert (r.width, r.height) == (4.0, 1.0) and r.area == pytest.approx(4.0)
    assert Rect(aspect=1.0).geometry.equals(Square().geometry)
    assert Annulus(inner=0.4).area == pytest.approx(np.pi * 0.84)
    assert Smile().area == pytest.approx(np.pi * (1 - 0.04 - 0.125), rel=1e-4)
    assert Car().area == pytest.approx(2.6083, abs=1e-4)
    for d in BUILT_IN[1:]:  # the unit disk's scale: area 2.3-4, within 1.42 of the origin
        assert isinstance(d, ShapelyDomain)
        assert 2.3 < d.area <= 4.0 and np.abs(d.geometry.bounds).max() < 1.42
    # 3 x 1 rectangle (centroid y 0.5) minus a triangle of area 0.2 (centroid y 1.3 / 3).
    assert HOLED.area == pytest.approx(2.8)
    np.testing.assert_allclose(HOLED.centroid, [1.5, (3 * 0.5 - 0.2 * 1.3 / 3) / 2.8])


def _points_and_distances(domain):
    """(K, 2) probe points and their analytic signed distances for disk, square, annulus."""
    c, s = np.cos(0.3), np.sin(0.3)
    if isinstance(domain, Disk):
        cases = [((0, 0), -1), ((0.6, 0.8), 0), ((c, s), 0), ((0.3, 0.4), -0.5), ((2, 0), 1),
                 ((-3, 4), 4)]
    elif isinstance(domain, Square):
        cases = [((0, 0), -1), ((0.5, 0.2), -0.5), ((1, 0), 0), ((1, 1), 0), ((-1, 0.3), 0),
                 ((0.999, 0.5), -0.001), ((2, 0), 1), ((2, 2), np.sqrt(2)), ((-1.5, 0.3), 0.5)]
    else:  # Annulus(inner=0.5)
        cases = [((0, 0), 0.5), ((0.1, 0), 0.4), ((0.75, 0), -0.25), ((0.5 * c, 0.5 * s), 0),
                 ((c, s), 0), ((0, -1), 0), ((0, 2), 1), ((0.6, 0.8), 0), ((0.3, 0.4), 0),
                 ((-0.7, 0), -0.2)]
    P = np.array([p for p, _ in cases], dtype=np.float64)
    return P, np.array([d for _, d in cases], dtype=np.float64)


@pytest.mark.parametrize("domain", [Disk(), Square(), Annulus(inner=0.5)], ids=repr)
def test_containment_and_signed_distance_are_analytic(domain):
    P, expected = _points_and_distances(domain)
    np.testing.assert_allclose(domain.signed_distance(P), expected, atol=1e-12)
    np.testing.assert_array_equal(domain.contains(P), expected <= 0)  # boundary included
    # Boundary points pushed 1e-9 away from the origin leave a region centred there (or
    # enter the annulus from its hole); pulled towards it, they stay in the disk and square.
    B = domain.boundary(64)
    outward, inward = B * (1 + 1e-9), B * (1 - 1e-9)
    if isinstance(domain, Annulus):
        outer = np.linalg.norm(B, axis=1) > 0.75
        assert not domain.contains(outward[outer]).any() and domain.contains(inward[outer]).all()
        assert domain.contains(outward[~outer]).all() and not domain.contains(inward[~outer]).any()
    else:
        assert not domain.contains(outward).any() and domain.contains(inward).all()


def test_shaped_signed_distance_in_the_holes():
    smile, car = Smile(), Car()
    # Eye centre (-0.4, 0.3): in the hole, 0.05 above the eye's flat side; mouth (0, -0.3):
    # 0.15 below its flat side; the origin: 0.15 above the mouth.
    np.testing.assert_allclose(smile.signed_distance([[-0.4, 0.3], [0.4, 0.3], [0, -0.3],
                                                      [0, 0], [0, 1.5]]),
                               [0.05, 0.05, 0.15, -0.15, 0.5], atol=1e-12)
    np.testing.assert_array_equal(smile.contains([[-0.4, 0.3], [0, -0.3], [0, 0], [0, -0.15]]),
                                  [False, False, True, True])
    # Car: the origin is nearest to the wheel arches (0.8902 - 0.2), not the sides (0.7).
    d0 = np.hypot(0.55, 0.7) - 0.2
    assert car.signed_distance([[0.0, 0.0]])[0] == pytest.approx(-d0, abs=1e-5)
    assert car.signed_distance([[1.15, 0.0], [-1.05, 0.0], [0.0, 0.7]]) == pytest.approx(
        [0, 0, 0], abs=1e-12)


def test_car_holds_the_papers_landmark_lines():
    """The paper's car experiment maps window edges onto [-0.5, 0.5] x {-0.25, 0.25}."""
    t = np.linspace(-0.5, 0.5, 200)
    lines = np.vstack([np.column_stack([t, np.full_like(t, y)]) for y in (-0.25, 0.25)])
    d = Car().signed_distance(lines)
    assert Car().contains(lines).all()
    assert d.max() < -0.2  # well inside: measured -0.253 (nearest: the wheel arches)


LOOPS = [(Disk(), 1), (Square(), 1), (Rect(), 1), (Annulus(), 2), (Smile(), 4), (Car(), 1),
         (HOLED, 2)]


@pytest.mark.parametrize("domain, count", LOOPS, ids=lambda x: getattr(x, "spec", str(x))[:20])
def test_boundary_loops(domain, count):
    import shapely

    loops = domain.boundary_loops()
    assert len(loops) == count
    for i, loop in enumerate(loops):
        assert loop.ndim == 2 and loop.shape[1] == 2 and len(loop) >= 4
        np.testing.assert_array_equal(loop[0], loop[-1])  # closed
        assert shapely.LinearRing(loop).is_ccw == (i == 0)  # outer CCW, holes CW
        assert np.abs(domain.signed_distance(loop)).max() < 1e-12  # on the boundary
        assert domain.contains(loop).all()
    total = sum(shapely.LineString(loop).length for loop in loops)
    assert total == pytest.approx(_reference_region(domain).boundary.length, rel=1e-4)


@pytest.mark.parametrize("domain, count", LOOPS, ids=lambda x: getattr(x, "spec", str(x))[:20])
def test_boundary_points_follow_the_loops(domain, count):
    import shapely

    n = 1000
    B = domain.boundary(n)
    assert B.shape == (n, 2) and B.dtype == np.float64
    assert np.abs(domain.signed_distance(B)).max() < 1e-12
    assert domain.contains(B).all()
    # Listed loop by loop, in proportion to the loops' lengths.
    loops = [shapely.LineString(loop) for loop in domain.boundary_loops()]
    lengths = np.array([line.length for line in loops])
    owner = np.argmin([shapely.distance(line, shapely.points(B)) for line in loops], axis=0)
    assert (np.diff(owner) >= 0).all()
    np.testing.assert_allclose(np.bincount(owner, minlength=count), n * lengths / lengths.sum(),
                               atol=1.0)


def test_square_boundary_is_evenly_spaced_counter_clockwise():
    np.testing.assert_allclose(Square().boundary(8), [[1, -1], [1, 0], [1, 1], [0, 1], [-1, 1],
                                                     [-1, 0], [-1, -1], [0, -1]], atol=1e-15)
    B = Annulus(inner=0.5).boundary(9)  # 6 on the outer circle, 3 on the inner, clockwise
    np.testing.assert_allclose(np.linalg.norm(B, axis=1), [1] * 6 + [0.5] * 3)
    np.testing.assert_allclose(B[6:], 0.5 * np.array([[1, 0], [-0.5, -np.sqrt(0.75)],
                                                       [-0.5, np.sqrt(0.75)]]), atol=1e-15)


def test_disk_loops_and_free_boundary_queries():
    (loop,) = Disk(center=(1.0, 2.0), radius=0.5).boundary_loops()
    np.testing.assert_allclose(np.linalg.norm(loop - [1, 2], axis=1), 0.5)
    assert FreeBoundary().boundary_loops() == []
    with pytest.raises(ValueError, match="domain 'free': no region, hence no signed distance"):
        FreeBoundary().signed_distance(np.zeros((3, 2)))
    for d in BUILT_IN + [HOLED]:
        with pytest.raises(ValueError, match=r"P: expected shape \(K, 2\), got \(3, 3\)"):
            d.signed_distance(np.zeros((3, 3)))
        with pytest.raises(ValueError, match="n: expected a positive count, got 0"):
            d.sample(0)


SHAPED_SPECS = [
    (Square(), "square"), (Square(side=1.5), "square:1.5"), (Rect(), "rect"),
    (Rect(aspect=3.0), "rect:3.0"), (Rect(aspect=2.0, size=1.0), "rect:2.0,1.0"),
    (Annulus(inner=0.4), "annulus:0.4"), (Annulus(inner=0.2, outer=2.0), "annulus:0.2,2.0"),
    (Smile(), "smile"), (Car(), "car"),
]


@pytest.mark.parametrize("domain, spec", SHAPED_SPECS, ids=lambda x: getattr(x, "spec", x))
def test_shaped_specs(domain, spec):
    import json

    assert domain.spec == spec
    assert get_domain(spec) == domain
    assert get_domain(domain.to_dict()) == domain
    assert get_domain(json.loads(json.dumps(domain.to_dict()))) == domain
    assert hash(get_domain(spec)) == hash(domain)


def test_short_specs_set_the_first_arguments():
    assert get_domain("rect:2") == Rect(aspect=2.0)
    assert get_domain("annulus:0.4") == Annulus(inner=0.4, outer=1.0)
    assert get_domain("square:1.5") == Square(side=1.5)
    assert Rect.spec_args == ("aspect", "size") and Annulus.spec_args == ("inner", "outer")
    assert Smile.spec_args == () and Car.spec_args == ()


@pytest.mark.parametrize(
    "spec, match",
    [
        ("annulus:1.2", r"^domain 'annulus:1.2': inner: expected a radius below outer = 1.0, "
                        r"got 1.2$"),
        ("annulus:1", r"^domain 'annulus:1': inner: expected a radius below outer"),
        ("annulus:0", r"^domain 'annulus:0': inner: expected a positive finite number, got 0.0$"),
        ("annulus:-0.2", r"^domain 'annulus:-0.2': inner: expected a positive finite number"),
        ("annulus:0.5,0", r"^domain 'annulus:0.5,0': outer: expected a positive finite number"),
        ("rect:0", r"^domain 'rect:0': aspect: expected a positive finite number, got 0.0$"),
        ("rect:2,-1", r"^domain 'rect:2,-1': size: expected a positive finite number, got -1.0$"),
        ("square:0", r"^domain 'square:0': side: expected a positive finite number, got 0.0$"),
        ("square:inf", r"^domain 'square:inf': side: expected a positive finite number, got inf$"),
        ("square:nan", r"^domain 'square:nan': side: expected a positive finite number"),
        ("smile:1", r"^domain 'smile:1': smile takes no values; got 1 value\(s\)$"),
        ("car:2", r"^domain 'car:2': car takes no values; got 1 value\(s\)$"),
        ("polygon", r"^domain 'polygon': no vertices; give the polygon as a GeoJSON file, "
                    r"PATH.json$"),
        ({"name": "square", "side": "2"},
         r"^domain 'square': side: expected a positive finite number, got '2'$"),
        ({"name": "polygon", "shell": [[0, 0], [1, 0]]},
         r"^domain 'polygon': outer ring: 2 distinct vertices, need at least 3$"),
    ],
)
def test_bad_shaped_specs(spec, match):
    with pytest.raises(InputError, match=match):
        get_domain(spec)


# --------------------------------------------------------------------------- user polygons

_SQUARE_WITH_HOLE = [[[0, 0], [2, 0], [2, 2], [0, 2], [0, 0]],
                     [[0.5, 0.5], [1.5, 0.5], [1.5, 1.5], [0.5, 1.5], [0.5, 0.5]]]


def _write_json(path, data) -> str:
    import json

    path.write_text(json.dumps(data) if not isinstance(data, str) else data)
    return str(path)


@pytest.mark.parametrize("document", [
    {"type": "Polygon", "coordinates": _SQUARE_WITH_HOLE},
    {"coordinates": _SQUARE_WITH_HOLE},
    {"type": "Feature", "properties": {"name": "room"},
     "geometry": {"type": "Polygon", "coordinates": _SQUARE_WITH_HOLE}},
    {"coordinates": [ring[:-1] for ring in _SQUARE_WITH_HOLE]},  # open rings
    {"coordinates": [ring[::-1] for ring in _SQUARE_WITH_HOLE]},  # either orientation
], ids=["Polygon", "bare", "Feature", "open rings", "reversed"])
def test_polygon_file(tmp_path, document):
    import json

    path = _write_json(tmp_path / "room.json", document)
    d = get_domain(path)
    assert isinstance(d, PolygonDomain) and d.name == "polygon"
    assert d.area == pytest.approx(3.0)
    np.testing.assert_allclose(d.centroid, [1.0, 1.0])
    assert len(d.boundary_loops()) == 2
    np.testing.assert_array_equal(d.contains([[0.25, 1], [1, 1], [0.5, 1], [3, 1]]),
                                  [True, False, True, False])
    np.testing.assert_allclose(d.signed_distance([[0.25, 1], [1, 1], [3, 1]]), [-0.25, 0.5, 1])
    # The results file holds the coordinates: the domain comes back without the file.
    stored = json.loads(json.dumps(d.to_dict()))
    (tmp_path / "room.json").unlink()
    assert set(stored) == {"name", "shell", "holes"} and len(stored["holes"]) == 1
    assert get_domain(stored) == d and get_domain(d.spec) == d
    assert hash(get_domain(stored)) == hash(d)


def test_polygon_from_coordinates_normalizes_them():
    d = PolygonDomain(shell=np.array([[0, 0], [1, 0], [0, 1], [0, 0]]))
    assert d.shell == ((0.0, 0.0), (1.0, 0.0), (0.0, 1.0)) and d.holes == ()
    assert d == PolygonDomain(shell=[[0, 0], [1, 0], [0, 1]])
    assert d.area == pytest.approx(0.5)


@pytest.mark.parametrize(
    "content, match",
    [
        ("nope", r"cannot parse: Expecting value: line 1 column 1"),
        ([1, 2], r'expected a GeoJSON Polygon \{"type": "Polygon", "coordinates": \[outer ring, '
                 r'hole rings\.\.\.\]\}, got list$'),
        ({"type": "Polygon"}, r"expected a GeoJSON Polygon .*, got an object without "
                              r"'coordinates'$"),
        ({"type": "MultiPolygon", "coordinates": [_SQUARE_WITH_HOLE]},
         r"expected a GeoJSON Polygon .*, got type 'MultiPolygon'$"),
        ({"type": "Feature", "geometry": None}, r"expected a GeoJSON Polygon .*, got NoneType$"),
        ({"coordinates": []}, r"expected a GeoJSON Polygon .*, got coordinates \[\]$"),
        ({"coordinates": [[[0, 0, 1], [1, 0, 1], [1, 1, 1]]]},
         r"outer ring: expected a list of \[x, y\] pairs, got shape \(3, 3\)$"),
        ({"coordinates": [[[0, 0], [1, 0], [1]]]},
         r"outer ring: expected a list of \[x, y\] pairs$"),
        ({"coordinates": [[[0, 0], [1, 0], [0, 0]]]},
         r"outer ring: 2 distinct vertices, need at least 3$"),
        ({"coordinates": [[[0, 0], [1, 0], [2, 0], [0, 0]]]},
         r"outer ring: zero area \(its vertices lie on one line\)$"),
        ({"coordinates": [[[0, 0], [1, 1], [1, 0], [0, 1]]]},
         r"polygon is not valid: Self-intersection\[0\.5 0\.5\]$"),
        ({"coordinates": [[[0, 0], [1, 0], [1, 1], [0, 1]], [[2, 2], [3, 2], [3, 3]]]},
         r"polygon is not valid: Hole lies outside shell\[2 2\]$"),
        ({"coordinates": [[[0, 0], [4, 0], [4, 4], [0, 4]], [[1, 1], [2, 1], [1, 1]]]},
         r"hole 1: 2 distinct vertices, need at least 3$"),
    ],
    ids=["not json", "list", "no coordinates", "MultiPolygon", "null geometry", "empty",
         "3D", "ragged", "two vertices", "collinear", "self-intersecting", "hole outside",
         "degenerate hole"],
)
def test_bad_polygon_files(tmp_path, content, match):
    path = _write_json(tmp_path / "bad.json", content)
    with pytest.raises(InputError, match=rf"^{re.escape(path)}: {match}"):
        get_domain(path)


def test_unreadable_polygon_files(tmp_path):
    missing = str(tmp_path / "nowhere.json")
    with pytest.raises(InputError, match=rf"^{re.escape(missing)}: no such file$"):
        get_domain(missing)
    folder = tmp_path / "folder.json"
    folder.mkdir()
    with pytest.raises(InputError, match=r"folder\.json: not a regular file$"):
        get_domain(str(folder))


# --------------------------------------------------------------------------- image masks


def _write_mask(path, mask) -> str:
    from PIL import Image

    Image.fromarray(np.where(mask, 255, 0).astype(np.uint8)).save(path)
    return str(path)


def _pixels(rows: int = 121, cols: int = 161):
    r, c = np.mgrid[0:rows, 0:cols]
    return r - (rows - 1) / 2, c - (cols - 1) / 2


def test_an_image_mask_of_an_annulus_is_the_annulus(tmp_path):
    r, c = _pixels()
    radius = np.hypot(r, c)
    path = _write_mask(tmp_path / "ring.png", (radius <= 50) & (radius >= 20))
    domain = get_domain(path)
    assert isinstance(domain, PolygonDomain) and len(domain.holes) == 1
    # The outline runs between pixel centres, within half a pixel of the circles of radius
    # 50 and 20 pixels; the box's side (2) is the outer diameter, 101 pixels.
    pixel = 1.0 / 50.5
    outer = np.linalg.norm(np.asarray(domain.shell), axis=1) / pixel
    inner = np.linalg.norm(np.asarray(domain.holes[0]), axis=1) / pixel
    assert 49.5 - 1e-9 <= outer.min() and outer.max() <= 50.5 + 1e-9
    assert 19.5 <= inner.min() and inner.max() <= 20.5
    low, high = np.pi * (49.5**2 - 20.5**2), np.pi * (50.5**2 - 19.5**2)
    assert low <= domain.area / pixel**2 <= high
    np.testing.assert_allclose(domain.centroid, 0.0, atol=1e-3)
    P = np.array([[0.0, 0.0], [0.7, 0.0], [0.0, -0.7], [0.99, 0.99]])
    assert domain.contains(P).tolist() == [False, True, True, False]
    assert get_domain(domain.to_dict()) == domain  # a results file rebuilds it


def test_an_image_mask_keeps_y_up(tmp_path):
    r, c = _pixels()
    # A triangle with its wide side at the top of the image (small row numbers).
    path = _write_mask(tmp_path / "tri.png", (r >= -50) & (np.abs(c) <= (50 - r) * 0.8))
    domain = get_domain(path)
    ymin, ymax = domain.geometry.bounds[1], domain.geometry.bounds[3]
    top = domain.contains([[0.8 * domain.geometry.bounds[2], ymax - 0.05]])
    bottom = domain.contains([[0.8 * domain.geometry.bounds[2], ymin + 0.05]])
    assert top.tolist() == [True] and bottom.tolist() == [False]


def test_bad_image_masks(tmp_path):
    r, c = _pixels()
    black = _write_mask(tmp_path / "black.png", np.zeros_like(r, dtype=bool))
    with pytest.raises(InputError, match=rf"^{re.escape(black)}: the mask has no region pixel"):
        get_domain(black)
    two = _write_mask(tmp_path / "two.png", (np.hypot(r, c - 40) < 20) | (np.hypot(r, c + 40) < 20))
    with pytest.raises(InputError, match=rf"^{re.escape(two)}: the mask has 2 separate regions"):
        get_domain(two)
    text = tmp_path / "text.png"
    text.write_text("not an image")
    with pytest.raises(InputError, match=rf"^{re.escape(str(text))}: cannot read the image mask"):
        get_domain(str(text))
    missing = str(tmp_path / "nowhere.png")
    with pytest.raises(InputError, match=rf"^{re.escape(missing)}: no such file$"):
        get_domain(missing)


def test_cli_draws_a_mask_domain(tmp_path, capsys):
    from pcgeom import cli
    from tests.helpers import assert_cli_fails

    r, c = _pixels()
    path = _write_mask(tmp_path / "blob.png", np.hypot(r, c / 1.5) < 50)
    out = tmp_path / "blob_domain.png"
    assert cli.main(["domains", "show", path, "-o", str(out)]) == 0
    assert out.stat().st_size > 0
    capsys.readouterr()
    black = _write_mask(tmp_path / "black.png", np.zeros_like(r, dtype=bool))
    assert_cli_fails(capsys, ["domains", "show", black, "-o", str(tmp_path / "x.png")],
                     "the mask has no region pixel")
    assert not (tmp_path / "x.png").exists()


# --------------------------------------------------------------------------- training


def _patch_shaped_like(domain, n_side: int = 20):
    """The three-peaks surface over the grid points whose (x, y) lies in ``domain``,
    stretched 1.6x along x: a cloud of the domain's topology (holes included) whose initial
    plane map does not fit the domain."""
    from pcgeom.examples import peaks_surface

    V, _ = peaks_surface("peaks3", n_side=n_side)
    V = V[domain.contains(V[:, :2])]
    V[:, 0] *= 1.6
    return V


def _short_config(domain_map: str = "networks"):
    """One stage of 30 epochs and 60 refinement steps on small nets (about 1 s per run), or
    the local mesh laid on the domain and 60 refinement steps."""
    import dataclasses

    from pcgeom.config import LocalMeshConfig, NetConfig, RefineConfig, ScheduleConfig, get_preset

    return get_preset(
        "fast",
        schedule=ScheduleConfig(epochs=30, epochs_min=1, batch_points=128, batch_domain=128),
        param_net=NetConfig(width=32, depth=2, init="siren", w0=5.0),
        lambda_net=NetConfig(width=16, depth=1, init="siren", w0=5.0),
        domain_samples=1024, max_stages=1, refine=RefineConfig(steps=60, batch_domain=256),
        domain_map=domain_map, disk_map=domain_map,
        local_mesh=dataclasses.replace(LocalMeshConfig(), domain_refine=RefineConfig(
            steps=60, batch_domain=1024, hand_backend="knn")),
    )


@pytest.fixture
def one_thread():
    import torch

    n = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(n)


@pytest.mark.parametrize("domain", BUILT_IN, ids=lambda d: d.spec)
def test_a_short_run_pulls_the_cloud_onto_each_domain(domain, one_thread):
    from pcgeom import parametrize

    V = _patch_shaped_like(domain)
    res = parametrize(V, domain, config=_short_config(), device="cpu", seed=0, progress=False)
    xy = ((V - res.center) / res.scale)[:, :2]  # the normalized cloud seen from above
    inside = domain.contains(res.uv).mean()
    fit, before = domain_hausdorff(res.uv, domain), domain_hausdorff(xy, domain)
    # Measured (seeds 0-2): inside 0.99-1.00 disk, 0.92-0.96 square, 0.98-1.00 rect,
    # 0.97-1.00 annulus, 0.81-0.87 smile, 0.95-1.00 car; Hausdorff 0.110-0.150 from 0.30-0.59
    # for the stretched xy projection (smile 0.133-0.148 from 0.428).
    assert inside > 0.7
    assert fit < 0.2
    assert fit < 0.6 * before
    assert res.domain == domain


@pytest.mark.parametrize("domain", BUILT_IN, ids=lambda d: d.spec)
def test_the_local_mesh_laid_on_each_domain_fills_it(domain, one_thread):
    from pcgeom import parametrize

    import shapely

    V = _patch_shaped_like(domain, n_side=40)
    res = parametrize(V, domain, config=_short_config("localmesh"), device="cpu", seed=0,
                      progress=False)
    if res.history[0].get("method") in ("riemann", "injective"):
        # A domain without holes gets the conformal composition, one with holes the
        # injective map, not a fill by HAND: the stretched patch's points thin out where the
        # map shrinks it (0.19 from the square's corners), but the mapped surface fills the
        # domain and stays inside it, and every hole of the patch lies on its domain hole.
        from pcgeom.examples import peaks_surface
        from pcgeom.metrics import angle_distortion, surface_hausdorff

        W, F = peaks_surface("peaks3", n_side=40)
        keep = domain.contains(W[:, :2])
        index = np.full(len(W), -1)
        index[keep] = np.arange(keep.sum())
        F = index[F]
        F = F[(F >= 0).all(axis=1)]
        # Measured on this small patch (1600 grid points at most): the car's surface misses
        # the domain by 0.047 (a side just past a wheel arch: the arch's reflex corners spread
        # the few rim points there). The grid's exactly collinear rows turn over 2 of 3042
        # triangles on the square, 2 of 1794 on the car (a 20k car shell with 11 holes:
        # 0.034%).
        # Onto the smile, 0.084: its eyes are holes of 3 and 4 grid points in this patch,
        # which the local mesh closes in part; the true triangles leave gaps beside them.
        # The car read 0.0785 on one CPU and under 0.07 on another (2026-12-06): the choice
        # of rotation weighed two triangles flat on the roof by the last bit of their area
        # (riemann.area_spread); 0.047-0.057 since, with the cloud nudged by 1e-9.
        bound = {"smile": 0.1}.get(domain.spec, 0.07)
        assert surface_hausdorff(res.uv, F, domain) < bound
        assert angle_distortion(V, F, res.uv).flipped <= 0.002 * len(F)
        assert [r["stage"] for r in res.history] == ["localmesh"]
        deep = [int(shapely.contains_xy(shapely.Polygon(r).buffer(-0.03), *res.uv.T).sum())
                for r in domain.boundary_loops()[1:]]
        # Measured [0, 1, 1] on the smile: a loop vertex of a 3-point eye released from its
        # ring (its triangle would be flat there) sits 0.03-0.07 inside the eye.
        assert max(deep, default=0) <= 1, deep
        return
    inside = domain.contains(res.uv).mean()
    fit = domain_hausdorff(res.uv, domain)
    rings = domain.boundary_loops()[1:]
    # Points deep in a hole of the domain: a hole of the cloud that missed it.
    deep = [int(shapely.contains_xy(shapely.Polygon(r).buffer(-0.03), *res.uv.T).sum())
            for r in rings]
    # Measured (seeds 0-2): inside 0.95-1.00, Hausdorff 0.066-0.086, at most 1 point deep in
    # a hole (the networks of test_a_short_run... at this size leave 30-44 of the smile's 986
    # points in its mouth).
    assert inside > 0.93
    assert fit < 0.1
    assert all(k <= 0.005 * len(V) for k in deep), deep
    assert [r["stage"] for r in res.history] == (
        ["localmesh"] if isinstance(domain, Disk) else ["localmesh", "refine"])
    assert res.domain == domain


def test_disk_refine_fills_the_disk_after_the_conformal_map(one_thread):
    import dataclasses

    from pcgeom import parametrize

    from pcgeom.config import get_preset

    disk = Disk()
    V = _patch_shaped_like(disk, n_side=40)
    config = get_preset("fast")  # its own refinement (whole domain sample, local steps), cut
    short = dataclasses.replace(config.local_mesh.domain_refine, steps=60)
    plain = parametrize(V, disk, config=config, progress=False)
    refined = parametrize(V, disk, progress=False, config=dataclasses.replace(
        config, local_mesh=dataclasses.replace(config.local_mesh, disk_refine=True,
                                               domain_refine=short)))
    assert [r["stage"] for r in plain.history] == ["localmesh"]
    assert [r["stage"] for r in refined.history] == ["localmesh", "refine"]
    before, after = domain_hausdorff(plain.uv, disk), domain_hausdorff(refined.uv, disk)
    # Measured 0.0662 -> 0.0591 on these 1184 points (60 steps; 1000 steps: 0.0592). On the
    # full clouds BENCHMARKS.md has the CLI's runs and LocalMeshConfig the figures.
    assert after < before - 0.003, (before, after)
    assert np.abs(refined.uv - plain.uv).max() > 1e-3  # the refinement moved the map


def test_label_is_the_spec_unless_it_holds_coordinates():
    assert Disk().label == "disk" and Disk(radius=0.5).label == "disk:0.5"
    assert get_domain("annulus:0.4").label == "annulus:0.4"
    square = [[0, 0], [1, 0], [1, 1], [0, 1]]
    small = [[0.4, 0.4], [0.6, 0.4], [0.6, 0.6]]
    assert PolygonDomain(shell=square).label == "polygon of 4 vertices"
    two = PolygonDomain(shell=square, holes=(small, [[0.1, 0.1], [0.2, 0.1], [0.2, 0.2]]))
    assert two.label == "polygon of 10 vertices with 2 holes"
    assert len(two.spec) > 100  # what the label replaces
