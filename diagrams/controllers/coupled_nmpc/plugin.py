"""Paper 001's coupled 6-DOF NMPC as a plug-in: how it is checked, wired, drawn and judged.

Owns: `CoupledNmpcPlugin`: the checks that need the scenario (a two-body orbit, the gimbaled
layout on the chaser's cuboid or a fixed bank planned by the SQP, the plan's thrust at most the
bank's), the wiring (path 2: eight force vectors in C, 24 numbers, straight to the gimbaled
bank, which clips them to the gimbal pyramid and the magnitude limit: the truth, not the
controller, decides what is produced; on a fixed bank, rpod's (the shoot-out's rcs_cube_12), one
level per thruster through the PWM, eqs. 11-12 with the gimbal angles fixed), the scene extras,
and the hooks to its results (metrics.py, mission.py) and figures (figures.py, imported only
when drawing).
Does not own: the config (config.py), the problem data and planner (problem.py), the controller
(systems/coupled_nmpc_controller.py), the NLP (rpod.planners.coupled_nmpc), the prediction
model (rpod.models.coupled_relative) or the scene (rpod.systems.coupled_nmpc_scene).
"""

import numpy as np
from pydrake.systems.primitives import MatrixGain

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
from rpod.planners.coupled_nmpc import FIXED_BANK_SOLVERS
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
        gimbaled = make_thruster_layout(scenario).gimbaled
        if gimbaled and thrusters.layout != LAYOUT:
            raise ScenarioError(
                "thrusters.layout",
                f"!CoupledNmpc commands force vectors of paper 001's gimbaled thrusters: "
                f"must be {LAYOUT} or a fixed bank, got {thrusters.layout!r}",
            )
        if not gimbaled and config.nmpc.solver not in FIXED_BANK_SOLVERS:
            raise ScenarioError(
                "controller.nmpc.solver",
                f"a fixed bank ({thrusters.layout}) is planned by {FIXED_BANK_SOLVERS} only, "
                f"got {config.nmpc.solver!r}",
            )
        if gimbaled and config.attitude_goal == "facing":
            raise ScenarioError(
                "controller.attitude_goal",
                "facing plans in a turned chaser frame, where the gimbal pyramids are not the "
                f"bank's: use a fixed bank with it, or aligned with {LAYOUT}",
            )
        if config.max_thrust_N > thrusters.max_thrust_N:
            raise ScenarioError(
                "controller.max_thrust_N",
                f"must not exceed thrusters.max_thrust_N ({thrusters.max_thrust_N:g} N), "
                f"got {config.max_thrust_N:g}",
            )
        chaser = scenario.chaser
        if gimbaled and chaser.shape == "box":
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
            CoupledNmpcController(
                planner,
                config.period_s(),
                config.integral_step_s,
                R_CCp=problem.planning_frame_R_CCp(scenario),
            ),
        )
        builder.Connect(sensed, controller.GetInputPort(SENSED_PORT))
        logged = {
            STATUS_LOG_KEY: controller.GetOutputPort("nmpc_status"),
            "coupled_xi_T_m_s": controller.GetOutputPort("integral_state_T"),
        }
        gimbaled = planner.params.layout.gimbaled
        command = "thruster_forces_C" if gimbaled else "thruster_levels"
        return ControllerWiring(
            controller, controller.GetOutputPort(command), logged, step_timer=controller.step_timer
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
        layout = make_thruster_layout(scenario)  # the bank's limits
        forces = wiring.command
        if not layout.gimbaled:  # levels -> the commanded force vectors, f_k = level f_max d_k
            to_forces = np.zeros((3 * layout.count, layout.count))
            for k, thruster in enumerate(layout.thrusters):
                to_forces[3 * k : 3 * k + 3, k] = thruster.max_thrust_N * thruster.direction_C
            forces = builder.AddNamedSystem("coupled_levels_to_forces", MatrixGain(to_forces))
            builder.Connect(wiring.command, forces.get_input_port())
            forces = forces.get_output_port()
        add_coupled_scene(
            builder,
            meshcat,
            scene,
            layout,
            p_TPt_T,
            p_CPc_C,
            scenario.controller.nmpc.los_half_angle_rad,
            forces,
            publish_period_s=scenario.visualization.publish_period_s,
            clip=layout.gimbaled,
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
