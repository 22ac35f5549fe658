"""The soft-capture second-order cone programs of paper 000: Problem 2 and the Problem 3 step.

Owns: one ``MathematicalProgram`` per horizon length N holding the convex soft-capture problem
(CW dynamics with the exact zero-order hold, thrust, speed, range lift, the field-of-view
relaxation, the docking cone, the terminal capture conditions, the L1 fuel cost and, for
Problem 3, the linearised collision rows with their penalised slacks), the per-solve data
updates, and the solve (Drake's ``ClarabelSolver``, or ECOS or QOCO on the program's standard
form, ``rpod.planners.conic_form``). Does not own: the SCP iteration, the horizon search or the
config (``rpod.planners.soft_capture``), the pointing law
(``rpod.planners.pointing``), the collision metric (``rpod.models.collision``).

Decision variables (N knots, k = 0..N-1, t_k = k dt): ``x_k = [p_LC_L, v_LC_L]`` (chaser centre
of mass relative to the target, in LVLH), ``u_k`` (k < N-1, thrust force in L [N], held over
[t_k, t_k+1)), ``w_k >= |u_k|`` elementwise (the L1 epigraph), ``rho_k`` (range lift) and, in
Problem 3, ``s_k >= 0`` (collision slack, k >= 1) and ``sigma_k >= 0`` (field-of-view slack,
one per step).

Field-of-view relaxation (replaces paper eqs. 20-24). Constraint (12) asks the angle between
successive lines of sight to be at most phi = omega_max dt (0 < phi <= pi/2). With the lift
(16), ``|r_k| <= rho_k``, we impose the second-order cone

    || r_k+1 - r_k || <= sin(phi / 2) (rho_k + rho_k+1).                       (FOV)

Why it is right: for |r_k| = |r_k+1| = rho and an angle theta between them, the chord is
``|r_k+1 - r_k| = 2 rho sin(theta / 2)``, so with a tight lift (rho_k = |r_k|) (FOV) holds iff
theta <= phi -- exact on the circle. Off it, with ``rho_k+1 = lambda rho_k``, squaring gives
``cos theta >= cos(phi) (1 + lambda)^2 / (4 lambda) + (1 - lambda)^2 / (4 lambda) >= cos(phi)``,
so a tight (FOV) always implies (12) (it is conservative, the more so the faster the range
changes: at most ~2 tan(phi/2) = 20 % range change per step for phi = 0.2). Where the optimiser
leaves rho_k above |r_k| the constraint loosens; the cost sum(rho_k) pushes the lift down (the
paper's argument), and ``plan_check`` measures the true angle on every plan.
What was wrong in the paper: multiplying (12) by -1 gives ``-r_k^T r_k+1 <= -rho_k rho_k+1 cos
phi``; adding (18), (19) gives ``z^T H z <= y^T S y`` with ``H = [[I, -I/2], [-I/2, I]]`` (the
paper prints +I/2: with it and rho <= r_max = 100 m, 3 |r|^2 <= (2 r_max sin(phi/2))^2 forces
|r| < 11.5 m) and ``S = [[1, -cos(phi)/2], [-cos(phi)/2, 1]]``, whose smallest eigenvalue is
``1 - cos(phi)/2`` (not ``1 - cos phi``). Following the paper's remaining steps with these,
``||sqrt(H) z|| <= sqrt((2 - cos phi) / 4) (rho_k + rho_k+1)`` (the authors' public code);
since ``z^T H z = |r_k+1 - r_k|^2 / 2 + (|r_k|^2 + |r_k+1|^2) / 2``, that is (FOV) with an extra
penalty ``(rho_k - rho_k+1)^2 / 2`` on range change -- equally exact on the circle but more
conservative off it. (FOV) is the simpler and less restrictive of the two.

Problem 3 does not keep the lift in the field of view. The lift is only as tight as the cost
makes it, and Problem 3's cost (fuel weighted by gamma = 5, sum(rho) by 1) makes it cheap to
inflate rho_k to buy a larger turn: with the lift in Problem 3, 5 of 100 Sec. VI-B-like samples
returned plans with true line-of-sight steps of up to 0.25 rad against phi = 0.2. Problem 3 has
an iterate r^i, and ``|r| >= g^T r`` for the unit ``g = r^i / |r^i|``, so it imposes

    || r_k+1 - r_k || <= sin(phi / 2) (g_k^T r_k + g_k+1^T r_k+1),             (FOV-i)

a restriction of the tight (FOV) (hence every solution satisfies (12), no lift needed), exact
to first order at the iterate (``g^T r = |r| cos(beta)`` for r turned by beta from the
iterate). Like the collision rows, (FOV-i) carries a slack ``sigma_k >= 0`` [m] on its right
side with the exact penalty psi, so every Problem 3 is feasible even when the Problem 2 iterate
broke (12) through a loose lift; the SCP's hard test checks the true angle. The lift stays in
(16) and in the cost, as in the paper.

Docking cone (eq. 11, measured in the target body frame). For the last ``N_dock`` knots, with
``X_k = r_k - R_LT,k D_t`` (chaser centre of mass relative to the target capture point), axis
``c_t = D_t / |D_t|`` and ``P`` the 2x3 projection onto the plane normal to c_t (for D_t along
z, ``P = [e_x, e_y]^T``, i.e. ``diag(1, 1, 0)``): ``|| P R_k^T X_k || <= tan(theta_dock) c_t^T
R_k^T X_k``, a cone of half-angle theta_dock (paper eq. 11 and the authors' code put
``tan(pi/2 - theta_dock)`` on the left, the same thing; they project in L instead of T, which
mixes frames).

Terminal conditions (13, 14). The capture pose turns the chaser by pi about the target's y axis
from the target's attitude (paper: ``Q(q(r_N)) = Q_t Q_y(-180 deg)``), so the chaser capture
point ``p_LC + R_LC D_c`` meets the target capture point ``R_LT D_t`` when the chaser centre of
mass is at ``p* = R_LT (D_t - R_y(pi) D_c)`` (= ``R_LT (D_t + D_c)`` for the Table I vectors):
``|r_N-1 - p*| <= eps_p`` (13). Velocity (14) constrains the chaser centre of mass,
``|v_N-1 - v*| <= eps_v``, with ``v*`` chosen by the caller (``soft_capture.py``): the default
makes the chaser capture point move with the target capture point, ``R_LT (w_LT_T x D_t)``.

Units (the config's ``socp_scaled``, on by default). The program's variables are the physical ones divided by
fixed units: positions, the lift and the field-of-view slack by ``POSITION_UNIT_M``, velocities
by v_max, forces (u, w) by U_max; the cost is divided by its largest coefficient. In SI the
dynamics rows mix 1 with (B_d / m) ~ 3e-4 and the cost weighs metres against newtons, and
Clarabel needs 24-35 iterations at N = 100; in these units 17-22, for the same optimum
(benchmarks/bench_soft_capture_solvers.py compares both in one run). Every number the class takes or
returns (``set_data``, ``set_linearisation``, ``SocpSolution``) is in SI; only the program
inside is scaled.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from pydrake.solvers import ClarabelSolver, MathematicalProgram, SolverOptions

from rpod.models.cw import cw_state_transition, cw_zoh_input
from rpod.planners.conic_form import ConicForm, solve_conic

_SOLVER_NAMES = {"clarabel": "Clarabel", "ecos": "ECOS", "qoco": "QOCO"}
# A standard-form solve's status as Drake's SolutionResult names it (soft_capture_scp reads it).
_CONIC_RESULTS = {
    "solved": "kSolutionFound",
    "infeasible": "kInfeasibleConstraints",
    "iteration_limit": "kIterationLimit",
    "failed": "kSolverSpecificError",
}
POSITION_UNIT_M = 10.0  # the program's unit of position, lift and field-of-view slack (docstring)


@dataclass(frozen=True)
class SocpData:
    """Everything Problem 2 / 3 needs that is not fixed by (config, N).

    Attributes:
        x0: Initial state (6,) ``[p_LC_L, v_LC_L]`` [m, m/s].
        R_LT_dock: Target attitudes (N_dock, 3, 3) at the docking-cone knots (the last ones).
        p_terminal_L: Terminal chaser centre-of-mass position ``p*`` (3,) in L [m].
        v_terminal_L: Terminal chaser centre-of-mass velocity ``v*`` (3,) in L [m/s].
    """

    x0: np.ndarray
    R_LT_dock: np.ndarray
    p_terminal_L: np.ndarray
    v_terminal_L: np.ndarray


@dataclass(frozen=True)
class SocpSolution:
    """One solve of the program.

    Attributes:
        success: ``MathematicalProgramResult.is_success()``.
        solution_result: Drake's ``SolutionResult`` name, e.g. ``"kSolutionFound"``.
        solver_status: Clarabel's own status word, e.g. ``"Solved"``, ``"PrimalInfeasible"``.
        solve_time_s: Wall-clock time of the ``Solve`` call (Drake's conversion + Clarabel) [s].
        x: States (N, 6); NaN unless success.
        u: Forces (N-1, 3) in L [N]; NaN unless success.
        rho: Range lift (N,) [m].
        slack: Collision slacks (N,) (0 at knot 0 and in Problem 2).
        cost: Optimal cost (NaN unless success).
        solver: The solver's name, e.g. ``"Clarabel"``.
        iterations: Its interior-point iterations.
    """

    success: bool
    solution_result: str
    solver_status: str
    solve_time_s: float
    x: np.ndarray
    u: np.ndarray
    rho: np.ndarray
    slack: np.ndarray
    cost: float
    solver: str = "Clarabel"
    iterations: int = 0


def fov_chord_factor(omega_max: float, dt: float) -> float:
    """``sin(phi / 2)``, phi = omega_max dt: the factor of the (FOV) cone (module docstring)."""
    return float(np.sin(0.5 * omega_max * dt))


def _lorentz(prog, A, b, variables):
    """``A z + b`` in the Lorentz cone (first entry >= norm of the rest); returns the evaluator."""
    return prog.AddLorentzConeConstraint(np.asfortranarray(A), b, variables).evaluator()


class SoftCaptureSocp:
    """Problem 2 (``with_collision=False``) or the Problem 3 subproblem for one horizon N.

    ``fov_constraints`` holds the (FOV) bindings, one per step, for inspection. The bounds
    (9), (10), (16) apply at every knot, the given initial one included, so a start outside
    them is reported infeasible by the solver. Clarabel has no warm start, so none is given.

    The program is built once; between solves only its data are rewritten (``set_data``: the
    initial state, the docking-cone and terminal cones; ``set_linearisation``, Problem 3: the
    collision rows and the (FOV-i) cones) with ``set_bounds`` / ``UpdateCoefficients``. Problem 3
    is written in the full variables (x, u) rather than the increments (dx, du) of eq. (26):
    ``alpha_k^i + J_k (r_k - r_k^i) + s_k >= alpha_min`` (25) is the same constraint, and
    ``u = u^i + du`` the same cost.

    Args:
        config: A ``SoftCaptureConfig`` (validated).
        N: Number of knots (>= 2).
        with_collision: Build Problem 3 (fuel weight gamma, collision rows and slacks) instead of
            Problem 2 (fuel weight 1).

    The config's ``socp_scaled`` writes the program in units (module docstring, "Units"), and
    its ``socp_solver`` names the solver: Drake's ClarabelSolver, or ECOS or QOCO on the
    program's standard form (rpod.planners.conic_form), built once and refreshed per solve.
    """

    def __init__(self, config, N: int, with_collision: bool):
        if N < 2:
            raise ValueError(f"N must be >= 2, got {N}")
        self.N = N
        self.with_collision = with_collision
        c = config
        self.scaled = scaled = c.socp_scaled
        self.solver = c.socp_solver
        n, dt, m = c.mean_motion, c.dt_s, c.chaser_mass_kg
        K = N - 1
        prog = self.prog = MathematicalProgram()
        self._x = prog.NewContinuousVariables(6 * N, "x")
        self._u = prog.NewContinuousVariables(3 * K, "u")
        self._w = prog.NewContinuousVariables(3 * K, "w")
        self._rho = prog.NewContinuousVariables(N, "rho")
        if with_collision:
            self._sigma = prog.NewContinuousVariables(K, "sigma")
            self._s = prog.NewContinuousVariables(K, "s")
        X = self._x.reshape(N, 6)
        U = self._u.reshape(N - 1, 3)
        self._r_vars = X[:, :3]

        # The unit of every variable (1 in SI): physical value = unit * program variable.
        length, speed, force = (
            (POSITION_UNIT_M, c.max_speed_m_s, c.max_thrust_N) if scaled else (1, 1, 1)
        )
        unit = np.ones(prog.num_vars())
        unit[: 6 * N] = np.tile([length] * 3 + [speed] * 3, N)
        unit[6 * N : 6 * N + 6 * K] = force  # u and w
        unit[6 * N + 6 * K : 7 * N + 6 * K] = length  # rho
        if with_collision:
            unit[7 * N + 6 * K : 7 * N + 7 * K] = length  # sigma [m]; s is dimensionless
        self._unit = unit
        self._unit_x = unit[: 6 * N].reshape(N, 6)

        def scaled_A(A, variables):
            """A's columns times the units of variables: A z_SI = scaled_A z_program."""
            scale = unit[prog.FindDecisionVariableIndices(variables)]
            return A @ sp.diags(scale) if sp.issparse(A) else np.asarray(A) * scale

        # Initial state: a bounding box on x_0, rewritten per solve.
        self._initial = prog.AddBoundingBoxConstraint(np.zeros(6), np.zeros(6), X[0]).evaluator()

        # Dynamics (5): x_k+1 - Phi x_k - (B_d / m) u_k = 0, one sparse block for all k.
        Phi = cw_state_transition(n, dt)
        Bd_m = cw_zoh_input(n, dt) / m  # u is a force; B_d maps accelerations
        A_dyn = sp.hstack(
            [
                sp.kron(sp.eye(K, N, k=1), sp.eye(6)) - sp.kron(sp.eye(K, N), Phi),
                -sp.kron(sp.eye(K), Bd_m),
            ],
            format="csc",
        )
        dynamics_vars = np.concatenate([self._x, self._u])
        prog.AddLinearEqualityConstraint(
            scaled_A(A_dyn, dynamics_vars).tocsc(), np.zeros(6 * K), dynamics_vars
        )

        # L1 epigraph: -w <= u <= w, vectorised over all components (u and w share a unit).
        I3K = sp.eye(3 * K, format="csc")
        prog.AddLinearConstraint(
            sp.vstack([sp.hstack([I3K, -I3K]), sp.hstack([-I3K, -I3K])], format="csc"),
            np.full(6 * K, -np.inf),
            np.zeros(6 * K),
            np.concatenate([self._u, self._w]),
        )

        # Range lift (16): rho_k <= r_max and |r_k| <= rho_k (which implies rho_k >= 0: no row).
        prog.AddBoundingBoxConstraint(-np.inf, c.max_range_m / length, self._rho)
        lift_A = np.zeros((4, 4))
        lift_A[0, 3] = 1.0
        lift_A[1:, :3] = np.eye(3)
        for k in range(N):
            _lorentz(prog, lift_A, np.zeros(4), np.concatenate([X[k, :3], [self._rho[k]]]))

        # Thrust (9) and speed (10) bounds, |u_k| <= U_max and |v_k| <= v_max, in units.
        bound_A = np.vstack([np.zeros((1, 3)), np.eye(3)])
        for k in range(K):
            _lorentz(prog, bound_A, np.array([c.max_thrust_N / force, 0.0, 0.0, 0.0]), U[k])
        for k in range(N):
            _lorentz(prog, bound_A, np.array([c.max_speed_m_s / speed, 0.0, 0.0, 0.0]), X[k, 3:])

        # Field of view (12). Problem 2: the (FOV) relaxation on the lift, sin(phi/2) (rho_k +
        # rho_k+1) >= |r_k+1 - r_k| on [r_k, r_k+1, rho_k, rho_k+1]. Problem 3: (FOV-i), the
        # lift replaced by its lower bound g_k^T r_k about the iterate, on [r_k, r_k+1]
        # (coefficients written per solve by set_linearisation). Module docstring. All these
        # variables are lengths: one unit, so the cones are the same in units as in SI.
        self._chord = fov_chord_factor(c.max_los_rate_rad_s, dt)
        fov_A = np.zeros((4, 7 if with_collision else 8))
        fov_A[1:, :3] = -np.eye(3)
        fov_A[1:, 3:6] = np.eye(3)
        if with_collision:
            fov_A[0, 6] = 1.0  # + sigma_k, the penalised slack of (FOV-i)
            # sin(phi/2) g^T on r_k, r_k+1, written by set_linearisation; nonzero from the
            # start, the pattern the standard form keeps (rpod.planners.conic_form).
            fov_A[0, :6] = self._chord
            fov_tail = [self._sigma[k : k + 1] for k in range(K)]
        else:
            fov_A[0, 6:] = self._chord
            fov_tail = [self._rho[k : k + 2] for k in range(K)]
        self._fov_A = fov_A
        self.fov_constraints = [
            prog.AddLorentzConeConstraint(
                fov_A, np.zeros(4), np.concatenate([X[k, :3], X[k + 1, :3], fov_tail[k]])
            )
            for k in range(K)
        ]

        # Docking cone (11) over the last N_dock knots; coefficients depend on R_LT,k. In
        # units the cone is divided through by the length unit (its b too).
        self._length = length
        self._tan_dock = float(np.tan(np.radians(c.docking_half_angle_deg)))
        D_t = np.asarray(c.p_TDt_T, dtype=float)
        self._c_t = D_t / np.linalg.norm(D_t)
        self._P_t = _normal_plane_basis(self._c_t)
        self._dock_b = np.array([-self._tan_dock * float(self._c_t @ D_t), 0.0, 0.0]) / length
        self._dock_knots = np.arange(max(0, N - c.docking_knots), N)
        # Written by set_data; dense from the start (the pattern the standard form keeps).
        self._dock = [
            _lorentz(prog, np.ones((3, 3)), np.zeros(3), X[k, :3]) for k in self._dock_knots
        ]

        # Terminal position (13) and velocity (14): [eps; z_N - target] in the Lorentz cone,
        # in units of length and speed.
        self._eps_p, self._eps_v = c.capture_position_tol_m, c.capture_speed_tol_m_s
        self._speed = speed
        self._terminal_p = _lorentz(prog, bound_A, np.zeros(4), X[N - 1, :3])
        self._terminal_v = _lorentz(prog, bound_A, np.zeros(4), X[N - 1, 3:])

        # Cost: fuel weight * sum(w) + sum(rho) (+ psi sum(s + sigma)); Problem 2 / Problem 3,
        # in units divided by its largest coefficient (cost_scale, undone in solve()).
        fuel_weight = c.fuel_weight_gamma if with_collision else c.problem2_fuel_weight
        cost_vars = [self._w, self._rho]
        cost_coefficients = [np.full(3 * K, fuel_weight), np.ones(N)]
        if with_collision:
            prog.AddBoundingBoxConstraint(0.0, np.inf, np.concatenate([self._s, self._sigma]))
            cost_vars += [self._s, self._sigma]
            cost_coefficients += [np.full(K, c.slack_penalty_psi)] * 2
            # Linearised collision (25) at knots 1..N-1: J_k . r_k + s_k >= alpha_min -
            # alpha_k^i + J_k . r_k^i; the J_k blocks are written per solve (times the unit).
            self._alpha_min = c.alpha_min
            self._collision_vars = np.concatenate([self._r_vars[1:].reshape(-1), self._s])
            self._collision_A = sp.hstack(
                [sp.block_diag([np.ones((1, 3))] * K), sp.eye(K)], format="csc"
            )
            # Its lower bounds are finite from the start (rewritten before every solve), so that
            # the standard form (rpod.planners.conic_form) has its rows.
            self._collision = prog.AddLinearConstraint(
                self._collision_A, np.zeros(K), np.full(K, np.inf), self._collision_vars
            ).evaluator()
        cost_vars = np.concatenate(cost_vars)
        cost = scaled_A(np.concatenate(cost_coefficients), cost_vars)
        self.cost_scale = float(np.max(np.abs(cost))) if scaled else 1.0
        prog.AddLinearCost(cost / self.cost_scale, 0.0, cost_vars)
        self._solver = ClarabelSolver()
        self._options = SolverOptions()
        if not c.socp_iterative_refinement:
            self._options.SetOption(ClarabelSolver.id(), "iterative_refinement_enable", False)
        self._form = None
        if self.solver != "clarabel":
            dynamic = [self._initial, *self._dock, self._terminal_p, self._terminal_v]
            if with_collision:
                dynamic += [b.evaluator() for b in self.fov_constraints] + [self._collision]
            self._form = ConicForm(prog, dynamic)

    def set_data(self, data: SocpData) -> None:
        """Writes the per-solve data (initial state, docking cone, terminal targets), in SI."""
        x0 = np.asarray(data.x0, dtype=float) / self._unit_x[0]
        self._initial.set_bounds(x0, x0)
        for evaluator, R_LT in zip(self._dock, data.R_LT_dock[-len(self._dock) :]):
            # [tan(theta) c_t^T R^T r - tan(theta) c_t^T D_t; P R^T r - P D_t], P D_t = 0.
            A = np.vstack([self._tan_dock * (self._c_t @ R_LT.T), self._P_t @ R_LT.T])
            evaluator.UpdateCoefficients(A, self._dock_b)
        bound_A = np.vstack([np.zeros((1, 3)), np.eye(3)])
        p_terminal = np.asarray(data.p_terminal_L, float)
        v_terminal = np.asarray(data.v_terminal_L, float)
        self._terminal_p.UpdateCoefficients(
            bound_A, np.concatenate([[self._eps_p], -p_terminal]) / self._length
        )
        self._terminal_v.UpdateCoefficients(
            bound_A, np.concatenate([[self._eps_v], -v_terminal]) / self._speed
        )

    def set_linearisation(self, alpha: np.ndarray, J: np.ndarray, r_ref: np.ndarray) -> None:
        """Writes the rows linearised about a reference path (Problem 3 only): the collision
        rows (25) and the (FOV-i) cones.

        Args:
            alpha: alpha_k^i at the reference (N,).
            J: d alpha_k / d r_k at the reference (N, 3) [1/m].
            r_ref: Reference chaser positions r_k^i (N, 3) [m].
        """
        if not self.with_collision:
            raise ValueError("set_linearisation needs a program built with_collision=True")
        K = self.N - 1
        # (FOV-i): first row [sin(phi/2) g_k^T, sin(phi/2) g_k+1^T, 1] on [r_k, r_k+1, sigma_k],
        # g the iterate's unit directions.
        g = r_ref / np.maximum(np.linalg.norm(r_ref, axis=1), 1e-9)[:, None]
        A_fov = self._fov_A
        zero_b = np.zeros(4)
        for k, binding in enumerate(self.fov_constraints):
            A_fov[0, :3] = self._chord * g[k]
            A_fov[0, 3:6] = self._chord * g[k + 1]
            binding.evaluator().UpdateCoefficients(A_fov, zero_b)
        A = self._collision_A.copy()
        # block_diag's csc data are the J rows, in order; J [1/m] times the length unit.
        A.data[: 3 * K] = J[1:].reshape(-1) * self._length
        lower = self._alpha_min - alpha[1:] + np.sum(J[1:] * r_ref[1:], axis=1)
        self._collision.UpdateCoefficients(A, lower, np.full(K, np.inf))

    def solve(self) -> SocpSolution:
        """Solves with the config's solver; never raises on infeasibility or a failed solve."""
        start = time.perf_counter()
        if self._form is not None:
            self._form.refresh()
            conic = solve_conic(self._form, self.solver)
            return self._solution(
                conic.status == "solved",
                _CONIC_RESULTS[conic.status],
                conic.solver_status,
                time.perf_counter() - start,
                conic.z,
                conic.cost,
                conic.iterations,
            )
        try:
            result = self._solver.Solve(self.prog, None, self._options)
        except RuntimeError as error:  # Drake reports solver-internal errors this way
            nan = np.full(self.prog.num_vars(), np.nan)
            elapsed = time.perf_counter() - start
            return self._solution(False, "solver_error", str(error), elapsed, nan, np.nan, 0)
        details = result.get_solver_details()
        return self._solution(
            result.is_success(),
            result.get_solution_result().name,
            str(details.status),
            time.perf_counter() - start,
            result.get_x_val(),
            float(result.get_optimal_cost()),
            int(details.iterations),
        )

    def _solution(self, success, result, status, elapsed, z, cost, iterations) -> SocpSolution:
        """The solve in SI: z (the program's variables) times their units, the cost unscaled."""
        N, K = self.N, self.N - 1
        nan = np.nan
        if success:
            z = z * self._unit
            x = z[: 6 * N].reshape(N, 6)
            u = z[6 * N : 6 * N + 3 * K].reshape(K, 3)
            rho = z[6 * N + 6 * K : 7 * N + 6 * K]
            slack = np.zeros(N)
            if self.with_collision:
                slack[1:] = z[7 * N + 7 * K :]
            cost = cost * self.cost_scale
        else:
            x, u = np.full((N, 6), nan), np.full((K, 3), nan)
            rho, slack, cost = np.full(N, nan), np.full(N, nan), nan
        return SocpSolution(
            success=success,
            solution_result=result,
            solver_status=status,
            solve_time_s=elapsed,
            x=x,
            u=u,
            rho=rho,
            slack=slack,
            cost=cost,
            solver=_SOLVER_NAMES[self.solver],
            iterations=iterations,
        )


def _normal_plane_basis(axis: np.ndarray) -> np.ndarray:
    """A 2x3 matrix whose rows are an orthonormal basis of the plane normal to unit ``axis``.

    For ``axis = e_z`` it is ``[e_x; e_y]``, so ``|P y| = |diag(1, 1, 0) y|`` (paper eq. 11).
    """
    if np.allclose(axis, [0.0, 0.0, 1.0]):
        return np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    e1 = np.cross(axis, np.eye(3)[np.argmin(np.abs(axis))])
    e1 /= np.linalg.norm(e1)
    return np.vstack([e1, np.cross(axis, e1)])
