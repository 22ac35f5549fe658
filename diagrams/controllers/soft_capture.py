"""Paper 000's soft capture as a plug-in: `controller: !SoftCapture {...}`.

Owns: the `SoftCapture` config type (the YAML tag: closed-loop settings and the planner's
*settings*), the derivation of the planner's *problem data* from the scenario (never written
twice: the orbit gives a, the chaser its mass and capture point D_c, the target its docking
port D_t and cone angle), how the closed loop (rpod.systems.soft_capture_controller) is added
to a diagram (path 1), the capture criterion, its results (capture, every planner call, the
accepted plans' knots) and the planned-path overlay of the scene.
Does not own: the planner (rpod.planners.soft_capture), the loop (systems/), files (scenarios/).

Mission: capture (paper 000's eps_p, eps_v on the capture points, no contact before).
"""

import dataclasses
import math

import numpy as np

from rpod.diagrams.controller_seam import (
    Actuation,
    ControllerPlugin,
    ControllerResults,
    ControllerWiring,
    MissionOutcome,
    register_controller,
)
from rpod.diagrams.controllers.soft_capture_stats import soft_capture_rows
from rpod.diagrams.scenario import (
    ScenarioError,
    body_polytopes,
    chaser_rotation_in_lvlh,
    initial_relative_state_L,
    target_rotation_in_lvlh,
)
from rpod.models.frames import quaternion_wxyz, rotation_from_wxyz
from rpod.models.gravity import R_EARTH_M
from rpod.planners.checked_plan import CheckedPlan, predict_plan_check
from rpod.planners.soft_capture import (
    SoftCaptureConfig,
    SoftCapturePlanner,
    SoftCaptureSettings,
)
from rpod.systems.sensed import SENSED_PORT
from rpod.systems.soft_capture_controller import MODES as CONTROLLER_MODES
from rpod.systems.soft_capture_controller import (
    PLANNER_STATUSES,
    SoftCaptureController,
    SoftCaptureControllerConfig,
)

LOGGED = (
    "body_wrench_desired",
    "reference_L",
    "force_feedforward_L",
    "controller_mode",
    "planner_status",
)


@dataclasses.dataclass
class SoftCapture(SoftCaptureControllerConfig):
    """Plan and fly paper 000's soft capture (closed-loop fields: see the base class).

    Args:
        planner: the planner's settings (Table I weights, bounds, tolerances, horizon search);
            its problem data come from the scenario (`planner_config`).
    """

    planner: SoftCaptureSettings = dataclasses.field(default_factory=SoftCaptureSettings)


def planner_config(scenario) -> SoftCaptureConfig:
    """The planner's full config: the scenario's settings plus the problem data derived from
    orbit (a = R_earth + altitude), chaser (mass, D_c) and target (D_t, cone angle)."""
    chaser, target = scenario.chaser, scenario.target
    return SoftCaptureConfig.from_settings(
        scenario.controller.planner,
        semi_major_axis_m=R_EARTH_M + scenario.orbit.altitude_m,
        chaser_mass_kg=chaser.mass_kg,
        docking_half_angle_deg=target.corridor_half_angle_deg,
        p_CDc_C=chaser.capture_point_C,
        p_TDt_T=target.docking_port_T,
    )


def controller_config(scenario) -> SoftCaptureControllerConfig:
    """The closed loop's config with the full planner config (what the system consumes)."""
    config = scenario.controller
    values = {f.name: getattr(config, f.name) for f in dataclasses.fields(config)}
    return SoftCaptureControllerConfig(**(values | {"planner": planner_config(scenario)}))


def capture_outcome(log: dict, scenario) -> dict:
    """The soft-capture criterion on a run's log (paper 000's eps_p, eps_v; Table I).

    Capture succeeds at the first log sample where the capture points -- the chaser's D_c
    (`chaser.capture_point_C`, in C) and the target's D_t (`target.docking_port_T`, in T) --
    are within eps_p of each other and their relative (inertial) speed is within eps_v
    (`capture_speed_m_s` of the SafetyMonitor), provided the true polytopes never touched
    before (`separation_m` > 0 at every sample up to and including that one). Contact is
    checked at the log samples: log at the control period for a run whose verdict matters.

    Returns:
        {success, reason, time_s, position_error_m, speed_error_m_s, contact_after_s}: the
        errors at the capture sample, or at the sample closest to meeting both tolerances
        (least max(position / eps_p, speed / eps_v)) when it failed; `contact_after_s` is the
        first contact after a successful capture (NaN if none: contact after capture does not
        undo it, but a hold the thrusters cannot sustain -- a fast tumble needs more
        centripetal force than they have -- ends in one, and a user should see it).
    """
    settings = scenario.controller.planner
    eps_p, eps_v = settings.capture_position_tol_m, settings.capture_speed_tol_m_s
    D_c = np.asarray(scenario.chaser.capture_point_C, float)
    D_t = np.asarray(scenario.target.docking_port_T, float)
    position_error = np.empty(len(log["t"]))
    for i, (p_LC_L, q_IL, q_IT, q_IC) in enumerate(
        zip(log["p_LC_L"], log["q_IL"], log["q_IT"], log["q_IC"])
    ):
        R_LI = rotation_from_wxyz(q_IL).T
        p_E_L = p_LC_L + R_LI @ rotation_from_wxyz(q_IC) @ D_c  # chaser capture point
        p_D_L = R_LI @ rotation_from_wxyz(q_IT) @ D_t  # target capture point
        position_error[i] = np.linalg.norm(p_E_L - p_D_L)
    speed = np.asarray(log["capture_speed_m_s"], float)
    separation = np.asarray(log["separation_m"], float)
    met = np.flatnonzero((position_error <= eps_p) & (speed <= eps_v))
    contact = np.flatnonzero(~(separation > 0.0))
    outcome = {
        "success": False,
        "reason": "",
        "time_s": float("nan"),
        "contact_after_s": float("nan"),
    }
    if len(met) and (not len(contact) or contact[0] > met[0]):
        i = int(met[0])
        outcome.update(
            success=True,
            reason=f"capture points within eps_p = {eps_p} m and "
            f"eps_v = {eps_v} m/s with no contact before",
        )
        if len(contact):
            outcome["contact_after_s"] = float(log["t"][int(contact[0])])
    elif len(contact) and (not len(met) or contact[0] <= met[0]):
        i = int(contact[0])
        outcome["reason"] = f"contact: the true polytopes touched at t = {log['t'][i]:.2f} s"
    else:
        i = int(np.argmin(np.maximum(position_error / eps_p, speed / eps_v)))
        if not np.any(position_error <= eps_p):
            outcome["reason"] = (
                f"position: the capture points never came within eps_p = "
                f"{eps_p} m (closest {position_error.min():.3f} m)"
            )
        else:
            within = position_error <= eps_p
            outcome["reason"] = (
                f"speed: while within eps_p the capture points' relative speed never fell to "
                f"eps_v = {eps_v} m/s (least {speed[within].min():.4f} m/s)"
            )
    outcome.update(
        time_s=float(log["t"][i]),
        position_error_m=float(position_error[i]),
        speed_error_m_s=float(speed[i]),
    )
    return outcome


def _json_safe(record: dict) -> dict:
    """The record with non-finite floats as None (strict JSON has no NaN)."""
    return {
        key: None if isinstance(value, float) and not math.isfinite(value) else value
        for key, value in record.items()
    }


def plan_knots(records: list[dict], dt: float) -> dict:
    """`plan_knots_t` (P, N_max), `plan_knots_p_LC_L`, `plan_knots_v_LC_L` (P, N_max, 3) and
    `plan_knots_u_L` (P, N_max - 1, 3) of the accepted plans, NaN-padded."""
    accepted = [r for r in records if r["accepted"]]
    width = max((len(r["x"]) for r in accepted), default=1)
    t = np.full((len(accepted), width), np.nan)
    x = np.full((len(accepted), width, 6), np.nan)
    u = np.full((len(accepted), width - 1, 3), np.nan)
    for i, record in enumerate(accepted):
        knots = np.asarray(record["x"], float)
        t[i, : len(knots)] = record["t_s"] + np.arange(len(knots)) * dt
        x[i, : len(knots)] = knots
        u[i, : len(knots) - 1] = np.asarray(record["u"], float)
    return {
        "plan_knots_t": t,
        "plan_knots_p_LC_L": x[..., :3],
        "plan_knots_v_LC_L": x[..., 3:],
        "plan_knots_u_L": u,
    }


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


def _outcome_text(capture: dict) -> str:
    if capture["success"]:
        text = (
            f"captured at {capture['time_s']:.1f} s to {capture['position_error_m']:.3f} m and "
            f"{capture['speed_error_m_s']:.3f} m/s"
        )
        if math.isfinite(capture["contact_after_s"]):
            text += f" (contact after capture at {capture['contact_after_s']:.1f} s)"
        return text
    return f"NOT captured: {capture['reason']}"


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
        try:
            planner_config(scenario).validate()
        except ValueError as error:
            raise ScenarioError("controller.planner", str(error)) from None

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
            Actuation.BODY_WRENCH,
            controller.GetOutputPort("body_wrench_desired"),
            scenario.controller.control_period_s,
            {name: controller.GetOutputPort(name) for name in LOGGED},
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
        """A soft-capture campaign beside paper 000 Sec. VI-B (soft_capture_stats.py)."""
        table = soft_capture_rows(rows)
        if not table:
            return None
        title = "Soft capture beside paper 000 Sec. VI-B (initial plans; soft_capture_stats.py):"
        return title, ["quantity", "this campaign", "paper 000"], table

    @staticmethod
    def make_plan(scenario, closed_loop: bool = False) -> ScenarioPlan:
        """`rpod plan`: the plan from the scenario's initial state (plan_scenario)."""
        return plan_scenario(scenario, closed_loop)

    def results(self, scenario, wiring, context, log) -> ControllerResults:
        controller = wiring.system
        records = controller.plan_records(controller.GetMyContextFromRoot(context))
        dt = scenario.controller.planner.dt_s
        for key in ("controller_mode", "planner_status"):
            log[key] = log[key][:, 0].astype(np.int64)
        extra_log = plan_knots(records, dt)
        capture = capture_outcome(log, scenario)
        accepted = [r for r in records if r["accepted"]]
        capture["planned_time_s"] = (
            accepted[-1]["t_s"] + (accepted[-1]["N"] - 1) * dt if accepted else float("nan")
        )
        if not accepted and not capture["success"]:
            last = records[-1] if records else {"status": "none", "reason": "no planner call"}
            capture["reason"] = f"no plan: {last['status']}: {last['reason']}"
        first = records[0] if records else {}
        last_call = records[-1]["status"] if records else "none"
        summary = {
            "capture": _json_safe(capture),
            "plans": [
                _json_safe(
                    {key: value for key, value in r.items() if key not in ("x", "u")}
                    | {"check_violations": _json_safe(r.get("check_violations", {}))}
                )
                for r in records
            ],
            # What a user reads it for: the status of the plan being flown at the end (the
            # last accepted one); a late replan that fails keeps that plan flying.
            "planner_status": accepted[-1]["status"] if accepted else last_call,
            "last_planner_call_status": last_call,
        }
        summary.update(
            _json_safe(
                {
                    "capture_success": bool(capture["success"]),
                    "capture_time_s": capture["time_s"],
                    "capture_position_error_m": capture["position_error_m"],
                    "capture_speed_error_m_s": capture["speed_error_m_s"],
                    "initial_plan_success": bool(first.get("accepted", False)),
                    "initial_plan_N": int(first.get("N", 0)),
                    "initial_plan_scp_iterations": int(first.get("scp_iterations", 0)),
                    "initial_plan_solve_time_s": float(first.get("total_solve_time_s", 0.0)),
                    "replans_accepted": sum(1 for r in records[1:] if r["accepted"]),
                    "replans_failed": sum(1 for r in records[1:] if not r["accepted"]),
                    # The independent plan check of every plan the planner called a success (None: the
                    # initial call had no such plan).
                    "plans_checked": sum(1 for r in records if r.get("check_passed") is not None),
                    "plans_check_failed": sum(1 for r in records if r.get("check_passed") is False),
                    "initial_plan_check_passed": first.get("check_passed"),
                    "contact_after_capture": bool(capture["success"])
                    and math.isfinite(capture["contact_after_s"]),
                }
            )
        )
        # The corridor a user reads this run for is paper 000's docking cone (eq. 11), which the
        # plan enforces over its last N_dock knots: the violation there, up to the capture.
        window = None
        if accepted:
            settings = scenario.controller.planner
            start = capture["planned_time_s"] - (settings.docking_knots - 1) * dt
            end = capture["time_s"] if capture["success"] else capture["planned_time_s"]
            inside = (log["t"] >= start - 1e-9) & (log["t"] <= end + 1e-9)
            if np.any(inside):
                window = [float(start), float(end)]
                summary["max_corridor_violation_deg"] = float(
                    np.degrees(np.max(log["corridor_violation_rad"][inside]))
                )
        summary["corridor_window_s"] = window
        summary["planner_status_codes"] = list(PLANNER_STATUSES)
        summary["controller_mode_codes"] = list(CONTROLLER_MODES)
        outcome = MissionOutcome(bool(capture["success"]), _outcome_text(capture))
        return ControllerResults(summary=summary, log=extra_log, outcome=outcome)


register_controller(SoftCapturePlugin())
