"""Paper 001's NMPC problem data from the scenario, never re-typed, and the planner built on it.

Owns: `feature_points`, `planning_frame_R_CCp` (the chaser frame the planner works in),
`coupled_params` (the prediction model's data), `coupled_weights` (eqs. 20-21's, from the
config) and `make_planner` (the NMPC of the scenario's `!CoupledNmpc` block).
Does not own: the prediction model (rpod.models.coupled_relative), the NLP
(rpod.planners.coupled_nmpc) or the config (config.py).

Problem data from the scenario: the chaser's mass and inertia (chaser.mass_kg,
chaser.inertia_kg_m2), the target's inertia (target.inertia_kg_m2, J_t of eq. 2), the thrusters
(make_thruster_layout: positions, nominal directions, gimbal angle, f_max; gimbaled_cuboid_8
on a chaser box of the cuboid it assumes, or a fixed bank, planned as one thrust per thruster:
rpod.models.coupled_relative), and the two feature points: the
rock r^t_pt/t is target.docking_port_T and the end effector r^c_pc/c is chaser.capture_point_C
(so the run's own capture_distance_m and capture_speed_m_s measure the feature points too),
unless `target_feature_point_T_m` / `chaser_feature_point_C_m` name others. The weights of
eqs. 20-21 are Sec. IV's (rpod.models.coupled_relative.CoupledNmpcWeights, with its stated
reading of the printed exponents and its choice of P), except the integral weight Q_xi, the
config's `integral_weight` (config.py says why its default is not the paper's printed value);
the config's `weights` can change each (Sec. IV's by default, bit for bit).

The chaser mass is the scenario's wet mass at t = 0: the prediction does not see the propellant
burned (~0.1 % of it on Sec. IV's manoeuvre).

The attitude goal. Eq. 20's Q_R tr(D - D R_TC) drives the chaser's axes onto the target's (the
paper's grasp: its end effector is below the chaser and the rock on top of the asteroid). A
chaser that docks faces the port instead: with `attitude_goal: facing` the planner works in a
chaser frame C' (R_CC' = R_TC*^T, fixed in the chaser) in which that goal is R_TC' = I: R_TC*
turns the chaser's capture axis c (its feature point's direction in C) onto -a, a the target
feature point's outward axis, by the least rotation (180 deg about the C axis least aligned
with c when c and a are parallel). Everything in C is carried into C' (inertia, feature
point, thruster positions and nozzle directions), and the controller gives the planner the
chaser's attitude as C''s; a fixed bank's thrust per thruster is the same in either frame.
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


def _unit(v) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v)


def facing_attitude_R_TC(p_TPt_T, p_CPc_C) -> np.ndarray:
    """R_TC* of `attitude_goal: facing` (module docstring): the least rotation that turns the
    capture axis c = unit(p_CPc_C) onto -a, a = unit(p_TPt_T) (180 deg about the C axis least
    aligned with c when c = a)."""
    c, goal = _unit(p_CPc_C), -_unit(p_TPt_T)
    axis = np.cross(c, goal)
    sin, cos = float(np.linalg.norm(axis)), float(c @ goal)
    if sin < 1e-12:
        if cos > 0:
            return np.eye(3)
        least = np.zeros(3)
        least[int(np.argmin(np.abs(c)))] = 1.0
        axis = _unit(np.cross(c, least))
        return 2.0 * np.outer(axis, axis) - np.eye(3)  # 180 deg about axis
    K = np.cross(np.eye(3), axis / sin)  # [k]x
    return np.eye(3) + sin * K + (1.0 - cos) * K @ K  # Rodrigues


def planning_frame_R_CCp(scenario) -> np.ndarray | None:
    """R_CC' of the chaser frame C' the planner works in (module docstring): R_TC*^T with
    `attitude_goal: facing`, None with 'aligned' (C itself)."""
    if scenario.controller.attitude_goal != "facing":
        return None
    return facing_attitude_R_TC(*feature_points(scenario)).T


def _layout_in(layout: ThrusterLayout, R_CCp: np.ndarray) -> ThrusterLayout:
    """The layout described in C' (positions and nozzle directions turned by R_CC'^T)."""
    thrusters = [
        dataclasses.replace(t, p_CK_C=R_CCp.T @ t.p_CK_C, direction_C=R_CCp.T @ t.direction_C)
        for t in layout.thrusters
    ]
    return ThrusterLayout(thrusters=thrusters, gimbaled=layout.gimbaled)


def coupled_params(scenario) -> cr.CoupledRelativeParams:
    """The prediction model's data from the scenario, in the planner's chaser frame (module
    docstring)."""
    config = scenario.controller
    p_TPt_T, p_CPc_C = feature_points(scenario)
    J_c = np.asarray(scenario.chaser.inertia_kg_m2, dtype=float)
    layout = _planning_layout(make_thruster_layout(scenario), config.max_thrust_N)
    R_CCp = planning_frame_R_CCp(scenario)
    if R_CCp is not None:
        J_c, p_CPc_C = R_CCp.T @ J_c @ R_CCp, R_CCp.T @ p_CPc_C
        layout = _layout_in(layout, R_CCp)
    return cr.CoupledRelativeParams(
        chaser_mass_kg=float(scenario.chaser.mass_kg),
        J_c=J_c,
        J_t=np.asarray(scenario.target.inertia_kg_m2, dtype=float),
        p_TPt_T=p_TPt_T,
        p_CPc_C=p_CPc_C,
        layout=layout,
    )


def coupled_weights(config, input_size: int) -> cr.CoupledNmpcWeights:
    """Eqs. 20-21's weights from the config (`weights`, `integral_weight`)."""
    w, eye3 = config.weights, np.eye(3)
    P = np.zeros((6, 6))
    P[:3, :3] = w.terminal_position * eye3
    P[3:, 3:] = w.terminal_velocity * eye3
    return cr.CoupledNmpcWeights(
        Q_R=w.attitude,
        Q_w=w.rate * eye3,
        Q_p=w.position * eye3,
        Q_xi=config.integral_weight * eye3,
        W_tau=w.torque * eye3,
        W_f=w.force * np.eye(input_size),
        P=P,
    )


def make_planner(scenario) -> CoupledNmpcPlanner:
    """The NMPC of the scenario's `!CoupledNmpc` block, on the scenario's problem data."""
    config = scenario.controller
    params = coupled_params(scenario)
    weights = coupled_weights(config, params.input_size)
    return CoupledNmpcPlanner(params, weights, dataclasses.replace(config.nmpc))
