"""Paper 004's MPC prediction model: the one-step map of the body-frame relative state and its
exact Jacobian (Sec. 4.4), and the frozen CW model it is compared against (eqs. 5-6).

Owns: `TargetState`, `BodyFrameStep` (the nonlinear map x_B(t + dt) = f(target(t), x_B(t), u_L),
its exact Jacobian (A_d, B_d) and the Jacobians along a predicted horizon) and
`cw_body_frame_matrices`. Does not own: the QP that uses (A_d, B_d) (rpod.planners.
los_corridor_mpc), the truth dynamics (rpod.systems), or the estimate of the target's state.

State and input. x_B = [p_TC_T, v_TC_T]: the chaser relative to the target, expressed in the
target body frame T, its velocity seen from T (eqs. 7-8, `rpod.models.los_corridor.
body_relative_state`). u_L is the chaser's commanded acceleration in the target's LVLH frame L,
held constant in L over the step (zero-order hold; L turns with the target's orbit, R_IL(t) =
`lvlh_rotation` of the target's state at each instant; L is I in free space, as in the truth).

The map (the paper's pipeline, eqs. 7-8 and 3):
  1. ECI recovery, linear in x_B: p_rel = R_IT p_B, v_rel = R_IT (v_B + w_IT_T x p_B)  (M_in).
  2. RK4 (`substeps` equal steps) of the target's orbit together with the relative state in I,
     p_rel'' = a(p_T + p_rel) - a(p_T) + R_IL(t) u_L (eq. 3 differenced). Propagating the
     relative state, not the chaser's absolute one, avoids cancellation: at 6,900 km an absolute
     position keeps only ~1e-9 m of its digits, so p_C - p_T loses them all; here the small
     difference of accelerations is rounded at ~1e-15 m/s^2 and p_rel keeps its own digits.
  3. The target's attitude, torque-free (Euler's equations with inertia_T, quaternion
     kinematics), by RK4 on the same substeps, as the rotation R_TT' accrued over the step (a
     quaternion that starts at identity, normalised at the end): R_IT' = R_IT R_TT'.
  4. Body-frame projection, linear: p_B' = R_IT'^T p_rel', v_B' = R_IT'^T v_rel' - w' x p_B'
     (M_out).

The Jacobian. Only step 2 depends on (x_B, u_L). Differentiating an explicit Runge-Kutta step
equals applying the same step to the variational system with its Jacobians taken at the stage
values, so RK4 of S' = F(t) S + [0 | 0; 0 | R_IL(t)] on S = d(p_rel, v_rel) / d(x_B, u_L) (6x9,
S(0) = [M_in | 0]) alongside the nominal, with F = [0 I; G 0] and G = `gravity_gradient` at the
chaser's p_T + p_rel at each stage, gives the derivative of the discrete map `step` itself,
exact up to round-off; then A_d, B_d = M_out S. It is cheap (one 6x9 linear solve riding on the
nominal's stages, no extra map evaluations); central differences of `step` agree with it to
their own resolution, ~2e-10 relative (tests). The paper's forward differences (eps = 1e-6)
through an absolute-ECI pipeline lose ~1e-3 of every entry to the cancellation above (1e-9 m
of round-off over a 1e-6 m perturbation; measured in the tests).

Cost (one core, measured): `step` ~0.15 ms, `jacobian` ~0.26 ms with the default 2 substeps,
about a third of it the attitude; `horizon` is `steps` Jacobians.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from rpod.models.cw import cw_state_transition, cw_zoh_input
from rpod.models.frames import lvlh_rotation, rotations_from_wxyz, skew
from rpod.models.gravity import (
    GRAVITY_MODELS,
    gravity_acceleration_xyz,
    gravity_gradient,
)
from rpod.models.rigid_body import angular_acceleration, quaternion_rate, validate_inertia

_IDENTITY_WXYZ = np.array([1.0, 0.0, 0.0, 0.0])


@dataclasses.dataclass(frozen=True)
class TargetState:
    """The target at one instant.

    Attributes:
        p_IT_I: Position (3,) of the target's centre of mass in I [m].
        v_IT_I: Its velocity (3,) in I [m/s].
        R_IT: Its attitude (3, 3), body frame T in I.
        w_IT_T: Its angular velocity (3,) in I, expressed in T [rad/s].
    """

    p_IT_I: np.ndarray
    v_IT_I: np.ndarray
    R_IT: np.ndarray
    w_IT_T: np.ndarray


def _out_of_frame(R_AF, w_AF_F) -> np.ndarray:
    """(6, 6): a relative state in and seen from a frame F that turns at w_AF_F in frame A ->
    the same in A: p_A = R_AF p_F, v_A = R_AF (v_F + w x p_F) (eqs. 7-8 inverted)."""
    M = np.zeros((6, 6))
    M[:3, :3] = M[3:, 3:] = R_AF
    M[3:, :3] = R_AF @ skew(w_AF_F)
    return M


def _into_frame(R_AF, w_AF_F) -> np.ndarray:
    """(6, 6): the inverse of `_out_of_frame`, p_F = R_AF^T p_A, v_F = R_AF^T v_A - w x p_F
    (eqs. 7-8)."""
    M = np.zeros((6, 6))
    M[:3, :3] = M[3:, 3:] = R_AF.T
    M[3:, :3] = -skew(w_AF_F) @ R_AF.T
    return M


class BodyFrameStep:
    """The nonlinear one-step map of paper 004 Sec. 4.4 and its exact Jacobian.

    Args:
        dt_s: Control step dt [s] (the paper's 1 s).
        gravity: One of GRAVITY_MODELS for the orbit and the differential gravity ('cw' is
            two-body here: this is the nonlinear model that CW linearises).
        inertia_T: The target's inertia (3, 3) in T [kg m^2] (only its ratios matter).
        substeps: RK4 steps per control step.
    """

    def __init__(self, dt_s: float, gravity: str, inertia_T: np.ndarray, substeps: int = 2):
        if not dt_s > 0.0:
            raise ValueError(f"dt_s must be positive, got {dt_s}")
        if gravity not in GRAVITY_MODELS:
            raise ValueError(f"unknown gravity model '{gravity}', expected one of {GRAVITY_MODELS}")
        if substeps < 1:
            raise ValueError(f"substeps must be at least 1, got {substeps}")
        validate_inertia(inertia_T)
        self.dt_s = float(dt_s)
        self.gravity = gravity
        self.substeps = int(substeps)
        self._h = self.dt_s / self.substeps
        self._J = np.array(inertia_T, dtype=float)
        self._J_inv = np.linalg.inv(self._J)

    def target_next(self, target: TargetState) -> TargetState:
        """The target at t + dt: orbit (eq. 3) and torque-free attitude, as `step` sees it."""
        return self._propagate(target, np.zeros(6), np.zeros(3), False)[0]

    def step(self, target: TargetState, x_B, u_L) -> np.ndarray:
        """x_B (6,) at t + dt from x_B and u_L ((3,) in L, held over the step) at t."""
        return self._propagate(target, x_B, u_L, False)[1]

    def jacobian(self, target: TargetState, x_B, u_L=None) -> tuple[np.ndarray, np.ndarray]:
        """(A_d (6, 6), B_d (6, 3)) = d step / d (x_B, u_L) at (x_B, u_L), exactly (module
        docstring); u_L defaults to zero (it moves the stage points, so it enters slightly)."""
        u_L = np.zeros(3) if u_L is None else u_L
        _, _, A_d, B_d = self._propagate(target, x_B, u_L, True)
        return A_d, B_d

    def horizon(self, target: TargetState, x_B, steps: int) -> tuple[np.ndarray, np.ndarray]:
        """(A (steps, 6, 6), B (steps, 6, 3)): the Jacobians along the predicted target.

        Step k's Jacobian is taken at the target propagated k steps (`target_next`) and at the
        free-motion (u_L = 0) prediction of x_B, which the Jacobian's own nominal gives for
        free. Under a non-principal tumble w_IT_T and R_IT change over the horizon, and so do
        A and B.
        """
        A = np.empty((steps, 6, 6))
        B = np.empty((steps, 6, 3))
        x = np.asarray(x_B, dtype=float)
        for k in range(steps):
            target, x, A[k], B[k] = self._propagate(target, x, np.zeros(3), True)
        return A, B

    def _propagate(self, target: TargetState, x_B, u_L, sensitivity: bool):
        """(target', x_B', A_d, B_d) over one step; A_d, B_d are None without `sensitivity`."""
        x_B = np.asarray(x_B, dtype=float)
        u_L = np.asarray(u_L, dtype=float)
        R_IT = np.asarray(target.R_IT, dtype=float)
        w_IT_T = np.asarray(target.w_IT_T, dtype=float)
        M_in = _out_of_frame(R_IT, w_IT_T)
        y = np.concatenate([target.p_IT_I, target.v_IT_I, M_in @ x_B])  # [p_T, v_T, p_rel, v_rel]
        S = np.hstack([M_in, np.zeros((6, 3))]) if sensitivity else None
        h = self._h
        for _ in range(self.substeps):  # RK4; S rides on the nominal's stage values
            k1, K1 = self._rates(y, S, u_L)
            k2, K2 = self._rates(y + 0.5 * h * k1, S if S is None else S + 0.5 * h * K1, u_L)
            k3, K3 = self._rates(y + 0.5 * h * k2, S if S is None else S + 0.5 * h * K2, u_L)
            k4, K4 = self._rates(y + h * k3, S if S is None else S + h * K3, u_L)
            y = y + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
            if S is not None:
                S = S + (h / 6.0) * (K1 + 2.0 * K2 + 2.0 * K3 + K4)
        R_TT_next, w_next = self._attitude(w_IT_T)
        target_next = TargetState(y[0:3], y[3:6], R_IT @ R_TT_next, w_next)
        M_out = _into_frame(target_next.R_IT, w_next)
        x_next = M_out @ y[6:12]  # eqs. 7-8
        if S is None:
            return target_next, x_next, None, None
        AB = M_out @ S
        return target_next, x_next, AB[:, :6], AB[:, 6:]

    def _rates(self, y, S, u_L):
        """d/dt of [p_T, v_T, p_rel, v_rel] (eq. 3, differenced) and of S (its variation)."""
        p_Tx, p_Ty, p_Tz, _, _, _, p_x, p_y, p_z = y[0:9].tolist()
        a_T = gravity_acceleration_xyz(p_Tx, p_Ty, p_Tz, self.gravity)
        a_C = gravity_acceleration_xyz(p_Tx + p_x, p_Ty + p_y, p_Tz + p_z, self.gravity)
        free = self.gravity == "free_space"
        R_IL = np.eye(3) if free else lvlh_rotation(y[0:3], y[3:6])  # L at this stage
        a_u = R_IL @ u_L  # zero-order hold in L
        ydot = np.empty(12)
        ydot[0:3] = y[3:6]
        ydot[3:6] = a_T
        ydot[6:9] = y[9:12]
        ydot[9] = a_C[0] - a_T[0] + a_u[0]  # eq. 3 at the chaser minus eq. 3 at the target
        ydot[10] = a_C[1] - a_T[1] + a_u[1]
        ydot[11] = a_C[2] - a_T[2] + a_u[2]
        if S is None:
            return ydot, None
        Sdot = np.empty((6, 9))
        Sdot[0:3] = S[3:6]
        Sdot[3:6] = gravity_gradient((p_Tx + p_x, p_Ty + p_y, p_Tz + p_z), self.gravity) @ S[0:3]
        Sdot[3:6, 6:9] += R_IL
        return ydot, Sdot

    def _attitude(self, w_IT_T):
        """(R_TT', w_IT_T'): the rotation accrued over the step and the rate at its end, by RK4 of
        torque-free Euler's equations and quaternion kinematics (paper 004 eq. 2)."""
        h = self._h
        q, w = _IDENTITY_WXYZ, w_IT_T
        for _ in range(self.substeps):
            q1, w1 = quaternion_rate(q, w), self._euler(w)
            q2 = quaternion_rate(q + 0.5 * h * q1, w + 0.5 * h * w1)
            w2 = self._euler(w + 0.5 * h * w1)
            q3 = quaternion_rate(q + 0.5 * h * q2, w + 0.5 * h * w2)
            w3 = self._euler(w + 0.5 * h * w2)
            q4, w4 = quaternion_rate(q + h * q3, w + h * w3), self._euler(w + h * w3)
            q = q + (h / 6.0) * (q1 + 2.0 * q2 + 2.0 * q3 + q4)
            w = w + (h / 6.0) * (w1 + 2.0 * w2 + 2.0 * w3 + w4)
        return rotations_from_wxyz(q), w  # normalises q

    def _euler(self, w) -> np.ndarray:
        """Torque-free w_dot = J^-1 (J w x w)."""
        return angular_acceleration(self._J, w, J_inv=self._J_inv)


def cw_body_frame_matrices(
    n: float, dt: float, target_k: TargetState, target_k1: TargetState
) -> tuple[np.ndarray, np.ndarray]:
    """The frozen CW model (eqs. 5-6) carried into the body frame: (A_d (6, 6), B_d (6, 3)).

    x_L' = Phi(dt) x_L + B_d(dt) u_L in L (`cw_state_transition`, `cw_zoh_input`), composed with
    the L -> T maps at t_k and t_k+1: p_T = R_TL p_L, v_T = R_TL v_L - w_LT_T x p_T, where
    R_TL = R_IT^T R_IL, R_IL = `lvlh_rotation` of each target state and w_LT_T = w_IT_T -
    R_TL w_IL_L with w_IL_L = [0, 0, n] (CW's own frame rate). So A_d = M(t_k+1) Phi M(t_k)^-1
    and B_d = M(t_k+1) B_d^L.

    Args:
        n: Mean motion of the circular reference orbit [rad/s].
        dt: Step [s].
        target_k: The target at t_k.
        target_k1: The target at t_k + dt (e.g. `BodyFrameStep.target_next(target_k)`).
    """
    R_LT_k, w_LT_T_k = _attitude_in_lvlh(n, target_k)
    M_k1 = _into_frame(*_attitude_in_lvlh(n, target_k1))
    A_d = M_k1 @ cw_state_transition(n, dt) @ _out_of_frame(R_LT_k, w_LT_T_k)  # eq. 5
    return A_d, M_k1 @ cw_zoh_input(n, dt)


def _attitude_in_lvlh(n: float, target: TargetState) -> tuple[np.ndarray, np.ndarray]:
    """(R_LT, w_LT_T) of a target whose L turns at [0, 0, n] in L (CW's frame)."""
    R_LT = lvlh_rotation(target.p_IT_I, target.v_IT_I).T @ np.asarray(target.R_IT, dtype=float)
    w_LT_T = np.asarray(target.w_IT_T, dtype=float) - R_LT.T @ np.array([0.0, 0.0, n])
    return R_LT, w_LT_T
