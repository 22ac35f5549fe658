"""Paper 003's problem data from the scenario, never re-typed, and the tracker's gains.

Owns: `planner_config` (the planner's full config: the settings as written plus the problem
data), `PlanarStart` (what the plan starts from, as sensed at t = 0), `initial_planar_state`
(x0 of eq. 1 as the scenario writes it), `tracking_config` (the PD gains), the fields that
are problem data (`DERIVED_FIELDS`) and the planar tolerance the plug-in's checks use.
Does not own: the planner (rpod.planners.planar_approach), the planar world's conventions
(rpod.models.planar_approach) or the PD law (rpod.systems.planar_tracking).

Problem data from the scenario, never re-typed (`planner_config`). Under `orbit.gravity:
free_space` the LVLH frame L is paper 003's inertial frame, the target centre its origin:
- omega_target = target.w_IT_T_deg_s z (a flat spin: x, y must be 0), theta_target0 = the
  target's initial yaw in L (q_LT or rpy_LT_deg; roll and pitch 0);
- the chaser's start x0 = [p_LC_L x, y, yaw of R_LC, v_LC_L x, y (seen in L), w_IC_C z].
The closed loop and `rpod plan` take the start, the target's yaw and its spin from the sensed
bundle at t = 0 instead (`PlanarStart`; on `!Truth` the same numbers, bit for bit: the truth
holds the scenario's values; on `!Ekf` the estimate's);
- l_s = chaser.size_m x (= y), l_t = target.size_m x (= y) (eq. 10), m = chaser.mass_kg,
  I = chaser.inertia_kg_m2 zz;
- the wrench limits (8) = `planar_8_wrench_limits(thrusters.size_m, thrusters.max_thrust_N)`;
- the NLP step dt = controller.control_period_s (Sec. V: the 0.1 s control period is the
  optimisation's time step).
The tracker's gains are `PlanarTrackingConfig.critically_damped(m, I_zz, ...)` at the
config's bandwidths and period.
"""

import dataclasses
import math

import numpy as np

from rpod.diagrams.scenario import (
    chaser_rotation_in_lvlh,
    initial_relative_state_L,
    target_rotation_in_lvlh,
)
from rpod.models import planar_approach as pa
from rpod.models.frames import rotation_from_wxyz
from rpod.planners.planar_approach import PlanarApproachConfig
from rpod.systems.planar_tracking import PlanarTrackingConfig, planar_state_from_sensed
from rpod.systems.sensed import Sensed

PLANAR_TOLERANCE = 1e-9  # z, roll, pitch, off-plane rates and inertia products must be 0 to this

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


def _yaw(R: np.ndarray) -> float:
    """The rotation's angle about z (atan2 of its first column)."""
    return math.atan2(R[1, 0], R[0, 0])


def is_planar_rotation(R: np.ndarray) -> bool:
    """True when R turns about z only (its z column is e_z)."""
    return bool(np.allclose(R[:, 2], [0.0, 0.0, 1.0], rtol=0.0, atol=PLANAR_TOLERANCE))


def initial_planar_state(scenario) -> np.ndarray:
    """x0 = [x, y, theta, v_x, v_y, omega] of eq. 1 from the chaser block (module docstring)."""
    p, v = initial_relative_state_L(scenario)
    theta = _yaw(chaser_rotation_in_lvlh(scenario))
    omega = math.radians(scenario.chaser.w_IC_C_deg_s[2])
    return np.array([p[0], p[1], theta, v[0], v[1], omega])


@dataclasses.dataclass(frozen=True)
class PlanarStart:
    """What paper 003's plan starts from, as the controller senses it at t = 0.

    Attributes:
        x0: the chaser's [x, y, theta, v_x, v_y, omega] (eq. 1).
        theta_target0_rad: the target's yaw in L.
        omega_target_rad_s: the target's spin about L's z (w_LT_L z).
    """

    x0: np.ndarray
    theta_target0_rad: float
    omega_target_rad_s: float

    @classmethod
    def from_sensed(cls, sensed: Sensed) -> "PlanarStart":
        """From a sensed bundle: the chaser as the tracker reads it (planar_state_from_sensed),
        the target the same way (the yaw of R_LT; R_LT's z row on w_IT_T, less w_IL_L z)."""
        R_LT = rotation_from_wxyz(sensed.q_IL).T @ rotation_from_wxyz(sensed.q_IT)
        omega = float(R_LT[2] @ sensed.w_IT_T) - float(sensed.w_IL_L[2])
        return cls(planar_state_from_sensed(sensed), _yaw(R_LT), omega)


def planner_config(scenario, start: PlanarStart | None = None) -> PlanarApproachConfig:
    """The planner's full config: the settings as written plus the problem data derived from
    the scenario (module docstring), the target's yaw and spin from `start` when given (what
    the controller sensed at t = 0) rather than from the scenario's target block."""
    chaser, target, thrusters = scenario.chaser, scenario.target, scenario.thrusters
    config = scenario.controller
    max_force, max_torque = pa.planar_8_wrench_limits(thrusters.size_m, thrusters.max_thrust_N)
    if start is None:
        omega_target = math.radians(target.w_IT_T_deg_s[2])
        theta_target0 = _yaw(target_rotation_in_lvlh(scenario))
    else:
        omega_target, theta_target0 = start.omega_target_rad_s, start.theta_target0_rad
    return PlanarApproachConfig(
        omega_target_rad_s=omega_target,
        theta_target0_rad=theta_target0,
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
