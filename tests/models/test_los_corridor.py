"""Paper 004's corridor (eqs. 9-10), r_sync (eq. 14, Table 3) and the body-frame relative state
(eqs. 7-8), against hand-worked points and the paper's own table."""

import math

import numpy as np
import pytest
from pydrake.math import RollPitchYaw, RotationMatrix

from rpod.models.los_corridor import (
    LosCorridor,
    body_relative_state,
    corridor_frame_R_TK,
    holding_range_m,
    suggested_hold_distance_m,
    sync_range_m,
)

CORRIDOR = LosCorridor()  # Table 1: 30 deg, 8 faces, floor 1 m


def test_the_matrix_is_9_by_3_with_the_faces_and_the_floor():
    A, b = CORRIDOR.A_c, CORRIDOR.b_c
    assert A.shape == (9, 3) and b.shape == (9,)
    t = math.tan(math.radians(30.0))
    np.testing.assert_allclose(A[0], [1.0, -t, 0.0], atol=1e-15)  # theta = 0: +x
    np.testing.assert_allclose(A[2], [0.0, -t, 1.0], atol=1e-15)  # theta = 90 deg: +z
    np.testing.assert_allclose(A[4], [-1.0, -t, 0.0], atol=1e-15)  # theta = 180 deg: -x
    np.testing.assert_array_equal(A[8], [0.0, -1.0, 0.0])
    np.testing.assert_array_equal(b, [0.0] * 8 + [-1.0])


@pytest.mark.parametrize(
    "p_T, inside",
    [
        ([0.0, 5.0, 0.0], True),  # on the axis
        ([0.0, 0.5, 0.0], False),  # on the axis, below the 1 m floor
        ([5.0 * math.tan(math.radians(29.0)), 5.0, 0.0], True),  # 29 deg toward +x
        ([5.0 * math.tan(math.radians(31.0)), 5.0, 0.0], False),  # 31 deg toward +x: face 1
        ([0.0, 5.0, -5.0 * math.tan(math.radians(31.0))], False),  # 31 deg toward -z: face 7
        ([0.0, -5.0, 0.0], False),  # behind the target
    ],
)
def test_hand_worked_points(p_T, inside):
    assert bool(CORRIDOR.contains(p_T)) is inside


def test_the_polyhedral_cone_contains_the_circular_one_and_its_edges_reach_the_secant():
    """Tangent faces circumscribe the circular cone: every direction at 30 deg is inside (on
    a face at the tangent directions); between faces the polyhedron reaches
    atan(tan(30 deg) / cos(22.5 deg)) = 32.0 deg."""
    phi = np.linspace(0.0, 2.0 * math.pi, 721)
    t = math.tan(math.radians(30.0))
    on_circle = np.column_stack([t * np.cos(phi), np.ones_like(phi), t * np.sin(phi)]) * 10.0
    assert np.all(CORRIDOR.slack(on_circle)[:, :8] >= -1e-12)
    edge = math.atan(t / math.cos(math.pi / 8))
    direction = np.array([math.cos(math.pi / 8), 0.0, math.sin(math.pi / 8)])
    just_inside = 10.0 * (np.array([0, 1, 0]) + (math.tan(edge) - 1e-9) * direction)
    just_outside = 10.0 * (np.array([0, 1, 0]) + (math.tan(edge) + 1e-6) * direction)
    assert CORRIDOR.contains(just_inside) and not CORRIDOR.contains(just_outside)


def test_the_lvlh_form_is_eq_10_for_a_spin_about_z():
    omega, t = math.radians(2.0), 37.0
    R_LT = RotationMatrix.MakeZRotation(omega * t).matrix()  # body z along L z, spinning
    A, b = CORRIDOR.in_lvlh(R_LT)
    R_z_minus = RotationMatrix.MakeZRotation(-omega * t).matrix()  # eq. 10's R_z(-omega t)
    np.testing.assert_allclose(A, CORRIDOR.A_c @ R_z_minus, atol=1e-15)
    p_T = np.array([0.3, 6.0, -0.4])
    assert np.allclose(b - A @ (R_LT @ p_T), CORRIDOR.slack(p_T), atol=1e-12)


# Paper 004 Table 3: (omega_t deg/s, a_max m/s^2, r_sync m as printed, one decimal).
TABLE_3 = [
    (1, 0.10, 656.6), (1, 0.05, 328.3), (1, 0.02, 131.3),
    (2, 0.10, 164.1), (2, 0.05, 82.1), (2, 0.02, 32.8),
    (3, 0.10, 73.0), (3, 0.05, 36.5), (3, 0.02, 14.6),
    (4, 0.10, 41.0), (4, 0.05, 20.5), (4, 0.02, 8.2),
    (5, 0.10, 26.3), (5, 0.05, 13.1), (5, 0.02, 5.3),
]  # fmt: skip


@pytest.mark.parametrize("omega_deg_s, a_max, printed", TABLE_3)
def test_r_sync_reproduces_table_3(omega_deg_s, a_max, printed):
    assert round(sync_range_m(a_max, math.radians(omega_deg_s)), 1) == pytest.approx(printed)


def test_a_co_rotating_chaser_is_at_rest_in_the_body_frame():
    """Eq. 8's transport term: v_c - v_t = w x r (in I) gives v_T = 0; and p_T is r in T."""
    R_IT = RotationMatrix(RollPitchYaw(0.3, -0.7, 1.1)).matrix()
    w_T = np.array([0.0, 0.0, math.radians(3.0)])
    p_T_true = np.array([1.0, 12.0, -2.0])
    r_t, v_t = np.array([7.0e6, 1.0e3, -2.0e3]), np.array([10.0, 7.5e3, 30.0])
    r_c = r_t + R_IT @ p_T_true
    v_c = v_t + R_IT @ np.cross(w_T, p_T_true)
    p_T, v_T = body_relative_state(R_IT, w_T, r_c, v_c, r_t, v_t)
    np.testing.assert_allclose(p_T, p_T_true, atol=1e-8)  # 7,000 km positions: 1e-8 m
    np.testing.assert_allclose(v_T, 0.0, atol=1e-10)  # 7.5 km/s differenced: ~1e-12 each


def test_the_holding_range_is_where_the_centripetal_acceleration_uses_the_whole_box():
    """At r_hold a point at rest in T turns on a circle of radius r_hold at omega_t: its
    acceleration, computed as the second difference of that circle, is a_max; it is r_sync / 2
    (paper 004's r_sync is the braking condition, not the holding one)."""
    a_max, omega = 0.05, math.radians(5.0)
    r_hold = holding_range_m(a_max, omega)
    assert r_hold == pytest.approx(sync_range_m(a_max, omega) / 2, rel=1e-12)
    dt = 1e-3
    circle = [r_hold * np.array([math.cos(omega * t), math.sin(omega * t)]) for t in (-dt, 0, dt)]
    acceleration = (circle[0] - 2 * circle[1] + circle[2]) / dt**2
    assert np.linalg.norm(acceleration) == pytest.approx(a_max, rel=1e-6)
    # The suggested hold point uses half of it (the 5 deg/s, 0.05 m/s^2: 3.28 m).
    assert suggested_hold_distance_m(a_max, omega) == pytest.approx(r_hold / 2, rel=1e-12)
    assert round(suggested_hold_distance_m(a_max, omega), 2) == 3.28


@pytest.mark.parametrize("axis", [[0, 1, 0], [0, 0, 1], [1, 0, 0], [0, -1, 0], [1, 2, -3]])
def test_the_corridor_frame_is_a_rotation_whose_y_is_the_axis(axis):
    R_TK = corridor_frame_R_TK(axis)
    assert np.allclose(R_TK.T @ R_TK, np.eye(3), atol=1e-15)
    assert np.isclose(np.linalg.det(R_TK), 1.0)
    assert np.allclose(R_TK[:, 1], np.asarray(axis) / np.linalg.norm(axis))


def test_the_corridor_frame_of_plus_y_is_t_itself():
    assert np.array_equal(corridor_frame_R_TK([0.0, 1.0, 0.0]), np.eye(3))
