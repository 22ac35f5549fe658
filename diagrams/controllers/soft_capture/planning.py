"""Paper 000's soft capture planned from the scenario's initial state, no simulation.

Owns: `plan_scenario` and its `ScenarioPlan` (what `rpod plan` writes, through the plug-in's
`make_plan`): the same predict-plan-check path as the closed loop's
(rpod.planners.checked_plan).
Does not own: the planner (rpod.planners.soft_capture), the plan file (rpod.scenarios.plan) or
its figures (plan_figures.py).
"""

import dataclasses

import numpy as np

from rpod.diagrams.controllers.soft_capture.problem import controller_config
from rpod.diagrams.scenario import (
    body_polytopes,
    chaser_rotation_in_lvlh,
    initial_relative_state_L,
    target_rotation_in_lvlh,
)
from rpod.models.frames import quaternion_wxyz
from rpod.planners.checked_plan import CheckedPlan, predict_plan_check
from rpod.planners.soft_capture import SoftCaptureConfig, SoftCapturePlanner


@dataclasses.dataclass
class ScenarioPlan:
    """A plan and everything it was made from.

    Attributes:
        checked: the predict-plan-check result (rpod.planners.checked_plan): the status, the
            plan, the prediction it was planned against and the checker's report.
        config: The ``SoftCaptureConfig`` it was planned with.
        x0: Initial state (6,) [m, m/s].
        chaser_hull: Chaser ``ConvexPolytope`` (C).
        target_hull: Target ``ConvexPolytope`` (T).
    """

    checked: CheckedPlan
    config: SoftCaptureConfig
    x0: np.ndarray
    chaser_hull: object
    target_hull: object

    @property
    def plan(self):
        """The planner's ``SoftCapturePlan``."""
        return self.checked.plan

    @property
    def prediction(self):
        """The ``TargetPrediction`` it was planned against."""
        return self.checked.prediction

    @property
    def wall_time_s(self) -> float:
        """Prediction + planning wall time [s]."""
        return self.checked.wall_time_s


def plan_scenario(scenario, closed_loop: bool = False) -> ScenarioPlan:
    """Plans the scenario's soft capture from its initial state, no simulation (`rpod plan`).

    The same predict-plan-check path as the closed loop's (rpod.planners.checked_plan), with
    the planner's config as the scenario gives it (settings as written, problem data derived);
    `closed_loop` plans what the closed loop's first plan is: eps_p, eps_v scaled by
    plan_tolerance_fraction and the hulls by 1 + collision_margin. An unsuccessful plan of
    N >= 2 knots is checked too (for diagnosis).
    """
    block = controller_config(scenario)
    config = block.planning_config() if closed_loop else block.planner
    target = scenario.target
    chaser_hull, target_hull = body_polytopes(scenario)
    if closed_loop:
        chaser_hull, target_hull = block.planning_hulls(chaser_hull, target_hull)
    x0 = np.concatenate(initial_relative_state_L(scenario))
    checked = predict_plan_check(
        SoftCapturePlanner(config, chaser_hull, target_hull),
        x0,
        quaternion_wxyz(target_rotation_in_lvlh(scenario)),
        np.radians(np.asarray(target.w_IT_T_deg_s, float)),
        np.asarray(target.inertia_kg_m2, float),
        R_LC0=chaser_rotation_in_lvlh(scenario),
        check_unsuccessful=True,
    )
    return ScenarioPlan(checked, config, x0, chaser_hull, target_hull)
