"""Paper 001's optimal control problem (22): its transcription, and the solvers that solve it.

Owns: `CoupledNmpcSettings` (horizon, transcription, solver and its options), `CoupledNmpc` (the
problem, built once per shape and solved from a new x0), `NmpcResult`, `shifted_warm_start` and
the independent checker `check_plan`. Does not own: the prediction model, its constraints and
costs (rpod.models.coupled_relative, used as they are), the vectorised transcription and its
derivatives (rpod.planners.coupled_shooting), the SQP algorithm (rpod.planners.coupled_sqp), the
receding-horizon controller system, or the scenario.

Transcription: multiple shooting with an explicit RK4 integrator. The input is piecewise constant
on N intervals of T_s = T / N (Sec. III-D); on each interval the state is carried from its node by
`rk4_substeps` classical RK4 steps (default 2: the dynamics sampled at the two ends and the
midpoint of each sub-step, the paper's "two collocation points per interval" replaced by an
equivalent of 4th order). Why not collocation: a collocation scheme of the paper's degree adds
2 x 21 unknowns and 2 x 21 equalities per interval and its accuracy at T_s = 60 s is that of a
degree-2 polynomial, while RK4 keeps the NLP at the N + 1 nodes and is 4th order.
`interval_defect` (scalar-generic: floats or AutoDiffXd) is the reference definition of one
interval's defect; the solvers evaluate the same numbers for all intervals at once, with exact
Jacobians by complex-step differentiation (rpod.planners.coupled_shooting, tested equal).

State in the NLP: the 21 entries of eq. 15 (R_TC's 9 entries, w_TC_T, p_PtPc_T, v_PtPc_T, xi_T).
The 18 absolute target entries of the model's state (R_IT, w_IT_T, p_IT_I, v_IT_I) are reached by
no input, so they are not decision variables: at each solve they are propagated once from x0 by
the same RK4 (the "reference"), and each interval starts its RK4 from the reference node.

SO(3) in the transcription: re-orthonormalisation. At the end of every interval R_TC (and the
reference's R_IT) is carried back onto SO(3) by three Newton-Schulz steps of the polar
decomposition (`coupled_shooting.polar_newton_schulz`): a polynomial, so the defect stays smooth
and its exact derivatives pass through it. Without it RK4's drift at 30 s steps through the
Sec. IV slew left the nodes 2.4e-2 off SO(3), and real-time iterations, which re-linearise about
their own previous answer, compounded it until they diverged.

Trust of the integrator: the chaser's attitude is fast against T_s (Sec. IV's thrusters give
~0.05 rad/s^2, a 180 deg slew in ~16 s), and RK4 at 30 s steps is only accurate while the
rotation per step stays below ~0.5 rad. `max_relative_rate_rad_s` (default 0.02 rad/s, not in the
paper) boxes each entry of w_TC_T at the nodes 1..N so that the solver cannot exploit the
integrator's error (with a constant torque on an interval the rate is monotone between nodes).
Even so, the transcription is coarse during the slew: against DOP853 at 1e-11 the Sec. IV plan's
defects are 2.6e-2 in R_TC and 6 cm in p (`check_plan`); the closed loop corrects them.

Cost: E(x_N) of eq. 21 + sum_k c_k + rho sum s. The integral of the stage cost (eq. 20) over
interval k is integrated by the same RK4 steps as x (c_k is a decision variable tied to it by the
defect in the IPOPT/SNOPT program; the SQP evaluates it directly).

Constraints: x_0 = x0; eq. 16 gimbal polyhedron (linear); eq. 17 squared, |f_k|^2 <= f_max^2
(the SQP linearises it at each iteration); eq. 18 at every node softened, A_p p_k - s_k <= 0,
s_k >= 0, with the L1 penalty rho sum s_k; the rate box above.

Solvers (`CoupledNmpcSettings.solver`):
- "sqp": Gauss-Newton SQP with OSQP subproblems (rpod.planners.coupled_sqp), to convergence. The
  solver that converges on the paper's T = 480 s: from Sec. IV's cold start in ~30 iterations
  (~1.2 s), warm-started in the closed loop in 4-6 iterations.
- "rti": one SQP iteration per solve from the shifted previous solution (the first solve, with
  no previous solution, is run to convergence).
- "casadi_ipopt": the paper's solver stack (CasADi and IPOPT, Sec. IV) but not its
  transcription: IPOPT with the exact Hessian of the Lagrangian through CasADi
  (rpod.planners.coupled_casadi) on rpod's RK4 multiple shooting, where the paper uses
  collocation with two points per interval (after eq. 22). It converges on T = 480 s
  from Sec. IV's cold start (~90 iterations) and, warm-started with the shifted previous solution
  and multipliers, in ~12 iterations per closed-loop step (benchmarks/bench_coupled_nmpc.py).
- "ipopt" (the paper's solver) and "snopt" through Drake's MathematicalProgram. Drake hands
  IPOPT no second derivatives (limited-memory quasi-Newton) and SNOPT its own quasi-Newton
  Hessian. Measured (2 shared cores): neither converges on T = 480 s from Sec. IV's start, IPOPT
  not from a warm start one interval on either (200 iterations, 34 s), while started at the SQP's
  answer IPOPT (tolerance 1e-3) confirms it (same cost to 1e-7). IPOPT converges on short
  horizons only: from a start 20 m inside the LOS polyhedron at T = 80 s (~25 iterations) and
  160 s (~75), not at 240 s or beyond (none of 8 RK4 sub-steps, scaling, other rate boxes, a
  nominal-thrust guess, three shooting nodes per interval or SR1 updates helped).

A failed solve is a status (`NmpcStatus`) with the solver's own word, never an exception.
"""

import dataclasses
import enum
import math
import os
import re
import tempfile
import time

import numpy as np
from pydrake.autodiffutils import ExtractGradient, ExtractValue, InitializeAutoDiff
from pydrake.solvers import (
    IpoptSolver,
    MathematicalProgram,
    SnoptSolver,
    SolutionResult,
    SolverOptions,
)

from rpod.models import coupled_relative as cr
from rpod.models.config import ConfigError, bounded, check_bounds, count, positive
from rpod.models.gimbal import gimbal_constraint_matrix, gimbal_polyhedron
from rpod.planners import coupled_shooting as cs
from rpod.planners.coupled_casadi import CasadiTranscription
from rpod.planners.coupled_sqp import CoupledSqp, SqpSettings

NLP_STATE_SIZE = cr.PAPER_STATE_SIZE
"""Entries of the state that are decision variables (eq. 15): x[:21]."""
DEFECT_SIZE = NLP_STATE_SIZE + 1
"""Rows of one interval's defect: 21 state entries and the stage-cost quadrature."""


_STATE_SCALES = (
    (cr.W_TC_T_SLICE, 1e-2),  # rad/s
    (cr.P_PTPC_T_SLICE, 1e2),  # m
    (cr.XI_T_SLICE, 1e4),  # m s
)
"""Typical magnitudes of the NLP state's groups (R_TC entries and v_PtPc_T [m/s] are ~1)."""


class NmpcStatus(str, enum.Enum):
    """What came of one solve."""

    SOLVED = "solved"
    ACCEPTABLE = "acceptable"
    RTI_STEP = "rti_step"
    MAX_ITERATIONS = "max_iterations"
    INFEASIBLE = "infeasible"
    SOLVER_UNAVAILABLE = "solver_unavailable"
    FAILED = "failed"


USABLE_STATUSES = (NmpcStatus.SOLVED, NmpcStatus.ACCEPTABLE, NmpcStatus.RTI_STEP)
"""Statuses whose plan is flown. ACCEPTABLE: the SQP stopped at its iteration limit at a point
whose defects and force excess are within `SqpSettings.acceptable_defect` (IPOPT's notion of
"solved to an acceptable level"); logged as such, never as SOLVED."""

_STATUS = {
    SolutionResult.kSolutionFound: NmpcStatus.SOLVED,
    SolutionResult.kIterationLimit: NmpcStatus.MAX_ITERATIONS,
    SolutionResult.kInfeasibleConstraints: NmpcStatus.INFEASIBLE,
    SolutionResult.kInfeasibleOrUnbounded: NmpcStatus.INFEASIBLE,
}


_IPOPT_STATUS = {
    "Solve_Succeeded": NmpcStatus.SOLVED,
    "Solved_To_Acceptable_Level": NmpcStatus.ACCEPTABLE,
    "Maximum_Iterations_Exceeded": NmpcStatus.MAX_ITERATIONS,
    "Maximum_CpuTime_Exceeded": NmpcStatus.MAX_ITERATIONS,
    "Maximum_WallTime_Exceeded": NmpcStatus.MAX_ITERATIONS,
    "Infeasible_Problem_Detected": NmpcStatus.INFEASIBLE,
}
"""IPOPT's return status names (as CasADi reports them) -> NmpcStatus; others are FAILED."""

SOLVERS = ("ipopt", "snopt", "sqp", "rti", "casadi_ipopt")
FIXED_BANK_SOLVERS = ("sqp", "rti")
"""The solvers that plan a fixed bank's thrust per thruster (rpod.planners.coupled_sqp); the
others' transcriptions hold paper 001's gimbal pyramids and force vectors."""

MAX_RK4_STEPS = 1000
"""Most RK4 steps over the horizon (intervals x rk4_substeps; Sec. IV's: 16): the work of every
solver iteration grows with them (CoupledNmpcSettings)."""


@dataclasses.dataclass
class CoupledNmpcSettings:
    """The transcription and the solver (defaults: Sec. IV's N = 8, T = 480 s; IPOPT).

    Args:
        horizon_s: T of eq. 22 [s].
        intervals: N, the number of piecewise-constant input intervals.
        rk4_substeps: RK4 steps per interval in the defects (>= 2: module docstring).
        solver: "ipopt", "snopt", "sqp" (Gauss-Newton SQP to convergence), "rti" (one SQP
            iteration per solve from the warm start: rpod.planners.coupled_sqp) or
            "casadi_ipopt" (IPOPT with exact Hessians: rpod.planners.coupled_casadi).
        max_iterations: IPOPT's max_iter / SNOPT's major iterations limit / SQP iterations.
        tolerance: IPOPT's tol and constr_viol_tol ("casadi_ipopt": tol, with IPOPT's default
            constr_viol_tol of 1e-4) / SNOPT's major optimality and feasibility
            tolerances.
        los_slack_weight: rho of the L1 penalty on the LOS slacks (1 / m, per unit of cost).
        los_half_angle_rad: the LOS polyhedron's angle (eq. 18; Sec. IV: pi / 4).
        max_relative_rate_rad_s: a box on each entry of w_TC_T at the nodes 1..N (not in the
            paper; module docstring, "Trust of the integrator").
        sqp: The SQP's own settings (its max_iterations is replaced by `max_iterations`).
        compile_derivatives: "casadi_ipopt" only: compile the intervals' derivatives to C
            (rpod.planners.coupled_casadi.compile_functions; ~40-80 s once, then cached on disk).
            Off, or without a C compiler, CasADi's virtual machine evaluates them, ~5x slower.

    Bounds (rpod.models.config, checked by `validate()`): the horizon at most the scenario's
    MAX_DURATION_S; at most 200 intervals and 100 RK4 steps per interval, and at most
    MAX_RK4_STEPS over the horizon (every SQP iteration integrates and differentiates each of
    them: measured ~15 ms per RK4 step per iteration through Drake's AutoDiffXd on 2 shared
    cores, 1.9 s at 64 intervals of 2 steps, against 0.2 s at Sec. IV's 8); at most 10000 solver
    iterations; the tolerance in (0, 1]; the slack weight up to 1e9; the LOS half-angle in
    (0, pi/2) (a pyramid); the rate box up to a revolution a second.
    """

    horizon_s: float = positive(cr.HORIZON_S, 1e6)
    intervals: int = count(cr.HORIZON_INTERVALS, 1, 200)
    rk4_substeps: int = count(2, 2, 100)
    solver: str = "ipopt"
    max_iterations: int = count(300, 1, 10_000)
    tolerance: float = positive(1e-6, 1.0)
    los_slack_weight: float = positive(cr.LOS_SLACK_WEIGHT, 1e9)
    los_half_angle_rad: float = bounded(
        cr.LOS_HALF_ANGLE_RAD, 0.0, math.pi / 2, low_open=True, high_open=True
    )
    max_relative_rate_rad_s: float = positive(0.02, 2.0 * math.pi)
    sqp: SqpSettings = dataclasses.field(default_factory=SqpSettings)
    compile_derivatives: bool = True

    def validate(self) -> None:
        """Raises ConfigError naming the first bad field: its declared bounds (check_bounds,
        `sqp.<field>` included), then the checks that need more than one field."""
        check_bounds(self)
        for name in ("intervals", "rk4_substeps", "max_iterations"):
            value = getattr(self, name)
            if int(value) != value:
                raise ConfigError(name, f"must be a positive integer, got {value!r}")
        if self.solver not in SOLVERS:
            raise ConfigError("solver", f"must be one of {SOLVERS}, got {self.solver!r}")
        steps = self.intervals * self.rk4_substeps
        if steps > MAX_RK4_STEPS:
            raise ConfigError(
                "rk4_substeps",
                f"intervals x rk4_substeps = {steps} RK4 steps over the horizon, must be at most "
                f"{MAX_RK4_STEPS}",
            )


@dataclasses.dataclass
class NmpcResult:
    """One solve of (22).

    Attributes:
        status: What came of it (NmpcStatus).
        solver_message: The solver's own word (IPOPT's status name, SNOPT's info code).
        u: The inputs (N, m), u[k] = the eight thrust vectors in C on interval k [N] (m = 24),
            or on a fixed bank each thruster's thrust (m = n, rpod.models.coupled_relative).
        x: The states at the nodes (N + 1, 39): x[:, :21] the NLP's, x[:, 21:] the target's
            reference (module docstring).
        slack: The LOS slacks at the nodes (N + 1, 4) [m].
        stage_costs: c_k, the stage cost integrated over each interval (N,).
        cost: The objective: E(x_N) + sum c_k + rho sum s.
        interval_s: T_s [s].
        solve_time_s: Wall time of the solver call [s].
        iterations: The solver's iteration count (IPOPT iterations, SNOPT major iterations),
            None when it could not be read.
        solver: The settings' solver.
    """

    status: NmpcStatus
    solver_message: str
    u: np.ndarray
    x: np.ndarray
    slack: np.ndarray
    stage_costs: np.ndarray
    cost: float
    interval_s: float
    solve_time_s: float
    iterations: int | None
    solver: str

    @property
    def solved(self) -> bool:
        return self.status is NmpcStatus.SOLVED

    @property
    def usable(self) -> bool:
        """Whether the plan's first input may be flown (a controller falls back otherwise)."""
        return self.status in USABLE_STATUSES and bool(np.all(np.isfinite(self.u)))

    @property
    def times_s(self) -> np.ndarray:
        """Node times from the solve's start (N + 1,) [s]."""
        return self.interval_s * np.arange(self.x.shape[0])


def rk4_interval(x, u, interval_s: float, substeps: int, params, weights):
    """(x(t_k + T_s), integral of F over the interval) by `substeps` classical RK4 steps.

    Args:
        x: State (39,) at the interval's start; float or object (AutoDiffXd) array.
        u: Input (24,), held constant.
        interval_s: T_s [s].
        substeps: RK4 steps.
        params, weights: The model's data and eq. 20's weights.
    """
    dt = interval_s / substeps
    q = 0.0
    for _ in range(substeps):
        k1 = cr.dynamics(x, u, params)
        l1 = cr.stage_cost(x, u, weights, params)
        x2 = x + (0.5 * dt) * k1
        k2 = cr.dynamics(x2, u, params)
        l2 = cr.stage_cost(x2, u, weights, params)
        x3 = x + (0.5 * dt) * k2
        k3 = cr.dynamics(x3, u, params)
        l3 = cr.stage_cost(x3, u, weights, params)
        x4 = x + dt * k3
        k4 = cr.dynamics(x4, u, params)
        l4 = cr.stage_cost(x4, u, weights, params)
        x = x + (dt / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
        q = q + (dt / 6.0) * (l1 + 2.0 * l2 + 2.0 * l3 + l4)
    x = np.array(x, copy=True)  # both rotations back onto SO(3) (coupled_shooting's docstring)
    for sl in (cr.R_TC_SLICE, cr.R_IT_SLICE):
        x[sl] = cs.polar_newton_schulz(x[sl].reshape(3, 3)).reshape(9)
    return x, q


def interval_defect(z, x_target, interval_s: float, substeps: int, params, weights):
    """The defect of one interval (DEFECT_SIZE,), zero when z is consistent.

    Args:
        z: [x_k[:21], u_k (24), x_k+1[:21], c_k] (67,), float or AutoDiffXd.
        x_target: The reference target state x_k[21:] (18,) at the interval's start (floats).

    Returns:
        [x_k+1[:21] - Phi(x_k, u_k)[:21], c_k - integral of F] (22,).
    """
    n = NLP_STATE_SIZE
    z = np.asarray(z)
    x_k = np.concatenate([z[:n], np.asarray(x_target, dtype=z.dtype)])
    u_k = z[n : n + cr.INPUT_SIZE]
    x_next = z[n + cr.INPUT_SIZE : 2 * n + cr.INPUT_SIZE]
    c_k = z[2 * n + cr.INPUT_SIZE]
    x_end, q = rk4_interval(x_k, u_k, interval_s, substeps, params, weights)
    return np.concatenate([x_next - x_end[:n], [c_k - q]])


class CoupledNmpc:
    """The NLP of eq. 22 (module docstring), built once, solved from any x0."""

    def __init__(
        self,
        params: cr.CoupledRelativeParams | None = None,
        weights: cr.CoupledNmpcWeights | None = None,
        settings: CoupledNmpcSettings | None = None,
    ):
        self.params = params if params is not None else cr.CoupledRelativeParams()
        self.weights = weights if weights is not None else cr.CoupledNmpcWeights()
        self.settings = settings if settings is not None else CoupledNmpcSettings()
        self.settings.validate()
        s = self.settings
        if not self.params.layout.gimbaled and s.solver not in FIXED_BANK_SOLVERS:
            raise ValueError(
                f"solver: a fixed thruster bank is planned by {FIXED_BANK_SOLVERS} only "
                f"(the gimbal rows of the others are paper 001's), got {s.solver!r}"
            )
        self.N = int(s.intervals)
        self.interval_s = s.horizon_s / self.N
        self.A_p = cr.los_polyhedron(self.params.p_TPt_T, s.los_half_angle_rad)
        self._target_nodes = np.zeros((self.N + 1, cr.STATE_SIZE - NLP_STATE_SIZE))
        self._casadi: CasadiTranscription | None = None
        self._multipliers = None  # casadi_ipopt: the last solve's (lam_x, lam_g)
        self.derivatives_message = ""
        """casadi_ipopt: how the derivatives are evaluated (compiled library or CasADi's VM)."""
        problem = cs.ShootingProblem(
            self.params,
            self.weights,
            self.N,
            self.interval_s,
            s.rk4_substeps,
            self.A_p,
            s.los_slack_weight,
            s.max_relative_rate_rad_s,
        )
        if s.solver == "casadi_ipopt":
            self.prog, self._sqp = None, None
            ipopt_options = {"max_iter": int(s.max_iterations), "tol": float(s.tolerance)}
            self._casadi = CasadiTranscription(problem, ipopt_options, s.compile_derivatives)
            self.derivatives_message = self._casadi.derivatives_message
        elif s.solver in ("sqp", "rti"):
            self.prog = None
            self._sqp: CoupledSqp | None = CoupledSqp(
                problem, dataclasses.replace(s.sqp, max_iterations=int(s.max_iterations))
            )
        else:
            self._sqp = None
            self._build()

    # ---------------------------------------------------------------------------- program

    def _build(self) -> None:
        N, n, m = self.N, NLP_STATE_SIZE, cr.INPUT_SIZE
        prog = MathematicalProgram()
        self.X = prog.NewContinuousVariables(N + 1, n, "x")
        self.U = prog.NewContinuousVariables(N, m, "u")
        self.C = prog.NewContinuousVariables(N, "c")
        self.S = prog.NewContinuousVariables(N + 1, self.A_p.shape[0], "s")

        # Variable scaling (SNOPT reads it; Drake's IPOPT does not support it and would warn).
        if self.settings.solver == "snopt":
            self._set_scaling(prog)

        # x_0 = x0 (eq. 22), bounds updated at each solve.
        self._initial = prog.AddBoundingBoxConstraint(np.zeros(n), np.zeros(n), self.X[0])

        # The integrator's trust region (module docstring): |w_TC_T| entries at nodes 1..N.
        w_max = self.settings.max_relative_rate_rad_s
        prog.AddBoundingBoxConstraint(-w_max, w_max, self.X[1:, cr.W_TC_T_SLICE].reshape(-1))

        # Defects (eq. 15 integrated over each interval), exact derivatives by AutoDiffXd.
        zeros = np.zeros(DEFECT_SIZE)
        for k in range(N):
            z = np.concatenate([self.X[k], self.U[k], self.X[k + 1], [self.C[k]]])
            prog.AddConstraint(self._defect_function(k), zeros, zeros, z, f"defect_{k}")

        # Eq. 16 on every thruster and interval: one sparse linear constraint.
        A_g, b_g = gimbal_constraint_matrix(self.params.layout)
        A_all = np.kron(np.eye(N), A_g)
        prog.AddLinearConstraint(
            A_all, np.full(A_all.shape[0], -np.inf), np.tile(b_g, N), self.U.reshape(-1)
        )
        # Eq. 17, squared (module docstring of coupled_relative, choice 4).
        f_max = self.params.layout.max_thrusts_N
        for k in range(N):
            for j in range(cr.THRUSTER_COUNT):
                prog.AddQuadraticConstraint(
                    2.0 * np.eye(3),
                    np.zeros(3),
                    -np.inf,
                    f_max[j] ** 2,
                    self.U[k, 3 * j : 3 * j + 3],
                )
        # Eq. 18 at every node, softened: A_p p_k - s_k <= 0, s_k >= 0.
        n_p = self.A_p.shape[0]
        A_los = np.hstack([self.A_p, -np.eye(n_p)])
        for k in range(N + 1):
            prog.AddLinearConstraint(
                A_los,
                np.full(n_p, -np.inf),
                np.zeros(n_p),
                np.concatenate([self.X[k, cr.P_PTPC_T_SLICE], self.S[k]]),
            )
        prog.AddBoundingBoxConstraint(0.0, np.inf, self.S.reshape(-1))

        # Cost: E(x_N) (eq. 21) + sum c_k (eq. 20 integrated) + rho sum s.
        pv = np.concatenate([self.X[N, cr.P_PTPC_T_SLICE], self.X[N, cr.V_PTPC_T_SLICE]])
        prog.AddQuadraticCost(2.0 * np.asarray(self.weights.P), np.zeros(6), pv, is_convex=True)
        prog.AddLinearCost(np.ones(N), 0.0, self.C)
        prog.AddLinearCost(
            np.full(self.S.size, self.settings.los_slack_weight), 0.0, self.S.reshape(-1)
        )
        self.prog = prog

    def _set_scaling(self, prog: MathematicalProgram) -> None:
        """Typical magnitudes on the Sec. IV approach (_STATE_SCALES; u, s ~10, c ~1e4)."""
        for sl, scale in _STATE_SCALES:
            for var in self.X[:, sl].reshape(-1):
                prog.SetVariableScaling(var, scale)
        for var in np.concatenate([self.U.reshape(-1), self.S.reshape(-1)]):
            prog.SetVariableScaling(var, 10.0)
        for var in self.C:
            prog.SetVariableScaling(var, 1e4)

    def _defect_function(self, k: int):
        """Interval k's defect for the NLP: values and exact Jacobians from the vectorised
        complex-step transcription (rpod.planners.coupled_shooting), the same numbers as
        `interval_defect` (tested) at ~1 ms instead of ~12 ms per AutoDiffXd call."""

        def defect(z):
            z = np.asarray(z)
            if z.dtype != object:
                return self._defect_and_jacobian(k, z, derivatives=False)[0]
            value, J = self._defect_and_jacobian(k, ExtractValue(z).reshape(-1))
            return InitializeAutoDiff(value, J @ ExtractGradient(z)).reshape(-1)

        return defect

    def _defect_and_jacobian(self, k: int, z: np.ndarray, derivatives: bool = True):
        n, m = NLP_STATE_SIZE, cr.INPUT_SIZE
        x_k, u_k = z[None, :n], z[None, n : n + m]
        x_next, c_k = z[n + m : 2 * n + m], z[2 * n + m]
        shooting = cs.shoot(
            x_k,
            u_k,
            self._target_nodes[k : k + 1],
            self.interval_s,
            self.settings.rk4_substeps,
            self.params,
            self.weights,
            derivatives,
        )
        value = np.concatenate([x_next - shooting.x_end[0], [c_k - shooting.q[0]]])
        if not derivatives:
            return value, None
        J = np.zeros((DEFECT_SIZE, z.size))
        J[:n, :n] = -shooting.A[0]
        J[:n, n : n + m] = -shooting.B[0]
        J[:n, n + m : 2 * n + m] = np.eye(n)
        J[n, : n + m] = -cs.cost_gradient(shooting, u_k, self.weights, self.params)[0]
        J[n, 2 * n + m] = 1.0
        return value, J

    # ---------------------------------------------------------------------------- data

    def _propagate_target(self, x0: np.ndarray) -> None:
        """The target's reference nodes: RK4 from x0, R_IT projected onto SO(3) at each node."""
        self._target_nodes[:] = cs.target_reference(
            x0, self.N, self.interval_s, self.settings.rk4_substeps, self.params
        )

    def rollout(self, x0: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Nodes (N + 1, 39) and stage costs (N,) of the RK4 transcription from x0 under u
        (the target part from the reference of the last `solve` or `rollout`)."""
        self._propagate_target(x0)
        x = np.empty((self.N + 1, cr.STATE_SIZE))
        c = np.empty(self.N)
        x[0] = x0
        x[:, NLP_STATE_SIZE:] = self._target_nodes
        for k in range(self.N):
            shooting = cs.shoot(
                x[k : k + 1, :NLP_STATE_SIZE],
                np.asarray(u[k : k + 1], dtype=float),
                self._target_nodes[k : k + 1],
                self.interval_s,
                self.settings.rk4_substeps,
                self.params,
                self.weights,
                derivatives=False,
            )
            x[k + 1, :NLP_STATE_SIZE] = shooting.x_end[0]
            c[k] = shooting.q[0]
        return x, c

    def _slack_guess(self, x: np.ndarray) -> np.ndarray:
        g = x[:, cr.P_PTPC_T_SLICE] @ self.A_p.T
        return np.maximum(g, 0.0) + 1e-3

    # ---------------------------------------------------------------------------- solve

    def _solver(self):
        if self.settings.solver == "snopt":
            return SnoptSolver()
        return IpoptSolver()

    def _options(self, solver, log_path: str) -> SolverOptions:
        s = self.settings
        options = SolverOptions()
        if self.settings.solver == "snopt":
            options.SetOption(solver.id(), "Major iterations limit", int(s.max_iterations))
            options.SetOption(solver.id(), "Major optimality tolerance", float(s.tolerance))
            options.SetOption(solver.id(), "Major feasibility tolerance", float(s.tolerance))
            options.SetOption(solver.id(), "Iterations limit", 1000000)
            options.SetOption(solver.id(), "Print file", log_path)
        else:
            options.SetOption(solver.id(), "max_iter", int(s.max_iterations))
            options.SetOption(solver.id(), "tol", float(s.tolerance))
            options.SetOption(solver.id(), "constr_viol_tol", float(s.tolerance))
            options.SetOption(solver.id(), "print_level", 0)
            options.SetOption(solver.id(), "file_print_level", 3)
            options.SetOption(solver.id(), "output_file", log_path)
        return options

    def _iterations(self, log_path: str) -> int | None:
        try:
            with open(log_path) as log:
                text = log.read()
        except OSError:
            return None
        pattern = (
            r"No\. of major iterations\s+(\d+)"
            if self.settings.solver == "snopt"
            else r"Number of Iterations\.*:\s*(\d+)"
        )
        found = re.findall(pattern, text)
        return int(found[-1]) if found else None

    def solve(self, x0: np.ndarray, warm_start: NmpcResult | None = None) -> NmpcResult:
        """Solves (22) from x0 (39,); warm_start: a guess (e.g. `shifted_warm_start`).

        Without a guess the solver starts from the zero-thrust rollout (every defect zero).
        """
        x0 = np.asarray(x0, dtype=float)
        if x0.shape != (cr.STATE_SIZE,) or not np.all(np.isfinite(x0)):
            raise ValueError(f"x0 must be {cr.STATE_SIZE} finite numbers, got shape {x0.shape}")
        N = self.N
        if warm_start is None:
            u_guess = np.zeros((N, self.params.input_size))
            x_guess, c_guess = self.rollout(x0, u_guess)
        elif self.settings.solver == "rti":
            # RTI linearises about the shifted previous solution with R_TC projected back onto
            # SO(3) at every node: the previous QP's full step (no line search checked it)
            # leaves R_TC off SO(3) by its linearisation error, which compounds step to step.
            self._propagate_target(x0)
            u_guess = np.asarray(warm_start.u, dtype=float)
            x_guess = np.asarray(warm_start.x, dtype=float).copy()
            x_guess[0] = x0
            R = cs.project_to_so3_batch(x_guess[1:, cr.R_TC_SLICE].reshape(-1, 3, 3))
            x_guess[1:, cr.R_TC_SLICE] = R.reshape(-1, 9)
            c_guess = np.asarray(warm_start.stage_costs, dtype=float)
        else:
            self._propagate_target(x0)
            u_guess = np.asarray(warm_start.u, dtype=float)
            x_guess = np.asarray(warm_start.x, dtype=float).copy()
            x_guess[0] = x0
            c_guess = np.asarray(warm_start.stage_costs, dtype=float)
        x0_nlp = x0[:NLP_STATE_SIZE]
        if self._sqp is not None:
            return self._solve_sqp(x0, x_guess, u_guess, cold=warm_start is None)
        if self._casadi is not None:
            return self._solve_casadi(x0, x_guess, u_guess, warm=warm_start is not None)
        self._initial.evaluator().UpdateLowerBound(x0_nlp)
        self._initial.evaluator().UpdateUpperBound(x0_nlp)

        guess = np.zeros(self.prog.num_vars())
        for variables, values in (
            (self.X, x_guess[:, :NLP_STATE_SIZE]),
            (self.U, u_guess),
            (self.C, c_guess),
            (self.S, self._slack_guess(x_guess)),
        ):
            guess[self.prog.FindDecisionVariableIndices(variables.reshape(-1))] = values.reshape(-1)

        solver = self._solver()
        if not solver.available() or not solver.enabled():
            return self._result(
                NmpcStatus.SOLVER_UNAVAILABLE,
                f"{self.settings.solver} unavailable",
                None,
                0.0,
                None,
                x0,
            )
        with tempfile.TemporaryDirectory() as folder:
            log_path = os.path.join(folder, "solver.log")
            options = self._options(solver, log_path)
            start = time.perf_counter()
            result = solver.Solve(self.prog, guess, options)
            elapsed = time.perf_counter() - start
            iterations = self._iterations(log_path)
        status = _STATUS.get(result.get_solution_result(), NmpcStatus.FAILED)
        details = result.get_solver_details()
        if self.settings.solver == "snopt":
            message = f"SNOPT info {details.info}"
        else:
            message = details.ConvertStatusToString()
        return self._result(status, message, result, elapsed, iterations, x0)

    def _solve_casadi(self, x0, x_guess, u_guess, warm: bool) -> NmpcResult:
        """IPOPT with exact Hessians through CasADi (rpod.planners.coupled_casadi); a warm
        start also carries the previous solve's multipliers, shifted one interval."""
        tr = self._casadi
        guess = tr.pack(x_guess, u_guess, self._slack_guess(x_guess))
        multipliers = (
            tr.shift_multipliers(*self._multipliers) if warm and self._multipliers else None
        )
        out = tr.solve(x0[:NLP_STATE_SIZE], self._target_nodes, guess, multipliers)
        status = _IPOPT_STATUS.get(out["status"], NmpcStatus.FAILED)
        # Only a usable answer's multipliers seed the next solve (a failed one's may be NaN);
        # without them the next solve starts IPOPT cold from the shifted primal guess.
        usable = status in USABLE_STATUSES and out["lam_x"] is not None
        usable = usable and bool(
            np.all(np.isfinite(out["lam_x"])) and np.all(np.isfinite(out["lam_g"]))
        )
        self._multipliers = (out["lam_x"], out["lam_g"]) if usable else None
        x_nlp, u, slack = tr.unpack(out["w"])
        x = np.hstack([x_nlp, self._target_nodes])
        return NmpcResult(
            status=status,
            solver_message=out["status"],
            u=u,
            x=x,
            slack=slack,
            stage_costs=tr.stage_costs(x_nlp, u, self._target_nodes),
            cost=out["cost"],
            interval_s=self.interval_s,
            solve_time_s=out["solve_time_s"],
            iterations=out["iterations"],
            solver=self.settings.solver,
        )

    def _solve_sqp(self, x0, x_guess, u_guess, cold: bool) -> NmpcResult:
        """SQP to convergence, or one RTI step (rpod.planners.coupled_sqp)."""
        # RTI's first problem (no previous solution to step from) is solved to convergence.
        real_time = self.settings.solver == "rti" and not cold
        start = time.perf_counter()
        out = self._sqp.run(
            x0[:NLP_STATE_SIZE],
            x_guess[:, :NLP_STATE_SIZE],
            u_guess,
            self._slack_guess(x_guess),
            self._target_nodes,
            real_time=real_time,
            cold=cold,
        )
        elapsed = time.perf_counter() - start
        if real_time and not out.qp_failed:
            status = NmpcStatus.RTI_STEP
        elif out.converged:
            status = NmpcStatus.SOLVED
        elif out.acceptable:
            status = NmpcStatus.ACCEPTABLE
        elif out.qp_failed:
            status = NmpcStatus.FAILED
        else:
            status = NmpcStatus.MAX_ITERATIONS
        pv = out.x[self.N, 12:18]
        cost = float(
            np.sum(out.q)
            + pv @ np.asarray(self.weights.P) @ pv
            + self.settings.los_slack_weight * np.sum(out.s)
        )
        return NmpcResult(
            status=status,
            solver_message=out.message,
            u=out.u,
            x=np.hstack([out.x, self._target_nodes]),
            slack=out.s,
            stage_costs=out.q,
            cost=cost,
            interval_s=self.interval_s,
            solve_time_s=elapsed,
            iterations=out.iterations,
            solver=self.settings.solver,
        )

    def _result(self, status, message, result, elapsed, iterations, x0) -> NmpcResult:
        N = self.N
        if result is None:
            u = np.full((N, self.params.input_size), np.nan)
            x_nlp = np.full((N + 1, NLP_STATE_SIZE), np.nan)
            slack = np.full((N + 1, self.A_p.shape[0]), np.nan)
            c = np.full(N, np.nan)
            cost = math.nan
        else:
            u = result.GetSolution(self.U)
            x_nlp = result.GetSolution(self.X)
            slack = result.GetSolution(self.S)
            c = result.GetSolution(self.C)
            cost = float(result.get_optimal_cost())
        x = np.hstack([x_nlp, self._target_nodes])
        return NmpcResult(
            status=status,
            solver_message=message,
            u=u,
            x=x,
            slack=slack,
            stage_costs=c,
            cost=cost,
            interval_s=self.interval_s,
            solve_time_s=elapsed,
            iterations=iterations,
            solver=self.settings.solver,
        )

    def shifted_warm_start(self, result: NmpcResult) -> NmpcResult:
        """The previous solution shifted one interval: u_k <- u_k+1, x_k <- x_k+1, the last input
        repeated and the last node carried on by the RK4 transcription under it."""
        u = np.vstack([result.u[1:], result.u[-1:]])
        x = np.vstack([result.x[1:], result.x[-1:]])
        c = np.concatenate([result.stage_costs[1:], [0.0]])
        x_end, c[-1] = rk4_interval(
            result.x[-1],
            result.u[-1],
            self.interval_s,
            self.settings.rk4_substeps,
            self.params,
            self.weights,
        )
        x[-1] = x_end
        return dataclasses.replace(result, u=u, x=x, stage_costs=c, slack=self._slack_guess(x))


# -------------------------------------------------------------------------------- checker


def _integrate(params, x0, u, duration_s, rtol, atol):
    from scipy.integrate import solve_ivp  # at use: every rpod process starts ~0.25 s sooner

    sol = solve_ivp(
        lambda _, x: cr.dynamics(x, u, params),
        (0.0, duration_s),
        x0,
        method="DOP853",
        rtol=rtol,
        atol=atol,
    )
    return sol.y[:, -1]


_GROUPS = {
    "R_TC": cr.R_TC_SLICE,
    "w_TC_T_rad_s": cr.W_TC_T_SLICE,
    "p_PtPc_T_m": cr.P_PTPC_T_SLICE,
    "v_PtPc_T_m_s": cr.V_PTPC_T_SLICE,
    "xi_T_m_s": cr.XI_T_SLICE,
}


def check_plan(
    result: NmpcResult, params: cr.CoupledRelativeParams, rtol: float = 1e-11, atol: float = 1e-11
) -> dict:
    """Re-evaluates a plan through code paths separate from the NLP.

    The inputs are re-integrated on `coupled_relative.dynamics` in floats by scipy's DOP853
    (rtol, atol), not RK4, (i) from each node over its interval (the multiple-shooting defects)
    and (ii) from x_0 through all intervals in one chain (the trajectory the inputs fly). The
    constraints are evaluated from their definitions: the gimbal pyramid per thruster from
    `rpod.models.gimbal.gimbal_polyhedron` (not the NLP's block matrix), the magnitude by
    np.linalg.norm (not squared), the LOS rows with the plan's slacks. On a fixed bank the
    force set of a thruster is the segment [0, f_max] d_k: gimbal_excess_N is then -u_k (a
    thrust below zero), magnitude_excess_N u_k - f_max.

    Returns a dict of worst values (excesses <= 0 mean satisfied):
        defect_<group>: max |DOP853 from node k - node k+1| over k, per state group.
        rollout_<group>: max |chained DOP853 - node k| over the nodes, per state group.
        rollout_target_p_m: the same for the target's orbit position (the reference).
        gimbal_excess_N: max over thrusters and intervals of A_k f_k - b_k.
        magnitude_excess_N: max |f_k| - f_max.
        los_excess_m: max A_p p_k - s_k; min_slack_m: min s_k; los_raw_excess_m: max A_p p_k.
        so3_error: max |R_TC^T R_TC - I| (entries) over the nodes.
    """
    x, u, N = result.x, result.u, result.u.shape[0]
    h = result.interval_s
    report = {}
    defects = np.zeros((N, cr.STATE_SIZE))
    chain = np.empty((N + 1, cr.STATE_SIZE))
    chain[0] = x[0]
    for k in range(N):
        defects[k] = _integrate(params, x[k], u[k], h, rtol, atol) - x[k + 1]
        chain[k + 1] = _integrate(params, chain[k], u[k], h, rtol, atol)
    for name, sl in _GROUPS.items():
        report[f"defect_{name}"] = float(np.max(np.abs(defects[:, sl])))
        report[f"rollout_{name}"] = float(np.max(np.abs(chain[:, sl] - x[:, sl])))
    report["rollout_target_p_m"] = float(
        np.max(np.abs(chain[:, cr.P_IT_I_SLICE] - x[:, cr.P_IT_I_SLICE]))
    )

    gimbal, magnitude = [], []
    for k in range(N):
        if not params.layout.gimbaled:
            gimbal.extend(-u[k])
            magnitude.extend(u[k] - params.layout.max_thrusts_N)
            continue
        forces = u[k].reshape(params.layout.count, 3)
        for thruster, f in zip(params.layout.thrusters, forces):
            A, b = gimbal_polyhedron(thruster)
            gimbal.append(np.max(A @ f - b))
            magnitude.append(np.linalg.norm(f) - thruster.max_thrust_N)
    report["gimbal_excess_N"] = float(np.max(gimbal))
    report["magnitude_excess_N"] = float(np.max(magnitude))

    A_p = cr.los_polyhedron(params.p_TPt_T)
    g = x[:, cr.P_PTPC_T_SLICE] @ A_p.T
    report["los_excess_m"] = float(np.max(g - result.slack))
    report["min_slack_m"] = float(np.min(result.slack))
    report["los_raw_excess_m"] = float(np.max(g))
    R = x[:, cr.R_TC_SLICE].reshape(-1, 3, 3)
    report["so3_error"] = float(np.max(np.abs(np.einsum("kji,kjl->kil", R, R) - np.eye(3))))
    return report
