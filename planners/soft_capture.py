"""The soft-capture planner of paper 000: config, result, and the search over the horizon N.

Owns: ``SoftCaptureConfig`` (Table I), ``SoftCapturePlan`` (the typed result), and
``SoftCapturePlanner``, which predicts nothing itself (it takes a ``TargetPrediction``), builds
the terminal and docking data from the prediction, keeps one Problem 2 and one Problem 3
program per horizon length N (built on first use, reused for every later plan), and searches N.
Does not own: the programs (``soft_capture_socp``), the iteration at one N
(``soft_capture_scp``), the pointing law (``pointing``), the target prediction
(``target_prediction``), the independent checker (``plan_check``), or anything that runs in time.

Horizon search (the paper gives no step). N is tried in increasing order, N_min, N_min + step,
..., always ending with N_max (default step 10: 40, 50, ..., 340, 350), and the first N whose plan
passes the hard test (alpha_k > 1 at every knot) is returned: the shortest capture found on the
grid. Why this search: feasibility is not monotone in N (the capture pose turns with the
tumble, so a longer horizon can fail where a shorter one succeeds), which rules out bisection;
the paper increments N upward, and its Fig. 9 shows time to capture growing with distance, so the
shortest success is both the natural answer and the cheapest to reach. A unit step would cost up
to 311 horizons x (1 + i_max) solves on an infeasible start; step 10 bounds that to 32 horizons
(each Problem 2 infeasibility is detected by one solve, and Problem 3 is feasible iff Problem 2 is,
so an infeasible Problem 2 skips the SCP). ``horizon_step`` and ``horizons`` change the grid.

Terminal velocity (14), which chaser point it constrains (``terminal_velocity_point``):
``"chaser_capture_point"`` (default): the chaser capture point D_c, with the chaser in the
capture pose and turning with the target, moves with the target capture point,
``v_N-1 = R_LT (w_LT_T x (D_t - R_y(pi) D_c)) = R_LT (w_LT_T x (D_t + D_c))``, i.e. the chaser
capture point's velocity equals ``R_LT (w_LT_T x D_t)``. The pointing law gives the same thing
at the capture pose (its rate is the line-of-sight rate, the target's rate less its spin about
the capture axis, which does not move the capture point). This is also the speed behind the
paper's tumble limit ``v_max / |D_c + D_t|``. ``"chaser_center_of_mass"``: the paper's literal
(14), ``v_N-1 = R_LT (w_LT_T x D_t)``, which leaves the capture points closing at
``|D_c| / |D_c + D_t|`` (half) of the target capture point's speed.
``w_LT_T = w_IT_T - R_LT^T [0, 0, n_orbit]`` is the target's rate relative to the rotating LVLH
frame, ``n_orbit`` the LVLH rate the prediction was made with.
"""

import enum
import math
from dataclasses import dataclass, field, fields

import numpy as np
from pydrake.math import RotationMatrix
from pydrake.trajectories import PiecewisePolynomial

from rpod.models.collision import ScalingMetricProgram
from rpod.models.config import ConfigError, bounded, check_bounds, count, positive
from rpod.models.cw import passively_safe_state
from rpod.models.docking import capture_reach_T
from rpod.models.frames import rotations_from_wxyz
from rpod.models.gravity import R_EARTH_M, mean_motion
from rpod.models.shapes import soft_capture_chaser_hull, soft_capture_target_hull
from rpod.planners.pointing import pointing_attitudes
from rpod.planners.soft_capture_scp import HorizonOutcome, solve_horizon
from rpod.planners.soft_capture_socp import SocpData, SoftCaptureSocp
from rpod.planners.target_prediction import TargetPrediction, predict_target

TERMINAL_VELOCITY_POINTS = ("chaser_capture_point", "chaser_center_of_mass")
SOCP_SOLVERS = ("clarabel", "ecos", "qoco")

MAX_GRID_KNOTS = 50_000
"""Most knots over the horizon grid (the sum of its N): the planner keeps a Problem 2 and a
Problem 3 program for every N it tries, ~18 kB per knot for the pair (64 MB for ten horizons of
~350 knots), so 50,000 knots is ~1 GB of programs; the default grid holds 6,240."""


class PlanStatus(str, enum.Enum):
    """What came of a planner call, in the planner's own words (a str: "success" == SUCCESS).

    The first block is the planner's (SoftCapturePlan.status); the last two are the
    predict-plan-check path's (rpod.planners.checked_plan): the target prediction failed, or
    the independent checker rejected a plan the planner called a success. The order is fixed:
    logs store these as codes (their index, after "none").
    """

    SUCCESS = "success"
    INVALID_INPUT = "invalid_input"
    TUMBLE_RATE_ABOVE_LIMIT = "tumble_rate_above_limit"
    INITIAL_STATE_IN_COLLISION = "initial_state_in_collision"
    NO_FEASIBLE_HORIZON = "no_feasible_horizon"
    PROBLEM2_INFEASIBLE = "problem2_infeasible"
    PROBLEM2_SOLVER_FAILURE = "problem2_solver_failure"
    PROBLEM3_INFEASIBLE = "problem3_infeasible"
    PROBLEM3_SOLVER_FAILURE = "problem3_solver_failure"
    COLLISION_METRIC_FAILED = "collision_metric_failed"
    SCP_MAX_ITERATIONS = "scp_max_iterations"
    PREDICTION_FAILED = "prediction_failed"
    CHECK_FAILED = "check_failed"


@dataclass(frozen=True)
class PlanTrajectories:
    """A plan as pydrake trajectories, so that any tracker can follow any planner's result.

    Times are absolute (the plan's start t0 plus the knot times).

    Attributes:
        position_L: p_LC_L (3) [m], the cubic Hermite spline through the knots' positions with
            the knots' velocities as slopes.
        velocity_L: v_LC_L (3) [m/s], first-order hold between the knots.
        force_L: the planned force in L (3) [N], zero-order hold over each step (the last
            step's force is held to the final knot).
    """

    position_L: PiecewisePolynomial
    velocity_L: PiecewisePolynomial
    force_L: PiecewisePolynomial


@dataclass
class SoftCaptureSettings:
    """How paper 000's soft capture is solved: Table I's weights, bounds and tolerances and the
    horizon search (the method, apart from the problem data of `SoftCaptureConfig`).

    Every number declares its legal range (rpod.models.config), checked by `validate()`.
    Generous but finite: a weight up to 1e9, a speed or range up to the scenario's own limits
    (MAX_RELATIVE_SPEED_M_S, MAX_RANGE_M in rpod.diagrams.scenario), a horizon up to 5000 knots
    (a Problem 3 solve costs ~1.4 ms per knot: ~7 s at 5000).

    Attributes:
        fuel_weight_gamma: gamma, weight of the L1 fuel term in Problem 3.
        problem2_fuel_weight: Weight of the L1 fuel term in Problem 2: 1 as the paper's
            Problem 2 is printed; the authors' public code uses gamma in both problems.
        slack_penalty_psi: psi, exact-penalty weight of the collision slacks s_k in Problem 3.
        max_thrust_N: U_max, bound on |u_k| (9) [N].
        max_range_m: r_max, bound on the range lift rho_k (16) [m].
        max_speed_m_s: v_max, bound on |v_k| (10) [m/s].
        max_los_rate_rad_s: omega_max, line-of-sight rate bound of the field of view (12)
            [rad/s]; at most a revolution a second, and omega_max dt at most pi/2 (`validate`).
        capture_position_tol_m: eps_p, terminal position tolerance (13) [m].
        capture_speed_tol_m_s: eps_v, terminal velocity tolerance (14) [m/s].
        docking_knots: N_dock, number of final knots inside the docking cone (11).
        alpha_min: Soft collision margin asked of the linearised rows (25); the hard test is 1,
            so it must exceed 1 (at most 100: hulls kept 100 times their size apart).
        max_scp_iterations: i_max, most Problem 3 solves per horizon (0: Problem 2 only); at
            most 1000, since the search may pay them at every horizon of the grid.
        dt_s: dt, knot spacing [s]; at most 200 s, so that max_knots dt stays within the
            scenario's MAX_DURATION_S (5000 x 200 s = 1e6 s).
        min_knots: N_min of the horizon search (Sec. VI-B).
        max_knots: N_max of the horizon search (Sec. VI-B).
        horizon_step: Step of the horizon search (module docstring; the paper gives none).
            The grid's knots, summed, are at most MAX_GRID_KNOTS (`validate`).
        terminal_velocity_point: Which chaser point (14) constrains: "chaser_capture_point"
            (default) or "chaser_center_of_mass" (module docstring).
        check_tumble_limit: Return "tumble_rate_above_limit" without solving when the initial
            tumble rate exceeds min(omega_max, v_max / |D_c + D_t|) (Sec. VI-B's envelope).
        socp_solver: Who solves Problems 2 and 3: "clarabel" (Drake's ClarabelSolver),
            "ecos" or "qoco" (their own packages, on the program's standard form,
            rpod.planners.conic_form). QOCO cannot tell an infeasible horizon: it ends at its
            iteration limit, which the search counts as a failure to solve.
        socp_scaled: Write Problems 2 and 3 in units rather than SI (rpod.planners
            .soft_capture_socp, "Units"): the same optimum in fewer iterations.
        socp_iterative_refinement: Clarabel refines every KKT solve (its default); off, each
            iteration costs ~30 % less. Clarabel stops on residuals computed from the data,
            not from the KKT solves, so an unrefined solve can cost iterations but not accuracy
            (measured: the same statuses and optima to 2e-8 relative,
            benchmarks/results/soft_capture_solvers.md).
    """

    fuel_weight_gamma: float = positive(5.0, 1e9)
    problem2_fuel_weight: float = positive(1.0, 1e9)
    slack_penalty_psi: float = positive(750.0, 1e9)
    max_thrust_N: float = positive(100.0, 1e6)
    max_range_m: float = positive(100.0, 1e6)
    max_speed_m_s: float = positive(1.5, 1e4)
    max_los_rate_rad_s: float = positive(0.2, 2.0 * math.pi)
    capture_position_tol_m: float = positive(0.35, 1e3)
    capture_speed_tol_m_s: float = positive(0.03, 1e2)
    docking_knots: int = count(5, 0, 5000)
    alpha_min: float = bounded(1.3, 1.0, 100.0, low_open=True)
    max_scp_iterations: int = count(15, 0, 1000)
    dt_s: float = positive(1.0, 200.0)
    min_knots: int = count(40, 2, 5000)
    max_knots: int = count(350, 2, 5000)
    horizon_step: int = count(10, 1, 5000)
    terminal_velocity_point: str = "chaser_capture_point"
    check_tumble_limit: bool = True
    socp_solver: str = "clarabel"
    socp_scaled: bool = True
    socp_iterative_refinement: bool = False

    def horizon_grid(self) -> list[int]:
        """The N values the search tries, in order."""
        grid = list(range(self.min_knots, self.max_knots + 1, self.horizon_step))
        if grid[-1] != self.max_knots:
            grid.append(self.max_knots)
        return grid

    def validate(self) -> None:
        """Raises ConfigError naming the first bad field: its declared bounds (check_bounds),
        then the checks that need more than one field."""
        check_bounds(self)
        for name in (
            "docking_knots",
            "max_scp_iterations",
            "min_knots",
            "max_knots",
            "horizon_step",
        ):
            value = getattr(self, name)
            if int(value) != value:
                raise ConfigError(name, f"must be an integer, got {value!r}")
        if not self.max_los_rate_rad_s * self.dt_s <= math.pi / 2:
            raise ConfigError("max_los_rate_rad_s", "omega_max dt must lie in (0, pi/2]")
        if not self.min_knots <= self.max_knots:
            raise ConfigError("min_knots", "need 2 <= min_knots <= max_knots")
        knots = sum(self.horizon_grid())
        if knots > MAX_GRID_KNOTS:
            raise ConfigError(
                "horizon_step",
                f"the horizon grid {self.min_knots}..{self.max_knots} by {self.horizon_step} "
                f"holds {knots} knots, must be at most {MAX_GRID_KNOTS} (a larger step or a "
                "smaller max_knots)",
            )
        if self.socp_solver not in SOCP_SOLVERS:
            raise ConfigError(
                "socp_solver", f"must be one of {SOCP_SOLVERS}, got {self.socp_solver!r}"
            )
        if self.terminal_velocity_point not in TERMINAL_VELOCITY_POINTS:
            raise ConfigError(
                "terminal_velocity_point",
                f"must be one of {TERMINAL_VELOCITY_POINTS}, got {self.terminal_velocity_point!r}",
            )


@dataclass
class SoftCaptureConfig(SoftCaptureSettings):
    """What the planner consumes: the problem data (Table I defaults) and the settings.

    In a scenario the problem data are never written: rpod's soft-capture plug-in derives them
    from `orbit`, `chaser` and `target` (`from_settings`); the defaults here are Table I's,
    for the planner on its own.

    Attributes:
        semi_major_axis_m: a, semi-major axis of the target's circular orbit [m]; n = sqrt(mu/a^3).
            At most R_earth + the scenario's MAX_ALTITUDE_M.
        chaser_mass_kg: m_c, chaser mass [kg] (force / m = the CW input acceleration); at most
            1e6 kg, past any spacecraft flown.
        docking_half_angle_deg: theta_dock, half-angle of the docking cone (11) [deg], in (0, 90).
        p_CDc_C: D_c, chaser capture point from the chaser centre of mass, in C [m]; its
            direction is the capture axis that the pointing law turns toward the target.
        p_TDt_T: D_t, target capture point from the target centre of mass, in T [m]; its
            direction is the docking-cone axis. Each entry of both within 1 km.
        (the rest: SoftCaptureSettings)
    """

    semi_major_axis_m: float = positive(7738e3, R_EARTH_M + 1.0e8)
    chaser_mass_kg: float = positive(1500.0, 1e6)
    docking_half_angle_deg: float = bounded(30.0, 0.0, 90.0, low_open=True, high_open=True)
    p_CDc_C: list[float] = bounded([0.0, 0.0, 2.7], -1e3, 1e3)  # noqa: RUF009 (a field())
    p_TDt_T: list[float] = bounded([0.0, 0.0, 2.7], -1e3, 1e3)  # noqa: RUF009

    @classmethod
    def from_settings(
        cls,
        settings: SoftCaptureSettings,
        *,
        semi_major_axis_m: float,
        chaser_mass_kg: float,
        docking_half_angle_deg: float,
        p_CDc_C,
        p_TDt_T,
    ) -> "SoftCaptureConfig":
        """The settings with the problem data of one scenario."""
        values = {f.name: getattr(settings, f.name) for f in fields(SoftCaptureSettings)}
        return cls(
            **values,
            semi_major_axis_m=float(semi_major_axis_m),
            chaser_mass_kg=float(chaser_mass_kg),
            docking_half_angle_deg=float(docking_half_angle_deg),
            p_CDc_C=[float(v) for v in p_CDc_C],
            p_TDt_T=[float(v) for v in p_TDt_T],
        )

    @property
    def mean_motion(self) -> float:
        """n = sqrt(mu / a^3) [rad/s]."""
        return mean_motion(self.semi_major_axis_m)

    @property
    def tumble_rate_limit_rad_s(self) -> float:
        """min(omega_max, v_max / |D_c + D_t|): the paper's applicability limit (Sec. VI-B)."""
        reach = np.linalg.norm(capture_reach_T(self.p_CDc_C, self.p_TDt_T))
        return min(self.max_los_rate_rad_s, self.max_speed_m_s / reach)

    def symbols(self) -> dict:
        """Table I parameters under their paper symbols (for plan files and reports)."""
        return {
            "n": self.mean_motion,
            "m": self.chaser_mass_kg,
            "dt": self.dt_s,
            "gamma": self.fuel_weight_gamma,
            "psi": self.slack_penalty_psi,
            "U_max": self.max_thrust_N,
            "r_max": self.max_range_m,
            "v_max": self.max_speed_m_s,
            "omega_max": self.max_los_rate_rad_s,
            "eps_p": self.capture_position_tol_m,
            "eps_v": self.capture_speed_tol_m_s,
            "theta_dock": math.radians(self.docking_half_angle_deg),
            "N_dock": self.docking_knots,
            "alpha_min": self.alpha_min,
            "i_max": self.max_scp_iterations,
            "D_c": np.asarray(self.p_CDc_C, dtype=float),
            "D_t": np.asarray(self.p_TDt_T, dtype=float),
        }

    def validate(self) -> None:
        """Raises ConfigError naming the first bad field: the capture points' shape, then
        SoftCaptureSettings.validate (every field's bounds, problem data included, then the
        checks that need more than one field)."""
        for name in ("p_CDc_C", "p_TDt_T"):
            vector = np.asarray(getattr(self, name), dtype=float)
            if vector.shape != (3,) or not np.all(np.isfinite(vector)) or not vector.any():
                raise ConfigError(name, "must be 3 finite numbers, not all zero")
        super().validate()


@dataclass
class HorizonAttempt:
    """One horizon tried by the search.

    Attributes:
        N: Number of knots.
        status: The ``HorizonOutcome`` status at this N.
        reason: Its one-line reason.
        scp_iterations: Problem 3 solves at this N.
        solve_time_s: Wall time of each SOCP solve at this N [s].
        step_time_s: Wall time of each step at this N (``HorizonOutcome.step_time_s``) [s].
    """

    N: int
    status: str
    reason: str
    scp_iterations: int
    solve_time_s: list[float]
    step_time_s: list[float] = field(default_factory=list)


@dataclass
class SoftCapturePlan:
    """The planner's result. Arrays are those of the returned horizon N.

    On success, the plan at the first horizon that passed. Otherwise the last iterate of the
    last horizon at which Problem 2 was feasible (for diagnosis; it fails the hard test), or
    empty arrays (N = 0) when no horizon got that far. Times are from the plan's start.

    Attributes:
        status: ``"success"``, ``"invalid_input"`` (non-finite start),
            ``"tumble_rate_above_limit"``, ``"initial_state_in_collision"`` (alpha <= 1 at the
            start), ``"no_feasible_horizon"`` (Problem 2 infeasible at every N tried), or the
            status of the last horizon tried (``"scp_max_iterations"``,
            ``"problem2_solver_failure"``, ``"problem3_infeasible"``,
            ``"problem3_solver_failure"``, ``"collision_metric_failed"``).
        reason: One line; for solver failures it carries Clarabel's own status word.
        N: Number of knots of the returned arrays.
        t: Knot times (N,) [s] from the plan start.
        x: States (N, 6): ``[p_LC_L, v_LC_L]`` [m, m/s].
        u: Thrust forces (N-1, 3) in L [N], held over each step.
        q_LT: Predicted target attitudes (N, 4), (w, x, y, z) of R_LT.
        w_IT_T: Predicted target rates (N, 3) in T [rad/s].
        q_LC: Pointing-law chaser attitudes (N, 4), (w, x, y, z) of R_LC.
        alpha: Collision metric at each knot (N,).
        rho: Range lift (N,) [m].
        slack: Collision slacks of the last Problem 3 solve (N,) (zeros after Problem 2).
        scp_iterations: Problem 3 solves at the returned N.
        solve_time_s: Wall time of each SOCP solve at the returned N, Problem 2 first [s].
        step_time_s: Wall time of each step at the returned N: Problem 2 with its alpha
            check, then each SCP iteration with its own (``HorizonOutcome.step_time_s``) [s].
        cost: Objective value of the last solve at the returned N.
        fuel_l1_N: sum_k |u_k|_1 [N] (times dt: the L1 impulse).
        min_alpha: min(alpha) (NaN for an empty plan).
        attempts: Every horizon tried, in order.
        total_solve_time_s: Sum of all SOCP solve times over the search [s].
    """

    status: str
    reason: str
    N: int
    t: np.ndarray
    x: np.ndarray
    u: np.ndarray
    q_LT: np.ndarray
    w_IT_T: np.ndarray
    q_LC: np.ndarray
    alpha: np.ndarray
    rho: np.ndarray
    slack: np.ndarray
    scp_iterations: int
    solve_time_s: list[float]
    cost: float
    fuel_l1_N: float
    min_alpha: float
    attempts: list[HorizonAttempt]
    total_solve_time_s: float
    step_time_s: list[float] = field(default_factory=list)

    def __post_init__(self):
        self.status = PlanStatus(self.status)

    @property
    def success(self) -> bool:
        """True when the plan passed the hard collision test at every knot."""
        return self.status is PlanStatus.SUCCESS

    def trajectories(self, t0_s: float = 0.0) -> PlanTrajectories:
        """The plan as pydrake trajectories from t0_s (needs N >= 2 knots)."""
        if self.N < 2:
            raise ValueError(f"a plan of {self.N} knots has no trajectory")
        t = t0_s + np.asarray(self.t, dtype=float)
        p, v = self.x[:, :3].T, self.x[:, 3:].T
        u = np.column_stack([self.u.T, self.u[-1]])  # the last force held to the final knot
        return PlanTrajectories(
            PiecewisePolynomial.CubicHermite(t, p, v),
            PiecewisePolynomial.FirstOrderHold(t, v),
            PiecewisePolynomial.ZeroOrderHold(t, u),
        )


def terminal_targets(
    config: SoftCaptureConfig, R_LT: np.ndarray, w_IT_T: np.ndarray, n_orbit: float
) -> tuple[np.ndarray, np.ndarray]:
    """The terminal chaser centre-of-mass position and velocity, eqs. (13) and (14).

    Args:
        config: The planner config.
        R_LT: Target attitude (3, 3) at the final knot.
        w_IT_T: Target inertial rate (3,) in T at the final knot [rad/s].
        n_orbit: LVLH rate about L's z axis used by the prediction [rad/s].

    Returns:
        ``(p*, v*)`` in L [m, m/s] (module docstring for which chaser point v* constrains).
    """
    D_t = np.asarray(config.p_TDt_T, dtype=float)
    reach_T = capture_reach_T(config.p_CDc_C, D_t)  # D_t + D_c (Table I)
    w_LT_T = np.asarray(w_IT_T, dtype=float) - R_LT.T @ np.array([0.0, 0.0, n_orbit])
    lever_T = reach_T if config.terminal_velocity_point == "chaser_capture_point" else D_t
    return R_LT @ reach_T, R_LT @ np.cross(w_LT_T, lever_T)  # (13), (14)


def _quaternions(R: np.ndarray) -> np.ndarray:
    return np.array([RotationMatrix(Rk).ToQuaternion().wxyz() for Rk in R])


class SoftCapturePlanner:
    """Paper 000's planner with a cache of programs per horizon length.

    Not thread-safe (the programs hold their data between solves); use one planner per thread
    or process.

    Args:
        config: Problem data; validated here (ValueError names the bad field).
        chaser_hull: Chaser convex hull in C (default: paper 000's hexagonal prism).
        target_hull: Target convex hull in T (default: paper 000's pentagonal prism).
    """

    def __init__(self, config: SoftCaptureConfig | None = None, chaser_hull=None, target_hull=None):
        self.config = config if config is not None else SoftCaptureConfig()
        self.config.validate()
        self.chaser_hull = chaser_hull if chaser_hull is not None else soft_capture_chaser_hull()
        self.target_hull = target_hull if target_hull is not None else soft_capture_target_hull()
        self._metric = ScalingMetricProgram(self.chaser_hull, self.target_hull)
        self._programs: dict[int, tuple[SoftCaptureSocp, SoftCaptureSocp]] = {}

    def programs(self, N: int) -> tuple[SoftCaptureSocp, SoftCaptureSocp]:
        """The (Problem 2, Problem 3) programs for N knots, built on first use."""
        if N not in self._programs:
            self._programs[N] = (
                SoftCaptureSocp(self.config, N, with_collision=False),
                SoftCaptureSocp(self.config, N, with_collision=True),
            )
        return self._programs[N]

    def plan(self, x0_L, prediction, horizons=None, R_LC0=None) -> SoftCapturePlan:
        """Plans a soft capture from ``x0_L`` against a predicted tumbling target.

        Args:
            x0_L: Initial chaser state (6,) ``[p_LC_L, v_LC_L]`` [m, m/s].
            prediction: A ``TargetPrediction`` from the plan's start time t_0 (= now), with
                knots ``t_0 + k dt`` covering the longest horizon tried, as made by
                ``predict_for_planner``.
            horizons: Optional list of N to try, in order (default: ``config.horizon_grid()``).
            R_LC0: Optional chaser attitude (3, 3) before the plan, for the pointing law.

        Returns:
            A ``SoftCapturePlan``; never raises on infeasibility or solver failure.
        """
        c = self.config
        x0 = np.asarray(x0_L, dtype=float).reshape(6)
        grid = list(horizons) if horizons is not None else c.horizon_grid()
        q_LT_all, w_IT_T_all = _prediction_at_knots(prediction, c.dt_s, max(grid))
        n_orbit = float(prediction.n_orbit)
        if not (np.all(np.isfinite(x0)) and np.linalg.norm(x0[:3]) > 0.0):
            return _empty_plan(
                "invalid_input",
                f"initial state {x0.tolist()} is not finite or sits at the target's centre",
                [],
            )
        tumble = float(np.linalg.norm(w_IT_T_all[0]))
        if c.check_tumble_limit and tumble > c.tumble_rate_limit_rad_s:
            return _empty_plan(
                "tumble_rate_above_limit",
                f"tumble rate {tumble:.4f} rad/s exceeds min(omega_max, v_max / |D_c + D_t|) = "
                f"{c.tumble_rate_limit_rad_s:.4f} rad/s",
                [],
            )
        R_LT_all = rotations_from_wxyz(q_LT_all)
        # A start in collision cannot pass the hard test at any N: one LP instead of a search.
        R_LC_start = pointing_attitudes(x0[None, :3], c.p_CDc_C, R_LC0)[0]
        alpha0 = self._metric.evaluate(R_LC_start, x0[:3], R_LT_all[0], np.zeros(3)).alpha
        if not alpha0 > 1.0:
            return _empty_plan(
                "initial_state_in_collision", f"alpha at the initial state is {alpha0:.4f} <= 1", []
            )
        attempts: list[HorizonAttempt] = []
        last_feasible: HorizonOutcome | None = None  # last N where Problem 2 was feasible
        for N in grid:
            p_star, v_star = terminal_targets(c, R_LT_all[N - 1], w_IT_T_all[N - 1], n_orbit)
            data = SocpData(
                x0=x0,
                R_LT_dock=R_LT_all[max(0, N - c.docking_knots) : N],
                p_terminal_L=p_star,
                v_terminal_L=v_star,
            )
            problem2, problem3 = self.programs(N)
            outcome = solve_horizon(c, problem2, problem3, data, R_LT_all[:N], self._metric, R_LC0)
            attempts.append(
                HorizonAttempt(
                    N,
                    outcome.status,
                    outcome.reason,
                    outcome.scp_iterations,
                    list(outcome.solve_time_s),
                    list(outcome.step_time_s),
                )
            )
            if outcome.x is not None:
                last_feasible = outcome
            if outcome.status == "success":
                break
        status, reason = _verdict(grid, attempts, last_feasible)
        if last_feasible is None:
            return _empty_plan(status, reason, attempts)
        chosen, N = last_feasible, last_feasible.N
        return SoftCapturePlan(
            status=status,
            reason=reason,
            N=N,
            t=np.arange(N) * c.dt_s,
            x=chosen.x,
            u=chosen.u,
            q_LT=q_LT_all[:N],
            w_IT_T=w_IT_T_all[:N],
            q_LC=_quaternions(chosen.R_LC),
            alpha=chosen.alpha,
            rho=chosen.rho,
            slack=chosen.slack,
            scp_iterations=chosen.scp_iterations,
            solve_time_s=list(chosen.solve_time_s),
            step_time_s=list(chosen.step_time_s),
            cost=chosen.cost,
            fuel_l1_N=float(np.abs(chosen.u).sum()),
            min_alpha=float(chosen.alpha.min()),
            attempts=attempts,
            total_solve_time_s=float(sum(sum(a.solve_time_s) for a in attempts)),
        )


def _verdict(grid, attempts, last_feasible) -> tuple[str, str]:
    """The plan's status and reason from the horizons tried."""
    span = f"{grid[0]}..{grid[-1]}"
    if attempts and attempts[-1].status == "success":
        return "success", f"N = {attempts[-1].N}: {attempts[-1].reason}"
    if last_feasible is None:
        infeasible = all(a.status == "problem2_infeasible" for a in attempts)
        status = "no_feasible_horizon" if infeasible else attempts[-1].status
        reasons = "; ".join(sorted({a.reason for a in attempts}))
        return status, f"no horizon in {span} gave a plan: {reasons}"
    return last_feasible.status, (
        f"no horizon in {span} passed; last feasible N = {last_feasible.N}: {last_feasible.reason}"
    )


def _empty_plan(status: str, reason: str, attempts: list[HorizonAttempt]) -> SoftCapturePlan:
    return SoftCapturePlan(
        status=status,
        reason=reason,
        N=0,
        t=np.zeros(0),
        x=np.zeros((0, 6)),
        u=np.zeros((0, 3)),
        q_LT=np.zeros((0, 4)),
        w_IT_T=np.zeros((0, 3)),
        q_LC=np.zeros((0, 4)),
        alpha=np.zeros(0),
        rho=np.zeros(0),
        slack=np.zeros(0),
        scp_iterations=0,
        solve_time_s=[],
        cost=float("nan"),
        fuel_l1_N=0.0,
        min_alpha=float("nan"),
        attempts=attempts,
        total_solve_time_s=float(sum(sum(a.solve_time_s) for a in attempts)),
    )


def _prediction_at_knots(prediction, dt: float, N: int) -> tuple[np.ndarray, np.ndarray]:
    """The prediction's (q_LT, w_IT_T) at the knots t_k = t_0 + k dt, k < N (t_0 = its start).

    Raises:
        ValueError: If the prediction's own knots are not ``k dt`` for k < N (a programming
            error: make it with ``predict_for_planner``).
    """
    t = np.asarray(prediction.t, dtype=float)
    expected = np.arange(N) * dt
    if len(t) < N or not np.allclose(t[:N] - t[0], expected, rtol=0.0, atol=1e-9 * dt * N):
        raise ValueError(
            f"the target prediction must have knots t_0 + k dt (dt = {dt}) for k < {N}; "
            f"got {len(t)} knots spanning {t[-1] - t[0] if len(t) else None} s"
        )
    return np.asarray(prediction.q_LT, dtype=float)[:N], np.asarray(prediction.w_IT_T)[:N]


def predict_for_planner(
    config: SoftCaptureConfig, q_LT0, w_IT_T0, inertia, t0_s: float = 0.0
) -> TargetPrediction:
    """The target prediction the planner expects: knots ``t0 + k dt``, k < N_max, L turning at n.

    Args:
        config: The planner config (dt, N_max, orbit).
        q_LT0: Estimated quaternion (4,) (w, x, y, z) of ``R_LT`` at t0.
        w_IT_T0: Estimated inertial body rate (3,) of the target, in T, at t0 [rad/s].
        inertia: Target inertia (3, 3) in T [kg m^2] (paper 000 eq. (27) in its examples).
        t0_s: Time of the estimate and of the plan's start [s].
    """
    t_knots = t0_s + np.arange(config.max_knots) * config.dt_s
    return predict_target(q_LT0, w_IT_T0, inertia, t_knots, n_orbit=config.mean_motion)


PAPER_TARGET_INERTIA_KG_M2 = np.array(  # paper 000 eq. (27)
    [[5.89056, 0.0, 0.0], [0.0, 11.4462, 0.233516], [0.0, 0.233516, 11.5365]]
)


def sample_sec_vib_start(
    rng: np.random.Generator, config: SoftCaptureConfig
) -> tuple[np.ndarray, TargetPrediction]:
    """One Sec. VI-B-like start: (x0 (6,) in L, the planner's TargetPrediction).

    The chaser on a passively safe relative orbit (eq. 6) of in-plane amplitude 15-25 m and
    cross-track 10-25 m at random phases, 15-50 m away; the target of eq. (27) at a uniformly
    random attitude, tumbling at 0-10 deg/s about a uniformly random axis. The paper's own
    draw is not printed beyond these ranges; rpod's benchmarks and guard tests use this one.
    """
    n = config.mean_motion
    while True:
        A0, B0 = rng.uniform(15.0, 25.0), rng.uniform(10.0, 25.0)
        phase, phase_z = rng.uniform(0.0, 2.0 * np.pi, 2)
        x0 = passively_safe_state(
            n,
            A0 * np.cos(phase),
            n * A0 * np.sin(phase),
            B0 * np.cos(phase_z),
            n * B0 * np.sin(phase_z),
        )
        if 15.0 <= np.linalg.norm(x0[:3]) <= 50.0:
            break
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    axis = rng.normal(size=3)
    w = axis / np.linalg.norm(axis) * np.radians(rng.uniform(0.0, 10.0))
    return x0, predict_for_planner(config, q, w, PAPER_TARGET_INERTIA_KG_M2)
