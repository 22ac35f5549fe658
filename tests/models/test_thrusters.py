"""Tests of rpod.models.thrusters against hand-computed wrenches, geometry and LP certificates.

Tolerances: wrenches and clip results are a handful of floating-point operations on O(1-100)
numbers, so they are checked to 1e-12 relative (round-off); LP certificates use HiGHS's
default 1e-7 feasibility tolerance, far from the margins asserted.
"""

import math

import numpy as np
import pytest
import scipy.optimize
from pydrake.autodiffutils import AutoDiffXd, ExtractGradient, InitializeAutoDiff

from rpod.models.thrusters import (
    DEFAULT_ISP_S,
    STANDARD_GRAVITY_M_S2,
    Thruster,
    ThrusterLayout,
    clip_gimbaled_force,
    clip_gimbaled_forces,
    force_from_gimbal_angles,
    gimbal_polyhedron,
    gimbaled_cuboid_8,
    mass_flow_rate,
    planar_8,
    rcs_cube_12,
    thruster_frame_C,
    validate_layout,
    validate_thruster,
    wrench_from_forces,
    wrench_matrix,
)

RTOL = 1e-12  # round-off of a few flops


# ----------------------------------------------------------------------------- validation


@pytest.mark.parametrize(
    "changes, field",
    [
        (dict(max_thrust_N=0.0), "max_thrust_N"),
        (dict(max_thrust_N=-1.0), "max_thrust_N"),
        (dict(isp_s=0.0), "isp_s"),
        (dict(isp_s=-200.0), "isp_s"),
        (dict(direction_C=[1.0, 1.0, 0.0]), "direction_C"),
        (dict(direction_C=[0.0, 0.0]), "direction_C"),
        (dict(p_CK_C=[0.0, np.nan, 0.0]), "p_CK_C"),
        (dict(gimbal_half_angle_rad=-0.1), "gimbal_half_angle_rad"),
        (dict(gimbal_half_angle_rad=math.pi / 2), "gimbal_half_angle_rad"),
    ],
)
def test_validate_thruster_names_the_bad_field(changes, field):
    fields = dict(p_CK_C=[1.0, 0.0, 0.0], direction_C=[0.0, 1.0, 0.0], max_thrust_N=1.0)
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


def test_wrench_from_forces_hand_case_and_symmetry():
    layout = gimbaled_cuboid_8()
    F = np.zeros((8, 3))
    F[0] = [0.0, 0.0, -20.0]  # at (0.75, 2, 0.75)
    # r x f = (2 (-20) - 0.75 (0), 0.75 (0) - 0.75 (-20), 0) = (-40, 15, 0); f = (0, 0, -20).
    np.testing.assert_allclose(wrench_from_forces(layout, F), [-40, 15, 0, 0, 0, -20], atol=RTOL)
    # The same force on antipodal thrusters: torques cancel, forces add.
    rng = np.random.default_rng(1)
    f = rng.normal(size=3)
    F = np.zeros((8, 3))
    F[0] = f
    F[6] = f  # thruster 6 is at -p_0
    np.testing.assert_allclose(wrench_from_forces(layout, F), np.r_[0, 0, 0, 2 * f], atol=1e-12)
    # Stacked 3n input accepted; equals B @ u for forces along the fixed directions.
    fixed = rcs_cube_12()
    u = rng.uniform(0, 1, 12)
    F = u[:, None] * fixed.max_thrusts_N[:, None] * fixed.directions_C
    expected = sum(
        np.r_[np.cross(p, f), f] for p, f in zip(fixed.p_CK_C, F)
    )  # direct sum of p x f with numpy's cross
    np.testing.assert_allclose(
        wrench_from_forces(fixed, F.ravel()), expected, rtol=RTOL, atol=1e-12
    )
    np.testing.assert_allclose(wrench_matrix(fixed) @ u, expected, rtol=RTOL, atol=1e-12)


def test_wrench_from_forces_autodiff_jacobian_is_skew_and_identity():
    layout = gimbaled_cuboid_8()
    f = np.random.default_rng(2).normal(size=24)
    wrench = wrench_from_forces(layout, InitializeAutoDiff(f).ravel())
    assert isinstance(wrench[0], AutoDiffXd)
    J = ExtractGradient(wrench)
    for k, p in enumerate(layout.p_CK_C):
        skew = np.array([[0, -p[2], p[1]], [p[2], 0, -p[0]], [-p[1], p[0], 0]])
        np.testing.assert_allclose(J[:3, 3 * k : 3 * k + 3], skew, atol=RTOL)  # d(p x f)/df
        np.testing.assert_allclose(J[3:, 3 * k : 3 * k + 3], np.eye(3), atol=RTOL)


# ----------------------------------------------------------------------------- gimbal geometry


def _tilted(thruster, angle, lateral):
    """Unit direction at `angle` from the nominal direction, tilted toward `lateral`."""
    return math.cos(angle) * thruster.direction_C + math.sin(angle) * lateral


def test_gimbal_polyhedron_contains_nominal_and_cuts_at_the_half_angle():
    for thruster in gimbaled_cuboid_8().thrusters:
        A, b = gimbal_polyhedron(thruster)
        assert A.shape == (4, 3) and np.all(b == 0.0)
        np.testing.assert_allclose(np.linalg.norm(A, axis=1), 1.0, rtol=RTOL)
        alpha = thruster.gimbal_half_angle_rad
        # Nominal direction strictly inside, by sin(alpha) on every face.
        np.testing.assert_allclose(A @ thruster.direction_C, -math.sin(alpha), rtol=RTOL)
        R = thruster_frame_C(thruster)
        for lateral in (R[:, 0], -R[:, 0], R[:, 2], -R[:, 2]):
            # Exactly one face is violated by sin(0.01) at alpha + 0.01 along a face normal...
            assert np.max(A @ _tilted(thruster, alpha + 0.01, lateral)) == pytest.approx(
                math.sin(0.01), rel=1e-9
            )
            # ... and alpha - 0.01 is inside by sin(0.01).
            assert np.max(A @ _tilted(thruster, alpha - 0.01, lateral)) == pytest.approx(
                -math.sin(0.01), rel=1e-9
            )
        assert np.all(A @ (-thruster.direction_C) > 0.0)  # backwards thrust excluded


def test_gimbal_polyhedron_is_inside_the_double_gimbal_set_of_eq_13():
    thruster = gimbaled_cuboid_8().thrusters[3]
    alpha = thruster.gimbal_half_angle_rad
    A, _ = gimbal_polyhedron(thruster)
    R_CK = thruster_frame_C(thruster)
    np.testing.assert_allclose(R_CK.T @ R_CK, np.eye(3), atol=RTOL)
    assert np.linalg.det(R_CK) == pytest.approx(1.0, rel=RTOL)
    p_hat = thruster.p_CK_C / np.linalg.norm(thruster.p_CK_C)
    np.testing.assert_allclose(R_CK[:, 1], p_hat, atol=RTOL)  # j_K = p/|p|
    f_nominal = force_from_gimbal_angles(thruster, 0, 0, 7.0)
    np.testing.assert_allclose(f_nominal, 7.0 * thruster.direction_C, atol=RTOL)
    # A single gimbal at its limit lands on a face of the pyramid (both gimbals).
    for a2, a3 in ((alpha, 0.0), (-alpha, 0.0), (0.0, alpha), (0.0, -alpha)):
        f = force_from_gimbal_angles(thruster, a2, a3, 1.0)
        assert np.max(A @ f) == pytest.approx(0.0, abs=1e-12)
    # Both gimbals at their limits is outside: the pyramid is the conservative inner set.
    assert np.max(A @ force_from_gimbal_angles(thruster, alpha, alpha, 1.0)) > 0.05
    # Any force in the pyramid is reachable with |alpha2|, |alpha3| <= alpha: invert eq. 13.
    rng = np.random.default_rng(3)
    t = math.tan(alpha)
    for _ in range(200):
        ax, li, lk = rng.uniform(0.1, 1.0), rng.uniform(-t, t), rng.uniform(-t, t)
        f_K = np.array([li, -1.0, lk]) * ax  # K components: i, j, k (thrust along -j)
        f_C = R_CK @ f_K
        assert np.all(A @ f_C <= 1e-12)
        # eq. 13: f_K = |f| (sin a3, -cos a2 cos a3, -sin a2 cos a3)
        a2 = math.atan2(-f_K[2], -f_K[1])
        a3 = math.atan2(f_K[0], math.hypot(f_K[1], f_K[2]))
        assert abs(a2) <= alpha + 1e-12 and abs(a3) <= alpha + 1e-12
        f_back = force_from_gimbal_angles(thruster, a2, a3, np.linalg.norm(f_C))
        np.testing.assert_allclose(f_back, f_C, atol=1e-12)


def test_gimbal_polyhedron_rejects_fixed_thruster():
    with pytest.raises(ValueError, match="gimbal_half_angle_rad"):
        gimbal_polyhedron(rcs_cube_12().thrusters[0])


def _feasible(thruster, f, tol):
    A, b = gimbal_polyhedron(thruster)
    return np.all(A @ f <= b + tol) and np.linalg.norm(f) <= thruster.max_thrust_N + tol


def test_clip_is_identity_on_feasible_and_lands_inside_otherwise():
    layout = gimbaled_cuboid_8()
    rng = np.random.default_rng(4)
    t = math.tan(math.pi / 4)
    for thruster in layout.thrusters:
        R = thruster_frame_C(thruster)
        for _ in range(50):
            # Feasible: inside the pyramid, inside the 20 N ball.
            f = R @ np.array([rng.uniform(-t, t), -1.0, rng.uniform(-t, t)])
            f *= rng.uniform(0, 20.0) / np.linalg.norm(f)
            f_c, clipped = clip_gimbaled_force(thruster, f)
            assert not clipped
            np.testing.assert_array_equal(f_c, f)  # bit for bit
            # Anything: lands inside (to round-off, 1e-12 of 20 N) and clipping is idempotent.
            g = rng.normal(size=3) * rng.choice([1.0, 10.0, 100.0])
            g_c, g_clipped = clip_gimbaled_force(thruster, g)
            assert _feasible(thruster, g_c, 20.0 * 1e-12)
            assert g_clipped == (not _feasible(thruster, g, 0.0))
            np.testing.assert_allclose(clip_gimbaled_force(thruster, g_c)[0], g_c, atol=1e-12)


def test_clip_hand_cases():
    thruster = gimbaled_cuboid_8().thrusters[0]
    n = thruster.direction_C
    e_i = thruster_frame_C(thruster)[:, 0]
    assert np.all(clip_gimbaled_force(thruster, -5.0 * n)[0] == 0.0)  # backwards -> off
    np.testing.assert_allclose(clip_gimbaled_force(thruster, 100.0 * n)[0], 20.0 * n, atol=RTOL)
    # 10 N axial with lateral 2 tan(pi/4) 10 = 20 N: lateral clamped to 10 N, |f| = 14.1 N < 20 N.
    f_c, clipped = clip_gimbaled_force(thruster, 10.0 * n + 20.0 * e_i)
    assert clipped
    np.testing.assert_allclose(f_c, 10.0 * n + 10.0 * e_i, atol=1e-12)
    # 18 N axial, 36 N lateral: clamped to (18, 18), |.| = 25.46 N, then scaled to 20 N.
    f_c, _ = clip_gimbaled_force(thruster, 18.0 * n + 36.0 * e_i)
    np.testing.assert_allclose(f_c, (20.0 / math.sqrt(2)) * (n + e_i), atol=1e-12)
    # A fixed thruster (angle 0) keeps only the axial part, in [0, f_max].
    fixed = Thruster([1, 0, 0], [0, 1, 0], 2.0)
    np.testing.assert_allclose(clip_gimbaled_force(fixed, [0.3, 1.5, -4.0])[0], [0, 1.5, 0], atol=0)
    # Vectorised: own nominal rows unchanged, a backwards row zeroed, a non-finite row zeroed
    # with infinite violation.
    layout = gimbaled_cuboid_8()
    F = 5.0 * layout.directions_C
    F[5] *= -1.0
    F[2, 1] = np.nan
    F_c, violation = clip_gimbaled_forces(layout, F)
    assert np.all(F_c[2] == 0.0) and violation[2] == np.inf
    assert np.all(F_c[5] == 0.0) and violation[5] == pytest.approx(5.0, rel=RTOL)
    keep = [0, 1, 3, 4, 6, 7]
    assert np.all(violation[keep] == 0.0) and np.all(F_c[keep] == F[keep])


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
