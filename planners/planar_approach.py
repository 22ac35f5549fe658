"""Paper 003's approach planner: the NLP of eqs. 5-9 for a planar chaser and a spinning target,
with the paper's duration search, and an independent checker of its plans.

Owns: `PlanarApproachConfig`, `duration_candidates` (Sec. III-A), `initial_guess`,
`plan_approach` (-> `PlanarPlan`), the two solution methods below, and `check_plan`.
Does not own: the dynamics, the docking-face and goal conventions, the keep-out zone (KOS) and
the wrench limits (rpod.models.planar_approach, where the conventions are written down), the
tracking controller, the allocation to thrusters or the pulse modulation.

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

Methods (`solver`):
- "scp" (default): sequential convex programming on MathematicalProgram with Clarabel. The cost
  and the dynamics are separable in translation and rotation, and only the wrench limits (8)
  and the heading condition of State II couple them (through theta in the body-frame rotation
  and through the torque's share of the planar_8 set). So the attitude (theta, omega, tau) is
  a QP (its cost terms, eq. 6, eq. 7, |tau| <= max_torque_Nm, and |theta_k - theta_face,k| <=
  the tolerance plus an L1-penalised slack at the knots of the samples that want State II),
  re-solved whenever that set of samples changes (`_solve_scp`); with theta_k and tau_k known,
  (8) is linear in the world force, and the translation is solved by a sequence of QPs. In
  each, every KOS piece (a disc, a half-disc, a half-ellipse; circumscribed polygons of 48
  facets per half, at most 0.25 mm larger) is replaced, for every pair of consecutive samples,
  by the facet half-plane that the previous iterate satisfies best at both (so the chord
  between them keeps out too), with `_CHORD_MARGIN_M` (0.2 mm) to spare for the bend of the
  straight world segment in the turning target frame; each such half-plane is disjoint from its
  piece, so the QP is a convex restriction, its solution is KOS-feasible, and the previous
  iterate stays feasible unless the attitude or the labels changed. Keep-out rows carry one
  slack per sample with an L1 penalty (1e4 per m), which makes a start inside the zone or a
  guess that cannot be flown recoverable; a converged answer with slack left is reported
  INFEASIBLE. Stops when labels and facets are unchanged and the (penalised) cost changed less
  than `scp_tolerance` (relative); not settled after `max_iterations` QPs is ITERATION_LIMIT.
  The decomposition can lose optimality where (8) is active and where State II is wanted: the
  attitude QP does not know which way, or how hard, the translation will push (the body-frame
  rotation of the force limits and the torque's share of the planar_8 set), nor how much the
  translation would gain by an earlier State II; the checker verifies (8) and the KOS on the
  result either way, and "ipopt"/"snopt" below polish the joint problem (with the State II
  labels, and so the heading bounds, of their start).
- "ipopt" (the paper's solver) and "snopt": the joint NLP (attitude and translation together)
  through Drake, the KOS as smooth terms (`keepout_smooth_terms`, at least 1e-3: ~0.2 mm), (8)
  as expressions of theta and F, re-solved once if the labels changed. Started from the SCP
  answer (`nlp_warm_start="scp"`, default) they confirm it; from the spiral guess ("guess")
  they are slow (Drake gives IPOPT no second derivatives, limited-memory quasi-Newton, and
  SNOPT builds its own quasi-Newton Hessian) and keep the guess's labels. Measured on 2 shared cores at the shortest Sec. V-A candidate (N = 236): "scp" 0.4 s to
  J = 1.983; IPOPT and SNOPT from its answer 34 s and 4 s to J = 1.980 (the SCP's polygons are
  up to 0.25 mm larger than the shapes); from the guess, 47 s and 42 s, both to a worse local
  optimum, J = 2.873 (their State II labels, and so the heading bounds, are the guess's)
  (benchmarks/results/planar_nlp.md; before (5') and the heading condition IPOPT took 315-330 s
  from the guess). At N = 864 and 1493 the polish alone takes 1-10 min. With (5')'s term
  Drake's IPOPT stopped in "Error in step computation" from the SCP answer at N = 24
  (w_terminal_velocity 100 and 1000; a SOLVER_FAILED status), where SNOPT confirms it; with
  w_terminal_velocity = 0 IPOPT does.

The paper's formulation as printed is `w_terminal_velocity=0, state_ii_heading=False`: eq. 5
and the position-only switch (its plans can then overlap the target:
benchmarks/results/planar_case1_study.md).

The goal as constraints (`goal_constraint`, beyond the paper). Eq. 5 weighs the goal against
the kinetic energy, so at a fast spin the plan stops short of a goal that runs away at
omega_t d_goal (Case Study 1: 5 cm short at 0.36 rad/s, ~0.1-0.7 m beyond). With
goal_constraint the plan's end is the docking state itself: p_N = p_goal and v_N = omega_t z x
p_N (the docking face's velocity), each of the four rows with an L1-penalised slack
(_GOAL_PENALTY per m and per m/s, above the constraints' multipliers and below the keep-out's),
so it holds exactly wherever the thrust and the KOS allow and a duration that cannot reach
the goal is GOAL_MISSED, not infeasible. The SCP carries it as these rows; the NLP as hard
equalities (it starts from the SCP's answer).

Duration search (Sec. III-A): the candidates are the times at which the target attitude equals
theta_approach, T_m = ((theta_approach - theta_t0) sgn(omega) mod 2 pi + 2 pi m) / |omega|, within
[duration_min_s, duration_max_s], the first `max_duration_candidates` of them, solved in
ascending order; the best (least cost (5)) success is kept. The paper prints no count. When
none of them reaches the goal, up to `max_extra_candidates` later ones are solved, in order,
until one does (beyond the paper; 0 by default): thrusters too weak to catch a fast docking
face in the first turns can in a later one.

A plan must reach its goal (rpod's rule, not the paper's): a candidate whose solve converged
but whose own end point p_N is farther than `goal_tolerance_m` (the mission's 5 cm) from
p_goal is GOAL_MISSED, with the miss distance in its message. A candidate that reaches the goal
beats any that misses; when every converged candidate misses, the least-cost one is returned
with status GOAL_MISSED (its trajectories kept: it is flyable, keep-out feasible, and not a
success).

A failed solve is a `PlanarPlanStatus` with the solver's own word, never an exception.
Exceptions are for bad configs (`validate`) and bad arguments.
"""

import dataclasses
import enum
import math
import time

import numpy as np
import scipy.sparse as sp
from pydrake.solvers import (
    ClarabelSolver,
    ExpressionConstraint,
    IpoptSolver,
    MathematicalProgram,
    SnoptSolver,
    SolutionResult,
    SolverOptions,
)
from pydrake.trajectories import PiecewisePolynomial

from rpod.models import planar_approach as pa
from rpod.models.thrusters import allocate_duty, planar_8, wrench_matrix

SOLVERS = ("scp", "ipopt", "snopt")
WRENCH_LIMITS = ("planar_8", "box")
WARM_STARTS = ("scp", "guess")

_SLACK_PENALTY = 1e4
"""L1 weight of the keep-out slacks (cost per metre of violation at one sample)."""
_GOAL_PENALTY = 1e3
"""L1 weight of the goal constraints' slacks (per m and per m/s; `goal_constraint`): exact where
the goal can be reached (645 of the 646 Case Study 1 plans at omega <= 0.5 rad/s end within
1e-10 m of it, benchmarks/results/planar_case1_study.md), and below the keep-out's, so a
duration that cannot reach the goal keeps out of the zone and misses the goal instead."""
_SLACK_TOLERANCE_M = 1e-6
"""Slack left at convergence above which the KOS is reported unsatisfiable."""
_LABEL_BAND = 0.1
"""A sample in the switching region within this many r_safe of the State I zone gets State II."""
_REGION_SHRINK = 1e-4
"""Relative shrink of the switching region's thresholds in the constraints (strict inequality)."""
_ACCUMULATE_AFTER = 8
"""SCP: from this iteration on, the attitude's alignment set only grows (`_solve_scp`)."""
_MAX_TURN_BETWEEN_SAMPLES_RAD = 0.02
"""Automatic sampling: the target turns at most this much between two keep-out samples."""
_FACETS_PER_HALF = 48
"""Facets per half-shape of the circumscribed KOS polygons (0.25 mm on r_safe = 0.45 m)."""
_DISTANCE_FACETS = 8
"""Facets of the inscribed polygon for |p| < 1.5 r_safe across the switching cone."""
_CHORD_MARGIN_M = 2e-4
"""SCP: every keep-out row holds with this much to spare. Between two samples the chaser
moves on a straight line in W, which the turning target frame bends: off the chord in T by at
most (dtheta^2 / 8) (|p| + 2 |v| / |omega_t|) for a turn dtheta between the samples (<= 0.02
rad with the automatic sampling: 5e-5 (|p| + 2 |v| / |omega_t|), 0.1 mm at 0.7 m and 0.5 m/s
per rad/s); the margin keeps that bend out of the pieces and inside the switching region."""
_NLP_TERM_MARGIN = 1e-3
"""Lower bound of the NLP's keep-out terms (~0.2 mm on r_safe = 0.45 m): the answer sits on
the constraints at the samples, and the margin covers the chord between them."""
_CHECK_SAMPLES_PER_STEP = 10
"""The checker evaluates the KOS at this many points per step (10x the knot density)."""


@dataclasses.dataclass
class PlanarPlannerSettings:
    """How the approach is planned: the settings of `PlanarApproachConfig` that are not problem
    data (a scenario's plug-in holds these and derives the problem data).

    Args:
        wrench_limit: "planar_8" (per-axis box plus the planar_8 coupling cut, the exact set)
            or "box" (per-axis box only).
        goal_standoff_m: d_goal, distance of the goal from the target centre on the docking
            normal; 0 means the geometry's default (r_relaxed + l_margin, 0.36 m here).
        w_goal: Weight of the terminal position error in (5) (Sec. V: 100).
        w_u: Weight of the wrench in (5) (Sec. V: 10).
        w_terminal_velocity: Weight of the terminal relative velocity in (5'), beyond the
            paper (module docstring); 0 gives the paper's eq. 5.
        duration_min_s: Shortest candidate duration.
        duration_max_s: Longest candidate duration.
        max_duration_candidates: At most this many candidates, the shortest first.
        max_extra_candidates: When none of those reaches the goal, solve up to this many of
            the later candidates, in ascending order, up to the first that does (beyond the
            paper; 0: none). Slow thrusters need long approaches at a fast spin.
        keepout_samples_per_step: Keep-out points per step, the knot included (>= 1); 0 for
            automatic (module docstring).
        solver: "scp", "ipopt" or "snopt" (module docstring).
        max_iterations: SCP iterations (QPs) per candidate.
        nlp_max_iterations: IPOPT max_iter / SNOPT major iterations limit.
        scp_tolerance: SCP stop: relative change of the cost between iterations.
        nlp_tolerance: IPOPT tol and constr_viol_tol / SNOPT major tolerances.
        smooth_max_sharpness: Sharpness of the NLP's smooth half-ellipse terms.
        nlp_warm_start: Where "ipopt" and "snopt" start: "scp" (the SCP's answer, its labels)
            or "guess" (the spiral guess).
        state_ii_heading: State II needs the heading condition (rpod's, module docstring);
            False gives the paper's position-only switch (Sec. III-C as printed).
        goal_constraint: The goal as terminal constraints (beyond the paper): p_N = p_goal
            and v_N = omega_t z x p_N (the docking face's velocity), module docstring.
    """

    wrench_limit: str = "planar_8"
    goal_standoff_m: float = 0.0
    w_goal: float = 100.0
    w_u: float = 10.0
    w_terminal_velocity: float = 1000.0
    duration_min_s: float = 1.0
    duration_max_s: float = 200.0
    max_duration_candidates: int = 3
    max_extra_candidates: int = 0
    keepout_samples_per_step: int = 0
    solver: str = "scp"
    max_iterations: int = 40
    nlp_max_iterations: int = 3000
    scp_tolerance: float = 1e-6
    nlp_tolerance: float = 1e-6
    smooth_max_sharpness: float = 20.0
    nlp_warm_start: str = "scp"
    state_ii_heading: bool = True
    goal_constraint: bool = False


@dataclasses.dataclass
class PlanarApproachConfig(PlanarPlannerSettings):
    """Problem data (here) and solver settings (`PlanarPlannerSettings`'s fields); defaults:
    Sec. V-A with a 0.3 m, 10 kg chaser.

    Args:
        omega_target_rad_s: The target's spin rate (non-zero; Sec. V-A: 0.1 rad/s).
        theta_approach_rad: Target attitude at closest approach (Sec. V-A: 3 pi / 4).
        theta_target0_rad: Target attitude at t = 0 (not in the paper; 0).
        chaser_side_m: l_s of eq. 10 (not in the paper; 0.3 m like the target).
        target_side_m: l_t of eq. 10 (Sec. V-A: 0.3 m).
        chaser_mass_kg: m (not in the paper; 10 kg).
        chaser_inertia_kg_m2: I about z (a 0.3 m square of 10 kg: m s^2 / 6 = 0.15 kg m^2).
        max_force_N: Force limit per body axis (planar_8 with F_thr = 0.3 N: 2 F_thr = 0.6 N).
        max_torque_Nm: Torque limit (planar_8 with F_thr = 0.3 N, s = 0.3 m: 2 s F_thr).
        dt_s: Largest NLP step (Sec. V's control period, 0.1 s); see the module docstring.
        goal_tolerance_m: A plan whose end point is farther than this from p_goal is
            GOAL_MISSED, not a success (the mission's position tolerance, 5 cm).
    """

    omega_target_rad_s: float = 0.1
    theta_approach_rad: float = 0.75 * math.pi
    theta_target0_rad: float = 0.0
    chaser_side_m: float = 0.3
    target_side_m: float = 0.3
    chaser_mass_kg: float = 10.0
    chaser_inertia_kg_m2: float = 0.15
    max_force_N: float = 0.6
    max_torque_Nm: float = 0.18
    dt_s: float = 0.1
    goal_tolerance_m: float = 0.05

    def validate(self) -> None:
        """Raises ValueError('field: message') naming the first bad field."""
        positive = (
            "chaser_side_m",
            "target_side_m",
            "chaser_mass_kg",
            "chaser_inertia_kg_m2",
            "max_force_N",
            "max_torque_Nm",
            "w_goal",
            "dt_s",
            "goal_tolerance_m",
            "duration_max_s",
            "scp_tolerance",
            "nlp_tolerance",
            "smooth_max_sharpness",
        )
        for name in positive:
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ValueError(f"{name}: must be a positive number, got {value!r}")
        for name in ("omega_target_rad_s", "theta_approach_rad", "theta_target0_rad"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value)):
                raise ValueError(f"{name}: must be a finite number, got {value!r}")
        if self.omega_target_rad_s == 0.0:
            raise ValueError("omega_target_rad_s: must be non-zero (the durations come from it)")
        value = self.max_extra_candidates
        if int(value) != value or value < 0:
            raise ValueError(f"max_extra_candidates: must be an integer >= 0, got {value!r}")
        for name in ("w_u", "w_terminal_velocity", "duration_min_s", "goal_standoff_m"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
                raise ValueError(f"{name}: must be >= 0, got {value!r}")
        if self.duration_min_s > self.duration_max_s:
            raise ValueError(
                f"duration_min_s: {self.duration_min_s} exceeds duration_max_s "
                f"{self.duration_max_s}"
            )
        for name in ("max_duration_candidates", "max_iterations", "nlp_max_iterations"):
            value = getattr(self, name)
            if int(value) != value or value < 1:
                raise ValueError(f"{name}: must be a positive integer, got {value!r}")
        for name in ("state_ii_heading", "goal_constraint"):
            value = getattr(self, name)
            if value is not True and value is not False:
                raise ValueError(f"{name}: must be true or false, got {value!r}")
        value = self.keepout_samples_per_step
        if int(value) != value or value < 0:
            raise ValueError(f"keepout_samples_per_step: must be an integer >= 0, got {value!r}")
        if self.solver not in SOLVERS:
            raise ValueError(f"solver: must be one of {SOLVERS}, got {self.solver!r}")
        if self.nlp_warm_start not in WARM_STARTS:
            raise ValueError(
                f"nlp_warm_start: must be one of {WARM_STARTS}, got {self.nlp_warm_start!r}"
            )
        if self.wrench_limit not in WRENCH_LIMITS:
            raise ValueError(
                f"wrench_limit: must be one of {WRENCH_LIMITS}, got {self.wrench_limit!r}"
            )

    @property
    def geometry(self) -> pa.KeepOutGeometry:
        """The KOS of these squares."""
        return pa.KeepOutGeometry(self.chaser_side_m, self.target_side_m)

    @property
    def standoff_m(self) -> float:
        """d_goal in use (goal_standoff_m, or the geometry's default when 0)."""
        return self.goal_standoff_m or self.geometry.default_goal_standoff_m

    @property
    def goal_position(self) -> np.ndarray:
        """p_goal of eq. 5, in W."""
        return pa.goal_position(self.theta_approach_rad, self.standoff_m)

    def samples_per_step(self, dt_s: float | None = None) -> int:
        """Keep-out points per step (the knot included) for a step of dt_s."""
        if self.keepout_samples_per_step:
            return int(self.keepout_samples_per_step)
        dt = self.dt_s if dt_s is None else dt_s
        turn = abs(self.omega_target_rad_s) * dt
        return max(2, math.ceil(turn / _MAX_TURN_BETWEEN_SAMPLES_RAD - 1e-9))


class PlanarPlanStatus(str, enum.Enum):
    """What came of a plan (or of one candidate duration)."""

    SUCCESS = "success"
    INFEASIBLE = "infeasible"
    ITERATION_LIMIT = "iteration_limit"
    SOLVER_FAILED = "solver_failed"
    SOLVER_UNAVAILABLE = "solver_unavailable"
    NO_CANDIDATE = "no_candidate"
    GOAL_MISSED = "goal_missed"  # converged, but p_N is beyond goal_tolerance_m of p_goal


@dataclasses.dataclass
class CandidateSolve:
    """One candidate duration's solve.

    Attributes:
        duration_s: T.
        status: What came of it.
        solver_message: The solver's own word (Clarabel's / IPOPT's status, SNOPT's info).
        solve_time_s: Wall time, building the programs included.
        iterations: SCP iterations (translation QPs after the attitude QP), or NLP solves
            (1, or 2 when the first answer changed the KOS labels).
        cost: J of eq. 5 (nan when no plan).
    """

    duration_s: float
    status: PlanarPlanStatus
    solver_message: str
    solve_time_s: float
    iterations: int
    cost: float


@dataclasses.dataclass
class PlanarPlan:
    """The planner's answer.

    Attributes:
        status: SUCCESS, or why not (of the shortest candidate when all failed).
        solver_message: The solver's own word.
        duration_s: The chosen T (nan when none).
        t_knots: Knot times (N + 1,) [s].
        x_knots: States at the knots (N + 1, 6): [x, y, theta, v_x, v_y, omega] in W.
        wrench_knots: World wrench [F_x, F_y, tau] held on each step (N, 3).
        x_traj: The 6-state as a first-order hold of the knots (exactly eq. 7's straight
            segments for the position and attitude, and the velocities under the held wrench).
        wrench_traj: The feed-forward wrench as a zero-order hold (Drake's: the last step's
            wrench at T, and beyond T when evaluated there; a tracker stops it at T).
        keepout_state: The KOS state (1 or 2) at each knot (N + 1,), the switching with the
            heading condition (rpod.models.planar_approach).
        cost: J of eq. 5.
        cost_terms: {"goal", "kinetic", "control", "terminal_velocity"}: the terms of J.
        goal_position: p_goal in W.
        theta_finish: The final attitude imposed (eq. 6).
        x0: The initial state given.
        candidates: Every candidate's solve, in the order solved.
    """

    status: PlanarPlanStatus
    solver_message: str
    duration_s: float
    t_knots: np.ndarray
    x_knots: np.ndarray
    wrench_knots: np.ndarray
    x_traj: PiecewisePolynomial | None
    wrench_traj: PiecewisePolynomial | None
    keepout_state: np.ndarray
    cost: float
    cost_terms: dict
    goal_position: np.ndarray
    theta_finish: float
    x0: np.ndarray
    candidates: list

    @property
    def success(self) -> bool:
        """True when status is SUCCESS."""
        return self.status == PlanarPlanStatus.SUCCESS

    @property
    def flyable(self) -> bool:
        """True when the plan has trajectories: SUCCESS, or GOAL_MISSED (safe but short)."""
        return self.x_traj is not None

    @property
    def terminal_position_error_m(self) -> float:
        """|p_N - p_goal| (nan when no plan)."""
        if not len(self.x_knots):
            return math.nan
        return float(np.linalg.norm(self.x_knots[-1, :2] - self.goal_position))


# --------------------------------------------------------------------------- durations, guess


def duration_candidates(config: PlanarApproachConfig, count: int | None = None) -> np.ndarray:
    """Durations T_m at which the target attitude is theta_approach (Sec. III-A), ascending.

    T_m = ((theta_approach - theta_t0) sgn(omega) mod 2 pi + 2 pi m) / |omega|, m = 0, 1, ...,
    within [duration_min_s, duration_max_s], at most `count` of them (default
    max_duration_candidates).
    """
    count = config.max_duration_candidates if count is None else count
    w = abs(config.omega_target_rad_s)
    delta = (config.theta_approach_rad - config.theta_target0_rad) * math.copysign(
        1.0, config.omega_target_rad_s
    )
    first = (delta % (2.0 * math.pi)) / w
    period = 2.0 * math.pi / w
    m0 = max(0, math.ceil((config.duration_min_s - first) / period - 1e-12))
    out = []
    m = m0
    while len(out) < count:
        t = first + m * period
        if t > config.duration_max_s + 1e-9:
            break
        if t >= max(config.duration_min_s, 1e-9):
            out.append(t)
        m += 1
    return np.array(out)


def _grid(config: PlanarApproachConfig, duration_s: float) -> tuple[int, float]:
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
    N, dt = _grid(config, duration_s)
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
class _Samples:
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


def _samples(config: PlanarApproachConfig, N: int, dt: float) -> _Samples:
    n = config.samples_per_step(dt)
    k = np.repeat(np.arange(N), n)
    s = np.tile(np.arange(n) / n, N)
    keep = ~((k == 0) & (s == 0.0))  # x_0 is given
    k = np.append(k[keep], N - 1)
    s = np.append(s[keep], 1.0)
    t = (k + s) * dt
    theta_t = pa.target_attitude(t, config.theta_target0_rad, config.omega_target_rad_s)
    return _Samples(k=k, s=s, theta_t=theta_t)


def _in_region(geometry: pa.KeepOutGeometry, p_T: np.ndarray) -> np.ndarray:
    """Inside the switching region as the planner constrains it (shrunk, inscribed polygon)."""
    alpha = geometry.switch_angle_rad * (1.0 - _REGION_SHRINK)
    normals, offset = _distance_facets(geometry)
    inside_polygon = np.all(p_T @ normals.T <= offset, axis=1)
    return (geometry.bearing_rad(p_T) < alpha) & inside_polygon & (p_T[:, 0] > 0.0)


def _distance_facets(geometry: pa.KeepOutGeometry) -> tuple[np.ndarray, float]:
    """Inscribed polygon of |p| < 1.5 r_safe across the cone: unit normals (M, 2), offset."""
    alpha = geometry.switch_angle_rad
    vertices = np.linspace(-alpha, alpha, _DISTANCE_FACETS + 1)
    mid = 0.5 * (vertices[1:] + vertices[:-1])
    half_step = 0.5 * (vertices[1] - vertices[0])
    radius = geometry.switch_distance_m * (1.0 - _REGION_SHRINK) * math.cos(half_step)
    return np.column_stack([np.cos(mid), np.sin(mid)]), radius


def _wanted(geometry: pa.KeepOutGeometry, p_T: np.ndarray) -> np.ndarray:
    """Samples that want State II: in the region and near/inside the State I zone (bool)."""
    near = geometry.q_state(p_T, pa.STATE_I) < _LABEL_BAND * geometry.r_safe_m
    return _in_region(geometry, p_T) & near


def _face_heading(config: PlanarApproachConfig, t: np.ndarray, theta_f: float) -> np.ndarray:
    """theta_f + omega_t (t - T): the heading facing the docking face, on theta_f's branch
    (theta_t(T) + pi = theta_f mod 2 pi: T is a candidate duration)."""
    return theta_f + config.omega_target_rad_s * (t - t[-1])


def _aligned_samples(config, samples, theta: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Samples whose step has the chaser's heading within the State II tolerance at both ends
    (the heading error is linear in t along a step: theta and theta_t both are), bool; all
    True with the paper's position-only switch (state_ii_heading false)."""
    if not config.state_ii_heading:
        return np.ones(samples.size, dtype=bool)
    theta_t = pa.target_attitude(t, config.theta_target0_rad, config.omega_target_rad_s)
    error = np.abs(pa.face_heading_error(theta, theta_t))
    knot_ok = error <= config.geometry.alignment_tolerance_rad * (1.0 - _REGION_SHRINK)
    return knot_ok[samples.k] & (knot_ok[samples.k + 1] | (samples.s == 0.0))


def _labels(wanted: np.ndarray, aligned: np.ndarray) -> np.ndarray:
    """STATE_II where the sample wants it and the heading is aligned, STATE_I elsewhere."""
    return np.where(wanted & aligned, pa.STATE_II, pa.STATE_I)


def _alignment_targets(samples, wanted, theta_bar, face, N):
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


# ------------------------------------------------------------------------------- the costs


def cost_terms(config: PlanarApproachConfig, X: np.ndarray, U: np.ndarray, dt: float) -> dict:
    """The terms of J of a knot sequence X (N + 1, 6), U (N, 3): eq. 5's three and (5')'s
    terminal relative velocity (0 with w_terminal_velocity = 0)."""
    goal = config.w_goal * float(np.sum((X[-1, :2] - config.goal_position) ** 2))
    relative = _relative_velocity_map(config.omega_target_rad_s) @ X[-1, [0, 1, 3, 4]]
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


def _solver_word(result) -> str:
    details = result.get_solver_details()
    for name in ("ConvertStatusToString", "status", "info"):
        if hasattr(details, name):
            value = getattr(details, name)
            value = value() if callable(value) else value
            return f"{result.get_solver_id().name()}: {value}"
    return f"{result.get_solver_id().name()}: {result.get_solution_result().name}"


# ------------------------------------------------------------------------ SCP: the attitude


def _attitude_qp(config, x0, theta_f, N, dt, align=None):
    """Eq. 5's rotational terms under eqs. 6-7 and |tau| <= max_torque_Nm: (theta, omega, tau)
    or None, with Clarabel's word.

    align = (knots (N + 1,) bool, face heading (N + 1,)): at those knots |theta - face| <=
    alignment_tolerance_rad (shrunk by 1e-3) + sigma, sigma >= 0 with an L1 penalty
    (_SLACK_PENALTY per rad): the attitude turns onto the docking face where the translation
    wants State II, as far as the torque allows; where it cannot, sigma > 0 and the samples
    there stay State I (`_labels`).
    """
    prog = MathematicalProgram()
    th = prog.NewContinuousVariables(N + 1, "theta")
    w = prog.NewContinuousVariables(N + 1, "omega")
    tau = prog.NewContinuousVariables(N, "tau")
    prog.AddBoundingBoxConstraint([x0[2], x0[5]], [x0[2], x0[5]], [th[0], w[0]])
    prog.AddBoundingBoxConstraint(theta_f, theta_f, th[N])
    prog.AddBoundingBoxConstraint(-config.max_torque_Nm, config.max_torque_Nm, tau)
    eye = sp.eye(N + 1, format="csr")
    shift = (eye[1:] - eye[:-1]).tocsc()  # x_k+1 - x_k
    pick = eye[:-1].tocsc()
    I_N = sp.eye(N, format="csc")
    A = sp.bmat(
        [[shift, -dt * pick, None], [None, shift, -dt / config.chaser_inertia_kg_m2 * I_N]],
        format="csc",
    )
    prog.AddLinearEqualityConstraint(A, np.zeros(2 * N), np.concatenate([th, w, tau]))
    Q = np.diag([config.chaser_inertia_kg_m2 * dt, 2.0 * config.w_u * dt])
    for k in range(N):
        prog.AddQuadraticCost(Q, np.zeros(2), [w[k], tau[k]], is_convex=True)
    if align is not None and np.any(align[0]):
        knots = np.flatnonzero(align[0])
        face = align[1][knots]
        sigma = prog.NewContinuousVariables(len(knots), "sigma")
        prog.AddBoundingBoxConstraint(0.0, np.inf, sigma)
        bound = config.geometry.alignment_tolerance_rad * (1.0 - 10.0 * _REGION_SHRINK)
        pick = sp.csr_matrix(
            (np.ones(len(knots)), (np.arange(len(knots)), knots)), shape=(len(knots), N + 1)
        )
        eye = sp.eye(len(knots), format="csr")
        A = sp.bmat([[pick, -eye], [pick, eye]], format="csc")
        lower = np.concatenate([np.full(len(knots), -np.inf), face - bound])
        upper = np.concatenate([face + bound, np.full(len(knots), np.inf)])
        prog.AddLinearConstraint(A, lower, upper, np.concatenate([th, sigma]))
        prog.AddLinearCost(_SLACK_PENALTY * np.ones(len(knots)), 0.0, sigma)
    result = ClarabelSolver().Solve(prog)
    word = _solver_word(result)
    if not result.is_success():
        return None, word
    return (result.GetSolution(th), result.GetSolution(w), result.GetSolution(tau)), word


# --------------------------------------------------------------------- SCP: the translation


class _TranslationScp:
    """The translation QPs of one candidate (module docstring, "scp")."""

    def __init__(self, config, x0, N, dt, theta, tau, samples):
        self.config = config
        self.geometry = config.geometry
        self.N, self.dt, self.samples = N, dt, samples
        m = config.chaser_mass_kg
        prog = self.prog = MathematicalProgram()
        self.P = prog.NewContinuousVariables(N + 1, 2, "p")
        self.V = prog.NewContinuousVariables(N + 1, 2, "v")
        self.F = prog.NewContinuousVariables(N, 2, "F")
        self.S = prog.NewContinuousVariables(samples.size, "slack")
        prog.AddBoundingBoxConstraint(x0[[0, 1, 3, 4]], x0[[0, 1, 3, 4]], [*self.P[0], *self.V[0]])
        prog.AddBoundingBoxConstraint(0.0, np.inf, self.S)
        # Eq. 7 on (p, v): p_k+1 - p_k - dt v_k = 0, v_k+1 - v_k - dt F_k / m = 0.
        eye = sp.eye(2 * (N + 1), format="csr")
        shift = (eye[2:] - eye[:-2]).tocsc()
        pick = eye[:-2].tocsc()
        I_F = sp.eye(2 * N, format="csc")
        A = sp.bmat([[shift, -dt * pick, None], [None, shift, -dt / m * I_F]], format="csc")
        variables = np.concatenate([self.P.ravel(), self.V.ravel(), self.F.ravel()])
        prog.AddLinearEqualityConstraint(A, np.zeros(4 * N), variables)
        # Eq. 8 at the known attitude and torque (`set_attitude`).
        A, lb = self._force_rows(theta, tau)
        self.force_limits = prog.AddLinearConstraint(A, lb, -lb, self.F.ravel())
        # Eq. 5: kinetic energy and wrench per step, the goal term, the slack penalty.
        Q = np.diag([m * dt, m * dt, 2.0 * config.w_u * dt, 2.0 * config.w_u * dt])
        for k in range(N):
            prog.AddQuadraticCost(Q, np.zeros(4), [*self.V[k], *self.F[k]], is_convex=True)
        prog.AddQuadraticErrorCost(config.w_goal * np.eye(2), config.goal_position, self.P[N])
        if config.w_terminal_velocity > 0.0:  # (5'): w_v |v_N - omega_t z x p_N|^2
            M = _relative_velocity_map(config.omega_target_rad_s)
            prog.AddQuadraticCost(
                2.0 * config.w_terminal_velocity * M.T @ M,
                np.zeros(4),
                [*self.P[N], *self.V[N]],
                is_convex=True,
            )
        prog.AddLinearCost(_SLACK_PENALTY * np.ones(samples.size), 0.0, self.S)
        if config.goal_constraint:  # p_N = p_goal, v_N = omega_t z x p_N, exact L1 penalties
            A_goal, b_goal = _goal_rows(config)
            G = prog.NewContinuousVariables(4, "goal_slack")
            eye = np.eye(4)
            prog.AddLinearConstraint(
                np.block([[A_goal, -eye], [A_goal, eye]]),
                np.concatenate([np.full(4, -np.inf), b_goal]),
                np.concatenate([b_goal, np.full(4, np.inf)]),
                np.concatenate([self.P[N], self.V[N], G]),
            )
            prog.AddLinearCost(_GOAL_PENALTY * np.ones(4), 0.0, G)
        self.keepout = prog.AddLinearConstraint(
            sp.csc_matrix((1, 2 * (N + 1) + samples.size)),
            [-np.inf],
            [np.inf],
            np.concatenate([self.P.ravel(), self.S]),
        )
        self.pieces = {
            state: self.geometry.pieces(state, _FACETS_PER_HALF)
            for state in (pa.STATE_I, pa.STATE_II)
        }
        alpha = self.geometry.switch_angle_rad * (1.0 - _REGION_SHRINK)
        distance_normals, distance_offset = _distance_facets(self.geometry)
        # State II's own conditions as pieces of one "facet" each that must all hold:
        # n . p_T >= offset (cone sides; -(inscribed polygon facets)).
        self.region_rows = (
            np.vstack(
                [[math.sin(alpha), -math.cos(alpha)], [math.sin(alpha), math.cos(alpha)]]
                + [-distance_normals]
            ),
            np.concatenate([[0.0, 0.0], -np.full(len(distance_normals), distance_offset)]),
        )

    def _force_rows(self, theta: np.ndarray, tau: np.ndarray):
        """Eq. 8 as rows of R(theta_k)^T F_k (and the planar_8 cut's sums) and their bound."""
        config, N = self.config, self.N
        c, s = np.cos(theta[:N]), np.sin(theta[:N])
        blocks = [np.array([[ck, sk], [-sk, ck]]) for ck, sk in zip(c, s)]
        fmax = config.max_force_N
        lower = [np.full(2 * N, -fmax)]
        rows = [sp.block_diag(blocks, format="csr")]
        if config.wrench_limit == "planar_8":
            kappa = 2.0 * fmax / config.max_torque_Nm
            room = np.maximum(2.0 * fmax - kappa * np.abs(tau), 0.0)
            sums = [np.array([[ck - sk, sk + ck], [ck + sk, sk - ck]]) for ck, sk in zip(c, s)]
            rows.append(sp.block_diag(sums, format="csr"))
            lower.append(-np.repeat(room, 2))
        return sp.vstack(rows).tocsc(), np.concatenate(lower)

    def set_attitude(self, theta: np.ndarray, tau: np.ndarray) -> None:
        """Reloads eq. 8's rows for a new attitude plan (theta, tau)."""
        A, lb = self._force_rows(theta, tau)
        self.force_limits.evaluator().UpdateCoefficients(A, lb, -lb)

    def update_keepout(self, P_bar: np.ndarray, labels: np.ndarray) -> tuple:
        """Chooses the facets at P_bar and loads the keep-out rows; returns the choice.

        Per pair of consecutive samples (a segment) and per piece of the segment's zone (State
        II's when both samples are labelled II, else State I's, which contains it), one facet
        that both samples must satisfy: the one P_bar satisfies best at the worse of the two.
        A half-plane is convex, so the chord between the two samples in T keeps out of the
        piece too: a path cannot cut a piece's corner between samples that chose different
        facets. Each State II sample also keeps the switching region's rows.
        """
        samples, N = self.samples, self.N
        p_T = samples.to_target(samples.positions(P_bar))
        c_all, s_all = np.cos(samples.theta_t), np.sin(samples.theta_t)
        row_j, row_n, row_b, choice = [], [], [], []
        first = np.arange(max(samples.size - 1, 1))
        second = np.minimum(first + 1, samples.size - 1)
        both_ii = (labels[first] == pa.STATE_II) & (labels[second] == pa.STATE_II)
        segment_state = np.where(both_ii, pa.STATE_II, pa.STATE_I)
        for state in (pa.STATE_I, pa.STATE_II):
            a, b = first[segment_state == state], second[segment_state == state]
            if not a.size:
                continue
            for normals, offsets in self.pieces[state]:
                signed = np.minimum(p_T[a] @ normals.T, p_T[b] @ normals.T) - offsets
                best = np.argmax(signed, axis=1)
                choice.append(best)
                row_j += [a, b]
                row_n += [normals[best], normals[best]]
                row_b += [offsets[best], offsets[best]]
        j = np.flatnonzero(labels == pa.STATE_II)
        if j.size:
            normals, offsets = self.region_rows
            for i in range(len(offsets)):
                row_j.append(j)
                row_n.append(np.broadcast_to(normals[i], (j.size, 2)))
                row_b.append(np.full(j.size, offsets[i]))
        j = np.concatenate(row_j)
        n_T = np.vstack(row_n)
        b = np.concatenate(row_b) + _CHORD_MARGIN_M
        c, s = c_all[j], s_all[j]
        n_W = np.column_stack([c * n_T[:, 0] - s * n_T[:, 1], s * n_T[:, 0] + c * n_T[:, 1]])
        k, w = samples.k[j], samples.s[j]
        rows = np.arange(len(j))
        r = np.repeat(rows, 5)
        cols = np.column_stack([2 * k, 2 * k + 1, 2 * k + 2, 2 * k + 3, 2 * (N + 1) + j]).ravel()
        vals = np.column_stack(
            [
                (1 - w) * n_W[:, 0],
                (1 - w) * n_W[:, 1],
                w * n_W[:, 0],
                w * n_W[:, 1],
                np.ones(len(j)),
            ]
        ).ravel()
        A = sp.csc_matrix((vals, (r, cols)), shape=(len(j), 2 * (N + 1) + samples.size))
        self.keepout.evaluator().UpdateCoefficients(A, b, np.full(len(b), np.inf))
        return tuple(np.concatenate(choice).tolist())

    def solve(self):
        """One QP: (P, V, F, slack) or None, and Clarabel's word."""
        result = ClarabelSolver().Solve(self.prog)
        word = _solver_word(result)
        if not result.is_success():
            return None, word
        get = result.GetSolution
        return (get(self.P), get(self.V), get(self.F), get(self.S)), word


def _goal_rows(config: PlanarApproachConfig) -> tuple[np.ndarray, np.ndarray]:
    """(A, b) with A [p_N; v_N] = b meaning p_N = p_goal and v_N = omega_t z x p_N
    (`goal_constraint`)."""
    A = np.vstack(
        [
            np.hstack([np.eye(2), np.zeros((2, 2))]),
            _relative_velocity_map(config.omega_target_rad_s),
        ]
    )
    return A, np.concatenate([config.goal_position, np.zeros(2)])


def _relative_velocity_map(omega_t: float) -> np.ndarray:
    """M with M [p_x, p_y, v_x, v_y] = v - omega_t z x p (the velocity seen from the target,
    expressed in W; its norm is the target frame's, Fig. 7)."""
    return np.array([[0.0, omega_t, 1.0, 0.0], [-omega_t, 0.0, 0.0, 1.0]])


def _solve_scp(config, x0, duration_s, guess):
    """The "scp" method for one duration: (status, word, iterations, X, U).

    Each iteration: the samples that want State II (`_wanted`, from the last translation)
    -> the attitude QP, asked to face the docking face at their knots (re-solved only when
    that set changed) -> labels: State II where wanted and aligned -> a translation QP at that
    attitude. From iteration _ACCUMULATE_AFTER on, the set the attitude aligns for only grows
    (the union of the wanted sets since): a sample at the edge of the final approach can
    otherwise toggle the attitude and the translation in a cycle. Settled when that set, the
    labels and the facets are unchanged and the cost moved less than scp_tolerance: the last
    translation and attitude were then solved with the same labels.
    """
    N, dt = _grid(config, duration_s)
    t = np.arange(N + 1) * dt
    theta_f = pa.chaser_final_attitude(config.theta_approach_rad, x0[2])
    face = _face_heading(config, t, theta_f)
    samples = _samples(config, N, dt)
    geometry = config.geometry
    P_bar, theta_bar = guess[0][:, :2], guess[0][:, 2]
    wanted = _wanted(geometry, samples.to_target(samples.positions(P_bar)))
    aligning = wanted  # the samples the attitude QP faces the docking face for

    def attitude_for(aligning, theta_bar):
        if not config.state_ii_heading:  # the paper's switch: no heading asked of State II
            return _attitude_qp(config, x0, theta_f, N, dt)
        align = _alignment_targets(samples, aligning, theta_bar, face, N)
        return _attitude_qp(config, x0, theta_f, N, dt, align)

    attitude, word = attitude_for(aligning, theta_bar)
    if attitude is None:
        return PlanarPlanStatus.INFEASIBLE, f"attitude QP: {word}", 0, None, None
    theta, omega, tau = attitude
    labels = _labels(wanted, _aligned_samples(config, samples, theta, t))
    scp = _TranslationScp(config, x0, N, dt, theta, tau, samples)
    choice, cost, status = None, math.inf, PlanarPlanStatus.ITERATION_LIMIT
    iterations = 0
    for iterations in range(1, config.max_iterations + 1):
        new_choice = scp.update_keepout(P_bar, labels)
        solution, word = scp.solve()
        if solution is None:
            return PlanarPlanStatus.SOLVER_FAILED, f"translation QP: {word}", iterations, None, None
        P, V, F, slack = solution
        X = np.column_stack([P, theta, V, omega])
        U = np.column_stack([F, tau])
        new_cost = sum(cost_terms(config, X, U, dt).values()) + _SLACK_PENALTY * slack.sum()
        new_wanted = _wanted(geometry, samples.to_target(samples.positions(P)))
        new_aligning = new_wanted | aligning if iterations >= _ACCUMULATE_AFTER else new_wanted
        same_aligning = np.array_equal(new_aligning, aligning)
        if not same_aligning:
            attitude, attitude_word = attitude_for(new_aligning, theta)
            if attitude is None:
                word = f"attitude QP: {attitude_word}"
                return PlanarPlanStatus.INFEASIBLE, word, iterations, None, None
            theta, omega, tau = attitude
            scp.set_attitude(theta, tau)
        new_labels = _labels(new_wanted, _aligned_samples(config, samples, theta, t))
        settled = (
            same_aligning
            and new_choice == choice
            and np.array_equal(new_labels, labels)
            and abs(new_cost - cost) <= config.scp_tolerance * (1.0 + abs(new_cost))
        )
        choice, cost, labels, aligning, P_bar = new_choice, new_cost, new_labels, new_aligning, P
        if settled:
            status = PlanarPlanStatus.SUCCESS
            break
    word = f"{word}; SCP {'converged' if status == PlanarPlanStatus.SUCCESS else 'stopped'}"
    if status == PlanarPlanStatus.SUCCESS and slack.max() > _SLACK_TOLERANCE_M:
        status = PlanarPlanStatus.INFEASIBLE
        word += f" with keep-out slack {slack.max():.3g} m left (the KOS cannot be kept)"
    return status, word, iterations, X, U


# ----------------------------------------------------------------------- NLP (IPOPT, SNOPT)


def _solve_nlp(config, x0, duration_s, guess):
    """The joint NLP with IPOPT or SNOPT for one duration: (status, word, iterations, X, U)."""
    N, dt = _grid(config, duration_s)
    samples = _samples(config, N, dt)
    geometry = config.geometry
    solver = SnoptSolver() if config.solver == "snopt" else IpoptSolver()
    if not (solver.available() and solver.enabled()):
        return PlanarPlanStatus.SOLVER_UNAVAILABLE, f"{config.solver} unavailable", 0, None, None
    X_guess, U_guess = guess
    prefix = ""
    if config.nlp_warm_start == "scp":
        scp_status, _, _, X_scp, U_scp = _solve_scp(config, x0, duration_s, guess)
        if scp_status == PlanarPlanStatus.SUCCESS:
            X_guess, U_guess = X_scp, U_scp
            prefix = "from the SCP answer: "
        else:
            prefix = f"from the guess (SCP: {scp_status.value}): "
    t = np.arange(N + 1) * dt

    def labels_of(X):
        wanted = _wanted(geometry, samples.to_target(samples.positions(X[:, :2])))
        return _labels(wanted, _aligned_samples(config, samples, X[:, 2], t))

    labels = labels_of(X_guess)
    options = SolverOptions()
    if config.solver == "snopt":
        options.SetOption(solver.id(), "Major iterations limit", int(config.nlp_max_iterations))
        options.SetOption(solver.id(), "Major optimality tolerance", config.nlp_tolerance)
        options.SetOption(solver.id(), "Major feasibility tolerance", config.nlp_tolerance)
        options.SetOption(solver.id(), "Iterations limit", 10**7)
        options.SetOption(solver.id(), "Superbasics limit", 10 * (N + 1) * 9)
    else:
        options.SetOption(solver.id(), "max_iter", int(config.nlp_max_iterations))
        options.SetOption(solver.id(), "tol", config.nlp_tolerance)
        options.SetOption(solver.id(), "constr_viol_tol", config.nlp_tolerance)
        options.SetOption(solver.id(), "print_level", 0)
    status, word, solves, X, U = PlanarPlanStatus.SOLVER_FAILED, "", 0, X_guess, U_guess
    for solves in (1, 2):  # one re-solve with the labels of the first answer
        prog, Xv, Uv = _nlp_program(config, x0, N, dt, samples, labels, X[:, 2])
        start = np.zeros(prog.num_vars())
        prog.SetDecisionVariableValueInVector(Xv, X, start)
        prog.SetDecisionVariableValueInVector(Uv, U, start)
        result = solver.Solve(prog, start, options)
        word = prefix + _solver_word(result)
        status = {
            SolutionResult.kSolutionFound: PlanarPlanStatus.SUCCESS,
            SolutionResult.kIterationLimit: PlanarPlanStatus.ITERATION_LIMIT,
            SolutionResult.kInfeasibleConstraints: PlanarPlanStatus.INFEASIBLE,
        }.get(result.get_solution_result(), PlanarPlanStatus.SOLVER_FAILED)
        if status != PlanarPlanStatus.SUCCESS:
            return status, word, solves, None, None
        X, U = result.GetSolution(Xv), result.GetSolution(Uv)
        new_labels = labels_of(X)
        if np.array_equal(new_labels, labels):
            break
        labels = new_labels
    return status, word, solves, X, U


def _nlp_program(config, x0, N, dt, samples, labels, theta_bar):
    """Eqs. 5-9 jointly, the keep-out as `keepout_smooth_terms` at the samples; the knots of
    State II samples facing the docking face (bounds on theta, on theta_bar's branch)."""
    prog = MathematicalProgram()
    X = prog.NewContinuousVariables(N + 1, 6, "x")
    U = prog.NewContinuousVariables(N, 3, "F")
    m, inertia = config.chaser_mass_kg, config.chaser_inertia_kg_m2
    prog.AddBoundingBoxConstraint(x0, x0, X[0])  # (6)
    theta_f = pa.chaser_final_attitude(config.theta_approach_rad, x0[2])
    prog.AddBoundingBoxConstraint(theta_f, theta_f, X[N, 2])  # (6)
    # (7): x_k+1 - x_k - dt f(x_k, F_k) = 0, one small binding per step.
    A = np.hstack([-np.eye(6), np.eye(6), np.zeros((6, 3))])
    A[[0, 1, 2], [3, 4, 5]] = -dt
    A[[3, 4, 5], [12, 13, 14]] = -dt / np.array([m, m, inertia])
    for k in range(N):
        prog.AddLinearEqualityConstraint(A, np.zeros(6), np.concatenate([X[k], X[k + 1], U[k]]))
    Q = dt * np.diag([m, m, inertia, 2.0 * config.w_u, 2.0 * config.w_u, 2.0 * config.w_u])
    for k in range(N):  # (5)
        prog.AddQuadraticCost(Q, np.zeros(6), np.concatenate([X[k, 3:], U[k]]), is_convex=True)
    prog.AddQuadraticErrorCost(config.w_goal * np.eye(2), config.goal_position, X[N, :2])
    if config.w_terminal_velocity > 0.0:  # (5')
        M = _relative_velocity_map(config.omega_target_rad_s)
        Q_v = 2.0 * config.w_terminal_velocity * M.T @ M
        prog.AddQuadraticCost(Q_v, np.zeros(4), X[N, [0, 1, 3, 4]], is_convex=True)
    if config.goal_constraint:  # hard here: the NLP starts from the SCP's answer
        A_goal, b_goal = _goal_rows(config)
        prog.AddLinearEqualityConstraint(A_goal, b_goal, X[N, [0, 1, 3, 4]])
    # State II only facing the docking face (module docstring).
    wanted = labels == pa.STATE_II
    if np.any(wanted) and config.state_ii_heading:
        face = _face_heading(config, np.arange(N + 1) * dt, theta_f)
        knots, face = _alignment_targets(samples, wanted, theta_bar, face, N)
        bound = config.geometry.alignment_tolerance_rad * (1.0 - 10.0 * _REGION_SHRINK)
        for k in np.flatnonzero(knots):
            prog.AddBoundingBoxConstraint(face[k] - bound, face[k] + bound, X[k, 2])
    # (8) in the body frame.
    fmax, tmax = config.max_force_N, config.max_torque_Nm
    prog.AddBoundingBoxConstraint(-tmax, tmax, U[:, 2])
    kappa = 2.0 * fmax / tmax
    for k in range(N):
        fx, fy, tau = pa.body_wrench(X[k, 2], U[k])
        rows, bound = [fx, fy], [fmax, fmax]
        if config.wrench_limit == "planar_8":
            rows += [fx + fy + kappa * tau, fx + fy - kappa * tau]
            rows += [fx - fy + kappa * tau, fx - fy - kappa * tau]
            bound += [2.0 * fmax] * 4
        bound = np.array(bound)
        constraint = ExpressionConstraint(np.array(rows), -bound, bound)
        prog.AddConstraint(constraint, constraint.vars())
    # (9) at the samples, in each sample's labelled state.
    P = X[:, :2]
    for j in range(samples.size):
        k, s = int(samples.k[j]), float(samples.s[j])
        if s == 0.0 or s == 1.0:
            p = P[k + int(s)]
        else:  # Expressions built one by one (a numpy ufunc on them reports stale FP flags)
            p = [(1.0 - s) * P[k, i] + s * P[k + 1, i] for i in range(2)]
        terms = pa.keepout_smooth_terms(
            p, samples.theta_t[j], config.geometry, labels[j], config.smooth_max_sharpness
        )
        terms = np.array(terms)
        lower = np.full(len(terms), _NLP_TERM_MARGIN)
        constraint = ExpressionConstraint(terms, lower, np.full(len(terms), np.inf))
        prog.AddConstraint(constraint, constraint.vars())
    return prog, X, U


# ------------------------------------------------------------------------------ the planner


def _solve_candidate(config, x0, duration_s):
    guess = initial_guess(config, x0, duration_s)
    start = time.perf_counter()
    method = _solve_scp if config.solver == "scp" else _solve_nlp
    status, word, iterations, X, U = method(config, x0, duration_s, guess)
    elapsed = time.perf_counter() - start
    cost = math.nan
    if X is not None:
        cost = sum(cost_terms(config, X, U, _grid(config, duration_s)[1]).values())
    if status == PlanarPlanStatus.SUCCESS:
        miss = float(np.linalg.norm(X[-1, :2] - config.goal_position))
        if miss > config.goal_tolerance_m:
            status = PlanarPlanStatus.GOAL_MISSED
            word = (
                f"goal missed: the plan ends {miss:.3f} m from the goal (tolerance "
                f"{config.goal_tolerance_m:g} m); {word}"
            )
    record = CandidateSolve(duration_s, status, word, elapsed, iterations, cost)
    return record, X, U


def _empty_plan(config, x0, status, word, candidates):
    theta_f = pa.chaser_final_attitude(config.theta_approach_rad, x0[2])
    return PlanarPlan(
        status=status,
        solver_message=word,
        duration_s=math.nan,
        t_knots=np.zeros(0),
        x_knots=np.zeros((0, 6)),
        wrench_knots=np.zeros((0, 3)),
        x_traj=None,
        wrench_traj=None,
        keepout_state=np.zeros(0, dtype=int),
        cost=math.nan,
        cost_terms={},
        goal_position=config.goal_position,
        theta_finish=theta_f,
        x0=x0,
        candidates=candidates,
    )


def plan_approach(config: PlanarApproachConfig, x0) -> PlanarPlan:
    """Plans the approach from x0 = [x, y, theta, v_x, v_y, omega] (W) over the candidate
    durations (Sec. III-A) and returns the best plan, or a failure status.

    Raises:
        ValueError: On a bad config field or a malformed x0 (not on an infeasible problem).
    """
    config.validate()
    x0 = np.asarray(x0, dtype=float)
    if x0.shape != (6,) or not np.all(np.isfinite(x0)):
        raise ValueError(f"x0 must be 6 finite numbers, got {x0!r}")
    durations = duration_candidates(config)
    if not durations.size:
        word = (
            f"no duration in [{config.duration_min_s}, {config.duration_max_s}] s brings the "
            f"target to theta_approach"
        )
        return _empty_plan(config, x0, PlanarPlanStatus.NO_CANDIDATE, word, [])
    records, best, missed = [], None, None
    extra = duration_candidates(config, len(durations) + config.max_extra_candidates)
    for duration in extra:
        if len(records) >= len(durations) and best is not None:
            break  # the extra candidates only until one reaches the goal
        record, X, U = _solve_candidate(config, x0, float(duration))
        records.append(record)
        if record.status == PlanarPlanStatus.SUCCESS and (
            best is None or record.cost < best[0].cost
        ):
            best = (record, X, U)
        if record.status == PlanarPlanStatus.GOAL_MISSED and (
            missed is None or record.cost < missed[0].cost
        ):
            missed = (record, X, U)
    if best is None:
        best = missed  # every converged candidate misses the goal: flyable, not a success
    if best is None:
        first = records[0]
        word = "; ".join(f"T = {r.duration_s:.3f} s: {r.solver_message}" for r in records)
        return _empty_plan(config, x0, first.status, word, records)
    record, X, U = best
    N, dt = _grid(config, record.duration_s)
    t = np.arange(N + 1) * dt
    t[-1] = record.duration_s
    held = np.vstack([U, U[-1]])  # Drake's ZeroOrderHold does not use the last sample
    theta_t = pa.target_attitude(t, config.theta_target0_rad, config.omega_target_rad_s)
    c, s = np.cos(theta_t), np.sin(theta_t)
    p_T = np.column_stack([c * X[:, 0] + s * X[:, 1], -s * X[:, 0] + c * X[:, 1]])
    heading = pa.face_heading_error(X[:, 2], theta_t) if config.state_ii_heading else None
    state = config.geometry.state(p_T, heading).astype(int)
    return PlanarPlan(
        status=record.status,
        solver_message=record.solver_message,
        duration_s=record.duration_s,
        t_knots=t,
        x_knots=X,
        wrench_knots=U,
        x_traj=PiecewisePolynomial.FirstOrderHold(t, X.T),
        wrench_traj=PiecewisePolynomial.ZeroOrderHold(t, held.T),
        keepout_state=state,
        cost=record.cost,
        cost_terms=cost_terms(config, X, U, dt),
        goal_position=config.goal_position,
        theta_finish=pa.chaser_final_attitude(config.theta_approach_rad, x0[2]),
        x0=x0,
        candidates=records,
    )


# ----------------------------------------------------------------------------- the checker

CHECK_TOLERANCES = {
    "euler_residual": 1e-6,  # m, rad, m/s, rad/s: Clarabel's equality rows (~1e-9) with margin
    "initial_state_error": 1e-9,
    "final_attitude_error_rad": 1e-6,
    "arrival_attitude_error_rad": 1e-9,  # N dt = T exactly
    "force_excess_N": 1e-6,
    "torque_excess_Nm": 1e-7,
    "wrench_cut_excess_N": 1e-6,
    "allocation_residual": 1e-6,  # planar_8 reproduces the wrench (eq. 14 at zero residual)
    "keepout_q_m": -1e-9,  # a lower bound: q >= 0 everywhere (polygons are circumscribed)
    "squares_gap_m": 0.0,  # a lower bound: the true squares never overlap (strictly > 0)
}
"""Pass thresholds of `check_plan` (upper bounds except keepout_q_m, a lower bound)."""


def _wrap(angle: float) -> float:
    return float((angle + math.pi) % (2.0 * math.pi) - math.pi)


def check_plan(plan: PlanarPlan, config: PlanarApproachConfig) -> dict:
    """Re-evaluates every constraint of eqs. 6-9 on a plan, independently of the planner.

    Reads the plan's trajectories (x_traj, wrench_traj), not its knot arrays, and recomputes:
    the eq. 7 residual per step (written out here); an exact zero-order-hold re-integration of
    eq. 2 from x_0 under the planned wrench (closed form, written out here; it differs from the
    plan by eq. 7's dropped a dt^2 / 2 terms: information, not a pass criterion); x_0 and the
    final attitude (mod 2 pi) against the request; the target attitude at arrival; the body
    wrench against the limits and, by rpod.models.thrusters.allocate_duty, whether the planar_8
    layout that has these limits reproduces it; the KOS q in the paper's switching state at
    10 points per step (the straight segments of eq. 7, the target at each point's own time,
    the heading interpolated as the plan's first-order hold: State II needs it aligned) with
    the exact shapes (not the planner's polygons); whether the true squares overlap there
    (separating axes, written out here); the terminal errors, the terminal relative velocity
    of (5') among them.

    Returns:
        A dict of worst values (names as in CHECK_TOLERANCES, plus information entries) and
        "passed": every CHECK_TOLERANCES entry holds (squares_gap_m strictly above 0).
    """
    if plan.x_traj is None or plan.wrench_traj is None:
        return {"passed": False, "reason": f"no plan ({plan.status.value})"}
    m, inertia = config.chaser_mass_kg, config.chaser_inertia_kg_m2
    t = np.asarray(plan.t_knots, dtype=float)
    dt = np.diff(t)
    X = plan.x_traj.vector_values(t).T
    F = plan.wrench_traj.vector_values(t[:-1]).T
    acc = F / np.array([m, m, inertia])
    # Eq. 7.
    predicted = X[:-1] + dt[:, None] * np.column_stack([X[:-1, 3:], acc])
    euler = float(np.abs(X[1:] - predicted).max())
    # Exact ZOH re-integration of eq. 2 from x_0.
    q, v = X[0, :3].copy(), X[0, 3:].copy()
    drift = np.zeros(3)
    drift_v = 0.0
    for k in range(len(dt)):
        q = q + v * dt[k] + 0.5 * acc[k] * dt[k] ** 2
        v = v + acc[k] * dt[k]
        drift = np.maximum(drift, np.abs(q - X[k + 1, :3]))
        drift_v = max(drift_v, float(np.abs(v - X[k + 1, 3:]).max()))
    # Eq. 6 and the arrival attitude.
    T = float(t[-1])
    final_attitude = abs(_wrap(X[-1, 2] - config.theta_approach_rad - math.pi))
    arrival = abs(
        _wrap(config.theta_target0_rad + config.omega_target_rad_s * T - config.theta_approach_rad)
    )
    # Eq. 8 in the body frame.
    c, s = np.cos(X[:-1, 2]), np.sin(X[:-1, 2])
    fbx = c * F[:, 0] + s * F[:, 1]
    fby = -s * F[:, 0] + c * F[:, 1]
    tau = F[:, 2]
    fmax, tmax = config.max_force_N, config.max_torque_Nm
    force_excess = float(np.maximum(np.abs(fbx), np.abs(fby)).max() - fmax)
    torque_excess = float(np.abs(tau).max() - tmax)
    cut = np.abs(fbx) + np.abs(fby) + 2.0 * fmax / tmax * np.abs(tau) - 2.0 * fmax
    layout = planar_8(side_m=tmax / fmax, max_thrust_N=0.5 * fmax)
    B = wrench_matrix(layout)
    allocation = 0.0
    for k in range(len(tau)):
        w = np.array([0.0, 0.0, tau[k], fbx[k], fby[k], 0.0])
        allocation = max(allocation, float(np.abs(B @ allocate_duty(B, w) - w).max()))
    # Eq. 9 at 10 points per step.
    n = _CHECK_SAMPLES_PER_STEP
    ts = np.append((t[:-1, None] + np.arange(n)[None, :] / n * dt[:, None]).ravel(), T)
    x_s = plan.x_traj.vector_values(ts)
    p = x_s[:2].T
    theta_t = config.theta_target0_rad + config.omega_target_rad_s * ts
    ct, st = np.cos(theta_t), np.sin(theta_t)
    p_T = np.column_stack([ct * p[:, 0] + st * p[:, 1], -st * p[:, 0] + ct * p[:, 1]])
    heading = (x_s[2] - theta_t) % (2.0 * math.pi) - math.pi  # wrap(theta - theta_t - pi)
    switch_heading = heading if config.state_ii_heading else None  # the plan's formulation
    q_values = config.geometry.q(p_T, switch_heading)
    state = config.geometry.state(p_T, switch_heading)
    # The true squares at the same points (separating axes: the two squares' edge normals).
    phi = x_s[2] - theta_t
    half_c, half_t = 0.5 * config.chaser_side_m, 0.5 * config.target_side_m
    gaps = []
    for axis in (0.0, 0.5 * math.pi):  # the target's axes
        u = np.array([math.cos(axis), math.sin(axis)])
        reach = half_c * (np.abs(np.cos(phi - axis)) + np.abs(np.sin(phi - axis)))
        gaps.append(np.abs(p_T @ u) - half_t - reach)
    for offset in (0.0, 0.5 * math.pi):  # the chaser's axes, in T
        u = np.column_stack([np.cos(phi + offset), np.sin(phi + offset)])
        reach = half_t * (np.abs(u[:, 0]) + np.abs(u[:, 1]))
        gaps.append(np.abs(np.sum(p_T * u, axis=1)) - half_c - reach)
    gap = np.max(gaps, axis=0)
    goal = config.standoff_m * np.array(
        [math.cos(config.theta_approach_rad), math.sin(config.theta_approach_rad)]
    )
    p_N, v_N = X[-1, :2], X[-1, 3:5]
    relative_v = v_N - config.omega_target_rad_s * np.array([-p_N[1], p_N[0]])
    report = {
        "euler_residual": euler,
        "initial_state_error": float(np.abs(X[0] - plan.x0).max()),
        "final_attitude_error_rad": final_attitude,
        "arrival_attitude_error_rad": arrival,
        "force_excess_N": force_excess,
        "torque_excess_Nm": torque_excess,
        "wrench_cut_excess_N": float(cut.max()) if config.wrench_limit == "planar_8" else 0.0,
        "allocation_residual": allocation if config.wrench_limit == "planar_8" else 0.0,
        "keepout_q_m": float(q_values.min()),
        "squares_gap_m": float(gap.min()),
        "keepout_violations": int(np.sum(q_values < CHECK_TOLERANCES["keepout_q_m"])),
        "keepout_samples": len(ts),
        "zoh_drift_position_m": float(drift[:2].max()),
        "zoh_drift_attitude_rad": float(drift[2]),
        "zoh_drift_velocity": drift_v,
        "terminal_position_error_m": float(np.linalg.norm(p_N - goal)),
        "terminal_speed_m_s": float(np.linalg.norm(v_N)),
        "terminal_relative_speed_m_s": float(np.linalg.norm(relative_v)),
        "state_ii_fraction": float(np.mean(state == pa.STATE_II)),
        "state_ii_max_heading_error_rad": float(
            np.abs(heading[state == pa.STATE_II]).max() if np.any(state == pa.STATE_II) else 0.0
        ),
    }
    lower_bounds = ("keepout_q_m", "squares_gap_m")
    passed = all(
        report[name] >= bound if name in lower_bounds else report[name] <= bound
        for name, bound in CHECK_TOLERANCES.items()
    )
    passed = passed and report["squares_gap_m"] > 0.0
    report["passed"] = bool(passed)
    return report
