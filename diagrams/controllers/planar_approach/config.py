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
