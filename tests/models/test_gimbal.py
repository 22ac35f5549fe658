"""Tests of rpod.models.gimbal: the gimbaled thrusters' wrench map (paper 001 eqs. 11-12),
thruster frame and gimbal angles (eq. 13), pyramid (eq. 16) and clip (eqs. 16-17), against hand
computations, numpy's cross product, AutoDiffXd Jacobians and the inverse of eq. 13.

Tolerances: wrenches and clip results are a handful of floating-point operations on O(1-100)
numbers, so they are checked to 1e-12 relative (round-off); the force-to-wrench matrix is built
from the same products as the wrench (exact zeros and copies), so it is checked exactly.
"""

import math

import numpy as np
import pytest
from pydrake.autodiffutils import AutoDiffXd, ExtractGradient, InitializeAutoDiff

from rpod.models.gimbal import (
    clip_gimbaled_force,
    clip_gimbaled_forces,
    force_from_gimbal_angles,
    force_to_wrench_matrix,
    gimbal_constraint_matrix,
    gimbal_constraints,
    gimbal_polyhedron,
    pyramid_polyhedron,
    thruster_frame_C,
    wrench_from_forces,
)
from rpod.models.thrusters import Thruster, gimbaled_cuboid_8, rcs_cube_12, wrench_matrix

RTOL = 1e-12  # round-off of a few flops


# ----------------------------------------------------------------------------- wrench map


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


def test_force_to_wrench_matrix_is_skew_and_identity_blocks_and_maps_like_the_sum():
    layout = gimbaled_cuboid_8()
    M = force_to_wrench_matrix(layout)
    assert M.shape == (6, 24)
    for k, (x, y, z) in enumerate(layout.p_CK_C):
        block = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])  # [p_k]x, written out
        np.testing.assert_array_equal(M[:3, 3 * k : 3 * k + 3], block)
        np.testing.assert_array_equal(M[3:, 3 * k : 3 * k + 3], np.eye(3))
    f = np.random.default_rng(5).normal(size=24) * 10.0
    np.testing.assert_allclose(M @ f, wrench_from_forces(layout, f), rtol=RTOL, atol=1e-12)


def test_gimbal_constraint_matrix_is_block_diagonal_of_each_thrusters_pyramid():
    layout = gimbaled_cuboid_8()
    A, b = gimbal_constraint_matrix(layout)
    assert A.shape == (32, 24) and np.all(b == 0.0)
    for k, thruster in enumerate(layout.thrusters):
        rows = slice(4 * k, 4 * k + 4)
        np.testing.assert_array_equal(A[rows, 3 * k : 3 * k + 3], gimbal_polyhedron(thruster)[0])
        A_rest = A[rows].copy()
        A_rest[:, 3 * k : 3 * k + 3] = 0.0
        assert np.all(A_rest == 0.0)


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


def test_gimbal_polyhedron_holds_the_nominal_thrust_and_cuts_at_its_half_angle():
    layout = gimbaled_cuboid_8()  # paper 001 Sec. IV: 20 N, pi/4 (coupled_relative's default)
    eps = 1e-6
    nominal = np.concatenate([10.0 * t.direction_C for t in layout.thrusters])
    assert np.all(gimbal_constraints(layout, nominal) < -1.0)  # well inside
    for k, thruster in enumerate(layout.thrusters):
        R_CK = thruster_frame_C(thruster)
        n = thruster.direction_C
        laterals = (R_CK[:, 0], -R_CK[:, 0], R_CK[:, 2], -R_CK[:, 2])  # plane order of eq. 16
        for plane, e in enumerate(laterals):
            for angle, inside in ((math.pi / 4 - eps, True), (math.pi / 4 + eps, False)):
                u = nominal.copy()
                u[3 * k : 3 * k + 3] = 10.0 * (math.cos(angle) * n + math.sin(angle) * e)
                g = gimbal_constraints(layout, u)
                assert np.all(g <= 0.0) == inside
                if not inside:
                    violated = np.flatnonzero(g > 0.0)
                    np.testing.assert_array_equal(violated, [4 * k + plane])
                    assert g[4 * k + plane] == pytest.approx(10.0 * math.sin(eps), rel=1e-6)
        # The block of this thruster is its pyramid and the generic 4-face pyramid's.
        A, _ = gimbal_constraint_matrix(layout)
        A_k, _ = gimbal_polyhedron(thruster)
        np.testing.assert_array_equal(A[4 * k : 4 * k + 4, 3 * k : 3 * k + 3], A_k)
        np.testing.assert_allclose(
            pyramid_polyhedron(n, R_CK[:, 0], R_CK[:, 2], math.pi / 4), A_k, atol=1e-15
        )


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
