"""Differentiable collision metric between two posed convex polytopes (paper 000 Sec. II-B).

Owns: the scaling ("inflation") metric alpha of DCOL (Tracy, Howell and Manchester, paper 000
ref. [17]) for two polytopes, written as one Drake ``MathematicalProgram`` per polytope pair, and
its exact gradient with respect to both poses from the LP's duals. Does not own: the polytopes
themselves (``rpod.models.shapes``), the Euclidean distance (``shapes.separation_distance``, an
independent computation the tests compare against), or the linearised constraint (25) of the
soft-capture SCP (``rpod.planners.soft_capture``).

Metric. Polytope a is ``{y_a : A_a y_a <= b_a}`` in its body frame a, posed in the common frame
W by ``(R_Wa, p_Wa)`` (``p_WQ = p_Wa + R_Wa y_a``); likewise b. Scaling a polytope uniformly by
alpha about its own origin turns ``b`` into ``alpha b``. alpha is the smallest such common
scaling at which the two scaled bodies share a point p (an LP in (p, alpha)):

    alpha = min alpha  s.t.  A_a R_Wa^T (p - p_Wa) <= alpha b_a,
                             A_b R_Wb^T (p - p_Wb) <= alpha b_b.

alpha > 1: separated (they would have to grow to touch); alpha = 1: touching; alpha < 1:
penetrating (paper 000: collision is detected if alpha < 1, constraint (15) asks alpha >
alpha_min > 1). It requires ``b > 0`` (each body's origin strictly inside it) and bounded
polytopes; then alpha >= 0, with alpha = 0 only when the origins coincide. The program's
variable is ``y = p - p_Wa`` (the touching point relative to a's origin, expressed in W) rather
than p: the same LP, but it sees only the difference ``p_Wb - p_Wa`` (exact translation
invariance, no loss of digits when the bodies are far from W's origin).

Gradient (envelope theorem). With multipliers ``lam_a, lam_b >= 0`` of the two constraint
blocks at the optimum, alpha's derivative with respect to any pose parameter is that of the
Lagrangian ``alpha + lam_a^T (A_a R_Wa^T (p - p_Wa) - alpha b_a) + lam_b^T (...)`` at fixed
(p, alpha). With ``g_a = R_Wa A_a^T lam_a`` and ``g_b = R_Wb A_b^T lam_b`` (world vectors; the
LP's stationarity in p gives ``g_a + g_b = 0``):

    d alpha / d p_Wa     = -g_a,                 d alpha / d p_Wb     = -g_b,
    d alpha / d theta_a  =  g_a x (p - p_Wa),    d alpha / d theta_b  =  g_b x (p - p_Wb),

where theta_a is a small rotation vector expressed in W applied on the left,
``R_Wa -> exp([theta_a]x) R_Wa``, i.e. body a turns about its own origin (p_Wa held fixed) by
theta_a measured in W (``R^T exp(-[theta]x) = R^T (I - [theta]x) + O(theta^2)`` gives the
cross products). So, for a body turning at angular velocity ``w_Wa_W`` (expressed in W),
``d alpha / dt = (d alpha / d theta_a) . w_Wa_W``; for a body-frame rate ``w_Wa_a`` use
``R_Wa w_Wa_a``. The formulas hold wherever the LP's dual is unique, which is the generic case;
where it is not (e.g. two faces exactly parallel at contact) alpha has a kink, and the
interior-point dual returned is the centre of the optimal dual set, a convex combination of the
one-sided gradients.

Solver: ``ClarabelSolver`` (interior point, from pydrake.solvers, named explicitly) with its gap
and feasibility tolerances at 1e-12, as ``shapes.separation_distance`` uses it. Why not
``ClpSolver`` (simplex, exact basic solutions): measured in one run over 200 random poses of
the paper's hulls, update + Clarabel solve takes ~76 us and update + Clp solve ~130 us (both
mostly Drake's per-solve translation); a whole ``evaluate`` (input checks, duals, KKT re-check,
gradients) takes ~160 us with Clarabel. Over 9,000 random poses (1 mm to 200 m apart) Clarabel
met every tolerance and matched Clp's exact solution to 3e-10 relative in alpha and 1e-8 in the
gradient. At a degenerate pose the interior-point dual is the centre of the optimal dual face,
an average of the one-sided gradients, rather than an arbitrary vertex of it. Every solution is
re-checked (primal feasibility, dual feasibility, stationarity, zero duality gap, 1e-8
relative) before it is returned; a failure of the check or of the solver is reported by
``status``, never raised.

Not thread-safe: a program holds its data between ``evaluate`` calls, and ``scaling_metric``
shares a module-level cache (separate processes, as in campaigns, are fine).
"""

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from pydrake.math import RotationMatrix
from pydrake.solvers import ClarabelSolver, MathematicalProgram, SolverOptions

from rpod.models.frames import cross
from rpod.models.shapes import ConvexPolytope, halfspaces_are_bounded

# Clarabel's gap and feasibility tolerances; alpha then agrees with an exact simplex solution to
# ~3e-10 relative (module docstring) at ~7% more time than Clarabel's 1e-8 defaults.
_SOLVER_TOLERANCE = 1e-12
# Relative tolerance of the KKT re-check of every LP solution. The solver meets it at ~1e-12;
# 1e-8 flags a wrong answer long before it matters to a metre-scale geometry.
_KKT_RTOL = 1e-8
# Tolerance on orthonormality of a rotation argument (interpolated attitudes are normalised
# quaternions, good to ~1e-15; 1e-6 catches a transposed or unnormalised matrix).
_ROTATION_TOL = 1e-6
_IDENTITY = np.eye(3)


@dataclass
class ScalingMetric:
    """The scaling metric alpha of two posed polytopes and its gradient (paper 000 Sec. II-B).

    All gradients are with respect to quantities expressed in the common frame W. When
    ``status != "ok"``, ``alpha`` and every gradient entry are NaN.

    Attributes:
        alpha: Smallest uniform scaling of both polytopes about their own origins at which they
            touch: > 1 separated, 1 touching, < 1 penetrating.
        status: ``"ok"``; ``"non_finite_pose"`` (a NaN or inf pose, the solver is not called);
            ``"inaccurate_solution"`` (the solver's answer failed the KKT re-check); or the
            solver's word (the ``SolutionResult`` name, e.g. ``"kUnbounded"``, or
            ``"solver_error: ..."`` if the solver threw).
        d_alpha_d_p_a: d alpha / d p_Wa (3,) [1/m], position of a's origin in W.
        d_alpha_d_theta_a: d alpha / d theta_a (3,) [1/rad], theta_a a rotation vector in W
            applied on the left, ``R_Wa -> exp([theta_a]x) R_Wa`` (a turns about its origin).
        d_alpha_d_p_b: d alpha / d p_Wb (3,) [1/m]; equals ``-d_alpha_d_p_a``.
        d_alpha_d_theta_b: d alpha / d theta_b (3,) [1/rad], ``R_Wb -> exp([theta_b]x) R_Wb``.
    """

    alpha: float
    status: str
    d_alpha_d_p_a: np.ndarray
    d_alpha_d_theta_a: np.ndarray
    d_alpha_d_p_b: np.ndarray
    d_alpha_d_theta_b: np.ndarray

    @classmethod
    def failed(cls, status: str) -> "ScalingMetric":
        """A result with NaN value and gradients and the given status."""
        nan3 = np.full(3, np.nan)
        return cls(np.nan, status, nan3, nan3.copy(), nan3.copy(), nan3.copy())


def _validate_for_scaling(polytope: ConvexPolytope, name: str) -> None:
    if not isinstance(polytope, ConvexPolytope):
        raise TypeError(f"{name} must be a ConvexPolytope, got {type(polytope).__name__}")
    if not np.all(polytope.b > 0.0):
        raise ValueError(
            f"{name}: the scaling metric needs b > 0 (body origin strictly inside), "
            f"got min(b) = {float(np.min(polytope.b))}"
        )
    if not halfspaces_are_bounded(polytope.A):
        raise ValueError(f"{name}: the halfspaces A y <= b are unbounded")


def _as_rotation_array(R, name: str) -> np.ndarray:
    if isinstance(R, RotationMatrix):
        return R.matrix()
    R = np.asarray(R, dtype=float)
    if R.shape != (3, 3):
        raise ValueError(f"{name} must be a RotationMatrix or a 3x3 array, got shape {R.shape}")
    return R


@dataclass
class _Batch:
    """ScalingMetricProgram.evaluate_many's program for K pose pairs and its CSR pattern."""

    prog: MathematicalProgram
    constraint: object
    values: np.ndarray  # CSR data, K blocks of [M_k, -b] row by row
    indices: np.ndarray
    indptr: np.ndarray
    y_entries: np.ndarray  # which entries of values hold M_k (the rest: the fixed -b)
    shape: tuple[int, int]
    lower: np.ndarray


class ScalingMetricProgram:
    """The scaling-metric LP for one pair of polytopes, built once and re-solved per pose.

    The program has the variables ``x = [y, alpha]`` (``y = p - p_Wa``, expressed in W) and two
    vectorised linear-constraint blocks, ``[A_a R_Wa^T, -b_a] x <= 0`` and
    ``[A_b R_Wb^T, -b_b] x <= A_b R_Wb^T (p_Wb - p_Wa)``; ``evaluate`` only rewrites their
    coefficients and upper bounds (``UpdateCoefficients``) and solves with ``ClarabelSolver``
    (module docstring: why).

    Args:
        polytope_a: Body a, in its frame a; ``b > 0`` and bounded.
        polytope_b: Body b, in its frame b; ``b > 0`` and bounded.

    Raises:
        ValueError: If a polytope does not contain its origin strictly or is unbounded.
    """

    def __init__(self, polytope_a: ConvexPolytope, polytope_b: ConvexPolytope):
        _validate_for_scaling(polytope_a, "polytope_a")
        _validate_for_scaling(polytope_b, "polytope_b")
        self.polytope_a = polytope_a
        self.polytope_b = polytope_b
        self._A_a, self._b_a = polytope_a.A, polytope_a.b
        self._A_b, self._b_b = polytope_b.A, polytope_b.b
        m_a, m_b = len(self._b_a), len(self._b_b)

        self.prog = MathematicalProgram()
        self._x = self.prog.NewContinuousVariables(4, "y_alpha")
        self.prog.AddLinearCost(np.array([0.0, 0.0, 0.0, 1.0]), 0.0, self._x)  # min alpha
        # Coefficient buffer [M_a; M_b] of both blocks (views into one array, so the KKT check
        # runs on the stack): the last column (-b) is fixed, the first three are set per pose.
        self._M = np.column_stack(
            [np.vstack([self._A_a, self._A_b]), -np.concatenate([self._b_a, self._b_b])]
        )
        self._M_a, self._M_b = self._M[:m_a], self._M[m_a:]
        self._h = np.zeros(m_a + m_b)  # stacked upper bounds [0; h_b]
        self._m_a = m_a
        # Scales of the KKT re-check: sum(lam * b) = 1 bounds every multiplier by 1 / min(b).
        self._lam_scale = 1.0 / min(self._b_a.min(), self._b_b.min())
        self._b_max = max(self._b_a.max(), self._b_b.max())
        self._row_norm_max = float(np.linalg.norm(self._M[:, :3], axis=1).max())
        self._lower_a = np.full(m_a, -np.inf)
        self._lower_b = np.full(m_b, -np.inf)
        self._upper_a = np.zeros(m_a)
        # Paper 000 Sec. II-B (DCOL): both scaled polytopes contain the point p.
        self._constraint_a = self.prog.AddLinearConstraint(
            self._M_a, self._lower_a, self._upper_a, self._x
        )
        self._constraint_b = self.prog.AddLinearConstraint(
            self._M_b, self._lower_b, np.zeros(m_b), self._x
        )
        self._batches: dict[int, _Batch] = {}  # evaluate_many's programs, by K
        self._solver = ClarabelSolver()
        self._options = SolverOptions()
        for name in ("tol_gap_abs", "tol_gap_rel", "tol_feas"):
            self._options.SetOption(ClarabelSolver.id(), name, _SOLVER_TOLERANCE)

    def evaluate(self, R_a, p_a, R_b, p_b) -> ScalingMetric:
        """Solves the LP at one pair of poses and returns alpha and its gradients.

        Args:
            R_a: ``R_Wa``, orientation of a in W (``RotationMatrix`` or 3x3 array).
            p_a: ``p_Wa`` (3,), a's origin in W [m].
            R_b: ``R_Wb``, orientation of b in W.
            p_b: ``p_Wb`` (3,), b's origin in W [m].

        Returns:
            The metric; ``status != "ok"`` (and NaNs) on a non-finite pose or a solver failure.

        Raises:
            ValueError: If an argument has the wrong shape or a rotation is not orthonormal
                (programming errors, not solver failures).
        """
        R_a = _as_rotation_array(R_a, "R_a")
        R_b = _as_rotation_array(R_b, "R_b")
        p_a = np.asarray(p_a, dtype=float).reshape(-1)
        p_b = np.asarray(p_b, dtype=float).reshape(-1)
        if p_a.shape != (3,) or p_b.shape != (3,):
            raise ValueError(f"p_a and p_b must have 3 entries, got {p_a.shape}, {p_b.shape}")
        if not np.isfinite(R_a.sum() + R_b.sum() + p_a.sum() + p_b.sum()):  # any NaN or inf
            return ScalingMetric.failed("non_finite_pose")
        if (
            np.abs(R_a.T @ R_a - _IDENTITY).max() > _ROTATION_TOL
            or np.abs(R_b.T @ R_b - _IDENTITY).max() > _ROTATION_TOL
        ):
            raise ValueError("R_a and R_b must be rotation matrices (orthonormal)")

        d = p_b - p_a  # p_Wb - p_Wa, expressed in W
        AR_a = self._A_a @ R_a.T  # A_a R_Wa^T
        AR_b = self._A_b @ R_b.T
        h_b = AR_b @ d
        self._M_a[:, :3] = AR_a
        self._M_b[:, :3] = AR_b
        self._constraint_a.evaluator().UpdateCoefficients(self._M_a, self._lower_a, self._upper_a)
        self._constraint_b.evaluator().UpdateCoefficients(self._M_b, self._lower_b, h_b)
        try:
            result = self._solver.Solve(self.prog, None, self._options)
        except RuntimeError as error:  # Drake reports solver-internal errors this way
            return ScalingMetric.failed(f"solver_error: {error}")
        if not result.is_success():
            return ScalingMetric.failed(result.get_solution_result().name)

        x = result.get_x_val()  # [y, alpha]: the program's only decision variables, in order
        y, alpha = x[:3], float(x[3])
        # Drake's dual is d(cost)/d(bound): <= 0 on an active upper bound. lam = -dual >= 0.
        lam_a = -result.GetDualSolution(self._constraint_a)
        lam_b = -result.GetDualSolution(self._constraint_b)
        if not self._kkt_holds(x, lam_a, lam_b, h_b, alpha):
            return ScalingMetric.failed("inaccurate_solution")

        g_a = R_a @ (self._A_a.T @ lam_a)  # R_Wa A_a^T lam_a, in W
        g_b = R_b @ (self._A_b.T @ lam_b)
        return ScalingMetric(
            alpha=alpha,
            status="ok",
            d_alpha_d_p_a=-g_a,
            d_alpha_d_theta_a=cross(g_a, y),  # y = p - p_Wa
            d_alpha_d_p_b=-g_b,
            d_alpha_d_theta_b=cross(g_b, y - d),  # y - d = p - p_Wb
        )

    def evaluate_many(self, R_a, p_a, R_b, p_b) -> list[ScalingMetric]:
        """``evaluate`` at K pairs of poses (arrays (K, 3, 3), (K, 3), (K, 3, 3), (K, 3)), as
        one LP: the K programs side by side (block-diagonal rows, the cost sum(alpha_k)),
        which separates into the K LPs, so its solution is theirs. One solve instead of K
        (issue 23: the SCP's linearisation was ~0.4 ms a knot, Drake's per-solve translation).

        Every block is re-checked as `evaluate` checks its LP (the combined gap tolerance,
        1e-12 absolute, bounds each block's gap); a pose that is not finite or a block that
        fails the check is evaluated on its own, so the results are `evaluate`'s to its
        tolerances.
        """
        R_a, R_b = np.asarray(R_a, float), np.asarray(R_b, float)
        p_a, p_b = np.asarray(p_a, float), np.asarray(p_b, float)
        K = len(p_a)
        if R_a.shape != (K, 3, 3) or R_b.shape != (K, 3, 3) or p_b.shape != (K, 3):
            raise ValueError("R_a, p_a, R_b, p_b must be (K, 3, 3), (K, 3), (K, 3, 3), (K, 3)")
        finite = np.isfinite(R_a.sum(axis=(1, 2)) + R_b.sum(axis=(1, 2)))
        finite &= np.isfinite(p_a.sum(axis=1) + p_b.sum(axis=1))
        if K < 2 or not finite.all():
            return [self.evaluate(R_a[k], p_a[k], R_b[k], p_b[k]) for k in range(K)]
        for R, name in ((R_a, "R_a"), (R_b, "R_b")):
            gram = np.einsum("kji,kjl->kil", R, R) - _IDENTITY
            if np.abs(gram).max() > _ROTATION_TOL:
                raise ValueError(f"{name} must hold rotation matrices (orthonormal)")
        batch = self._batch(K)
        d = p_b - p_a
        AR_a = np.einsum("ij,klj->kil", self._A_a, R_a)  # A_a R_Wa^T, per knot
        AR_b = np.einsum("ij,klj->kil", self._A_b, R_b)
        h_b = np.einsum("kij,kj->ki", AR_b, d)
        M = np.concatenate([AR_a, AR_b], axis=1)  # (K, m, 3); the alpha column is fixed
        batch.values[batch.y_entries] = M.reshape(-1)
        A = sp.csr_matrix((batch.values, batch.indices, batch.indptr), shape=batch.shape)
        upper = np.concatenate([np.zeros((K, self._m_a)), h_b], axis=1).reshape(-1)
        batch.constraint.evaluator().UpdateCoefficients(A, batch.lower, upper)
        try:
            result = self._solver.Solve(batch.prog, None, self._options)
        except RuntimeError:
            result = None
        if result is None or not result.is_success():
            return [self.evaluate(R_a[k], p_a[k], R_b[k], p_b[k]) for k in range(K)]
        x = result.get_x_val().reshape(K, 4)
        lam = -result.GetDualSolution(batch.constraint).reshape(K, -1)
        lam_a, lam_b = lam[:, : self._m_a], lam[:, self._m_a :]
        alpha, y = x[:, 3], x[:, :3]
        good = self._kkt_holds_many(M, x, lam, h_b)
        g_a = np.einsum("kij,mi,km->kj", R_a.transpose(0, 2, 1), self._A_a, lam_a)
        g_b = np.einsum("kij,mi,km->kj", R_b.transpose(0, 2, 1), self._A_b, lam_b)
        theta_a, theta_b = np.cross(g_a, y), np.cross(g_b, y - d)
        return [
            ScalingMetric(
                alpha=float(alpha[k]),
                status="ok",
                d_alpha_d_p_a=-g_a[k],
                d_alpha_d_theta_a=theta_a[k],  # g_a x (p - p_Wa)
                d_alpha_d_p_b=-g_b[k],
                d_alpha_d_theta_b=theta_b[k],  # g_b x (p - p_Wb)
            )
            if good[k]
            else self.evaluate(R_a[k], p_a[k], R_b[k], p_b[k])
            for k in range(K)
        ]

    def _kkt_holds_many(self, M, x, lam, h_b) -> np.ndarray:
        """`_kkt_holds` for K blocks at once: M (K, m, 3), x (K, 4), lam (K, m), h_b (K, m_b)."""
        K = len(x)
        b = self._M[:, 3]  # the fixed column -[b_a; b_b]
        h = np.concatenate([np.zeros((K, self._m_a)), h_b], axis=1)
        alpha = x[:, 3]
        length = 1.0 + np.abs(h_b).max(axis=1) + np.abs(alpha) * self._b_max
        residual = np.einsum("kij,kj->ki", M, x[:, :3]) + b * alpha[:, None] - h
        stationarity = np.concatenate(
            [np.einsum("kij,ki->kj", M, lam), (lam @ b + 1.0)[:, None]], axis=1
        )
        return (
            (residual.max(axis=1) <= _KKT_RTOL * length)
            & (lam.min(axis=1) >= -_KKT_RTOL * self._lam_scale)
            & (
                np.abs(stationarity).max(axis=1)
                <= _KKT_RTOL * (1.0 + self._lam_scale * max(self._row_norm_max, self._b_max))
            )
            & (
                np.abs(alpha + np.sum(lam * h, axis=1))
                <= _KKT_RTOL * self._lam_scale * self._row_norm_max * length
            )
        )

    def _batch(self, K: int) -> "_Batch":
        """The K-block program (built once per K): variables [y_k, alpha_k] per block."""
        batch = self._batches.get(K)
        if batch is not None:
            return batch
        m = len(self._M)
        prog = MathematicalProgram()
        x = prog.NewContinuousVariables(4 * K, "y_alpha")
        prog.AddLinearCost(np.tile([0.0, 0.0, 0.0, 1.0], K), 0.0, x)  # sum of alpha_k
        # CSR pattern: row (k, i) holds [M_k[i, :3], -b[i]] in columns 4k .. 4k + 3.
        indices = (4 * np.arange(K)[:, None, None] + np.arange(4)[None, None, :]).repeat(m, 1)
        values = np.tile(self._M, (K, 1, 1)).astype(float)
        y_entries = np.zeros((K, m, 4), dtype=bool)
        y_entries[:, :, :3] = True
        shape = (K * m, 4 * K)
        A = sp.csr_matrix(
            (values.reshape(-1), indices.reshape(-1), np.arange(0, K * m * 4 + 1, 4)), shape
        )
        lower = np.full(K * m, -np.inf)
        constraint = prog.AddLinearConstraint(A, lower, np.zeros(K * m), x)
        batch = self._batches[K] = _Batch(
            prog=prog,
            constraint=constraint,
            values=values.reshape(-1),
            indices=indices.reshape(-1),
            indptr=np.arange(0, K * m * 4 + 1, 4),
            y_entries=y_entries.reshape(-1),
            shape=shape,
            lower=lower,
        )
        return batch

    def _kkt_holds(self, x, lam_a, lam_b, h_b, alpha) -> bool:
        """Re-checks optimality of (x, lam) for ``min alpha s.t. M x <= h`` (stacked blocks).

        Primal feasibility ``M x <= h``, dual feasibility ``lam >= 0``, stationarity
        ``M^T lam + e_4 = 0`` and a zero duality gap ``alpha + lam^T h = 0``, each to
        ``_KKT_RTOL`` times its natural scale (lengths ~ |h| + alpha max(b); multipliers
        <= 1 / min(b)).
        """
        h = self._h
        h[self._m_a :] = h_b
        lam = np.concatenate([lam_a, lam_b])
        length = 1.0 + np.abs(h_b).max() + abs(alpha) * self._b_max
        stationarity = self._M.T @ lam
        stationarity[3] += 1.0
        return bool(
            (self._M @ x - h).max() <= _KKT_RTOL * length
            and lam.min() >= -_KKT_RTOL * self._lam_scale
            and np.abs(stationarity).max()
            <= _KKT_RTOL * (1.0 + self._lam_scale * max(self._row_norm_max, self._b_max))
            and abs(alpha + lam @ h) <= _KKT_RTOL * self._lam_scale * self._row_norm_max * length
        )


# Programs cached by polytope content (``ConvexPolytope`` holds arrays, so it is not hashable).
_PROGRAMS: dict[tuple, ScalingMetricProgram] = {}
_MAX_CACHED_PROGRAMS = 64


def _polytope_key(polytope: ConvexPolytope) -> tuple:
    return (polytope.A.shape, polytope.A.tobytes(), polytope.b.tobytes())


def scaling_metric(
    polytope_a: ConvexPolytope, R_a, p_a, polytope_b: ConvexPolytope, R_b, p_b
) -> ScalingMetric:
    """The scaling metric of two posed polytopes, through a cached ``ScalingMetricProgram``.

    One program is built per (a, b) pair of polytope data (A, b) and kept (up to 64 pairs, the
    oldest dropped first); see ``ScalingMetricProgram.evaluate`` for the arguments, the result
    and the exceptions (bad polytopes or argument shapes only). Hot loops over one pair may hold
    their own ``ScalingMetricProgram`` and skip the lookup (~5 us).
    """
    key = (_polytope_key(polytope_a), _polytope_key(polytope_b))
    program = _PROGRAMS.get(key)
    if program is None:
        if len(_PROGRAMS) >= _MAX_CACHED_PROGRAMS:
            del _PROGRAMS[next(iter(_PROGRAMS))]
        program = _PROGRAMS[key] = ScalingMetricProgram(polytope_a, polytope_b)
    return program.evaluate(R_a, p_a, R_b, p_b)
