"""Paper 003's planar approach as a plug-in: how it is checked, planned, wired, drawn, judged.

Owns: `PlanarApproachPlugin`: the checks that need the scenario (free space, planar_8, squares,
a planar start and a flat spin, the planner's full config), the plan made once at start
(planning.py, called in the tracker's initialization event; `flown_run` reads it back for the
results and the planned end), how the tracker is wired (path 1: body wrench -> box-constrained
allocation to 8 duties, eq. 14 -> PWM with N_PWM slots, Sec. IV-B -> `planar_8` thrusters), the
keep-out scene extras and the hooks to its results (metrics.py, mission.py), figures
(figures.py) and campaign tables and maps (tables.py, campaign_maps.py), the plotting ones
imported only when drawing.
Does not own: the config (config.py), the problem data (problem.py), the PD law (eqs. 11-13,
rpod.systems.planar_tracking), the allocator, the PWM or the thrusters (the builder wires them)
or the scene (rpod.systems.planar_scene).
"""

import dataclasses
import math
import typing

import numpy as np

from rpod.diagrams.controller_seam import (
    ControllerPlugin,
    ControllerResults,
    ControllerWiring,
)
from rpod.diagrams.controllers.planar_approach.config import PlanarApproach
from rpod.diagrams.controllers.planar_approach.metrics import planar_log, planar_summary
from rpod.diagrams.controllers.planar_approach.mission import outcome
from rpod.diagrams.controllers.planar_approach.plan_file import plan_output
from rpod.diagrams.controllers.planar_approach.planning import PlanarApproachRun, make_run
from rpod.diagrams.controllers.planar_approach.problem import (
    PLANAR_TOLERANCE,
    PlanarStart,
    is_planar_rotation,
    planner_config,
    tracking_config,
)
from rpod.diagrams.controllers.planar_approach.tables import campaign_rows, metric_rows
from rpod.diagrams.scenario import (
    ScenarioError,
    chaser_rotation_in_lvlh,
    initial_relative_state_L,
    target_rotation_in_lvlh,
)
from rpod.systems.planar_tracking import PlanarReference, PlanarTrackingController
from rpod.systems.sensed import SENSED_PORT, Sensed

LOGGED = {
    "planar_body_wrench_desired": "body_wrench_desired",
    "planar_wrench_L": "planar_wrench_L",
    "planar_tracking_error": "tracking_error",
    "planar_reference_state": "reference_state",
    "planar_sensed_state": "planar_state",
}
"""Log key -> the tracker's output port (held at its samples)."""
LOG_SHAPES = {  # the keys the figures read (figures.py documents each)
    "planar_flown_state": 6,
    "planar_plan_state": 6,
    "planar_position_error_m": None,
    "planar_attitude_error_rad": None,
    "planar_target_yaw_rad": None,
    "planar_relative_velocity_T": 2,
    "planar_keepout_state": None,
    "planar_keepout_q_m": None,
    "planar_goal_L": 2,
    "planar_chaser_side_m": None,
    "planar_target_side_m": None,
    "planar_body_wrench_desired": 6,
}


@dataclasses.dataclass
class PlanarWiring(ControllerWiring):
    """The tracker's wiring.

    Attributes:
        sensed: The sensed bundle's port (the scene's keep-out state reads the same bundle).
    """

    sensed: typing.Any = None


def flown_run(wiring: PlanarWiring, context) -> PlanarApproachRun:
    """The plan made at t = 0 and the reference flown (planning.PlanarApproachRun), held by the
    tracker; `context` is the diagram's, after `Simulator.Initialize`."""
    tracker = wiring.system
    return tracker.reference(tracker.GetMyContextFromRoot(context)).plan


class PlanarApproachPlugin(ControllerPlugin):
    """Plug-in of rpod.systems.planar_tracking.PlanarTrackingController on a paper-003 plan."""

    config_type = PlanarApproach
    system_name = "planar_tracker"
    log_shapes = LOG_SHAPES

    def run_figures(self) -> dict:
        """Figs. 4-7 of a run (figures.py)."""
        from rpod.diagrams.controllers.planar_approach import figures  # only when drawing

        return figures.run_figures()

    def validate(self, config, scenario) -> None:
        super().validate(config, scenario)
        if scenario.orbit.gravity != "free_space":
            raise ScenarioError(
                "orbit.gravity",
                "paper 003's approach is planar and inertial: must be free_space, got "
                f"{scenario.orbit.gravity!r}",
            )
        thrusters = scenario.thrusters
        if thrusters.layout != "planar_8":
            raise ScenarioError(
                "thrusters.layout", f"paper 003's chaser flies planar_8, got {thrusters.layout!r}"
            )
        chaser, target = scenario.chaser, scenario.target
        for prefix, body in (("chaser", chaser), ("target", target)):
            if body.shape != "box":
                raise ScenarioError(f"{prefix}.shape", "paper 003's bodies are squares: box")
            if not math.isclose(body.size_m[0], body.size_m[1], rel_tol=1e-12):
                raise ScenarioError(
                    f"{prefix}.size_m",
                    f"paper 003's bodies are squares in the plane: x and y must be equal, got "
                    f"{list(body.size_m)}",
                )
            J = np.asarray(body.inertia_kg_m2, float)
            if np.max(np.abs([J[0, 2], J[1, 2], J[2, 0], J[2, 1]])) > PLANAR_TOLERANCE:
                raise ScenarioError(
                    f"{prefix}.inertia_kg_m2",
                    "z must be a principal axis (xz, yz products 0): a planar motion stays "
                    "planar only then",
                )
        p, v = initial_relative_state_L(scenario)
        if abs(p[2]) > PLANAR_TOLERANCE or abs(v[2]) > PLANAR_TOLERANCE:
            raise ScenarioError(
                "chaser.p_LC_L",
                f"the start must be in the plane z = 0 at rest in z, got {p[2]:g} m",
            )
        if not is_planar_rotation(chaser_rotation_in_lvlh(scenario)):
            raise ScenarioError(
                "chaser.rpy_LC_deg", "the chaser must start upright in the plane: roll, pitch 0"
            )
        if max(abs(chaser.w_IC_C_deg_s[0]), abs(chaser.w_IC_C_deg_s[1])) > PLANAR_TOLERANCE:
            raise ScenarioError("chaser.w_IC_C_deg_s", "only a z rate is planar: x, y must be 0")
        if not is_planar_rotation(target_rotation_in_lvlh(scenario)):
            field = "target.q_LT" if target.q_LT else "target.rpy_LT_deg"
            raise ScenarioError(field, "the target must start upright in the plane: roll, pitch 0")
        w = target.w_IT_T_deg_s
        if max(abs(w[0]), abs(w[1])) > PLANAR_TOLERANCE or w[2] == 0.0:
            raise ScenarioError(
                "target.w_IT_T_deg_s",
                f"paper 003's target spins about z: [0, 0, omega] with omega != 0, got {list(w)}",
            )
        try:  # the settings as written, with the problem data derived from the scenario
            planner_config(scenario).validate()
        except ScenarioError as error:
            raise error.under("controller.planner") from None

    def add_to_diagram(self, builder, scenario, sensed) -> PlanarWiring:
        def plan_at_start(sensed_at_t0: Sensed) -> PlanarReference:  # planning.py
            return make_run(scenario, PlanarStart.from_sensed(sensed_at_t0)).to_fly()

        tracker = builder.AddNamedSystem(
            self.system_name,
            PlanarTrackingController(tracking_config(scenario), plan_at_start=plan_at_start),
        )
        builder.Connect(sensed, tracker.GetInputPort(SENSED_PORT))
        return PlanarWiring(
            tracker,
            tracker.GetOutputPort("body_wrench_desired"),
            {key: tracker.GetOutputPort(port) for key, port in LOGGED.items()},
            sensed=sensed,
        )

    def planned_end_s(self, wiring, context) -> float | None:
        """The planned arrival T; 0 without a plan (the start pose is held from t = 0)."""
        run = flown_run(wiring, context)
        return run.arrival_s if run.plan.flyable else 0.0

    def add_scene_extras(self, builder, meshcat, scenario, wiring, scene=None) -> None:
        """The keep-out zone on the target frame, State I or II as the chaser's state says,
        the goal (rpod.systems.planar_scene) and the plan's path once it is made
        (rpod.systems.scene.PlannedPathOverlay)."""
        from rpod.systems.planar_scene import add_planar_scene  # only when drawing
        from rpod.systems.scene import PlannedPathOverlay

        config = planner_config(scenario)  # the settings: the zone and the goal, no plan
        add_planar_scene(
            builder,
            meshcat,
            config.geometry,
            wiring.sensed,
            publish_period_s=scenario.visualization.publish_period_s,
            goal_L=config.goal_position,
            height_m=float(scenario.target.size_m[2]),
        )
        overlay = builder.AddNamedSystem(
            "scene.planned_path",
            PlannedPathOverlay(meshcat, scenario.visualization.publish_period_s, knot_size_m=0.01),
        )
        builder.Connect(
            wiring.system.GetOutputPort("planned_path"), overlay.GetInputPort("planned_path")
        )

    @staticmethod
    def make_plan(scenario, closed_loop: bool = False):
        """`rpod plan`: the plan from the scenario's initial state (plan_file.plan_output)."""
        return plan_output(scenario, closed_loop)

    def campaign_table(self, rows):
        """Paper 003's case studies or the modulation comparison (tables.campaign_rows)."""
        return campaign_rows(rows)

    def campaign_figures(self, rows, out_dir):
        """Figs. 8-9-like maps of a campaign (campaign_maps.write_campaign_maps), for
        `rpod report`."""
        from rpod.diagrams.controllers.planar_approach.campaign_maps import (  # when drawing
            write_campaign_maps,
        )

        return write_campaign_maps(metric_rows(rows), out_dir)

    def results(self, scenario, wiring, context, log) -> ControllerResults:
        """metrics.py's arrays and summary, mission.py's outcome."""
        run = flown_run(wiring, context)
        extra = planar_log(run, scenario, log)
        summary = planar_summary(run, scenario, log, extra)
        return ControllerResults(
            summary=summary, log=extra, outcome=outcome(summary, scenario.controller)
        )
