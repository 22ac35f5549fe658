"""Wires a `Scenario` into a Drake Diagram with loggers.

Owns: `build_diagram` (the truth, the sensed bundle, the controller plug-in and the actuation
path it drives, the safety monitor, loggers on every key signal, the Meshcat scene when asked),
`DiagramHandles`, and `sensed_at_start` (the bundle a truth-fed controller reads first, which
`rpod plan` plans from: rpod.diagrams.controller_seam, "Planning once at start").
Does not own: the scenario's model objects (thruster presets, shapes, initial attitudes:
scenario.py), running and summarising (simulate.py, metrics.py), files (rpod.scenarios).

Signal flow (the PWM latches, at each period start, the duty the controller holds then:
systems/pwm.py says which sample that is). The controller
is whatever plug-in the scenario's `controller: !Tag` names (rpod.diagrams.controller_seam); it
reads the sensed bundle and drives one of the actuation paths, which the builder wires:

    truth --relative state, LVLH, attitudes, target orbit--> sensed (Multiplexer)
          --> controller, monitor
    with `navigation: !Ekf`, the controller reads an estimate instead (the monitor, an ideal
    actuator and the scene still the truth), and is built with the target inertia the
    navigation estimated by t = 0 (`with_estimated_inertia`):
    truth --> truth_sensed (Multiplexer), chaser_state_I --> navigation --sensed--> controller
    path 1: controller --body wrench--> WrenchAllocator --duty--> PwmModulator --on/off--> truth
    path 2: controller --per-thruster levels--> PwmModulator --on/off--> truth
            controller --force vectors (gimbaled)--> ThrusterBank --wrench, mass flow--> truth
    path 3: controller --ideal force/acceleration--> IdealActuator --wrench, mass flow--> truth
    (a fixed bank lives inside the truth: rpod.systems.truth)

The plug-in's `results` adds its summary entries (and the mission outcome) and log arrays.
"""

import dataclasses
import math

import numpy as np
from pydrake.systems.framework import Diagram, DiagramBuilder
from pydrake.systems.primitives import (
    ConstantVectorSource,
    LogVectorOutput,
    Multiplexer,
)

from rpod.diagrams import controller_seam
from rpod.diagrams.controller_seam import Actuation
from rpod.diagrams.navigation import add_navigation, with_estimated_inertia
from rpod.diagrams.scenario import (
    Scenario,
    body_polytopes,
    chaser_rotation_in_lvlh,
    docking_geometry,
    initial_relative_state_L,
    make_thruster_layout,
    target_rotation_in_lvlh,
    validate_scenario,
)
from rpod.models.frames import quaternion_wxyz, rotation_from_wxyz
from rpod.models.orbit import initial_orbit_state, lvlh_of
from rpod.models.thrusters import ThrusterLayout
from rpod.systems.allocator import WrenchAllocator
from rpod.systems.ideal_actuator import IdealActuator
from rpod.systems.lifetime import release_diagram
from rpod.systems.navigation import NAVIGATION_LOG_KEYS, RelativeNavigation
from rpod.systems.navigation_config import Ekf
from rpod.systems.pwm import PwmModulator
from rpod.systems.safety_monitor import SafetyMonitor
from rpod.systems.sensed import SENSED_FIELDS, SENSED_PORT
from rpod.systems.thruster_bank import ThrusterBank
from rpod.systems.truth import Truth


@dataclasses.dataclass
class DiagramHandles:
    """The named systems and loggers of a built diagram (None where a scenario has none)."""

    orbital: Truth  # the one truth system, under each of the roles it took over
    target_attitude: Truth
    chaser_attitude: Truth
    monitor: SafetyMonitor
    controller: object | None  # the controller plug-in's system (None: coasting)
    bank: Truth | ThrusterBank | None  # the truth (fixed bank), a ThrusterBank (gimbaled), None
    loggers: dict  # log key -> VectorLogSink
    layout: ThrusterLayout | None
    scene: object | None
    wiring: controller_seam.ControllerWiring | None = None  # what the plug-in handed back
    scene_driver: object | None = None  # publishes the scene from the Simulator's monitor
    navigation: RelativeNavigation | None = None  # None: the controller reads the truth


def make_truth(scenario: Scenario, layout: ThrusterLayout | None, wrench_input: bool) -> Truth:
    """The scenario's truth system: with a fixed thruster layout inside, or a wrench input, or
    neither (coasting: the navigation's lead-in)."""
    chaser, target = scenario.chaser, scenario.target
    # Initial attitudes are given relative to LVLH; the truth holds them relative to ECI. R_IL0
    # goes through the q_IL quaternion, as the truth's own q_IL output gives it.
    R_IL0 = rotation_from_wxyz(
        quaternion_wxyz(lvlh_of(*initial_orbit_state(scenario.orbit), scenario.orbit.gravity)[0])
    )
    return Truth(
        scenario.orbit,
        *initial_relative_state_L(scenario),
        chaser.mass_kg,
        np.asarray(target.inertia_kg_m2, float),
        quaternion_wxyz(R_IL0 @ target_rotation_in_lvlh(scenario)),
        np.radians(target.w_IT_T_deg_s),
        np.asarray(chaser.inertia_kg_m2, float),
        quaternion_wxyz(R_IL0 @ chaser_rotation_in_lvlh(scenario)),
        np.radians(chaser.w_IC_C_deg_s),
        layout,
        wrench_input=wrench_input,
    )


def sensed_at_start(scenario: Scenario) -> np.ndarray:
    """The sensed vector (rpod.systems.sensed) the truth gives at t = 0: what a controller
    reads first under `navigation: !Truth`, number for number (the same truth outputs)."""
    truth = make_truth(scenario, None, False)
    context = truth.CreateDefaultContext()
    sensed = np.concatenate([truth.GetOutputPort(name).Eval(context) for name, _ in SENSED_FIELDS])
    release_diagram(truth)  # freed on return (rpod.systems.lifetime)
    return sensed


def build_diagram(scenario: Scenario, meshcat=None) -> tuple[Diagram, DiagramHandles]:
    """Builds the scenario's diagram; draws it in `meshcat` when one is given."""
    validate_scenario(scenario)
    builder = DiagramBuilder()
    connect = builder.Connect
    chaser, target = scenario.chaser, scenario.target
    layout = make_thruster_layout(scenario) if scenario.thrusters.enabled else None
    # Initial attitudes are given relative to LVLH; the truth holds them relative to ECI. R_IL0
    # goes through the q_IL quaternion, as the truth's own q_IL output gives it.

    # The sensed bundle first, then the controller (it says which actuation path it drives),
    # then the truth, built for that path.
    # The true bundle (what the monitor, an ideal actuator and the scene read), then what the
    # controller reads: the same bundle (navigation !Truth) or the navigation's estimate (!Ekf),
    # then the controller (it says which actuation path it drives), then the truth for that path.
    estimated = isinstance(scenario.navigation, Ekf)
    bundle = builder.AddNamedSystem(
        "truth_sensed" if estimated else "sensed",
        Multiplexer([size for _, size in SENSED_FIELDS]),
    )
    truth_port = bundle.get_output_port()
    navigation = None
    controller_scenario = scenario  # what the controller is built from
    if estimated:
        coasting_truth = make_truth(scenario, None, False)
        navigation = add_navigation(builder, scenario, coasting_truth)
        release_diagram(coasting_truth)  # its lead-in is flown: freed (rpod.systems.lifetime)
        sensed_port = navigation.GetOutputPort("sensed")
        controller_scenario = with_estimated_inertia(scenario, navigation)
    else:
        sensed_port = truth_port
    plugin = controller_seam.plugin_for(scenario.controller)
    wiring = plugin.add_to_diagram(builder, controller_scenario, sensed_port) if plugin else None
    actuation = plugin.actuation_for(scenario.controller) if wiring is not None else None
    ideal = actuation is Actuation.IDEAL
    gimbaled = layout is not None and layout.gimbaled and not ideal
    # The truth holds a fixed bank itself; an ideal actuator or a gimbaled bank (its force
    # vectors clipped by ThrusterBank) hands it a body wrench and a mass flow instead.
    # One system holds the whole continuous truth: both orbits, both attitudes, the chaser's
    # mass and the thrusters' wrench (rpod.systems.truth says why).
    truth = builder.AddNamedSystem(
        "truth", make_truth(scenario, None if ideal or gimbaled else layout, ideal or gimbaled)
    )
    for index, (name, _) in enumerate(SENSED_FIELDS):
        connect(truth.GetOutputPort(name), bundle.get_input_port(index))
    if navigation is not None:
        connect(truth_port, navigation.GetInputPort("truth_sensed"))
        connect(truth.GetOutputPort("chaser_state_I"), navigation.GetInputPort("chaser_state_I"))
    # The handles (DiagramHandles) name the one truth system for each of its old roles.
    orbital = target_attitude = chaser_attitude = truth

    loggers = {}
    period = scenario.log_period_s

    def log(key, port):
        loggers[key] = LogVectorOutput(port, builder, period)

    bank = controller = None
    chaser_shape, target_shape = body_polytopes(scenario)
    docking = docking_geometry(scenario)  # port, axis, corridor, hull: built once
    if gimbaled:
        bank = builder.AddNamedSystem("thruster_bank", ThrusterBank(layout))
        connect(bank.GetOutputPort("body_wrench"), truth.GetInputPort("body_wrench"))
        connect(
            bank.GetOutputPort("propellant_mass_flow"), truth.GetInputPort("propellant_mass_flow")
        )
    elif layout is not None and not ideal:
        bank = truth
    if bank is not None:
        log("body_wrench", bank.GetOutputPort("body_wrench"))
        log("command_clipped", bank.GetOutputPort("command_clipped"))

    relative = orbital.GetOutputPort("relative_state_L")
    q_IL = orbital.GetOutputPort("q_IL")
    w_IL_L = orbital.GetOutputPort("w_IL_L")
    sensed = {
        "relative_state_L": relative,
        "q_IL": q_IL,
        "w_IL_L": w_IL_L,
        "target_attitude": truth.GetOutputPort("target_attitude"),
        "chaser_attitude": truth.GetOutputPort("chaser_attitude"),
        "target_state_I": truth.GetOutputPort("target_state_I"),
    }
    if wiring is not None:
        controller = wiring.system
        for name, port in wiring.logged.items():
            log(name, port)
    if gimbaled:  # path 2 with force vectors (3 per thruster, in C): no PWM
        if wiring is None:
            idle = ConstantVectorSource(np.zeros(layout.command_size))
            forces = builder.AddNamedSystem("idle", idle).get_output_port()
        else:
            forces = wiring.command
        connect(forces, bank.GetInputPort("thruster_command"))
        log("thruster_force_C", forces)
    elif bank is not None:
        if wiring is None:
            idle = builder.AddNamedSystem("idle", ConstantVectorSource(np.zeros(layout.count)))
            duty = idle.get_output_port()
        elif actuation is Actuation.BODY_WRENCH:
            allocator = builder.AddNamedSystem("wrench_allocator", WrenchAllocator(layout))
            connect(wiring.command, allocator.GetInputPort("body_wrench_desired"))
            duty = allocator.GetOutputPort("thruster_duty")
        elif actuation is Actuation.THRUSTER_COMMANDS:
            duty = wiring.command
        else:
            raise NotImplementedError(f"actuation path {actuation} is not wired yet")
        log("thruster_duty", duty)
        if scenario.thrusters.pwm:
            pwm = builder.AddNamedSystem(
                "pwm",
                PwmModulator(
                    layout.count,
                    plugin.command_period_s(scenario.controller) if wiring is not None else 0.1,
                    scenario.thrusters.subdivisions,
                    scenario.thrusters.min_on_slots,
                    scheme=scenario.thrusters.modulation,
                    schmitt_hysteresis=scenario.thrusters.schmitt_hysteresis,
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
        connect(truth_port, actuator.GetInputPort("sensed"))  # the physics: true attitude
        connect(truth.GetOutputPort("chaser_mass"), actuator.GetInputPort("chaser_mass"))
        connect(actuator.GetOutputPort("body_wrench"), truth.GetInputPort("body_wrench"))
        connect(
            actuator.GetOutputPort("propellant_mass_flow"),
            truth.GetInputPort("propellant_mass_flow"),
        )
        log("body_wrench", actuator.GetOutputPort("body_wrench"))

    monitor = builder.AddNamedSystem(
        "safety_monitor",
        SafetyMonitor(docking, chaser_shape, chaser.capture_point_C),
    )
    connect(truth_port, monitor.GetInputPort(SENSED_PORT))

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
        "penetration_m",
        "corridor_violation_rad",
        "capture_speed_m_s",
        "capture_distance_m",
        "port_distance_m",
    ):
        log(name, monitor.GetOutputPort(name))
    if navigation is not None:
        log("navigation_sensed", sensed_port)  # what the controller read
        for name in ("estimate", "covariance", "navigation_status"):
            log(NAVIGATION_LOG_KEYS[name], navigation.GetOutputPort(name))

    scene = None
    if meshcat is not None:
        from rpod.systems.scene import RendezvousScene, SceneGeometry  # only when drawing

        # What the scene draws is the scenario's own geometry; how is its visualization block.
        geometry = SceneGeometry(
            target_box_size_m=list(target.size_m),
            chaser_box_size_m=list(chaser.size_m),
            docking_port_T=docking.p_TD_T.tolist(),
            docking_axis_T=docking.axis_T.tolist(),
            corridor_half_angle_deg=math.degrees(docking.corridor_half_angle_rad),
            corridor_length_m=docking.corridor_length_m,
            target_vertices_T=(target_shape.vertices.tolist() if target.shape != "box" else []),
            chaser_vertices_C=(chaser_shape.vertices.tolist() if chaser.shape != "box" else []),
        )
        scene = RendezvousScene.AddToBuilder(
            builder, meshcat, scenario.visualization, truth_port, geometry
        )
        if wiring is not None:
            plugin.add_scene_extras(builder, meshcat, scenario, wiring, scene)
        if navigation is not None:  # where the controller believes the target is
            from rpod.systems.navigation_scene import EstimatedTargetGhost

            ghost = builder.AddNamedSystem(
                "estimated_target",
                EstimatedTargetGhost(meshcat, geometry, scenario.visualization.publish_period_s),
            )
            connect(truth_port, ghost.GetInputPort("truth_sensed"))
            connect(sensed_port, ghost.GetInputPort("estimated_sensed"))

    # Every scene system (the bodies, the overlays, a method's extras) is published by one
    # driver from the Simulator's monitor: no drawing adds a step (rpod.systems.scene).
    scene_driver = None
    if meshcat is not None:
        from rpod.systems.scene import SceneDriver

        scene_driver = SceneDriver.for_systems(builder.GetSystems())
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
        scene_driver,
        navigation,
    )
    return diagram, handles
