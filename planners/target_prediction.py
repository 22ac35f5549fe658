"""Prediction of a tumbling target's attitude and body rate over a planning horizon.

Owns: the planner's own prediction model of the target (DESIGN.md: truth and prediction are
different things): the torque-free Euler equations with quaternion kinematics (paper 000 eq.
(2)), integrated from the estimated attitude and rate, plus the turning of the LVLH frame L
itself, and interpolation between the planner's knots. Does not own: the truth tumble
(``rpod.systems``), state estimation, or the soft-capture program that consumes the prediction.

Frames. ``q_LT`` is the quaternion (w, x, y, z) of ``R_LT`` (target body T in LVLH L);
``w_IT_T`` is T's inertial angular velocity expressed in T, the rate Euler's equations govern.
Paper 000 writes eq. (2) for "the rotation from T to O" (O = L) with the body rate, i.e. it
treats L as inertial over the manoeuvre. Here L turns: in a circular orbit L rotates relative to
the inertial frame I at ``w_IL = n z_L`` about the orbit normal, whose direction is fixed in I.
Let I' be the inertial frame that coincides with L at the estimate time t0. Then
``R_I'L(t) = Rz(n (t - t0))`` and

    R_LT(t) = R_LI'(t) R_I'T(t) = Rz(-n (t - t0)) R_I'T(t),     R_I'T(t0) = R_LT(t0),

where ``R_I'T`` obeys eq. (2) exactly (I' is inertial). With ``n_orbit = 0`` this is paper 000's
model. In the paper's Table I orbit (a = 7738 km, n = 9.3e-4 rad/s), L turns by 0.32 rad over a
350 s horizon. That is not negligible: it would misplace the capture point D_t (2.7 m from the
centre of mass) by up to ~0.9 m, against eps_p = 0.35 m, so the soft-capture planner should
pass n. The quaternion of the product is sign-continuous in time, because both factors are.
Quaternion products and rotations go through ``pydrake.common.eigen_geometry.Quaternion``.

Integration: scipy ``solve_ivp`` with DOP853 (8th-order Dormand-Prince), ``rtol = atol =
1e-12``. Energy and angular momentum then hold to ~1e-11 relative over a 350 s horizon at
10 deg/s (tests). The quaternion is normalised at the knots only; its norm drifts by ~7e-12
over the horizon, so no projection is needed during the integration.

Interpolation: between knots, cubic Hermite splines (``pydrake.trajectories.
PiecewisePolynomial.CubicHermite``) of the four quaternion components and of the three rates,
whose knot slopes are the exact model derivatives (eq. (2) at each knot, no finite
differences); the quaternion is normalised after evaluation. This is fourth order: the error is
<= h^4/384 max|q''''| ~ h^4 (|w|/2)^4 / 384, ~3e-7 rad for h = 1 s at 10 deg/s.
``PiecewiseQuaternionSlerp`` (which the authors' public code also uses) is exact only for a
constant rotation about a fixed axis; under the nutation of a non-axisymmetric body it errs by
~h^2 |w_dot| / 8, 1.0e-3 rad for the paper's target (eq. (27)) at 10 deg/s with h = 1 s,
against 3e-7 rad for the Hermite spline (tests).
"""

from dataclasses import dataclass, field

import numpy as np
from pydrake.common.eigen_geometry import Quaternion
from pydrake.math import RotationMatrix
from pydrake.trajectories import PiecewisePolynomial

from rpod.models.rigid_body import angular_acceleration, quaternion_rate, validate_inertia

# DOP853 tolerances: ~1e-11 relative global error over a few hundred seconds of tumble (tests).
_RTOL = 1e-12
_ATOL = 1e-12
# A query time may exceed the knot span by this fraction of the span (round-off in t).
_SPAN_SLACK = 1e-9


def _lvlh_turn(n_orbit: float, tau: float) -> Quaternion:
    """Quaternion of ``Rz(-n tau)``, the turn of L relative to I' over tau seconds."""
    half = -0.5 * n_orbit * tau
    return Quaternion(np.cos(half), 0.0, 0.0, np.sin(half))


@dataclass(eq=False)
class TargetPrediction:
    """The predicted target attitude in LVLH and body rate, at knots and between them.

    Attributes:
        t: Knot times (N,), strictly increasing [s]; ``t[0]`` is the estimate's time.
        q_LT: Quaternions (N, 4) (w, x, y, z) of ``R_LT`` at the knots, unit, sign-continuous.
        w_IT_T: Inertial angular velocity of T expressed in T (N, 3) at the knots [rad/s].
        inertia: The target inertia (3, 3) about its centre of mass, in T [kg m^2], used for
            the rate slopes of the interpolation.
        n_orbit: LVLH rate about z_L [rad/s] (module docstring), used for the attitude slopes.
    """

    t: np.ndarray
    q_LT: np.ndarray
    w_IT_T: np.ndarray
    inertia: np.ndarray
    n_orbit: float = 0.0
    _q_spline: PiecewisePolynomial = field(init=False, repr=False)
    _w_spline: PiecewisePolynomial = field(init=False, repr=False)

    def __post_init__(self):
        self.t = np.asarray(self.t, dtype=float).reshape(-1)
        self.q_LT = np.asarray(self.q_LT, dtype=float)
        self.w_IT_T = np.asarray(self.w_IT_T, dtype=float)
        self.inertia = np.asarray(self.inertia, dtype=float)
        n = len(self.t)
        if n < 2 or not np.all(np.diff(self.t) > 0.0):
            raise ValueError("t must hold at least 2 strictly increasing knot times")
        if self.q_LT.shape != (n, 4) or self.w_IT_T.shape != (n, 3):
            raise ValueError(
                f"q_LT must be ({n}, 4) and w_IT_T ({n}, 3), got {self.q_LT.shape}, "
                f"{self.w_IT_T.shape}"
            )
        validate_inertia(self.inertia)
        J_inv = np.linalg.inv(self.inertia)
        # Exact slopes at the knots. Rates: Euler's equations (paper 000 eq. (2)).
        w_dot = np.array([angular_acceleration(self.inertia, w, J_inv=J_inv) for w in self.w_IT_T])
        # Attitude: q_LT_dot = 1/2 q_LT (x) [0, w_LT_T], w_LT_T = w_IT_T - R_LT^T (n z_L);
        # R_LT^T z_L is the third row of R_LT.
        q_dot = np.empty((n, 4))
        for k, (q, w) in enumerate(zip(self.q_LT, self.w_IT_T)):
            z_L_in_T = RotationMatrix(Quaternion(q / np.linalg.norm(q))).matrix()[2]
            q_dot[k] = quaternion_rate(q, w - float(self.n_orbit) * z_L_in_T)
        self._q_spline = PiecewisePolynomial.CubicHermite(self.t, self.q_LT.T, q_dot.T)
        self._w_spline = PiecewisePolynomial.CubicHermite(self.t, self.w_IT_T.T, w_dot.T)

    def _check_time(self, t: float) -> float:
        t = float(t)
        slack = _SPAN_SLACK * (self.t[-1] - self.t[0])
        if not (self.t[0] - slack <= t <= self.t[-1] + slack):
            raise ValueError(f"t = {t} is outside the predicted span [{self.t[0]}, {self.t[-1]}]")
        return t

    def q_LT_at(self, t: float) -> np.ndarray:
        """Unit quaternion (4,) of ``R_LT`` at time t (exact at knots, Hermite between)."""
        q = self._q_spline.value(self._check_time(t)).reshape(-1)
        return q / np.linalg.norm(q)

    def R_LT(self, t: float) -> np.ndarray:
        """``R_LT`` (3, 3) at time t in [t[0], t[-1]].

        Raises:
            ValueError: If t is outside the knot span (no extrapolation).
        """
        return RotationMatrix(Quaternion(self.q_LT_at(t))).matrix()

    def w_IT_T_at(self, t: float) -> np.ndarray:
        """``w_IT_T`` (3,) [rad/s] at time t in [t[0], t[-1]] (exact at knots, Hermite between).

        Raises:
            ValueError: If t is outside the knot span (no extrapolation).
        """
        return self._w_spline.value(self._check_time(t)).reshape(-1)


def predict_target(
    q_LT0, w_IT_T0, inertia, t_knots, n_orbit: float = 0.0, max_step_s: float = np.inf
) -> TargetPrediction:
    """Integrates the torque-free tumble (paper 000 eq. (2)) and samples it at the knots.

    Args:
        q_LT0: Estimated quaternion (4,) of ``R_LT`` at ``t_knots[0]`` (normalised here).
        w_IT_T0: Estimated inertial body rate (3,) of T, in T, at ``t_knots[0]`` [rad/s].
        inertia: Target inertia (3, 3) about its centre of mass, in T [kg m^2] (eq. (27) in
            the paper's examples).
        t_knots: Knot times (N,), N >= 2, strictly increasing [s]; the prediction starts at
            ``t_knots[0]`` (typically 0, or the current time when replanning).
        n_orbit: Mean motion of the circular orbit (rate of L about z_L) [rad/s]; 0 reproduces
            paper 000's model, which treats L as inertial (module docstring).
        max_step_s: Largest integrator step [s]; the default leaves the step to DOP853's error
            control (at rtol 1e-12 it takes ~1.8 s steps on average at 10 deg/s, ~2300 model
            evaluations and 50-90 ms for a 350 s horizon).

    Returns:
        The prediction at the knots, with interpolation in between.

    Raises:
        ValueError: On a non-finite or zero quaternion, a non-finite rate or orbit rate, a
            non-physical inertia, bad knots, or a non-positive ``max_step_s``.
        RuntimeError: If ``solve_ivp`` fails (not expected for finite inputs: the motion is
            smooth and |w| is bounded by energy conservation).
    """
    q0 = np.asarray(q_LT0, dtype=float).reshape(-1)
    w0 = np.asarray(w_IT_T0, dtype=float).reshape(-1)
    J = np.asarray(inertia, dtype=float)
    t_knots = np.asarray(t_knots, dtype=float).reshape(-1)
    q_norm = np.linalg.norm(q0) if q0.shape == (4,) else np.nan
    if not (np.isfinite(q_norm) and q_norm > 0.0):
        raise ValueError(f"q_LT0 must be 4 finite numbers with a non-zero norm, got {q_LT0}")
    if w0.shape != (3,) or not np.all(np.isfinite(w0)):
        raise ValueError(f"w_IT_T0 must be 3 finite numbers, got {w_IT_T0}")
    validate_inertia(J)
    if t_knots.size < 2 or not np.all(np.isfinite(t_knots)) or np.any(np.diff(t_knots) <= 0.0):
        raise ValueError("t_knots must hold at least 2 finite, strictly increasing times")
    if not np.isfinite(n_orbit):
        raise ValueError(f"n_orbit must be finite, got {n_orbit}")
    if not max_step_s > 0.0:
        raise ValueError(f"max_step_s must be > 0, got {max_step_s}")
    q0 = q0 / q_norm
    J_inv = np.linalg.inv(J)

    def rhs(_t, state):
        q_I_T, w = state[:4], state[4:]
        # Paper 000 eq. (2): q_dot = 1/2 L(q) [0; w], w_dot = J^-1 (-w x J w).
        return np.concatenate([quaternion_rate(q_I_T, w), angular_acceleration(J, w, J_inv=J_inv)])

    # State [q_I'T, w_IT_T] with I' = L at t_knots[0], so q_I'T(t0) = q_LT0.
    from scipy.integrate import solve_ivp  # at use: every rpod process starts ~0.25 s sooner

    solution = solve_ivp(
        rhs,
        (t_knots[0], t_knots[-1]),
        np.concatenate([q0, w0]),
        method="DOP853",
        t_eval=t_knots,
        rtol=_RTOL,
        atol=_ATOL,
        max_step=max_step_s,
    )
    if not solution.success:
        raise RuntimeError(f"predict_target: solve_ivp failed: {solution.message}")
    # R_LT = Rz(-n tau) R_I'T: q_LT = q_z(-n tau) (x) q_I'T, tau = t - t0 (module docstring).
    q_LT = np.array(
        [
            _lvlh_turn(float(n_orbit), t - t_knots[0])
            .multiply(Quaternion(q / np.linalg.norm(q)))
            .wxyz()
            for t, q in zip(t_knots, solution.y[:4].T)
        ]
    )
    return TargetPrediction(
        t=t_knots, q_LT=q_LT, w_IT_T=solution.y[4:].T.copy(), inertia=J, n_orbit=float(n_orbit)
    )
