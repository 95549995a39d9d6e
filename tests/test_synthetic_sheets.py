"""pcgeom.synthetic_sheets: the open test surfaces of the topology work, and their truths."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

from pcgeom import InputError
from pcgeom.maps.topology import measure
from pcgeom.metrics import angle_distortion
from pcgeom.synthetic_sheets import holed_sheet, lips_sheet


def test_lips_sheet_is_a_disk_whose_walls_nearly_touch():
    s = lips_sheet(4000, gap=0.75)
    got = measure(s.faces)
    assert (got["euler"], got["boundary_loops"], got["genus"], got["pinched"]) == (1, 1, 0, 0)
    # Outward-consistent: the parameters map the true triangles without a flip.
    assert angle_distortion(s.points, s.faces, s.params).flipped == 0
    # Points with a neighbour of the other wall among their 8 nearest (opposite normals).
    _, nb = cKDTree(s.points).query(s.points, 9)
    cross = (np.einsum("nkd,nd->nk", s.normals[nb[:, 1:]], s.normals) < 0).any(axis=1)
    assert 0.05 < cross.mean() < 0.3, cross.mean()
    np.testing.assert_allclose(np.linalg.norm(s.normals, axis=1), 1.0)


@pytest.mark.parametrize("sampling", ["uniform", "grid", "scan"])
def test_holed_sheet_has_its_holes(sampling):
    s = holed_sheet(3000, radii=(2.0, 4.0), sampling=sampling)
    got = measure(s.faces)
    assert (got["boundary_loops"], got["genus"]) == (3, 0) == (s.boundary_loops, 0)
    # An isometric map up to the height field: its own parameters fold nothing.
    assert angle_distortion(s.points, s.faces, s.params).flipped == 0


def test_bad_arguments_are_one_line_errors():
    with pytest.raises(InputError, match=r"^lips_sheet: unknown sampling 'scan'"):
        lips_sheet(1000, sampling="scan")
    with pytest.raises(InputError, match=r"^lips_sheet: gap must be a number > 0, got -1"):
        lips_sheet(1000, gap=-1)
    with pytest.raises(InputError, match=r"^holed_sheet: unknown sampling 'x'"):
        holed_sheet(1000, sampling="x")
