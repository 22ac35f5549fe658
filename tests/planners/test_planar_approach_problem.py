"""Paper 003's approach problem (rpod.planners.planar_approach_problem): the spiral guess
against eq. 7, the terminal relative-velocity term (5') against the paper's eq. 5, and the
paper's position-only KOS switch against rpod's heading condition, each plan checked by the
independent checker."""

import numpy as np

from rpod.planners.planar_approach import PlanarApproachConfig, plan_approach
from rpod.planners.planar_approach_check import check_plan
from rpod.planners.planar_approach_problem import initial_guess

X0 = np.array([1.0, 0.0, 0.0, 0.0, 0.0, 0.0])  # Sec. V-A: (1.0, 0.0) m, at rest


def test_the_guess_satisfies_eq_7_and_starts_at_x0():
    config = PlanarApproachConfig()
    X, U = initial_guess(config, X0, 20.0)
    assert X.shape == (201, 6) and U.shape == (200, 3)
    dt = 0.1
    accel = U / np.array([10.0, 10.0, 0.15])
    np.testing.assert_allclose(
        X[1:], X[:-1] + dt * np.column_stack([X[:-1, 3:], accel]), atol=1e-12
    )
    np.testing.assert_array_equal(X[0], X0)


def test_the_terminal_velocity_term_synchronises_the_arrival():
    # The paper's eq. 5 (w_terminal_velocity = 0) against (5') on Sec. V-A's chosen duration.
    speeds = []
    for weight in (0.0, 1000.0):
        config = PlanarApproachConfig(
            w_terminal_velocity=weight, duration_min_s=80.0, max_duration_candidates=1
        )
        plan = plan_approach(config, X0)
        assert plan.success, plan.solver_message
        report = check_plan(plan, config)
        assert report["passed"], report
        speeds.append(report["terminal_relative_speed_m_s"])
        assert (plan.cost_terms["terminal_velocity"] == 0.0) == (weight == 0.0)
    assert speeds[0] > 0.01 and speeds[1] < 0.4 * speeds[0]


def test_the_papers_position_only_switch_lets_the_plan_overlap_the_target():
    # Sec. III-C as printed (State II by position alone) with eq. 5: Sec. V-A's plan is
    # feasible for its own KOS, but the true squares overlap before the arrival (the chaser
    # enters the relaxed zone still turned away from the docking face); rpod's heading
    # condition keeps them apart (test_sec_v_a_plans_and_passes_the_checker).
    config = PlanarApproachConfig(
        w_terminal_velocity=0.0,
        state_ii_heading=False,
        duration_min_s=80.0,
        max_duration_candidates=1,
    )
    plan = plan_approach(config, X0)
    assert plan.success, plan.solver_message
    report = check_plan(plan, config)
    assert report["keepout_q_m"] >= -1e-9  # its own (position-only) KOS holds
    assert report["squares_gap_m"] < -0.01  # the squares overlap by more than a centimetre
    assert not report["passed"]
