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


def test_the_capture_pose_puts_the_capture_points_together():
    """Paper 000 Table I: D_c = D_t = [0, 0, 2.7] m gives the chaser's centre of mass at
    [0, 0, 5.4] m in T; for any D_c, D_t the chaser's capture point lands on D_t."""
    from rpod.models.docking import R_TC_CAPTURE, capture_reach_T

    np.testing.assert_allclose(capture_reach_T([0, 0, 2.7], [0, 0, 2.7]), [0, 0, 5.4])
    rng = np.random.default_rng(5)
    for _ in range(5):
        D_c, D_t = rng.normal(size=(2, 3))
        p_TC_T = capture_reach_T(D_c, D_t)
        np.testing.assert_allclose(p_TC_T + R_TC_CAPTURE @ D_c, D_t, atol=1e-15)
    assert np.allclose(R_TC_CAPTURE @ R_TC_CAPTURE.T, np.eye(3)) and np.linalg.det(R_TC_CAPTURE) > 0
