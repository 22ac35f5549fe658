"""The `Scenario` dataclass: everything a run needs, loadable from YAML by hand.

Owns: the scenario schema (composing the configs that live beside their systems), its defaults
(every field has one that makes a scenario run) and its semantic validation, which raises
`ScenarioError` naming the field. Reading files and reporting errors to the user is
rpod.scenarios' job.

Units are SI; a field whose name ends in `_deg` or `_deg_s` is in degrees (per second).
"""

import dataclasses
import math
import typing

import numpy as np
from pydrake.systems.analysis import SimulatorConfig

from rpod.diagrams import controller_seam
from rpod.diagrams import mission as mission_choices
from rpod.models import modulation
from rpod.models import thrusters as presets
from rpod.models.config import CHOICES_KEY, ConfigError, check_bounds
from rpod.models.docking import DockingGeometry
from rpod.models.frames import rotation_from_rpy_deg, rotation_from_wxyz
from rpod.models.gravity import GRAVITY_MODELS, MIN_ALTITUDE_M
from rpod.models.orbit import OrbitConfig, epoch_utc_datetime64, initial_orbit_state, lvlh_of
from rpod.models.rigid_body import validate_inertia
from rpod.models.shapes import (
    ConvexPolytope,
    separation_distance,
    soft_capture_chaser_hull,
    soft_capture_target_hull,
)
from rpod.models.thrusters import ThrusterLayout
from rpod.planners.pointing import min_rotation
from rpod.systems import navigation_config as navigation_choices
from rpod.systems.scene import SceneConfig

THRUSTER_LAYOUTS = ("rcs_cube_12", "planar_8", "gimbaled_cuboid_8")
GIMBALED_LAYOUTS = ("gimbaled_cuboid_8",)  # per-thruster force vectors (paper 001 eqs. 16-17)
CHASER_SHAPES = ("box", "soft_capture_chaser")
TARGET_SHAPES = ("box", "soft_capture_target")
INTEGRATION_SCHEMES = (
    "runge_kutta2",
    "runge_kutta3",
    "runge_kutta5",
    "bogacki_shampine3",
)  # explicit: the truth is not stiff

# Bounds on the work one scenario may ask for (README, "What rpod guarantees"). Each is far
# beyond any rendezvous scenario and far below what would hang the run or exhaust memory.
MAX_ALTITUDE_M = 1.0e8  # 100,000 km: past GEO and the apogees of highly elliptic orbits
MAX_RANGE_M = 1.0e6  # |p_LC_L|: 1000 km, well past where relative navigation starts
MAX_RELATIVE_SPEED_M_S = 1.0e4  # |v_LC_L|
MAX_SPIN_DEG_S = 360.0  # one revolution a second; tumbling debris turns at a few deg/s
MAX_DURATION_S = 1.0e6  # 11.6 days of simulated time
MAX_SAMPLES = 1_000_000  # log samples, and scene frames, per run (~1 GB of log at most)
MAX_SUBDIVISIONS = 1000  # PWM slots per control period
MAX_EVENTS = 100_000_000  # controller samples x PWM slots, and max-size integrator steps
QUATERNION_NORM_TOLERANCE = 1e-3  # |q| - 1 within this is normalised (4-digit entries pass)


ScenarioError = ConfigError
"""A scenario field is invalid; `field` is its dotted path (e.g. 'target.inertia_kg_m2')."""


def _diag(values):
    return lambda: [[values[0], 0.0, 0.0], [0.0, values[1], 0.0], [0.0, 0.0, values[2]]]


@dataclasses.dataclass
class ChaserConfig:
    """The chaser spacecraft and its initial state relative to the target.

    Args:
        p_LC_L: initial position of the chaser's centre of mass in LVLH [m].
        v_LC_L: initial velocity seen in the rotating LVLH frame [m/s], or, with
            velocity_seen_in 'T', seen in the tumbling target's frame (expressed in L).
        velocity_seen_in: 'L' (default) or 'T': with 'T', v_LC_L = [0, 0, 0] starts the chaser
            at rest relative to the tumbling target, co-rotating with it (paper 004 Sec. 9's
            starts: zero velocity in the body frame).
        rpy_LC_deg: initial attitude relative to LVLH, roll-pitch-yaw [deg].
        point_at_target: instead of rpy_LC_deg, start with the capture axis (the direction of
            capture_point_C) on the line of sight to the target: the least rotation from L
            that turns it there (rpy_LC_deg must then be left at zero).
        w_IC_C_deg_s: initial angular velocity in the chaser body frame [deg/s].
        mass_kg: wet mass at t = 0 (the truth draws propellant from it).
        inertia_kg_m2: inertia about the centre of mass in C (constant) [kg m^2].
        size_m: box edge lengths along the C axes, for the separation check and the scene [m]
            (shape 'box').
        capture_point_C: the chaser's capture point (e.g. its docking mechanism) in C [m].
        shape: the true geometry, for the separation check, the scene and a soft-capture
            planner: 'box' (size_m) or 'soft_capture_chaser' (paper 000's hexagonal prism,
            rpod.models.shapes.soft_capture_chaser_hull; size_m is then unused).
    """

    p_LC_L: list[float] = dataclasses.field(default_factory=lambda: [0.0, -30.0, 0.0])
    v_LC_L: list[float] = dataclasses.field(default_factory=lambda: [0.0, 0.0, 0.0])
    velocity_seen_in: str = "L"
    rpy_LC_deg: list[float] = dataclasses.field(default_factory=lambda: [0.0, 0.0, 0.0])
    point_at_target: bool = False
    w_IC_C_deg_s: list[float] = dataclasses.field(default_factory=lambda: [0.0, 0.0, 0.0])
    mass_kg: float = 500.0
    inertia_kg_m2: list[list[float]] = dataclasses.field(default_factory=_diag([190, 190, 190]))
    size_m: list[float] = dataclasses.field(default_factory=lambda: [1.5, 1.5, 1.5])
    capture_point_C: list[float] = dataclasses.field(default_factory=lambda: [0.0, 0.0, 0.75])
    shape: str = "box"


@dataclasses.dataclass
class TargetConfig:
    """The tumbling target (torque-free rigid body at the LVLH origin).

    Args:
        q_LT: initial attitude relative to LVLH as a quaternion (w, x, y, z), of unit norm
            (within 1e-3, then normalised). Give q_LT or rpy_LT_deg, not both; neither is
            the identity.
        rpy_LT_deg: initial attitude relative to LVLH, roll-pitch-yaw [deg].
        w_IT_T_deg_s: initial angular velocity in the target body frame [deg/s].
        inertia_kg_m2: inertia about the centre of mass in T; any symmetric positive-definite
            matrix that satisfies the triangle inequality (non-diagonal allowed) [kg m^2].
        size_m: box edge lengths along the T axes [m] (shape 'box').
        docking_port_T: the target's capture point in T [m].
        docking_axis_T: the docking axis in T (normalised on use).
        corridor_half_angle_deg: half-angle of the approach corridor about the docking axis.
        corridor_length_m: extent of the approach corridor from the docking port [m]: the
            summary's corridor violation counts only the samples whose capture point is within
            it (a chaser starting outside the corridor is not violating it), and the scene
            draws it this long.
        shape: the true geometry, for the separation check, the scene and a soft-capture
            planner: 'box' (size_m) or 'soft_capture_target' (paper 000's pentagonal prism,
            rpod.models.shapes.soft_capture_target_hull; size_m is then unused).
    """

    q_LT: list[float] = dataclasses.field(default_factory=list)
    rpy_LT_deg: list[float] = dataclasses.field(default_factory=list)
    w_IT_T_deg_s: list[float] = dataclasses.field(default_factory=lambda: [0.5, 0.0, 1.0])
    inertia_kg_m2: list[list[float]] = dataclasses.field(
        default_factory=lambda: [[1200.0, 50.0, -30.0], [50.0, 1000.0, 20.0], [-30.0, 20.0, 800.0]]
    )
    size_m: list[float] = dataclasses.field(default_factory=lambda: [2.0, 2.0, 2.0])
    docking_port_T: list[float] = dataclasses.field(default_factory=lambda: [0.0, 0.0, 1.0])
    docking_axis_T: list[float] = dataclasses.field(default_factory=lambda: [0.0, 0.0, 1.0])
    corridor_half_angle_deg: float = 30.0
    corridor_length_m: float = 20.0
    shape: str = "box"


@dataclasses.dataclass
class ThrustersConfig:
    """The chaser's thruster bank and its modulation.

    Args:
        enabled: False runs without thrusters (a coasting chaser).
        layout: preset name, one of rcs_cube_12, planar_8, gimbaled_cuboid_8.
        max_thrust_N: thrust of one thruster when on (or its magnitude limit when gimbaled).
        isp_s: specific impulse of every thruster.
        size_m: edge length of the cube (rcs_cube_12, planar_8) the thrusters sit on [m].
        pwm: True drives the thrusters on/off through PWM; False applies duty as throttle.
        subdivisions: PWM slots per control period (paper 003 Sec. IV-B).
        min_on_slots: minimum pulse length in slots (0: none).
        modulation: how a duty becomes ON/OFF slots (rpod.models.modulation): pwm_carry
            (leading-edge PWM, the remainder carried to the next period), round (no carry),
            schmitt (a Schmitt trigger), delta_sigma (a first-order delta-sigma modulator).
        schmitt_hysteresis: the Schmitt trigger's band width in duty, in [0, 1).
    """

    enabled: bool = True
    layout: str = "rcs_cube_12"
    max_thrust_N: float = 10.0
    isp_s: float = 220.0
    size_m: float = 1.5
    pwm: bool = True
    subdivisions: int = 10
    min_on_slots: int = 0
    modulation: str = "pwm_carry"
    schmitt_hysteresis: float = 0.2


def default_simulator_config() -> SimulatorConfig:
    """Drake's SimulatorConfig with rpod's defaults: runge_kutta3 (with PWM every 10 ms slot
    ends a step anyway, and RK3 is the cheapest error-controlled scheme), accuracy 1e-6, steps
    of at most 10 s, as fast as possible, no publish per step."""
    return SimulatorConfig(
        integration_scheme="runge_kutta3",
        max_step_size=10.0,
        accuracy=1e-6,
        use_error_control=True,
        target_realtime_rate=0.0,
        publish_every_time_step=False,
    )


@dataclasses.dataclass
class StopConfig:
    """Ending a run before duration_s, on the controller's terms.

    Args:
        at_plan_end: end the run at the controller's planned end (a soft capture's final knot;
            the plug-in says, rpod.diagrams.controller_seam) plus hold_s, if that is before
            duration_s, which stays the upper bound. A controller with no plan runs to
            duration_s.
        hold_s: simulated time kept after the planned end (to see the capture held) [s].
    """

    at_plan_end: bool = False
    hold_s: float = 10.0


@dataclasses.dataclass
class Scenario:
    """A complete rpod run: orbit, bodies, actuators, controller, duration, logging.

    Args:
        description: one line shown by `rpod list`.
        orbit: the target's orbit and the truth gravity model.
        chaser: the chaser and its initial relative state.
        target: the tumbling target.
        thrusters: the chaser's thrusters and PWM.
        controller: the guidance/control law, chosen by YAML tag among the registered
            plug-ins (rpod.diagrams.controller_seam): `!HoldPoint {...}` (the default),
            `!SoftCapture {...}`, ...; `null` coasts (no controller).
        navigation: what the controller reads: `!Truth {}` (the default: the true state, as
            every paper assumes) or `!Ekf {...}` (sensors and a relative-navigation filter on
            the truth: rpod.systems.navigation).
        mission: how the run's success is judged: `!ControllerCriterion {}` (the default: the
            controller's own criterion) or `!Capture {...}` (paper 000's capture criterion,
            alike for every controller: rpod.diagrams.mission).
        seed: the seed of every random draw of the run (the sensors' noise).
        duration_s: simulated time [s]; with stop.at_plan_end, the most simulated time.
        stop: ending the run at the controller's planned end (stop.at_plan_end).
        log_period_s: sample period of every logged signal [s].
        simulator: Drake's own SimulatorConfig (integration_scheme, accuracy, max_step_size,
            use_error_control, target_realtime_rate, publish_every_time_step; start_time
            must stay 0); runge_kutta5 suits long coasts (far fewer steps at the same
            accuracy).
        visualization: how the Meshcat scene is drawn and recorded: the scene's own config
            (rpod.systems.scene.SceneConfig); what it draws comes from chaser and target.
    """

    description: str = ""
    orbit: OrbitConfig = dataclasses.field(default_factory=OrbitConfig)
    chaser: ChaserConfig = dataclasses.field(default_factory=ChaserConfig)
    target: TargetConfig = dataclasses.field(default_factory=TargetConfig)
    thrusters: ThrustersConfig = dataclasses.field(default_factory=ThrustersConfig)
    # A typed union whose members are the controller configs registered when a scenario is
    # read (rpod.scenarios.schema reads CHOICES_KEY), and None.
    controller: typing.Any = dataclasses.field(
        default_factory=controller_seam.default_config,
        metadata={CHOICES_KEY: controller_seam.config_types},
    )
    navigation: typing.Union[navigation_choices.Truth, navigation_choices.Ekf] = dataclasses.field(  # noqa: UP007
        default_factory=navigation_choices.Truth
    )
    mission: typing.Union[mission_choices.ControllerCriterion, mission_choices.Capture] = (  # noqa: UP007
        dataclasses.field(default_factory=mission_choices.ControllerCriterion)
    )
    seed: int = 0
    duration_s: float = 600.0
    stop: StopConfig = dataclasses.field(default_factory=StopConfig)
    log_period_s: float = 1.0
    simulator: SimulatorConfig = dataclasses.field(default_factory=default_simulator_config)
    # The camera frames each run from its content unless the scenario places it.
    visualization: SceneConfig = dataclasses.field(default_factory=SceneConfig)


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


def docking_geometry(scenario: Scenario) -> DockingGeometry:
    """The target's docking geometry (port, axis, corridor, true hull), built once from the
    scenario's target block for every system that uses it."""
    target = scenario.target
    return DockingGeometry(
        p_TD_T=np.asarray(target.docking_port_T, float),
        axis_T=np.asarray(target.docking_axis_T, float),
        corridor_half_angle_rad=math.radians(target.corridor_half_angle_deg),
        corridor_length_m=target.corridor_length_m,
        hull=body_polytopes(scenario)[1],
    )


def body_polytopes(scenario: Scenario) -> tuple[ConvexPolytope, ConvexPolytope]:
    """The true (chaser in C, target in T) polytopes the scenario's `shape` fields name."""
    chaser, target = scenario.chaser, scenario.target
    chaser_shape = (
        soft_capture_chaser_hull()
        if chaser.shape == "soft_capture_chaser"
        else ConvexPolytope.box(chaser.size_m)
    )
    target_shape = (
        soft_capture_target_hull()
        if target.shape == "soft_capture_target"
        else ConvexPolytope.box(target.size_m)
    )
    return chaser_shape, target_shape


def target_rotation_in_lvlh(scenario: Scenario) -> np.ndarray:
    """R_LT at t = 0: from q_LT (normalised) or rpy_LT_deg, whichever is given; else identity."""
    target = scenario.target
    if target.q_LT:
        q = np.asarray(target.q_LT, float)
        return rotation_from_wxyz(q / np.linalg.norm(q))
    return rotation_from_rpy_deg(target.rpy_LT_deg or [0.0, 0.0, 0.0])


def initial_relative_state_L(scenario: Scenario) -> tuple[np.ndarray, np.ndarray]:
    """(p_LC_L, v_LC_L) at t = 0, the velocity seen in L whatever chaser.velocity_seen_in says.

    Seen in T: v_L = v + w_LT_L x p, with w_LT_L = R_LT w_IT_T - w_IL_L (transport theorem).
    """
    chaser = scenario.chaser
    p_L, v_L = np.asarray(chaser.p_LC_L, float), np.asarray(chaser.v_LC_L, float)
    if chaser.velocity_seen_in == "T":
        w_IL_L = lvlh_of(*initial_orbit_state(scenario.orbit), scenario.orbit.gravity)[1]
        w_IT_L = target_rotation_in_lvlh(scenario) @ np.radians(scenario.target.w_IT_T_deg_s)
        v_L = v_L + np.cross(w_IT_L - w_IL_L, p_L)
    return p_L, v_L


def chaser_rotation_in_lvlh(scenario: Scenario) -> np.ndarray:
    """R_LC at t = 0: from rpy_LC_deg, or with point_at_target the least rotation that puts the
    capture axis on the line of sight (-p_LC_L)."""
    chaser = scenario.chaser
    if not chaser.point_at_target:
        return rotation_from_rpy_deg(chaser.rpy_LC_deg)
    p = np.asarray(chaser.p_LC_L, float)
    c = np.asarray(chaser.capture_point_C, float)
    return min_rotation(c / np.linalg.norm(c), -p / np.linalg.norm(p))


def starts_in_contact(scenario: Scenario) -> bool:
    """True when the chaser's and the target's true shapes touch or overlap at t = 0.

    A QP (separation_distance) only when the bodies' bounding spheres overlap: a campaign
    validates every run, and most starts are metres away.
    """
    chaser_shape, target_shape = body_polytopes(scenario)
    radii = sum(
        float(np.max(np.linalg.norm(s.vertices, axis=1))) for s in (chaser_shape, target_shape)
    )
    if float(np.linalg.norm(scenario.chaser.p_LC_L)) > radii:
        return False
    distance = separation_distance(
        target_shape,
        target_rotation_in_lvlh(scenario),
        np.zeros(3),
        chaser_shape,
        chaser_rotation_in_lvlh(scenario),
        np.asarray(scenario.chaser.p_LC_L, float),
    )
    return distance <= 0.0


def _require(condition: bool, field: str, message: str) -> None:
    if not condition:
        raise ScenarioError(field, message)


def _vector(values, field: str, size: int = 3, nonzero: bool = False) -> np.ndarray:
    array = np.asarray(values, dtype=float)
    _require(array.shape == (size,), field, f"expected {size} numbers, got {len(values)}")
    _require(bool(np.all(np.isfinite(array))), field, "must be finite")
    if nonzero:
        _require(float(np.linalg.norm(array)) > 1e-12, field, "must not be the zero vector")
    return array


def _positive(value: float, field: str) -> None:
    _require(math.isfinite(value) and value > 0, field, f"must be positive, got {value}")


def _inertia(values, field: str) -> None:
    _require(
        len(values) == 3 and all(len(row) == 3 for row in values), field, "expected a 3x3 matrix"
    )
    validate_inertia(np.asarray(values, dtype=float), field)


def _rigid_body(config, prefix: str, shapes: tuple[str, ...]) -> None:
    """Checks the inertia, shape and box size shared by ChaserConfig and TargetConfig."""
    _inertia(config.inertia_kg_m2, f"{prefix}.inertia_kg_m2")
    _require(
        config.shape in shapes, f"{prefix}.shape", f"must be one of {shapes}, got '{config.shape}'"
    )
    size = _vector(config.size_m, f"{prefix}.size_m")
    _require(bool(np.all(size > 0)), f"{prefix}.size_m", "edge lengths must be positive")


def _at_most(value: float, limit: float, field: str, what: str = "") -> None:
    _require(value <= limit, field, f"{what or 'must be'} at most {limit:g}, got {value:g}")


def _norm_at_most(vector: np.ndarray, limit: float, field: str, unit: str) -> None:
    norm = math.hypot(*vector)  # hypot does not overflow where the sum of squares would
    _require(norm <= limit, field, f"norm must be at most {limit:g} {unit}, got {norm:g}")


def _validate_work(scenario: Scenario) -> None:
    """The bounds on samples, events and steps (MAX_* above): a run that ends in bounded time."""
    duration = scenario.duration_s
    _at_most(duration, MAX_DURATION_S, "duration_s")
    _require(
        scenario.log_period_s <= duration,
        "log_period_s",
        f"must not exceed duration_s = {duration:g} (the log would hold only t = 0), "
        f"got {scenario.log_period_s:g}",
    )
    for field, period in (
        ("log_period_s", scenario.log_period_s),
        ("visualization.publish_period_s", scenario.visualization.publish_period_s),
    ):
        _at_most(duration / period, MAX_SAMPLES, field, f"duration_s / {field} must be")
    _at_most(
        duration / scenario.simulator.max_step_size,
        MAX_EVENTS,
        "simulator.max_step_size",
        "duration_s / simulator.max_step_size must be",
    )
    _at_most(scenario.visualization.trail_max_points, MAX_SAMPLES, "visualization.trail_max_points")
    thrusters, controller = scenario.thrusters, scenario.controller
    if controller is not None:
        period = controller_seam.plugin_for(controller).command_period_s(controller)
        slots = thrusters.subdivisions if thrusters.enabled and thrusters.pwm else 1
        field = "controller.control_period_s"
        _at_most(
            duration / period * slots,
            MAX_EVENTS,
            field,
            "duration_s / the command period x PWM subdivisions must be",
        )


def _validate_actuation(plugin, scenario: Scenario) -> None:
    """The controller's actuation path fits the thrusters (rpod.diagrams.controller_seam)."""
    thrusters, tag = scenario.thrusters, f"!{plugin.tag}"
    path = plugin.actuation_for(scenario.controller)
    if path is controller_seam.Actuation.IDEAL:
        return  # straight to the truth; thrusters.isp_s prices the propellant
    _require(
        thrusters.enabled,
        "thrusters.enabled",
        f"the {tag} controller drives the thrusters ({path.value}): enable them",
    )
    gimbaled = thrusters.layout in GIMBALED_LAYOUTS
    _require(
        not (gimbaled and path is controller_seam.Actuation.BODY_WRENCH),
        "thrusters.layout",
        f"{thrusters.layout} takes force vectors per thruster, and {tag} drives a body wrench "
        "(the allocator handles fixed thrusters only): choose a fixed layout or a controller "
        "on per-thruster commands",
    )


def scenario_warnings(scenario: Scenario) -> list[str]:
    """Warnings about a valid scenario that will likely fail (the controller's
    `load_warnings`), one line each; [] when there is nothing to say."""
    plugin = controller_seam.plugin_for(scenario.controller)
    return list(plugin.load_warnings(scenario.controller, scenario)) if plugin else []


def validate_scenario(scenario: Scenario) -> None:
    """Raises ScenarioError naming the first invalid field of the scenario."""
    orbit = scenario.orbit
    _require(orbit.gravity in GRAVITY_MODELS, "orbit.gravity", f"must be one of {GRAVITY_MODELS}")
    _require(
        MIN_ALTITUDE_M <= orbit.altitude_m <= MAX_ALTITUDE_M,
        "orbit.altitude_m",
        f"must be in [{MIN_ALTITUDE_M:.0f}, {MAX_ALTITUDE_M:g}] m, got {orbit.altitude_m:g}",
    )
    _require(
        0.0 <= orbit.inclination_deg <= 180.0,
        "orbit.inclination_deg",
        f"must be in [0, 180] deg, got {orbit.inclination_deg:g}",
    )
    for name in ("raan_deg", "arg_latitude_deg"):
        _require(math.isfinite(getattr(orbit, name)), f"orbit.{name}", "must be finite")
    try:
        epoch_utc_datetime64(orbit.epoch_utc)
    except ValueError as error:
        raise ScenarioError("orbit.epoch_utc", str(error)) from None

    chaser = scenario.chaser
    _norm_at_most(_vector(chaser.p_LC_L, "chaser.p_LC_L"), MAX_RANGE_M, "chaser.p_LC_L", "m")
    _norm_at_most(
        _vector(chaser.v_LC_L, "chaser.v_LC_L"), MAX_RELATIVE_SPEED_M_S, "chaser.v_LC_L", "m/s"
    )
    _require(
        chaser.velocity_seen_in in ("L", "T"),
        "chaser.velocity_seen_in",
        f"must be 'L' or 'T', got {chaser.velocity_seen_in!r}",
    )
    _vector(chaser.rpy_LC_deg, "chaser.rpy_LC_deg")
    if chaser.point_at_target:
        _require(
            not any(chaser.rpy_LC_deg),
            "chaser.point_at_target",
            "the attitude is given twice: point_at_target and a non-zero rpy_LC_deg",
        )
        _require(
            float(np.linalg.norm(chaser.capture_point_C)) > 1e-9,
            "chaser.point_at_target",
            "capture_point_C is at the centre of mass: there is no capture axis to point",
        )
        _require(
            float(np.linalg.norm(chaser.p_LC_L)) > 1e-9,
            "chaser.point_at_target",
            "the chaser starts at the target's centre: there is no line of sight",
        )
    _norm_at_most(
        _vector(chaser.w_IC_C_deg_s, "chaser.w_IC_C_deg_s"),
        MAX_SPIN_DEG_S,
        "chaser.w_IC_C_deg_s",
        "deg/s",
    )
    _positive(chaser.mass_kg, "chaser.mass_kg")
    _rigid_body(chaser, "chaser", CHASER_SHAPES)
    _vector(chaser.capture_point_C, "chaser.capture_point_C")

    target = scenario.target
    if target.q_LT:
        _require(
            not target.rpy_LT_deg,
            "target.q_LT",
            "both q_LT and rpy_LT_deg are given: give the attitude once (set the other to [])",
        )
        norm = float(np.linalg.norm(_vector(target.q_LT, "target.q_LT", size=4, nonzero=True)))
        _require(
            abs(norm - 1.0) <= QUATERNION_NORM_TOLERANCE,
            "target.q_LT",
            f"must be a unit quaternion (norm 1 within {QUATERNION_NORM_TOLERANCE:g}), "
            f"got norm {norm:.6g}",
        )
    if target.rpy_LT_deg:
        _vector(target.rpy_LT_deg, "target.rpy_LT_deg")
    _norm_at_most(
        _vector(target.w_IT_T_deg_s, "target.w_IT_T_deg_s"),
        MAX_SPIN_DEG_S,
        "target.w_IT_T_deg_s",
        "deg/s",
    )
    _rigid_body(target, "target", TARGET_SHAPES)
    _vector(target.docking_port_T, "target.docking_port_T")
    _vector(target.docking_axis_T, "target.docking_axis_T", nonzero=True)
    _require(
        0.0 < target.corridor_half_angle_deg < 90.0,
        "target.corridor_half_angle_deg",
        f"must be in (0, 90) deg, got {target.corridor_half_angle_deg}",
    )

    thrusters = scenario.thrusters
    if thrusters.enabled:
        _require(
            thrusters.layout in THRUSTER_LAYOUTS,
            "thrusters.layout",
            f"must be one of {THRUSTER_LAYOUTS}, got '{thrusters.layout}'",
        )
        _positive(thrusters.max_thrust_N, "thrusters.max_thrust_N")
        _positive(thrusters.isp_s, "thrusters.isp_s")
        _positive(thrusters.size_m, "thrusters.size_m")
        _require(
            1 <= thrusters.subdivisions <= MAX_SUBDIVISIONS,
            "thrusters.subdivisions",
            f"must be in [1, {MAX_SUBDIVISIONS}], got {thrusters.subdivisions}",
        )
        _require(
            0 <= thrusters.min_on_slots <= thrusters.subdivisions,
            "thrusters.min_on_slots",
            "must be between 0 and subdivisions",
        )
        _require(
            thrusters.modulation in modulation.SCHEMES,
            "thrusters.modulation",
            f"must be one of {tuple(modulation.SCHEMES)}, got '{thrusters.modulation}'",
        )
        _require(
            0.0 <= thrusters.schmitt_hysteresis < 1.0,
            "thrusters.schmitt_hysteresis",
            f"must be in [0, 1), got {thrusters.schmitt_hysteresis}",
        )
        _require(
            thrusters.modulation != "delta_sigma" or thrusters.min_on_slots <= 1,
            "thrusters.min_on_slots",
            "delta_sigma fires single slots: must be 0 or 1",
        )

    controller = scenario.controller
    if controller is not None:
        plugin = controller_seam.plugin_for(controller)  # KeyError: a programming error
        _validate_actuation(plugin, scenario)
        plugin.validate(controller, scenario)
        period = plugin.command_period_s(controller)
        _require(
            math.isfinite(period) and period > 0,
            "controller.control_period_s",
            f"the command period must be positive, got {period}",
        )

    if isinstance(scenario.navigation, navigation_choices.Ekf):
        try:
            check_bounds(scenario.navigation)
            scenario.navigation.validate()
        except ConfigError as error:
            raise error.under("navigation") from None
    if isinstance(scenario.mission, mission_choices.Capture):
        try:
            check_bounds(scenario.mission)
        except ConfigError as error:
            raise error.under("mission") from None
    _require(
        isinstance(scenario.seed, int) and 0 <= scenario.seed < 2**63,
        "seed",
        f"must be an integer in [0, 2^63), got {scenario.seed}",
    )
    _positive(scenario.duration_s, "duration_s")
    _positive(scenario.log_period_s, "log_period_s")
    _require(
        math.isfinite(scenario.stop.hold_s) and scenario.stop.hold_s >= 0,
        "stop.hold_s",
        f"must not be negative, got {scenario.stop.hold_s}",
    )
    simulator = scenario.simulator
    _require(
        simulator.integration_scheme in INTEGRATION_SCHEMES,
        "simulator.integration_scheme",
        f"must be one of {INTEGRATION_SCHEMES}",
    )
    _require(
        not (simulator.integration_scheme == "runge_kutta2" and simulator.use_error_control),
        "simulator.use_error_control",
        "runge_kutta2 has no error estimate: set use_error_control: false",
    )
    _positive(simulator.accuracy, "simulator.accuracy")
    _positive(simulator.max_step_size, "simulator.max_step_size")
    _require(
        math.isfinite(simulator.target_realtime_rate) and simulator.target_realtime_rate >= 0,
        "simulator.target_realtime_rate",
        f"must not be negative, got {simulator.target_realtime_rate}",
    )
    _require(
        simulator.start_time == 0.0,
        "simulator.start_time",
        f"must be 0 (every controller and PWM period starts at t = 0), got {simulator.start_time}",
    )
    try:
        scenario.visualization.validate()
    except ScenarioError as error:
        raise error.under("visualization") from None
    _positive(scenario.target.corridor_length_m, "target.corridor_length_m")
    _validate_work(scenario)
    # Last: it needs valid shapes and attitudes.
    _require(
        not starts_in_contact(scenario),
        "chaser.p_LC_L",
        "the chaser starts in contact with or inside the target (their shapes overlap at "
        f"t = 0; p_LC_L = {list(map(float, chaser.p_LC_L))} m)",
    )
