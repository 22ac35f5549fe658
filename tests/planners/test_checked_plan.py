"""The one predict-plan-check path, the planner's status enum and the plan as pydrake
trajectories: a plan's trajectories pass through its knots, its status is a PlanStatus that
still reads as the word, and a bad measurement is a status, never an exception."""

import numpy as np
import pytest

from rpod.planners.checked_plan import predict_plan_check
from rpod.planners.soft_capture import PlanStatus, SoftCaptureConfig, SoftCapturePlanner

CONFIG = SoftCaptureConfig()
J_TARGET = np.diag([5.89056, 11.4462, 11.5365])  # paper 000 eq. (27), principal
Q_IDENTITY = [1.0, 0.0, 0.0, 0.0]


def _start() -> np.ndarray:
    """A passively safe start ~20 m away (paper 000 eq. 6: y = 2 vx / n, vy = -2 n x)."""
    n = CONFIG.mean_motion
    x, vx = -5.0, 0.0081
    return np.array([x, 2 * vx / n, 8.0, vx, -2 * n * x, 0.0])


@pytest.fixture(scope="module")
def checked():
    return predict_plan_check(
        SoftCapturePlanner(CONFIG), _start(), Q_IDENTITY, np.radians([0.0, 0.0, 2.0]), J_TARGET
    )


def test_a_planned_and_checked_start_is_accepted_with_its_report(checked):
    assert checked.accepted and checked.status is PlanStatus.SUCCESS
    assert checked.status == "success"  # a str enum: summaries and logs read the word
    assert checked.report is not None and checked.report.passed()
    assert checked.plan.N == len(checked.plan.t) and checked.check_time_s > 0.0


def test_trajectories_pass_through_the_knots_and_hold_the_force(checked):
    plan = checked.plan
    t0 = 12.0
    trajectories = plan.trajectories(t0_s=t0)
    for k in (0, plan.N // 2, plan.N - 1):
        t = t0 + plan.t[k]
        np.testing.assert_allclose(trajectories.position_L.value(t)[:, 0], plan.x[k, :3], atol=1e-9)
        np.testing.assert_allclose(
            trajectories.velocity_L.value(t)[:, 0], plan.x[k, 3:], atol=1e-12
        )
    # The force is held over each step: at mid-step it is that step's u_k.
    k = plan.N // 3
    middle = t0 + 0.5 * (plan.t[k] + plan.t[k + 1])
    np.testing.assert_allclose(trajectories.force_L.value(middle)[:, 0], plan.u[k], atol=1e-12)
    # The spline's slope at a knot is the knot's velocity (cubic Hermite).
    slope = trajectories.position_L.derivative(1).value(t0 + plan.t[k])[:, 0]
    np.testing.assert_allclose(slope, plan.x[k, 3:], atol=1e-9)


def test_a_bad_measurement_is_a_status_not_an_exception():
    result = predict_plan_check(
        SoftCapturePlanner(CONFIG), _start(), [np.nan, 0.0, 0.0, 0.0], np.zeros(3), J_TARGET
    )
    assert result.status is PlanStatus.PREDICTION_FAILED and not result.accepted
    assert result.plan is None and result.reason


def test_a_tumble_above_the_limit_is_the_planners_own_status():
    result = predict_plan_check(
        SoftCapturePlanner(CONFIG), _start(), Q_IDENTITY, np.radians([20.0, 0.0, 0.0]), J_TARGET
    )
    assert result.status is PlanStatus.TUMBLE_RATE_ABOVE_LIMIT and result.report is None
