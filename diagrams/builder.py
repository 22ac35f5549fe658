"""Wires a `Scenario` into a Drake Diagram with loggers, and simulates it.

Owns: `build_diagram` (systems named in the diagram, loggers on every key signal, the Meshcat
scene when asked), `simulate` (a `SimulationResult` with logs, metrics and timings) and the
scenario-to-system translation (thruster presets, initial attitudes).
Does not own: files and the command line (rpod.scenarios, rpod.diagrams.outputs).

Signal flow of a controlled scenario (one period of delay between the controller's sample and
the thrusters, as on a real flight computer: the PWM latches the duty computed at the previous
sample). The controller is a HoldPointController or a SoftCaptureController:

    OrbitalDynamics --relative_state_L, q_IL, w_IL_L--> controller
    RigidBodyAttitude (target, chaser) --attitude--> controller
    controller --body_wrench_desired--> WrenchAllocator --thruster_duty--> PwmModulator
    PwmModulator --thruster_on--> ThrusterBank --body_wrench--> OrbitalDynamics, chaser attitude

Soft capture (controller type 'soft_capture'): the summary gains `capture` (the capture
criterion, `capture_outcome`) and `plans` (every planner call of the controller); the log gains
`controller_mode`, `planner_status`, `force_feedforward_L`, `reference_L` (the planned position
at each sample) and the accepted plans' knots, `plan_knots_t` (P, N_max), `plan_knots_p_LC_L`
and `plan_knots_v_LC_L` (P, N_max, 3), `plan_knots_u_L` (P, N_max - 1, 3), NaN-padded: one row
per accepted plan, not a time series.
"""

import dataclasses
import math
import time

import numpy as np
from pydrake.systems.analysis import ApplySimulatorConfig, Simulator, SimulatorConfig
from pydrake.systems.framework import Diagram, DiagramBuilder
from pydrake.systems.primitives import (
    ConstantVectorSource,
    Demultiplexer,
    LogVectorOutput,
    Multiplexer,
)

from rpod.diagrams.scenario import (
    Scenario,
    body_polytopes,
    target_rotation_in_lvlh,
    validate_scenario,
)
from rpod.models import thrusters as presets
from rpod.models.frames import quaternion_wxyz, rotation_from_rpy_deg, rotation_from_wxyz
from rpod.models.thrusters import STANDARD_GRAVITY_M_S2, ThrusterLayout
from rpod.systems.allocator import WrenchAllocator
from rpod.systems.hold_point_controller import HoldPointController
from rpod.systems.orbital_dynamics import OrbitalDynamics
from rpod.systems.pwm import PwmModulator
from rpod.systems.rigid_body_attitude import RigidBodyAttitude
from rpod.systems.safety_monitor import SafetyMonitor
from rpod.systems.sensed import SENSED_FIELDS, SENSED_PORT
from rpod.systems.soft_capture_controller import MODES as CONTROLLER_MODES
from rpod.systems.soft_capture_controller import PLANNER_STATUSES, SoftCaptureController
from rpod.systems.thruster_bank import ThrusterBank

HOLD_POSITION_TOLERANCE_M = 0.5  # "reached its hold point": within this of H ...
HOLD_SPEED_TOLERANCE_M_S = 0.02  # ... and moving with it to within this.


def make_thruster_layout(scenario: Scenario) -> ThrusterLayout:
    """The preset thruster layout a scenario names, with its thrust, Isp and size."""
    config = scenario.thrusters
    if config.layout == "rcs_cube_12":
        return presets.rcs_cube_12(config.size_m, config.max_thrust_N, config.isp_s)
    if config.layout == "planar_8":
        return presets.planar_8(config.size_m, config.max_thrust_N, config.isp_s)
    if config.layout == "gimbaled_cuboid_8":
        return presets.gimbaled_cuboid_8(max_thrust_N=config.max_thrust_N, isp_s=config.isp_s)
    raise ValueError(f"unknown thruster layout '{config.layout}'")


@dataclasses.dataclass
class DiagramHandles:
    """The named systems and loggers of a built diagram (None where a scenario has none)."""

    orbital: OrbitalDynamics
    target_attitude: RigidBodyAttitude
    chaser_attitude: RigidBodyAttitude
    monitor: SafetyMonitor
    controller: HoldPointController | SoftCaptureController | None
    bank: ThrusterBank | None
    loggers: dict  # log key -> VectorLogSink
    layout: ThrusterLayout | None
    scene: object | None


def build_diagram(scenario: Scenario, meshcat=None) -> tuple[Diagram, DiagramHandles]:
    """Builds the scenario's diagram; draws it in `meshcat` when one is given."""
    validate_scenario(scenario)
    builder = DiagramBuilder()
    chaser, target = scenario.chaser, scenario.target
    orbital = builder.AddNamedSystem(
        "orbital_dynamics",
        OrbitalDynamics(
            scenario.orbit,
            np.asarray(chaser.p_LC_L, float),
            np.asarray(chaser.v_LC_L, float),
            chaser.mass_kg,
            force_frame="C",
        ),
    )
    # Initial attitudes are given relative to LVLH; the truth holds them relative to ECI.
    context = orbital.CreateDefaultContext()
    R_IL0 = rotation_from_wxyz(orbital.GetOutputPort("q_IL").Eval(context))
    J_T = np.asarray(target.inertia_kg_m2, float)
    J_C = np.asarray(chaser.inertia_kg_m2, float)
    target_attitude = builder.AddNamedSystem(
        "target_attitude",
        RigidBodyAttitude(
            J_T,
            quaternion_wxyz(R_IL0 @ target_rotation_in_lvlh(scenario)),
            np.radians(target.w_IT_T_deg_s),
            with_torque_input=False,
        ),
    )
    chaser_attitude = builder.AddNamedSystem(
        "chaser_attitude",
        RigidBodyAttitude(
            J_C,
            quaternion_wxyz(R_IL0 @ rotation_from_rpy_deg(chaser.rpy_LC_deg)),
            np.radians(chaser.w_IC_C_deg_s),
            with_torque_input=True,
        ),
    )
    connect = builder.Connect
    connect(chaser_attitude.GetOutputPort("attitude"), orbital.GetInputPort("chaser_attitude"))

    loggers = {}
    period = scenario.log_period_s

    def log(key, port):
        loggers[key] = LogVectorOutput(port, builder, period)

    layout = bank = controller = None
    chaser_shape, target_shape = body_polytopes(scenario)
    if scenario.thrusters.enabled:
        layout = make_thruster_layout(scenario)
        bank = builder.AddNamedSystem("thruster_bank", ThrusterBank(layout))
        split = builder.AddNamedSystem("body_wrench_split", Demultiplexer([3, 3]))
        connect(bank.GetOutputPort("body_wrench"), split.get_input_port(0))
        connect(split.get_output_port(0), chaser_attitude.GetInputPort("body_torque"))
        connect(bank.GetOutputPort("body_wrench"), orbital.GetInputPort("body_wrench"))
        connect(
            bank.GetOutputPort("propellant_mass_flow"), orbital.GetInputPort("propellant_mass_flow")
        )
        log("body_wrench", bank.GetOutputPort("body_wrench"))
        log("command_clipped", bank.GetOutputPort("command_clipped"))
    else:
        zero_wrench = builder.AddNamedSystem("no_thrust", ConstantVectorSource(np.zeros(6)))
        zero_flow = builder.AddNamedSystem("no_mass_flow", ConstantVectorSource(np.zeros(1)))
        zero_torque = builder.AddNamedSystem("no_torque", ConstantVectorSource(np.zeros(3)))
        connect(zero_wrench.get_output_port(), orbital.GetInputPort("body_wrench"))
        connect(zero_flow.get_output_port(), orbital.GetInputPort("propellant_mass_flow"))
        connect(zero_torque.get_output_port(), chaser_attitude.GetInputPort("body_torque"))

    relative = orbital.GetOutputPort("relative_state_L")
    q_IL = orbital.GetOutputPort("q_IL")
    w_IL_L = orbital.GetOutputPort("w_IL_L")
    sensed = {
        "relative_state_L": relative,
        "q_IL": q_IL,
        "w_IL_L": w_IL_L,
        "target_attitude": target_attitude.GetOutputPort("attitude"),
        "chaser_attitude": chaser_attitude.GetOutputPort("attitude"),
    }
    # The sensed bundle (rpod.systems.sensed): today the truth; a navigation filter goes here.
    bundle = builder.AddNamedSystem("sensed", Multiplexer([size for _, size in SENSED_FIELDS]))
    for index, (name, _) in enumerate(SENSED_FIELDS):
        connect(sensed[name], bundle.get_input_port(index))
    sensed_port = bundle.get_output_port()

    if bank is not None:
        if scenario.controller.type == "hold_point":
            controller = builder.AddNamedSystem(
                "hold_point_controller",
                HoldPointController(
                    scenario.controller.hold_point,
                    chaser.mass_kg,
                    J_C,
                    np.asarray(target.docking_port_T, float),
                    np.asarray(target.docking_axis_T, float),
                ),
            )
            logged = ("body_wrench_desired", "hold_point_L", "reference_L")
        elif scenario.controller.type == "soft_capture":
            controller = builder.AddNamedSystem(
                "soft_capture_controller",
                SoftCaptureController(
                    scenario.controller.soft_capture, J_C, J_T, chaser_shape, target_shape
                ),
            )
            logged = ("body_wrench_desired", "reference_L", "force_feedforward_L",
                      "controller_mode", "planner_status")  # fmt: skip
        if controller is not None:  # every controller: sensed signals in, body wrench out
            connect(sensed_port, controller.GetInputPort(SENSED_PORT))
            allocator = builder.AddNamedSystem("wrench_allocator", WrenchAllocator(layout))
            connect(
                controller.GetOutputPort("body_wrench_desired"),
                allocator.GetInputPort("body_wrench_desired"),
            )
            duty = allocator.GetOutputPort("thruster_duty")
            for name in logged:
                log(name, controller.GetOutputPort(name))
        else:
            idle = builder.AddNamedSystem("idle", ConstantVectorSource(np.zeros(layout.count)))
            duty = idle.get_output_port()
        log("thruster_duty", duty)
        if scenario.thrusters.pwm:
            pwm = builder.AddNamedSystem(
                "pwm",
                PwmModulator(
                    layout.count,
                    scenario.controller.control_period_s(),
                    scenario.thrusters.subdivisions,
                    scenario.thrusters.min_on_slots,
                ),
            )
            connect(duty, pwm.GetInputPort("thruster_duty"))
            command = pwm.GetOutputPort("thruster_on")
            log("thruster_delivered_duty", pwm.GetOutputPort("delivered_duty"))
        else:
            command = duty
        connect(command, bank.GetInputPort("thruster_command"))
        log("thruster_on", command)

    monitor = builder.AddNamedSystem(
        "safety_monitor",
        SafetyMonitor(
            target_shape,
            chaser_shape,
            target.docking_port_T,
            target.docking_axis_T,
            math.radians(target.corridor_half_angle_deg),
            chaser.capture_point_C,
        ),
    )
    connect(sensed_port, monitor.GetInputPort(SENSED_PORT))

    log("relative_state_L", relative)
    log("q_IL", q_IL)
    log("w_IL_L", w_IL_L)
    log("target_state_I", orbital.GetOutputPort("target_state_I"))
    log("chaser_state_I", orbital.GetOutputPort("chaser_state_I"))
    log("chaser_mass", orbital.GetOutputPort("chaser_mass"))
    log("target_attitude", sensed["target_attitude"])
    log("chaser_attitude", sensed["chaser_attitude"])
    for name in ("separation_m", "corridor_violation_rad", "capture_speed_m_s"):
        log(name, monitor.GetOutputPort(name))

    scene = None
    if meshcat is not None:
        from rpod.systems.scene import RendezvousScene, SceneConfig  # only when drawing

        visualization = scenario.visualization
        scene_config = SceneConfig(
            target_box_size_m=list(target.size_m),
            chaser_box_size_m=list(chaser.size_m),
            docking_port_T=list(target.docking_port_T),
            docking_axis_T=list(target.docking_axis_T),
            corridor_half_angle_deg=target.corridor_half_angle_deg,
            corridor_length_m=visualization.corridor_length_m,
            publish_period_s=visualization.publish_period_s,
            trail=visualization.trail,
            trail_max_points=visualization.trail_max_points,
            camera_position_L_m=list(visualization.camera_position_L_m),
            target_vertices_T=(target_shape.vertices.tolist() if target.shape != "box" else []),
            chaser_vertices_C=(chaser_shape.vertices.tolist() if chaser.shape != "box" else []),
        )
        scene = RendezvousScene.AddToBuilder(
            builder,
            meshcat,
            scene_config,
            sensed_port,
        )
        if isinstance(controller, SoftCaptureController):
            from rpod.systems.scene import PlannedPathOverlay

            overlay = builder.AddNamedSystem(
                "scene.planned_path",
                PlannedPathOverlay(meshcat, visualization.publish_period_s),
            )
            connect(controller.GetOutputPort("planned_path"), overlay.GetInputPort("planned_path"))

    diagram = builder.Build()
    diagram.set_name(scenario.description or "rpod")
    handles = DiagramHandles(
        orbital, target_attitude, chaser_attitude, monitor, controller, bank, loggers, layout, scene
    )
    return diagram, handles


@dataclasses.dataclass
class SimulationResult:
    """What `simulate` returns.

    Attributes:
        log: time series keyed as in log.npz (time is the first axis of every array).
        summary: metrics, status and timings (the content of summary.json).
    """

    log: dict
    summary: dict


def _sample_final_state(context, handles: DiagramHandles) -> None:
    """Adds the state where the simulation stopped to every log, unless it is already there.

    The loggers sample every log_period_s; the run ends at duration_s (or where the integrator
    failed), which need not be a sample time. The final metrics (sim_time_s, the final state,
    delta-v) are read from the log's last row, so that row must be the simulation's end.
    """
    now = context.get_time()
    for logger in handles.loggers.values():
        times = logger.FindLog(context).sample_times()
        if len(times) == 0 or times[-1] < now:
            logger.ForcedPublish(logger.GetMyContextFromRoot(context))


def _collect_log(diagram, context, handles: DiagramHandles, scenario: Scenario) -> dict:
    """Turns the loggers' samples into the named arrays of log.npz."""
    raw = {}
    for key, logger in handles.loggers.items():
        samples = logger.FindLog(context)
        raw[key] = (samples.sample_times(), samples.data().T)
    t = raw["relative_state_L"][0]
    count = len(t)
    data = {key: value[1][:count] for key, value in raw.items()}
    log = {"t": t}
    log["p_LC_L"], log["v_LC_L"] = (
        data["relative_state_L"][:, 0:3],
        data["relative_state_L"][:, 3:6],
    )
    log["q_IT"], log["w_IT_T"] = data["target_attitude"][:, 0:4], data["target_attitude"][:, 4:7]
    log["q_IC"], log["w_IC_C"] = data["chaser_attitude"][:, 0:4], data["chaser_attitude"][:, 4:7]
    log["q_IL"], log["w_IL_L"] = data["q_IL"], data["w_IL_L"]
    log["p_IT_I"], log["v_IT_I"] = data["target_state_I"][:, 0:3], data["target_state_I"][:, 3:6]
    log["p_IC_I"], log["v_IC_I"] = data["chaser_state_I"][:, 0:3], data["chaser_state_I"][:, 3:6]
    log["chaser_mass_kg"] = data["chaser_mass"][:, 0]
    log["propellant_kg"] = scenario.chaser.mass_kg - log["chaser_mass_kg"]
    for key in ("separation_m", "corridor_violation_rad", "capture_speed_m_s"):
        log[key] = data[key][:, 0]
    n = handles.layout.count if handles.layout is not None else 0
    zeros = np.zeros((count, n))
    log["thruster_duty"] = data.get("thruster_duty", zeros)
    log["thruster_on"] = data.get("thruster_on", zeros)
    log["command_clipped"] = data.get("command_clipped", zeros)
    # Without PWM the duty is applied as throttle: delivered equals commanded.
    log["thruster_delivered_duty"] = data.get("thruster_delivered_duty", log["thruster_duty"])
    log["body_wrench"] = data.get("body_wrench", np.zeros((count, 6)))
    for key in ("body_wrench_desired", "hold_point_L", "reference_L", "force_feedforward_L"):
        if key in data:
            log[key] = data[key]
    for key in ("controller_mode", "planner_status"):
        if key in data:
            log[key] = data[key][:, 0].astype(np.int64)
    return log


def _json_safe(record: dict) -> dict:
    """The record with non-finite floats as None (strict JSON has no NaN)."""
    return {
        key: None if isinstance(value, float) and not math.isfinite(value) else value
        for key, value in record.items()
    }


def _plan_knots(records: list[dict], dt: float) -> dict:
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
    return {"plan_knots_t": t, "plan_knots_p_LC_L": x[..., :3], "plan_knots_v_LC_L": x[..., 3:],
            "plan_knots_u_L": u}  # fmt: skip


def capture_outcome(log: dict, scenario: Scenario) -> dict:
    """The soft-capture criterion on a run's log (paper 000's eps_p, eps_v; Table I).

    Capture succeeds at the first log sample where the capture points -- the chaser's D_c
    (`chaser.capture_point_C`, in C) and the target's D_t (`target.docking_port_T`, in T) --
    are within eps_p of each other and their relative (inertial) speed is within eps_v
    (`capture_speed_m_s` of the SafetyMonitor), provided the true polytopes never touched
    before (`separation_m` > 0 at every sample up to and including that one). Contact is
    checked at the log samples: log at the control period for a run whose verdict matters.

    Returns:
        {success, reason, time_s, position_error_m, speed_error_m_s, contact_after_s,
        planned_time_s}: the errors at the capture sample, or at the sample closest to meeting
        both tolerances (least max(position / eps_p, speed / eps_v)) when it failed;
        `contact_after_s` is the first contact after a successful capture (NaN if none: contact
        after capture does not undo it, but a hold the thrusters cannot sustain -- a fast tumble
        needs more centripetal force than they have -- ends in one, and a user should see it);
        `planned_time_s` is the final knot of the last accepted plan (NaN without one).
    """
    planner = scenario.controller.soft_capture.planner
    eps_p, eps_v = planner.capture_position_tol_m, planner.capture_speed_tol_m_s
    D_c = np.asarray(scenario.chaser.capture_point_C, float)
    D_t = np.asarray(scenario.target.docking_port_T, float)
    position_error = np.empty(len(log["t"]))
    for i, (p_LC_L, q_IL, q_IT, q_IC) in enumerate(
        zip(log["p_LC_L"], log["q_IL"], log["q_IT"], log["q_IC"])
    ):
        R_LI = rotation_from_wxyz(q_IL).T
        p_E_L = p_LC_L + R_LI @ rotation_from_wxyz(q_IC) @ D_c  # chaser capture point
        p_D_L = R_LI @ rotation_from_wxyz(q_IT) @ D_t  # target capture point
        p_DE_L = p_E_L - p_D_L
        position_error[i] = np.linalg.norm(p_DE_L)
    speed = np.asarray(log["capture_speed_m_s"], float)
    separation = np.asarray(log["separation_m"], float)
    met = np.flatnonzero((position_error <= eps_p) & (speed <= eps_v))
    contact = np.flatnonzero(~(separation > 0.0))
    outcome = {"success": False, "reason": "", "time_s": float("nan"),
               "contact_after_s": float("nan")}  # fmt: skip
    if len(met) and (not len(contact) or contact[0] > met[0]):
        i = int(met[0])
        outcome.update(success=True, reason=f"capture points within eps_p = {eps_p} m and "
                       f"eps_v = {eps_v} m/s with no contact before")  # fmt: skip
        if len(contact):
            outcome["contact_after_s"] = float(log["t"][int(contact[0])])
    elif len(contact) and (not len(met) or contact[0] <= met[0]):
        i = int(contact[0])
        outcome["reason"] = f"contact: the true polytopes touched at t = {log['t'][i]:.2f} s"
    else:
        i = int(np.argmin(np.maximum(position_error / eps_p, speed / eps_v)))
        if not np.any(position_error <= eps_p):
            outcome["reason"] = (f"position: the capture points never came within eps_p = "
                                 f"{eps_p} m (closest {position_error.min():.3f} m)")  # fmt: skip
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


def _summary(log: dict, scenario: Scenario) -> dict:
    """Metrics of a finished run (see README, 'Outputs')."""
    mass0, mass = scenario.chaser.mass_kg, log["chaser_mass_kg"][-1]
    isp = scenario.thrusters.isp_s
    summary = {
        "sim_time_s": float(log["t"][-1]),
        # Sum over thrusters of impulse / mass: with one Isp, exactly g0 Isp ln(m0 / m).
        "delta_v_m_s": float(STANDARD_GRAVITY_M_S2 * isp * math.log(mass0 / mass)),
        "propellant_kg": float(mass0 - mass),
        "min_separation_m": float(np.min(log["separation_m"])),
        "max_corridor_violation_deg": float(np.degrees(np.max(log["corridor_violation_rad"]))),
        "final_p_LC_L": log["p_LC_L"][-1].tolist(),
        "final_range_m": float(np.linalg.norm(log["p_LC_L"][-1])),
        "final_speed_m_s": float(np.linalg.norm(log["v_LC_L"][-1])),
        "final_capture_speed_m_s": float(log["capture_speed_m_s"][-1]),
        "clipped_command_samples": int(np.count_nonzero(log["command_clipped"])),
    }
    if "hold_point_L" in log:
        p_H = log["hold_point_L"][-1]
        R_IL = rotation_from_wxyz(log["q_IL"][-1])
        R_LT = R_IL.T @ rotation_from_wxyz(log["q_IT"][-1])
        w_LT_L = R_LT @ log["w_IT_T"][-1] - log["w_IL_L"][-1]
        hold_error = float(np.linalg.norm(log["p_LC_L"][-1] - p_H))
        speed_error = float(np.linalg.norm(log["v_LC_L"][-1] - np.cross(w_LT_L, p_H)))
        summary["final_hold_error_m"] = hold_error
        summary["final_hold_speed_error_m_s"] = speed_error
        summary["hold_reached"] = bool(
            hold_error < HOLD_POSITION_TOLERANCE_M and speed_error < HOLD_SPEED_TOLERANCE_M_S
        )
    return summary


def simulate(scenario: Scenario, meshcat=None) -> SimulationResult:
    """Builds and simulates a scenario; returns its logs and summary.

    Integrator failures do not raise: the run stops there, and `summary['status']` says why
    ('ok' or 'failed: ...'); the logs hold what was simulated.
    """
    start = time.perf_counter()
    diagram, handles = build_diagram(scenario, meshcat)
    simulator = Simulator(diagram)
    integrator = scenario.integrator
    ApplySimulatorConfig(
        SimulatorConfig(
            integration_scheme=integrator.scheme,
            accuracy=integrator.accuracy,
            max_step_size=integrator.max_step_s,
            use_error_control=integrator.scheme != "runge_kutta2",
            target_realtime_rate=0.0,
            publish_every_time_step=False,
        ),
        simulator,
    )
    if meshcat is not None:
        from rpod.diagrams.recording import start_recording

        start_recording(meshcat, fps=max(1.0 / scenario.visualization.publish_period_s, 1.0))
    # Wall time from here: Initialize runs initialization events (the soft-capture controller's
    # first plan), which belong to the simulation's cost, not the build's.
    built = time.perf_counter()
    status = "ok"
    try:
        simulator.Initialize()
        simulator.AdvanceTo(scenario.duration_s)
    except RuntimeError as error:
        status = f"failed: {str(error).splitlines()[0]}"
    finished = time.perf_counter()
    if meshcat is not None:
        meshcat.StopRecording()
        meshcat.PublishRecording()
    context = simulator.get_context()
    _sample_final_state(context, handles)
    log = _collect_log(diagram, context, handles, scenario)
    summary = {"status": status, **_summary(log, scenario)}
    if isinstance(handles.controller, SoftCaptureController):
        records = handles.controller.plan_records(handles.controller.GetMyContextFromRoot(context))
        dt = scenario.controller.soft_capture.planner.dt_s
        log.update(_plan_knots(records, dt))
        capture = capture_outcome(log, scenario)
        accepted = [r for r in records if r["accepted"]]
        capture["planned_time_s"] = (
            accepted[-1]["t_s"] + (accepted[-1]["N"] - 1) * dt if accepted else float("nan")
        )
        if not accepted and not capture["success"]:
            last = records[-1] if records else {"status": "none", "reason": "no planner call"}
            capture["reason"] = f"no plan: {last['status']}: {last['reason']}"
        summary["capture"] = _json_safe(capture)
        summary["plans"] = [
            _json_safe({key: value for key, value in r.items() if key not in ("x", "u")}
                       | {"check_violations": _json_safe(r.get("check_violations", {}))})
            for r in records
        ]  # fmt: skip
        summary["planner_status"] = records[-1]["status"] if records else "none"
        # Flat scalars for campaign reports (which summarise top-level numbers and booleans).
        first = records[0] if records else {}
        summary.update(_json_safe({
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
        }))  # fmt: skip
        summary["planner_status_codes"] = list(PLANNER_STATUSES)
        summary["controller_mode_codes"] = list(CONTROLLER_MODES)
    integ = simulator.get_integrator()
    summary.update(
        wall_time_s=finished - built,
        build_time_s=built - start,
        real_time_factor=float(context.get_time() / max(finished - built, 1e-9)),
        integrator_steps=int(integ.get_num_steps_taken()),
        derivative_evaluations=int(integ.get_num_derivative_evaluations()),
    )
    return SimulationResult(log=log, summary=summary)
