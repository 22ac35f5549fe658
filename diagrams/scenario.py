"""The `Scenario` dataclass: everything a run needs, loadable from YAML by hand.

Owns: the scenario schema (composing the configs that live beside their systems), its defaults
(every field has one that makes a scenario run) and its semantic validation, which raises
`ScenarioError` naming the field. Reading files and reporting errors to the user is
rpod.scenarios' job.

Units are SI; a field whose name ends in `_deg` or `_deg_s` is in degrees (per second).
"""

import dataclasses
import math

import numpy as np

from rpod.models.frames import rotation_from_rpy_deg, rotation_from_wxyz
from rpod.models.gravity import GRAVITY_MODELS, MIN_ALTITUDE_M, R_EARTH_M
from rpod.models.rigid_body import validate_inertia
from rpod.models.shapes import (
    ConvexPolytope,
    separation_distance,
    soft_capture_chaser_hull,
    soft_capture_target_hull,
)
from rpod.systems.hold_point_controller import HoldPointControllerConfig
from rpod.systems.orbital_dynamics import OrbitConfig
from rpod.systems.soft_capture_controller import SoftCaptureControllerConfig

THRUSTER_LAYOUTS = ("rcs_cube_12", "planar_8", "gimbaled_cuboid_8")
CONTROLLERS = ("hold_point", "soft_capture", "none")
CHASER_SHAPES = ("box", "soft_capture_chaser")
TARGET_SHAPES = ("box", "soft_capture_target")
INTEGRATION_SCHEMES = ("runge_kutta2", "runge_kutta3", "runge_kutta5", "bogacki_shampine3")

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


class ScenarioError(ValueError):
    """A scenario field is invalid; `field` is its dotted path (e.g. 'target.inertia_kg_m2')."""

    def __init__(self, field: str, message: str):
        super().__init__(f"{field}: {message}")
        self.field = field
        self.message = message


def _diag(values):
    return lambda: [[values[0], 0.0, 0.0], [0.0, values[1], 0.0], [0.0, 0.0, values[2]]]


@dataclasses.dataclass
class ChaserConfig:
    """The chaser spacecraft and its initial state relative to the target.

    Args:
        p_LC_L: initial position of the chaser's centre of mass in LVLH [m].
        v_LC_L: initial velocity seen in the rotating LVLH frame [m/s].
        rpy_LC_deg: initial attitude relative to LVLH, roll-pitch-yaw [deg].
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
    rpy_LC_deg: list[float] = dataclasses.field(default_factory=lambda: [0.0, 0.0, 0.0])
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
    """

    enabled: bool = True
    layout: str = "rcs_cube_12"
    max_thrust_N: float = 10.0
    isp_s: float = 220.0
    size_m: float = 1.5
    pwm: bool = True
    subdivisions: int = 10
    min_on_slots: int = 0


@dataclasses.dataclass
class ControllerConfig:
    """Which controller flies the chaser.

    Args:
        type: 'hold_point' (track the hold point on the docking axis), 'soft_capture' (plan
            and fly paper 000's soft capture) or 'none' (coast).
        hold_point: gains and geometry of the hold-point law.
        soft_capture: the soft-capture planner's data (Table I) and closed-loop settings.
            Its planner must agree with the scenario: semi_major_axis_m with the orbit,
            chaser_mass_kg with the chaser, p_CDc_C with chaser.capture_point_C, p_TDt_T with
            target.docking_port_T and docking_axis_T, docking_half_angle_deg with
            target.corridor_half_angle_deg. A tumble faster than the method's limit is not
            a config error: the planner reports it at run time and the controller falls back.
    """

    type: str = "hold_point"
    hold_point: HoldPointControllerConfig = dataclasses.field(
        default_factory=HoldPointControllerConfig
    )
    soft_capture: SoftCaptureControllerConfig = dataclasses.field(
        default_factory=SoftCaptureControllerConfig
    )

    def control_period_s(self) -> float:
        """The sample period of the active controller (the PWM period)."""
        if self.type == "soft_capture":
            return self.soft_capture.control_period_s
        return self.hold_point.control_period_s


@dataclasses.dataclass
class IntegratorConfig:
    """Numerical integration of the continuous truth.

    Args:
        scheme: Drake integration scheme; runge_kutta3 suits PWM (steps end at every slot
            anyway), runge_kutta5 suits long coasts (far fewer steps at the same accuracy).
        accuracy: target accuracy of the error-controlled step.
        max_step_s: upper bound on the step size [s].
    """

    scheme: str = "runge_kutta3"
    accuracy: float = 1e-6
    max_step_s: float = 10.0


@dataclasses.dataclass
class VisualizationConfig:
    """How the Meshcat scene is drawn and recorded (geometry comes from chaser and target).

    Args:
        publish_period_s: scene update period in simulated time [s].
        trail: draw the chaser's trail.
        trail_max_points: trail markers kept (older ones are reused).
        camera_position_L_m: camera position in LVLH, looking at the target [m].
        corridor_length_m: length of the drawn approach corridor (docking cone) [m].
    """

    publish_period_s: float = 0.5
    trail: bool = True
    trail_max_points: int = 400
    camera_position_L_m: list[float] = dataclasses.field(
        default_factory=lambda: [25.0, -40.0, 18.0]
    )
    corridor_length_m: float = 20.0


@dataclasses.dataclass
class Scenario:
    """A complete rpod run: orbit, bodies, actuators, controller, duration, logging.

    Args:
        description: one line shown by `rpod list`.
        orbit: the target's orbit and the truth gravity model.
        chaser: the chaser and its initial relative state.
        target: the tumbling target.
        thrusters: the chaser's thrusters and PWM.
        controller: the guidance/control law.
        duration_s: simulated time [s].
        log_period_s: sample period of every logged signal [s].
        integrator: numerical integration settings.
        visualization: Meshcat scene and recording settings.
    """

    description: str = ""
    orbit: OrbitConfig = dataclasses.field(default_factory=OrbitConfig)
    chaser: ChaserConfig = dataclasses.field(default_factory=ChaserConfig)
    target: TargetConfig = dataclasses.field(default_factory=TargetConfig)
    thrusters: ThrustersConfig = dataclasses.field(default_factory=ThrustersConfig)
    controller: ControllerConfig = dataclasses.field(default_factory=ControllerConfig)
    duration_s: float = 600.0
    log_period_s: float = 1.0
    integrator: IntegratorConfig = dataclasses.field(default_factory=IntegratorConfig)
    visualization: VisualizationConfig = dataclasses.field(default_factory=VisualizationConfig)


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
        rotation_from_rpy_deg(scenario.chaser.rpy_LC_deg),
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
    try:
        validate_inertia(np.asarray(values, dtype=float))
    except ValueError as error:
        raise ScenarioError(field, str(error)) from None


def _rigid_body(config, prefix: str, shapes: tuple[str, ...]) -> None:
    """Checks the inertia, shape and box size shared by ChaserConfig and TargetConfig."""
    _inertia(config.inertia_kg_m2, f"{prefix}.inertia_kg_m2")
    _require(config.shape in shapes, f"{prefix}.shape", f"must be one of {shapes}, "
             f"got '{config.shape}'")  # fmt: skip
    size = _vector(config.size_m, f"{prefix}.size_m")
    _require(bool(np.all(size > 0)), f"{prefix}.size_m", "edge lengths must be positive")


def _same_vector(values, expected, field: str, what: str) -> None:
    difference = np.asarray(values, float) - np.asarray(expected, float)
    _require(
        bool(np.all(np.abs(difference) <= 1e-9)),
        field,
        f"must equal {what} = {list(map(float, expected))}, got {list(map(float, values))}",
    )


def _validate_soft_capture(scenario: Scenario) -> None:
    """Checks the soft-capture block and its agreement with the rest of the scenario."""
    config = scenario.controller.soft_capture
    prefix = "controller.soft_capture."
    try:
        config.validate()
    except ValueError as error:
        field, _, message = str(error).partition(": ")
        raise ScenarioError(prefix + field, message) from None
    planner = config.planner
    orbit = scenario.orbit
    _require(orbit.gravity != "free_space", "orbit.gravity",
             "the soft-capture planner needs an orbit (CW model): not free_space")  # fmt: skip
    a = R_EARTH_M + orbit.altitude_m
    _require(
        abs(planner.semi_major_axis_m - a) <= 1.0,
        prefix + "planner.semi_major_axis_m",
        f"must equal R_earth + orbit.altitude_m = {a:.1f} m (the planner's CW model is about "
        f"the scenario's orbit), got {planner.semi_major_axis_m}",
    )
    chaser, target = scenario.chaser, scenario.target
    _require(
        abs(planner.chaser_mass_kg - chaser.mass_kg) <= 1e-9 * chaser.mass_kg,
        prefix + "planner.chaser_mass_kg",
        f"must equal chaser.mass_kg = {chaser.mass_kg}, got {planner.chaser_mass_kg}",
    )
    _same_vector(chaser.capture_point_C, planner.p_CDc_C, "chaser.capture_point_C",
                 prefix + "planner.p_CDc_C")  # fmt: skip
    _same_vector(target.docking_port_T, planner.p_TDt_T, "target.docking_port_T",
                 prefix + "planner.p_TDt_T")  # fmt: skip
    D_t = np.asarray(planner.p_TDt_T, float)
    axis = np.asarray(target.docking_axis_T, float)
    _same_vector(axis / np.linalg.norm(axis), D_t / np.linalg.norm(D_t), "target.docking_axis_T",
                 "the direction of " + prefix + "planner.p_TDt_T")  # fmt: skip
    _require(
        abs(target.corridor_half_angle_deg - planner.docking_half_angle_deg) <= 1e-9,
        "target.corridor_half_angle_deg",
        f"must equal {prefix}planner.docking_half_angle_deg = {planner.docking_half_angle_deg}",
    )


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
        duration / scenario.integrator.max_step_s,
        MAX_EVENTS,
        "integrator.max_step_s",
        "duration_s / integrator.max_step_s must be",
    )
    _at_most(scenario.visualization.trail_max_points, MAX_SAMPLES, "visualization.trail_max_points")
    thrusters, controller = scenario.thrusters, scenario.controller
    if controller.type != "none":
        slots = thrusters.subdivisions if thrusters.enabled and thrusters.pwm else 1
        field = f"controller.{controller.type}.control_period_s"
        _at_most(
            duration / controller.control_period_s() * slots,
            MAX_EVENTS,
            field,
            "duration_s / control_period_s x PWM subdivisions must be",
        )


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

    chaser = scenario.chaser
    _norm_at_most(_vector(chaser.p_LC_L, "chaser.p_LC_L"), MAX_RANGE_M, "chaser.p_LC_L", "m")
    _norm_at_most(
        _vector(chaser.v_LC_L, "chaser.v_LC_L"), MAX_RELATIVE_SPEED_M_S, "chaser.v_LC_L", "m/s"
    )
    _vector(chaser.rpy_LC_deg, "chaser.rpy_LC_deg")
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
        _require(
            thrusters.layout != "gimbaled_cuboid_8",
            "thrusters.layout",
            "gimbaled_cuboid_8 needs a force-vector controller (the NMPC of paper 001); "
            "the hold-point allocator drives fixed thrusters only",
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

    controller = scenario.controller
    _require(controller.type in CONTROLLERS, "controller.type", f"must be one of {CONTROLLERS}")
    if controller.type == "hold_point":
        _require(
            thrusters.enabled, "thrusters.enabled", "the hold_point controller needs thrusters"
        )
        gains = controller.hold_point
        prefix = "controller.hold_point."
        for name in (
            "control_period_s",
            "translation_bandwidth_rad_s",
            "translation_damping",
            "max_speed_m_s",
            "attitude_bandwidth_rad_s",
            "attitude_damping",
            "descent_gate_deg",
            "max_reference_step_deg",
        ):
            _positive(getattr(gains, name), prefix + name)
        _require(gains.hold_distance_m >= 0, prefix + "hold_distance_m", "must not be negative")
        _vector(gains.capture_axis_C, prefix + "capture_axis_C", nonzero=True)
    if controller.type == "soft_capture":
        _require(
            thrusters.enabled, "thrusters.enabled", "the soft_capture controller needs thrusters"
        )
        _validate_soft_capture(scenario)

    _positive(scenario.duration_s, "duration_s")
    _positive(scenario.log_period_s, "log_period_s")
    integrator = scenario.integrator
    _require(
        integrator.scheme in INTEGRATION_SCHEMES,
        "integrator.scheme",
        f"must be one of {INTEGRATION_SCHEMES}",
    )
    _positive(integrator.accuracy, "integrator.accuracy")
    _positive(integrator.max_step_s, "integrator.max_step_s")
    _positive(scenario.visualization.publish_period_s, "visualization.publish_period_s")
    _positive(scenario.visualization.corridor_length_m, "visualization.corridor_length_m")
    _require(
        scenario.visualization.trail_max_points >= 1,
        "visualization.trail_max_points",
        "must be at least 1",
    )
    _validate_work(scenario)
    # Last: it needs valid shapes and attitudes.
    _require(
        not starts_in_contact(scenario),
        "chaser.p_LC_L",
        "the chaser starts in contact with or inside the target (their shapes overlap at "
        f"t = 0; p_LC_L = {list(map(float, chaser.p_LC_L))} m)",
    )
