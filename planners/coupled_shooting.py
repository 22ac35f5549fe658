"""Paper 001's multiple-shooting transcription, vectorised: every interval at once, with exact
derivatives by complex-step differentiation.

Owns: the batched RK4 flow of the prediction model over the N intervals of a horizon
(`shoot`), its exact Jacobians with respect to each interval's start state and input, the
states at every RK4 stage point (where the stage cost of eq. 20 is sampled by the quadrature)
with their Jacobians, and the target's reference nodes (`target_reference`). Does not own the
model (rpod.models.coupled_relative), the optimisation algorithms (rpod.planners.coupled_nmpc,
rpod.planners.coupled_sqp) or the controller.

The transcription is the one `coupled_nmpc.interval_defect` evaluates one interval at a time:
from node k, the full 39-entry state [x_k[:21], target reference node k] is carried by
`substeps` classical RK4 steps under the constant input u_k; the stage cost is integrated by the
same RK4 weights at the same stage points. `shoot` gives the same numbers (tested to 1e-12),
for all intervals in one vectorised pass.

Derivatives. The flow is written with `coupled_relative.dynamics_batch`, whose operations are
complex-analytic. Each interval is evaluated for 27 directions at once (its 21 NLP state
entries and the 6 of the wrench [tau_C; f_C], through which alone the 24 inputs act, eqs.
11-12: d/du = d/dw M), direction j at x + i h e_j with h = 1e-30: the imaginary part of every
output divided by h is its exact derivative along e_j (no subtractive cancellation, so it is
exact to round-off whatever h), and the real part is the value itself (its error is O(h^2)).
This gives the same derivatives as AutoDiffXd through the scalar-generic model (tested to
1e-12) at ~2.5 ms for the whole horizon instead of ~95 ms.
"""

import dataclasses

import numpy as np

from rpod.models import coupled_relative as cr

NX = cr.PAPER_STATE_SIZE
"""State entries that are decision variables (eq. 15): x[:21]."""
NU = cr.INPUT_SIZE
NZ = NX + NU
"""Directions of one interval's derivatives on paper 001's bank: its start state (21) then its
input (24); `shoot` takes any input size (a fixed bank's n)."""
_STEP = 1e-30
"""Complex step h (module docstring): any h this small gives derivatives exact to round-off."""
_RK4_WEIGHTS = np.array([1.0, 2.0, 2.0, 1.0]) / 6.0


@dataclasses.dataclass(frozen=True)
class ShootingProblem:
    """The data of the NLP (22) that every solver's transcription shares.

    Attributes:
        params, weights: The model's data and eqs. 20-21's weights.
        intervals: N.
        interval_s: T_s = T / N [s].
        substeps: RK4 steps per interval.
        A_p: The LOS polyhedron's rows (eq. 18).
        los_slack_weight: rho of the L1 penalty on the LOS slacks.
        max_relative_rate_rad_s: The box on w_TC_T at the nodes 1..N.
    """

    params: cr.CoupledRelativeParams
    weights: cr.CoupledNmpcWeights
    intervals: int
    interval_s: float
    substeps: int
    A_p: np.ndarray
    los_slack_weight: float
    max_relative_rate_rad_s: float


@dataclasses.dataclass
class Shooting:
    """The RK4 transcription over the N intervals from given nodes and inputs.

    Attributes:
        x_end: Phi(x_k, u_k)[:21], each interval's end state (N, 21).
        q: The stage cost of eq. 20 integrated over each interval by the RK4 quadrature (N,).
        stage_x: The NLP state at every RK4 stage point (N, S, 21), S = 4 x substeps.
        stage_weights: Quadrature weight of each stage point (S,) [s]: sum_j w_j F(x_j, u_k)
            is q_k.
        A: d x_end / d x_k (N, 21, 21), or None without derivatives.
        B: d x_end / d u_k (N, 21, m), or None (m: the input's size, 24 for paper 001's
            gimbaled bank, n for a fixed bank: rpod.models.coupled_relative).
        stage_J: d stage_x / d [x_k; u_k] (N, S, 21, 21 + m), or None.
    """

    x_end: np.ndarray
    q: np.ndarray
    stage_x: np.ndarray
    stage_weights: np.ndarray
    A: np.ndarray | None = None
    B: np.ndarray | None = None
    stage_J: np.ndarray | None = None


def stage_weights(interval_s: float, substeps: int) -> np.ndarray:
    """The RK4 quadrature weights of the 4 x substeps stage points of one interval [s]."""
    return np.tile(_RK4_WEIGHTS * (interval_s / substeps), substeps)


def stage_cost_batch(x: np.ndarray, u: np.ndarray, weights: cr.CoupledNmpcWeights, params):
    """F(x, u) of eq. 20 for rows x (B, >= 21), u (B, m): `coupled_relative.stage_cost`
    vectorised (D diagonal, as CoupledNmpcWeights requires)."""
    d = np.diag(np.asarray(weights.D, dtype=float))
    R_diag = x[:, [0, 4, 8]]
    attitude = weights.Q_R * ((1.0 - R_diag) @ d)
    w = x[:, cr.W_TC_T_SLICE]
    p = x[:, cr.P_PTPC_T_SLICE]
    xi = x[:, cr.XI_T_SLICE]
    tau = u @ cr._force_to_wrench_matrix(params)[:3].T  # eq. 12
    return (
        attitude
        + _quadratic_rows(w, weights.Q_w)
        + _quadratic_rows(p, weights.Q_p)
        + _quadratic_rows(xi, weights.Q_xi)
        + _quadratic_rows(tau, weights.W_tau)
        + _quadratic_rows(u, weights.W_f)
    )  # eq. 20


def _quadratic_rows(v, Q):
    return np.sum((v @ Q) * v, axis=1)


def _rk4(x, u, interval_s, substeps, params, record, wrench=None):
    """Carries rows x (B, 39) over one interval under u (B, 24) or its wrench (B, 6); returns
    (x_end, stage states (B, S, 39))."""
    dt = interval_s / substeps
    stages = []
    for _ in range(substeps):
        k1 = cr.dynamics_batch(x, u, params, wrench)
        x2 = x + (0.5 * dt) * k1
        k2 = cr.dynamics_batch(x2, u, params, wrench)
        x3 = x + (0.5 * dt) * k2
        k3 = cr.dynamics_batch(x3, u, params, wrench)
        x4 = x + dt * k3
        k4 = cr.dynamics_batch(x4, u, params, wrench)
        if record:
            stages.extend([x, x2, x3, x4])
        x = x + (dt / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    stage_x = np.stack(stages, axis=1) if record else None
    R = polar_newton_schulz(x[:, cr.R_TC_SLICE].reshape(-1, 3, 3))
    x = x.copy()
    x[:, cr.R_TC_SLICE] = R.reshape(-1, 9)
    return x, stage_x


def _quadrature(stage_x, u, weights, params, w_stage) -> np.ndarray:
    """q_k = sum_j w_j F(stage_x[k, j], u_k) (N,), the RK4 quadrature of eq. 20."""
    N, S = stage_x.shape[:2]
    F = stage_cost_batch(
        stage_x.reshape(N * S, -1), np.repeat(u, S, axis=0), weights, params
    ).reshape(N, S)
    return F @ w_stage


def shoot(
    x_nodes: np.ndarray,
    u: np.ndarray,
    target_nodes: np.ndarray,
    interval_s: float,
    substeps: int,
    params: cr.CoupledRelativeParams,
    weights: cr.CoupledNmpcWeights,
    derivatives: bool = True,
) -> Shooting:
    """Every interval of the transcription at once (module docstring).

    Args:
        x_nodes: The NLP state at the interval starts (N, 21) (or (N + 1, 21): the last row is
            not used).
        u: The inputs (N, m) [N].
        target_nodes: The target's reference at the nodes (>= N, 18) (`target_reference`).
        interval_s: T_s [s]; substeps: RK4 steps per interval.
        params, weights: The model's data and eq. 20's weights.
        derivatives: False for values only (one real pass, for line searches and rollouts).
    """
    N = u.shape[0]
    start = np.concatenate([x_nodes[:N], target_nodes[:N]], axis=1)
    w_stage = stage_weights(interval_s, substeps)
    if not derivatives:
        x_end, stage_x = _rk4(start, u, interval_s, substeps, params, record=True)
        stage_x = stage_x[:, :, :NX]
        q = _quadrature(stage_x, u, weights, params, w_stage)
        return Shooting(x_end[:, :NX], q, stage_x, w_stage)

    # Directions: the 21 state entries, then the 6 entries of the wrench [tau_C; f_C]; the
    # input enters only through the wrench (eqs. 11-12, linear: w = M u), so d/du = d/dw M.
    M = cr._force_to_wrench_matrix(params)
    nd = NX + 6
    X = np.repeat(start[:, None, :], nd, axis=1).astype(complex)
    W = np.repeat((u @ M.T)[:, None, :], nd, axis=1).astype(complex)
    X[:, np.arange(NX), np.arange(NX)] += 1j * _STEP
    W[:, NX + np.arange(6), np.arange(6)] += 1j * _STEP
    x_end, stage_x = _rk4(
        X.reshape(N * nd, -1),
        None,
        interval_s,
        substeps,
        params,
        record=True,
        wrench=W.reshape(N * nd, 6),
    )
    x_end = x_end.reshape(N, nd, -1)[:, :, :NX]
    stage_x = stage_x.reshape(N, nd, -1, stage_x.shape[-1])[:, :, :, :NX]
    J_end = np.swapaxes(x_end.imag, 1, 2) / _STEP  # (N, 21, 27)
    J_stage = np.transpose(stage_x.imag, (0, 2, 3, 1)) / _STEP  # (N, S, 21, 27)
    stage_values = stage_x[:, 0].real.copy()
    return Shooting(
        x_end=x_end[:, 0].real.copy(),
        q=_quadrature(stage_values, u, weights, params, w_stage),
        stage_x=stage_values,
        stage_weights=w_stage,
        A=J_end[:, :, :NX].copy(),
        B=J_end[:, :, NX:] @ M,
        stage_J=np.concatenate([J_stage[..., :NX], J_stage[..., NX:] @ M], axis=-1),
    )


def cost_gradient(shooting: Shooting, u: np.ndarray, weights, params) -> np.ndarray:
    """d q_k / d [x_k; u_k] (N, 21 + m): the exact gradient of each interval's RK4 quadrature of
    eq. 20, from the stage points' Jacobians (needs `shoot(..., derivatives=True)`)."""
    c = shooting.stage_weights
    y = shooting.stage_x
    dF = np.zeros_like(y)  # dF / d(stage state) at each stage point (N, S, 21)
    dF[:, :, [0, 4, 8]] = -weights.Q_R * np.diag(np.asarray(weights.D, dtype=float))
    dF[:, :, cr.W_TC_T_SLICE] = 2.0 * y[:, :, cr.W_TC_T_SLICE] @ weights.Q_w
    dF[:, :, cr.P_PTPC_T_SLICE] = 2.0 * y[:, :, cr.P_PTPC_T_SLICE] @ weights.Q_p
    dF[:, :, cr.XI_T_SLICE] = 2.0 * y[:, :, cr.XI_T_SLICE] @ weights.Q_xi
    grad = np.einsum("s,nsi,nsiz->nz", c, dF, shooting.stage_J)
    M_tau = cr._force_to_wrench_matrix(params)[:3]
    H_u = np.asarray(weights.W_f) + M_tau.T @ np.asarray(weights.W_tau) @ M_tau
    grad[:, NX:] += 2.0 * np.sum(c) * u @ H_u  # the input terms, u constant on the interval
    return grad


POLAR_ITERATIONS = 3
"""Newton-Schulz steps that carry R_TC back onto SO(3) at each interval's end: from RK4's
drift (measured up to 2.4e-2 at 30 s steps through a slew) the error after 1, 2, 3 steps is
~1.5 e^2, ~1e-6, ~1e-12."""


def polar_newton_schulz(R, iterations: int = POLAR_ITERATIONS):
    """The rotation nearest to R (its polar factor) by Newton-Schulz: R <- R (3 I - R^T R) / 2.

    A polynomial in R's entries, so float, complex (complex-step derivatives: transpose, never
    conjugate) and AutoDiffXd inputs all pass through, and the transcription stays smooth.
    R: (3, 3) or a stack (B, 3, 3). Converges for |R^T R - I| < 1 (RK4's drift is ~1e-2).
    """
    R = np.asarray(R)
    eye3 = np.eye(3)
    for _ in range(iterations):
        RtR = np.matmul(np.swapaxes(R, -1, -2), R)
        R = 0.5 * np.matmul(R, 3.0 * eye3 - RtR)
    return R


def project_to_so3(R: np.ndarray) -> np.ndarray:
    """The rotation nearest to R (polar decomposition by SVD)."""
    U, _, Vt = np.linalg.svd(R)
    return U @ np.diag([1.0, 1.0, np.linalg.det(U @ Vt)]) @ Vt


def project_to_so3_batch(R: np.ndarray) -> np.ndarray:
    """`project_to_so3` for a stack (B, 3, 3)."""
    U, _, Vt = np.linalg.svd(R)
    d = np.linalg.det(np.matmul(U, Vt))
    U = U.copy()
    U[:, :, 2] *= d[:, None]
    return np.matmul(U, Vt)


def target_reference(
    x0: np.ndarray,
    intervals: int,
    interval_s: float,
    substeps: int,
    params: cr.CoupledRelativeParams,
) -> np.ndarray:
    """The target's reference nodes (N + 1, 18): x0[21:] carried by the same RK4 (no input
    reaches it), R_IT projected back onto SO(3) at every node."""
    nodes = np.empty((intervals + 1, cr.STATE_SIZE - NX))
    x = np.asarray(x0, dtype=float)[NX:].copy()
    nodes[0] = x
    dt = interval_s / substeps
    for k in range(intervals):
        for _ in range(substeps):  # the same RK4 steps as `shoot` takes on these entries
            k1 = cr.target_dynamics(x, params)
            k2 = cr.target_dynamics(x + (0.5 * dt) * k1, params)
            k3 = cr.target_dynamics(x + (0.5 * dt) * k2, params)
            k4 = cr.target_dynamics(x + dt * k3, params)
            x = x + (dt / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
        x[:9] = polar_newton_schulz(x[:9].reshape(3, 3)).reshape(9)
        nodes[k + 1] = x
    return nodes
