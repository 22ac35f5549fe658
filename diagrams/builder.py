"""Wires a `Scenario` into a Drake Diagram with loggers, and simulates it.

Owns: `build_diagram` (systems named in the diagram, loggers on every key signal, the Meshcat
scene when asked), `simulate` (a `SimulationResult` with logs, metrics and timings) and the
scenario-to-system translation (thruster presets, initial attitudes).
Does not own: files and the command line (rpod.scenarios, rpod.diagrams.outputs).

Signal flow (one period of delay between the controller's sample and the thrusters, as on a
real flight computer: the PWM latches the duty computed at the previous sample). The controller
is whatever plug-in the scenario's `controller: !Tag` names (rpod.diagrams.controller_seam); it
reads the sensed bundle and drives one of the actuation paths, which the builder wires:

    truth --relative state, LVLH, both attitudes--> sensed (Multiplexer) --> controller, monitor
    path 1: controller --body wrench--> WrenchAllocator --duty--> PwmModulator --on/off--> truth
    path 2: controller --per-thruster levels--> PwmModulator --on/off--> truth
    (the truth holds the thruster bank: rpod.systems.truth)

The plug-in's `results` adds its summary entries (and the mission outcome) and log arrays.
"""

import dataclasses
import math
import time

import numpy as np
from pydrake.systems.analysis import ApplySimulatorConfig, Simulator, SimulatorConfig
from pydrake.systems.framework import Diagram, DiagramBuilder
from pydrake.systems.primitives import (
    ConstantVectorSource,
    LogVectorOutput,
    Multiplexer,
)

from rpod.diagrams import controller_seam
from rpod.diagrams.controller_seam import Actuation
from rpod.diagrams.scenario import (
    Scenario,
    body_polytopes,
    chaser_rotation_in_lvlh,
    target_rotation_in_lvlh,
    validate_scenario,
)
from rpod.models import thrusters as presets
from rpod.models.frames import quaternion_wxyz, rotation_from_wxyz
from rpod.models.thrusters import STANDARD_GRAVITY_M_S2, ThrusterLayout
from rpod.systems.allocator import WrenchAllocator
from rpod.systems.ideal_actuator import IdealActuator
from rpod.systems.orbital_dynamics import OrbitalDynamics
from rpod.systems.pwm import PwmModulator
from rpod.systems.rigid_body_attitude import RigidBodyAttitude
from rpod.systems.safety_monitor import SafetyMonitor
from rpod.systems.sensed import SENSED_FIELDS, SENSED_PORT
from rpod.systems.thruster_bank import ThrusterBank
from rpod.systems.truth import Truth, initial_orbit_state, lvlh_of


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
    controller: object | None  # the controller plug-in's system (None: coasting)
    bank: ThrusterBank | None
    loggers: dict  # log key -> VectorLogSink
    layout: ThrusterLayout | None
    scene: object | None
    wiring: controller_seam.ControllerWiring | None = None  # what the plug-in handed back


def build_diagram(scenario: Scenario, meshcat=None) -> tuple[Diagram, DiagramHandles]:
    """Builds the scenario's diagram; draws it in `meshcat` when one is given."""
    validate_scenario(scenario)
    builder = DiagramBuilder()
    connect = builder.Connect
    chaser, target = scenario.chaser, scenario.target
    layout = make_thruster_layout(scenario) if scenario.thrusters.enabled else None
    # Initial attitudes are given relative to LVLH; the truth holds them relative to ECI. R_IL0
    # goes through the q_IL quaternion, as the truth's own q_IL output gives it.
    R_IL0 = rotation_from_wxyz(
        quaternion_wxyz(lvlh_of(*initial_orbit_state(scenario.orbit), scenario.orbit.gravity)[0])
    )
    J_T = np.asarray(target.inertia_kg_m2, float)
    J_C = np.asarray(chaser.inertia_kg_m2, float)
    # The sensed bundle first, then the controller (it says which actuation path it drives),
    # then the truth, built for that path.
    bundle = builder.AddNamedSystem("sensed", Multiplexer([size for _, size in SENSED_FIELDS]))
    sensed_port = bundle.get_output_port()
    plugin = controller_seam.plugin_for(scenario.controller)
    wiring = plugin.add_to_diagram(builder, scenario, sensed_port) if plugin else None
    ideal = wiring is not None and wiring.actuation is Actuation.IDEAL
    # One system holds the whole continuous truth: both orbits, both attitudes, the chaser's
    # mass and the thrusters' wrench (rpod.systems.truth says why).
    truth = builder.AddNamedSystem(
        "truth",
        Truth(
            scenario.orbit,
            np.asarray(chaser.p_LC_L, float),
            np.asarray(chaser.v_LC_L, float),
            chaser.mass_kg,
            J_T,
            quaternion_wxyz(R_IL0 @ target_rotation_in_lvlh(scenario)),
            np.radians(target.w_IT_T_deg_s),
            J_C,
            quaternion_wxyz(R_IL0 @ chaser_rotation_in_lvlh(scenario)),
            np.radians(chaser.w_IC_C_deg_s),
            None if ideal else layout,
            wrench_input=ideal,
        ),
    )
    for index, (name, _) in enumerate(SENSED_FIELDS):
        connect(truth.GetOutputPort(name), bundle.get_input_port(index))
    # The handles (DiagramHandles) name the one truth system for each of its old roles.
    orbital = target_attitude = chaser_attitude = truth

    loggers = {}
    period = scenario.log_period_s

    def log(key, port):
        loggers[key] = LogVectorOutput(port, builder, period)

    bank = controller = None
    chaser_shape, target_shape = body_polytopes(scenario)
    if layout is not None and not ideal:
        bank = truth
        log("body_wrench", truth.GetOutputPort("body_wrench"))
        log("command_clipped", truth.GetOutputPort("command_clipped"))

    relative = orbital.GetOutputPort("relative_state_L")
    q_IL = orbital.GetOutputPort("q_IL")
    w_IL_L = orbital.GetOutputPort("w_IL_L")
    sensed = {
        "relative_state_L": relative,
        "q_IL": q_IL,
        "w_IL_L": w_IL_L,
        "target_attitude": truth.GetOutputPort("target_attitude"),
        "chaser_attitude": truth.GetOutputPort("chaser_attitude"),
    }
    if wiring is not None:
        controller = wiring.system
        for name, port in wiring.logged.items():
            log(name, port)
    if bank is not None:
        if wiring is None:
            idle = builder.AddNamedSystem("idle", ConstantVectorSource(np.zeros(layout.count)))
            duty = idle.get_output_port()
        elif wiring.actuation is Actuation.BODY_WRENCH:
            allocator = builder.AddNamedSystem("wrench_allocator", WrenchAllocator(layout))
            connect(wiring.command, allocator.GetInputPort("body_wrench_desired"))
            duty = allocator.GetOutputPort("thruster_duty")
        elif wiring.actuation is Actuation.THRUSTER_COMMANDS:
            duty = wiring.command
        else:
            raise NotImplementedError(f"actuation path {wiring.actuation} is not wired yet")
        log("thruster_duty", duty)
        if scenario.thrusters.pwm:
            pwm = builder.AddNamedSystem(
                "pwm",
                PwmModulator(
                    layout.count,
                    wiring.control_period_s if wiring is not None else 0.1,
                    scenario.thrusters.subdivisions,
                    scenario.thrusters.min_on_slots,
                ),
            )
            connect(duty, pwm.GetInputPort("thruster_duty"))
            command = pwm.GetOutputPort("thruster_on")
            log("thruster_delivered_duty", pwm.GetOutputPort("delivered_duty"))
        else:
            command = duty
        connect(command, truth.GetInputPort("thruster_command"))
        log("thruster_on", command)
    if ideal:
        command = wiring.ideal
        actuator = builder.AddNamedSystem(
            "ideal_actuator",
            IdealActuator(
                command.quantity,
                command.frame,
                command.bound,
                command.limit,
                scenario.thrusters.isp_s,
            ),
        )
        connect(wiring.command, actuator.GetInputPort("command"))
        connect(sensed_port, actuator.GetInputPort("sensed"))
        connect(truth.GetOutputPort("chaser_mass"), actuator.GetInputPort("chaser_mass"))
        connect(actuator.GetOutputPort("body_wrench"), truth.GetInputPort("body_wrench"))
        connect(
            actuator.GetOutputPort("propellant_mass_flow"),
            truth.GetInputPort("propellant_mass_flow"),
        )
        log("body_wrench", actuator.GetOutputPort("body_wrench"))

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
    for name in (
        "separation_m",
        "corridor_violation_rad",
        "capture_speed_m_s",
        "capture_distance_m",
        "port_distance_m",
    ):
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
            corridor_length_m=target.corridor_length_m,
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
        if wiring is not None:
            plugin.add_scene_extras(builder, meshcat, scenario, wiring)

    diagram = builder.Build()
    diagram.set_name(scenario.description or "rpod")
    handles = DiagramHandles(
        orbital,
        target_attitude,
        chaser_attitude,
        monitor,
        controller,
        bank,
        loggers,
        layout,
        scene,
        wiring,
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
    for key in (
        "separation_m",
        "corridor_violation_rad",
        "capture_speed_m_s",
        "capture_distance_m",
        "port_distance_m",
    ):
        log[key] = data[key][:, 0]
    n = handles.layout.count if handles.layout is not None else 0
    zeros = np.zeros((count, n))
    log["thruster_duty"] = data.get("thruster_duty", zeros)
    log["thruster_on"] = data.get("thruster_on", zeros)
    log["command_clipped"] = data.get("command_clipped", zeros)
    # Without PWM the duty is applied as throttle: delivered equals commanded.
    log["thruster_delivered_duty"] = data.get("thruster_delivered_duty", log["thruster_duty"])
    log["body_wrench"] = data.get("body_wrench", np.zeros((count, 6)))
    for key in handles.wiring.logged if handles.wiring is not None else ():
        log[key] = data[key]  # the controller's own signals, under the names it gave them
    return log


def _max_in_corridor(log: dict, corridor_length_m: float) -> float | None:
    """The largest corridor violation [deg] at the samples within the corridor's extent
    (port_distance_m <= corridor_length_m): negative when always inside the cone (the least
    margin), None when the chaser never came within the extent."""
    inside = log["port_distance_m"] <= corridor_length_m
    if not np.any(inside):
        return None
    return float(np.degrees(np.max(log["corridor_violation_rad"][inside])))


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
        # Only where the capture point is within the corridor's extent (TargetConfig).
        "max_corridor_violation_deg": _max_in_corridor(log, scenario.target.corridor_length_m),
        "final_p_LC_L": log["p_LC_L"][-1].tolist(),
        "final_range_m": float(np.linalg.norm(log["p_LC_L"][-1])),
        "final_speed_m_s": float(np.linalg.norm(log["v_LC_L"][-1])),
        "final_capture_speed_m_s": float(log["capture_speed_m_s"][-1]),
        "clipped_command_samples": int(np.count_nonzero(log["command_clipped"])),
    }
    return summary


def _end_time_s(scenario: Scenario, handles: DiagramHandles, context, warnings: list) -> float:
    """Where the run ends: duration_s, or the controller's planned end plus stop.hold_s when
    stop.at_plan_end asks and it is earlier. A plan that outlasts the run is a warning."""
    end_s = scenario.duration_s
    if handles.wiring is None:
        return end_s
    plugin = controller_seam.plugin_for(scenario.controller)
    planned = plugin.planned_end_s(handles.wiring, context)
    if planned is None:
        return end_s
    if planned > end_s:
        warnings.append(
            f"the controller's plan ends at {planned:.1f} s, after the run's end at "
            f"{end_s:.1f} s: raise duration_s (stop.at_plan_end then ends the run at the plan)"
        )
    if scenario.stop.at_plan_end:
        end_s = min(end_s, planned + scenario.stop.hold_s)
    return end_s


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
    # Wall time from here: Initialize runs initialization events (a planning controller's
    # first plan), which belong to the simulation's cost, not the build's.
    built = time.perf_counter()
    status, warnings = "ok", []
    try:
        simulator.Initialize()
        end_s = _end_time_s(scenario, handles, simulator.get_context(), warnings)
        simulator.AdvanceTo(end_s)
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
    outcome = None
    if handles.wiring is not None:
        results = controller_seam.plugin_for(scenario.controller).results(
            scenario, handles.wiring, context, log
        )
        log.update(results.log)
        summary.update(results.summary)
        outcome = results.outcome
    summary["warnings"] = warnings
    # "Did the simulation run" (status) apart from "did the mission succeed" (mission).
    summary["mission"] = {
        "success": None if outcome is None else bool(outcome.success),
        "outcome": "no mission criterion (no controller)" if outcome is None else outcome.text,
    }
    integ = simulator.get_integrator()
    summary.update(
        wall_time_s=finished - built,
        build_time_s=built - start,
        real_time_factor=float(context.get_time() / max(finished - built, 1e-9)),
        integrator_steps=int(integ.get_num_steps_taken()),
        derivative_evaluations=int(integ.get_num_derivative_evaluations()),
    )
    return SimulationResult(log=log, summary=summary)
