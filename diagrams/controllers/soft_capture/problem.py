"""Paper 000's soft-capture problem data, derived from the scenario (never re-typed).

Owns: `planner_config` (the planner's full config: the scenario's settings plus the problem
data: the orbit gives a, the chaser its mass and capture point D_c, the target its docking port
D_t and cone angle) and `controller_config` (the closed loop's config with it).
Does not own: the planner (rpod.planners.soft_capture) or the closed loop
(rpod.systems.soft_capture_controller).
"""

import dataclasses

from rpod.models.gravity import R_EARTH_M
from rpod.planners.soft_capture import SoftCaptureConfig
from rpod.systems.soft_capture_controller import SoftCaptureControllerConfig


def planner_config(scenario) -> SoftCaptureConfig:
    """The planner's full config: the scenario's settings plus the problem data derived from
    orbit (a = R_earth + altitude), chaser (mass, D_c) and target (D_t, cone angle)."""
    chaser, target = scenario.chaser, scenario.target
    return SoftCaptureConfig.from_settings(
        scenario.controller.planner,
        semi_major_axis_m=R_EARTH_M + scenario.orbit.altitude_m,
        chaser_mass_kg=chaser.mass_kg,
        docking_half_angle_deg=target.corridor_half_angle_deg,
        p_CDc_C=chaser.capture_point_C,
        p_TDt_T=target.docking_port_T,
    )


def controller_config(scenario) -> SoftCaptureControllerConfig:
    """The closed loop's config with the full planner config (what the system consumes)."""
    config = scenario.controller
    values = {f.name: getattr(config, f.name) for f in dataclasses.fields(config)}
    return SoftCaptureControllerConfig(**(values | {"planner": planner_config(scenario)}))
