"""Paper 000's soft capture planned from the scenario's initial state, no simulation.

Owns: `plan_scenario` and its `ScenarioPlan` (what `rpod plan` writes, through the plug-in's
`make_plan`): the closed loop's own predict-plan-check call on the bundle it reads at t = 0
(rpod.diagrams.controller_seam, "Planning once at start").
Does not own: the planner (rpod.planners.soft_capture), the plan file (rpod.scenarios.plan) or
its figures (plan_figures.py).
"""

import dataclasses

import numpy as np

from rpod.diagrams.builder import sensed_at_start
from rpod.diagrams.controllers.soft_capture.problem import controller_config
from rpod.diagrams.scenario import body_polytopes
from rpod.planners.checked_plan import CheckedPlan
from rpod.planners.soft_capture import SoftCaptureConfig, SoftCapturePlanner
from rpod.systems.sensed import Sensed
from rpod.systems.soft_capture_controller import plan_from_sensed


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

    The closed loop's own call (`plan_from_sensed`) on the bundle the truth gives at t = 0
    (`sensed_at_start`), with the planner's config as the scenario gives it (settings as
    written, problem data derived); `closed_loop` plans with the closed loop's margins (eps_p,
    eps_v scaled by plan_tolerance_fraction, the hulls by 1 + collision_margin): the truth-fed
    closed loop's first plan, bit for bit. An unsuccessful plan of N >= 2 knots is checked too
    (for diagnosis).
    """
    block = controller_config(scenario)
    config = block.planning_config() if closed_loop else block.planner
    chaser_hull, target_hull = body_polytopes(scenario)
    if closed_loop:
        chaser_hull, target_hull = block.planning_hulls(chaser_hull, target_hull)
    sensed = Sensed.from_vector(sensed_at_start(scenario))
    checked = plan_from_sensed(
        SoftCapturePlanner(config, chaser_hull, target_hull),
        np.asarray(scenario.target.inertia_kg_m2, float),
        sensed,
        check_unsuccessful=True,
    )
    x0 = sensed.relative_state_L.copy()
    return ScenarioPlan(checked, config, x0, chaser_hull, target_hull)
