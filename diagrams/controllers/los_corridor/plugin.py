"""Paper 004's guidance as a plug-in: how it is wired, drawn, judged and reported.

Owns: `LosCorridorPlugin`: the checks that need the scenario (an orbit to linearise, the PWM
period), the load-time warning of a hold point the box cannot hold, the wiring (path 3, the
ideal acceleration in L with paper 004's box |u_i| <= a_max; or, with `actuation: thrusters`,
path 1 through rpod.systems.acceleration_to_wrench, the allocator, the PWM and the thruster
bank), the drawing of the corridor in the scene, and the hooks to its results (metrics.py),
figures (figures.py, imported only when drawing) and campaign tables (tables.py).
Does not own: the config (config.py), the guidance (systems/los_guidance.py), the corridor
model (rpod.models.los_corridor) or the MPC (rpod.planners.los_corridor_mpc).
"""

import dataclasses
import math

import numpy as np

from rpod.diagrams.controller_seam import (
    Actuation,
    ControllerPlugin,
    ControllerResults,
    ControllerWiring,
    IdealCommand,
)
from rpod.diagrams.controllers.los_corridor import tables
from rpod.diagrams.controllers.los_corridor.config import THRUSTER_PERIOD_S, LosCorridor
from rpod.diagrams.controllers.los_corridor.metrics import STATUS_LOG_KEY, los_results
from rpod.diagrams.scenario import ScenarioError, body_polytopes
from rpod.models.los_corridor import (
    corridor_frame_R_TK,
    holding_range_m,
    suggested_hold_distance_m,
)
from rpod.systems.acceleration_to_wrench import AccelerationToWrench
from rpod.systems.los_guidance import LosGuidance
from rpod.systems.sensed import SENSED_PORT

LOG_SHAPES = {  # the keys the figures read (figures.py documents each)
    "los_range_m": None,
    "los_sync_range_m": None,
    "los_hold_point_T": 3,
    "los_face_distance_m": -1,  # faces 1..n_f, then the floor
    "los_command_L": 3,
    "los_nominal_L": 3,
    "los_applied_L": 3,
    "los_regime": None,
    "los_mpc_status": None,
    "los_fallback": None,
    "los_a_max_m_s2": None,
    "los_half_angle_deg": None,
    "los_R_TK": 9,
}


def guidance_geometry(config, scenario):
    """(the guidance's config, R_TK or None): with `corridor_axis: docking` the corridor's frame
    about the docking axis; with `capture` the hold distance from the target's centre at which
    the capture point is hold_distance_m beyond the port (config.py)."""
    if config.corridor_axis == "y_T":
        return config, None
    axis = np.asarray(scenario.target.docking_axis_T, dtype=float)
    axis = axis / np.linalg.norm(axis)
    R_TK = corridor_frame_R_TK(axis)
    if not config.capture:
        return config, R_TK
    port_up = float(np.asarray(scenario.target.docking_port_T, dtype=float) @ axis)
    reach = float(np.linalg.norm(scenario.chaser.capture_point_C))
    hold = port_up + config.hold_distance_m + reach
    return dataclasses.replace(config, hold_distance_m=hold, capture=False), R_TK


def _bounding_radius_sum_m(scenario) -> float:
    """The radii of the spheres about the two bodies' centres that hold their true shapes,
    added: closer than this, the bodies may touch [m]."""
    return sum(
        float(np.max(np.linalg.norm(shape.vertices, axis=1))) for shape in body_polytopes(scenario)
    )


class LosCorridorPlugin(ControllerPlugin):
    """Plug-in of rpod.systems.los_guidance.LosGuidance."""

    config_type = LosCorridor
    system_name = "los_guidance"
    actuation = Actuation.IDEAL
    log_shapes = LOG_SHAPES

    def run_figures(self) -> dict:
        """los_corridor.png and los_body_frame.png (figures.py)."""
        from rpod.diagrams.controllers.los_corridor import figures  # only when drawing

        return figures.run_figures()

    def actuation_for(self, config) -> Actuation:
        return Actuation.IDEAL if config.actuation == "ideal" else Actuation.BODY_WRENCH

    def validate(self, config, scenario) -> None:
        super().validate(config, scenario)
        if scenario.orbit.gravity in ("cw", "free_space"):
            raise ScenarioError(
                "orbit.gravity",
                f"the LOS guidance linearises an orbit ({scenario.orbit.gravity} has none "
                "in ECI): use two_body or two_body_j2",
            )
        if config.actuation == "thrusters" and not math.isclose(
            THRUSTER_PERIOD_S * round(config.control_period_s / THRUSTER_PERIOD_S),
            config.control_period_s,
        ):
            raise ScenarioError(
                "controller.control_period_s",
                f"with thrusters it must be a multiple of the {THRUSTER_PERIOD_S} s PWM period",
            )
        if config.corridor_axis == "docking":
            port = np.asarray(scenario.target.docking_port_T, dtype=float)
            axis = np.asarray(scenario.target.docking_axis_T, dtype=float)
            axis = axis / np.linalg.norm(axis)
            up = float(port @ axis)
            if np.linalg.norm(port - up * axis) > 1e-6 * (1.0 + np.linalg.norm(port)) or up < 0:
                raise ScenarioError(
                    "target.docking_port_T",
                    "controller.corridor_axis: docking puts the corridor's apex at the target's "
                    "centre: the port must lie on the docking axis through it, on its + side",
                )
        if config.capture and not np.linalg.norm(scenario.chaser.capture_point_C) > 0:
            raise ScenarioError(
                "chaser.capture_point_C", "controller.capture needs a capture point off the centre"
            )

    def load_warnings(self, config, scenario) -> list[str]:
        """A hold point the box cannot hold at rest in the tumbling frame (omega_t^2 |p_TH| >
        a_max, rpod.models.los_corridor.holding_range_m), with the hold distance that can."""
        omega = float(np.linalg.norm(np.radians(scenario.target.w_IT_T_deg_s)))
        if omega == 0.0:
            return []
        a_max, hold = config.a_max_m_s2, guidance_geometry(config, scenario)[0].hold_distance_m
        r_hold = holding_range_m(a_max, omega)
        if hold <= r_hold:
            return []
        offer = suggested_hold_distance_m(a_max, omega)
        text = (
            f"controller.hold_distance_m: the hold point {hold:g} m up the axis cannot be held: "
            f"at rest in the tumbling frame it needs omega_t^2 r = {omega**2 * hold:.3g} m/s^2, "
            f"more than a_max = {a_max:g} m/s^2 (the box holds out to r_sync / 2 = "
            f"{r_hold:.2f} m); "
        )
        if offer > config.floor_m:
            text += (
                f"hold_distance_m = {offer:.2f} (r_sync / 4, half the box left for control) "
                "can be held"
            )
        else:
            text += f"no point beyond the corridor's {config.floor_m:g} m floor can be held"
        return [text]

    def add_to_diagram(self, builder, scenario, sensed) -> ControllerWiring:
        config = scenario.controller
        guidance_config, R_TK = guidance_geometry(config, scenario)
        guidance = builder.AddNamedSystem(
            self.system_name,
            LosGuidance(
                guidance_config,
                np.asarray(scenario.target.inertia_kg_m2),
                scenario.orbit.gravity,
                keep_out_m=_bounding_radius_sum_m(scenario),
                R_TK=R_TK,
            ),
        )
        builder.Connect(sensed, guidance.GetInputPort(SENSED_PORT))
        logged = {
            "los_command_L": guidance.GetOutputPort("acceleration_command_L"),
            "los_nominal_L": guidance.GetOutputPort("nominal_command_L"),
            STATUS_LOG_KEY: guidance.GetOutputPort("guidance_status"),
            "hold_point_L": guidance.GetOutputPort("hold_point_L"),
            "los_face_distance_m": guidance.GetOutputPort("face_distance_m"),
        }
        command = guidance.GetOutputPort("acceleration_command_L")
        if config.actuation == "ideal":
            ideal = IdealCommand("acceleration", "L", "box", config.a_max_m_s2)
            return ControllerWiring(guidance, command, logged, ideal, guidance.step_timer)
        adapter = builder.AddNamedSystem(
            "acceleration_to_wrench",
            AccelerationToWrench(
                scenario.chaser.mass_kg,
                np.asarray(scenario.chaser.inertia_kg_m2),
                THRUSTER_PERIOD_S,
                capture_point_C=scenario.chaser.capture_point_C if config.capture else None,
            ),
        )
        builder.Connect(command, adapter.GetInputPort("acceleration_command_L"))
        builder.Connect(sensed, adapter.GetInputPort(SENSED_PORT))
        wrench = adapter.GetOutputPort("body_wrench_desired")
        logged["body_wrench_desired"] = wrench
        return ControllerWiring(guidance, wrench, logged, step_timer=guidance.step_timer)

    def command_period_s(self, config) -> float:
        """The guidance's period on the ideal path; through thrusters, the acceleration-to-
        wrench adapter's (THRUSTER_PERIOD_S), which is the PWM period."""
        return config.control_period_s if config.actuation == "ideal" else THRUSTER_PERIOD_S

    def add_scene_extras(self, builder, meshcat, scenario, wiring, scene=None) -> None:
        if scene is None:
            return
        from rpod.systems.los_corridor_scene import add_los_corridor_to_scene  # only when drawing

        guidance = wiring.system
        add_los_corridor_to_scene(
            scene,
            guidance.corridor,
            scenario.controller.drawn_length_m,
            guidance.p_TH_T,
            R_TK=guidance.R_TK,
        )

    def campaign_table(self, rows):
        """Paper 004's Monte Carlo set or Table 3 beside the campaign (tables.py)."""
        return tables.campaign_table(rows)

    def results(self, scenario, wiring, context, log) -> ControllerResults:
        """metrics.py's arrays (the raw status vector split and dropped), summary and outcome."""
        guidance = wiring.system
        added, summary, outcome = los_results(scenario, guidance.p_TH_T, log, guidance.R_TK)
        return ControllerResults(summary=summary, log=added, outcome=outcome)
