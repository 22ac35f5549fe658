"""Tests for tests.reference.rigid_body_attitude: structure, derivatives, and simulated motion."""

import numpy as np
import pytest
from pydrake.common.eigen_geometry import AngleAxis
from pydrake.systems.analysis import ResetIntegratorFromFlags, Simulator
from scipy.integrate import solve_ivp

from rpod.models.rigid_body import (
    angular_acceleration,
    angular_momentum_in_inertial,
    quaternion_rate,
    rotational_kinetic_energy,
)

from .rigid_body_attitude import RigidBodyAttitude

# Paper 000 eq. (27): the target's inertia [kg m^2].
J_PAPER_000 = np.array(
    [
        [5.89056, 0.0, 0.0],
        [0.0, 11.4462, 0.233516],
        [0.0, 0.233516, 11.5365],
    ]
)
DEG = np.pi / 180.0
Q_IDENTITY = np.array([1.0, 0.0, 0.0, 0.0])


def test_port_structure():
    system = RigidBodyAttitude(J_PAPER_000, Q_IDENTITY, np.zeros(3))
    assert system.num_input_ports() == 1
    assert system.get_body_torque_input_port().get_name() == "body_torque"
    assert system.get_body_torque_input_port().size() == 3
    assert system.num_output_ports() == 1
    assert system.get_attitude_output_port().get_name() == "attitude"
    assert system.get_attitude_output_port().size() == 7
    context = system.CreateDefaultContext()
    assert context.num_continuous_states() == 7
    assert context.num_discrete_state_groups() == 0
    # The output is declared to depend on xc only, so there is no torque -> attitude feedthrough.
    assert not system.HasDirectFeedthrough(0, 0)

    free = RigidBodyAttitude(J_PAPER_000, Q_IDENTITY, np.zeros(3), with_torque_input=False)
    assert free.num_input_ports() == 0
    with pytest.raises(RuntimeError):
        free.get_body_torque_input_port()


def test_constructor_validation_and_initial_state():
    with pytest.raises(ValueError, match="triangle"):
        RigidBodyAttitude(np.diag([1.0, 1.0, 3.0]), Q_IDENTITY, np.zeros(3))
    with pytest.raises(ValueError, match="symmetric"):
        RigidBodyAttitude(np.array([[1, 0.5, 0], [0, 1, 0], [0, 0, 1.0]]), Q_IDENTITY, np.zeros(3))
    with pytest.raises(ValueError, match="norm"):
        RigidBodyAttitude(J_PAPER_000, np.zeros(4), np.zeros(3))
    with pytest.raises(ValueError, match="w_B"):
        RigidBodyAttitude(J_PAPER_000, Q_IDENTITY, np.zeros(2))

    # The default quaternion is normalised; set_initial_state normalises too (exact to 1 ulp).
    system = RigidBodyAttitude(J_PAPER_000, [2.0, 0.0, 0.0, 0.0], [0.1, 0.2, 0.3], False)
    context = system.CreateDefaultContext()
    np.testing.assert_allclose(
        context.get_continuous_state_vector().CopyToVector(), [1, 0, 0, 0, 0.1, 0.2, 0.3]
    )
    system.set_initial_state(context, [0.0, 0.0, 3.0, 4.0], [-1.0, 0.0, 2.0])
    np.testing.assert_allclose(
        system.get_attitude_output_port().Eval(context), [0, 0, 0.6, 0.8, -1, 0, 2], atol=1e-16
    )


def test_time_derivatives_match_model():
    # Same formula evaluated through the system and directly: only round-off may differ.
    rng = np.random.default_rng(3)
    system = RigidBodyAttitude(J_PAPER_000, Q_IDENTITY, np.zeros(3))
    context = system.CreateDefaultContext()
    for _ in range(20):
        q = rng.normal(size=4)
        q *= rng.uniform(0.9, 1.1) / np.linalg.norm(q)  # unnormalised, as an integrator leaves it
        w = rng.normal(scale=0.3, size=3)
        tau = rng.normal(size=3)
        context.SetContinuousState(np.concatenate([q, w]))
        system.get_body_torque_input_port().FixValue(context, tau)
        xdot = system.EvalTimeDerivatives(context).CopyToVector()
        np.testing.assert_allclose(xdot[:4], quaternion_rate(q, w), rtol=1e-14, atol=1e-15)
        np.testing.assert_allclose(
            xdot[4:], angular_acceleration(J_PAPER_000, w, tau), rtol=1e-12, atol=1e-14
        )
        # The output is the state with the quaternion normalised.
        y = system.get_attitude_output_port().Eval(context)
        np.testing.assert_allclose(y, np.concatenate([q / np.linalg.norm(q), w]), atol=1e-15)


def _scipy_reference(J, q0, w0, t_eval):
    """Torque-free attitude by scipy DOP853 at rtol 1e-12 (independent integrator)."""
    J_inv = np.linalg.inv(J)

    def rhs(_, x):
        return np.concatenate(
            [quaternion_rate(x[:4], x[4:]), angular_acceleration(J, x[4:], None, J_inv)]
        )

    sol = solve_ivp(
        rhs,
        (0.0, t_eval[-1]),
        np.concatenate([q0, w0]),
        method="DOP853",
        t_eval=t_eval,
        rtol=1e-12,
        atol=1e-12,
    )
    assert sol.success
    return sol.y.T


def test_simulated_tumble_matches_scipy_and_conserves():
    # Paper 000 eq. (27) target tumbling at 10 deg/s for 600 s (~17 revolutions).
    w0 = 10.0 * DEG * np.array([0.6, -0.5, 0.62]) / np.linalg.norm([0.6, -0.5, 0.62])
    q0 = np.array([0.3, -0.2, 0.8, 0.1])
    q0 /= np.linalg.norm(q0)
    system = RigidBodyAttitude(J_PAPER_000, q0, w0, with_torque_input=False)
    simulator = Simulator(system)
    # RK5 (error-controlled); max step 10 s is only a cap, accuracy sets the real step.
    integrator = ResetIntegratorFromFlags(simulator, "runge_kutta5", 10.0)
    integrator.set_target_accuracy(1e-10)
    simulator.Initialize()
    context = simulator.get_context()

    times = np.linspace(0.0, 600.0, 61)
    reference = _scipy_reference(J_PAPER_000, q0, w0, times)
    E0 = rotational_kinetic_energy(J_PAPER_000, w0)
    h0 = angular_momentum_in_inertial(q0, J_PAPER_000, w0)
    for t, x_ref in zip(times, reference):
        simulator.AdvanceTo(t)
        y = system.get_attitude_output_port().Eval(context)
        # Drake RK5 at target accuracy 1e-10 takes ~1600 steps and ends ~7e-10 (relative) from
        # scipy, whose own error is ~1e-11; 1e-8 leaves a 10x margin and is far below the O(1)
        # error that a wrong sign or frame in the dynamics produces.
        np.testing.assert_allclose(y[:4], x_ref[:4], atol=1e-8)
        np.testing.assert_allclose(y[4:], x_ref[4:], atol=1e-8 * np.linalg.norm(w0))
        # Energy and inertial angular momentum are invariants of the exact flow; same budget.
        assert rotational_kinetic_energy(J_PAPER_000, y[4:]) == pytest.approx(E0, rel=1e-8)
        np.testing.assert_allclose(
            angular_momentum_in_inertial(y[:4], J_PAPER_000, y[4:]),
            h0,
            atol=1e-8 * np.linalg.norm(h0),
        )


@pytest.mark.parametrize("axis", [0, 1, 2])
def test_constant_principal_torque_from_rest(axis):
    # About a principal axis from rest the gyroscopic term stays zero, so w = tau / J_ii t and
    # the attitude is a rotation by tau / (2 J_ii) t^2 about that axis (exact solution).
    J = np.diag([2.0, 3.0, 4.0])
    tau = np.zeros(3)
    tau[axis] = 0.05
    system = RigidBodyAttitude(J, Q_IDENTITY, np.zeros(3))
    simulator = Simulator(system)
    context = simulator.get_mutable_context()
    system.get_body_torque_input_port().FixValue(context, tau)
    ResetIntegratorFromFlags(simulator, "runge_kutta5", 10.0).set_target_accuracy(1e-10)
    t_final = 20.0
    simulator.AdvanceTo(t_final)
    y = system.get_attitude_output_port().Eval(context)

    alpha = tau[axis] / J[axis, axis]
    w_expected = np.zeros(3)
    w_expected[axis] = alpha * t_final
    unit = np.zeros(3)
    unit[axis] = 1.0
    q_expected = AngleAxis(0.5 * alpha * t_final**2, unit).quaternion().wxyz()
    # w(t) is linear, which RK5 integrates exactly (round-off only); the quaternion follows a
    # quadratic angle, integrated to the 1e-10 target accuracy, hence 1e-8.
    np.testing.assert_allclose(y[4:], w_expected, atol=1e-12)
    np.testing.assert_allclose(y[:4], q_expected, atol=1e-8)
