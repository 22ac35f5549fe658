"""Wires a `Scenario` into a Drake Diagram with loggers, and simulates it.

Owns: `build_diagram` (systems named in the diagram, loggers on every key signal, the Meshcat
scene when asked), `simulate` (a `SimulationResult` with logs, metrics and timings) and the
scenario-to-system translation (thruster presets, initial attitudes).
Does not own: files and the command line (rpod.scenarios, rpod.diagrams.outputs).

Signal flow of a controlled scenario (one period of delay between the controller's sample and
the thrusters, as on a real flight computer: the PWM latches the duty computed at the previous
sample):

    OrbitalDynamics --relative_state_L, q_IL, w_IL_L--> HoldPointController
    RigidBodyAttitude (target, chaser) --attitude--> HoldPointController
    HoldPointController --body_wrench_desired--> WrenchAllocator --thruster_duty--> PwmModulator
    PwmModulator --thruster_on--> ThrusterBank --body_wrench--> OrbitalDynamics, chaser attitude
"""

import dataclasses
import math
import time

import numpy as np
from pydrake.systems.analysis import ApplySimulatorConfig, Simulator, SimulatorConfig
from pydrake.systems.framework import Diagram, DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource, Demultiplexer, LogVectorOutput

from rpod.models import thrusters as presets
from rpod.models.frames import quaternion_wxyz, rotation_from_rpy_deg, rotation_from_wxyz
from rpod.models.shapes import ConvexPolytope
from rpod.models.thrusters import STANDARD_GRAVITY_M_S2, ThrusterLayout
from rpod.systems.allocator import WrenchAllocator
from rpod.systems.hold_point_controller import HoldPointController
from rpod.systems.orbital_dynamics import OrbitalDynamics
from rpod.systems.pwm import PwmModulator
from rpod.systems.rigid_body_attitude import RigidBodyAttitude
from rpod.systems.safety_monitor import SafetyMonitor
from rpod.systems.thruster_bank import ThrusterBank

from rpod.diagrams.scenario import Scenario, validate_scenario

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


def target_rotation_in_lvlh(scenario: Scenario) -> np.ndarray:
    """R_LT at t = 0: from q_LT when given, else from rpy_LT_deg."""
    target = scenario.target
    if target.q_LT:
        return rotation_from_wxyz(np.asarray(target.q_LT, float))
    return rotation_from_rpy_deg(target.rpy_LT_deg)


@dataclasses.dataclass
class DiagramHandles:
    """The named systems and loggers of a built diagram (None where a scenario has none)."""

    orbital: OrbitalDynamics
    target_attitude: RigidBodyAttitude
    chaser_attitude: RigidBodyAttitude
    monitor: SafetyMonitor
    controller: HoldPointController | None
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
            for name, port in sensed.items():
                connect(port, controller.GetInputPort(name))
            allocator = builder.AddNamedSystem("wrench_allocator", WrenchAllocator(layout))
            connect(
                controller.GetOutputPort("body_wrench_desired"),
                allocator.GetInputPort("body_wrench_desired"),
            )
            duty = allocator.GetOutputPort("thruster_duty")
            log("body_wrench_desired", controller.GetOutputPort("body_wrench_desired"))
            log("hold_point_L", controller.GetOutputPort("hold_point_L"))
            log("reference_L", controller.GetOutputPort("reference_L"))
        else:
            idle = builder.AddNamedSystem("idle", ConstantVectorSource(np.zeros(layout.count)))
            duty = idle.get_output_port()
        log("thruster_duty", duty)
        if scenario.thrusters.pwm:
            pwm = builder.AddNamedSystem(
                "pwm",
                PwmModulator(
                    layout.count,
                    scenario.controller.hold_point.control_period_s,
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
            ConvexPolytope.box(target.size_m),
            ConvexPolytope.box(chaser.size_m),
            target.docking_port_T,
            target.docking_axis_T,
            math.radians(target.corridor_half_angle_deg),
            chaser.capture_point_C,
        ),
    )
    for name, port in sensed.items():
        connect(port, monitor.GetInputPort(name))

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
            publish_period_s=visualization.publish_period_s,
            trail=visualization.trail,
            trail_max_points=visualization.trail_max_points,
            camera_position_L_m=list(visualization.camera_position_L_m),
        )
        scene = RendezvousScene.AddToBuilder(
            builder,
            meshcat,
            scene_config,
            relative,
            q_IL,
            sensed["target_attitude"],
            sensed["chaser_attitude"],
        )

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
    for key in ("body_wrench_desired", "hold_point_L", "reference_L"):
        if key in data:
            log[key] = data[key]
    return log


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
    simulator.Initialize()
    built = time.perf_counter()
    status = "ok"
    try:
        simulator.AdvanceTo(scenario.duration_s)
    except RuntimeError as error:
        status = f"failed: {str(error).splitlines()[0]}"
    finished = time.perf_counter()
    if meshcat is not None:
        meshcat.StopRecording()
        meshcat.PublishRecording()
    context = simulator.get_context()
    log = _collect_log(diagram, context, handles, scenario)
    summary = {"status": status, **_summary(log, scenario)}
    integ = simulator.get_integrator()
    summary.update(
        wall_time_s=finished - built,
        build_time_s=built - start,
        real_time_factor=float(context.get_time() / max(finished - built, 1e-9)),
        integrator_steps=int(integ.get_num_steps_taken()),
        derivative_evaluations=int(integ.get_num_derivative_evaluations()),
    )
    return SimulationResult(log=log, summary=summary)
