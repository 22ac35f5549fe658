"""SoftCaptureController: structure, the safe fallback, and tracking a plan on CW truth.

Truths: a start the planner cannot solve (a horizon too short to cover the range at v_max, or a
tumble above min(omega_max, v_max / |D_c + D_t|)) must give zero wrench and the planner's status
on the output ports, never an exception; flown on Clohessy-Wiltshire truth without PWM (thrust
applied as commanded), the closed loop must land on the plan's own terminal state, which the
planner computed by the exact zero-order-hold CW discretisation (an independent integration:
Drake's error-controlled Runge-Kutta on the continuous CW equations of the truth).
"""

import dataclasses

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator

from rpod.diagrams.simulate import simulate
from rpod.models.cw import passively_safe_state
from rpod.planners import checked_plan, plan_check
from rpod.planners.pointing import min_rotation
from rpod.planners.soft_capture import SoftCaptureConfig
from rpod.scenarios.loader import load_scenario
from rpod.systems.sensed import sensed_vector
from rpod.systems.soft_capture_controller import (
    MODE_FALLBACK,
    PLANNER_STATUSES,
    SoftCaptureController,
    SoftCaptureControllerConfig,
)

J_CHASER = np.diag([4300.0, 1300.0, 4100.0])
J_TARGET = np.array([[5.89056, 0.0, 0.0], [0.0, 11.4462, 0.233516], [0.0, 0.233516, 11.5365]])
Q_IDENTITY = np.array([1.0, 0.0, 0.0, 0.0])


def _start():
    """A passively safe start ~20 m from the target, with the capture axis on the line of sight."""
    n = SoftCaptureConfig().mean_motion
    x0 = passively_safe_state(n, -5.0, 0.0081, 8.0, 0.0)
    R_LC = min_rotation(np.array([0.0, 0.0, 1.0]), -x0[:3] / np.linalg.norm(x0[:3]))
    from pydrake.math import RotationMatrix

    return x0, RotationMatrix(R_LC).ToQuaternion().wxyz(), n


def _initialised(config, w_IT_T):
    """The controller after its initialization event (the plan at t0) with fixed inputs."""
    controller = SoftCaptureController(config, J_CHASER, J_TARGET)
    context = controller.CreateDefaultContext()
    x0, q_LC, n = _start()
    controller.GetInputPort("sensed").FixValue(
        context,  # L = I at this instant
        sensed_vector(x0, Q_IDENTITY, np.array([0.0, 0.0, n]), np.r_[Q_IDENTITY, w_IT_T],
                      np.r_[q_LC, 0.0, 0.0, 0.0]),
    )  # fmt: skip
    simulator = Simulator(controller, context)
    simulator.Initialize()
    return controller, simulator


def test_structure():
    controller = SoftCaptureController(SoftCaptureControllerConfig(), J_CHASER, J_TARGET)
    inputs = {controller.get_input_port(i).get_name(): controller.get_input_port(i).size()
              for i in range(controller.num_input_ports())}  # fmt: skip
    assert inputs == {"sensed": 33}  # the sensed bundle, rpod.systems.sensed
    outputs = {
        controller.get_output_port(i).get_name() for i in range(controller.num_output_ports())
    }
    assert outputs == {"body_wrench_desired", "reference_L", "force_feedforward_L",
                       "controller_mode", "planner_status", "planned_path"}  # fmt: skip
    assert controller.GetOutputPort("body_wrench_desired").size() == 6
    assert not controller.HasAnyDirectFeedthrough()  # held between samples


@pytest.mark.parametrize(
    "planner, w_IT_T, status",
    [
        # 10 knots (9 s) cannot cover ~17 m to the capture pose at v_max = 1.5 m/s.
        (SoftCaptureConfig(min_knots=10, max_knots=10), np.zeros(3), "no_feasible_horizon"),
        # 15 deg/s > min(0.2 rad/s, 1.5 / 5.4 rad/s) = 11.46 deg/s.
        (SoftCaptureConfig(), np.radians([15.0, 0.0, 0.0]), "tumble_rate_above_limit"),
    ],
)
def test_an_infeasible_plan_falls_back_to_zero_thrust_with_its_status(planner, w_IT_T, status):
    config = SoftCaptureControllerConfig(planner=planner)
    controller, simulator = _initialised(config, w_IT_T)
    simulator.AdvanceTo(0.35)  # a few samples after the failure: still no exception, no thrust
    context = simulator.get_context()
    np.testing.assert_array_equal(controller.GetOutputPort("body_wrench_desired").Eval(context),
                                  np.zeros(6))  # fmt: skip
    assert controller.GetOutputPort("controller_mode").Eval(context)[0] == MODE_FALLBACK
    code = int(controller.GetOutputPort("planner_status").Eval(context)[0])
    assert PLANNER_STATUSES[code] == status
    assert np.all(np.isnan(controller.GetOutputPort("reference_L").Eval(context)))
    records = controller.plan_records(context)
    assert len(records) == 1  # retry_period_s = 0: no second attempt
    assert records[0]["status"] == status and not records[0]["accepted"]
    assert records[0]["reason"]  # a one-line reason for the summary
    assert controller.GetOutputPort("planned_path").Eval(context).index == 0


def test_config_validation_names_the_field():
    with pytest.raises(ValueError, match="^replan_period_s"):
        SoftCaptureControllerConfig(replan_period_s=2.5).validate()
    with pytest.raises(ValueError, match="^planner.max_speed_m_s"):
        SoftCaptureControllerConfig(planner=SoftCaptureConfig(max_speed_m_s=-1.0)).validate()
    with pytest.raises(ValueError, match="^plan_tolerance_fraction"):
        SoftCaptureControllerConfig(plan_tolerance_fraction=0.0).validate()
    with pytest.raises(ValueError, match="^control_period_s"):
        SoftCaptureControllerConfig(control_period_s=0.3).validate()  # 1 s is not 0.3 k
    with pytest.raises(ValueError, match="^attitude_feedforward"):
        SoftCaptureControllerConfig(attitude_feedforward="yes").validate()


def test_tracking_a_plan_on_cw_truth_without_pwm_lands_on_its_terminal_state():
    """One plan (no replanning), CW truth, thrust as commanded: the flown state at every knot
    matches the plan's.

    Tolerance 5 mm and 1 mm/s: the plan is exact for a force held in L, while the closed loop
    holds a body-frame force over each 0.1 s sample as the chaser turns (up to ~1 deg/s here,
    i.e. ~2e-3 rad of force direction per sample) and corrects with a 0.4 rad/s feedback; the
    truth is integrated to accuracy 1e-6. Measured: 0.7 mm and 0.2 mm/s at the final knot.
    """
    _, scenario = load_scenario("soft_capture")
    scenario = dataclasses.replace(
        scenario,
        orbit=dataclasses.replace(scenario.orbit, gravity="cw"),
        thrusters=dataclasses.replace(scenario.thrusters, pwm=False),
        duration_s=49.0,
    )
    scenario.controller.replan_period_s = 0.0
    result = simulate(scenario)
    log = result.log
    (plan,) = result.summary["plans"]
    assert plan["status"] == "success" and plan["N"] == 50  # the final knot is at t = 49 s
    knots_t = log["plan_knots_t"][0]
    rows = [int(np.argmin(np.abs(log["t"] - t))) for t in knots_t]
    np.testing.assert_allclose(log["t"][rows], knots_t, atol=1e-9)
    position_error = np.linalg.norm(log["p_LC_L"][rows] - log["plan_knots_p_LC_L"][0], axis=1)
    velocity_error = np.linalg.norm(log["v_LC_L"][rows] - log["plan_knots_v_LC_L"][0], axis=1)
    assert position_error.max() < 5e-3, position_error
    assert velocity_error.max() < 1e-3, velocity_error
    assert result.summary["capture"]["success"], result.summary["capture"]


def test_a_failed_plan_is_retried_at_the_retry_period():
    config = SoftCaptureControllerConfig(
        planner=SoftCaptureConfig(min_knots=10, max_knots=10), retry_period_s=0.2
    )
    controller, simulator = _initialised(config, np.zeros(3))
    simulator.AdvanceTo(0.45)
    records = controller.plan_records(simulator.get_context())
    assert [r["kind"] for r in records] == ["initial", "retry", "retry"]
    assert [r["t_s"] for r in records] == pytest.approx([0.0, 0.2, 0.4])
    assert all(r["status"] == "no_feasible_horizon" for r in records)


def test_an_accepted_plan_passed_the_independent_check():
    """The record of an accepted plan carries the checker's verdict: passed, nothing violated,
    its own LP's alpha equal to the planner's (same scaled hulls); the true hulls' alpha is
    1 + collision_margin times it (the hulls are scaled about their origins)."""
    config = SoftCaptureControllerConfig()
    controller, simulator = _initialised(config, np.zeros(3))
    (record,) = controller.plan_records(simulator.get_context())
    assert record["accepted"] and record["status"] == "success"
    assert record["check_passed"] is True and record["check_violations"] == {}
    assert record["check_min_alpha"] == pytest.approx(record["min_alpha"], abs=1e-7)
    scale = 1.0 + config.collision_margin
    assert record["check_min_alpha_true"] == pytest.approx(scale * record["min_alpha"], rel=1e-7)
    assert record["check_dynamics_residual"] < 1e-9  # closed form vs expm
    assert record["check_time_s"] > 0.0


def test_a_cloned_context_keeps_its_own_memory():
    """The controller's memory is shared, not copied, when Drake clones a context
    (``_Memory.__deepcopy__``): updates replace it whole, so a clone never sees them."""
    controller, simulator = _initialised(SoftCaptureControllerConfig(), np.zeros(3))
    clone = simulator.get_context().Clone()
    simulator.AdvanceTo(10.05)  # the replan at 10 s adds a record
    assert [r["kind"] for r in controller.plan_records(simulator.get_context())] == [
        "initial",
        "replan",
    ]
    assert [r["kind"] for r in controller.plan_records(clone)] == ["initial"]


def test_an_initial_plan_the_checker_rejects_is_not_flown(monkeypatch):
    """A negative terminal tolerance makes every plan fail the check: the planner's success is
    not accepted, the status says why, and the safe fallback (zero wrench) applies."""
    monkeypatch.setitem(plan_check.DEFAULT_TOLERANCES, "terminal_position_excess_m", -1.0)
    controller, simulator = _initialised(SoftCaptureControllerConfig(), np.zeros(3))
    simulator.AdvanceTo(0.35)
    context = simulator.get_context()
    (record,) = controller.plan_records(context)
    assert record["status"] == "check_failed" and not record["accepted"]
    assert record["check_passed"] is False
    assert list(record["check_violations"]) == ["terminal_position_excess_m"]
    assert "terminal_position_excess_m" in record["reason"]
    code = int(controller.GetOutputPort("planner_status").Eval(context)[0])
    assert PLANNER_STATUSES[code] == "check_failed"
    assert controller.GetOutputPort("controller_mode").Eval(context)[0] == MODE_FALLBACK
    np.testing.assert_array_equal(controller.GetOutputPort("body_wrench_desired").Eval(context),
                                  np.zeros(6))  # fmt: skip
    assert controller.GetOutputPort("planned_path").Eval(context).index == 0


def test_a_replan_the_checker_rejects_keeps_the_previous_plan(monkeypatch):
    """Only the replan at t = 10 s fails the check (a dynamics residual forced above its
    tolerance): the initial plan stays active and is still tracked. The chaser is put on the
    plan's knot at 10 s, so that the replan itself succeeds."""
    reports = []

    def check_rejecting_after_the_first(*args, **kwargs):
        report = plan_check.check_plan(*args, **kwargs)
        reports.append(report)
        if len(reports) > 1:
            report.dynamics_residual = 1.0
        return report

    monkeypatch.setattr(checked_plan, "check_plan", check_rejecting_after_the_first)
    controller, simulator = _initialised(SoftCaptureControllerConfig(), np.zeros(3))
    simulator.AdvanceTo(9.95)
    context = simulator.get_context()
    knot_10 = controller.plan_records(context)[0]["x"][10]
    sensed = controller.GetInputPort("sensed").Eval(context).copy()
    sensed[0:6] = knot_10  # relative_state_L
    controller.GetInputPort("sensed").FixValue(context, sensed)
    simulator.AdvanceTo(10.05)
    initial, replan = controller.plan_records(context)
    assert initial["accepted"] and initial["check_passed"] is True
    assert replan["kind"] == "replan" and replan["t_s"] == pytest.approx(10.0)
    assert replan["status"] == "check_failed" and not replan["accepted"]
    assert replan["check_violations"] == {"dynamics_residual": 1.0}
    assert controller.GetOutputPort("planned_path").Eval(context).index == 1
    assert controller.GetOutputPort("controller_mode").Eval(context)[0] != MODE_FALLBACK


def test_the_attitude_law_feeds_forward_the_line_of_sight_acceleration():
    """With attitude_feedforward the torque gains exactly J a_des: the inertial derivative of the
    pointing law's rate w_IL + p x v / |p|^2 along the reference motion (the plan's force plus
    the CW terms), taken here by a central difference instead of the controller's closed form.
    Without it, a fast tumble's final seconds lag (soft_capture_250 sample 61: 2.5 deg of pointing
    error at the final knot and no capture; tests/scenarios/test_run_soft_capture.py)."""
    w_IT_T = np.radians([2.0, -3.0, 1.5])
    wrenches = {}
    for feedforward in (False, True):
        config = SoftCaptureControllerConfig(attitude_feedforward=feedforward)
        controller, simulator = _initialised(config, w_IT_T)
        context = simulator.get_context()
        wrenches[feedforward] = controller.GetOutputPort("body_wrench_desired").Eval(context)
        u_L = controller.GetOutputPort("force_feedforward_L").Eval(context)
    # The force is the same; only the torque changes.
    np.testing.assert_allclose(wrenches[True][3:], wrenches[False][3:], rtol=0, atol=1e-9)

    x0, q_LC, n = _start()  # L = I at t0, so R_IC = R_LC
    p, v = x0[:3], x0[3:]
    a = u_L / config.planner.chaser_mass_kg + np.array(
        [3 * n * n * p[0] + 2 * n * v[1], -2 * n * v[0], -n * n * p[2]]
    )

    def line_of_sight_rate(h):
        p_h, v_h = p + v * h + 0.5 * a * h * h, v + a * h
        return np.cross(p_h, v_h) / (p_h @ p_h)

    h = 1e-3
    w_dot_L = (line_of_sight_rate(h) - line_of_sight_rate(-h)) / (2 * h)
    alpha_L = w_dot_L + np.cross([0.0, 0.0, n], line_of_sight_rate(0.0))
    from pydrake.common.eigen_geometry import Quaternion
    from pydrake.math import RotationMatrix

    R_LC = RotationMatrix(Quaternion(q_LC)).matrix()
    expected = J_CHASER @ (R_LC.T @ alpha_L)
    assert np.linalg.norm(expected) > 1e-3  # the reference turns: a real check
    np.testing.assert_allclose(
        wrenches[True][:3] - wrenches[False][:3], expected, rtol=1e-5, atol=1e-8
    )
