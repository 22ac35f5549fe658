"""The exact relative acceleration in LVLH against the truth it models (a Drake run of the
coasting `Truth`, differentiated numerically), against CW where CW holds, and its Jacobian
against finite differences."""

import numpy as np
import pytest

from rpod.models.cw import cw_acceleration
from rpod.models.gravity import MU_EARTH_M3_S2, R_EARTH_M
from rpod.models.orbit import OrbitConfig, initial_orbit_state
from rpod.models.relative_orbit import TargetOrbit, relative_acceleration_L, relative_jacobian_L
from rpod.systems.truth import Truth

ORBIT = OrbitConfig(altitude_m=500e3, inclination_deg=51.6, raan_deg=30.0, gravity="two_body_j2")


def _target(gravity="two_body_j2") -> TargetOrbit:
    return TargetOrbit(*initial_orbit_state(ORBIT), gravity)


def test_the_acceleration_is_the_truth_s_relative_motion_seen_in_lvlh():
    """The coasting truth's relative_state_L 0.05 s apart, the central difference of its
    velocity: the model's acceleration at the middle sample within 2e-8 m/s^2 (without the
    LVLH frame's angular acceleration it was 3e-7 m/s^2 off, 200 m out)."""
    from pydrake.systems.analysis import ResetIntegratorFromFlags, Simulator

    p0, v0 = np.array([30.0, -200.0, 12.0]), np.array([0.05, -0.02, 0.01])
    q = np.array([1.0, 0.0, 0.0, 0.0])
    J = np.diag([1.0, 2.0, 3.0])
    truth = Truth(ORBIT, p0, v0, 100.0, J, q, np.zeros(3), J, q, np.zeros(3), None)
    simulator = Simulator(truth)
    ResetIntegratorFromFlags(simulator, "runge_kutta5", 1.0).set_target_accuracy(1e-10)
    context = simulator.get_mutable_context()
    samples = []
    step = 0.05
    for k in range(3):
        simulator.AdvanceTo(1.0 + k * step)
        samples.append(
            (
                truth.GetOutputPort("relative_state_L").Eval(context).copy(),
                truth.GetOutputPort("target_state_I").Eval(context).copy(),
            )
        )
    (_, _), (middle, target), (_, _) = samples
    numeric = (samples[2][0][3:] - samples[0][0][3:]) / (2 * step)
    model = relative_acceleration_L(
        TargetOrbit(target[:3], target[3:], "two_body_j2"), middle[:3], middle[3:]
    )
    np.testing.assert_allclose(model, numeric, rtol=0, atol=2e-8)


def test_close_to_the_target_on_a_circular_two_body_orbit_it_is_cw():
    target = _target("two_body")
    n = np.sqrt(MU_EARTH_M3_S2 / (R_EARTH_M + ORBIT.altitude_m) ** 3)
    p, v = np.array([2.0, -10.0, 1.0]), np.array([0.01, 0.0, -0.02])
    exact = relative_acceleration_L(target, p, v)
    # CW leaves out terms of order n^2 p^2 / r: ~1e-11 m/s^2 at 10 m.
    np.testing.assert_allclose(exact, cw_acceleration(n, p, v), atol=1e-10)


@pytest.mark.parametrize("gravity", ["two_body", "two_body_j2"])
def test_the_jacobian_is_the_acceleration_s_derivative(gravity):
    target = _target(gravity)
    p, v = np.array([40.0, -120.0, 25.0]), np.array([0.1, -0.05, 0.02])
    A = relative_jacobian_L(target, p)
    h = 1e-3
    for i in range(3):
        e = np.zeros(3)
        e[i] = h
        dp = (
            relative_acceleration_L(target, p + e, v) - relative_acceleration_L(target, p - e, v)
        ) / (2 * h)
        dv = (
            relative_acceleration_L(target, p, v + e) - relative_acceleration_L(target, p, v - e)
        ) / (2 * h)
        np.testing.assert_allclose(A[3:6, i], dp, atol=1e-12)
        np.testing.assert_allclose(A[3:6, 3 + i], dv, atol=1e-12)
    np.testing.assert_array_equal(A[0:3, 3:6], np.eye(3))
