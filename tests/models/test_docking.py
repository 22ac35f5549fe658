"""DockingGeometry: the corridor's angle law on hand-worked points, and its checks."""

import math

import numpy as np
import pytest

from rpod.models.docking import DockingGeometry
from rpod.models.shapes import ConvexPolytope


def _docking(**changes) -> DockingGeometry:
    values = {
        "p_TD_T": [0.0, 0.0, 1.0],
        "axis_T": [0.0, 0.0, 2.0],  # not unit: normalised
        "corridor_half_angle_rad": math.radians(30.0),
        "corridor_length_m": 20.0,
        "hull": ConvexPolytope.box([2.0, 2.0, 2.0]),
    }
    return DockingGeometry(**(values | changes))


def test_the_axis_is_normalised_and_the_port_is_an_array():
    docking = _docking()
    np.testing.assert_array_equal(docking.axis_T, [0.0, 0.0, 1.0])
    assert isinstance(docking.p_TD_T, np.ndarray)


@pytest.mark.parametrize(
    "p_DX_T, expected_deg",
    [
        ([0.0, 0.0, 5.0], -30.0),  # on the axis: 30 deg inside
        ([3.0, 0.0, 3.0], 15.0),  # 45 deg off the axis
        ([1.0, 0.0, math.sqrt(3.0)], 0.0),  # on the cone (30 deg)
        ([0.0, 2.0, 0.0], 60.0),  # square to the axis
        ([0.0, 0.0, -1.0], 150.0),  # behind the port
    ],
)
def test_corridor_violation_is_the_angle_from_the_axis_minus_the_half_angle(p_DX_T, expected_deg):
    assert math.degrees(_docking().corridor_violation_rad(p_DX_T)) == pytest.approx(
        expected_deg, abs=1e-9
    )


@pytest.mark.parametrize(
    "changes",
    [
        {"axis_T": [0.0, 0.0, 0.0]},
        {"corridor_half_angle_rad": 0.0},
        {"corridor_half_angle_rad": math.pi / 2},
        {"corridor_length_m": -1.0},
    ],
)
def test_bad_geometry_is_refused(changes):
    with pytest.raises(ValueError):
        _docking(**changes)
