"""Paper 003's planar approach as a plug-in: `controller: !PlanarApproach {...}`.

Owns: the `PlanarApproach` config type (the YAML tag: the planner's settings, the tracker's
bandwidths, what is flown after the plan, the goal tolerances), the derivation of the planner's
problem data from the scenario (`planner_config`), the plan made when the diagram is built and
the reference the tracker follows (`PlanarApproachRun`), how the tracker is wired (path 1: body
wrench -> box-constrained allocation to 8 duties, eq. 14 -> PWM with N_PWM slots, Sec. IV-B ->
`planar_8` thrusters), the keep-out scene extras, the results (tracking errors, terminal
errors, keep-out and contact, fuel, switches, the mission outcome) and the `rpod report`
tables of its campaigns.
Does not own: the planner (rpod.planners.planar_approach), the keep-out geometry and the
conventions of the planar world (rpod.models.planar_approach), the PD law (eqs. 11-13,
rpod.systems.planar_tracking), the allocator, the PWM or the thrusters (the builder wires
them), the figures (rpod.diagrams.plots_planar) or the scene (rpod.systems.planar_scene).

Problem data from the scenario, never re-typed (`planner_config`). Under `orbit.gravity:
free_space` the LVLH frame L is paper 003's inertial frame, the target centre its origin:
- omega_target = target.w_IT_T_deg_s z (a flat spin: x, y must be 0), theta_target0 = the
  target's initial yaw in L (q_LT or rpy_LT_deg; roll and pitch 0);
- the chaser's start x0 = [p_LC_L x, y, yaw of R_LC, v_LC_L x, y (seen in L), w_IC_C z];
- l_s = chaser.size_m x (= y), l_t = target.size_m x (= y) (eq. 10), m = chaser.mass_kg,
  I = chaser.inertia_kg_m2 zz;
- the wrench limits (8) = `planar_8_wrench_limits(thrusters.size_m, thrusters.max_thrust_N)`;
- the NLP step dt = controller.control_period_s (Sec. V: the 0.1 s control period is the
  optimisation's time step).
The tracker's gains are `PlanarTrackingConfig.critically_damped(m, I_zz, ...)` at the
config's bandwidths and period.

When it plans. Once, in `add_to_diagram`, from the scenario's initial state (the same call as
`plan_scenario`); the plan's wall time is in the summary (`planar_plan_solve_time_s`), not in
the run's wall time. A plan that is not a success is a status, never an exception: the
tracker then holds the chaser's start pose (position and heading at rest), the run goes on
(with `stop.at_plan_end` it ends `stop.hold_s` after t = 0) and the mission fails with the
planner's own word.

After the plan (beyond the paper, `after_plan`). The paper's run ends with the manoeuvre. Here
the reference goes on past the planned arrival T: with 'co_rotate' (default) it is the plan's
final pose fixed in the target frame (turning with the target at omega_target about its centre,
heading too), so the chaser synchronises with the docking face, as a capture needs; with 'rest'
the tracker's own behaviour: the final pose at rest in L. The planner has no terminal
relative-velocity term (the paper says so, Sec. V-C); rpod's adds one (`w_terminal_velocity`,
rpod.planners.planar_approach), so Sec. V-A's plan arrives at 0.003 m/s (0.014 m/s without);
the co-rotating hold brings what is left towards zero. The hold needs m omega_t^2 |p_goal| of
centripetal force, more than weak thrusters have at a fast spin (0.85 N at 0.485 rad/s against
0.06 N along an axis with 0.03 N thrusters): then the PD saturates and the squares can touch.
'release' stops commanding at T (the tracker's release time): a chaser that arrives
synchronised with the face moves away from it on a straight line while both turn at omega_t,
so the gap opens. 'auto' co-rotates where the hold needs at most HOLD_FORCE_SHARE (half) of the
thrusters' force along an axis and releases otherwise (`planar_after_plan` says which flew).

Heading (`attitude_reference`). 'plan' (default, the bundled scenario): the tracker follows
the plan's heading, as the paper's eq. 12 does. The planner admits State II (the relaxed zone,
r_relaxed = face-to-face contact plus l_margin) only where its heading faces the docking face
within 3 deg (the paper's "in State II, the chaser is aligned with the target's docking
surface", Sec. III-C, made a condition), so the plan turns onto the face before the final
approach. Before that condition, Sec. V-A's plan entered State II at ~63 s still ~165 deg off
the face and the true squares overlapped from 77.2 s to 83.8 s of the plan itself
(`planar_plan_contact_s`, `planar_plan_min_separation_m`: the true shapes along the plan's
knots). 'face_aligned' (beyond the paper; the remedy before the planner had the condition)
keeps the plan's path and turns the heading onto the docking face, theta_t + pi, over
`align_time_s` (20 s) before the plan first comes within reach of the target (the
half-diagonals' sum plus l_margin), then turns with the face (`face_aligned_reference`); the
attitude error is then reported against that heading.

Mission (chosen here; the paper states no tolerance): success = the plan is a success (its own
end point within `goal_position_tolerance_m` of the goal: a plan that misses is GOAL_MISSED,
flown for its figures and never a success) AND the true shapes never touch over the whole run
(`separation_m` > 0 at every log sample, and the core's ContactWatch, summary["contact"], at
every integrator step; a contact in the hold after the arrival fails the mission too,
`planar_contact_after_arrival_s` says when it began: the hold needs m omega^2 r of centripetal
force, `planar_hold_force_ratio` times what the thrusters give along an axis) AND at the
planned arrival T (the first log sample at or after it) the chaser is
within `goal_position_tolerance_m` (5 cm) of the goal x_goal of eq. 5, within
`goal_attitude_tolerance_deg` (5 deg) of theta_finish (eq. 6) and moves relative to the
target's docking face (in the target frame, Fig. 7) at most `goal_speed_tolerance_m_s` (0.03
m/s: the allowable contact velocity the paper cites, Sasaki et al.). A campaign's table
(`rpod report`) leads with the mission success share (Wilson 95 %), then the safety figures:
`planar_safe` = the plan reached its goal and the true shapes never touched in the whole run.

Thruster switches (`planar_switches`, OFF -> ON and ON -> OFF of every thruster, from OFF at
t = 0). Counted from the logged `thruster_on` when the log samples every PWM slot (exact for
every scheme); otherwise None: a log at the control period cannot say them (the PWM and the
logger sample the same instant an ulp apart in some periods, rpod.systems.pwm).
"""

import copy
import dataclasses
import itertools
import math

import numpy as np
from pydrake.trajectories import PiecewisePolynomial

from rpod.diagrams.controller_seam import (
    Actuation,
    ControllerPlugin,
    ControllerResults,
    ControllerWiring,
    MissionOutcome,
    register_controller,
)
from rpod.diagrams.scenario import (
    ScenarioError,
    body_polytopes,
    chaser_rotation_in_lvlh,
    initial_relative_state_L,
    target_rotation_in_lvlh,
)
from rpod.models import planar_approach as pa
from rpod.models.frames import rotations_from_wxyz
from rpod.models.shapes import separation_distance
from rpod.models.statistics import SuccessShare
from rpod.models.thrusters import STANDARD_GRAVITY_M_S2
from rpod.planners import planar_approach as planner
from rpod.planners.planar_approach import (
    PlanarApproachConfig,
    PlanarPlan,
    check_plan,
    plan_approach,
)
from rpod.systems.planar_tracking import PlanarTrackingConfig, PlanarTrackingController
from rpod.systems.sensed import SENSED_PORT

AFTER_PLAN = ("co_rotate", "rest", "release", "auto")
HOLD_FORCE_SHARE = 0.5
"""'auto' co-rotates when the hold's centripetal force is at most this share of the thrusters'
force along an axis (the rest is the tracker's), and releases the chaser otherwise."""
ATTITUDE_REFERENCES = ("plan", "face_aligned")
UNRECORDED = "not recorded (runs stored before rpod recorded it)"
"""The formulation of a stored run without `planar_formulation`."""
PLANAR_TOLERANCE = 1e-9  # z, roll, pitch, off-plane rates and inertia products must be 0 to this
HOLD_KNOT_STEP_S = 0.02  # knots of the co-rotating hold (chord sag 0.1 mm at 2 rad/s, 0.5 m)
LOGGED = {
    "planar_body_wrench_desired": "body_wrench_desired",
    "planar_wrench_L": "planar_wrench_L",
    "planar_tracking_error": "tracking_error",
    "planar_reference_state": "reference_state",
    "planar_sensed_state": "planar_state",
}
"""Log key -> the tracker's output port (held at its samples)."""
LOG_SHAPES = {  # the keys the figures read (rpod.diagrams.plots_planar documents each)
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

# The planner's fields that are problem data (derived from the scenario, `planner_config`);
# every other PlanarApproachConfig field is a setting, from PlanarPlannerSettings.
DERIVED_FIELDS = (
    "omega_target_rad_s",
    "theta_target0_rad",
    "chaser_side_m",
    "target_side_m",
    "chaser_mass_kg",
    "chaser_inertia_kg_m2",
    "max_force_N",
    "max_torque_Nm",
    "dt_s",
    "goal_tolerance_m",
)


@dataclasses.dataclass
class PlanarPlannerSettings(planner.PlanarPlannerSettings):
    """The planner's settings (rpod.planners.planar_approach.PlanarPlannerSettings: their docs)
    and the approach attitude; the problem data come from the scenario.

    Args:
        theta_approach_deg: Target attitude at closest approach (Sec. V-A: 3 pi / 4 = 135 deg).
    """

    theta_approach_deg: float = 135.0

    def planner_fields(self) -> dict:
        """These settings as PlanarApproachConfig keyword arguments (theta in radians)."""
        values = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        values["theta_approach_rad"] = math.radians(values.pop("theta_approach_deg"))
        return values

    def validate(self) -> None:
        """Raises ValueError('field: message') naming the first bad field (the planner's own
        checks, on these settings with valid problem data)."""
        try:
            PlanarApproachConfig(**self.planner_fields()).validate()
        except ValueError as error:
            field, _, message = str(error).partition(": ")
            field = "theta_approach_deg" if field == "theta_approach_rad" else field
            raise ValueError(f"{field}: {message}") from None


@dataclasses.dataclass
class PlanarApproach:
    """Plan paper 003's approach (eqs. 5-9) and fly it with the PD tracker (eqs. 11-13).

    Args:
        control_period_s: The tracker's and PWM's period, and the NLP step (Sec. V: 0.1 s).
        planner: The planner's settings; its problem data come from the scenario.
        position_bandwidth_rad_s: w_n of the critically damped position loops.
        attitude_bandwidth_rad_s: w_n of the attitude loop.
        feedforward: Add the planner's wrench to eq. 12 (the paper does not: False).
        after_plan: What comes after the planned arrival: 'co_rotate' (the plan's final pose
            fixed in the target frame), 'rest' (the final pose at rest in L), 'release' (no
            thrust: the chaser coasts from the synchronised state) or 'auto' (co_rotate where
            the hold needs at most HOLD_FORCE_SHARE of the thrusters' force, else release).
        goal_position_tolerance_m: Mission: chaser centre to x_goal at the arrival.
        goal_speed_tolerance_m_s: Mission: speed relative to the target frame at the arrival.
        goal_attitude_tolerance_deg: Mission: heading error to theta_finish at the arrival.
        attitude_reference: The heading the tracker follows: 'plan' (the planner's, the paper)
            or 'face_aligned' (turned onto the docking face before the chaser comes within
            reach of the target: module docstring).
        align_time_s: 'face_aligned': how long the turn onto the docking face takes [s].
    """

    control_period_s: float = 0.1
    planner: PlanarPlannerSettings = dataclasses.field(default_factory=PlanarPlannerSettings)
    position_bandwidth_rad_s: float = 0.4
    attitude_bandwidth_rad_s: float = 0.8
    feedforward: bool = False
    after_plan: str = "co_rotate"
    goal_position_tolerance_m: float = 0.05
    goal_speed_tolerance_m_s: float = 0.03
    goal_attitude_tolerance_deg: float = 5.0
    attitude_reference: str = "plan"
    align_time_s: float = 20.0

    def validate(self) -> None:
        """Raises ValueError('field: message') naming the first bad field."""
        for name in (
            "control_period_s",
            "position_bandwidth_rad_s",
            "attitude_bandwidth_rad_s",
            "goal_position_tolerance_m",
            "goal_speed_tolerance_m_s",
            "goal_attitude_tolerance_deg",
            "align_time_s",
        ):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ValueError(f"{name}: must be a positive number, got {value!r}")
        if self.after_plan not in AFTER_PLAN:
            raise ValueError(f"after_plan: must be one of {AFTER_PLAN}, got {self.after_plan!r}")
        if self.attitude_reference not in ATTITUDE_REFERENCES:
            raise ValueError(
                f"attitude_reference: must be one of {ATTITUDE_REFERENCES}, got "
                f"{self.attitude_reference!r}"
            )
        try:
            self.planner.validate()
        except ValueError as error:
            raise ValueError(f"planner.{error}") from None


# --------------------------------------------------------------------------- problem data


def _yaw(R: np.ndarray) -> float:
    """The rotation's angle about z (atan2 of its first column)."""
    return math.atan2(R[1, 0], R[0, 0])


def _planar_rotation(R: np.ndarray) -> bool:
    """True when R turns about z only (its z column is e_z)."""
    return bool(np.allclose(R[:, 2], [0.0, 0.0, 1.0], rtol=0.0, atol=PLANAR_TOLERANCE))


def initial_planar_state(scenario) -> np.ndarray:
    """x0 = [x, y, theta, v_x, v_y, omega] of eq. 1 from the chaser block (module docstring)."""
    p, v = initial_relative_state_L(scenario)
    theta = _yaw(chaser_rotation_in_lvlh(scenario))
    omega = math.radians(scenario.chaser.w_IC_C_deg_s[2])
    return np.array([p[0], p[1], theta, v[0], v[1], omega])


def planner_config(scenario) -> PlanarApproachConfig:
    """The planner's full config: the settings as written plus the problem data derived from
    the scenario (module docstring)."""
    chaser, target, thrusters = scenario.chaser, scenario.target, scenario.thrusters
    config = scenario.controller
    max_force, max_torque = pa.planar_8_wrench_limits(thrusters.size_m, thrusters.max_thrust_N)
    return PlanarApproachConfig(
        omega_target_rad_s=math.radians(target.w_IT_T_deg_s[2]),
        theta_target0_rad=_yaw(target_rotation_in_lvlh(scenario)),
        chaser_side_m=float(chaser.size_m[0]),
        target_side_m=float(target.size_m[0]),
        chaser_mass_kg=float(chaser.mass_kg),
        chaser_inertia_kg_m2=float(chaser.inertia_kg_m2[2][2]),
        max_force_N=max_force,
        max_torque_Nm=max_torque,
        dt_s=float(config.control_period_s),
        goal_tolerance_m=float(config.goal_position_tolerance_m),
        **config.planner.planner_fields(),
    )


def tracking_config(scenario) -> PlanarTrackingConfig:
    """The PD gains, critically damped for the scenario's chaser at the config's bandwidths."""
    config = scenario.controller
    return PlanarTrackingConfig.critically_damped(
        scenario.chaser.mass_kg,
        scenario.chaser.inertia_kg_m2[2][2],
        config.position_bandwidth_rad_s,
        config.attitude_bandwidth_rad_s,
        config.control_period_s,
    )


# ---------------------------------------------------------------------------- the reference


def co_rotating_hold(
    x_end: np.ndarray, t_end: float, omega: float, duration_s: float
) -> PiecewisePolynomial:
    """The pose x_end fixed in a frame turning at omega about the origin, from t_end on.

    p(t) = R(omega s) p_end, theta(t) = theta_end + omega s, v = omega z x p, omega (s = t -
    t_end), a first-order hold on knots HOLD_KNOT_STEP_S apart over duration_s.
    """
    s = np.linspace(0.0, duration_s, max(2, math.ceil(duration_s / HOLD_KNOT_STEP_S) + 1))
    c, si = np.cos(omega * s), np.sin(omega * s)
    x, y = c * x_end[0] - si * x_end[1], si * x_end[0] + c * x_end[1]
    knots = np.vstack([x, y, x_end[2] + omega * s, -omega * y, omega * x, np.full_like(s, omega)])
    return PiecewisePolynomial.FirstOrderHold(t_end + s, knots)


def contact_reach_m(config: PlanarApproachConfig) -> float:
    """Centre distance below which two squares can touch at some attitudes: the sum of their
    half-diagonals (eq. 10's worst case, without the margin)."""
    return 0.5 * math.sqrt(2.0) * (config.chaser_side_m + config.target_side_m)


def face_aligned_reference(
    plan: PlanarPlan, config: PlanarApproachConfig, align_time_s: float
) -> PiecewisePolynomial:
    """The plan's x(t) with its heading turned onto the docking face before the chaser can
    touch the target (module docstring, `attitude_reference: face_aligned`).

    t_c: the first knot within contact_reach_m + l_margin of the target centre (none: the
    plan's own heading). theta_face(t) = theta_finish + omega_t (t - T) + 2 pi k (the chaser's +x
    face against the target's docking face, k making the turn shortest at t_c), and
    theta_ref = theta_plan + s (theta_face - theta_plan), s = smoothstep((t - t_c) / tau + 1)
    (0 before t_c - tau, 1 from t_c on), omega_ref its derivative. Positions and velocities are
    the plan's, a first-order hold on its knots as plan.x_traj.
    """
    t, X = plan.t_knots, plan.x_knots.copy()
    near = np.flatnonzero(
        np.linalg.norm(X[:, :2], axis=1) < contact_reach_m(config) + config.geometry.margin_m
    )
    if not len(near):
        return copy.copy(plan.x_traj)
    t_c = float(t[near[0]])
    tau = min(align_time_s, t_c) if t_c > 0.0 else 0.0
    omega_t = config.omega_target_rad_s
    face = plan.theta_finish + omega_t * (t - plan.duration_s)
    k = round((X[near[0], 2] - face[near[0]]) / (2.0 * math.pi))
    face = face + 2.0 * math.pi * k
    if tau > 0.0:
        u = np.clip((t - t_c) / tau + 1.0, 0.0, 1.0)
        s = u**3 * (10.0 - 15.0 * u + 6.0 * u**2)
        ds = 30.0 * u**2 * (1.0 - u) ** 2 / tau
    else:
        s, ds = (t >= t_c).astype(float), np.zeros_like(t)
    delta = face - X[:, 2]
    X[:, 5] = X[:, 5] + s * (omega_t - X[:, 5]) + ds * delta
    X[:, 2] = X[:, 2] + s * delta
    return PiecewisePolynomial.FirstOrderHold(t, X.T)


@dataclasses.dataclass
class PlanarApproachRun:
    """What one run plans and flies, kept on the tracker (`tracker.planar_run`).

    Attributes:
        config: The planner's full config (settings and derived problem data).
        plan: The planner's answer.
        check: `check_plan`'s report of a successful plan (None otherwise).
        reference: The tracker's reference x_ref(t) (6 x 1).
        feedforward: Its feed-forward wrench in L (3 x 1), or None.
        x0: The start state.
        after_plan: What is flown after the arrival: 'co_rotate', 'rest' or 'release' ('auto'
            resolved).
    """

    config: PlanarApproachConfig
    plan: PlanarPlan
    check: dict | None
    reference: PiecewisePolynomial
    feedforward: PiecewisePolynomial | None
    x0: np.ndarray
    after_plan: str = "co_rotate"

    @property
    def release_time_s(self) -> float | None:
        """When the tracker stops commanding (the arrival, with 'release'), else None."""
        return self.arrival_s if self.after_plan == "release" else None

    @property
    def arrival_s(self) -> float:
        """The planned arrival T (nan without a plan)."""
        return float(self.plan.duration_s) if self.plan.flyable else math.nan


def plan_scenario(scenario) -> tuple[PlanarApproachConfig, np.ndarray, PlanarPlan, dict | None]:
    """(planner config, x0, plan, check report or None): the plan from the scenario's initial
    state, no simulation (what the closed loop plans; check_plan on a success)."""
    config = planner_config(scenario)
    x0 = initial_planar_state(scenario)
    plan = plan_approach(config, x0)
    return config, x0, plan, check_plan(plan, config) if plan.flyable else None


def make_run(scenario) -> PlanarApproachRun:
    """Plans and builds the reference (module docstring: after the plan, on failure)."""
    config, x0, plan, check = plan_scenario(scenario)
    block = scenario.controller
    feedforward = None
    if not plan.flyable:  # hold the start pose, at rest
        hold = np.concatenate([x0[:3], np.zeros(3)])
        reference = PiecewisePolynomial.FirstOrderHold([0.0, 1.0], np.column_stack([hold, hold]))
        return PlanarApproachRun(config, plan, check, reference, None, x0, "rest")
    T = float(plan.duration_s)
    after_plan = block.after_plan
    if after_plan == "auto":
        after_plan = (
            "co_rotate" if hold_force_ratio(plan, config) <= HOLD_FORCE_SHARE else "release"
        )
    if block.attitude_reference == "face_aligned":
        reference = face_aligned_reference(plan, config, block.align_time_s)
    else:
        reference = copy.copy(plan.x_traj)  # a copy: the plan's own trajectory is left as is
    if block.feedforward:
        feedforward = copy.copy(plan.wrench_traj)  # held on each step over [0, T]
    hold_s = max(scenario.duration_s - T, 0.0)
    if after_plan == "co_rotate" and hold_s > 0.0:
        hold = co_rotating_hold(plan.x_knots[-1], T, config.omega_target_rad_s, hold_s)
        reference.ConcatenateInTime(hold)
        if feedforward is not None:  # the centripetal force m omega^2 (-p), no torque
            p = hold.vector_values(hold.get_segment_times())[:2]
            force = -config.chaser_mass_kg * config.omega_target_rad_s**2 * p
            wrench = np.vstack([force, np.zeros(force.shape[1])])
            feedforward.ConcatenateInTime(
                PiecewisePolynomial.FirstOrderHold(hold.get_segment_times(), wrench)
            )
    return PlanarApproachRun(config, plan, check, reference, feedforward, x0, after_plan)


def formulation_text(config: PlanarApproachConfig, block: PlanarApproach) -> str:
    """The formulation a run planned and flew, in one line: the cost (eq. 5, with (5') and
    its weight), the State II switch, the goal constraints, the candidates, the tracker."""
    parts = [
        "eq. 5"
        if config.w_terminal_velocity == 0.0
        else f"eq. 5 + (5') w_v {config.w_terminal_velocity:g}",
        "State II facing the face" if config.state_ii_heading else "position-only switch",
    ]
    if config.goal_constraint:
        parts.append("goal as constraints")
    candidates = f"{config.max_duration_candidates} candidates"
    if config.max_extra_candidates:
        candidates += f" + up to {config.max_extra_candidates} more"
    parts.append(candidates)
    parts.append("PD + feed-forward" if block.feedforward else "PD")
    parts.append(f"after the arrival: {block.after_plan}")
    return ", ".join(parts)


def hold_force_ratio(plan: PlanarPlan, config: PlanarApproachConfig) -> float:
    """The co-rotating hold's centripetal force m omega_t^2 |p_N| over the thrusters' least
    force (along an axis): above 1 the hold cannot be flown."""
    radius = float(np.linalg.norm(plan.x_knots[-1, :2]))
    return config.chaser_mass_kg * config.omega_target_rad_s**2 * radius / config.max_force_N


# ------------------------------------------------------------------------------- results


def _finite(value):
    """A float, or None when it is not finite (strict JSON has no NaN)."""
    if value is None:
        return None
    value = float(value)
    return value if math.isfinite(value) else None


def planar_log(run: PlanarApproachRun, scenario, log: dict) -> dict:
    """The per-sample arrays the plug-in adds to log.npz (prefixed planar_; N samples):

    planar_plan_state (N, 6) the plan x(t) of eq. 1 at each sample (NaN outside [0, T]);
    planar_flown_state (N, 6) the truth's [x, y, theta, v_x, v_y, omega] in L (theta unwrapped);
    planar_position_error_m (N) |p - p_plan| (NaN outside [0, T]);
    planar_attitude_error_rad (N) theta - theta_ref wrapped, against the heading the tracker
    follows (the plan's, or with 'face_aligned' the turned one; NaN outside [0, T]);
    planar_target_yaw_rad (N) theta_t, unwrapped; planar_relative_velocity_T (N, 2) the chaser's
    velocity relative to the target, seen and expressed in T (Fig. 7): R(theta_t)^T (v -
    omega_t z x p); planar_p_T (N, 2) the chaser centre in T; planar_keepout_state (N) the KOS
    state (1 or 2) at the chaser's pose (State II needs the heading facing the docking face,
    rpod.models.planar_approach); planar_keepout_q_m (N) q of eq. 9 there (< 0 inside the
    zone); planar_goal_L (N, 2) x_goal; planar_chaser_side_m, planar_target_side_m (N).
    """
    config, plan = run.config, run.plan
    t = np.asarray(log["t"], float)
    n = len(t)
    R_IL = rotations_from_wxyz(log["q_IL"])
    R_LC = np.einsum("nji,njk->nik", R_IL, rotations_from_wxyz(log["q_IC"]))
    R_LT = np.einsum("nji,njk->nik", R_IL, rotations_from_wxyz(log["q_IT"]))
    theta = np.unwrap(np.arctan2(R_LC[:, 1, 0], R_LC[:, 0, 0]))
    # w_LC_L z = (R_LC w_IC_C) z - w_IL_L z (rpod.systems.planar_tracking).
    omega = np.einsum("nj,nj->n", R_LC[:, 2], log["w_IC_C"]) - log["w_IL_L"][:, 2]
    p, v = log["p_LC_L"][:, :2], log["v_LC_L"][:, :2]
    flown = np.column_stack([p, theta, v, omega])
    theta_t = np.unwrap(np.arctan2(R_LT[:, 1, 0], R_LT[:, 0, 0]))
    omega_t = np.einsum("nj,nj->n", R_LT[:, 2], log["w_IT_T"]) - log["w_IL_L"][:, 2]
    c, s = np.cos(theta_t), np.sin(theta_t)
    v_rel = v - omega_t[:, None] * np.column_stack([-p[:, 1], p[:, 0]])
    v_rel_T = np.column_stack(
        [c * v_rel[:, 0] + s * v_rel[:, 1], -s * v_rel[:, 0] + c * v_rel[:, 1]]
    )
    p_T = np.column_stack([c * p[:, 0] + s * p[:, 1], -s * p[:, 0] + c * p[:, 1]])
    heading_error = pa.face_heading_error(theta, theta_t)
    geometry = config.geometry
    planned = np.full((n, 6), np.nan)
    heading = np.full(n, np.nan)  # the tracked heading: the plan's, or turned to the face
    if plan.flyable:
        within = t <= plan.duration_s + 1e-9
        planned[within] = plan.x_traj.vector_values(t[within]).T
        heading[within] = run.reference.vector_values(t[within])[2]
    error = np.linalg.norm(p - planned[:, :2], axis=1)
    attitude = (theta - heading + math.pi) % (2.0 * math.pi) - math.pi
    return {
        "planar_plan_state": planned,
        "planar_flown_state": flown,
        "planar_position_error_m": error,
        "planar_attitude_error_rad": attitude,
        "planar_target_yaw_rad": theta_t,
        "planar_relative_velocity_T": v_rel_T,
        "planar_p_T": p_T,
        "planar_keepout_state": geometry.state(p_T, heading_error).astype(np.int64),
        "planar_keepout_q_m": geometry.q(p_T, heading_error),
        "planar_goal_L": np.tile(config.goal_position, (n, 1)),
        "planar_chaser_side_m": np.full(n, config.chaser_side_m),
        "planar_target_side_m": np.full(n, config.target_side_m),
    }


def switch_count(log: dict, scenario, period_s: float, until: int | None = None) -> int | None:
    """ON/OFF transitions of all thrusters up to sample `until` (the thrusters start OFF), or
    None when the log does not sample every PWM slot (module docstring)."""
    t = np.asarray(log["t"], float)
    end = len(t) if until is None else until + 1
    thrusters = scenario.thrusters
    slot = period_s / thrusters.subdivisions if thrusters.pwm else period_s
    if np.any(np.diff(t[:end]) > slot * (1.0 + 1e-6)):
        return None
    on = np.asarray(log["thruster_on"][:end]) > 0.5
    return int(np.count_nonzero(on[1:] != on[:-1]) + np.count_nonzero(on[:1]))


def plan_separation(run: PlanarApproachRun, scenario) -> tuple[float, float | None]:
    """(least separation of the true shapes along the plan [m], first planned time they touch
    or None), at the plan's knots, the target turning as the planner predicts it: whether a
    contact of the flown run was already in the plan. Exact: bounding spheres skip only the
    knots that cannot be nearer than the least exact separation found."""
    if not run.plan.flyable:
        return math.nan, None
    chaser_shape, target_shape = body_polytopes(scenario)
    reach = sum(float(np.max(np.linalg.norm(s.vertices, axis=1))) for s in body_polytopes(scenario))
    config, t, X = run.config, run.plan.t_knots, run.plan.x_knots
    theta_t = pa.target_attitude(t, config.theta_target0_rad, config.omega_target_rad_s)
    distance = np.linalg.norm(X[:, :2], axis=1) - reach  # a lower bound: bounding spheres
    # Exact where the bound is not above the least exact distance so far (nearest first), so
    # the minimum returned is exact, and every touching knot (bound <= 0) is evaluated.
    best = math.inf
    for k in np.argsort(distance):
        if distance[k] > 0.0 and distance[k] >= best:
            break
        distance[k] = separation_distance(
            target_shape,
            _rotation_z(theta_t[k]),
            np.zeros(3),
            chaser_shape,
            _rotation_z(X[k, 2]),
            np.array([X[k, 0], X[k, 1], 0.0]),
        )
        best = min(best, distance[k])
    touching = np.flatnonzero(distance <= 0.0)
    return float(max(np.min(distance), 0.0)), float(t[touching[0]]) if len(touching) else None


def _rotation_z(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _arrival_index(t: np.ndarray, arrival_s: float) -> int:
    """The first sample at or after the arrival (the last one if the run ended before)."""
    return int(min(np.searchsorted(t, arrival_s - 1e-9), len(t) - 1))


def planar_summary(run: PlanarApproachRun, scenario, log: dict, extra: dict) -> dict:
    """The summary.json entries (flat scalars prefixed planar_, for campaign reports)."""
    config, plan, block = run.config, run.plan, scenario.controller
    t = np.asarray(log["t"], float)
    # The approach: up to the arrival sample (the whole run without a plan); after it, the hold.
    # Contact counts over the whole run (the core's ContactWatch, summary["contact"]);
    # planar_contact_after_arrival_s says when a contact began in the hold.
    end = _arrival_index(t, plan.duration_s) if plan.flyable else len(t) - 1
    touching = np.flatnonzero(~(np.asarray(log["separation_m"], float) > 0.0))
    contact = bool(len(touching))
    after = touching[touching > end]
    q = extra["planar_keepout_q_m"][: end + 1]
    summary = {
        "planar_plan_status": plan.status.value,
        "planar_plan_success": bool(plan.success),
        "planar_plan_flown": bool(plan.flyable),
        "planar_plan_message": plan.solver_message,
        "planar_plan_duration_s": _finite(plan.duration_s),
        "planar_plan_cost": _finite(plan.cost),
        **{f"planar_plan_cost_{k}": _finite(v) for k, v in plan.cost_terms.items()},
        "planar_plan_solve_time_s": float(sum(c.solve_time_s for c in plan.candidates)),
        "planar_plan_candidates": [
            {
                "duration_s": c.duration_s,
                "status": c.status.value,
                "message": c.solver_message,
                "solve_time_s": c.solve_time_s,
                "iterations": c.iterations,
                "cost": _finite(c.cost),
            }
            for c in plan.candidates
        ],
        "planar_plan_check_passed": None if run.check is None else bool(run.check["passed"]),
        "planar_plan_terminal_position_error_m": _finite(plan.terminal_position_error_m),
        "planar_omega_target_rad_s": config.omega_target_rad_s,
        "planar_theta_approach_deg": math.degrees(config.theta_approach_rad),
        "planar_thrust_N": float(scenario.thrusters.max_thrust_N),
        "planar_modulation": scenario.thrusters.modulation,
        "planar_formulation": formulation_text(config, block),
        "planar_chaser_side_m": config.chaser_side_m,
        "planar_goal_L": config.goal_position.tolist(),
        "planar_contact": contact,
        "planar_first_contact_s": float(t[touching[0]]) if contact else None,
        "planar_min_keepout_q_m": float(np.min(q)),
        "planar_keepout_intrusion_s": float(np.sum(np.diff(t, append=t[-1])[: end + 1][q < 0.0])),
        "planar_contact_after_arrival_s": float(t[after[0]]) if len(after) else None,
        "planar_switches": switch_count(log, scenario, block.control_period_s),
        "planar_safe": bool(plan.success and not contact),  # whole run, goal reached by plan
    }
    plan_separation_m, plan_contact_s = plan_separation(run, scenario)
    summary["planar_plan_min_separation_m"] = _finite(plan_separation_m)
    summary["planar_plan_contact_s"] = plan_contact_s
    if run.check is not None:
        summary["planar_plan_terminal_relative_speed_m_s"] = run.check[
            "terminal_relative_speed_m_s"
        ]
        summary["planar_plan_min_keepout_q_m"] = run.check["keepout_q_m"]
    for key in ("rms_tracking_error_m", "max_tracking_error_m", "rms_attitude_error_deg"):
        summary[f"planar_{key}"] = None
    for key in ("position_error_m", "relative_speed_m_s", "attitude_error_deg", "time_s"):
        summary[f"planar_terminal_{key}"] = None
    summary.update(
        planar_delta_v_m_s=None,
        planar_plan_delta_v_m_s=None,
        planar_switches_to_arrival=None,
        planar_state_ii_from_s=None,
        planar_final_relative_speed_m_s=float(
            np.linalg.norm(extra["planar_relative_velocity_T"][-1])
        ),
        planar_final_hold_error_m=None,
        planar_hold_force_ratio=None,
        planar_after_plan=run.after_plan,
        planar_goal_reached=False,
    )
    if not plan.flyable:
        return summary
    T = float(plan.duration_s)
    i = _arrival_index(t, T)
    within = t <= T + 1e-9
    error = extra["planar_position_error_m"][within]
    attitude = extra["planar_attitude_error_rad"][within]
    p_i = log["p_LC_L"][i, :2]
    theta_i = extra["planar_flown_state"][i, 2]
    attitude_i = abs(float(pa.wrap_to_pi(theta_i - plan.theta_finish)))
    speed_i = float(np.linalg.norm(extra["planar_relative_velocity_T"][i]))
    position_i = float(np.linalg.norm(p_i - config.goal_position))
    mass = np.asarray(log["chaser_mass_kg"], float)
    isp = scenario.thrusters.isp_s
    dt_plan = np.diff(plan.t_knots)
    state_ii = np.flatnonzero(extra["planar_keepout_state"] == pa.STATE_II)
    summary.update(
        planar_rms_tracking_error_m=float(np.sqrt(np.mean(error**2))),
        planar_max_tracking_error_m=float(np.max(error)),
        planar_rms_attitude_error_deg=float(np.degrees(np.sqrt(np.mean(attitude**2)))),
        planar_terminal_time_s=float(t[i]),
        planar_terminal_position_error_m=position_i,
        planar_terminal_relative_speed_m_s=speed_i,
        planar_terminal_attitude_error_deg=math.degrees(attitude_i),
        planar_delta_v_m_s=float(STANDARD_GRAVITY_M_S2 * isp * math.log(mass[0] / mass[i])),
        planar_plan_delta_v_m_s=float(
            np.sum(np.linalg.norm(plan.wrench_knots[:, :2], axis=1) * dt_plan)
            / config.chaser_mass_kg
        ),
        planar_switches_to_arrival=switch_count(log, scenario, block.control_period_s, i),
        planar_state_ii_from_s=float(t[state_ii[0]]) if len(state_ii) else None,
    )
    summary["planar_hold_force_ratio"] = hold_force_ratio(plan, config)
    if run.after_plan == "co_rotate" and t[-1] > T:
        # The hold point: the plan's final position turned with the target since T.
        turn = config.omega_target_rad_s * (t[-1] - T)
        c, s = math.cos(turn), math.sin(turn)
        x_N = plan.x_knots[-1]
        hold = np.array([c * x_N[0] - s * x_N[1], s * x_N[0] + c * x_N[1]])
        summary["planar_final_hold_error_m"] = float(np.linalg.norm(log["p_LC_L"][-1, :2] - hold))
    summary["planar_goal_reached"] = bool(
        position_i <= block.goal_position_tolerance_m
        and speed_i <= block.goal_speed_tolerance_m_s
        and math.degrees(attitude_i) <= block.goal_attitude_tolerance_deg
    )
    return summary


def outcome(summary: dict, block: PlanarApproach) -> MissionOutcome:
    """The mission verdict and its one line (module docstring)."""
    if not summary.get("planar_plan_flown", summary["planar_plan_success"]):
        return MissionOutcome(
            False,
            f"NOT a success, NOT flown: plan {summary['planar_plan_status']}: "
            f"{summary['planar_plan_message']}; held the start pose",
        )
    rms = summary["planar_rms_tracking_error_m"]
    terminal = (
        f"at arrival {summary['planar_terminal_time_s']:.1f} s: "
        f"{summary['planar_terminal_position_error_m']:.3f} m from the goal, "
        f"{summary['planar_terminal_relative_speed_m_s']:.3f} m/s relative, "
        f"{summary['planar_terminal_attitude_error_deg']:.1f} deg"
    )
    switches = summary["planar_switches"]
    tail = (
        f"RMS tracking error {100.0 * rms:.2f} cm; final relative speed "
        f"{summary['planar_final_relative_speed_m_s']:.4f} m/s; delta-v to arrival "
        f"{summary['planar_delta_v_m_s']:.4f} m/s"
        + (f"; {switches} thruster switches" if switches is not None else "")
    )
    later = summary["planar_contact_after_arrival_s"]
    if later is not None:
        why = (
            "released at the arrival"
            if summary["planar_after_plan"] == "release"
            else f"the co-rotating hold needs {summary['planar_hold_force_ratio']:.2g}x the "
            "thrusters' force"
        )
        tail += f"; contact after the arrival at {later:.2f} s ({why})"
    missed = ""
    if not summary["planar_plan_success"]:  # flown, but the plan itself misses its goal
        missed = f"the plan missed its goal ({summary['planar_plan_message']}); "
    if summary["planar_contact"]:
        planned = summary["planar_plan_contact_s"]
        where = (
            f"; the plan itself touches from {planned:.1f} s"
            if planned is not None
            else "; the plan does not touch"
        )
        return MissionOutcome(
            False,
            f"NOT a success: contact at {summary['planar_first_contact_s']:.2f} s (true shapes "
            f"touched{where}); {missed}{terminal}; {tail}",
        )
    if missed or not summary["planar_goal_reached"]:
        reached = "reached" if summary["planar_goal_reached"] else "NOT reached"
        return MissionOutcome(
            False,
            f"NOT a success: {missed}goal {reached} {terminal} (tolerances "
            f"{block.goal_position_tolerance_m:g} m, {block.goal_speed_tolerance_m_s:g} m/s, "
            f"{block.goal_attitude_tolerance_deg:g} deg); no contact in the run; {tail}",
        )
    return MissionOutcome(True, f"approached, no contact in the run, {terminal}; {tail}")


# ------------------------------------------------------------------------------ campaigns


def _metric_rows(rows: list[dict]) -> list[dict]:
    """The metrics of the ok runs that are this plug-in's."""
    return [
        row["metrics"]
        for row in rows
        if row.get("status") == "ok"
        and row.get("metrics")
        and "planar_plan_status" in row["metrics"]
    ]


def _mean_std(values) -> str:
    """'mean +- std' of the values given (None left out), or the one value, or '-'."""
    values = np.array([v for v in values if v is not None], float)
    if not values.size:
        return "-"
    if values.size == 1:
        return f"{values[0]:.4g}"
    return f"{values.mean():.4g} +- {values.std():.2g}"


def _share(flags) -> str:
    flags = list(flags)
    return f"{100.0 * sum(flags) / len(flags):.0f}% ({sum(flags)}/{len(flags)})" if flags else "-"


def campaign_rows(rows: list[dict]) -> tuple[str, list[str], list[list[str]]] | None:
    """The `rpod report` table of a planar-approach campaign (rows of the store), or None.

    The title leads with the mission success share of the ok runs (Wilson 95 %), then the
    safety figures (planned to the goal and no contact in the whole run; contact), and names
    the formulation each run recorded (`planar_formulation`); with several, the lines are
    grouped by formulation, labelled A, B, ... in a first column.
    Varying modulation: one line per scheme (tracking error, terminal speed, fuel, switches).
    Else varying theta_approach (Case Study 2, Fig. 9): one line per theta; else varying
    omega_target (Case Study 1, Fig. 8): one line per omega. Each line: runs, planned
    (success), planned terminal error (the paper's "final position error", mean +- std over the
    other parameter), flown RMS tracking error, safe share (planned and no contact), mission.
    """
    metrics = _metric_rows(rows)
    if not metrics:
        return None
    mission = SuccessShare(
        sum((m.get("mission") or {}).get("success") is True for m in metrics), len(metrics)
    )
    safe_share = SuccessShare(sum(bool(m.get("planar_safe")) for m in metrics), len(metrics))
    contact_share = SuccessShare(sum(bool(m.get("planar_contact")) for m in metrics), len(metrics))
    formulations = sorted({m.get("planar_formulation") or UNRECORDED for m in metrics})
    labels = {text: chr(ord("A") + i) for i, text in enumerate(formulations)}
    if len(formulations) == 1:
        named = f"Formulation: {formulations[0]}"
    else:  # one group of lines per formulation, labelled
        named = "Formulations: " + "; ".join(f"{labels[f]}: {f}" for f in formulations)
    lead = (
        f"mission success {mission.percent_text()} of the ok runs; safe (plan reached its goal, "
        f"no contact in the whole run) {safe_share.percent_text()}; contact "
        f"{contact_share.percent_text()}. {named}"
    )
    schemes = sorted({m["planar_modulation"] for m in metrics})
    if len(schemes) > 1:
        header = ["modulation", "runs", "RMS tracking cm", "terminal m/s", "delta-v m/s"]
        header += ["switches", "contact", "mission"]
        table = []
        for scheme in schemes:
            group = [m for m in metrics if m["planar_modulation"] == scheme]
            table.append(
                [
                    scheme,
                    str(len(group)),
                    _mean_std(
                        [
                            100.0 * m["planar_rms_tracking_error_m"]
                            if m["planar_rms_tracking_error_m"] is not None
                            else None
                            for m in group
                        ]
                    ),
                    _mean_std([m["planar_terminal_relative_speed_m_s"] for m in group]),
                    _mean_std([m["planar_delta_v_m_s"] for m in group]),
                    _mean_std([m["planar_switches"] for m in group]),
                    _share([m["planar_contact"] for m in group]),
                    _share([(m.get("mission") or {}).get("success") is True for m in group]),
                ]
            )
        title = (
            f"Paper 003's approach flown with each modulation scheme (beyond the paper): {lead}:"
        )
        return title, header, table
    thetas = sorted({round(m["planar_theta_approach_deg"], 6) for m in metrics})
    key, label = (
        ("planar_theta_approach_deg", "theta_approach deg")
        if len(thetas) > 1
        else ("planar_omega_target_rad_s", "omega_target rad/s")
    )
    values = sorted({round(m[key], 6) for m in metrics})
    header = [label, "runs", "mission", "safe", "planned to the goal"]
    header += ["planned final error m (mean +- std)", "flown RMS tracking m"]
    several = len(formulations) > 1
    table = []
    for formulation, value in itertools.product(formulations, values):
        group = [
            m
            for m in metrics
            if round(m[key], 6) == value
            and (m.get("planar_formulation") or UNRECORDED) == formulation
        ]
        if not group:
            continue
        table.append(
            [labels[formulation]] * several
            + [
                f"{value:g}",
                str(len(group)),
                _share([(m.get("mission") or {}).get("success") is True for m in group]),
                _share([m["planar_safe"] for m in group]),
                _share([m["planar_plan_success"] for m in group]),
                _mean_std([m["planar_plan_terminal_position_error_m"] for m in group]),
                _mean_std([m["planar_rms_tracking_error_m"] for m in group]),
            ]
        )
    case = "2 (Fig. 9)" if len(thetas) > 1 else "1 (Fig. 8)"
    title = f"Paper 003 Case Study {case} beside this campaign: {lead}:"
    return title, ["formulation"] * several + header, table


# -------------------------------------------------------------------------------- plug-in


class PlanarApproachPlugin(ControllerPlugin):
    """Plug-in of rpod.systems.planar_tracking.PlanarTrackingController on a paper-003 plan."""

    config_type = PlanarApproach
    system_name = "planar_tracker"
    log_shapes = LOG_SHAPES

    def run_figures(self) -> dict:
        """Figs. 4-7 of a run (rpod.diagrams.plots_planar)."""
        from rpod.diagrams import plots_planar  # only when drawing: no matplotlib at load

        return plots_planar.run_figures()

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
        if not _planar_rotation(chaser_rotation_in_lvlh(scenario)):
            raise ScenarioError(
                "chaser.rpy_LC_deg", "the chaser must start upright in the plane: roll, pitch 0"
            )
        if max(abs(chaser.w_IC_C_deg_s[0]), abs(chaser.w_IC_C_deg_s[1])) > PLANAR_TOLERANCE:
            raise ScenarioError("chaser.w_IC_C_deg_s", "only a z rate is planar: x, y must be 0")
        if not _planar_rotation(target_rotation_in_lvlh(scenario)):
            field = "target.q_LT" if target.q_LT else "target.rpy_LT_deg"
            raise ScenarioError(field, "the target must start upright in the plane: roll, pitch 0")
        w = target.w_IT_T_deg_s
        if max(abs(w[0]), abs(w[1])) > PLANAR_TOLERANCE or w[2] == 0.0:
            raise ScenarioError(
                "target.w_IT_T_deg_s",
                f"paper 003's target spins about z: [0, 0, omega] with omega != 0, got {list(w)}",
            )
        try:
            planner_config(scenario).validate()
        except ValueError as error:
            raise ScenarioError("controller.planner", str(error)) from None

    def add_to_diagram(self, builder, scenario, sensed) -> ControllerWiring:
        run = make_run(scenario)
        tracker = builder.AddNamedSystem(
            self.system_name,
            PlanarTrackingController(
                tracking_config(scenario), run.reference, run.feedforward, run.release_time_s
            ),
        )
        tracker.planar_run = run  # read by results, planned_end_s and the scene
        tracker.planar_sensed = sensed  # the scene's KOS state reads the same bundle
        builder.Connect(sensed, tracker.GetInputPort(SENSED_PORT))
        return ControllerWiring(
            tracker,
            Actuation.BODY_WRENCH,
            tracker.GetOutputPort("body_wrench_desired"),
            scenario.controller.control_period_s,
            {key: tracker.GetOutputPort(port) for key, port in LOGGED.items()},
        )

    def planned_end_s(self, wiring, context) -> float | None:
        """The planned arrival T; 0 without a plan (the start pose is held from t = 0)."""
        run = wiring.system.planar_run
        return run.arrival_s if run.plan.flyable else 0.0

    def add_scene_extras(self, builder, meshcat, scenario, wiring, scene=None) -> None:
        """The keep-out zone on the target frame, State I or II as the chaser's state says, and
        the planned path (rpod.systems.planar_scene)."""
        from rpod.systems.planar_scene import add_planar_scene  # only when drawing

        run = wiring.system.planar_run
        path = run.plan.x_knots[:, :2] if run.plan.flyable else np.zeros((0, 2))
        add_planar_scene(
            builder,
            meshcat,
            run.config.geometry,
            wiring.system.planar_sensed,
            publish_period_s=scenario.visualization.publish_period_s,
            planned_path_L=path,
            goal_L=run.config.goal_position,
            height_m=float(scenario.target.size_m[2]),
        )

    def campaign_table(self, rows):
        """Paper 003's case studies or the modulation comparison (`campaign_rows`)."""
        return campaign_rows(rows)

    def campaign_figures(self, rows, out_dir):
        """Figs. 8-9-like maps of a campaign (rpod.diagrams.plots_planar.write_campaign_maps),
        for `rpod report`."""
        from rpod.diagrams.plots_planar import write_campaign_maps

        return write_campaign_maps(_metric_rows(rows), out_dir)

    def results(self, scenario, wiring, context, log) -> ControllerResults:
        run = wiring.system.planar_run
        extra = planar_log(run, scenario, log)
        summary = planar_summary(run, scenario, log, extra)
        return ControllerResults(
            summary=summary, log=extra, outcome=outcome(summary, scenario.controller)
        )


register_controller(PlanarApproachPlugin())
