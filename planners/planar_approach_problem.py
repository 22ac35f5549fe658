"""Paper 003's approach problem for one duration, apart from any algorithm: what the two
methods (`planar_approach_scp`, `planar_approach_nlp`) share.

Owns: the statement below (eqs. 5-9 and rpod's departures from the paper), the time grid
(`grid`), the keep-out samples at and between knots (`Samples`, `samples`), the KOS labels
(`wanted`, `aligned_samples`, `labels`, `alignment_targets`, `face_heading`, and
`distance_facets`, the switching region's inscribed polygon), the cost terms (`cost_terms`), the
goal as rows (`goal_rows`) and (5')'s relative-velocity map (`relative_velocity_map`), the
spiral initial guess (`initial_guess`), the solver's word (`solver_word`), and
`PlanarPlanStatus`, the outcome both methods report (here, not in the front door, so that the
methods need not import it; `rpod.planners.planar_approach` re-exports it).
Does not own: the config, the result and the duration search (`planar_approach`), any program
or solve (the methods), the checker (`planar_approach_check`), the dynamics, the docking-face
and goal conventions, the KOS shapes and the wrench limits (rpod.models.planar_approach).

The problem, for one duration T = N dt:
    min  w_goal |p_N - p_goal|^2 + sum_k (E_kin,k + w_u |F_k|^2) dt                      (5)
         + w_v |v_N - omega_t z x p_N|^2                                              (5')
    s.t. x_0 = x_init, theta_N = theta_finish                                          (6)
         x_k+1 = x_k + f(x_k, F_k) dt  (forward Euler of eq. 2)                        (7)
         body wrench R(theta_k)^T [F_x, F_y], tau within the planar_8 limits           (8)
         q(p, theta, t) >= 0 at every knot and between knots, the KOS state switching  (9)
E_kin = m |v|^2 / 2 + I omega^2 / 2 (the chaser's kinetic energy); the goal term is on the
position (the final attitude is the hard constraint 6).

Two departures from the paper (both said where they act):
- (5'), the terminal relative velocity (the chaser's velocity seen from the target frame at T,
  Fig. 7's quantity), weighted by `w_terminal_velocity` (default 1000 s^2/m^2 x the cost's
  units; 0 gives the paper's eq. 5). The paper leaves it out and reports ~0.03 m/s at the end
  (Sec. V-C: "introducing an explicit terminal relative-velocity term could further reduce the
  residual motion"); Sec. V-A's plan ends at 0.014 m/s without it and 0.003 m/s with it.
- The KOS state needs the heading (rpod.models.planar_approach): State II (the relaxed zone)
  only where the chaser faces the docking face within alignment_tolerance_rad, the paper's
  "close to and properly aligned" (Sec. III-C) made a condition. Position-only switching let
  Sec. V-A's plan put the chaser's centre in the relaxed zone while it was still turned
  ~165 deg off the face, and the squares overlapped from 77 to 84 s of the plan itself.

F is the world wrench (the paper's decision variable); its limits (8) are the body-frame limits of
the thruster layout, which are the real ones: per body axis |f_b| <= max_force_N, |tau| <=
max_torque_Nm, and for planar_8 also the coupling cut |f_bx| + |f_by| + 2 (F_max / tau_max) |tau|
<= 2 F_max, which makes the set exactly the thrusters'
(rpod.models.planar_approach.body_wrench_excess; `wrench_limit="box"` drops the cut).
`planar_8_wrench_limits(side, F_thr)` derives the two numbers from the layout.

Time step. The NLP step is the control period dt_s (Sec. V: 10 Hz), shortened for each candidate
to dt = T / ceil(T / dt_s) so that N dt = T exactly and the target attitude at arrival is
theta_approach exactly (rounding T to the 0.1 s grid would miss it by up to omega dt / 2, 0.1 rad
at 2 rad/s).

Keep-out at and between knots. Forward Euler moves the position along the straight segment
p_k -> p_k+1 during step k (eq. 7: p_k+1 = p_k + v_k dt), while the target keeps turning. q is
constrained at every knot and at `keepout_samples_per_step - 1` evenly spaced points inside
every step, each against the KOS at its own time (default: enough points that the target turns
at most 0.02 rad between two, at least 2 per step: 2 at 0.1 rad/s, 10 at 2 rad/s). The checker
evaluates q at 10 points per step.

KOS switching, made smooth for the solver. The state is a function of the chaser's relative
pose (memoryless; rpod.models.planar_approach). Each sample point carries a label, fixed
while one convex (or smooth) subproblem is solved and updated between solves from the latest
iterate: State II where the point "wants" it (in the switching region and within
`_LABEL_BAND` (0.1 r_safe) of the State I zone or inside it) and the planned heading faces the
docking face within the tolerance at both knots of its step (the heading error is linear
along a step); State I elsewhere. A State II label also bounds the heading at those knots, and
comes with the switching conditions themselves as constraints (bearing below alpha, |p| below
1.5 r_safe, both shrunk by 1e-4), so a point labelled II is in State II, and a point labelled I
keeps out of the State I zone, which contains the State II zone: every iterate satisfies the
paper's switching KOS whatever the labels, and a new label never makes the previous iterate
infeasible (with zero keep-out slack). The band lets points near the zone dive into the relaxed
region and releases points that have left it.

The goal as constraints (`goal_constraint`, beyond the paper). Eq. 5 weighs the goal against
the kinetic energy, so at a fast spin the plan stops short of a goal that runs away at
omega_t d_goal (Case Study 1: 5 cm short at 0.36 rad/s, ~0.1-0.7 m beyond). With
goal_constraint the plan's end is the docking state itself: p_N = p_goal and v_N = omega_t z x
p_N (the docking face's velocity), each of the four rows with an L1-penalised slack
(planar_approach_scp's _GOAL_PENALTY per m and per m/s, above the constraints' multipliers and
below the keep-out's), so it holds exactly wherever the thrust and the KOS allow and a duration
that cannot reach the goal is GOAL_MISSED, not infeasible. The SCP carries it as these rows;
the NLP as hard equalities (it starts from the SCP's answer).
"""

from __future__ import annotations

import dataclasses
import enum
import math
from typing import TYPE_CHECKING

import numpy as np

from rpod.models import planar_approach as pa

if TYPE_CHECKING:  # annotations only: the front door imports this module
    from rpod.planners.planar_approach import PlanarApproachConfig

_LABEL_BAND = 0.1
"""A sample in the switching region within this many r_safe of the State I zone gets State II."""
REGION_SHRINK = 1e-4
"""Relative shrink of the switching region's thresholds in the constraints (strict inequality)."""
_DISTANCE_FACETS = 8
"""Facets of the inscribed polygon for |p| < 1.5 r_safe across the switching cone."""


class PlanarPlanStatus(str, enum.Enum):
    """What came of a plan (or of one candidate duration)."""

    SUCCESS = "success"
    INFEASIBLE = "infeasible"
    ITERATION_LIMIT = "iteration_limit"
    SOLVER_FAILED = "solver_failed"
    SOLVER_UNAVAILABLE = "solver_unavailable"
    NO_CANDIDATE = "no_candidate"
    GOAL_MISSED = "goal_missed"  # converged, but p_N is beyond goal_tolerance_m of p_goal


# ------------------------------------------------------------------------ grid, the guess


def grid(config: PlanarApproachConfig, duration_s: float) -> tuple[int, float]:
    """(N, dt) with N dt = T exactly and dt <= dt_s."""
    N = max(1, math.ceil(duration_s / config.dt_s - 1e-9))
    return N, duration_s / N


def _smoothstep(s):
    s = np.clip(s, 0.0, 1.0)
    return s * s * s * (10.0 - 15.0 * s + 6.0 * s * s)


def initial_guess(
    config: PlanarApproachConfig, x0, duration_s: float
) -> tuple[np.ndarray, np.ndarray]:
    """A spiral guess (X (N + 1, 6), U (N, 3)), consistent with eq. 7.

    For the first 80 % of T the position spirals in polar coordinates from x0 to the docking
    normal at radius 1.1x the State I zone's reach (outside every KOS piece, inside 1.5 r_safe),
    the shortest way round; for the last 20 % it descends along the turning docking normal to
    the goal. Attitude: a smoothstep to theta_finish. Velocities and wrenches are the forward
    differences that satisfy eq. 7; the guess ignores (8).
    """
    x0 = np.asarray(x0, dtype=float)
    N, dt = grid(config, duration_s)
    geometry = config.geometry
    t = np.arange(N + 1) * dt
    t1 = 0.8 * duration_s
    r_orbit = min(1.1 * geometry.state_i_extent_m, 0.98 * geometry.switch_distance_m)
    r_orbit = max(r_orbit, config.standoff_m)
    r0 = float(np.hypot(x0[0], x0[1]))
    phi0 = math.atan2(x0[1], x0[0]) if r0 > 0 else 0.0
    theta_t = pa.target_attitude(t, config.theta_target0_rad, config.omega_target_rad_s)
    phi1 = phi0 + float(pa.wrap_to_pi(theta_t[np.searchsorted(t, t1)] - phi0))
    s1 = _smoothstep(t / t1)
    s2 = _smoothstep((t - t1) / (duration_s - t1))
    radius = np.where(
        t <= t1, r0 + (r_orbit - r0) * s1, r_orbit + (config.standoff_m - r_orbit) * s2
    )
    bearing = np.where(
        t <= t1, phi0 + (phi1 - phi0) * s1, phi1 + (theta_t - theta_t[np.searchsorted(t, t1)])
    )
    P = np.column_stack([radius * np.cos(bearing), radius * np.sin(bearing)])
    P[0] = x0[:2]
    theta_f = pa.chaser_final_attitude(config.theta_approach_rad, x0[2])
    theta = x0[2] + (theta_f - x0[2]) * _smoothstep(t / duration_s)
    Q = np.column_stack([P, theta])
    V = np.empty((N + 1, 3))
    V[0] = x0[3:]
    V[1:N] = np.diff(Q, axis=0)[1:] / dt
    V[N] = V[N - 1]
    inertia = np.array([config.chaser_mass_kg, config.chaser_mass_kg, config.chaser_inertia_kg_m2])
    U = np.diff(V, axis=0) / dt * inertia
    X = np.empty((N + 1, 6))
    X[:, 3:] = V  # the roll-out of eq. 7 from x0 under U reaches exactly these velocities
    X[0, :3] = x0[:3]
    X[1:, :3] = x0[:3] + np.cumsum(V[:-1], axis=0) * dt
    return X, U


# ------------------------------------------------------------------------ samples and labels


@dataclasses.dataclass
class Samples:
    """The keep-out sample points: p = (1 - s) p_k + s p_k+1 at t = (k + s) dt."""

    k: np.ndarray
    s: np.ndarray
    theta_t: np.ndarray

    @property
    def size(self) -> int:
        return len(self.k)

    def positions(self, P: np.ndarray) -> np.ndarray:
        """Sample positions (S, 2) from knot positions P (N + 1, 2)."""
        return (1.0 - self.s)[:, None] * P[self.k] + self.s[:, None] * P[self.k + 1]

    def to_target(self, p: np.ndarray) -> np.ndarray:
        """Sample positions in T (S, 2)."""
        c, s = np.cos(self.theta_t), np.sin(self.theta_t)
        return np.column_stack([c * p[:, 0] + s * p[:, 1], -s * p[:, 0] + c * p[:, 1]])


def samples(config: PlanarApproachConfig, N: int, dt: float) -> Samples:
    """The keep-out samples of N steps of dt: `samples_per_step(dt)` per step, x_0 left out."""
    n = config.samples_per_step(dt)
    k = np.repeat(np.arange(N), n)
    s = np.tile(np.arange(n) / n, N)
    keep = ~((k == 0) & (s == 0.0))  # x_0 is given
    k = np.append(k[keep], N - 1)
    s = np.append(s[keep], 1.0)
    t = (k + s) * dt
    theta_t = pa.target_attitude(t, config.theta_target0_rad, config.omega_target_rad_s)
    return Samples(k=k, s=s, theta_t=theta_t)


def _in_region(geometry: pa.KeepOutGeometry, p_T: np.ndarray) -> np.ndarray:
    """Inside the switching region as the planner constrains it (shrunk, inscribed polygon)."""
    alpha = geometry.switch_angle_rad * (1.0 - REGION_SHRINK)
    normals, offset = distance_facets(geometry)
    inside_polygon = np.all(p_T @ normals.T <= offset, axis=1)
    return (geometry.bearing_rad(p_T) < alpha) & inside_polygon & (p_T[:, 0] > 0.0)


def distance_facets(geometry: pa.KeepOutGeometry) -> tuple[np.ndarray, float]:
    """Inscribed polygon of |p| < 1.5 r_safe across the cone: unit normals (M, 2), offset."""
    alpha = geometry.switch_angle_rad
    vertices = np.linspace(-alpha, alpha, _DISTANCE_FACETS + 1)
    mid = 0.5 * (vertices[1:] + vertices[:-1])
    half_step = 0.5 * (vertices[1] - vertices[0])
    radius = geometry.switch_distance_m * (1.0 - REGION_SHRINK) * math.cos(half_step)
    return np.column_stack([np.cos(mid), np.sin(mid)]), radius


def wanted(geometry: pa.KeepOutGeometry, p_T: np.ndarray) -> np.ndarray:
    """Samples that want State II: in the region and near/inside the State I zone (bool)."""
    near = geometry.q_state(p_T, pa.STATE_I) < _LABEL_BAND * geometry.r_safe_m
    return _in_region(geometry, p_T) & near


def face_heading(config: PlanarApproachConfig, t: np.ndarray, theta_f: float) -> np.ndarray:
    """theta_f + omega_t (t - T): the heading facing the docking face, on theta_f's branch
    (theta_t(T) + pi = theta_f mod 2 pi: T is a candidate duration)."""
    return theta_f + config.omega_target_rad_s * (t - t[-1])


def aligned_samples(config, samples, theta: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Samples whose step has the chaser's heading within the State II tolerance at both ends
    (the heading error is linear in t along a step: theta and theta_t both are), bool; all
    True with the paper's position-only switch (state_ii_heading false)."""
    if not config.state_ii_heading:
        return np.ones(samples.size, dtype=bool)
    theta_t = pa.target_attitude(t, config.theta_target0_rad, config.omega_target_rad_s)
    error = np.abs(pa.face_heading_error(theta, theta_t))
    knot_ok = error <= config.geometry.alignment_tolerance_rad * (1.0 - REGION_SHRINK)
    return knot_ok[samples.k] & (knot_ok[samples.k + 1] | (samples.s == 0.0))


def labels(wanted: np.ndarray, aligned: np.ndarray) -> np.ndarray:
    """STATE_II where the sample wants it and the heading is aligned, STATE_I elsewhere."""
    return np.where(wanted & aligned, pa.STATE_II, pa.STATE_I)


def alignment_targets(samples, wanted, theta_bar, face, N):
    """(knots to align (N + 1,) bool, their face heading (N + 1,)): both ends of the step of
    every sample that wants State II; each contiguous run of such knots on one 2 pi branch:
    theta_f's when the run ends at T, else the one nearest the previous heading theta_bar at
    the run's first knot."""
    knots = np.zeros(N + 1, dtype=bool)
    j = np.flatnonzero(wanted)
    knots[samples.k[j]] = True
    knots[samples.k[j][samples.s[j] > 0.0] + 1] = True
    target = face.copy()
    edges = np.flatnonzero(np.diff(np.concatenate([[0], knots.astype(int), [0]])))
    for first, end in zip(edges[::2], edges[1::2]):
        if end - 1 < N:
            turns = round((theta_bar[first] - face[first]) / (2.0 * math.pi))
            target[first:end] += 2.0 * math.pi * turns
    return knots, target


# ------------------------------------------------------------------------- costs, goal rows


def cost_terms(config: PlanarApproachConfig, X: np.ndarray, U: np.ndarray, dt: float) -> dict:
    """The terms of J of a knot sequence X (N + 1, 6), U (N, 3): eq. 5's three and (5')'s
    terminal relative velocity (0 with w_terminal_velocity = 0)."""
    goal = config.w_goal * float(np.sum((X[-1, :2] - config.goal_position) ** 2))
    relative = relative_velocity_map(config.omega_target_rad_s) @ X[-1, [0, 1, 3, 4]]
    terminal = config.w_terminal_velocity * float(np.sum(relative**2))
    kinetic = 0.5 * (
        config.chaser_mass_kg * np.sum(X[:-1, 3:5] ** 2)
        + config.chaser_inertia_kg_m2 * np.sum(X[:-1, 5] ** 2)
    )
    control = config.w_u * float(np.sum(U**2))
    return {
        "goal": goal,
        "kinetic": float(kinetic) * dt,
        "control": control * dt,
        "terminal_velocity": terminal,
    }


def goal_rows(config: PlanarApproachConfig) -> tuple[np.ndarray, np.ndarray]:
    """(A, b) with A [p_N; v_N] = b meaning p_N = p_goal and v_N = omega_t z x p_N
    (`goal_constraint`)."""
    A = np.vstack(
        [
            np.hstack([np.eye(2), np.zeros((2, 2))]),
            relative_velocity_map(config.omega_target_rad_s),
        ]
    )
    return A, np.concatenate([config.goal_position, np.zeros(2)])


def relative_velocity_map(omega_t: float) -> np.ndarray:
    """M with M [p_x, p_y, v_x, v_y] = v - omega_t z x p (the velocity seen from the target,
    expressed in W; its norm is the target frame's, Fig. 7)."""
    return np.array([[0.0, omega_t, 1.0, 0.0], [-omega_t, 0.0, 0.0, 1.0]])


# ---------------------------------------------------------------------------- solver's word


def solver_word(result) -> str:
    """The solver's own word on a MathematicalProgramResult: "<solver>: <its status>"."""
    details = result.get_solver_details()
    for name in ("ConvertStatusToString", "status", "info"):
        if hasattr(details, name):
            value = getattr(details, name)
            value = value() if callable(value) else value
            return f"{result.get_solver_id().name()}: {value}"
    return f"{result.get_solver_id().name()}: {result.get_solution_result().name}"
