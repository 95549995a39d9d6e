"""The local mesh laid on a domain (pcgeom.domainmap) and Domain.project."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np
import pytest
import shapely

from pcgeom.cloud import normalize
from pcgeom.domainmap import harmonic_onto
from pcgeom.domains import Annulus, Disk, ShapelyDomain, Smile, Square, get_domain
from pcgeom.errors import InputError
from pcgeom.localmesh import local_mesh, lscm_free


def _sheet(domain, n: int, turn: float, mirror: bool, bump: float = 0.0):
    """The domain's own quasi-uniform sample, mirrored, turned, scaled by 3 and lifted into a
    tilted plane of 3D (plus an optional bump): a cloud whose exact map onto the domain is
    known (the sample itself, up to the domain's symmetries)."""
    P = domain.sample(n, seed=1)
    Q = P * [1.0, -1.0] if mirror else P.copy()
    c, s = np.cos(turn), np.sin(turn)
    Q = 3.0 * Q @ np.array([[c, -s], [s, c]]).T
    X = np.column_stack([Q, bump * np.exp(-(Q ** 2).sum(axis=1))])
    tilt = np.array([[1.0, 0.0, 0.0], [0.0, 0.8, -0.6], [0.0, 0.6, 0.8]])
    return P, X @ tilt.T, np.tile(tilt[:, 2], (n, 1))


def _map(domain, X, normals, landmarks=()):
    Xn, _, _ = normalize(X)
    mesh = local_mesh(Xn, normals, 24)
    return harmonic_onto(Xn, mesh, lscm_free(Xn, mesh), domain, landmarks=landmarks)


@pytest.mark.parametrize("turn, mirror", [(0.0, False), (1.2, False), (2.5, True)])
def test_a_flat_smile_lands_on_itself_whatever_its_pose(turn, mirror):
    smile = Smile()
    P, X, normals = _sheet(smile, 3000, turn, mirror)
    U, info = _map(smile, X, normals)
    assert info["mesh_holes"] == 3 and info["paired"] == 3
    # The smile is symmetric about x = 0: its mirror image is as good a map.
    error = min(np.linalg.norm(U - P, axis=1).mean(),
                np.linalg.norm(U - P * [-1.0, 1.0], axis=1).mean())
    # Measured 0.004-0.006 (the boundary is laid by arc length, so the rim points slide a
    # little); a wrong pairing of the eyes and the mouth is off by 0.3 or more.
    assert error < 0.02, error


def test_each_hole_of_a_bent_smile_encloses_its_domain_hole():
    smile = Smile()
    _, X, normals = _sheet(smile, 3000, 0.7, True, bump=1.0)
    U, _ = _map(smile, X, normals)
    deep = [int(shapely.contains_xy(shapely.Polygon(ring).buffer(-0.02), *U.T).sum())
            for ring in smile.boundary_loops()[1:]]
    # Measured [0, 1, 0]: a harmonic map onto a region that is not convex may cross a hole's
    # rim (the refinement mends it). A hole of the cloud laid elsewhere leaves about
    # 3000 x (hole area / domain area) points in it: 50 in an eye, 392 in the mouth.
    assert max(deep) <= 3, deep


def test_landmarks_choose_among_the_turns_of_a_square():
    square = Square()
    P, X, normals = _sheet(square, 2000, 0.4, False)
    edge = np.flatnonzero(P[:, 0] > 0.9)  # points near the edge x = 1
    target = np.column_stack([np.full(50, -1.0), np.linspace(-1, 1, 50)])  # onto x = -1
    U, _ = _map(square, X, normals, landmarks=[(edge, target)])
    assert U[edge, 0].mean() < -0.85
    U, _ = _map(square, X, normals)
    # Without them the square's eight symmetries are all as good; with them the rotation by
    # pi is the one that sends x = 1 to x = -1.
    assert np.abs(U[edge, 0]).mean() > 0.85


def test_harmonic_onto_refuses_a_domain_of_two_parts():
    @dataclass(frozen=True)
    class TwoSquares(ShapelyDomain):
        """Two unit squares apart."""

        name: ClassVar[str] = "two_squares"

        def _build_geometry(self):
            return shapely.MultiPolygon([shapely.box(0, 0, 1, 1), shapely.box(2, 0, 3, 1)])

    _, X, normals = _sheet(Square(), 500, 0.0, False)
    with pytest.raises(InputError, match="has 2 separate parts; the local-mesh map needs one "
                                         "connected region"):
        _map(TwoSquares(), X, normals)


# --------------------------------------------------------------------------- Domain.project


def test_project_moves_outside_points_to_the_nearest_boundary_point():
    square = Square()
    P = np.array([[2.0, 0.5], [-3.0, -4.0], [0.2, 0.3], [1.0, 1.0], [0.0, -1.5]])
    Q = square.project(P)
    np.testing.assert_allclose(Q, np.clip(P, -1.0, 1.0), atol=1e-12)
    assert Q is not P and np.array_equal(P[2], [0.2, 0.3])


def test_project_onto_the_disk_is_radial_and_exact():
    disk = get_domain("disk:2")
    P = np.array([[3.0, 4.0], [0.5, 0.5], [0.0, -2.0]])
    np.testing.assert_allclose(disk.project(P), [[1.2, 1.6], [0.5, 0.5], [0.0, -2.0]],
                               atol=1e-15)
    assert isinstance(disk, Disk)


def test_project_out_of_the_annulus_hole_lands_on_the_inner_circle():
    annulus = Annulus(inner=0.4)
    theta = np.linspace(0, 2 * np.pi, 17)
    P = np.column_stack([0.1 * np.cos(theta), 0.1 * np.sin(theta)])
    Q = annulus.project(P)
    # Radially onto the inner circle, within the polylines' chord error (1.9e-5 x radius).
    np.testing.assert_allclose(np.linalg.norm(Q, axis=1), 0.4, atol=1e-5)
    # The nearest point of a 512-gon seen from near its centre is off radial by at most half
    # a segment, pi / 512.
    turn = np.angle((Q[:, 0] + 1j * Q[:, 1]) / (P[:, 0] + 1j * P[:, 1]))
    assert np.abs(turn).max() <= np.pi / 512 + 1e-9


def test_the_free_boundary_has_nothing_to_project_onto():
    with pytest.raises(ValueError, match="domain 'free': no region to project onto"):
        get_domain("free").project(np.zeros((1, 2)))
