"""Paper 000's soft capture as a plug-in: how the closed loop is checked, wired, drawn, judged.

Owns: `SoftCapturePlugin`: the checks that need the scenario (an orbit, the docking axis along
D_t, the planner's full config), the closed loop (rpod.systems.soft_capture_controller) on
path 1, the planned-path overlay of the scene, the planned end of the run, and the hooks to its
results (metrics.py), plan (planning.py, `rpod plan`) and campaign table (tables.py).
Does not own: the config (config.py), the problem data (problem.py), the planner
(rpod.planners.soft_capture), the loop (systems/) or files (scenarios/).
"""

import numpy as np

from rpod.diagrams.controller_seam import (
    ControllerPlugin,
    ControllerResults,
    ControllerWiring,
    PlanOutput,
)
from rpod.diagrams.controllers.soft_capture import tables
from rpod.diagrams.controllers.soft_capture.config import SoftCapture
from rpod.diagrams.controllers.soft_capture.metrics import soft_capture_results
from rpod.diagrams.controllers.soft_capture.plan_file import plan_output
from rpod.diagrams.controllers.soft_capture.planning import plan_scenario
from rpod.diagrams.controllers.soft_capture.problem import controller_config, planner_config
from rpod.diagrams.scenario import ScenarioError, body_polytopes
from rpod.systems.sensed import SENSED_PORT
from rpod.systems.soft_capture_controller import SoftCaptureController

LOGGED = (
    "body_wrench_desired",
    "reference_L",
    "force_feedforward_L",
    "controller_mode",
    "planner_status",
)


class SoftCapturePlugin(ControllerPlugin):
    """Plug-in of rpod.systems.soft_capture_controller.SoftCaptureController."""

    config_type = SoftCapture
    system_name = "soft_capture_controller"

    def validate(self, config, scenario) -> None:
        super().validate(config, scenario)  # the config's own checks
        if scenario.orbit.gravity == "free_space":
            raise ScenarioError(
                "orbit.gravity",
                "the soft-capture planner needs an orbit (CW model): not free_space",
            )
        D_t = np.asarray(scenario.target.docking_port_T, float)
        axis = np.asarray(scenario.target.docking_axis_T, float)
        if (
            np.linalg.norm(D_t) < 1e-12
            or np.linalg.norm(axis / np.linalg.norm(axis) - D_t / np.linalg.norm(D_t)) > 1e-9
        ):
            raise ScenarioError(
                "target.docking_axis_T",
                "paper 000's docking cone is about the direction of the docking port D_t: "
                f"docking_axis_T must be that direction, {list(map(float, D_t))}",
            )
        try:  # the settings as written, with the problem data derived from the scenario
            planner_config(scenario).validate()
        except ScenarioError as error:
            raise error.under("controller.planner") from None

    def add_to_diagram(self, builder, scenario, sensed) -> ControllerWiring:
        chaser_shape, target_shape = body_polytopes(scenario)
        controller = builder.AddNamedSystem(
            self.system_name,
            SoftCaptureController(
                controller_config(scenario),
                np.asarray(scenario.chaser.inertia_kg_m2, float),
                np.asarray(scenario.target.inertia_kg_m2, float),
                chaser_shape,
                target_shape,
            ),
        )
        builder.Connect(sensed, controller.GetInputPort(SENSED_PORT))
        return ControllerWiring(
            controller,
            controller.GetOutputPort("body_wrench_desired"),
            {name: controller.GetOutputPort(name) for name in LOGGED},
            step_timer=controller.step_timer,
        )

    def add_scene_extras(self, builder, meshcat, scenario, wiring, scene=None) -> None:
        from rpod.systems.scene import PlannedPathOverlay  # only when drawing

        overlay = builder.AddNamedSystem(
            "scene.planned_path",
            PlannedPathOverlay(meshcat, scenario.visualization.publish_period_s),
        )
        builder.Connect(
            wiring.system.GetOutputPort("planned_path"), overlay.GetInputPort("planned_path")
        )

    def planned_end_s(self, wiring, context) -> float | None:
        """The final knot of the last accepted plan (replans keep the same final time)."""
        controller = wiring.system
        records = controller.plan_records(controller.GetMyContextFromRoot(context))
        accepted = [r for r in records if r["accepted"]]
        if not accepted:
            return None
        return accepted[-1]["t_s"] + (accepted[-1]["N"] - 1) * controller.config.planner.dt_s

    def campaign_table(self, rows):
        """A soft-capture campaign beside paper 000 Sec. VI-B (tables.py)."""
        return tables.campaign_table(rows)

    @staticmethod
    def make_plan(scenario, closed_loop: bool = False) -> PlanOutput:
        """`rpod plan`: the plan from the scenario's initial state (planning.plan_scenario),
        as plan_file.plan_output writes it."""
        return plan_output(plan_scenario(scenario, closed_loop))

    def results(self, scenario, wiring, context, log) -> ControllerResults:
        """metrics.py's log additions (codes as int64, the plans' knots), summary, outcome."""
        controller = wiring.system
        records = controller.plan_records(controller.GetMyContextFromRoot(context))
        added, summary, outcome = soft_capture_results(scenario, records, log)
        return ControllerResults(summary=summary, log=added, outcome=outcome)
