"""Tests for rpod.models.rigid_body against conservation laws, closed forms and Drake rotations."""

import numpy as np
import pytest
from pydrake.autodiffutils import ExtractGradient, ExtractValue, InitializeAutoDiff
from pydrake.common.eigen_geometry import AngleAxis, Quaternion
from pydrake.math import RollPitchYaw
from scipy.integrate import solve_ivp

from rpod.models.config import ConfigError
from rpod.models.rigid_body import (
    angular_acceleration,
    angular_momentum_in_inertial,
    axisymmetric_torque_free_solution,
    quaternion_rate,
    rotational_kinetic_energy,
    validate_inertia,
)

# Paper 000 eq. (27): the target's inertia [kg m^2] (non-diagonal).
J_PAPER_000 = np.array(
    [
        [5.89056, 0.0, 0.0],
        [0.0, 11.4462, 0.233516],
        [0.0, 0.233516, 11.5365],
    ]
)
DEG = np.pi / 180.0


def _integrate(J, q0, w0, t_eval):
    """Torque-free attitude by scipy DOP853 at rtol 1e-12 (the independent reference)."""
    J_inv = np.linalg.inv(J)

    def rhs(_, x):
        return np.concatenate(
            [quaternion_rate(x[:4], x[4:]), angular_acceleration(J, x[4:], None, J_inv)]
        )

    sol = solve_ivp(
        rhs,
        (t_eval[0], t_eval[-1]),
        np.concatenate([q0, w0]),
        method="DOP853",
        t_eval=t_eval,
        rtol=1e-12,
        atol=1e-12,
    )
    assert sol.success
    return sol.y.T


def _random_quaternion(rng):
    q = rng.normal(size=4)
    return q / np.linalg.norm(q)


def test_torque_free_conserves_energy_and_momentum():
    # Paper 000 eq. (27) inertia, 10 deg/s tumble in a generic direction, 600 s.
    rng = np.random.default_rng(0)
    w0 = 10.0 * DEG * np.array([0.6, -0.5, 0.62]) / np.linalg.norm([0.6, -0.5, 0.62])
    q0 = _random_quaternion(rng)
    times = np.linspace(0.0, 600.0, 601)
    states = _integrate(J_PAPER_000, q0, w0, times)

    E0 = rotational_kinetic_energy(J_PAPER_000, w0)
    h0 = angular_momentum_in_inertial(q0, J_PAPER_000, w0)
    energies = np.array([rotational_kinetic_energy(J_PAPER_000, x[4:]) for x in states])
    momenta = np.array([angular_momentum_in_inertial(x[:4], J_PAPER_000, x[4:]) for x in states])

    # The motion is a genuine tumble (rates change by > 10 %), so conservation is not trivial.
    assert np.ptp(states[:, 4:], axis=0).max() > 0.1 * np.linalg.norm(w0)
    # DOP853 at rtol = atol = 1e-12 keeps the state to ~1e-10 relative over 600 s; energy and
    # momentum are conserved exactly by the true flow, so 1e-9 relative is the bound.
    np.testing.assert_allclose(energies, E0, rtol=1e-9)
    np.testing.assert_allclose(
        momenta, np.tile(h0, (len(times), 1)), atol=1e-9 * np.linalg.norm(h0)
    )
    # The quaternion flow preserves the norm exactly; same tolerance reasoning.
    np.testing.assert_allclose(np.linalg.norm(states[:, :4], axis=1), 1.0, atol=1e-9)


@pytest.mark.parametrize("J_a", [4.0, 16.0])  # prolate and oblate about body z
def test_axisymmetric_closed_form_matches_integration(J_a):
    J_t = 10.0
    rng = np.random.default_rng(1)
    w0 = 10.0 * DEG * np.array([0.5, -0.3, 0.8])
    q0 = _random_quaternion(rng)
    times = np.linspace(0.0, 600.0, 301)
    states = _integrate(np.diag([J_t, J_t, J_a]), q0, w0, times)
    q_cf, w_cf = axisymmetric_torque_free_solution(J_t, J_a, w0, q0, times)
    assert q_cf.shape == (301, 4) and w_cf.shape == (301, 3)
    # Integration error ~1e-10 over ~20 revolutions at rtol 1e-12; 1e-8 leaves margin and is
    # far below the ~1e-1 error a wrong sign of lambda or a wrong composition order gives.
    np.testing.assert_allclose(w_cf, states[:, 4:], atol=1e-8 * np.linalg.norm(w0))
    np.testing.assert_allclose(q_cf, states[:, :4], atol=1e-8)

    # Scalar time gives single vectors equal to the array result.
    q_s, w_s = axisymmetric_torque_free_solution(J_t, J_a, w0, q0, times[17])
    np.testing.assert_allclose(q_s, q_cf[17], atol=1e-15)
    np.testing.assert_allclose(w_s, w_cf[17], atol=1e-15)


def test_axisymmetric_pure_spin_is_rotation_about_body_z():
    # Spin about the symmetry axis only: R_IB(t) = R_IB(0) Rz(w t) exactly (Drake AngleAxis).
    q0 = RollPitchYaw(0.1, -0.4, 0.7).ToQuaternion()
    w = 0.3
    t = 7.0
    q_cf, w_cf = axisymmetric_torque_free_solution(3.0, 5.0, [0.0, 0.0, w], q0.wxyz(), t)
    expected = q0.multiply(AngleAxis(w * t, [0.0, 0.0, 1.0]).quaternion())
    # Closed form vs composition of two exact rotations: round-off only.
    np.testing.assert_allclose(q_cf, expected.wxyz(), atol=1e-14)
    np.testing.assert_allclose(w_cf, [0.0, 0.0, w], atol=1e-15)


def test_quaternion_rate_matches_finite_difference_of_exact_rotation():
    # For constant w_B, q(t + dt) = q(t) (x) exp(w_B dt / 2) exactly (Drake quaternion product);
    # a central difference with dt = 1e-5 has O(dt^2 |w|^3) ~ 1e-11 truncation, so 1e-9.
    rng = np.random.default_rng(2)
    for _ in range(5):
        q = Quaternion(_random_quaternion(rng))
        w_B = rng.normal(size=3)
        dt = 1e-5
        angle = np.linalg.norm(w_B)
        axis = w_B / angle

        def q_at(h, q=q, angle=angle, axis=axis):
            return q.multiply(AngleAxis(angle * h, axis).quaternion()).wxyz()

        fd = (q_at(dt) - q_at(-dt)) / (2.0 * dt)
        np.testing.assert_allclose(quaternion_rate(q.wxyz(), w_B), fd, atol=1e-9)


def test_angular_acceleration_known_values_and_autodiff():
    J = np.diag([2.0, 3.0, 4.0])
    w = np.array([0.1, -0.2, 0.3])
    tau = np.array([0.5, 0.0, -1.0])
    # Euler's equations componentwise for a diagonal inertia (exact arithmetic up to round-off).
    expected = np.array(
        [
            (tau[0] - (4.0 - 3.0) * w[1] * w[2]) / 2.0,
            (tau[1] - (2.0 - 4.0) * w[2] * w[0]) / 3.0,
            (tau[2] - (3.0 - 2.0) * w[0] * w[1]) / 4.0,
        ]
    )
    np.testing.assert_allclose(angular_acceleration(J, w, tau), expected, atol=1e-15)

    # AutoDiffXd object arrays: value equals the float result and the gradient matches a
    # central difference (step 1e-6, quadratic function, so the difference is exact to
    # round-off ~1e-10).
    x_ad = InitializeAutoDiff(np.concatenate([w, tau])).ravel()
    wdot_ad = angular_acceleration(J_PAPER_000, x_ad[:3], x_ad[3:], np.linalg.inv(J_PAPER_000))
    np.testing.assert_allclose(
        ExtractValue(wdot_ad).ravel(), angular_acceleration(J_PAPER_000, w, tau), atol=1e-15
    )
    fd = np.zeros((3, 6))
    x = np.concatenate([w, tau])
    for i in range(6):
        e = np.zeros(6)
        e[i] = 1e-6
        fd[:, i] = (
            angular_acceleration(J_PAPER_000, (x + e)[:3], (x + e)[3:])
            - angular_acceleration(J_PAPER_000, (x - e)[:3], (x - e)[3:])
        ) / 2e-6
    np.testing.assert_allclose(ExtractGradient(wdot_ad), fd, atol=1e-9)


def test_validate_inertia_accepts_physical():
    validate_inertia(J_PAPER_000)
    validate_inertia(np.diag([1.0, 1.0, 2.0]))  # thin disk: triangle equality holds exactly
    validate_inertia(np.diag([1.0, 1.0, 2.0 * (1.0 + 1e-12)]))  # within the relative tolerance


@pytest.mark.parametrize(
    "J, message",
    [
        (np.eye(2), "3x3"),
        (np.array([[1.0, 0.1, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]), "symmetric"),
        (np.diag([1.0, -1.0, 1.0]), "positive definite"),
        (np.diag([1.0, 2.0, 0.0]), "positive definite"),
        (np.diag([1.0, 1.0, 2.1]), "triangle"),
        (np.diag([1.0, np.nan, 1.0]), "non-finite"),
    ],
)
def test_validate_inertia_rejects(J, message):
    with pytest.raises(ConfigError, match=message) as error:
        validate_inertia(J, "target.inertia_kg_m2")
    assert error.value.field == "target.inertia_kg_m2"


def test_attitude_pd_torque_makes_euler_equations_the_commanded_second_order_law():
    """Through Euler's equations (angular_acceleration, paper 000 eq. 2) the PD torque gives
    exactly w_dot = alpha_ff + w_a^2 e + 2 zeta w_a (w_des - w): the gyroscopic term cancels."""
    from rpod.models.rigid_body import angular_acceleration, attitude_pd_torque

    rng = np.random.default_rng(11)
    J = np.array([[1200.0, 50.0, -30.0], [50.0, 1000.0, 20.0], [-30.0, 20.0, 800.0]])
    for with_feedforward in (False, True):
        e, w_err, w = rng.normal(size=(3, 3)) * [[0.1], [0.05], [0.2]]
        alpha = rng.normal(size=3) * 0.01 if with_feedforward else None
        tau = attitude_pd_torque(J, e, w_err, w, 0.8, 0.9, alpha)
        expected = 0.8**2 * e + 2 * 0.9 * 0.8 * w_err + (alpha if with_feedforward else 0.0)
        np.testing.assert_allclose(angular_acceleration(J, w, tau), expected, atol=1e-14)
