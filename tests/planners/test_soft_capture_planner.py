"""End-to-end tests of the soft-capture planner (paper 000, Problems 2 and 3 and the N search).

Every successful plan is re-checked by the independent checker (``plan_check``): dynamics by
expm, every constraint in its nonlinear form, alpha by a separate LP. Starting states are
Sec. VI-B-like: passively safe relative orbits (eq. 6) 20-45 m away, the target of eq. (27)
tumbling at 0.5-9 deg/s from a random attitude.
"""

import numpy as np
import pytest

from rpod.models.cw import passively_safe_state
from rpod.planners.plan_check import check_plan
from rpod.planners.soft_capture import (
    SoftCaptureConfig,
    SoftCapturePlanner,
    predict_for_planner,
    terminal_targets,
)

INERTIA_KG_M2 = np.array(  # paper 000 eq. (27)
    [[5.89056, 0.0, 0.0], [0.0, 11.4462, 0.233516], [0.0, 0.233516, 11.5365]]
)
CONFIG = SoftCaptureConfig()

# name: (q_LT0 (w, x, y, z), w_IT_T0 [rad/s], (x, vx, z, vz) of the safe orbit [m, m/s],
#        the horizon the search stops at, whether Problem 3 must have been needed).
CASES = {
    "slow_tumble_problem2_only": (
        [-0.962044, 0.074495, -0.205985, -0.162765], [0.008029, 0.005105, -0.001452],
        (-16.4086, 0.006278, 11.6680, -0.014908), 40, False,
    ),
    "scp_correction": (
        [-0.041975, 0.320404, 0.540486, -0.776823], [0.012007, 0.016016, 0.007744],
        (15.4931, -0.000804, 22.5507, 0.002807), 50, True,
    ),
    "fast_tumble_far_start": (
        [-0.910116, 0.001257, 0.305295, -0.280148], [-0.059647, -0.130092, 0.00789],
        (-7.5133, -0.020134, -3.0235, -0.015534), 60, True,
    ),
    "fastest_tumble": (
        [0.333195, -0.407711, 0.123328, -0.841156], [0.140645, -0.055671, 0.05295],
        (-15.1976, -0.001337, 15.1905, -0.006113), 50, False,
    ),
}  # fmt: skip


@pytest.fixture(scope="module")
def planner():
    """One planner for the module: its programs are built once per N and reused."""
    return SoftCapturePlanner(CONFIG)


def _case(name):
    q, w, (x, vx, z, vz), N, needs_scp = CASES[name]
    x0 = passively_safe_state(CONFIG.mean_motion, x, vx, z, vz)
    return x0, predict_for_planner(CONFIG, q, w, INERTIA_KG_M2), N, needs_scp


@pytest.mark.parametrize("name", list(CASES))
def test_plan_succeeds_and_passes_the_independent_checker(planner, name):
    x0, prediction, N, needs_scp = _case(name)
    plan = planner.plan(x0, prediction)

    assert plan.status == "success", plan.reason
    assert plan.N == N
    assert (plan.scp_iterations >= 1) == needs_scp
    assert len(plan.solve_time_s) == plan.scp_iterations + 1
    # One step per solve, each holding its solve (plus the data, linearisation and alpha LPs).
    assert len(plan.step_time_s) == len(plan.solve_time_s)
    assert all(step > solve for step, solve in zip(plan.step_time_s, plan.solve_time_s))
    assert plan.attempts[-1].step_time_s == plan.step_time_s
    assert plan.x.shape == (N, 6) and plan.u.shape == (N - 1, 3)
    assert plan.q_LT.shape == plan.q_LC.shape == (N, 4) and plan.alpha.shape == (N,)
    np.testing.assert_allclose(plan.t, np.arange(N) * CONFIG.dt_s)
    assert plan.min_alpha == pytest.approx(plan.alpha.min()) and plan.min_alpha > 1.0
    # The search went up the grid: every shorter horizon failed, here by Problem 2
    # infeasibility, reported with Clarabel's own word.
    assert [a.N for a in plan.attempts] == [n for n in CONFIG.horizon_grid() if n <= N]
    for attempt in plan.attempts[:-1]:
        assert attempt.status == "problem2_infeasible"
        assert "PrimalInfeasible" in attempt.reason

    report = check_plan(plan, CONFIG, prediction, x0=x0)
    assert report.violations() == {}, report.violations()
    assert report.collision_free
    # alpha_min is a soft margin: plans may end below it, never below 1.
    assert report.min_alpha > 1.0


def test_program_reuse_gives_the_plan_of_a_fresh_build(planner):
    # The module planner has already solved other data at N = 40; rewriting the data
    # (UpdateCoefficients / set_bounds) must leave no trace of them.
    x0, prediction, _, _ = _case("slow_tumble_problem2_only")
    reused = planner.plan(x0, prediction)
    fresh = SoftCapturePlanner(CONFIG).plan(x0, prediction)
    assert planner.programs(40) is planner.programs(40)
    assert reused.status == fresh.status == "success"
    # Same data, same deterministic solver: agreement to round-off (1e-9 m covers a
    # different summation order inside the solver).
    np.testing.assert_allclose(reused.x, fresh.x, atol=1e-9)
    np.testing.assert_allclose(reused.u, fresh.u, atol=1e-6)  # forces ~1e2 N


def test_tumble_above_the_method_limit_is_reported_not_raised():
    # 0.3 rad/s about T's x axis, normal to D_t: the capture point moves at 0.3 * 5.4 = 1.62
    # m/s > v_max, so no plan can meet (14) within (10).
    x0, _, _, _ = _case("slow_tumble_problem2_only")
    q0, w0 = CASES["slow_tumble_problem2_only"][0], [0.3, 0.0, 0.0]
    prediction = predict_for_planner(CONFIG, q0, w0, INERTIA_KG_M2)
    assert CONFIG.tumble_rate_limit_rad_s == pytest.approx(0.2)  # min(0.2, 1.5 / 5.4)

    early = SoftCapturePlanner(CONFIG).plan(x0, prediction)
    assert early.status == "tumble_rate_above_limit" and early.N == 0
    assert early.attempts == [] and early.x.shape == (0, 6)

    # Without the early test the solver finds it infeasible at every horizon tried.
    unchecked = SoftCaptureConfig(check_tumble_limit=False)
    plan = SoftCapturePlanner(unchecked).plan(x0, prediction, horizons=[40, 80])
    assert plan.status == "no_feasible_horizon" and not plan.success
    assert [a.N for a in plan.attempts] == [40, 80]
    assert "PrimalInfeasible" in plan.reason
    assert np.isnan(plan.min_alpha)


def test_terminal_targets_are_the_capture_pose_and_its_velocity():
    # Independent check of (13)-(14) with the turning LVLH frame: differentiate the predicted
    # capture pose p*(t) = R_LT(t) (D_t + D_c) numerically through the prediction's own
    # interpolation (cubic Hermite with the model's exact slopes at the knots).
    q0, w0 = CASES["fastest_tumble"][:2]
    prediction = predict_for_planner(CONFIG, q0, w0, INERTIA_KG_M2)
    k, h = 100, 1e-4  # an interior knot; central difference error ~h^2 |p'''| ~ 1e-10 m/s
    t = prediction.t[k]
    reach = np.array([0.0, 0.0, 5.4])  # D_t + D_c in T (Table I)
    for point, lever in [("chaser_capture_point", reach), ("chaser_center_of_mass", reach / 2)]:
        config = SoftCaptureConfig(terminal_velocity_point=point)
        p_star, v_star = terminal_targets(
            config, prediction.R_LT(t), prediction.w_IT_T[k], prediction.n_orbit
        )
        np.testing.assert_allclose(p_star, prediction.R_LT(t) @ reach, atol=1e-12)
        v_fd = (prediction.R_LT(t + h) @ lever - prediction.R_LT(t - h) @ lever) / (2 * h)
        # 1e-7 m/s: Hermite interpolation error (~3e-7 rad at 1 s spacing, module
        # target_prediction) enters only through h-symmetric terms that cancel to O(h^2).
        np.testing.assert_allclose(v_star, v_fd, atol=1e-7)


def test_config_validation_names_the_bad_field():
    with pytest.raises(ValueError, match="max_thrust_N"):
        SoftCapturePlanner(SoftCaptureConfig(max_thrust_N=-1.0))
    with pytest.raises(ValueError, match="terminal_velocity_point"):
        SoftCapturePlanner(SoftCaptureConfig(terminal_velocity_point="nose"))
    with pytest.raises(ValueError, match="alpha_min"):
        SoftCapturePlanner(SoftCaptureConfig(alpha_min=0.9))


def test_horizon_grid_covers_the_paper_range():
    assert CONFIG.horizon_grid() == list(range(40, 351, 10))
    assert SoftCaptureConfig(horizon_step=30).horizon_grid()[-2:] == [340, 350]


def test_bad_starts_are_reported_not_raised(planner):
    _, prediction, _, _ = _case("slow_tumble_problem2_only")
    nan_start = planner.plan(np.full(6, np.nan), prediction)
    assert nan_start.status == "invalid_input" and nan_start.N == 0
    # 1.4 m from the target's centre: both hulls hold a 1.2 m ball about their origins, so
    # they overlap (alpha < 1) whatever the attitudes; no horizon is tried.
    inside = planner.plan(np.array([0.9, 0.6, 0.9, 0.0, 0.0, 0.0]), prediction)
    assert inside.status == "initial_state_in_collision" and inside.attempts == []
    assert "alpha" in inside.reason


def test_config_loads_from_yaml_with_drake_typed_loader():
    from pydrake.common.yaml import yaml_load_typed

    config = yaml_load_typed(
        schema=SoftCaptureConfig,
        data="{horizon_step: 5, p_TDt_T: [0.0, 0.0, 3.0], check_tumble_limit: false}",
        defaults=SoftCaptureConfig(),
    )
    assert config.horizon_step == 5 and config.p_TDt_T == [0.0, 0.0, 3.0]
    assert not config.check_tumble_limit and config.max_thrust_N == 100.0  # default kept
    config.validate()


def test_the_socp_settings_load_from_yaml_and_an_unknown_solver_is_named():
    from pydrake.common.yaml import yaml_load_typed

    from rpod.models.config import ConfigError

    config = yaml_load_typed(
        schema=SoftCaptureConfig,
        data="{socp_solver: ecos, socp_scaled: false, socp_iterative_refinement: true}",
        defaults=SoftCaptureConfig(),
    )
    config.validate()
    assert (config.socp_solver, config.socp_scaled, config.socp_iterative_refinement) == (
        "ecos",
        False,
        True,
    )
    with pytest.raises(ConfigError, match="socp_solver"):
        SoftCaptureConfig(socp_solver="mosek").validate()
