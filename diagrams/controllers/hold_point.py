"""The hold-point controller as a plug-in: `controller: !HoldPoint {...}`.

Owns: the `HoldPoint` config type (the YAML tag), how the law (rpod.systems.hold_point_controller)
is added to a diagram (path 1: body wrench -> allocator -> PWM -> thrusters), and its results:
the hold errors, when the hold was reached, and the mission outcome.
Does not own: the law itself (systems/hold_point_controller.py).

Mission: the chaser holds the point `hold_distance_m` beyond the docking port, synchronised
with the tumble, to HOLD_POSITION_TOLERANCE_M and HOLD_SPEED_TOLERANCE_M_S at the end of the
run. `hold_reached_time_s` is the first log sample from which both hold at every later sample.
"""

import dataclasses

import numpy as np

from rpod.diagrams.controller_seam import (
    Actuation,
    ControllerPlugin,
    ControllerResults,
    ControllerWiring,
    MissionOutcome,
    register_controller,
)
from rpod.diagrams.scenario import docking_geometry
from rpod.models.frames import rotations_from_wxyz
from rpod.systems.hold_point_controller import HoldPointController, HoldPointControllerConfig
from rpod.systems.sensed import SENSED_PORT

HOLD_POSITION_TOLERANCE_M = 0.5  # "reached its hold point": within this of H ...
HOLD_SPEED_TOLERANCE_M_S = 0.02  # ... and moving with it to within this.


@dataclasses.dataclass
class HoldPoint(HoldPointControllerConfig):
    """Fly to and hold a point on the target's rotating docking axis (fields: see the base)."""


def hold_errors(log: dict) -> tuple[np.ndarray, np.ndarray]:
    """(position error [m], speed error [m/s]) to the logged hold point H at every sample.

    The speed error is against H's own velocity in L, w_LT x p_LH (H is fixed in T).
    """
    p_H = log["hold_point_L"]
    R_IL = rotations_from_wxyz(log["q_IL"])
    R_IT = rotations_from_wxyz(log["q_IT"])
    R_LT = np.transpose(R_IL, (0, 2, 1)) @ R_IT
    w_LT_L = np.einsum("nij,nj->ni", R_LT, log["w_IT_T"]) - log["w_IL_L"]
    position = np.linalg.norm(log["p_LC_L"] - p_H, axis=1)
    speed = np.linalg.norm(log["v_LC_L"] - np.cross(w_LT_L, p_H), axis=1)
    return position, speed


class HoldPointPlugin(ControllerPlugin):
    """Plug-in of rpod.systems.hold_point_controller.HoldPointController."""

    config_type = HoldPoint
    system_name = "hold_point_controller"

    def add_to_diagram(self, builder, scenario, sensed) -> ControllerWiring:
        config = scenario.controller
        controller = builder.AddNamedSystem(
            self.system_name,
            HoldPointController(
                config,
                scenario.chaser.mass_kg,
                np.asarray(scenario.chaser.inertia_kg_m2, float),
                docking_geometry(scenario),
            ),
        )
        builder.Connect(sensed, controller.GetInputPort(SENSED_PORT))
        command = controller.GetOutputPort("body_wrench_desired")
        logged = {
            name: controller.GetOutputPort(name)
            for name in ("body_wrench_desired", "hold_point_L", "reference_L")
        }
        return ControllerWiring(
            controller, Actuation.BODY_WRENCH, command, config.control_period_s, logged
        )

    def results(self, scenario, wiring, context, log) -> ControllerResults:
        position, speed = hold_errors(log)
        within = (position < HOLD_POSITION_TOLERANCE_M) & (speed < HOLD_SPEED_TOLERANCE_M_S)
        reached = bool(within[-1])
        # The first sample of the final run of samples inside the tolerances.
        outside = np.flatnonzero(~within)
        first = 0 if not len(outside) else int(outside[-1]) + 1
        reached_at = float(log["t"][first]) if reached else float("nan")
        summary = {
            "final_hold_error_m": float(position[-1]),
            "final_hold_speed_error_m_s": float(speed[-1]),
            "hold_reached": reached,
            "hold_reached_time_s": reached_at if reached else None,
        }
        if reached:
            text = (
                f"hold point reached at {reached_at:.1f} s, held to {position[-1]:.3f} m and "
                f"{speed[-1]:.4f} m/s"
            )
        else:
            text = (
                f"hold point NOT reached: at the end {position[-1]:.3f} m (tolerance "
                f"{HOLD_POSITION_TOLERANCE_M} m) and {speed[-1]:.4f} m/s (tolerance "
                f"{HOLD_SPEED_TOLERANCE_M_S} m/s) from it"
            )
        return ControllerResults(summary=summary, outcome=MissionOutcome(reached, text))


register_controller(HoldPointPlugin(), default=True)
