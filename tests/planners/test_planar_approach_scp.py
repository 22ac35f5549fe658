"""Paper 003's approach planner, method "scp" (rpod.planners.planar_approach_scp): an
infeasible attitude QP and a start inside the target as statuses, and the box wrench limit
planned within its box and checked by the independent checker."""

import dataclasses

import numpy as np

from rpod.planners.planar_approach import PlanarApproachConfig, PlanarPlanStatus, plan_approach
from rpod.planners.planar_approach_check import check_plan

X0 = np.array([1.0, 0.0, 0.0, 0.0, 0.0, 0.0])  # Sec. V-A: (1.0, 0.0) m, at rest


def test_too_little_thrust_is_a_status_not_an_exception():
    # 1e-5 N m cannot turn 10 kg m^2 / 66 by 135 deg in 23.6 s: the attitude QP is infeasible.
    config = PlanarApproachConfig(max_force_N=1e-4, max_torque_Nm=1e-5, max_duration_candidates=1)
    plan = plan_approach(config, X0)
    assert plan.status == PlanarPlanStatus.INFEASIBLE and not plan.success
    assert "Clarabel" in plan.solver_message and "Infeasible" in plan.solver_message
    assert plan.x_traj is None and plan.wrench_traj is None
    assert check_plan(plan, config)["passed"] is False


def test_a_start_inside_the_target_is_infeasible():
    config = PlanarApproachConfig(max_duration_candidates=1)
    plan = plan_approach(config, [0.2, 0.05, 0.0, 0.0, 0.0, 0.0])
    assert plan.status == PlanarPlanStatus.INFEASIBLE
    assert "slack" in plan.solver_message


def test_the_box_limit_plans_within_its_box():
    config = PlanarApproachConfig(
        wrench_limit="box", max_force_N=0.06, max_torque_Nm=0.018, max_duration_candidates=1
    )
    plan = plan_approach(config, X0)
    # A tenth of the force cannot reach the goal in the first candidate: the plan ends 0.164 m
    # from it (measured), GOAL_MISSED and not a success, but within its box and the KOS.
    assert plan.status == PlanarPlanStatus.GOAL_MISSED and not plan.success and plan.flyable
    assert plan.terminal_position_error_m > config.goal_tolerance_m
    assert f"ends {plan.terminal_position_error_m:.3f} m from the goal" in plan.solver_message
    report = check_plan(plan, config)
    assert report["passed"] and report["force_excess_N"] <= 1e-6
    # The status is the tolerance's alone: the same plan is a success at 0.2 m.
    looser = dataclasses.replace(config, goal_tolerance_m=0.2)
    assert plan_approach(looser, X0).success
