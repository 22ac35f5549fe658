"""Tests for rpod.models.frames: LVLH geometry, its exact angular velocity, and the transforms.

Independent truths used here: the defining geometry of LVLH (x along p, z along p x v); the
derivative of R_IL along an orbit integrated with scipy, differentiated numerically
(skew(w_IL_I) = dR_IL/dt R_IL^T); the closed-form relative position of a chaser sharing the
target's circular orbit; the quaternion -> rotation-matrix formula written out by hand; numpy's
cross product and AutoDiffXd's derivatives for the vector products.
"""

import math

import numpy as np
import pytest
from pydrake.autodiffutils import AutoDiffXd, ExtractGradient, InitializeAutoDiff
from pydrake.common.eigen_geometry import AngleAxis
from scipy.integrate import solve_ivp

from rpod.models.frames import (
    attitude_error,
    cross,
    cross_2d,
    cross_rows,
    inertial_to_lvlh,
    lvlh_angular_velocity,
    lvlh_rotation,
    lvlh_to_inertial,
    quaternion_conjugate,
    quaternion_product,
    quaternion_wxyz,
    rotate_by_wxyz,
    rotation_from_rpy_deg,
    rotation_from_wxyz,
    rotation_vector_quaternion,
    skew,
    skew_rows,
)
from rpod.models.gravity import (
    MU_EARTH_M3_S2,
    R_EARTH_M,
    circular_orbit_state,
    j2_acceleration,
    mean_motion,
    two_body_acceleration,
)

DEG = math.pi / 180.0


def _random_orbit_states(rng, count):
    """ECI states of random (generally eccentric) LEO-to-GEO orbits."""
    states = []
    for _ in range(count):
        p = rng.normal(size=3)
        p *= rng.uniform(6.6e6, 4.2e7) / np.linalg.norm(p)
        v = rng.normal(size=3)
        v -= 0.5 * np.dot(v, p) / np.dot(p, p) * p  # keep some radial velocity, not all
        v *= (
            rng.uniform(0.8, 1.2)
            * math.sqrt(MU_EARTH_M3_S2 / np.linalg.norm(p))
            / np.linalg.norm(v)
        )
        states.append((p, v))
    return states


def test_lvlh_rotation_is_right_handed_with_the_defining_axes():
    rng = np.random.default_rng(1)
    for p, v in _random_orbit_states(rng, 30):
        R = lvlh_rotation(p, v)
        # Round-off only (unit vectors built from 1e7 m and 1e4 m/s inputs): 1e-14.
        np.testing.assert_allclose(R.T @ R, np.eye(3), rtol=0, atol=1e-14)
        assert np.linalg.det(R) == pytest.approx(1.0, abs=1e-14)
        np.testing.assert_allclose(R[:, 0], p / np.linalg.norm(p), rtol=0, atol=1e-15)
        h = np.cross(p, v)
        np.testing.assert_allclose(R[:, 2], h / np.linalg.norm(h), rtol=0, atol=1e-15)
        # y is along-track: in the orbit plane, perpendicular to x, and has v_y > 0.
        assert np.dot(R[:, 1], v) > 0.0
        assert abs(np.dot(R[:, 1], p)) < 1e-15 * np.linalg.norm(p)


def _trajectory(with_j2, inclination_deg=51.6):
    def rhs(t, x):
        a = two_body_acceleration(x[0:3])
        if with_j2:
            a = a + j2_acceleration(x[0:3])
        return np.concatenate([x[3:6], a])

    p0, v0 = circular_orbit_state(500e3, inclination_deg * DEG, 25.0 * DEG, 10.0 * DEG)
    sol = solve_ivp(
        rhs,
        (0.0, 6000.0),
        np.concatenate([p0, v0]),
        method="DOP853",
        rtol=1e-13,
        atol=1e-7,
        dense_output=True,
    )
    assert sol.success
    accel = (
        (lambda p: two_body_acceleration(p) + j2_acceleration(p))
        if with_j2
        else two_body_acceleration
    )
    return sol.sol, accel


def _finite_difference_w_IL_L(state_of_t, t, step):
    """w_IL_L from skew(w_IL_I) = dR_IL/dt R_IL^T, dR/dt by the 4th-order central stencil."""

    def R(tt):
        x = state_of_t(tt)
        return lvlh_rotation(x[0:3], x[3:6])

    dR = (-R(t + 2 * step) + 8 * R(t + step) - 8 * R(t - step) + R(t - 2 * step)) / (12 * step)
    R_IL = R(t)
    W = dR @ R_IL.T
    skew_residual = np.abs(W + W.T).max()
    w_IL_I = np.array([W[2, 1], W[0, 2], W[1, 0]])
    return R_IL.T @ w_IL_I, skew_residual


@pytest.mark.parametrize("with_j2", [True, False])
def test_lvlh_angular_velocity_matches_finite_difference_of_R_IL(with_j2):
    state_of_t, accel = _trajectory(with_j2)
    n = mean_motion(R_EARTH_M + 500e3)
    max_wx = 0.0
    for t in np.linspace(100.0, 5900.0, 24):
        x = state_of_t(t)
        w_code = lvlh_angular_velocity(x[0:3], x[3:6], accel(x[0:3]))
        w_fd, skew_residual = _finite_difference_w_IL_L(state_of_t, t, step=1.0)
        # Tolerance 1e-13 rad/s (1e-10 of n, ~1e-7 of the J2 x-component ~1.5e-6 rad/s): the
        # 4th-order stencil's truncation with a 1 s step is ~n^5 h^4 ~ 1e-15, the DOP853 dense
        # output at rtol 1e-13 is good to ~1e-13 relative in R; measured max error ~4e-16.
        np.testing.assert_allclose(w_code, w_fd, rtol=0, atol=1e-13)
        assert skew_residual < 1e-13  # dR R^T is skew: R stays orthonormal along the orbit.
        assert w_code[1] == 0.0
        assert abs(w_fd[1]) < 1e-13  # the LVLH frame never turns about its along-track axis
        assert w_code[2] == pytest.approx(n, rel=5e-3)  # orbital rate (J2 shifts it ~1e-3)
        max_wx = max(max_wx, abs(w_code[0]))
    if with_j2:
        # The J2 normal acceleration turns the orbit plane: w_x is ~1e-6 rad/s, far above the
        # 1e-13 test resolution, so the comparison above really checks the x-component.
        assert max_wx > 1e-6
    else:
        # A central force has no normal component: w_x vanishes to round-off of a . h.
        assert max_wx < 1e-17


def test_inertial_lvlh_round_trip():
    rng = np.random.default_rng(2)
    for p, v in _random_orbit_states(rng, 20):
        a = two_body_acceleration(p) + j2_acceleration(p)
        R_IL, w = lvlh_rotation(p, v), lvlh_angular_velocity(p, v, a)
        p_TC_I = rng.normal(scale=100.0, size=3)
        v_TC_I = rng.normal(scale=0.1, size=3)
        p_L, v_L = inertial_to_lvlh(R_IL, w, p_TC_I, v_TC_I)
        p_back, v_back = lvlh_to_inertial(R_IL, w, p_L, v_L)
        # Round-off only: products of unit-norm R with 100 m and 1e-3 rad/s x 100 m vectors.
        np.testing.assert_allclose(p_back, p_TC_I, rtol=0, atol=1e-12)
        np.testing.assert_allclose(v_back, v_TC_I, rtol=0, atol=1e-15)
        # The transport term is really there: for a relative state at rest in I, the velocity
        # seen in L is -w x p (the target's frame sweeps past it at ~0.1 m/s).
        _, v_static = inertial_to_lvlh(R_IL, w, p_TC_I, np.zeros(3))
        np.testing.assert_allclose(v_static, -np.cross(w, R_IL.T @ p_TC_I), rtol=0, atol=1e-16)


@pytest.mark.parametrize("angle_deg", [0.001, 0.1, 5.0, 60.0])
def test_chaser_on_same_circular_orbit_is_at_rest_in_lvlh(angle_deg):
    altitude, inclination, raan, u_target = 500e3, 51.6 * DEG, 40.0 * DEG, 75.0 * DEG
    theta = angle_deg * DEG
    r = R_EARTH_M + altitude
    p_T, v_T = circular_orbit_state(altitude, inclination, raan, u_target)
    p_C, v_C = circular_orbit_state(altitude, inclination, raan, u_target + theta)
    R_IL = lvlh_rotation(p_T, v_T)
    w = lvlh_angular_velocity(p_T, v_T, two_body_acceleration(p_T))
    p_L, v_L = inertial_to_lvlh(R_IL, w, p_C - p_T, v_C - v_T)
    # Closed form: the chaser is the same circle rotated by theta about the orbit normal, so in
    # L it sits at r (cos theta - 1, sin theta, 0). Both circular states rotate rigidly with
    # L at the same rate n, so the velocity seen in L is exactly zero, not merely to first order
    # (a CW/linearised view would give errors ~ n r theta^2; none appear here).
    # Tolerance: round-off of the 7,000 km / 7.6 km/s absolute states that are subtracted,
    # ~1e-15 * 6.9e6 m ~ 1e-8 m and ~1e-15 * 7.6e3 m/s ~ 1e-11 m/s; take 1e-8 m and 1e-11 m/s.
    expected = r * np.array([math.cos(theta) - 1.0, math.sin(theta), 0.0])
    np.testing.assert_allclose(p_L, expected, rtol=0, atol=1e-8)
    np.testing.assert_allclose(v_L, np.zeros(3), rtol=0, atol=1e-11)
    # Without the transport term the along-track separation would show up as a velocity of
    # n * |p| (here >= 0.13 m/s even at 0.001 deg; measured residual
    # ~1e-12 m/s and ~1e-9 m in position): the test can tell.
    assert np.linalg.norm(R_IL.T @ (v_C - v_T)) > 0.1


def _rotation_from_quaternion_by_hand(q):
    """Unit quaternion (w, x, y, z) -> rotation matrix (Hamilton convention, active rotation)."""
    w, x, y, z = q / np.linalg.norm(q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def test_quaternion_helpers_round_trip():
    rng = np.random.default_rng(3)
    for _ in range(50):
        q = rng.normal(size=4)
        q_unnormalised = q * rng.uniform(0.5, 2.0)
        R = rotation_from_wxyz(q_unnormalised)
        # Round-off tolerances (unit-magnitude entries): 1e-14 for R, 1e-14 for q.
        np.testing.assert_allclose(R, _rotation_from_quaternion_by_hand(q), rtol=0, atol=1e-14)
        q_back = quaternion_wxyz(R)
        q_unit = q / np.linalg.norm(q)
        assert np.linalg.norm(q_back) == pytest.approx(1.0, abs=1e-14)
        # q and -q are the same rotation.
        sign = 1.0 if np.dot(q_back, q_unit) > 0 else -1.0
        np.testing.assert_allclose(sign * q_back, q_unit, rtol=0, atol=1e-14)
        np.testing.assert_allclose(rotation_from_wxyz(q_back), R, rtol=0, atol=1e-14)
    # 90 deg about z maps x to y.
    q_z90 = np.array([math.cos(math.pi / 4), 0.0, 0.0, math.sin(math.pi / 4)])
    np.testing.assert_allclose(
        rotation_from_wxyz(q_z90) @ [1.0, 0.0, 0.0], [0, 1, 0], rtol=0, atol=1e-15
    )


def test_rotate_by_wxyz_matches_rotation_matrix():
    # The float-only hot path (used by OrbitalDynamics for body-frame forces) on unit
    # quaternions; round-off tolerance 1e-15 relative to |v|.
    rng = np.random.default_rng(4)
    for _ in range(50):
        q = rng.normal(size=4)
        q /= np.linalg.norm(q)
        v = rng.normal(scale=3.0, size=3)
        np.testing.assert_allclose(
            np.array(rotate_by_wxyz(q, v)),
            _rotation_from_quaternion_by_hand(q) @ v,
            rtol=0,
            atol=1e-15 * np.linalg.norm(v),
        )


def test_rotation_from_rpy_deg_is_z_y_x_composition():
    # Drake's RollPitchYaw: R = Rz(yaw) Ry(pitch) Rx(roll), angles in radians.
    def Rx(a):
        c, s = math.cos(a), math.sin(a)
        return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])

    def Ry(a):
        c, s = math.cos(a), math.sin(a)
        return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])

    def Rz(a):
        c, s = math.cos(a), math.sin(a)
        return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])

    for rpy in [(10.0, -20.0, 30.0), (0.0, 0.0, 90.0), (-170.0, 45.0, 5.0)]:
        r, p, y = np.radians(rpy)
        np.testing.assert_allclose(
            rotation_from_rpy_deg(rpy), Rz(y) @ Ry(p) @ Rx(r), rtol=0, atol=1e-15
        )


def test_rotations_from_wxyz_matches_drake_rotation_matrix():
    """The one vectorised quaternion -> rotation helper against pydrake's RotationMatrix, for a
    batch of random (non-unit) quaternions and for a (2, 5, 4) stack; tolerance 1e-14."""
    from pydrake.common.eigen_geometry import Quaternion
    from pydrake.math import RotationMatrix

    from rpod.models.frames import rotations_from_wxyz

    rng = np.random.default_rng(7)
    q = rng.normal(size=(50, 4)) * rng.uniform(0.5, 2.0, size=(50, 1))
    expected = np.array([RotationMatrix(Quaternion(qk / np.linalg.norm(qk))).matrix() for qk in q])
    np.testing.assert_allclose(rotations_from_wxyz(q), expected, atol=1e-14)
    stacked = rotations_from_wxyz(q[:10].reshape(2, 5, 4))
    np.testing.assert_allclose(stacked.reshape(10, 3, 3), expected[:10], atol=1e-14)


# ---- Vector products. ----


def test_cross_and_skew_agree_with_numpys_cross_and_are_antisymmetric():
    rng = np.random.default_rng(11)
    for _ in range(100):
        a, b = rng.normal(size=3) * 10.0, rng.normal(size=3)
        # The same three differences of products as numpy's: equal to round-off (1 ulp of |a||b|).
        np.testing.assert_allclose(cross(a, b), np.cross(a, b), rtol=0, atol=1e-14 * 10.0 * 4.0)
        np.testing.assert_allclose(skew(a) @ b, np.cross(a, b), rtol=0, atol=1e-14 * 10.0 * 4.0)
        np.testing.assert_array_equal(skew(a), -skew(a).T)
    assert cross((1.0, 0.0, 0.0), [0.0, 1.0, 0.0]).tolist() == [0.0, 0.0, 1.0]  # any 3-sequence


def test_cross_and_skew_keep_autodiff_scalars_with_exact_derivatives():
    rng = np.random.default_rng(12)
    a, b = rng.normal(size=3), rng.normal(size=3)
    a_ad = InitializeAutoDiff(a)[:, 0]  # d/da
    c = cross(a_ad, b)
    assert isinstance(c[0], AutoDiffXd)
    np.testing.assert_allclose(ExtractGradient(c), -skew(b), rtol=0, atol=1e-15)  # d(a x b)/da
    S = skew(a_ad)
    assert S.dtype == object and isinstance(S[0, 0], AutoDiffXd)
    np.testing.assert_allclose(ExtractGradient(S @ b), -skew(b), rtol=0, atol=1e-15)


def test_row_variants_equal_the_single_vector_ones_bit_for_bit():
    rng = np.random.default_rng(13)
    A, B = rng.normal(size=(20, 3)), rng.normal(size=(20, 3))
    rows, S = cross_rows(A, B), skew_rows(A)
    for k in range(20):
        np.testing.assert_array_equal(rows[k], cross(A[k], B[k]))
        np.testing.assert_array_equal(S[k], skew(A[k]))
    np.testing.assert_array_equal(cross_rows(A, B[0]), np.array([cross(a, B[0]) for a in A]))
    assert skew_rows(A.reshape(4, 5, 3)).shape == (4, 5, 3, 3)
    # Complex entries are not conjugated (complex-step derivatives pass through).
    Z = A + 1j * B
    np.testing.assert_array_equal(cross_rows(Z, A).imag, cross_rows(B, A))
    # The planar product is the z component of the 3-D one.
    u, v = rng.normal(size=(20, 2)), rng.normal(size=(20, 2))
    flat = np.zeros((20, 1))
    np.testing.assert_array_equal(
        cross_2d(u, v), cross_rows(np.hstack([u, flat]), np.hstack([v, flat]))[:, 2]
    )


def test_the_quaternion_algebra_agrees_with_drakes():
    """quaternion_product, rotation_vector_quaternion and attitude_error against pydrake's
    RotationMatrix and AngleAxis, on random rotations (1e-12)."""
    rng = np.random.default_rng(5)
    for _ in range(50):
        a, b = (q / np.linalg.norm(q) for q in rng.standard_normal((2, 4)))
        np.testing.assert_allclose(
            rotation_from_wxyz(quaternion_product(a, b)),
            rotation_from_wxyz(a) @ rotation_from_wxyz(b),
            atol=1e-12,
        )
        np.testing.assert_allclose(
            quaternion_product(a, quaternion_conjugate(a)), [1, 0, 0, 0], atol=1e-12
        )
        theta = rng.uniform(-3.0, 3.0, 3)
        angle = np.linalg.norm(theta)
        drake = AngleAxis(angle, theta / angle).rotation()
        np.testing.assert_allclose(
            rotation_from_wxyz(rotation_vector_quaternion(theta)), drake, atol=1e-12
        )
        if angle < np.pi:  # the shorter way round is theta itself
            q = quaternion_product(a, rotation_vector_quaternion(theta))
            np.testing.assert_allclose(attitude_error(a, q), theta, atol=1e-10)
