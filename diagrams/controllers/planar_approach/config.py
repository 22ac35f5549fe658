"""Paper 003's planar approach config: the YAML tag `!PlanarApproach`.

Owns: `PlanarApproach` (the planner's settings, the tracker's bandwidths, what is flown after
the plan and the heading it follows, the goal tolerances) and `PlanarPlannerSettings` (the
planner's settings and the approach attitude; the problem data come from the scenario,
problem.py), with their `validate()`; the choices of `after_plan` and `attitude_reference`
(reference.py says what each flies) and HOLD_FORCE_SHARE, where 'auto' switches.
Does not own: the planner's own settings and checks (rpod.planners.planar_approach) or what
is derived from the scenario (problem.py).
"""

import dataclasses
import math

from rpod.models.config import ConfigError, bounded, check_bounds, positive
from rpod.planners import planar_approach as planner
from rpod.planners.planar_approach import PlanarApproachConfig

AFTER_PLAN = ("co_rotate", "rest", "release", "auto")
HOLD_FORCE_SHARE = 0.5
"""'auto' co-rotates when the hold's centripetal force is at most this share of the thrusters'
force along an axis (the rest is the tracker's), and releases the chaser otherwise."""
ATTITUDE_REFERENCES = ("plan", "face_aligned")


@dataclasses.dataclass
class PlanarPlannerSettings(planner.PlanarPlannerSettings):
    """The planner's settings (rpod.planners.planar_approach.PlanarPlannerSettings: their docs)
    and the approach attitude; the problem data come from the scenario.

    Args:
        theta_approach_deg: Target attitude at closest approach (Sec. V-A: 3 pi / 4 = 135 deg),
            within a turn either way (the planner's theta_approach_rad bound).
    """

    theta_approach_deg: float = bounded(135.0, -360.0, 360.0)

    def planner_fields(self) -> dict:
        """These settings as PlanarApproachConfig keyword arguments (theta in radians)."""
        values = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        values["theta_approach_rad"] = math.radians(values.pop("theta_approach_deg"))
        return values

    def validate(self) -> None:
        """Raises ConfigError naming the first bad field: the bounds of these settings
        (theta_approach_deg's in degrees), then the planner's own checks on them with valid
        problem data (theta_approach_rad named as theta_approach_deg)."""
        check_bounds(self)
        try:
            PlanarApproachConfig(**self.planner_fields()).validate()
        except ConfigError as error:
            field = "theta_approach_deg" if error.field == "theta_approach_rad" else error.field
            raise ConfigError(field, error.message) from None


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

    Bounds (rpod.models.config, checked by `validate()`): the period in (0, 300] s (it is also
    the planner's step dt_s: at most MAX_PLAN_KNOTS of them in planner.duration_max_s);
    bandwidths in (0, 10] rad/s; the position tolerance within 1 km (the planner's
    goal_tolerance_m), the speed tolerance up to 100 m/s, the heading tolerance in (0, 180] deg;
    the turn within an hour, as the planner's durations.
    """

    control_period_s: float = positive(0.1, 300.0)
    planner: PlanarPlannerSettings = dataclasses.field(default_factory=PlanarPlannerSettings)
    position_bandwidth_rad_s: float = positive(0.4, 10.0)
    attitude_bandwidth_rad_s: float = positive(0.8, 10.0)
    feedforward: bool = False
    after_plan: str = "co_rotate"
    goal_position_tolerance_m: float = positive(0.05, 1e3)
    goal_speed_tolerance_m_s: float = positive(0.03, 1e2)
    goal_attitude_tolerance_deg: float = positive(5.0, 180.0)
    attitude_reference: str = "plan"
    align_time_s: float = positive(20.0, 3600.0)

    def validate(self) -> None:
        """Raises ConfigError naming the first bad field: its declared bounds (check_bounds,
        `planner.<field>` included), then the choices, the planner's own checks and the
        planner's knots at this period."""
        check_bounds(self)
        if self.after_plan not in AFTER_PLAN:
            raise ConfigError("after_plan", f"must be one of {AFTER_PLAN}, got {self.after_plan!r}")
        if self.attitude_reference not in ATTITUDE_REFERENCES:
            raise ConfigError(
                "attitude_reference",
                f"must be one of {ATTITUDE_REFERENCES}, got {self.attitude_reference!r}",
            )
        try:
            self.planner.validate()
        except ConfigError as error:
            raise error.under("planner") from None
        # The period is the planner's step dt_s: the longest candidate's knots, which the
        # planner checks too (on problem.planner_config), here named by the field written.
        knots = self.planner.duration_max_s / self.control_period_s
        if knots - 1e-9 > planner.MAX_PLAN_KNOTS:
            raise ConfigError(
                "control_period_s",
                f"planner.duration_max_s / control_period_s (the planner's step) is {knots:.6g} "
                f"knots, must be at most {planner.MAX_PLAN_KNOTS}",
            )
