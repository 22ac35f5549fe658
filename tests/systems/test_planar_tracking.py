"""Tests of rpod.systems.planar_tracking: paper 003's planar PD tracker (eqs. 11-13).

Truths: hand-computed PD wrenches and rotations (exact up to round-off, 1e-12); the sampled
closed loop of a double integrator, which with a zero-order hold is a linear recursion
x_{k+1} = (A - B K) x_k known in closed form (RK3 integrates the piecewise-quadratic motion
exactly, so 1e-9 is round-off); and, through the real allocator and PWM on planar_8 thrusters
of 0.03 N, convergence from an offset (tolerances: the PWM's minimum impulse).
"""

import math

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import BasicVector, DiagramBuilder, LeafSystem
from pydrake.systems.primitives import MatrixGain
from pydrake.trajectories import PiecewisePolynomial

from rpod.models.thrusters import planar_8, wrench_matrix
from rpod.systems.allocator import WrenchAllocator
from rpod.systems.plan_at_start import PlannedPath
from rpod.systems.planar_tracking import (
    PlanarReference,
    PlanarTrackingConfig,
    PlanarTrackingController,
    body_wrench_from_planar,
    critically_damped_gains,
    planar_state_from_sensed,
    wrap_to_pi,
)
from rpod.systems.pwm import PwmModulator
from rpod.systems.sensed import SENSED_SIZE, Sensed, sensed_vector

T = 0.1
GAINS = PlanarTrackingConfig(T, 2.0, 3.0, 0.5, 0.25)  # round numbers for hand computation


def _about_z(angle):
    return np.array([math.cos(angle / 2), 0.0, 0.0, math.sin(angle / 2)])


def _sensed(x, theta_L=0.0, w_L=0.0):
    """The sensed bundle of a planar chaser state x in L, with L at yaw theta_L in I."""
    px, py, theta, vx, vy, omega = x
    return sensed_vector(
        relative_state_L=[px, py, 0.0, vx, vy, 0.0],
        q_IL=_about_z(theta_L),
        w_IL_L=[0.0, 0.0, w_L],
        target_attitude=np.r_[1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        chaser_attitude=np.r_[_about_z(theta_L + theta), 0.0, 0.0, w_L + omega],
    )


def _constant(values):
    return PiecewisePolynomial(np.asarray(values, dtype=float).reshape(-1, 1))


def _outputs(controller, sensed, t=0.0):
    """All outputs after the update at time t with this sensed input."""
    context = controller.CreateDefaultContext()
    context.SetTime(t)
    controller.GetInputPort("sensed").FixValue(context, sensed)
    controller.ExecuteInitializationEvents(context)
    names = (
        "body_wrench_desired",
        "planar_wrench_L",
        "tracking_error",
        "reference_state",
        "planar_state",
    )
    return {name: controller.GetOutputPort(name).Eval(context) for name in names}


def test_ports_config_and_reference_checks():
    controller = PlanarTrackingController(PlanarTrackingConfig(), _constant(np.zeros(6)))
    assert controller.GetInputPort("sensed").size() == SENSED_SIZE
    assert controller.GetOutputPort("body_wrench_desired").size() == 6
    assert not controller.HasAnyDirectFeedthrough()  # held between samples
    assert controller.CreateDefaultContext().get_discrete_state(0).size() == 27
    for field in ("control_period_s", "attitude_kd_N_m_s_per_rad"):
        bad = PlanarTrackingConfig(**{field: -1.0})
        with pytest.raises(ValueError, match=field):
            bad.validate()
    with pytest.raises(ValueError, match="reference_state must be 6 x 1"):
        PlanarTrackingController(PlanarTrackingConfig(), _constant(np.zeros(3)))
    with pytest.raises(ValueError, match="reference_wrench_L must be 3 x 1"):
        PlanarTrackingController(PlanarTrackingConfig(), _constant(np.zeros(6)), _constant([0]))


def test_reference_at_rest_gives_the_pd_of_the_error():
    reference = [0.5, 0.5, 0.3, 0.0, 0.0, 0.0]
    x = [0.1, -0.2, 0.0, 0.01, 0.02, -0.05]  # heading 0: body axes = L axes
    out = _outputs(PlanarTrackingController(GAINS, _constant(reference)), _sensed(x))
    # e = [0.4, 0.7, 0.3, -0.01, -0.02, 0.05] (eq. 11)
    np.testing.assert_allclose(out["tracking_error"], [0.4, 0.7, 0.3, -0.01, -0.02, 0.05])
    # F_x = 2 * 0.4 + 3 * -0.01, F_y = 2 * 0.7 + 3 * -0.02, tau = 0.5 * 0.3 + 0.25 * 0.05 (eq. 12)
    np.testing.assert_allclose(out["planar_wrench_L"], [0.77, 1.34, 0.1625], atol=1e-12)
    np.testing.assert_allclose(
        out["body_wrench_desired"], [0, 0, 0.1625, 0.77, 1.34, 0], atol=1e-12
    )
    np.testing.assert_allclose(out["reference_state"], reference)
    np.testing.assert_allclose(out["planar_state"], x, atol=1e-15)


@pytest.mark.parametrize("theta_L", [0.0, 1.1])  # L turned in I changes nothing
def test_body_rotation_of_eq_13_for_a_rotated_chaser(theta_L):
    # Chaser at heading 90 deg in L: a world force along +x is along -y_C.
    x = [0.0, 0.0, math.pi / 2, 0.0, 0.0, 0.0]
    reference = [1.0, 0.0, math.pi / 2, 0.0, 0.0, 0.0]  # e_x = 1 only: F_L = (2, 0, 0)
    out = _outputs(PlanarTrackingController(GAINS, _constant(reference)), _sensed(x, theta_L))
    np.testing.assert_allclose(out["planar_wrench_L"], [2.0, 0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(out["body_wrench_desired"], [0, 0, 0, 0, -2.0, 0], atol=1e-12)
    # A general heading: f_C = R(theta)^T F_L, by hand for theta = 30 deg.
    c, s = math.cos(math.pi / 6), math.sin(math.pi / 6)
    wrench = body_wrench_from_planar(np.array([1.0, 2.0, 0.3]), math.pi / 6)
    np.testing.assert_allclose(wrench, [0, 0, 0.3, c + 2 * s, -s + 2 * c, 0], atol=1e-15)
    # The rotated force, turned back by the chaser's attitude, is the world force.
    R_LC = np.array([[c, -s], [s, c]])
    np.testing.assert_allclose(R_LC @ wrench[3:5], [1.0, 2.0], atol=1e-15)


def test_planar_state_is_read_relative_to_l():
    x = [0.3, -0.4, -2.5, 0.01, -0.02, 0.07]
    sensed = Sensed.from_vector(_sensed(x, theta_L=0.8, w_L=0.05))
    np.testing.assert_allclose(planar_state_from_sensed(sensed), x, atol=1e-14)


def test_heading_error_wraps_around():
    assert wrap_to_pi(math.pi) == math.pi
    assert wrap_to_pi(-math.pi) == math.pi
    assert wrap_to_pi(3 * math.pi + 0.25) == pytest.approx(-math.pi + 0.25, abs=1e-14)
    assert wrap_to_pi(-0.1) == -0.1
    # Chaser at 3.0 rad, reference at -3.0 rad: the short way is +0.283 rad, not -6 rad.
    x = [0.0, 0.0, 3.0, 0.0, 0.0, 0.0]
    out = _outputs(PlanarTrackingController(GAINS, _constant([0, 0, -3.0, 0, 0, 0])), _sensed(x))
    assert out["tracking_error"][2] == pytest.approx(2 * math.pi - 6.0, abs=1e-12)
    assert out["planar_wrench_L"][2] == pytest.approx(0.5 * (2 * math.pi - 6.0), abs=1e-12)
    # An unwrapped reference heading (three turns on) is the same heading.
    x = [0.0, 0.0, -0.1, 0.0, 0.0, 0.0]
    reference = _constant([0, 0, 6 * math.pi + 0.1, 0, 0, 0])
    out = _outputs(PlanarTrackingController(GAINS, reference), _sensed(x))
    assert out["tracking_error"][2] == pytest.approx(0.2, abs=1e-12)


def test_feedforward_passes_through_and_the_reference_is_held_at_rest_outside_its_span():
    # From t = 1 to 3 s: x from 0 to 0.2 m at 0.1 m/s, heading 60 deg; a constant feed-forward.
    times = np.array([1.0, 3.0])
    heading = math.pi / 3
    states = np.array([[0.0, 0.0, heading, 0.1, 0.0, 0.0], [0.2, 0.0, heading, 0.1, 0.0, 0.0]])
    reference = PiecewisePolynomial.FirstOrderHold(times, states.T)
    feedforward = PiecewisePolynomial.FirstOrderHold(times, np.array([[0.1, -0.2, 0.03]] * 2).T)
    controller = PlanarTrackingController(GAINS, reference, feedforward)
    # At t = 2 s the chaser is on the reference: the output is the feed-forward, rotated.
    out = _outputs(controller, _sensed([0.1, 0.0, heading, 0.1, 0.0, 0.0]), t=2.0)
    np.testing.assert_allclose(out["tracking_error"], np.zeros(6), atol=1e-15)
    np.testing.assert_allclose(out["planar_wrench_L"], [0.1, -0.2, 0.03], atol=1e-15)
    np.testing.assert_allclose(
        out["body_wrench_desired"],
        body_wrench_from_planar(np.array([0.1, -0.2, 0.03]), heading),
        atol=1e-15,
    )
    # Off the reference, PD and feed-forward add: 0.5 m behind in x -> F_x + 2 * 0.5.
    out = _outputs(controller, _sensed([-0.4, 0.0, heading, 0.1, 0.0, 0.0]), t=2.0)
    np.testing.assert_allclose(out["planar_wrench_L"], [1.1, -0.2, 0.03], atol=1e-12)
    # Without a feed-forward (paper 003), the same on-reference chaser gets nothing.
    out = _outputs(
        PlanarTrackingController(GAINS, reference),
        _sensed([0.1, 0.0, heading, 0.1, 0.0, 0.0]),
        t=2.0,
    )
    np.testing.assert_allclose(out["body_wrench_desired"], np.zeros(6), atol=1e-15)
    # After the end: the end pose at rest, no feed-forward. Before the start: the start pose.
    at_end = [0.2, 0.0, heading, 0.0, 0.0, 0.0]
    out = _outputs(controller, _sensed(at_end), t=5.0)
    np.testing.assert_allclose(out["reference_state"], at_end, atol=1e-15)
    np.testing.assert_allclose(out["planar_wrench_L"], np.zeros(3), atol=1e-15)
    out = _outputs(controller, _sensed(at_end), t=0.0)
    np.testing.assert_allclose(out["reference_state"], [0, 0, heading, 0, 0, 0], atol=1e-15)


def test_a_released_tracker_commands_nothing_from_the_release_on():
    reference = _constant([0.5, 0.0, 0.0, 0.0, 0.0, 0.0])
    off = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0]  # 0.5 m from the reference
    controller = PlanarTrackingController(GAINS, reference, release_time_s=2.0)
    before = _outputs(controller, _sensed(off), t=1.9)
    assert before["planar_wrench_L"][0] == pytest.approx(GAINS.position_kp_N_per_m * 0.5)
    for t in (2.0, 7.0):
        out = _outputs(controller, _sensed(off), t=t)
        np.testing.assert_array_equal(out["planar_wrench_L"], np.zeros(3))
        np.testing.assert_array_equal(out["body_wrench_desired"], np.zeros(6))
        assert out["tracking_error"][0] == pytest.approx(0.5)  # still measured
    with pytest.raises(ValueError, match="release_time_s"):
        PlanarTrackingController(GAINS, reference, release_time_s=math.nan)


def test_a_tracker_that_plans_at_start_plans_once_from_what_it_senses_at_t0():
    calls = []
    path = PlannedPath(1, 0.0, np.array([[0.2, 0.0, 0.0], [0.5, 0.0, 0.0]]))

    def plan_at_start(sensed):
        calls.append(planar_state_from_sensed(sensed))
        x_goal = planar_state_from_sensed(sensed) + [0.5, 0.0, 0.0, 0.0, 0.0, 0.0]
        return PlanarReference(_constant(x_goal), path=path, plan="the plan")

    controller = PlanarTrackingController(GAINS, plan_at_start=plan_at_start)
    context = controller.CreateDefaultContext()
    start = [0.2, 0.0, 0.0, 0.0, 0.0, 0.0]
    controller.GetInputPort("sensed").FixValue(context, _sensed(start))
    simulator = Simulator(controller, context)
    simulator.Initialize()
    assert len(calls) == 1
    np.testing.assert_array_equal(calls[0], start)
    reference = controller.reference(context)
    assert reference.plan == "the plan"
    assert controller.GetOutputPort("planned_path").Eval(context) is path
    wrench = controller.GetOutputPort("planar_wrench_L").Eval(context)
    assert wrench[0] == pytest.approx(GAINS.position_kp_N_per_m * 0.5)  # the planned reference
    # The periodic updates fly the same reference and plan no more.
    controller.GetInputPort("sensed").FixValue(context, _sensed([0.3, 0, 0, 0, 0, 0]))
    simulator.AdvanceTo(3.5 * T)
    assert len(calls) == 1
    assert controller.reference(context) is reference
    wrench = controller.GetOutputPort("planar_wrench_L").Eval(context)
    assert wrench[0] == pytest.approx(GAINS.position_kp_N_per_m * 0.4)
    with pytest.raises(ValueError, match="either"):
        PlanarTrackingController(GAINS)
    with pytest.raises(ValueError, match="either"):
        PlanarTrackingController(GAINS, _constant(start), plan_at_start=plan_at_start)


def test_critically_damped_gains_put_a_double_pole_at_exp_minus_wn_t():
    for inertia, w_n in ((10.0, 0.4), (0.15, 0.8), (500.0, 0.05)):
        kp, kd = critically_damped_gains(inertia, w_n, T)
        A = np.array([[1.0, T], [0.0, 1.0]])
        B = np.array([[T * T / (2 * inertia)], [T / inertia]])
        poles = np.linalg.eigvals(A - B @ np.array([[kp, kd]]))
        np.testing.assert_allclose(poles, [math.exp(-w_n * T)] * 2, atol=1e-6)  # a double root
        assert kp == pytest.approx(inertia * w_n**2, rel=0.1)  # near the continuous gains
        assert kd == pytest.approx(2 * inertia * w_n, rel=0.1)
    default = PlanarTrackingConfig()
    # The numbers the module docstring states, to their last digit.
    assert default.position_kp_N_per_m == pytest.approx(1.54, abs=5e-3)
    assert default.position_kd_N_s_per_m == pytest.approx(7.77, abs=5e-3)
    assert default.attitude_kp_N_m_per_rad == pytest.approx(0.0887, abs=5e-5)
    assert default.attitude_kd_N_m_s_per_rad == pytest.approx(0.226, abs=5e-4)
    assert PlanarTrackingConfig.critically_damped(10.0, 0.15) == default


class _PlanarPlant(LeafSystem):
    """A free planar rigid body (paper 003 eq. 2) driven by a body wrench, reporting `sensed`."""

    def __init__(self, mass, inertia, x0):
        super().__init__()
        self._mass, self._inertia = mass, inertia
        self.DeclareContinuousState(BasicVector(np.asarray(x0, dtype=float)))  # its default
        self._wrench_port = self.DeclareVectorInputPort("body_wrench", 6)
        self.DeclareVectorOutputPort(
            "sensed", SENSED_SIZE, self._calc_sensed, {self.all_state_ticket()}
        )

    def DoCalcTimeDerivatives(self, context, derivatives):
        x = context.get_continuous_state_vector().CopyToVector()
        w = self._wrench_port.Eval(context)
        c, s = math.cos(x[2]), math.sin(x[2])
        f_x, f_y = c * w[3] - s * w[4], s * w[3] + c * w[4]  # f_L = R(theta) f_C
        derivatives.get_mutable_vector().SetFromVector(
            [x[3], x[4], x[5], f_x / self._mass, f_y / self._mass, w[2] / self._inertia]
        )

    def _calc_sensed(self, context, output: BasicVector):
        output.SetFromVector(_sensed(context.get_continuous_state_vector().CopyToVector()))


def _closed_loop(x0, mass=10.0, inertia=0.15, thrust_N=None):
    """Controller (default gains, reference at rest at the origin) on the planar plant, either
    directly (thrust_N None) or through the allocator, the PWM and planar_8 thrusters."""
    builder = DiagramBuilder()
    controller = builder.AddSystem(
        PlanarTrackingController(PlanarTrackingConfig(), _constant(np.zeros(6)))
    )
    plant = builder.AddSystem(_PlanarPlant(mass, inertia, x0))
    builder.Connect(plant.GetOutputPort("sensed"), controller.GetInputPort("sensed"))
    wrench = controller.GetOutputPort("body_wrench_desired")
    if thrust_N is not None:
        layout = planar_8(0.3, thrust_N)
        allocator = builder.AddSystem(WrenchAllocator(layout))
        pwm = builder.AddSystem(PwmModulator(layout.count, T, 10))
        bank = builder.AddSystem(MatrixGain(wrench_matrix(layout)))  # [tau_C; f_C] = B u
        builder.Connect(wrench, allocator.get_input_port())
        builder.Connect(allocator.get_output_port(), pwm.GetInputPort("thruster_duty"))
        builder.Connect(pwm.GetOutputPort("thruster_on"), bank.get_input_port())
        wrench = bank.get_output_port()
    builder.Connect(wrench, plant.GetInputPort("body_wrench"))
    simulator = Simulator(builder.Build())
    simulator.get_mutable_integrator().set_target_accuracy(1e-10)
    return simulator, plant


@pytest.mark.parametrize(
    "x0, axis, inertia",
    [([0.05, 0.0, 0.0, 0.0, 0.0, 0.0], (0, 3), 10.0), ([0, 0, 0.2, 0, 0, 0.01], (2, 5), 0.15)],
)
def test_sampled_closed_loop_is_the_critically_damped_recursion(x0, axis, inertia):
    # One axis at a time, so that the other stays exactly at rest and the axis is a double
    # integrator with a zero-order hold: x_k = (A - B K)^k x_0 exactly.
    simulator, plant = _closed_loop(x0)
    default = PlanarTrackingConfig()
    gains = (
        (default.position_kp_N_per_m, default.position_kd_N_s_per_m)
        if axis[0] == 0
        else (default.attitude_kp_N_m_per_rad, default.attitude_kd_N_m_s_per_rad)
    )
    A = np.array([[1.0, T], [0.0, 1.0]])
    B = np.array([[T * T / (2 * inertia)], [T / inertia]])
    closed = A - B @ np.array([gains])
    expected = np.array(x0)[list(axis)]
    samples = []
    for k in range(1, 201):
        simulator.AdvanceTo(k * T)
        x = plant.GetMyContextFromRoot(simulator.get_context()).get_continuous_state_vector()
        expected = closed @ expected
        samples.append(x.CopyToVector()[list(axis)])
        np.testing.assert_allclose(samples[-1], expected, atol=1e-9 * abs(x0[axis[0]]))
    # Critically damped: the error decays without crossing zero.
    assert np.all(np.array(samples)[:, 0] * x0[axis[0]] > 0)


def test_converges_through_allocator_and_pwm_with_weak_thrusters():
    # 5 cm, 3 cm and 0.2 rad off, at rest, on eight 0.03 N thrusters (paper 003 Case Study 2).
    simulator, plant = _closed_loop([0.05, -0.03, 0.2, 0.0, 0.0, 0.0], thrust_N=0.03)
    simulator.AdvanceTo(40.0)
    x = plant.GetMyContextFromRoot(simulator.get_context()).get_continuous_state_vector()
    x = x.CopyToVector()
    # One 10 ms slot of one thruster changes the speed by 3e-5 m/s and the rate by 3e-4 rad/s.
    assert np.hypot(x[0], x[1]) < 1e-3
    assert abs(x[2]) < math.radians(0.2)
    assert np.hypot(x[3], x[4]) < 2e-4
    assert abs(x[5]) < 2e-3
