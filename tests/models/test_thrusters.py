"""Tests of rpod.models.thrusters against hand-computed wrenches, geometry and LP certificates
(the gimbaled thrusters' laws, rpod.models.gimbal, are tested in test_gimbal.py).

Tolerances: wrenches and clip results are a handful of floating-point operations on O(1-100)
numbers, so they are checked to 1e-12 relative (round-off); LP certificates use HiGHS's
default 1e-7 feasibility tolerance, far from the margins asserted.
"""

import math

import numpy as np
import pytest
import scipy.optimize

from rpod.models.gimbal import wrench_from_forces
from rpod.models.thrusters import (
    DEFAULT_ISP_S,
    STANDARD_GRAVITY_M_S2,
    Thruster,
    ThrusterLayout,
    gimbaled_cuboid_8,
    mass_flow_rate,
    planar_8,
    rcs_cube_12,
    validate_layout,
    validate_thruster,
    wrench_matrix,
)

RTOL = 1e-12  # round-off of a few flops


# ----------------------------------------------------------------------------- validation


@pytest.mark.parametrize(
    "changes, field",
    [
        ({"max_thrust_N": 0.0}, "max_thrust_N"),
        ({"max_thrust_N": -1.0}, "max_thrust_N"),
        ({"isp_s": 0.0}, "isp_s"),
        ({"isp_s": -200.0}, "isp_s"),
        ({"direction_C": [1.0, 1.0, 0.0]}, "direction_C"),
        ({"direction_C": [0.0, 0.0]}, "direction_C"),
        ({"p_CK_C": [0.0, np.nan, 0.0]}, "p_CK_C"),
        ({"gimbal_half_angle_rad": -0.1}, "gimbal_half_angle_rad"),
        ({"gimbal_half_angle_rad": math.pi / 2}, "gimbal_half_angle_rad"),
    ],
)
def test_validate_thruster_names_the_bad_field(changes, field):
    fields = {"p_CK_C": [1.0, 0.0, 0.0], "direction_C": [0.0, 1.0, 0.0], "max_thrust_N": 1.0}
    fields.update(changes)
    with pytest.raises(ValueError, match=field):
        validate_thruster(Thruster(**fields))


def test_validate_layout_rejects_gimbal_angle_on_fixed_layout_and_empty_layout():
    t = Thruster([1, 0, 0], [0, 1, 0], 1.0, gimbal_half_angle_rad=0.2)
    with pytest.raises(ValueError, match=r"thrusters\[0\].gimbal_half_angle_rad"):
        validate_layout(ThrusterLayout([t], gimbaled=False))
    with pytest.raises(ValueError, match="empty"):
        validate_layout(ThrusterLayout([], gimbaled=False))
    validate_layout(ThrusterLayout([t], gimbaled=True))  # fine when gimbaled


# ----------------------------------------------------------------------------- planar_8


def test_planar_8_matches_hand_computed_columns():
    # h = 0.15 m, F = 0.03 N. (f_x, f_y, tau_z) per thruster, tau_z = r_x f_y - r_y f_x (003 eq. 4),
    # written out by hand from Fig. 2: corner (+,+): x-face fires -x, y-face fires -y; etc.
    h, F = 0.15, 0.03
    expected = np.array(
        [
            [-F, 0, +h * F],  # at (+h, +h), force -x: tau = -(h)(-F)
            [0, -F, -h * F],  # at (+h, +h), force -y: tau = (h)(-F)
            [+F, 0, -h * F],  # at (-h, +h), force +x: tau = -(h)(F)
            [0, -F, +h * F],  # at (-h, +h), force -y: tau = (-h)(-F)
            [+F, 0, +h * F],  # at (-h, -h), force +x: tau = -(-h)(F)
            [0, +F, -h * F],  # at (-h, -h), force +y: tau = (-h)(F)
            [-F, 0, -h * F],  # at (+h, -h), force -x: tau = -(-h)(-F)
            [0, +F, +h * F],  # at (+h, -h), force +y: tau = (h)(F)
        ]
    )
    B = wrench_matrix(planar_8(side_m=0.3, max_thrust_N=0.03))
    np.testing.assert_allclose(B[[3, 4, 2]].T, expected, rtol=0, atol=RTOL)
    np.testing.assert_array_equal(B[[0, 1, 5]], 0.0)  # planar: no tau_x, tau_y, f_z
    assert all(t.p_CK_C[2] == 0.0 for t in planar_8().thrusters)


def _positively_reaches(B, target):
    """LP: is there u >= 0 with B u = target? (HiGHS; independent of the allocator)."""
    res = scipy.optimize.linprog(
        np.ones(B.shape[1]), A_eq=B, b_eq=target, bounds=(0, None), method="highs"
    )
    return res.status == 0


def _strictly_positive_null_margin(B):
    """max t s.t. B u = 0, t <= u <= 1; > 0 iff some u > 0 has B u = 0."""
    n = B.shape[1]
    c = np.zeros(n + 1)
    c[-1] = -1.0
    A_ub = np.hstack([-np.eye(n), np.ones((n, 1))])  # t - u_k <= 0
    A_eq = np.hstack([B, np.zeros((B.shape[0], 1))])
    res = scipy.optimize.linprog(
        c,
        A_ub=A_ub,
        b_ub=np.zeros(n),
        A_eq=A_eq,
        b_eq=np.zeros(B.shape[0]),
        bounds=[(0, 1)] * n + [(None, 1)],
        method="highs",
    )
    assert res.status == 0
    return -res.fun


def test_planar_8_positively_spans_the_planar_wrenches():
    B = wrench_matrix(planar_8())[[3, 4, 2]]  # (f_x, f_y, tau_z)
    assert np.linalg.matrix_rank(B) == 3
    # rank 3 and a strictly positive null vector <=> the columns positively span R^3.
    assert _strictly_positive_null_margin(B) > 0.1
    for i in range(3):
        for sign in (1.0, -1.0):
            assert _positively_reaches(B, sign * np.eye(3)[i])


# ----------------------------------------------------------------------------- rcs_cube_12


def test_rcs_cube_12_matches_hand_computed_columns():
    h, F = 0.5, 10.0
    B = wrench_matrix(rcs_cube_12(side_m=1.0, max_thrust_N=10.0))
    # Thruster 0 at (h, h, 0), force (-F, 0, 0): r x f = (0, 0, h F).
    np.testing.assert_allclose(B[:, 0], [0, 0, h * F, -F, 0, 0], atol=RTOL)
    # Thruster 4 at (0, h, h), force (0, -F, 0): r x f = (h F, 0, 0).
    np.testing.assert_allclose(B[:, 4], [h * F, 0, 0, 0, -F, 0], atol=RTOL)
    # Thruster 8 at (h, 0, h), force (0, 0, -F): r x f = (0, h F, 0).
    np.testing.assert_allclose(B[:, 8], [0, h * F, 0, 0, 0, -F], atol=RTOL)
    # Thruster 10 at (-h, 0, -h), force (0, 0, +F): r x f = (0, (-h)(-F)... ) = (0, h F, 0).
    np.testing.assert_allclose(B[:, 10], [0, h * F, 0, 0, 0, F], atol=RTOL)
    # One thruster per cube edge midpoint: 12 distinct points, each with two coordinates +-h.
    P = rcs_cube_12(side_m=1.0).p_CK_C
    assert len({tuple(p) for p in P}) == 12
    assert np.all(np.sort(np.abs(P), axis=1) == [0.0, h, h])


def test_rcs_cube_12_positively_spans_all_six_dof():
    B = wrench_matrix(rcs_cube_12())
    assert np.linalg.matrix_rank(B) == 6
    assert _strictly_positive_null_margin(B) > 0.1
    for i in range(6):
        for sign in (1.0, -1.0):
            assert _positively_reaches(B, sign * np.eye(6)[i]), (i, sign)


# ----------------------------------------------------------------------------- gimbaled_cuboid_8


def test_gimbaled_cuboid_8_geometry_per_paper_001():
    layout = gimbaled_cuboid_8()
    assert layout.gimbaled and layout.count == 8 and layout.command_size == 24
    P = layout.p_CK_C
    corners = {(x, y, z) for x in (-0.75, 0.75) for y in (-2.0, 2.0) for z in (-0.75, 0.75)}
    assert {tuple(p) for p in P} == corners  # the corners of the 1.5 x 4 x 1.5 m cuboid
    np.testing.assert_allclose(layout.max_thrusts_N, 20.0)
    np.testing.assert_allclose(layout.gimbal_half_angles_rad, math.pi / 4)
    # Nominal thrust on the line through the thruster and the CoM, along -j = -p/|p| (eq. 13).
    np.testing.assert_allclose(
        layout.directions_C, -P / np.linalg.norm(P, axis=1, keepdims=True), atol=RTOL
    )
    # Hence every thruster at nominal produces zero torque ...
    np.testing.assert_allclose(wrench_matrix(layout)[:3], 0.0, atol=RTOL)
    # ... and documented antipodal pairs k, (k + 2) % 4 + 4 fired together cancel completely.
    for k in range(4):
        m = (k + 2) % 4 + 4
        np.testing.assert_allclose(P[m], -P[k], atol=0)
        F = np.zeros((8, 3))
        F[k] = 20.0 * layout.directions_C[k]
        F[m] = 20.0 * layout.directions_C[m]
        np.testing.assert_allclose(wrench_from_forces(layout, F), 0.0, atol=1e-12)
    # Mirror pairs k, k + 4 across y = 0.
    np.testing.assert_allclose(P[4:], P[:4] * [1, -1, 1], atol=0)


# ----------------------------------------------------------------------------- mass flow


def test_mass_flow_rate_hand_values():
    layout = rcs_cube_12(max_thrust_N=10.0, isp_s=220.0)
    # 10 N at 220 s: 10 / (220 * 9.80665) = 10 / 2157.463 kg/s.
    magnitudes = np.zeros(12)
    magnitudes[3] = 10.0
    assert mass_flow_rate(layout, magnitudes) == pytest.approx(10.0 / 2157.463, rel=1e-12)
    # Mixed Isp: 5 N at 300 s + 20 N at 100 s = 5/2941.995 + 20/980.665.
    mixed = ThrusterLayout(
        [
            Thruster([1, 0, 0], [0, 1, 0], 20.0, isp_s=300.0),
            Thruster([0, 1, 0], [1, 0, 0], 20.0, isp_s=100.0),
        ]
    )
    assert mass_flow_rate(mixed, [5.0, -20.0]) == pytest.approx(
        5.0 / 2941.995 + 20.0 / 980.665, rel=1e-12
    )
    np.testing.assert_allclose(layout.max_mass_flows_kg_s, 10.0 / (220.0 * STANDARD_GRAVITY_M_S2))
    assert DEFAULT_ISP_S == 220.0
