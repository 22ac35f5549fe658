"""Paper 001's NMPC problem data from the scenario, never re-typed, and the planner built on it.

Owns: `feature_points`, `coupled_params` (the prediction model's data) and `make_planner` (the
NMPC of the scenario's `!CoupledNmpc` block).
Does not own: the prediction model (rpod.models.coupled_relative), the NLP
(rpod.planners.coupled_nmpc) or the config (config.py).

Problem data from the scenario: the chaser's mass and inertia (chaser.mass_kg,
chaser.inertia_kg_m2), the target's inertia (target.inertia_kg_m2, J_t of eq. 2), the thrusters
(make_thruster_layout: positions, nominal directions, gimbal angle, f_max; the layout must be
gimbaled_cuboid_8 on a chaser box of the cuboid it assumes), and the two feature points: the
rock r^t_pt/t is target.docking_port_T and the end effector r^c_pc/c is chaser.capture_point_C
(so the run's own capture_distance_m and capture_speed_m_s measure the feature points too),
unless `target_feature_point_T_m` / `chaser_feature_point_C_m` name others. The weights of
eqs. 20-21 are Sec. IV's (rpod.models.coupled_relative.CoupledNmpcWeights, with its stated
reading of the printed exponents and its choice of P), except the integral weight Q_xi, the
config's `integral_weight` (config.py says why its default is not the paper's printed value).
The chaser mass is the scenario's wet mass at t = 0: the prediction does not see the propellant
burned (~0.1 % of it on Sec. IV's manoeuvre).
"""

import dataclasses

import numpy as np

from rpod.diagrams.scenario import make_thruster_layout
from rpod.models import coupled_relative as cr
from rpod.models.thrusters import ThrusterLayout
from rpod.planners.coupled_nmpc import CoupledNmpc as CoupledNmpcPlanner


def _planning_layout(layout: ThrusterLayout, max_thrust_N: float) -> ThrusterLayout:
    """The layout with every f_max set to max_thrust_N (0: unchanged)."""
    if max_thrust_N == 0:
        return layout
    thrusters = [dataclasses.replace(t, max_thrust_N=max_thrust_N) for t in layout.thrusters]
    return ThrusterLayout(thrusters=thrusters, gimbaled=layout.gimbaled)


def feature_points(scenario) -> tuple[np.ndarray, np.ndarray]:
    """(p_TPt_T, p_CPc_C): the config's, or the scenario's docking port and capture point."""
    config = scenario.controller
    p_TPt_T = config.target_feature_point_T_m or scenario.target.docking_port_T
    p_CPc_C = config.chaser_feature_point_C_m or scenario.chaser.capture_point_C
    return np.asarray(p_TPt_T, dtype=float), np.asarray(p_CPc_C, dtype=float)


def coupled_params(scenario) -> cr.CoupledRelativeParams:
    """The prediction model's data from the scenario (module docstring)."""
    config = scenario.controller
    p_TPt_T, p_CPc_C = feature_points(scenario)
    return cr.CoupledRelativeParams(
        chaser_mass_kg=float(scenario.chaser.mass_kg),
        J_c=np.asarray(scenario.chaser.inertia_kg_m2, dtype=float),
        J_t=np.asarray(scenario.target.inertia_kg_m2, dtype=float),
        p_TPt_T=p_TPt_T,
        p_CPc_C=p_CPc_C,
        layout=_planning_layout(make_thruster_layout(scenario), config.max_thrust_N),
    )


def make_planner(scenario) -> CoupledNmpcPlanner:
    """The NMPC of the scenario's `!CoupledNmpc` block, on the scenario's problem data."""
    config = scenario.controller
    weights = cr.CoupledNmpcWeights(Q_xi=config.integral_weight * np.eye(3))
    return CoupledNmpcPlanner(coupled_params(scenario), weights, dataclasses.replace(config.nmpc))
