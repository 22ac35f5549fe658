"""Paper 004's MPC safety filter (eq. 11) as one persistent OSQP problem (or PIQP, or DAQP on it
condensed: `LosMpcSettings.qp_solver`).

Owns: `LosMpcSettings` (horizon, weights, input bound, solver tolerances), `LosCorridorMpc`
(the QP, built once) and `MpcResult`. Does not own: the prediction model A_d, B_d (given per
step, one pair for the whole horizon or one per predicted step: CW's exact STM and ZOH input
matrix, or the online linearisation, rpod.planners.los_prediction), the corridor
(rpod.models.los_corridor), the reference or what a controller does when the QP fails.

The QP (eq. 11), over z = [x_0, ..., x_N, u_0, ..., u_{N-1}] (N = N_p):

    min  sum_{j<N} |x_j - x_ref|_Q^2 + |x_N - x_ref|_{Q_N}^2
         + sum_{j<N} |u_j - u_nom|_{R_u}^2 + |u_j - u_{j-1}|_{R_du}^2  (11a; u_{-1}: last applied)
    s.t. x_0 = x_k                                                    (11c)
         x_{j+1} = A_d,j x_j + B_d,j u_j,  j < N                      (11b)
         A_c [x_j]_{1:3} <= b_c,  j = 0..N                            (11d)
         -a_max <= u_j <= a_max                                       (11e)

written as OSQP's min 1/2 z'Pz + q'z, l <= A z <= u. The input-rate term is u' D' R D u -
2 e' R D u + const with D the first difference (its first row the identity) and e = [u_{-1}, 0,
...], so P is constant and only q depends on x_ref, u_nom and u_{-1}.

u_nom is the guidance law's nominal command (paper 004 Sec. 7: "the nominal PD command is
refined through the QP-based MPC safety filter"): the paper's 11a has |u_j|_{R_u}, which is
u_nom = 0, and does not say how the PD command enters; centring the small input weight on it
is how it does here (R_u = 1e-2 against Q's 15-30 keeps the tracking and the constraints in
charge). A_d,j = A_d for all j is the paper's frozen-over-the-horizon model; one per step is the
predicted-attitude model of a non-principal tumble.

Persistence (what the paper's public code does not do: it rebuilds OSQP every step, so its warm
start never takes effect). The problem is set up once. The constraint matrix's sparsity is
fixed up front: every entry of every A_d and B_d block is stored, zeros included, so a new
A_d, B_d only rewrites values (`update(Ax=...)`, and only when they change), never the pattern,
and OSQP keeps its factorisation's symbolic part. Each step then updates q, l, u, and OSQP starts
from the previous primal and dual solution shifted one step along the horizon (the receding
horizon's own guess; `shift_warm_start`), which cut the p99 per step by ~20% against OSQP's
unshifted warm start (benchmarks/results/los_corridor_mpc.md).

The best-effort QP (`soft=True`; rpod's, not the paper's). When the QP above is infeasible (a
chaser that cannot be kept inside from where it is) a hard-constrained MPC has no input at all,
and whatever the controller flies instead ignores the corridor. The same QP with 11d softened,

    A_c [x_j]_{1:3} <= b_c,j + |A_c,i| s_j,   s_j >= 0,   cost + sum_j (rho s_j + s_j^2),

has a solution (s_j is how far outside the corridor step j's plan may go [m]) and, with rho
above the corridor's multipliers, is an exact penalty: where the hard QP is feasible its optimum
is the hard one's (s = 0; tested), and where it is not, the input keeps the predicted excursion
as small as the box allows. rho is `LosMpcSettings.corridor_penalty`. Once the corridor is soft
nothing keeps the plan off the target (inside the corridor its floor does): the shortest way
back into the cone can run through its apex. So the best-effort QP keeps every predicted
position j >= 1 beyond the plane tangent to a keep-out sphere, n . p_j + t_j >= r_ko with n the
current direction p_0 / |p_0| (the usual convex inner approximation of |p| >= r_ko), softened
too, t_j >= 0 at KEEP_OUT_FACTOR rho per metre, so that a chaser already closing on the target
faster than the box can stop gets the input that intrudes least rather than none (then the
fallback chain's last resort, the regime's PD toward H, flew it through the target: Table 3's
outside starts at 2 and 3 deg/s, 0.02 m/s^2).
"""

import dataclasses
import enum
import time

import numpy as np
import osqp
import piqp
import scipy.sparse as sp

from rpod.models.config import ConfigError, bounded, check_bounds, count, positive
from rpod.planners import los_corridor_condensed

KEEP_OUT_FACTOR = 10.0  # the keep-out's penalty over the corridor's: the target first
QP_SOLVERS = ("osqp", "piqp", "daqp")


class MpcStatus(str, enum.Enum):
    """What came of one solve, in OSQP's terms (PIQP's and DAQP's mapped onto them)."""

    SOLVED = "solved"
    SOLVED_INACCURATE = "solved_inaccurate"
    PRIMAL_INFEASIBLE = "primal_infeasible"
    DUAL_INFEASIBLE = "dual_infeasible"
    MAX_ITERATIONS = "max_iterations"
    OTHER = "other"


_PIQP_STATUS = {
    piqp.PIQP_SOLVED: MpcStatus.SOLVED,
    piqp.PIQP_MAX_ITER_REACHED: MpcStatus.MAX_ITERATIONS,
    piqp.PIQP_PRIMAL_INFEASIBLE: MpcStatus.PRIMAL_INFEASIBLE,
    piqp.PIQP_DUAL_INFEASIBLE: MpcStatus.DUAL_INFEASIBLE,
}

_DAQP_STATUS = {
    **dict.fromkeys(los_corridor_condensed.SOLVED_FLAGS, MpcStatus.SOLVED),
    los_corridor_condensed.INFEASIBLE_FLAG: MpcStatus.PRIMAL_INFEASIBLE,
    los_corridor_condensed.UNBOUNDED_FLAG: MpcStatus.DUAL_INFEASIBLE,
    los_corridor_condensed.ITERATION_LIMIT_FLAG: MpcStatus.MAX_ITERATIONS,
}

_OSQP_STATUS = {
    "solved": MpcStatus.SOLVED,
    "solved inaccurate": MpcStatus.SOLVED_INACCURATE,
    "primal infeasible": MpcStatus.PRIMAL_INFEASIBLE,
    "primal infeasible inaccurate": MpcStatus.PRIMAL_INFEASIBLE,
    "dual infeasible": MpcStatus.DUAL_INFEASIBLE,
    "dual infeasible inaccurate": MpcStatus.DUAL_INFEASIBLE,
    "maximum iterations reached": MpcStatus.MAX_ITERATIONS,
}


@dataclasses.dataclass
class LosMpcSettings:
    """Paper 004 Sec. 6's MPC (defaults: the single-scenario configuration).

    Args:
        horizon: N_p (40 single scenario, 20 Monte Carlo).
        Q_diag: tracking weight Q (diag(15, 30, 15, 1, 1, 1)).
        terminal_factor: Q_N = terminal_factor Q (30).
        R_u_diag: input weight R_u (1e-2 I).
        R_du_diag: input-rate weight R_du (1e4 I; Monte Carlo: diag(1e5, 1e4, 1e5)).
        a_max_m_s2: the box bound on each input component (11e) [m/s^2].
        eps_abs: OSQP's absolute tolerance (1e-4: on los_corridor, 1e-3 let the chaser out
            of the corridor by 0.3 m, and 1e-5 took 1.5x the time for the same flight).
        eps_rel: OSQP's relative tolerance (likewise).
        max_iter: OSQP's iteration limit.
        shift_warm_start: start each solve from the previous solution shifted one step (the
            receding horizon's own guess: x_j <- x_{j+1}, u_j <- u_{j+1}, and the duals of
            each block likewise, the last repeated) instead of OSQP's unshifted previous one.
        check_tolerance_m: an iterate OSQP did not finish (iteration limit, or solved
            inaccurately) is used when its inputs, clipped to the box and rolled out through
            the model from x_k, keep every predicted position inside the corridor to within
            this distance [m] (Sec. 9's 1e-3 m); else the step has no usable input.
        polishing: OSQP's solution polishing (a reduced KKT solve on the guessed active set).
        margin_m: the corridor is tightened by this distance at every predicted step j >= 1
            (the plan keeps off the faces by it; 0: the paper's 11d). The prediction model is
            a linearisation frozen over the horizon, so a plan that rides a face leaves the
            truth millimetres outside it (benchmarks/results/los_filter_study.md: 2-7 mm with
            0, none with 0.1 m).
        recovery_steps: R. A chaser already outside the (tightened) corridor makes 11d
            infeasible at j = 0 and, through it, the whole QP for as long as it stays out;
            with R > 0 each face's bound at step j is relaxed by the current excess times
            max(0, 1 - (j / R)^2): a funnel back inside within R steps, quadratic as the path
            of a chaser that starts from rest at a bounded acceleration (a linear one asks for
            a speed at j = 1 that the box cannot give) (0: the paper's hard 11d).
        corridor_penalty: rho of the best-effort QP (module docstring), per metre outside the
            corridor per predicted step; 0: no best-effort QP (what a failed hard QP flies is
            then the fallback chain alone, as the paper does).
        qp_solver: "osqp" (ADMM, warm-started by the shift; eps_abs, eps_rel, polishing and
            shift_warm_start are its settings), "piqp" (PIQP's proximal interior point on
            the same QP, from its own start every step, at its default tolerances, 1e-8
            absolute) or "daqp" (DAQP's dual active set on the QP condensed onto the inputs,
            warm-started by the shifted working set: rpod.planners.los_corridor_condensed);
            max_iter applies to each: benchmarks/results/los_corridor_mpc.md compares them.

    Bounds (rpod.models.config, checked by `validate()`): the horizon at most 2000 steps (the
    QP grows by 9 variables and a corridor row per face each step; measured ~1 ms per step per
    solve: 0.04 s at 40, 2.1 s at 2000), the funnel no longer than the longest horizon; OSQP at
    most 1e6 iterations (an ADMM iteration is one sparse back-solve); weights up to 1e9
    (terminal_factor up to 1e6, so Q_N stays within 1e15); tolerances in (0, 1]; the input bound
    up to 1000 m/s^2 (100 g); the margin and the check tolerance within 1 km.
    """

    horizon: int = count(40, 1, 2000)
    Q_diag: list[float] = bounded([15, 30, 15, 1, 1, 1], 0.0, 1e9)  # noqa: RUF009 (a field())
    terminal_factor: float = positive(30.0, 1e6)
    R_u_diag: list[float] = bounded([1e-2] * 3, 0.0, 1e9)  # noqa: RUF009
    R_du_diag: list[float] = bounded([1e4] * 3, 0.0, 1e9)  # noqa: RUF009
    a_max_m_s2: float = positive(0.10, 1e3)
    eps_abs: float = positive(1e-4, 1.0)
    eps_rel: float = positive(1e-4, 1.0)
    max_iter: int = count(4000, 1, 1_000_000)
    shift_warm_start: bool = True
    check_tolerance_m: float = positive(1e-3, 1e3)
    polishing: bool = False
    margin_m: float = bounded(0.1, 0.0, 1e3)
    recovery_steps: int = count(10, 0, 2000)
    corridor_penalty: float = bounded(1e5, 0.0, 1e9)
    qp_solver: str = "osqp"

    def validate(self) -> None:
        """Raises ConfigError naming the first bad field: its declared bounds (check_bounds),
        then the checks that need more than one number."""
        check_bounds(self)
        for name in ("horizon", "max_iter", "recovery_steps"):
            value = getattr(self, name)
            if int(value) != value:
                raise ConfigError(name, f"must be an integer, got {value}")
        for name, size in (("Q_diag", 6), ("R_u_diag", 3), ("R_du_diag", 3)):
            if np.shape(getattr(self, name)) != (size,):
                raise ConfigError(name, f"expected {size} finite non-negative numbers")
        if not np.all(np.asarray(self.R_u_diag) + np.asarray(self.R_du_diag) > 0):
            raise ConfigError("R_u_diag", "R_u + R_du must be positive definite")
        if self.qp_solver not in QP_SOLVERS:
            raise ConfigError("qp_solver", f"must be one of {QP_SOLVERS}, got {self.qp_solver!r}")


@dataclasses.dataclass
class MpcResult:
    """One solve.

    Attributes:
        status: the QP solver's verdict as an MpcStatus.
        u0: the first input (3) to apply, or None when the step has no usable input.
        u: the inputs (N, 3), x: the predicted states (N + 1, 6) (None likewise).
        iterations: the QP solver's iterations (ADMM, interior-point or active-set).
        solve_time_s: wall time of the update, the solve and the check [s].
        checked: an unfinished iterate passed the rollout check (LosMpcSettings); its x is
            the rollout, its u the clipped inputs. On the best-effort QP, which promises no
            corridor nor keep-out, every finite iterate passes (its inputs clipped to the box).
        excess_m: the best-effort QP's largest planned s_j, how far outside the corridor its
            plan goes at worst [m] (0 on the hard QP).
    """

    status: MpcStatus
    u0: np.ndarray | None
    u: np.ndarray | None
    x: np.ndarray | None
    iterations: int
    solve_time_s: float
    checked: bool = False
    excess_m: float = 0.0

    @property
    def solved(self) -> bool:
        """There is an input to apply: the QP was solved, or its iterate passed the check."""
        return self.status is MpcStatus.SOLVED or self.checked


class LosCorridorMpc:
    """The persistent QP of eq. 11 (module docstring)."""

    def __init__(
        self,
        settings: LosMpcSettings,
        A_c: np.ndarray,
        b_c: np.ndarray,
        soft: bool = False,
        keep_out_m: float = 0.0,
    ):
        """Builds and sets up the QP once (A_d = I, B_d = 0 until the first `solve`).

        Args:
            settings: the MPC's settings (validated here).
            A_c, b_c: the corridor's half-spaces on the position, A_c p <= b_c (eq. 9).
            soft: the best-effort QP (module docstring), with settings.corridor_penalty.
            keep_out_m: r_ko, the best-effort QP's keep-out radius about the target [m].
        """
        settings.validate()
        if soft and not settings.corridor_penalty > 0:
            raise ValueError("corridor_penalty: the best-effort QP needs a positive penalty")
        if not (np.isfinite(keep_out_m) and keep_out_m >= 0):
            raise ValueError(f"keep_out_m: must not be negative, got {keep_out_m}")
        self.settings = settings
        self.soft = soft
        self.keep_out_m = float(keep_out_m)
        N = self.N = int(settings.horizon)
        self._A_c = np.asarray(A_c, dtype=float)
        self._b_c = np.asarray(b_c, dtype=float)
        nx, nu, nc = 6, 3, len(self._b_c)
        self._u_offset = nx * (N + 1)
        # Soft only, after the inputs: the corridor's slacks s_0..s_N, the keep-out's t_0..t_N.
        self._s_offset = self._u_offset + nu * N
        self._t_offset = self._s_offset + N + 1
        self._nz = self._s_offset + (2 * (N + 1) if soft else 0)

        # Cost: P constant (x_ref and u_{-1} enter q only).
        Q = np.diag(np.asarray(settings.Q_diag, dtype=float))
        R_u = np.diag(np.asarray(settings.R_u_diag, dtype=float))
        self._R_du = np.diag(np.asarray(settings.R_du_diag, dtype=float))
        P_x = sp.block_diag([Q] * N + [settings.terminal_factor * Q])
        D = sp.eye(N) - sp.eye(N, k=-1)  # first difference; row 0 is u_0 (minus u_{-1} in q)
        R_du_blk = sp.kron(sp.eye(N), self._R_du)
        D_blk = sp.kron(D, sp.eye(nu))
        P_u = sp.kron(sp.eye(N), R_u) + D_blk.T @ R_du_blk @ D_blk
        P_s = sp.eye(2 * (N + 1)) if soft else sp.csc_matrix((0, 0))  # the s_j^2, t_j^2 terms
        self._P = sp.triu(2.0 * sp.block_diag([P_x, P_u, P_s]), format="csc")
        self._Q = Q
        self._R_u = R_u
        self._Q_N = settings.terminal_factor * Q

        # Constraints: rows [x_0 = x_k (6); dynamics (6N); corridor (nc (N+1)); inputs (3N)].
        # Every A_d and B_d entry is an explicit entry (ids >= 0 tag them for updates).
        rows, cols, values, ids = [], [], [], []

        def add(r, c, v, tag=-1):
            rows.append(r)
            cols.append(c)
            values.append(v)
            ids.append(tag)

        for i in range(nx):
            add(i, i, 1.0)
        self._dynamics_slots = []  # (j, "A"|"B", row, col) for tagged entries, in tag order
        for j in range(N):
            r0 = nx + nx * j
            for i in range(nx):
                add(r0 + i, nx * (j + 1) + i, 1.0)  # x_{j+1}
            for i in range(nx):
                for k in range(nx):  # -A_d,j x_j
                    add(r0 + i, nx * j + k, 0.0, len(self._dynamics_slots))
                    self._dynamics_slots.append((j, "A", i, k))
                for k in range(nu):  # -B_d,j u_j
                    add(r0 + i, self._u_offset + nu * j + k, 0.0, len(self._dynamics_slots))
                    self._dynamics_slots.append((j, "B", i, k))
        r_corr = nx + nx * N
        self._row_norms = np.linalg.norm(self._A_c, axis=1)
        for j in range(N + 1):
            for i in range(nc):
                for k in range(3):
                    if self._A_c[i, k] != 0.0:
                        add(r_corr + nc * j + i, nx * j + k, self._A_c[i, k])
                if soft:  # - |A_c,i| s_j: the face moved out by s_j metres
                    add(r_corr + nc * j + i, self._s_offset + j, -self._row_norms[i])
        r_u = r_corr + nc * (N + 1)
        self._corridor_rows = slice(r_corr, r_u)
        for j in range(N):
            for k in range(nu):
                add(r_u + nu * j + k, self._u_offset + nu * j + k, 1.0)
        m = r_u + nu * N
        if soft:  # s_j, t_j >= 0, then the keep-out n . p_j + t_j >= r_ko (n tagged -2 - index)
            for j in range(2 * (N + 1)):
                add(m + j, self._s_offset + j, 1.0)
            m += 2 * (N + 1)
            for j in range(N + 1):
                for k in range(3):
                    add(m + j, nx * j + k, 0.0, -2 - (3 * j + k))
                add(m + j, self._t_offset + j, 1.0)
            m += N + 1
        # CSC with explicit zeros kept: build from ids, read the slot order, then the values.
        tags = sp.csc_matrix(
            (np.arange(len(values), dtype=float) + 1.0, (rows, cols)), shape=(m, self._nz)
        )
        order = tags.data.astype(int) - 1  # csc slot -> entry
        self._A = sp.csc_matrix(
            (np.asarray(values)[order], tags.indices.copy(), tags.indptr.copy()),
            shape=(m, self._nz),
        )
        entry_ids = np.asarray(ids)[order]
        self._dyn_csc_slots = np.flatnonzero(entry_ids >= 0)  # csc slots of A_d, B_d entries
        self._ko_csc_slots = np.flatnonzero(entry_ids <= -2)  # csc slots of the keep-out's n
        self._ko_source = -2 - entry_ids[self._ko_csc_slots]  # index into n tiled N + 1 times
        # Where each of those slots takes its value in [A_d,j.ravel(), B_d,j.ravel()] over j
        # (negated): 54 values per step.
        source = np.array(
            [
                54 * j + (6 * i + k if kind == "A" else 36 + 3 * i + k)
                for j, kind, i, k in self._dynamics_slots
            ]
        )
        self._slot_source = source[entry_ids[self._dyn_csc_slots]]
        self._last_dynamics = None  # (A_d, B_d) last written into the solver
        self._last_solution = None  # (x, y) of the last successful solve, for the shift
        self._nc = nc
        a_max = settings.a_max_m_s2
        x_rows = np.zeros(nx * (N + 1))
        s_rows = np.zeros(2 * (N + 1) if soft else 0)
        ko_lower = np.r_[-np.inf, np.full(N, self.keep_out_m)] if soft else s_rows
        self._l = np.concatenate(
            [x_rows, np.full(nc * (N + 1), -np.inf), np.full(nu * N, -a_max), s_rows, ko_lower]
        )
        self._u = np.concatenate(
            [x_rows, np.tile(self._b_c, N + 1), np.full(nu * N, a_max), s_rows + np.inf]
            + [np.full(len(ko_lower), np.inf)]
        )
        self._n_eq = nx * (N + 1)  # rows x_0 = x_k and the dynamics: the equalities
        if settings.qp_solver == "piqp":
            self._setup_piqp()
            return
        if settings.qp_solver == "daqp":
            self._condensed = los_corridor_condensed.CondensedQp(self)
            return
        self._solver = osqp.OSQP()
        self._solver.setup(
            P=self._P,
            q=np.zeros(self._nz),
            A=self._A,
            l=self._l,
            u=self._u,
            eps_abs=settings.eps_abs,
            eps_rel=settings.eps_rel,
            max_iter=settings.max_iter,
            warm_starting=True,
            polishing=settings.polishing,
            verbose=False,
        )

    def _setup_piqp(self) -> None:
        """PIQP on the same QP: equalities A_eq z = b (rows before `_n_eq`), the rest as
        h_l <= G z <= h_u; A_eq's and G's values gathered from A's CSC slots at every step."""
        tags = self._A.copy()
        tags.data = np.arange(1.0, tags.nnz + 1.0)  # slot numbers survive the row slicing
        self._A_eq, self._G = tags[: self._n_eq].tocsc(), tags[self._n_eq :].tocsc()
        self._eq_source = self._A_eq.data.astype(int) - 1
        self._g_source = self._G.data.astype(int) - 1
        self._A_values = self._A.data.copy()
        self._A_eq.data, self._G.data = (
            self._A_values[self._eq_source],
            self._A_values[self._g_source],
        )
        self._solver = piqp.SparseSolver()
        self._solver.settings.verbose = False
        self._solver.settings.max_iter = int(self.settings.max_iter)
        n = self._n_eq
        self._solver.setup(
            self._P, np.zeros(self._nz), self._A_eq, self._l[:n], self._G, self._l[n:], self._u[n:]
        )

    def _solve_piqp(self, x_k, q, l, u, A_d, B_d) -> tuple[MpcStatus, np.ndarray, int]:
        """(status, z, iterations) of PIQP on this step's data."""
        self._A_values[self._dyn_csc_slots] = self._dynamics_values(A_d, B_d)
        if self.soft:
            self._A_values[self._ko_csc_slots] = self._keep_out_values(x_k)
        self._A_eq.data[:] = self._A_values[self._eq_source]
        self._G.data[:] = self._A_values[self._g_source]
        n = self._n_eq
        self._solver.update(c=q, A=self._A_eq, b=l[:n], G=self._G, h_l=l[n:], h_u=u[n:])
        status = _PIQP_STATUS.get(self._solver.solve(), MpcStatus.OTHER)
        result = self._solver.result
        return status, np.array(result.x, dtype=float), int(result.info.iter)

    def qp(self, x_k, x_ref, u_prev, A_d, B_d, u_nom=None):
        """(P, q, A, l, u) of the QP at these data (P upper triangular): for a reference solve."""
        A = self._A.copy()
        A.data[self._dyn_csc_slots] = self._dynamics_values(*self._per_step(A_d, B_d))
        if self.soft:
            A.data[self._ko_csc_slots] = self._keep_out_values(x_k)
        l, u = self._l.copy(), self._u.copy()
        l[:6] = u[:6] = x_k
        u[self._corridor_rows] = self._corridor_bounds(x_k).ravel()
        return self._P, self._linear_cost(x_ref, u_prev, u_nom), A, l, u

    def _corridor_bounds(self, x_k) -> np.ndarray:
        """(N + 1, nc): the right-hand side of 11d at each step: b_c tightened by margin_m
        (j >= 1), relaxed by the funnel of a chaser outside (LosMpcSettings)."""
        settings = self.settings
        tightened = self._b_c - settings.margin_m * self._row_norms
        excess = np.maximum(self._A_c @ np.asarray(x_k, dtype=float)[:3] - tightened, 0.0)
        steps = np.arange(self.N + 1)
        if settings.recovery_steps > 0:
            keep = np.maximum(1.0 - (steps / settings.recovery_steps) ** 2, 0.0)
        elif settings.margin_m > 0:
            keep = (steps == 0).astype(float)  # x_0 is data: within the margin is no failure
        else:
            keep = np.zeros(self.N + 1)  # the paper's 11d, j = 0 included
        return tightened[None, :] + keep[:, None] * excess[None, :]

    def _per_step(self, A_d, B_d) -> tuple[np.ndarray, np.ndarray]:
        """(A_d (N, 6, 6), B_d (N, 6, 3)) from one pair or one per step."""
        A_d, B_d = np.asarray(A_d, dtype=float), np.asarray(B_d, dtype=float)
        if A_d.shape == (6, 6) and B_d.shape == (6, 3):
            return np.broadcast_to(A_d, (self.N, 6, 6)), np.broadcast_to(B_d, (self.N, 6, 3))
        if A_d.shape != (self.N, 6, 6) or B_d.shape != (self.N, 6, 3):
            raise ValueError(
                f"A_d, B_d: expected (6, 6) and (6, 3), or ({self.N}, 6, 6) and ({self.N}, 6, 3);"
                f" got {A_d.shape} and {B_d.shape}"
            )
        return A_d, B_d

    @staticmethod
    def _keep_out_direction(x_k) -> np.ndarray:
        """n = p_0 / |p_0| of the keep-out rows (module docstring)."""
        p = np.asarray(x_k, dtype=float)[:3]
        norm = float(np.linalg.norm(p))
        return p / norm if norm > 0 else np.array([0.0, 1.0, 0.0])

    def _keep_out_values(self, x_k) -> np.ndarray:
        """The keep-out rows' n at every step, in CSC slot order (soft only)."""
        return np.tile(self._keep_out_direction(x_k), self.N + 1)[self._ko_source]

    def _dynamics_values(self, A_d, B_d) -> np.ndarray:
        """The constraint matrix's A_d,j, B_d,j slots (negated), in CSC slot order."""
        flat = np.concatenate([A_d.reshape(self.N, 36), B_d.reshape(self.N, 18)], axis=1)
        return -flat.ravel()[self._slot_source]

    def _linear_cost(self, x_ref, u_prev, u_nom=None) -> np.ndarray:
        """q: -2 Q x_ref on each state (Q_N on the last), -2 R_u u_nom on each input and
        -2 R_du u_{-1} on u_0."""
        q = np.zeros(self._nz)
        x_ref = np.asarray(x_ref, dtype=float)
        q[: 6 * self.N] = np.tile(-2.0 * self._Q @ x_ref, self.N)
        q[6 * self.N : self._u_offset] = -2.0 * self._Q_N @ x_ref
        if u_nom is not None:
            q[self._u_offset : self._s_offset] = np.tile(
                -2.0 * self._R_u @ np.asarray(u_nom, float), self.N
            )
        q[self._u_offset : self._u_offset + 3] -= 2.0 * self._R_du @ np.asarray(u_prev, float)
        q[self._s_offset : self._t_offset] = self.settings.corridor_penalty  # rho s_j
        q[self._t_offset :] = KEEP_OUT_FACTOR * self.settings.corridor_penalty
        return q

    @staticmethod
    def _shift(vector: np.ndarray, start: int, size: int, count: int) -> None:
        """Moves `count` blocks of `size` at `start` one block earlier, the last repeated."""
        blocks = vector[start : start + size * count].reshape(count, size)
        blocks[:-1] = blocks[1:].copy()

    def _shifted_primal(self) -> np.ndarray:
        z = self._last_solution[0].copy()
        self._shift(z, 0, 6, self.N + 1)
        self._shift(z, self._u_offset, 3, self.N)
        if self.soft:
            self._shift(z, self._s_offset, 1, self.N + 1)
            self._shift(z, self._t_offset, 1, self.N + 1)
        return z

    def _shifted_dual(self) -> np.ndarray:
        """Rows: x_0 (6), dynamics (6 N), corridor (nc (N + 1)), inputs (3 N), then the
        slacks' and the keep-out's (3 (N + 1), soft only)."""
        y = self._last_solution[1].copy()
        N, nc = self.N, self._nc
        self._shift(y, 6, 6, N)
        self._shift(y, 6 + 6 * N, nc, N + 1)
        self._shift(y, 6 + 6 * N + nc * (N + 1), 3, N)
        if self.soft:
            start = 6 + 6 * N + nc * (N + 1) + 3 * N
            for block in range(3):  # s >= 0, t >= 0, the keep-out
                self._shift(y, start + block * (N + 1), 1, N + 1)
        return y

    def solve(self, x_k, x_ref, u_prev, A_d, B_d, u_nom=None) -> MpcResult:
        """One receding-horizon step: updates the data, solves warm, returns u_0 (eq. 11).

        Args:
            x_k: the current body-frame state (6).
            x_ref: the reference state (6).
            u_prev: u_{-1}, the input applied last (3).
            A_d, B_d: the prediction model, (6, 6) and (6, 3) for the whole horizon or
                (N, 6, 6) and (N, 6, 3), one per predicted step.
            u_nom: the nominal command the input weight is centred on (3; None: 0, the paper).
        """
        start = time.perf_counter()
        l, u = self._l, self._u
        l[:6] = u[:6] = np.asarray(x_k, dtype=float)
        bounds = self._corridor_bounds(x_k)
        u[self._corridor_rows] = bounds.ravel()
        A_d, B_d = self._per_step(A_d, B_d)
        if self.settings.qp_solver == "piqp":
            q = self._linear_cost(x_ref, u_prev, u_nom)
            status, z, iterations = self._solve_piqp(x_k, q, l, u, A_d, B_d)
            return self._result(start, status, z, None, iterations, A_d, B_d, bounds)
        if self.settings.qp_solver == "daqp":
            q = self._linear_cost(x_ref, u_prev, u_nom)
            n = self._keep_out_direction(x_k) if self.soft else None
            flag, z, iterations = self._condensed.solve(l[:6], q, bounds, A_d, B_d, n)
            status = _DAQP_STATUS.get(flag, MpcStatus.OTHER)
            return self._result(start, status, z, None, iterations, A_d, B_d, bounds)
        last = self._last_dynamics
        if self.soft:  # the keep-out's direction changes at every step: one update for both
            slots = np.concatenate([self._dyn_csc_slots, self._ko_csc_slots])
            values = np.concatenate([self._dynamics_values(A_d, B_d), self._keep_out_values(x_k)])
            order = np.argsort(slots)
            self._solver.update(Ax=values[order], Ax_idx=slots[order])
        elif last is None or not (np.array_equal(last[0], A_d) and np.array_equal(last[1], B_d)):
            # New model values only (the pattern is fixed): OSQP refactors numerically.
            self._solver.update(Ax=self._dynamics_values(A_d, B_d), Ax_idx=self._dyn_csc_slots)
            self._last_dynamics = (A_d.copy(), B_d.copy())
        self._solver.update(q=self._linear_cost(x_ref, u_prev, u_nom), l=l, u=u)
        if self.settings.shift_warm_start and self._last_solution is not None:
            self._solver.warm_start(x=self._shifted_primal(), y=self._shifted_dual())
        result = self._solver.solve(raise_error=False)  # a failure is a status, not a raise
        status = _OSQP_STATUS.get(result.info.status, MpcStatus.OTHER)
        return self._result(
            start, status, result.x, result.y, int(result.info.iter), A_d, B_d, bounds
        )

    def _result(self, start, status, z, y, iterations, A_d, B_d, bounds) -> MpcResult:
        """The MpcResult of a solver's answer z (duals y for the next shift; None: none)."""
        l = self._l
        checked = False
        if status is MpcStatus.SOLVED:
            x = z[: self._u_offset].reshape(self.N + 1, 6)
            u_all = z[self._u_offset : self._s_offset].reshape(self.N, 3)
            if self.soft:  # OSQP's box is met to its tolerance; the best effort's exactly
                u_all = np.clip(u_all, -self.settings.a_max_m_s2, self.settings.a_max_m_s2)
        elif (
            status in (MpcStatus.MAX_ITERATIONS, MpcStatus.SOLVED_INACCURATE)
            and z is not None
            and np.all(np.isfinite(z))
        ):
            u_all, x, checked = self._rollout_check(l[:6], z, A_d, B_d, bounds)
        if status is not MpcStatus.SOLVED and not checked:
            elapsed = time.perf_counter() - start
            return MpcResult(status, None, None, None, iterations, elapsed)
        if y is not None:
            self._last_solution = (z.copy(), y.copy())
        excess = float(np.max(z[self._s_offset : self._t_offset], initial=0.0))
        elapsed = time.perf_counter() - start
        return MpcResult(status, u_all[0].copy(), u_all, x, iterations, elapsed, checked, excess)

    def _rollout_check(self, x_k, z, A_d, B_d, bounds) -> tuple[np.ndarray, np.ndarray, bool]:
        """(u clipped, the rollout x, whether every predicted position j >= 1 meets the QP's
        own 11d bounds to check_tolerance_m): the independent check of an unfinished iterate."""
        a_max = self.settings.a_max_m_s2
        u_all = np.clip(z[self._u_offset : self._s_offset].reshape(self.N, 3), -a_max, a_max)
        x = np.empty((self.N + 1, 6))
        x[0] = x_k
        for j in range(self.N):
            x[j + 1] = A_d[j] @ x[j] + B_d[j] @ u_all[j]
        if self.soft:  # no corridor or keep-out promised: the least excursion the box allows
            return u_all, x, True
        distance = (bounds[1:] - x[1:, :3] @ self._A_c.T) / self._row_norms
        return u_all, x, bool(np.min(distance) >= -self.settings.check_tolerance_m)
