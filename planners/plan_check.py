"""An independent checker of soft-capture plans (paper 000, Problem 1 evaluated on the result).

Owns: re-evaluating a ``SoftCapturePlan`` against its config and the target prediction through
code paths separate from the planner's: the dynamics by ``scipy.linalg.expm`` of the CW
matrices written out here (not ``rpod.models.cw``), every constraint in its original nonlinear
form (the true line-of-sight angle, not the (FOV) cone; the docking cone as an angle in the
target body frame), the terminal capture conditions, the pointing law's geometry, and the
collision metric alpha by its own LP with ``scipy.optimize.linprog`` (HiGHS), not the Drake
program. It reports the worst value of each; it does not decide what a plan is for.
Does not own: planning, or any Drake program. It imports no planner module (only the hull data
from ``rpod.models.shapes`` and the config's fields, read by name).

Every ``*_excess`` is ``max(measured - bound)`` over the knots it applies to: <= 0 means the
constraint holds (with margin), > 0 is a violation in the constraint's own unit.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from rpod.models.cw import cw_continuous
from rpod.models.docking import capture_reach_T
from rpod.models.frames import rotations_from_wxyz
from rpod.models.gravity import mean_motion
from rpod.models.shapes import soft_capture_chaser_hull, soft_capture_target_hull

# Default pass thresholds and why. The planner's numbers come from Clarabel (interior point,
# default feasibility and gap tolerances 1e-8, relative to data of size ~1e2), so constraints
# hold to ~1e-6 in their units; the dynamics residual compares two exact discretisations
# (closed form vs expm, ~1e-12) on top of that.
DEFAULT_TOLERANCES = {
    "dynamics_residual": 1e-5,  # m and m/s; solver feasibility on equality rows
    "thrust_excess_N": 1e-4,  # N; 1e-6 relative to U_max = 100 N
    "speed_excess_m_s": 1e-6,
    "range_excess_m": 1e-5,
    "los_angle_excess_rad": 1e-6,  # the (FOV) cone is exact on circles, conservative off them
    "docking_cone_excess_m": 1e-6,
    "terminal_position_excess_m": 1e-6,
    "terminal_velocity_excess_m_s": 1e-6,
    "pointing_error_rad": 1e-9,  # attitudes are built, not optimised: round-off only
    "pointing_twist_rad": 1e-9,
    "alpha_mismatch": 1e-7,  # two exact LPs (simplex) on the same poses
    "prediction_mismatch": 1e-12,  # the plan must carry the prediction's own knots
}


@dataclass
class PlanCheckReport:
    """Worst values over the plan (module docstring for the sign convention).

    Attributes:
        dynamics_residual: max |x_k+1 - (Phi x_k + B_d u_k / m)|, entries in m and m/s.
        initial_state_error: max |x_0 - x0| (0 when no x0 was given).
        thrust_excess_N: max(|u_k| - U_max).
        speed_excess_m_s: max(|v_k| - v_max).
        range_excess_m: max(|r_k| - r_max).
        los_angle_excess_rad: max(angle(r_k, r_k+1) - omega_max dt), the true angle (12).
        max_los_angle_rad: max angle(r_k, r_k+1).
        docking_cone_excess_m: max over the last N_dock knots of
            |lateral| - tan(theta_dock) axial, in the target body frame (11).
        terminal_position_excess_m: |r_N-1 - p*| - eps_p (13).
        terminal_velocity_excess_m_s: |v_N-1 - v*| - eps_v (14), v* per the config's point.
        capture_point_speed_m_s: |velocity of the chaser capture point (pointing law, at the
            planned r_N-1, v_N-1) - velocity of the target capture point| (information: the
            closing speed at contact).
        pointing_error_rad: max angle between R_LC D_c and the line of sight -r_k.
        pointing_twist_rad: max rotation about the line of sight between successive attitudes
            (0 for minimum-norm increments).
        alpha_check: alpha at each knot by the independent LP (N,).
        min_alpha: min(alpha_check).
        alpha_mismatch: max |alpha_check - plan.alpha|.
        prediction_mismatch: max difference between the plan's and the prediction's target
            attitude (quaternion, sign-aligned) and rate.
        collision_free: all(alpha_check > 1).
    """

    dynamics_residual: float
    initial_state_error: float
    thrust_excess_N: float
    speed_excess_m_s: float
    range_excess_m: float
    los_angle_excess_rad: float
    max_los_angle_rad: float
    docking_cone_excess_m: float
    terminal_position_excess_m: float
    terminal_velocity_excess_m_s: float
    capture_point_speed_m_s: float
    pointing_error_rad: float
    pointing_twist_rad: float
    alpha_check: np.ndarray
    min_alpha: float
    alpha_mismatch: float
    prediction_mismatch: float
    collision_free: bool

    def violations(self, tolerances: dict | None = None) -> dict[str, float]:
        """The checks above their tolerance (``DEFAULT_TOLERANCES`` merged with overrides)."""
        limits = dict(DEFAULT_TOLERANCES)
        limits.update(tolerances or {})
        found = {name: getattr(self, name) for name in limits if getattr(self, name) > limits[name]}
        if self.initial_state_error > limits["dynamics_residual"]:
            found["initial_state_error"] = self.initial_state_error
        if not self.collision_free:
            found["min_alpha"] = self.min_alpha
        return found

    def passed(self, tolerances: dict | None = None) -> bool:
        """True when nothing exceeds its tolerance and alpha > 1 at every knot."""
        return not self.violations(tolerances)

    def summary(self) -> dict:
        """Scalar fields as plain floats (for JSON)."""
        return {
            f.name: float(getattr(self, f.name))
            for f in fields(self)
            if np.ndim(getattr(self, f.name)) == 0
        }


def _cw_discretisation(n: float, dt: float, m: float) -> tuple[np.ndarray, np.ndarray]:
    """Phi and B_d / m by the matrix exponential of [[A, B / m], [0, 0]] dt (Van Loan)."""
    A, _ = cw_continuous(n)  # paper 004 eq. (4); the expm below is independent of the STM
    M = np.zeros((9, 9))
    M[:6, :6] = A
    M[3:6, 6:] = np.eye(3) / m
    from scipy.linalg import expm  # at use: every rpod process starts ~0.25 s sooner

    E = expm(M * dt)
    return E[:6, :6], E[:6, 6:]


def _angle(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Angles between rows of a and b, by atan2 (accurate at small angles)."""
    return np.arctan2(np.linalg.norm(np.cross(a, b), axis=1), np.sum(a * b, axis=1))


def scaling_alpha_lp(A_a, b_a, R_a, p_a, A_b, b_b, R_b, p_b) -> float:
    """alpha by ``linprog`` (HiGHS): min alpha s.t. A_i R_i^T (p - p_i) <= alpha b_i, i = a, b.

    Returns:
        alpha, or NaN if HiGHS does not report an optimum.
    """
    rows = np.vstack([np.column_stack([A_a @ R_a.T, -b_a]), np.column_stack([A_b @ R_b.T, -b_b])])
    rhs = np.concatenate([A_a @ R_a.T @ p_a, A_b @ R_b.T @ p_b])
    from scipy.optimize import linprog  # at use: every rpod process starts ~0.25 s sooner

    result = linprog(
        c=[0.0, 0.0, 0.0, 1.0],
        A_ub=rows,
        b_ub=rhs,
        bounds=[(None, None)] * 3 + [(0.0, None)],
        method="highs",
    )
    return float(result.x[3]) if result.status == 0 else float("nan")


def check_plan(
    plan,
    config,
    prediction,
    x0=None,
    chaser_hull=None,
    target_hull=None,
) -> PlanCheckReport:
    """Re-evaluates a plan independently of the planner (module docstring).

    Args:
        plan: A ``SoftCapturePlan`` with N >= 2 knots.
        config: The ``SoftCaptureConfig`` it was planned with.
        prediction: The ``TargetPrediction`` it was planned against (knots ``k dt``).
        x0: Optional initial state (6,) the plan must start from.
        chaser_hull: Chaser ``ConvexPolytope`` (default: paper 000's).
        target_hull: Target ``ConvexPolytope`` (default: paper 000's).

    Returns:
        The report.
    """
    chaser_hull = chaser_hull if chaser_hull is not None else soft_capture_chaser_hull()
    target_hull = target_hull if target_hull is not None else soft_capture_target_hull()
    N, dt, m = plan.N, config.dt_s, config.chaser_mass_kg
    n = mean_motion(config.semi_major_axis_m)
    x, u = np.asarray(plan.x, float), np.asarray(plan.u, float)
    r, v = x[:, :3], x[:, 3:]

    # Dynamics (5) by expm, and the initial state.
    Phi, Bd_m = _cw_discretisation(n, dt, m)
    residual = x[1:] - (x[:-1] @ Phi.T + u @ Bd_m.T)
    x0_error = 0.0 if x0 is None else float(np.abs(x[0] - np.asarray(x0, float)).max())

    # The target as predicted (from the prediction object, not the plan's copy).
    q_LT = np.asarray(prediction.q_LT, float)[:N]
    w_IT_T = np.asarray(prediction.w_IT_T, float)[:N]
    sign = np.sign(np.sum(q_LT * plan.q_LT, axis=1))[:, None]
    prediction_mismatch = max(
        float(np.abs(sign * q_LT - plan.q_LT).max()), float(np.abs(w_IT_T - plan.w_IT_T).max())
    )
    R_LT = rotations_from_wxyz(q_LT)
    R_LC = rotations_from_wxyz(plan.q_LC)

    # Bounds (9), (10), (16) and the true field-of-view angle (12).
    los_angles = _angle(r[:-1], r[1:])
    phi = config.max_los_rate_rad_s * dt

    # Docking cone (11) in the target body frame, last N_dock knots.
    D_t = np.asarray(config.p_TDt_T, float)
    D_c = np.asarray(config.p_CDc_C, float)
    axis_T = D_t / np.linalg.norm(D_t)
    dock = slice(max(0, N - config.docking_knots), N)
    Y = np.einsum("kji,kj->ki", R_LT[dock], r[dock]) - D_t  # R_k^T r_k - D_t
    axial = Y @ axis_T
    lateral = np.linalg.norm(Y - axial[:, None] * axis_T, axis=1)
    tan_dock = np.tan(np.radians(config.docking_half_angle_deg))

    # Terminal position (13) and velocity (14).
    R_N, w_N = R_LT[-1], w_IT_T[-1]
    w_LT_T = w_N - R_N.T @ np.array([0.0, 0.0, float(prediction.n_orbit)])
    reach_T = capture_reach_T(D_c, D_t)
    lever_T = reach_T if config.terminal_velocity_point == "chaser_capture_point" else D_t
    p_star = R_N @ reach_T
    v_star = R_N @ np.cross(w_LT_T, lever_T)
    # Closing speed of the capture points with the pointing law's rate at the final knot:
    # the capture point r - |D_c| r_hat moves at v - (|D_c| / |r|) (I - r_hat r_hat^T) v.
    r_hat = r[-1] / np.linalg.norm(r[-1])
    v_perp = v[-1] - r_hat * (r_hat @ v[-1])
    chaser_point_velocity = v[-1] - np.linalg.norm(D_c) / np.linalg.norm(r[-1]) * v_perp
    target_point_velocity = R_N @ np.cross(w_LT_T, D_t)

    # Pointing law: capture axis on the line of sight; increments without twist about it.
    axis_L = R_LC @ (D_c / np.linalg.norm(D_c))
    pointing_error = _angle(axis_L, -r)
    increments = R_LC[1:] @ R_LC[:-1].transpose(0, 2, 1)
    rotvec = _rotation_vectors(increments)
    bisector = -(
        r[:-1] / np.linalg.norm(r[:-1], axis=1)[:, None]
        + r[1:] / np.linalg.norm(r[1:], axis=1)[:, None]
    )
    bisector /= np.linalg.norm(bisector, axis=1)[:, None]
    twist = np.abs(np.sum(rotvec * bisector, axis=1))

    # Collision metric by an independent LP at the plan's poses.
    alpha = np.array(
        [
            scaling_alpha_lp(
                chaser_hull.A,
                chaser_hull.b,
                R_LC[k],
                r[k],
                target_hull.A,
                target_hull.b,
                R_LT[k],
                np.zeros(3),
            )
            for k in range(N)
        ]
    )

    return PlanCheckReport(
        dynamics_residual=float(np.abs(residual).max()),
        initial_state_error=x0_error,
        thrust_excess_N=float((np.linalg.norm(u, axis=1) - config.max_thrust_N).max()),
        speed_excess_m_s=float((np.linalg.norm(v, axis=1) - config.max_speed_m_s).max()),
        range_excess_m=float((np.linalg.norm(r, axis=1) - config.max_range_m).max()),
        los_angle_excess_rad=float((los_angles - phi).max()),
        max_los_angle_rad=float(los_angles.max()),
        docking_cone_excess_m=float((lateral - tan_dock * axial).max()),
        terminal_position_excess_m=float(
            np.linalg.norm(r[-1] - p_star) - config.capture_position_tol_m
        ),
        terminal_velocity_excess_m_s=float(
            np.linalg.norm(v[-1] - v_star) - config.capture_speed_tol_m_s
        ),
        capture_point_speed_m_s=float(
            np.linalg.norm(chaser_point_velocity - target_point_velocity)
        ),
        pointing_error_rad=float(pointing_error.max()),
        pointing_twist_rad=float(twist.max()) if len(twist) else 0.0,
        alpha_check=alpha,
        min_alpha=float(np.min(alpha)),
        alpha_mismatch=float(np.abs(alpha - plan.alpha).max()),
        prediction_mismatch=prediction_mismatch,
        collision_free=bool(np.all(alpha > 1.0)),
    )


def _rotation_vectors(R: np.ndarray) -> np.ndarray:
    """Rotation vectors (axis * angle) of rotation matrices (K, 3, 3), for angles < pi."""
    skew = np.stack(
        [R[:, 2, 1] - R[:, 1, 2], R[:, 0, 2] - R[:, 2, 0], R[:, 1, 0] - R[:, 0, 1]], axis=1
    )  # 2 sin(angle) axis
    sin2 = np.linalg.norm(skew, axis=1)
    cos = np.clip((np.trace(R, axis1=1, axis2=2) - 1.0) / 2.0, -1.0, 1.0)
    angle = np.arctan2(0.5 * sin2, cos)
    scale = np.where(sin2 > 1e-300, angle / np.where(sin2 > 1e-300, sin2, 1.0), 0.5)
    return skew * scale[:, None]
