"""Paper 003's plan, made once at start, and the reference flown from it.

Owns: `plan_scenario` (the plan from what the controller senses at t = 0, no simulation: the
same call the closed loop makes, with `check_plan` on a success) and `make_run`, which plans
and builds the tracker's reference into a `PlanarApproachRun` (the tracker holds it:
`PlanarApproachRun.to_fly`).
Does not own: the planner and its checker (rpod.planners.planar_approach,
rpod.planners.planar_approach_check) or the references' shapes (reference.py).

When it plans. Once, at t = 0, in the tracker's initialization event, from the sensed bundle
it reads then (rpod.diagrams.controller_seam, "Planning once at start": the estimate under
`navigation: !Ekf`; under `!Truth` the scenario's start, bit for bit); `rpod plan` makes the
same call on the truth's bundle at t = 0. The plan's wall time is in the summary
(`planar_plan_solve_time_s`) and, as soft capture's, in the run's wall time. A plan that is
not a success is a status, never an exception: the tracker then holds the chaser's start pose
(position and heading at rest), the run goes on (with `stop.at_plan_end` it ends
`stop.hold_s` after t = 0) and the mission fails with the planner's own word.
"""

import copy
import dataclasses
import math

import numpy as np
from pydrake.trajectories import PiecewisePolynomial

from rpod.diagrams.builder import sensed_at_start
from rpod.diagrams.controllers.planar_approach.config import HOLD_FORCE_SHARE
from rpod.diagrams.controllers.planar_approach.problem import PlanarStart, planner_config
from rpod.diagrams.controllers.planar_approach.reference import (
    co_rotating_hold,
    face_aligned_reference,
    hold_force_ratio,
)
from rpod.planners.planar_approach import PlanarApproachConfig, PlanarPlan, plan_approach
from rpod.planners.planar_approach_check import check_plan
from rpod.systems.plan_at_start import PlannedPath
from rpod.systems.planar_tracking import PlanarReference
from rpod.systems.sensed import Sensed


@dataclasses.dataclass
class PlanarApproachRun:
    """What one run plans and flies, held by the tracker (`to_fly`), read back by the plug-in.

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

    def to_fly(self) -> PlanarReference:
        """The tracker's reference, its feed-forward and release, the planned path (drawn)
        and this run (read back by the plug-in: `PlanarTrackingController.reference`)."""
        path = PlannedPath()
        if self.plan.flyable:
            knots = self.plan.x_knots[:, :2]
            path = PlannedPath(1, 0.0, np.column_stack([knots, np.zeros(len(knots))]))
        return PlanarReference(
            self.reference, self.feedforward, self.release_time_s, path=path, plan=self
        )


def plan_scenario(
    scenario, start: PlanarStart | None = None
) -> tuple[PlanarApproachConfig, np.ndarray, PlanarPlan, dict | None]:
    """(planner config, x0, plan, check report or None): the plan from `start`, what the
    controller sensed at t = 0 (None: the bundle the truth gives then, `sensed_at_start`: what
    `rpod plan` plans from), no simulation; check_plan on a success."""
    if start is None:
        start = PlanarStart.from_sensed(Sensed.from_vector(sensed_at_start(scenario)))
    config = planner_config(scenario, start)
    plan = plan_approach(config, start.x0)
    return config, start.x0, plan, check_plan(plan, config) if plan.flyable else None


def make_run(scenario, start: PlanarStart | None = None) -> PlanarApproachRun:
    """Plans from `start` (as `plan_scenario`) and builds the reference (module docstring:
    after the plan, on failure)."""
    config, x0, plan, check = plan_scenario(scenario, start)
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
