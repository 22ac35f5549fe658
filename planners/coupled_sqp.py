"""Paper 001's optimal control problem (22) by sequential quadratic programming: Gauss-Newton
SQP to convergence, or one real-time iteration (RTI) per control step.

Owns: `CoupledSqp`, the algorithm: each iteration linearises the multiple-shooting
transcription (rpod.planners.coupled_shooting: the same RK4 defects and RK4 cost quadrature as
the IPOPT transcription of rpod.planners.coupled_nmpc, with exact derivatives) about the current
guess, solves one sparse QP with OSQP (one problem, its sparsity fixed, values updated), and
takes the step with a backtracking line search on an l1 merit function. Does not own the
model, the transcription, the problem's data (CoupledNmpcSettings, NmpcResult live in
coupled_nmpc), or the controller.

The QP (variables u_0..u_N-1, x_1..x_N (NLP states), s_1..s_N (LOS slacks); x_0 is data):
- cost: the Gauss-Newton model of eq. 22's objective. At every RK4 stage point j of interval k,
  the quadratic terms of eq. 20 in the state, c_j y_j^T Q_y y_j with y = (w_TC_T, p_PtPc_T,
  xi_T), are taken with y_j linearised in (x_k, u_k) (Hessian 2 c_j G_j^T Q_y G_j: exact first
  derivatives, the second derivatives of the flow dropped, which keeps the QP convex); the
  attitude term Q_R tr(D - D R) (linear in R) by its exact gradient; the input terms of eq. 20
  (constant on an interval, so T_s (u^T W_f u + tau^T W_tau tau) exactly), eq. 21 exactly, and
  rho sum s. A Levenberg-Marquardt term mu |z - z_bar|^2 (in scaled variables) regularises it.
- constraints: the linearised defects x_k+1 = Phi(x_bar_k, u_bar_k) + A_k dx_k + B_k du_k;
  eq. 16 exactly (linear); eq. 17 linearised about the current forces, 2 f_bar.f <= f_max^2 +
  |f_bar|^2 (exact at convergence), plus the cap d_k.f_k <= f_max that bounds the QP when
  f_bar = 0; eq. 18 softened exactly as the NLP (A_p p_k - s_k <= 0, s_k >= 0); the NLP's box on
  the relative rate at the nodes. On a fixed bank (one thrust per thruster,
  rpod.models.coupled_relative) eqs. 16-17 are the box 0 <= u_k <= f_max, exact and linear: the
  cap rows hold it, and there are no gimbal or magnitude rows.

Why Gauss-Newton SQP beside IPOPT: Drake gives IPOPT no second derivatives, and with its
limited-memory Hessian IPOPT does not converge on T = 480 s (coupled_nmpc's docstring). Paper
001's CasADi gave IPOPT exact Hessians. The Gauss-Newton model is what acados and the RTI
literature (Diehl et al. 2005) use for tracking-type costs like eq. 20; a fixed point of the
iteration satisfies the NLP's KKT conditions (the Hessian model changes the path, not the
solution), and the status says whether that point was reached.

RTI: one iteration per control step from the previous solution shifted one interval, without a
line search (Diehl's real-time iteration). Its status is RTI_STEP when the QP was solved: the
plan is one Newton-type step towards the optimum, not the optimum.
"""

import dataclasses
import logging
import math

import numpy as np
import osqp
import piqp
import scipy.sparse as sp

from rpod.models import coupled_relative as cr
from rpod.models.config import ConfigError, bounded, check_bounds, count, positive
from rpod.models.gimbal import gimbal_constraint_matrix
from rpod.planners import coupled_shooting as cs

_logger = logging.getLogger(__name__)

NX = cs.NX
QP_SOLVERS = ("osqp", "piqp")
# PIQP's statuses in OSQP's words (what run() and the outcome read).
_PIQP_STATUS = {
    piqp.PIQP_SOLVED: "solved",
    piqp.PIQP_MAX_ITER_REACHED: "maximum iterations reached",
    piqp.PIQP_PRIMAL_INFEASIBLE: "primal infeasible",
    piqp.PIQP_DUAL_INFEASIBLE: "dual infeasible",
}

_SCALES = np.concatenate(
    [
        np.ones(9),  # R_TC entries
        np.full(3, 1e-2),  # w_TC_T [rad/s]
        np.full(3, 10.0),  # p_PtPc_T [m]
        np.full(3, 0.1),  # v_PtPc_T [m/s]
        np.full(3, 1e3),  # xi_T [m s]
    ]
)
"""Typical magnitudes of the NLP state's entries near the goal; the QP is solved in x / scale."""
_INPUT_SCALE = 10.0  # N
_Y_ROWS = np.r_[9:12, 12:15, 18:21]
"""Stage-cost residual rows (w, p, xi) in the NLP state."""


@dataclasses.dataclass
class SqpSettings:
    """The algorithm's knobs (defaults chosen on Sec. IV's scenario; see the module docstring).

    Args:
        max_iterations: SQP iterations of a full solve from a warm start.
        cold_start_max_iterations: SQP iterations of a solve with no warm start (the first of
            a receding horizon, which starts from the zero-thrust rollout).
        step_tolerance: Converged when the scaled step's largest entry is below this (1e-3: 1 cm
            in p_PtPc_T, 0.01 N in a force; OSQP's accuracy where the LOS pyramid's apex and the
            gimbal pyramids' apexes make the QP degenerate does not allow much less) ...
        defect_tolerance: ... and every defect is below this (scaled by `_SCALES`: 1e-4 is 1 mm
            in p, 1e-6 rad/s in w; the QP's equality rows hold to OSQP's ~2e-5 there, and the
            RK4 transcription's own error against the true dynamics is ~1e-2) ...
        magnitude_tolerance_N: ... and no force exceeds f_max by more than this [N].
        acceptable_defect: At the iteration limit, a point whose largest scaled defect and
            force excess [N] are below this, and whose merit fell, is ACCEPTABLE (flown).
        regularization: mu of the Levenberg-Marquardt term (scaled variables).
        osqp_eps: OSQP's absolute and relative tolerances.
        rti_osqp_eps: The same for a real-time iteration's QP (RTI's step is inexact by design;
            at 1e-6 OSQP's ADMM took ~900 iterations, 24 ms, on the closed loop's QPs).
        osqp_max_iter: OSQP's iteration limit (PIQP's too).
        qp_solver: "osqp" (ADMM, warm-started from the last answer shifted one interval) or
            "piqp" (a proximal interior point: ~10-20 iterations whatever the QP's conditioning,
            where OSQP takes hundreds to thousands; issue 23). osqp_eps and rti_osqp_eps are
            then PIQP's absolute and relative tolerances.

    Bounds (rpod.models.config, checked by `validate()`): SQP iterations in [1, 10000] (the
    cold start's may be 0: then a cold solve stops at `max_iterations` too), each a full
    shooting pass and QP; tolerances in (0, 1] (scaled; magnitude_tolerance_N up to 1000 N);
    the regularization in [0, 1e9] (0: plain Gauss-Newton); OSQP at most 1e6 iterations.
    """

    max_iterations: int = count(50, 1, 10_000)
    cold_start_max_iterations: int = count(100, 0, 10_000)
    step_tolerance: float = positive(1e-3, 1.0)
    defect_tolerance: float = positive(1e-4, 1.0)
    magnitude_tolerance_N: float = positive(1e-3, 1e3)
    acceptable_defect: float = positive(1e-3, 1.0)
    regularization: float = bounded(1e-6, 0.0, 1e9)
    osqp_eps: float = positive(1e-6, 1.0)
    rti_osqp_eps: float = positive(1e-4, 1.0)
    osqp_max_iter: int = count(20000, 1, 1_000_000)
    qp_solver: str = "osqp"

    def validate(self) -> None:
        """Raises ConfigError naming the first field outside its declared bounds (or an unknown
        qp_solver)."""
        check_bounds(self)
        if self.qp_solver not in QP_SOLVERS:
            raise ConfigError("qp_solver", f"must be one of {QP_SOLVERS}, got {self.qp_solver!r}")


@dataclasses.dataclass
class SqpOutcome:
    """What `CoupledSqp.run` returns.

    Attributes:
        converged: The convergence test passed.
        qp_failed: The last QP was not solved (OSQP's status in `message`).
        message: A short account (OSQP's status on a failure).
        x: NLP-state nodes (N + 1, 21); u: inputs (N, m); s: LOS slacks (N + 1, 4).
        q: The stage costs of each interval (N,).
        iterations: SQP iterations taken; qp_iterations: OSQP iterations summed.
        max_defect: The largest scaled defect at the returned point.
        acceptable: Not converged, but the point's largest scaled defect and force excess
            are below `SqpSettings.acceptable_defect` and its merit is below the guess's.
    """

    converged: bool
    qp_failed: bool
    message: str
    x: np.ndarray
    u: np.ndarray
    s: np.ndarray
    q: np.ndarray
    iterations: int
    qp_iterations: int
    max_defect: float
    acceptable: bool = False


class CoupledSqp:
    """Gauss-Newton SQP / RTI on the RK4 multiple-shooting transcription (module docstring)."""

    def __init__(self, problem: cs.ShootingProblem, settings: SqpSettings | None = None):
        params, weights = problem.params, problem.weights
        self.params, self.weights = params, weights
        self.N, self.h = int(problem.intervals), float(problem.interval_s)
        self.substeps = int(problem.substeps)
        self.A_p = np.asarray(problem.A_p, dtype=float)
        self.rho = float(problem.los_slack_weight)
        self.w_max = float(problem.max_relative_rate_rad_s)
        self.settings = settings if settings is not None else SqpSettings()
        self.settings.validate()
        layout = params.layout
        self.nu, self.n_thrusters, self.gimbaled = params.input_size, layout.count, layout.gimbaled
        self.f_max = layout.max_thrusts_N
        self.directions = layout.directions_C
        if self.gimbaled:
            self.A_g, self.b_g = gimbal_constraint_matrix(layout)
        M_tau = cr._force_to_wrench_matrix(params)[:3]
        self.H_u = 2.0 * self.h * (np.asarray(weights.W_f) + M_tau.T @ weights.W_tau @ M_tau)
        self.Q_y = np.zeros((9, 9))
        self.Q_y[:3, :3], self.Q_y[3:6, 3:6], self.Q_y[6:, 6:] = (
            weights.Q_w,
            weights.Q_p,
            weights.Q_xi,
        )
        self.d_att = np.diag(np.asarray(weights.D, dtype=float))
        self._d_rows = np.repeat(self.d_att, 3)  # D's entry for each entry of R (row-major)
        self._L_y_T = np.linalg.cholesky(self.Q_y).T
        self._layout_indices()
        self._cost_indices()
        self._setup_solver()
        self._nu_merit = np.zeros(self.N * NX)
        self._nu_force = 0.0
        self._last_qp: tuple[np.ndarray, np.ndarray] | None = None
        self._shifted: tuple[np.ndarray, np.ndarray] | None = None

    # ------------------------------------------------------------------------------ layout

    def _layout_indices(self) -> None:
        N, n = self.N, self.n_thrusters
        self.n_u, self.n_x, self.n_s = N * self.nu, N * NX, N * 4
        self.nz = self.n_u + self.n_x + self.n_s
        self.D = np.concatenate(
            [np.full(self.n_u, _INPUT_SCALE), np.tile(_SCALES, N), np.ones(self.n_s)]
        )
        # Constraint rows: dynamics, gimbal, magnitude, cap, LOS, slack >= 0, rate box (a fixed
        # bank: no gimbal or magnitude rows, its box in the cap rows).
        gimbal, magnitude = (4 * n, n) if self.gimbaled else (0, 0)
        counts = [N * NX, N * gimbal, N * magnitude, N * n, N * 4, N * 4, N * 3]
        starts = np.concatenate([[0], np.cumsum(counts)])
        self.rows = {
            name: slice(starts[i], starts[i + 1])
            for i, name in enumerate(("dyn", "gimbal", "mag", "cap", "los", "slack", "rate"))
        }
        self.m = int(starts[-1])

    def _cost_indices(self) -> None:
        """Columns of [x_k; u_k] for k = 1..N-1 (N-1, 21 + m, 1) and of u_0 (m, 1)."""
        self._Hk_idx = np.stack(
            [np.concatenate([self.ix(k), self.iu(k)]) for k in range(1, self.N)]
        )[:, :, None]
        self._Hu0 = self.iu(0)[:, None]

    def iu(self, k: int) -> np.ndarray:
        return k * self.nu + np.arange(self.nu)

    def ix(self, k: int) -> np.ndarray:
        """Columns of x_k, k = 1..N."""
        return self.n_u + (k - 1) * NX + np.arange(NX)

    def i_s(self, k: int) -> np.ndarray:
        return self.n_u + self.n_x + (k - 1) * 4 + np.arange(4)

    def _pattern(self) -> tuple[np.ndarray, np.ndarray]:
        """Structural masks of P (upper triangle) and A: every entry any iteration may fill."""
        N = self.N
        P = np.zeros((self.nz, self.nz), dtype=bool)
        for k in range(N):
            cols = self.iu(k) if k == 0 else np.concatenate([self.ix(k), self.iu(k)])
            P[np.ix_(cols, cols)] = True
        P[np.ix_(self.ix(N), self.ix(N))] = True
        P[np.arange(self.nz), np.arange(self.nz)] = True
        A = self._constraint_matrix(
            np.ones((N, NX, NX)), np.ones((N, NX, self.nu)), np.ones((N, self.nu))
        )
        return np.triu(P), A.copy() != 0.0

    # ------------------------------------------------------------------------------ QP data

    def _constraint_matrix(self, A_dyn, B_dyn, u_bar) -> np.ndarray:
        """The dense constraint matrix in unscaled variables (the constant rows written once,
        the defects' A_k, B_k and eq. 17's linearisation written at each call)."""
        if not hasattr(self, "_A_dense"):
            self._A_dense = self._constant_rows()
        A = self._A_dense
        A[self._B_rows, self._B_cols] = -B_dyn
        A[self._Ad_rows, self._Ad_cols] = -A_dyn[1:]
        if self.gimbaled:
            A[self._mag_rows, self._mag_cols] = 2.0 * u_bar.reshape(self.N, self.n_thrusters, 3)
        return A

    def _constant_rows(self) -> np.ndarray:
        N, r, n = self.N, self.rows, self.n_thrusters
        A = np.zeros((self.m, self.nz))
        dyn_rows = r["dyn"].start + np.arange(N * NX).reshape(N, NX)
        self._B_rows = dyn_rows[:, :, None]
        self._B_cols = np.stack([self.iu(k) for k in range(N)])[:, None, :]
        self._Ad_rows = dyn_rows[1:, :, None]
        self._Ad_cols = np.stack([self.ix(k) for k in range(1, N)])[:, None, :]
        if self.gimbaled:
            self._mag_rows = (r["mag"].start + np.arange(N * n).reshape(N, n))[:, :, None]
            self._mag_cols = np.stack([self.iu(k).reshape(n, 3) for k in range(N)])
        for k in range(N):
            rows = dyn_rows[k]
            A[np.ix_(rows, self.ix(k + 1))] = np.eye(NX)
            if self.gimbaled:
                g_rows = r["gimbal"].start + 4 * n * k + np.arange(4 * n)
                A[np.ix_(g_rows, self.iu(k))] = self.A_g
                for j in range(n):
                    cols = self.iu(k)[3 * j : 3 * j + 3]
                    A[r["cap"].start + n * k + j, cols] = self.directions[j]
            else:  # the box 0 <= u_k <= f_max
                A[r["cap"].start + n * k + np.arange(n), self.iu(k)] = 1.0
            los_rows = r["los"].start + 4 * k + np.arange(4)
            A[np.ix_(los_rows, self.ix(k + 1)[12:15])] = self.A_p
            A[los_rows, self.i_s(k + 1)] = -1.0
            A[r["slack"].start + 4 * k + np.arange(4), self.i_s(k + 1)] = 1.0
            A[r["rate"].start + 3 * k + np.arange(3), self.ix(k + 1)[9:12]] = 1.0
        return A

    def _bounds(self, shooting, x_bar, u_bar) -> tuple[np.ndarray, np.ndarray]:
        N, r = self.N, self.rows
        lo = np.full(self.m, -np.inf)
        hi = np.zeros(self.m)
        rhs = shooting.x_end - np.einsum("kij,kj->ki", shooting.B, u_bar)
        rhs[1:] -= np.einsum("kij,kj->ki", shooting.A[1:], x_bar[1:N])
        lo[r["dyn"]] = hi[r["dyn"]] = rhs.reshape(-1)
        if self.gimbaled:
            hi[r["gimbal"]] = np.tile(self.b_g, N)
            f_bar = u_bar.reshape(N, self.n_thrusters, 3)
            hi[r["mag"]] = (self.f_max[None, :] ** 2 + np.sum(f_bar**2, axis=2)).reshape(-1)
        else:
            lo[r["cap"]] = 0.0
        hi[r["cap"]] = np.tile(self.f_max, N)
        lo[r["slack"]], hi[r["slack"]] = 0.0, np.inf
        lo[r["rate"]], hi[r["rate"]] = -self.w_max, self.w_max
        return lo, hi

    def _cost(self, shooting, x_bar, u_bar, mu) -> tuple[np.ndarray, np.ndarray]:
        """(H, grad): the Gauss-Newton Hessian model (with mu's term) and the objective's exact
        gradient at the guess, in unscaled variables."""
        N = self.N
        c = shooting.stage_weights
        J = shooting.stage_J  # (N, S, 21, 21 + m)
        # Residual Jacobians of the sums of squares, all stage points stacked: sqrt(2 c_j) L^T
        # G_y (Q_y = L L^T) and sqrt(Q_R c_j d) G_R (module docstring).
        Gy = np.einsum("ij,nsjz->nsiz", self._L_y_T, J[:, :, _Y_ROWS, :])
        Gy *= np.sqrt(2.0 * c)[None, :, None, None]
        GR = (
            J[:, :, :9, :] * np.sqrt(self.weights.Q_R * np.outer(c, self._d_rows))[None, :, :, None]
        )
        G = np.concatenate([Gy, GR], axis=2).reshape(N, -1, NX + self.nu)
        Hk = np.matmul(np.swapaxes(G, 1, 2), G)  # (N, 21 + m, 21 + m)
        Hk[:, NX:, NX:] += self.H_u
        gk = cs.cost_gradient(shooting, u_bar, self.weights, self.params)  # (N, 21 + m), exact
        self._interval_model = (Hk, gk)
        H = np.zeros((self.nz, self.nz))
        grad = np.zeros(self.nz)
        H[self._Hu0, self._Hu0.T] += Hk[0, NX:, NX:]
        grad[self.iu(0)] += gk[0, NX:]
        H[self._Hk_idx, np.swapaxes(self._Hk_idx, 1, 2)] += Hk[1:]
        np.add.at(grad, self._Hk_idx[:, :, 0], gk[1:])
        # Eq. 21 on [p_N; v_N].
        pv = self.ix(N)[12:18]
        P = np.asarray(self.weights.P)
        H[np.ix_(pv, pv)] += 2.0 * P
        grad[pv] += 2.0 * P @ x_bar[N, 12:18]
        grad[self.n_u + self.n_x :] += self.rho
        # Levenberg-Marquardt mu |(z - z_bar) / D|^2 (zero gradient at z_bar).
        H[np.arange(self.nz), np.arange(self.nz)] += 2.0 * mu / self.D**2
        return H, grad

    def _pack(self, x, u, s) -> np.ndarray:
        return np.concatenate([u.reshape(-1), x[1:].reshape(-1), s[1:].reshape(-1)])

    def _unpack(self, z, x0):
        N = self.N
        u = z[: self.n_u].reshape(N, self.nu)
        x = np.vstack([x0[None, :], z[self.n_u : self.n_u + self.n_x].reshape(N, NX)])
        s = z[self.n_u + self.n_x :].reshape(N, 4)
        return x, u, s

    # ------------------------------------------------------------------------------ solver

    def _setup_solver(self) -> None:
        P_mask, A_mask = self._pattern()
        self._P_index = np.nonzero(sp.csc_matrix(P_mask.astype(float)))
        self._A_index = np.nonzero(sp.csc_matrix(A_mask.astype(float)))
        P0 = sp.csc_matrix(P_mask.astype(float))
        A0 = sp.csc_matrix(A_mask.astype(float))
        # CSC order of the masks' entries, so values gathered from a dense matrix line up.
        self._P_rows, self._P_cols = _csc_entries(P0)
        self._A_rows, self._A_cols = _csc_entries(A0)
        self._P_scale = self.D[self._P_rows] * self.D[self._P_cols]
        # Rows in the units of the scaled variables: a defect row of state entry i is divided
        # by its scale, eq. 17's squared row by f_max^2, eq. 18's by the position scale.
        E = np.ones(self.m)
        E[self.rows["dyn"]] = 1.0 / np.tile(_SCALES, self.N)
        E[self.rows["mag"]] = 1.0 / np.max(self.f_max) ** 2
        E[self.rows["cap"]] = 1.0 / np.max(self.f_max)
        E[self.rows["los"]] = 1.0 / _SCALES[12]
        E[self.rows["rate"]] = 1.0 / _SCALES[9]
        self._row_scale = E
        self._A_scale = E[self._A_rows] * self.D[self._A_cols]
        if self.settings.qp_solver == "piqp":
            self._setup_piqp(P0, A0)
            return
        self._solver = osqp.OSQP()
        self._solver.setup(
            P=P0,
            q=np.zeros(self.nz),
            A=A0,
            l=np.full(self.m, -np.inf),
            u=np.full(self.m, np.inf),
            eps_abs=self.settings.osqp_eps,
            eps_rel=self.settings.osqp_eps,
            max_iter=self.settings.osqp_max_iter,
            polishing=True,
            warm_starting=True,
            adaptive_rho=True,
            verbose=False,
        )
        self._eps = self.settings.osqp_eps

    def _setup_piqp(self, P0, A0) -> None:
        """PIQP on the same scaled QP: P's upper triangle; the defect rows as equalities
        A_eq z = b, every other row as h_l <= G z <= h_u (values gathered per solve)."""
        upper = sp.triu(P0, format="csc")
        self._P_upper_rows, self._P_upper_cols = _csc_entries(upper)
        self._P_upper_scale = self.D[self._P_upper_rows] * self.D[self._P_upper_cols]
        dyn = np.zeros(self.m, dtype=bool)
        dyn[self.rows["dyn"]] = True
        self._eq_rows, self._ineq_rows = np.flatnonzero(dyn), np.flatnonzero(~dyn)
        A_eq, G = A0[self._eq_rows].tocsc(), A0[self._ineq_rows].tocsc()
        self._eq_entries, self._g_entries = _csc_entries(A_eq), _csc_entries(G)
        self._P_piqp, self._A_eq, self._G = upper, A_eq, G
        self._solver = piqp.SparseSolver()
        self._solver.settings.verbose = False
        self._solver.settings.max_iter = int(self.settings.osqp_max_iter)
        self._eps = None  # set by run()
        self._piqp_ready = False

    def _piqp(self, H, g, A, lo, hi):
        """One PIQP solve of the scaled QP; (status, z, y, iterations) as `_osqp` returns."""
        D, E = self.D, self._row_scale
        sigma = 1.0 / max(1.0, float(np.max(np.abs(g * D))))
        self._P_piqp.data[:] = H[self._P_upper_rows, self._P_upper_cols] * (
            self._P_upper_scale * sigma
        )
        eq_rows, g_rows = self._eq_rows, self._ineq_rows
        rows, cols = self._eq_entries
        self._A_eq.data[:] = A[eq_rows[rows], cols] * E[eq_rows[rows]] * D[cols]
        rows, cols = self._g_entries
        self._G.data[:] = A[g_rows[rows], cols] * E[g_rows[rows]] * D[cols]
        data = {
            "P": self._P_piqp,
            "c": g * D * sigma,
            "A": self._A_eq,
            "b": lo[eq_rows] * E[eq_rows],
            "G": self._G,
            "h_l": lo[g_rows] * E[g_rows],
            "h_u": hi[g_rows] * E[g_rows],
        }
        if self._piqp_ready:
            self._solver.update(**data)
        else:
            self._solver.setup(**data)
            self._piqp_ready = True
        status = _PIQP_STATUS.get(self._solver.solve(), "piqp failed")
        result = self._solver.result
        iterations = int(result.info.iter)
        x = np.asarray(result.x, dtype=float)
        if status != "solved" or not np.all(np.isfinite(x)):
            return status, None, None, iterations
        y = np.zeros(self.m)
        y[eq_rows] = np.asarray(result.y, dtype=float)
        y[g_rows] = np.asarray(result.z_u, dtype=float) - np.asarray(result.z_l, dtype=float)
        z = x * D
        y = y * E / sigma
        self._last_qp = (z, y)
        return status, z, y, iterations

    def _solve_qp(self, H, g, A, lo, hi):
        """Solves the QP in scaled variables z = D z_s; returns (status, z, y, iterations).

        A linearisation with a non-finite number is refused before it reaches OSQP; an OSQP
        error leaves the solver rebuilt for the next call."""
        if not (
            np.all(np.isfinite(H)) and np.all(np.isfinite(g)) and np.all(np.isfinite(A))
        ) or np.any(np.isnan(lo) | np.isnan(hi)):
            return "non-finite linearisation", None, None, 0
        try:
            if self.settings.qp_solver == "piqp":
                return self._piqp(H, g, A, lo, hi)
            return self._osqp(H, g, A, lo, hi)
        except (ValueError, RuntimeError) as error:  # the solver's data validation
            self._setup_solver()
            return f"{self.settings.qp_solver} error: {error}", None, None, 0

    def _osqp(self, H, g, A, lo, hi):
        D, E = self.D, self._row_scale
        # The objective in units where its gradient is O(1) (OSQP's tolerances are absolute
        # and relative to the norms of P z and q).
        sigma = 1.0 / max(1.0, float(np.max(np.abs(g * D))))
        self._solver.update(
            Px=H[self._P_rows, self._P_cols] * (self._P_scale * sigma),
            Ax=A[self._A_rows, self._A_cols] * self._A_scale,
            q=g * D * sigma,
            l=lo * E,
            u=hi * E,
        )
        if self._shifted is not None:  # the previous solve's answer, one interval on
            z_guess, y_guess = self._shifted
            self._solver.warm_start(x=z_guess / D, y=y_guess * sigma / E)
            self._shifted = None
        result = self._solver.solve()
        status = result.info.status
        _logger.debug(
            "OSQP %s in %d iterations, polish %d",
            status,
            result.info.iter,
            result.info.status_polish,
        )
        if result.x is None or not np.all(np.isfinite(result.x)):
            return status, None, None, int(result.info.iter)
        # Independent check of the returned point against this call's data: OSQP's update
        # reports bad data (it keeps the previous data) only on its console. Tolerance: well
        # above what OSQP's own eps allows (a solve of other data misses by O(1)).
        Az = A @ (result.x * D)
        violation = float(np.max(np.maximum(np.maximum(lo - Az, Az - hi), 0.0) * E))
        if violation > max(1e-2, 1e2 * self._eps):
            self._setup_solver()
            return f"{status}, but rows violated by {violation:.2g} (scaled)", None, None, 0
        z = result.x * D
        y = result.y * E / sigma
        self._last_qp = (z, y)
        return status, z, y, int(result.info.iter)

    def _shift(self, z: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """A QP answer moved one interval on (the receding horizon's shift): every block of
        variables and of constraint rows, interval k <- k + 1, the last one repeated. The QP is
        in absolute variables, so this is the next step's natural guess for OSQP."""
        N = self.N

        def shifted(v: np.ndarray) -> np.ndarray:
            v = v.reshape(N, -1)
            return np.vstack([v[1:], v[-1:]]).reshape(-1)

        z_new = np.concatenate(
            [
                shifted(z[: self.n_u]),
                shifted(z[self.n_u : self.n_u + self.n_x]),
                shifted(z[self.n_u + self.n_x :]),
            ]
        )
        y_new = np.concatenate([shifted(y[rows]) for rows in self.rows.values()])
        return z_new, y_new

    # ------------------------------------------------------------------------------ merit

    @staticmethod
    def _defects(shooting, x) -> np.ndarray:
        """Phi(x_k, u_k) - x_k+1 (N, 21), unscaled."""
        return shooting.x_end - x[1:]

    def _objective(self, shooting, x, s) -> float:
        pv = x[self.N, 12:18]
        return float(
            np.sum(shooting.q) + pv @ np.asarray(self.weights.P) @ pv + self.rho * np.sum(s)
        )

    def _merit(self, shooting, x, u, s) -> float:
        """The l1 merit: objective + nu |defects|_1 + nu_f sum (|f| - f_max)+."""
        return (
            self._objective(shooting, x, s)
            + float(self._nu_merit @ np.abs(self._defects(shooting, x)).reshape(-1))
            + self._nu_force * float(np.sum(self._magnitude_excess(u)))
        )

    def _infeasibility(self, shooting, x, u) -> float:
        """The largest scaled defect or force excess [N]: what the filter rule compares."""
        return max(
            float(np.max(np.abs(self._defects(shooting, x)) / _SCALES)),
            float(np.max(self._magnitude_excess(u))),
        )

    def _magnitude_excess(self, u) -> np.ndarray:
        """How far each force is beyond its limits [N]: |f_k| - f_max, or on a fixed bank
        outside [0, f_max]."""
        if not self.gimbaled:
            thrust = u.reshape(self.N, self.n_thrusters)
            return np.maximum(np.maximum(thrust - self.f_max[None, :], -thrust), 0.0)
        f = np.linalg.norm(u.reshape(self.N, self.n_thrusters, 3), axis=2)
        return np.maximum(f - self.f_max[None, :], 0.0)

    def _shoot(self, x, u, target_nodes, derivatives):
        return cs.shoot(
            x, u, target_nodes, self.h, self.substeps, self.params, self.weights, derivatives
        )

    # ------------------------------------------------------------------------------ run

    def run(
        self, x0, x_guess, u_guess, s_guess, target_nodes, real_time: bool, cold: bool = False
    ) -> SqpOutcome:
        """SQP from a guess (module docstring); real_time: one iteration, no line search.

        Args:
            x0: The NLP state at t (21,) (x_guess[0] is replaced by it).
            x_guess, u_guess, s_guess: The guess (N + 1, 21), (N, m), (N + 1, 4).
            target_nodes: The target's reference nodes (N + 1, 18).
        """
        st = self.settings
        self._nu_merit = np.zeros(self.N * NX)
        self._nu_force = 0.0
        # OSQP starts from the last QP's answer shifted one interval (a warm-started solve is
        # the next step of a receding horizon); a cold solve from OSQP's own last iterate.
        self._shifted = None if cold or self._last_qp is None else self._shift(*self._last_qp)
        x = np.asarray(x_guess, dtype=float).copy()
        x[0] = x0
        u = np.asarray(u_guess, dtype=float).copy()
        s = np.asarray(s_guess, dtype=float).copy()
        s[0] = np.maximum(self.A_p @ x0[12:15], 0.0)  # x_0 is data: its least slacks
        s[1:] = np.maximum(s[1:], np.maximum(x[1:, 12:15] @ self.A_p.T, 0.0))
        shooting = self._shoot(x, u, target_nodes, derivatives=True)
        start = (shooting, x, u, s)
        qp_iterations, message = 0, ""
        eps = st.rti_osqp_eps if real_time else st.osqp_eps
        if eps != self._eps and st.qp_solver == "piqp":
            self._solver.settings.eps_abs = self._solver.settings.eps_rel = eps
            self._eps = eps
        elif eps != self._eps:  # RTI: a looser QP and no polish (its step is inexact anyway)
            self._solver.update_settings(eps_abs=eps, eps_rel=eps, polishing=not real_time)
            self._eps = eps
        max_iterations = 1 if real_time else st.max_iterations
        if cold and not real_time:
            max_iterations = max(max_iterations, st.cold_start_max_iterations)
        converged = False
        for iteration in range(1, max_iterations + 1):
            H, grad = self._cost(shooting, x, u, st.regularization)
            z_bar = self._pack(x, u, s)
            A = self._constraint_matrix(shooting.A, shooting.B, u)
            lo, hi = self._bounds(shooting, x, u)
            status, z, y, qp_iters = self._solve_qp(H, grad - H @ z_bar, A, lo, hi)
            qp_iterations += qp_iters
            if status not in ("solved", "solved inaccurate") or z is None:
                out = self._outcome(
                    False, True, f"QP: {status}", x, u, s, shooting, iteration, qp_iterations
                )
                if iteration > 1:  # the current iterate may still be worth flying
                    out.acceptable = self._acceptable(start, shooting, x, u, s)
                return out
            x_new, u_new, s_new = self._unpack(z, x0)
            s_new = np.vstack([s[:1], s_new])
            if real_time:
                # No second pass through the dynamics: the stage costs the QP's model predicts.
                dz = np.concatenate([x_new[:-1] - x[:-1], u_new - u], axis=1)
                dz[0, :NX] = 0.0
                Hk, gk = self._interval_model
                q = shooting.q + np.einsum("kz,kz->k", gk, dz)
                q += 0.5 * np.einsum("kz,kzw,kw->k", dz, Hk, dz)
                predicted = dataclasses.replace(shooting, q=q)
                out = self._outcome(
                    False, False, "rti step", x_new, u_new, s_new, predicted, 1, qp_iterations
                )
                out.max_defect = math.nan  # not evaluated: the next step's linearisation will
                return out
            delta = self._pack(x_new, u_new, s_new) - z_bar
            dx, du, ds = x_new - x, u_new - u, s_new - s

            # Line search on the l1 merit phi = J + nu |defects|_1 + nu_f sum (|f| - f_max)+,
            # nu from the QP's multipliers of the defects (kept non-decreasing).
            self._nu_merit = np.maximum(self._nu_merit, 1.5 * np.abs(y[self.rows["dyn"]]))
            # d|f|^2 / d|f| = 2 |f|: the multiplier of the squared row times 2 f_max per N (a
            # fixed bank's box is linear and exact: every trial point keeps it).
            if self.gimbaled:
                self._nu_force = max(
                    self._nu_force,
                    3.0 * float(np.max(self.f_max)) * float(np.max(np.abs(y[self.rows["mag"]]))),
                )
            phi0 = self._merit(shooting, x, u, s)
            slope = float(grad @ delta) - float(
                self._nu_merit @ np.abs(self._defects(shooting, x)).reshape(-1)
            )
            f0, h0 = self._objective(shooting, x, s), self._infeasibility(shooting, x, u)
            alpha, accepted = 1.0, False
            for _ in range(10):
                xt, ut, s_t = x + alpha * dx, u + alpha * du, s + alpha * ds
                trial = self._shoot(xt, ut, target_nodes, derivatives=False)
                # Armijo on the merit, or (against the Maratos effect near a solution, where
                # the l1 merit can refuse a good full step) a clear gain in feasibility at a
                # negligible cost in objective (a filter-like rule).
                h_t = self._infeasibility(trial, xt, ut)
                f_t = self._objective(trial, xt, s_t)
                if self._merit(trial, xt, ut, s_t) <= phi0 + 1e-4 * alpha * min(slope, 0.0) or (
                    h_t <= 0.5 * h0 and f_t <= f0 + 1e-9 * max(1.0, abs(f0))
                ):
                    accepted = True
                    break
                alpha *= 0.5
            x, u, s = xt, ut, s_t
            step = float(np.max(np.abs(alpha * delta) / self.D))
            shooting = self._shoot(x, u, target_nodes, derivatives=True)
            max_defect = float(np.max(np.abs(self._defects(shooting, x)) / _SCALES))
            excess = float(np.max(self._magnitude_excess(u)))
            message = (
                f"iteration {iteration}: alpha {alpha:.3g}, step {step:.2e}, scaled defect"
                f" {max_defect:.2e}, |f| excess {excess:.2e} N"
            )
            _logger.debug("%s, accepted %s", message, accepted)
            if (
                step < st.step_tolerance
                and max_defect < st.defect_tolerance
                and excess < st.magnitude_tolerance_N
            ):
                converged = True
                break
        out = self._outcome(converged, False, message, x, u, s, shooting, iteration, qp_iterations)
        out.acceptable = not converged and self._acceptable(start, shooting, x, u, s)
        return out

    def _acceptable(self, start, shooting, x, u, s) -> bool:
        """Feasible to `acceptable_defect` and better than the guess on the merit."""
        return self._infeasibility(shooting, x, u) < self.settings.acceptable_defect and (
            self._merit(shooting, x, u, s) <= self._merit(*start)
        )

    def _outcome(self, converged, qp_failed, message, x, u, s, shooting, iterations, qp_iters):
        return SqpOutcome(
            converged=converged,
            qp_failed=qp_failed,
            message=message,
            x=x,
            u=u,
            s=s,
            q=shooting.q.copy(),
            iterations=iterations,
            qp_iterations=qp_iters,
            max_defect=float(np.max(np.abs(self._defects(shooting, x)) / _SCALES)),
        )


def _csc_entries(M: sp.csc_matrix) -> tuple[np.ndarray, np.ndarray]:
    """(rows, cols) of a CSC matrix's stored entries, in storage order."""
    cols = np.repeat(np.arange(M.shape[1]), np.diff(M.indptr))
    return M.indices.copy(), cols
