"""Paper 004's MPC QP (eq. 11) condensed onto its inputs, for a dense active-set solver (DAQP).

Owns: `CondensedQp`, which eliminates the predicted states of `LosCorridorMpc`'s sparse QP by
its own dynamics rows and solves what is left with DAQP, warm-started by the previous step's
active set shifted one step along the horizon. Does not own: the QP's data (weights, corridor
bounds, keep-out direction: rpod.planners.los_corridor_mpc builds them, and this module reads
them from it) or what a controller does with the answer.

Condensing. x_0 = x_k and x_{j+1} = A_d,j x_j + B_d,j u_j (11b, 11c) give every predicted
state as x = Phi x_k + Gamma u, Phi_{j+1} = A_d,j Phi_j and Gamma_{j+1} = A_d,j Gamma_j + [..,
B_d,j, ..] (block column j), 2 N small products a step. Over w = [u, s, t] (the best-effort
QP's slacks after the inputs), with the sparse QP's state weights diagonal (diag(Q), Q_N =
terminal_factor Q):

    H = [[Gamma' P_x Gamma + P_u, 0], [0, P_st]],  f = [Gamma' (P_x Phi x_k + q_x) + q_u; q_st]
    corridor  A_c (Phi x_k + Gamma u)_j,pos - |A_c| s_j <= b_j                  (11d)
    keep-out  n . (Phi x_k + Gamma u)_j,pos + t_j >= r_ko,  j >= 1
    box       -a_max <= u <= a_max; s, t >= 0  (DAQP's simple bounds)          (11e)

the same optimum as the sparse QP (tested against it). 3 N inputs (+ 2 (N + 1) slacks) and the
corridor's nc (N + 1) rows: 120 x 328 at the single scenario's N = 40.
"""

from __future__ import annotations

from ctypes import c_int

import daqp
import numpy as np

INFINITY = 1e30  # DAQP's bound for "none"
ACTIVE = 1  # DAQP's sense of an inequality to start in the working set
# DAQP's exit flags: 1 solved, 2 solved with soft constraints, -1 infeasible, -3 unbounded,
# -4 iteration limit; the rest (cycling, non-convex, an overdetermined start) are failures.
SOLVED_FLAGS, INFEASIBLE_FLAG, UNBOUNDED_FLAG, ITERATION_LIMIT_FLAG = (1, 2), -1, -3, -4


class CondensedQp:
    """Eq. 11 over the inputs (and slacks) of one `LosCorridorMpc` (module docstring)."""

    def __init__(self, mpc):
        """Reads the constant parts (P_u, the state weights, the slacks' weights) from mpc."""
        self.N, self.soft = mpc.N, mpc.soft
        N, u_off, s_off = mpc.N, mpc._u_offset, mpc._s_offset
        P = mpc._P.toarray()
        P = P + P.T - np.diag(P.diagonal())  # the sparse QP keeps the upper triangle
        self._P_x = np.diag(P)[:u_off].copy()  # diagonal: diag(Q) N times, then Q_N
        if np.count_nonzero(P[:u_off, :u_off] - np.diag(self._P_x)):
            raise ValueError("condensing needs diagonal state weights")
        self._P_u = P[u_off:s_off, u_off:s_off]
        self._n_u, self._n_w = 3 * N, P.shape[0] - u_off
        self._P_st = P[s_off:, s_off:]
        self._A_c, self._row_norms = mpc._A_c, mpc._row_norms
        self._a_max = mpc.settings.a_max_m_s2
        self._keep_out_m = mpc.keep_out_m
        self._max_iter = int(mpc.settings.max_iter)
        self._u_off, self._s_off, self._nc = u_off, s_off, len(mpc._b_c)
        # The slacks' columns do not change: - |A_c,i| s_j in corridor row (j, i), t_j in
        # keep-out row j (soft only).
        nc, n_s = self._nc, self._n_w - self._n_u
        self._corridor_slacks = np.zeros((nc * (N + 1), n_s))
        self._keep_out_slacks = np.zeros((N + 1, n_s))
        if self.soft:
            self._corridor_slacks[:, : N + 1] = np.kron(np.eye(N + 1), -self._row_norms[:, None])
            self._keep_out_slacks[:, N + 1 :] = np.eye(N + 1)
        self._active = None  # the last solve's working set, for the warm start

    def _prediction(self, x_k, A_d, B_d) -> tuple[np.ndarray, np.ndarray]:
        """(x_free (N + 1, 6) = Phi x_k, Gamma (N + 1, 6, 3 N))."""
        N = self.N
        x_free = np.empty((N + 1, 6))
        gamma = np.zeros((N + 1, 6, 3 * N))
        x_free[0] = x_k
        for j in range(N):
            x_free[j + 1] = A_d[j] @ x_free[j]
            gamma[j + 1, :, : 3 * j] = A_d[j] @ gamma[j, :, : 3 * j]
            gamma[j + 1, :, 3 * j : 3 * j + 3] = B_d[j]
        return x_free, gamma

    def problem(self, x_k, q, bounds, A_d, B_d, keep_out_n=None):
        """(H, f, A, upper, lower, x_free, gamma) of the condensed QP at this step's data.

        q: the sparse QP's linear cost; bounds: the corridor's right-hand sides (N + 1, nc);
        keep_out_n: the keep-out direction (soft only)."""
        N, nc, n_u, n_w = self.N, self._nc, self._n_u, self._n_w
        x_free, gamma = self._prediction(x_k, A_d, B_d)
        flat = gamma.reshape(6 * (N + 1), n_u)
        H = np.zeros((n_w, n_w))
        H[:n_u, :n_u] = flat.T @ (self._P_x[:, None] * flat) + self._P_u
        H[n_u:, n_u:] = self._P_st
        f = q[self._u_off :].copy()
        f[:n_u] += flat.T @ (self._P_x * x_free.ravel() + q[: self._u_off])
        corridor = np.einsum("ik,jkn->jin", self._A_c, gamma[:, :3, :]).reshape(-1, n_u)
        rows = [np.hstack([corridor, self._corridor_slacks])]
        upper = [(bounds - x_free[:, :3] @ self._A_c.T).ravel()]
        lower = [np.full(nc * (N + 1), -INFINITY)]
        if self.soft:
            keep = np.einsum("k,jkn->jn", keep_out_n, gamma[:, :3, :])
            rows.append(np.hstack([keep, self._keep_out_slacks]))
            upper.append(np.full(N + 1, INFINITY))
            ko_lower = self._keep_out_m - x_free[:, :3] @ keep_out_n
            ko_lower[0] = -INFINITY  # x_0 is data
            lower.append(ko_lower)
        simple_upper = np.r_[np.full(n_u, self._a_max), np.full(n_w - n_u, INFINITY)]
        simple_lower = np.r_[np.full(n_u, -self._a_max), np.zeros(n_w - n_u)]
        A = np.vstack(rows)
        upper = np.concatenate([simple_upper, *upper])
        lower = np.concatenate([simple_lower, *lower])
        return H, f, A, upper, lower, x_free, gamma

    def _warm_sense(self, size: int) -> np.ndarray:
        """The last working set shifted one step along the horizon (inputs, corridor rows,
        slacks and keep-out rows of step j + 1 become step j's), the last step kept."""
        sense = np.zeros(size, dtype=c_int)
        if self._active is None or len(self._active) != size:
            return sense
        N, nc, n_u = self.N, self._nc, self._n_u
        active = self._active
        blocks = [(0, 3, N)]  # u bounds: blocks of 3, N of them
        if self.soft:
            blocks += [(n_u, 1, N + 1), (n_u + N + 1, 1, N + 1)]
        start = self._n_w
        blocks.append((start, nc, N + 1))  # corridor rows
        if self.soft:
            blocks.append((start + nc * (N + 1), 1, N + 1))  # keep-out rows
        for offset, width, count in blocks:
            block = active[offset : offset + width * count].reshape(count, width)
            shifted = np.vstack([block[1:], block[-1:]])
            sense[offset : offset + width * count] = np.where(shifted.ravel(), ACTIVE, 0)
        return sense

    def solve(self, x_k, q, bounds, A_d, B_d, keep_out_n=None):
        """(flag, z, iterations): DAQP's exit flag, the sparse QP's variable vector (states
        rebuilt from the inputs) or None, and its iterations. A warm start that fails (its
        working set infeasible, say) is followed by a cold one."""
        H, f, A, upper, lower, x_free, gamma = self.problem(x_k, q, bounds, A_d, B_d, keep_out_n)
        sense = self._warm_sense(len(upper))
        w, _, flag, info = daqp.solve(H, f, A, upper, lower, sense, iter_limit=self._max_iter)
        iterations = int(info.get("iterations", 0))
        if flag not in SOLVED_FLAGS and np.any(sense):  # the guess may be what failed: cold
            cold = np.zeros_like(sense)
            w, _, flag, info = daqp.solve(H, f, A, upper, lower, cold, iter_limit=self._max_iter)
            iterations += int(info.get("iterations", 0))
        if flag not in SOLVED_FLAGS:
            self._active = None
            return flag, None, iterations
        self._active = np.asarray(info["lam"]) != 0.0
        w = np.asarray(w, dtype=float)
        x = x_free.ravel() + gamma.reshape(6 * (self.N + 1), self._n_u) @ w[: self._n_u]
        return flag, np.concatenate([x, w]), iterations
