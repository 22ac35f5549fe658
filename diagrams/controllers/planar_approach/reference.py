"""The reference the tracker follows after and around paper 003's plan (beyond the paper).

Owns: `co_rotating_hold` (the plan's final pose fixed in the turning target frame),
`face_aligned_reference` (the plan's path with its heading turned onto the docking face),
`contact_reach_m` and `hold_force_ratio` (whether the hold can be flown).
Does not own: the plan (rpod.planners.planar_approach) or choosing among these at build time
(planning.py).

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
"""

import copy
import math

import numpy as np
from pydrake.trajectories import PiecewisePolynomial

from rpod.planners.planar_approach import PlanarApproachConfig, PlanarPlan

HOLD_KNOT_STEP_S = 0.02  # knots of the co-rotating hold (chord sag 0.1 mm at 2 rad/s, 0.5 m)


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


def hold_force_ratio(plan: PlanarPlan, config: PlanarApproachConfig) -> float:
    """The co-rotating hold's centripetal force m omega_t^2 |p_N| over the thrusters' least
    force (along an axis): above 1 the hold cannot be flown."""
    radius = float(np.linalg.norm(plan.x_knots[-1, :2]))
    return config.chaser_mass_kg * config.omega_target_rad_s**2 * radius / config.max_force_N
