"""Paper 003's approach planner: the NLP of eqs. 5-9 for a planar chaser and a spinning target,
with the paper's duration search; the front door (config, result, search).

Owns: `PlanarPlannerSettings` and `PlanarApproachConfig` (with `validate`), the result
(`CandidateSolve`, `PlanarPlan`, and `PlanarPlanStatus`, re-exported from
`planar_approach_problem`), `duration_candidates` (Sec. III-A) and `plan_approach`
(-> `PlanarPlan`): the candidate durations, one method's solve per candidate, the goal rule and
the choice of the best.
Does not own: the problem data both methods share, with eqs. 5-9 and rpod's departures written
out (`planar_approach_problem`), the methods (`planar_approach_scp`, `planar_approach_nlp`), the
independent checker (`planar_approach_check`), the dynamics, the docking-face and goal
conventions, the keep-out zone (KOS) and the wrench limits (rpod.models.planar_approach, where
the conventions are written down), the tracking controller, the allocation to thrusters or the
pulse modulation.

Methods (`solver`): "scp" (default), sequential convex programming on MathematicalProgram with
Clarabel (`planar_approach_scp`); "ipopt" (the paper's solver) and "snopt", the joint NLP
through Drake, started from the SCP's answer unless `nlp_warm_start="guess"`
(`planar_approach_nlp`). Each method's module says how it solves, what it costs (measured) and
where it can lose optimality.

The paper's formulation as printed is `w_terminal_velocity=0, state_ii_heading=False`: eq. 5
and the position-only switch (its plans can then overlap the target:
benchmarks/results/planar_case1_study.md).

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
import math
import time

import numpy as np
from pydrake.trajectories import PiecewisePolynomial

from rpod.models import planar_approach as pa
from rpod.models.config import ConfigError, bounded, check_bounds, count, positive
from rpod.planners import planar_approach_problem as problem
from rpod.planners.planar_approach_nlp import solve_nlp
from rpod.planners.planar_approach_problem import PlanarPlanStatus
from rpod.planners.planar_approach_scp import solve_scp

SOLVERS = ("scp", "ipopt", "snopt")
WRENCH_LIMITS = ("planar_8", "box")
WARM_STARTS = ("scp", "guess")

_MAX_TURN_BETWEEN_SAMPLES_RAD = 0.02
"""Automatic sampling: the target turns at most this much between two keep-out samples."""

MAX_PLAN_KNOTS = 36_000
"""Most knots of a candidate (its duration over dt_s): an hour at Sec. V's 10 Hz."""
MAX_KEEPOUT_SAMPLES = 400_000
"""Most keep-out points of a candidate (knots x points per step; each is a few rows of every
subproblem): 100 times Sec. V-A's 4000, 20 times Case Study 1's largest (2000 knots x 10)."""


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
            paper (`planar_approach_problem`); 0 gives the paper's eq. 5.
        duration_min_s: Shortest candidate duration.
        duration_max_s: Longest candidate duration.
        max_duration_candidates: At most this many candidates, the shortest first.
        max_extra_candidates: When none of those reaches the goal, solve up to this many of
            the later candidates, in ascending order, up to the first that does (beyond the
            paper; 0: none). Slow thrusters need long approaches at a fast spin.
        keepout_samples_per_step: Keep-out points per step, the knot included (>= 1); 0 for
            automatic (`planar_approach_problem`).
        solver: "scp", "ipopt" or "snopt" (module docstring).
        max_iterations: SCP iterations (QPs) per candidate.
        nlp_max_iterations: IPOPT max_iter / SNOPT major iterations limit.
        scp_tolerance: SCP stop: relative change of the cost between iterations.
        nlp_tolerance: IPOPT tol and constr_viol_tol / SNOPT major tolerances.
        smooth_max_sharpness: Sharpness of the NLP's smooth half-ellipse terms.
        nlp_warm_start: Where "ipopt" and "snopt" start: "scp" (the SCP's answer, its labels)
            or "guess" (the spiral guess).
        state_ii_heading: State II needs the heading condition (rpod's,
            `planar_approach_problem`); False gives the paper's position-only switch (Sec.
            III-C as printed).
        goal_constraint: The goal as terminal constraints (beyond the paper): p_N = p_goal
            and v_N = omega_t z x p_N (the docking face's velocity), `planar_approach_problem`.

    Bounds (rpod.models.config; `PlanarApproachConfig.validate`): durations within an hour
    (with the step dt_s, at most MAX_PLAN_KNOTS knots and MAX_KEEPOUT_SAMPLES keep-out points:
    the program grows with both; Sec. V-A's three candidates, 2600 knots in all, plan in ~5 s);
    at most 100 candidates and 100 more, 100 keep-out points per step; 1000 SCP iterations
    (QPs) and 10000 NLP iterations per candidate; weights up to 1e9 (w_goal positive, the
    others may be 0); tolerances in (0, 1]; the goal's standoff within 1 km; the sharpness at
    most 500, since exp(sharpness tanh(.)) overflows a double past 709.
    """

    wrench_limit: str = "planar_8"
    goal_standoff_m: float = bounded(0.0, 0.0, 1e3)
    w_goal: float = positive(100.0, 1e9)
    w_u: float = bounded(10.0, 0.0, 1e9)
    w_terminal_velocity: float = bounded(1000.0, 0.0, 1e9)
    duration_min_s: float = bounded(1.0, 0.0, 3600.0)
    duration_max_s: float = positive(200.0, 3600.0)
    max_duration_candidates: int = count(3, 1, 100)
    max_extra_candidates: int = count(0, 0, 100)
    keepout_samples_per_step: int = count(0, 0, 100)
    solver: str = "scp"
    max_iterations: int = count(40, 1, 1000)
    nlp_max_iterations: int = count(3000, 1, 10_000)
    scp_tolerance: float = positive(1e-6, 1.0)
    nlp_tolerance: float = positive(1e-6, 1.0)
    smooth_max_sharpness: float = positive(20.0, 500.0)
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
        dt_s: Largest NLP step (Sec. V's control period, 0.1 s); see `planar_approach_problem`.
        goal_tolerance_m: A plan whose end point is farther than this from p_goal is
            GOAL_MISSED, not a success (the mission's position tolerance, 5 cm).

    Bounds: the spin within a revolution a second either way (the scenario's MAX_SPIN_DEG_S),
    non-zero (`validate`); the angles within a turn either way; sides, tolerance within 1 km;
    mass up to 1e6 kg, inertia up to 1e9 kg m^2, force and torque up to 1e6; the step up to the
    scenario's MAX_DURATION_S.
    """

    omega_target_rad_s: float = bounded(0.1, -2.0 * math.pi, 2.0 * math.pi)
    theta_approach_rad: float = bounded(0.75 * math.pi, -2.0 * math.pi, 2.0 * math.pi)
    theta_target0_rad: float = bounded(0.0, -2.0 * math.pi, 2.0 * math.pi)
    chaser_side_m: float = positive(0.3, 1e3)
    target_side_m: float = positive(0.3, 1e3)
    chaser_mass_kg: float = positive(10.0, 1e6)
    chaser_inertia_kg_m2: float = positive(0.15, 1e9)
    max_force_N: float = positive(0.6, 1e6)
    max_torque_Nm: float = positive(0.18, 1e6)
    dt_s: float = positive(0.1, 1e6)
    goal_tolerance_m: float = positive(0.05, 1e3)

    def validate(self) -> None:
        """Raises ConfigError naming the first bad field: its declared bounds (check_bounds),
        then the checks that need more than one field."""
        check_bounds(self)
        if self.omega_target_rad_s == 0.0:
            raise ConfigError("omega_target_rad_s", "must be non-zero (the durations come from it)")
        for name in (
            "max_duration_candidates",
            "max_extra_candidates",
            "keepout_samples_per_step",
            "max_iterations",
            "nlp_max_iterations",
        ):
            value = getattr(self, name)
            if int(value) != value:
                raise ConfigError(name, f"must be an integer, got {value!r}")
        if self.duration_min_s > self.duration_max_s:
            raise ConfigError(
                "duration_min_s",
                f"{self.duration_min_s} exceeds duration_max_s {self.duration_max_s}",
            )
        for name in ("state_ii_heading", "goal_constraint"):
            value = getattr(self, name)
            if value is not True and value is not False:
                raise ConfigError(name, f"must be true or false, got {value!r}")
        if self.solver not in SOLVERS:
            raise ConfigError("solver", f"must be one of {SOLVERS}, got {self.solver!r}")
        if self.nlp_warm_start not in WARM_STARTS:
            raise ConfigError(
                "nlp_warm_start", f"must be one of {WARM_STARTS}, got {self.nlp_warm_start!r}"
            )
        if self.wrench_limit not in WRENCH_LIMITS:
            raise ConfigError(
                "wrench_limit", f"must be one of {WRENCH_LIMITS}, got {self.wrench_limit!r}"
            )
        # The longest candidate is at most duration_max_s: its knots and keep-out points.
        steps = self.duration_max_s / self.dt_s  # a float: inf for a dt_s of 1e-320
        if steps - 1e-9 > MAX_PLAN_KNOTS:  # problem.grid's ceil
            raise ConfigError(
                "duration_max_s",
                f"{self.duration_max_s:g} s at dt_s = {self.dt_s:g} s is {steps:.6g} knots, must "
                f"be at most {MAX_PLAN_KNOTS}",
            )
        knots, dt = problem.grid(self, self.duration_max_s)
        points = knots * self.samples_per_step(dt)
        if points > MAX_KEEPOUT_SAMPLES:
            raise ConfigError(
                "keepout_samples_per_step",
                f"{knots} knots of {self.samples_per_step(dt)} keep-out points are {points}, must "
                f"be at most {MAX_KEEPOUT_SAMPLES}",
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


# ------------------------------------------------------------------------------ durations


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


# ------------------------------------------------------------------------------ the planner


def _solve_candidate(config, x0, duration_s):
    guess = problem.initial_guess(config, x0, duration_s)
    start = time.perf_counter()
    method = solve_scp if config.solver == "scp" else solve_nlp
    status, word, iterations, X, U = method(config, x0, duration_s, guess)
    elapsed = time.perf_counter() - start
    cost = math.nan
    if X is not None:
        cost = sum(problem.cost_terms(config, X, U, problem.grid(config, duration_s)[1]).values())
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
    N, dt = problem.grid(config, record.duration_s)
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
        cost_terms=problem.cost_terms(config, X, U, dt),
        goal_position=config.goal_position,
        theta_finish=pa.chaser_final_attitude(config.theta_approach_rad, x0[2]),
        x0=x0,
        candidates=records,
    )
