"""Tests for rpod.planners.plan_check: it must agree with independent truths and catch faults."""

import dataclasses

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from rpod.models.collision import ScalingMetricProgram
from rpod.models.cw import cw_state_transition, passively_safe_state
from rpod.models.shapes import soft_capture_chaser_hull, soft_capture_target_hull
from rpod.planners.plan_check import check_plan, scaling_alpha_lp
from rpod.planners.soft_capture import SoftCaptureConfig, SoftCapturePlanner, predict_for_planner

CONFIG = SoftCaptureConfig()
INERTIA_KG_M2 = np.array(
    [[5.89056, 0.0, 0.0], [0.0, 11.4462, 0.233516], [0.0, 0.233516, 11.5365]]
)  # paper 000 eq. (27)


@pytest.fixture(scope="module")
def good():
    """A successful Problem 2 plan (N = 40), its prediction and its start."""
    q0, w0 = [-0.962044, 0.074495, -0.205985, -0.162765], [0.008029, 0.005105, -0.001452]
    x0 = passively_safe_state(CONFIG.mean_motion, -16.4086, 0.006278, 11.6680, -0.014908)
    prediction = predict_for_planner(CONFIG, q0, w0, INERTIA_KG_M2)
    plan = SoftCapturePlanner(CONFIG).plan(x0, prediction, horizons=[40])
    assert plan.status == "success", plan.reason
    return plan, prediction, x0


def test_good_plan_passes(good):
    plan, prediction, x0 = good
    report = check_plan(plan, CONFIG, prediction, x0=x0)
    assert report.passed(), report.violations()
    assert report.dynamics_residual < 1e-8  # expm vs the planner's closed form + solver


def test_dynamics_by_expm_agree_with_the_closed_form_cw_solution(good):
    # A coasting "plan" propagated with rpod.models.cw's closed-form transition: the checker's
    # expm discretisation must see it as exact (two independent derivations, ~1e-12).
    plan, prediction, x0 = good
    Phi = cw_state_transition(CONFIG.mean_motion, CONFIG.dt_s)
    x = [x0]
    for _ in range(plan.N - 1):
        x.append(Phi @ x[-1])
    coast = dataclasses.replace(plan, x=np.array(x), u=np.zeros_like(plan.u))
    report = check_plan(coast, CONFIG, prediction, x0=x0)
    assert report.dynamics_residual < 1e-10


@pytest.mark.parametrize(
    "fault, field",
    [
        ("thrust_kick", "dynamics_residual"),
        ("thrust_too_large", "thrust_excess_N"),
        ("miss_the_capture_point", "terminal_position_excess_m"),
        ("wrong_alpha", "alpha_mismatch"),
        ("capture_axis_off_target", "pointing_error_rad"),
        ("wrong_start", "initial_state_error"),
        ("stale_prediction", "prediction_mismatch"),
    ],
)
def test_faults_are_caught(good, fault, field):
    plan, prediction, x0 = good
    x, u = plan.x.copy(), plan.u.copy()
    q_LC, alpha, q_LT = plan.q_LC.copy(), plan.alpha.copy(), plan.q_LT.copy()
    if fault == "thrust_kick":
        u[5] += [5.0, 0.0, 0.0]
    elif fault == "thrust_too_large":
        u[3] = [0.0, 0.0, 1.01 * CONFIG.max_thrust_N]
    elif fault == "miss_the_capture_point":
        x[-1, :3] += [0.0, 0.5, 0.0]
    elif fault == "wrong_alpha":
        alpha[7] += 0.01
    elif fault == "capture_axis_off_target":
        q_LC[9] = Rotation.from_rotvec([0.0, 0.01, 0.0]).as_quat()[[3, 0, 1, 2]]
    elif fault == "wrong_start":
        x0 = x0 + np.array([0.1, 0.0, 0.0, 0.0, 0.0, 0.0])
    elif fault == "stale_prediction":
        q_LT[-1] = q_LT[0]
    faulty = dataclasses.replace(plan, x=x, u=u, q_LC=q_LC, alpha=alpha, q_LT=q_LT)
    violations = check_plan(faulty, CONFIG, prediction, x0=x0).violations()
    assert field in violations, violations


def test_true_line_of_sight_angle_is_measured(good):
    # Turn knot 20 about the target so that the step into it is 0.25 rad; the checker must
    # report the nonlinear angle's excess over omega_max dt = 0.2 rad.
    plan, prediction, _ = good
    x = plan.x.copy()
    r19, r20 = x[19, :3], x[20, :3]
    axis = np.cross(r19, r20) / np.linalg.norm(np.cross(r19, r20))
    turn = 0.25 - np.arctan2(np.linalg.norm(np.cross(r19, r20)), r19 @ r20)
    x[20, :3] = Rotation.from_rotvec(turn * axis).apply(r20)
    report = check_plan(dataclasses.replace(plan, x=x), CONFIG, prediction)
    assert report.los_angle_excess_rad == pytest.approx(0.05, abs=1e-12)


@pytest.mark.parametrize("half_angle_deg, inside", [(29.9, True), (30.1, False)])
def test_docking_cone_is_measured_in_the_target_body_frame(good, half_angle_deg, inside):
    # Place the last knot 3 m from the target capture point at a chosen angle off the cone axis
    # in T, along T's x axis, and express it in L through the predicted attitude.
    plan, prediction, _ = good
    R_N = prediction.R_LT(prediction.t[plan.N - 1])
    beta = np.radians(half_angle_deg)
    Y = 3.0 * np.array([np.sin(beta), 0.0, np.cos(beta)])  # chaser from D_t, in T
    x = plan.x.copy()
    x[-1, :3] = R_N @ (np.array(CONFIG.p_TDt_T) + Y)
    report = check_plan(dataclasses.replace(plan, x=x), CONFIG, prediction)
    # Excess = |lateral| - tan(30 deg) axial = 3 (sin(beta) - tan(30 deg) cos(beta)).
    expected = 3.0 * (np.sin(beta) - np.tan(np.radians(30.0)) * np.cos(beta))
    assert report.docking_cone_excess_m == pytest.approx(expected, abs=1e-12)
    assert (report.docking_cone_excess_m <= 0.0) == inside


def test_alpha_lp_matches_the_drake_metric_and_a_closed_form():
    chaser, target = soft_capture_chaser_hull(), soft_capture_target_hull()
    # Capture pose on the axis: the z faces (1.2099 and 1.2 m from the origins) touch when
    # alpha (1.2099 + 1.2) = 5.4 m.
    R_capture = np.diag([-1.0, 1.0, -1.0])
    alpha = scaling_alpha_lp(chaser.A, chaser.b, R_capture, np.array([0.0, 0.0, 5.4]),
                             target.A, target.b, np.eye(3), np.zeros(3))  # fmt: skip
    assert alpha == pytest.approx(5.4 / 2.4099, rel=1e-9)  # HiGHS default tolerances ~1e-9
    metric = ScalingMetricProgram(chaser, target)
    rng = np.random.default_rng(5)
    for _ in range(50):
        R_c, R_t = Rotation.random(2, random_state=rng).as_matrix()
        p_c = rng.normal(size=3) * rng.uniform(2.0, 20.0)
        reference = metric.evaluate(R_c, p_c, R_t, np.zeros(3))
        independent = scaling_alpha_lp(chaser.A, chaser.b, R_c, p_c,
                                       target.A, target.b, R_t, np.zeros(3))  # fmt: skip
        assert independent == pytest.approx(reference.alpha, rel=1e-9)
