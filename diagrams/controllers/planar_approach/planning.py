"""Paper 003's plan, made when the diagram is built, and the reference flown from it.

Owns: `plan_scenario` (the plan from the scenario's initial state, no simulation: the same call
the closed loop makes, with `check_plan` on a success) and `make_run`, which plans and builds
the tracker's reference into a `PlanarApproachRun` (the plug-in keeps it in its wiring).
Does not own: the planner and its checker (rpod.planners.planar_approach,
rpod.planners.planar_approach_check) or the references' shapes (reference.py).

When it plans. Once, in `add_to_diagram`, from the scenario's initial state (the same call as
`plan_scenario`); the plan's wall time is in the summary (`planar_plan_solve_time_s`), not in
the run's wall time. A plan that is not a success is a status, never an exception: the
tracker then holds the chaser's start pose (position and heading at rest), the run goes on
(with `stop.at_plan_end` it ends `stop.hold_s` after t = 0) and the mission fails with the
planner's own word.
"""

import copy
import dataclasses
import math

import numpy as np
from pydrake.trajectories import PiecewisePolynomial

from rpod.diagrams.controllers.planar_approach.config import HOLD_FORCE_SHARE
from rpod.diagrams.controllers.planar_approach.problem import (
    initial_planar_state,
    planner_config,
)
from rpod.diagrams.controllers.planar_approach.reference import (
    co_rotating_hold,
    face_aligned_reference,
    hold_force_ratio,
)
from rpod.planners.planar_approach import PlanarApproachConfig, PlanarPlan, plan_approach
from rpod.planners.planar_approach_check import check_plan


@dataclasses.dataclass
class PlanarApproachRun:
    """What one run plans and flies, kept in the plug-in's wiring (`PlanarWiring.run`).

    Attributes:
        config: The planner's full config (settings and derived problem data).
        plan: The planner's answer.
        check: `check_plan`'s report of a successful plan (None otherwise).
        reference: The tracker's reference x_ref(t) (6 x 1).
        feedforward: Its feed-forward wrench in L (3 x 1), or None.
        x0: The start state.
        after_plan: What is flown after the arrival: 'co_rotate', 'rest' or 'release' ('auto'
            resolved).
    """

    config: PlanarApproachConfig
    plan: PlanarPlan
    check: dict | None
    reference: PiecewisePolynomial
    feedforward: PiecewisePolynomial | None
    x0: np.ndarray
    after_plan: str = "co_rotate"

    @property
    def release_time_s(self) -> float | None:
        """When the tracker stops commanding (the arrival, with 'release'), else None."""
        return self.arrival_s if self.after_plan == "release" else None

    @property
    def arrival_s(self) -> float:
        """The planned arrival T (nan without a plan)."""
        return float(self.plan.duration_s) if self.plan.flyable else math.nan


def plan_scenario(scenario) -> tuple[PlanarApproachConfig, np.ndarray, PlanarPlan, dict | None]:
    """(planner config, x0, plan, check report or None): the plan from the scenario's initial
    state, no simulation (what the closed loop plans; check_plan on a success)."""
    config = planner_config(scenario)
    x0 = initial_planar_state(scenario)
    plan = plan_approach(config, x0)
    return config, x0, plan, check_plan(plan, config) if plan.flyable else None


def make_run(scenario) -> PlanarApproachRun:
    """Plans and builds the reference (module docstring: after the plan, on failure)."""
    config, x0, plan, check = plan_scenario(scenario)
    block = scenario.controller
    feedforward = None
    if not plan.flyable:  # hold the start pose, at rest
        hold = np.concatenate([x0[:3], np.zeros(3)])
        reference = PiecewisePolynomial.FirstOrderHold([0.0, 1.0], np.column_stack([hold, hold]))
        return PlanarApproachRun(config, plan, check, reference, None, x0, "rest")
    T = float(plan.duration_s)
    after_plan = block.after_plan
    if after_plan == "auto":
        after_plan = (
            "co_rotate" if hold_force_ratio(plan, config) <= HOLD_FORCE_SHARE else "release"
        )
    if block.attitude_reference == "face_aligned":
        reference = face_aligned_reference(plan, config, block.align_time_s)
    else:
        reference = copy.copy(plan.x_traj)  # a copy: the plan's own trajectory is left as is
    if block.feedforward:
        feedforward = copy.copy(plan.wrench_traj)  # held on each step over [0, T]
    hold_s = max(scenario.duration_s - T, 0.0)
    if after_plan == "co_rotate" and hold_s > 0.0:
        hold = co_rotating_hold(plan.x_knots[-1], T, config.omega_target_rad_s, hold_s)
        reference.ConcatenateInTime(hold)
        if feedforward is not None:  # the centripetal force m omega^2 (-p), no torque
            p = hold.vector_values(hold.get_segment_times())[:2]
            force = -config.chaser_mass_kg * config.omega_target_rad_s**2 * p
            wrench = np.vstack([force, np.zeros(force.shape[1])])
            feedforward.ConcatenateInTime(
                PiecewisePolynomial.FirstOrderHold(hold.get_segment_times(), wrench)
            )
    return PlanarApproachRun(config, plan, check, reference, feedforward, x0, after_plan)
