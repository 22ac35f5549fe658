"""Paper 001's coupled 6-DOF NMPC as a plug-in: how it is checked, wired, drawn and judged.

Owns: `CoupledNmpcPlugin`: the checks that need the scenario (a two-body orbit, the gimbaled
layout on the chaser's cuboid, the plan's thrust at most the bank's), the wiring (path 2: eight
force vectors in C, 24 numbers, straight to the gimbaled bank, which clips them to the gimbal
pyramid and the magnitude limit: the truth, not the controller, decides what is produced), the
scene extras, and the hooks to its results (metrics.py, mission.py) and figures (figures.py,
imported only when drawing).
Does not own: the config (config.py), the problem data and planner (problem.py), the controller
(systems/coupled_nmpc_controller.py), the NLP (rpod.planners.coupled_nmpc), the prediction
model (rpod.models.coupled_relative) or the scene (rpod.systems.coupled_nmpc_scene).
"""

import numpy as np

from rpod.diagrams.controller_seam import (
    Actuation,
    ControllerPlugin,
    ControllerResults,
    ControllerWiring,
)
from rpod.diagrams.controllers.coupled_nmpc import problem
from rpod.diagrams.controllers.coupled_nmpc.config import CoupledNmpc
from rpod.diagrams.controllers.coupled_nmpc.metrics import (
    STATUS_LOG_KEY,
    coupled_log,
    coupled_summary,
)
from rpod.diagrams.controllers.coupled_nmpc.mission import coupled_outcome
from rpod.diagrams.controllers.coupled_nmpc.problem import feature_points
from rpod.diagrams.scenario import ScenarioError, make_thruster_layout
from rpod.systems.coupled_nmpc_controller import CoupledNmpcController
from rpod.systems.sensed import SENSED_PORT

LAYOUT = "gimbaled_cuboid_8"
GRAVITIES = ("two_body", "two_body_j2")  # the prediction propagates a two-body orbit in I
LOG_SHAPES = {  # the keys the figures read (figures.py documents each)
    "coupled_eigenaxis_error_rad": None,
    "coupled_w_TC_T_rad_s": 3,
    "coupled_p_PtPc_T_m": 3,
    "coupled_v_PtPc_T_m_s": 3,
    "coupled_thruster_forces_C_N": -1,  # 3 per thruster
    "coupled_force_C_N": 3,
    "coupled_torque_C_Nm": 3,
    "coupled_los_margin_m": None,
    "coupled_max_thrust_N": None,
    "coupled_gimbal_half_angle_rad": None,
    "nmpc_status": None,
    "nmpc_fallback": None,
    "nmpc_solve_time_s": None,
}


class CoupledNmpcPlugin(ControllerPlugin):
    """Plug-in of rpod.systems.coupled_nmpc_controller.CoupledNmpcController."""

    config_type = CoupledNmpc
    system_name = "coupled_nmpc"
    actuation = Actuation.THRUSTER_COMMANDS
    log_shapes = LOG_SHAPES

    def run_figures(self) -> dict:
        """coupled_state.png, coupled_thrusters.png and coupled_nmpc.png (figures.py)."""
        from rpod.diagrams.controllers.coupled_nmpc import figures  # only when drawing

        return figures.run_figures()

    def validate(self, config, scenario) -> None:
        super().validate(config, scenario)
        if scenario.orbit.gravity not in GRAVITIES:
            raise ScenarioError(
                "orbit.gravity",
                f"!CoupledNmpc predicts two-body orbits in ECI: use one of {GRAVITIES}, "
                f"got {scenario.orbit.gravity!r}",
            )
        thrusters = scenario.thrusters
        if thrusters.layout != LAYOUT:
            raise ScenarioError(
                "thrusters.layout",
                f"!CoupledNmpc commands force vectors of paper 001's gimbaled thrusters: "
                f"must be {LAYOUT}, got {thrusters.layout!r}",
            )
        if config.max_thrust_N > thrusters.max_thrust_N:
            raise ScenarioError(
                "controller.max_thrust_N",
                f"must not exceed thrusters.max_thrust_N ({thrusters.max_thrust_N:g} N), "
                f"got {config.max_thrust_N:g}",
            )
        chaser = scenario.chaser
        if chaser.shape == "box":
            cuboid = 2.0 * np.max(np.abs(make_thruster_layout(scenario).p_CK_C), axis=0)
            if not np.allclose(chaser.size_m, cuboid, rtol=0.0, atol=1e-9):
                raise ScenarioError(
                    "chaser.size_m",
                    f"{LAYOUT} puts its thrusters on the corners of a {cuboid.tolist()} m "
                    f"cuboid: the chaser box must be that, got {list(chaser.size_m)}",
                )

    def add_to_diagram(self, builder, scenario, sensed) -> ControllerWiring:
        config = scenario.controller
        planner = problem.make_planner(scenario)  # looked up here: a study may replace it
        controller = builder.AddNamedSystem(
            self.system_name,
            CoupledNmpcController(planner, config.period_s(), config.integral_step_s),
        )
        builder.Connect(sensed, controller.GetInputPort(SENSED_PORT))
        logged = {
            STATUS_LOG_KEY: controller.GetOutputPort("nmpc_status"),
            "coupled_xi_T_m_s": controller.GetOutputPort("integral_state_T"),
        }
        return ControllerWiring(
            controller,
            controller.GetOutputPort("thruster_forces_C"),
            logged,
            step_timer=controller.step_timer,
        )

    def command_period_s(self, config) -> float:
        """T_c: control_period_s, or T / N when it is 0 (config.period_s)."""
        return config.period_s()

    def add_scene_extras(self, builder, meshcat, scenario, wiring, scene=None) -> None:
        """The LOS pyramid and the rock on T, the end effector on C, and each thruster's force
        as an arrow, the commands drawn as the bank clips them (rpod.systems.coupled_nmpc_scene)."""
        if scene is None:
            return
        from rpod.systems.coupled_nmpc_scene import add_coupled_scene  # only when drawing

        p_TPt_T, p_CPc_C = feature_points(scenario)
        add_coupled_scene(
            builder,
            meshcat,
            scene,
            make_thruster_layout(scenario),  # the bank's limits
            p_TPt_T,
            p_CPc_C,
            scenario.controller.nmpc.los_half_angle_rad,
            wiring.command,
            publish_period_s=scenario.visualization.publish_period_s,
            clip=True,
        )

    def results(self, scenario, wiring, context, log) -> ControllerResults:
        """metrics.py's arrays (the raw status vector split and dropped) and summary, and
        mission.py's outcome."""
        controller = wiring.system
        added, gimbal, magnitude, wrench = coupled_log(scenario, controller.params, log)
        records = controller.solve_records(controller.GetMyContextFromRoot(context))
        summary = coupled_summary(records, log, added, gimbal, magnitude, wrench)
        # The seam's names for every method (rpod.diagrams.controller_seam.ControllerResults).
        summary["solver_failures"] = summary["nmpc_not_usable"]
        summary["fallback_s"] = summary["nmpc_fallback_steps"] * scenario.controller.period_s()
        return ControllerResults(summary=summary, log=added, outcome=coupled_outcome(summary))
