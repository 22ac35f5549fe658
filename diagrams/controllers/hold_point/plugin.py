"""The hold-point controller as a plug-in: how the law is added to a diagram, and its results.

Owns: `HoldPointPlugin`: the law (rpod.systems.hold_point_controller) added to the diagram on
path 1 (body wrench -> allocator -> PWM -> thrusters), the outputs it logs, and its results
(metrics.py). Does not own: the config (config.py), the law itself, or its metrics.
"""

import numpy as np

from rpod.diagrams.controller_seam import (
    ControllerPlugin,
    ControllerResults,
    ControllerWiring,
)
from rpod.diagrams.controllers.hold_point.config import HoldPoint
from rpod.diagrams.controllers.hold_point.metrics import hold_results
from rpod.diagrams.scenario import ScenarioError, docking_geometry
from rpod.systems.hold_point_controller import HoldPointController
from rpod.systems.sensed import SENSED_PORT


class HoldPointPlugin(ControllerPlugin):
    """Plug-in of rpod.systems.hold_point_controller.HoldPointController."""

    config_type = HoldPoint
    system_name = "hold_point_controller"

    def validate(self, config, scenario) -> None:
        """The config's bounds, and a capture axis to point: chaser.capture_point_C non-zero."""
        super().validate(config, scenario)
        if not np.linalg.norm(scenario.chaser.capture_point_C) > 1e-9:
            raise ScenarioError(
                "chaser.capture_point_C",
                "the hold-point law points the capture axis (the capture point's direction) at "
                "the target: it must not be the zero vector",
            )

    def add_to_diagram(self, builder, scenario, sensed) -> ControllerWiring:
        config = scenario.controller
        controller = builder.AddNamedSystem(
            self.system_name,
            HoldPointController(
                config,
                scenario.chaser.mass_kg,
                np.asarray(scenario.chaser.inertia_kg_m2, float),
                docking_geometry(scenario),
                scenario.chaser.capture_point_C,
            ),
        )
        builder.Connect(sensed, controller.GetInputPort(SENSED_PORT))
        command = controller.GetOutputPort("body_wrench_desired")
        logged = {
            name: controller.GetOutputPort(name)
            for name in ("body_wrench_desired", "hold_point_L", "reference_L")
        }
        return ControllerWiring(controller, command, logged, step_timer=controller.step_timer)

    def results(self, scenario, wiring, context, log) -> ControllerResults:
        summary, outcome = hold_results(log)
        return ControllerResults(summary=summary, outcome=outcome)
