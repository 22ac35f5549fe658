"""Paper 001's coupled 6-DOF relative-motion prediction model, constraints and cost (eqs. 1-21).

Owns, as scalar-generic numpy functions (float arrays, or numpy object arrays of pydrake
AutoDiffXd or symbolic.Expression, so that a planner gets exact derivatives of the same code):

- the state and input layouts of the NMPC prediction model (eq. 15) and their packing;
- the continuous dynamics x_dot = f(x, u): relative attitude on SO(3) (eq. 3), relative angular
  velocity (eq. 4), the feature-point relative translation (eqs. 7-10) with two-body orbits of
  both bodies (eq. 6), the wrench of the eight gimbaled thrusters (eqs. 11-12, through
  `rpod.models.gimbal.wrench_from_forces`) and the integral state (eq. 14);
- the eigenaxis error (eq. 5), the magnitude limit (eq. 17), the line-of-sight polyhedron
  (eq. 18) softened by slacks (Sec. IV), and the stage and terminal costs (eqs. 20-21) with the
  paper's Sec. IV weights;
- conversions between this relative state and the two bodies' absolute states.

Does not own: the optimal control problem (22), its transcription or solver (a planner builds
them from these functions), the truth simulation (rpod.systems), or perturbations (the paper's
f_p and tau_d are zero here: this is the prediction model); the gimbal pyramid (eq. 16), its
block matrix and the force-to-wrench matrix (rpod.models.gimbal); the cross product and its matrix (rpod.models.frames).

Frames and names (paper 001 -> rpod monogram). I: ECI (the paper's F_e); T: target body (F_t),
origin at its centre of mass t; C: chaser body (F_c), origin at c; Pt: the target feature point
(the rock, pt); Pc: the chaser feature point (the end effector, pc).

- R_c/t = R_t/e^T R_c/e -> ``R_TC`` (maps C components to T components); R_t/e -> ``R_IT``.
- w^t_c/t = R_c/t w^c_c/e - w^t_t/e -> ``w_TC_T``; w^t_t/e -> ``w_IT_T``; w^c_c/e -> ``w_IC_C``.
- p^t_pc/pt -> ``p_PtPc_T`` (from the rock to the end effector, in T); its derivative taken in
  the target frame F_t (the paper's t-dot), in T -> ``v_PtPc_T``.
- r^t_pt/t -> ``p_TPt_T`` and r^c_pc/c -> ``p_CPc_C`` (constant body-fixed lever arms).
- r_t/e, r_t/e-dot -> ``p_IT_I``, ``v_IT_I`` (target orbit, in I).

State x (STATE_SIZE = 39). The first 21 entries are the paper's x of eq. 15; the last 18 are the
absolute target quantities that eqs. 2, 6 and 10 need (no input reaches them):

    x[0:9]    R_TC, row-major (x[0:3] is R_TC's first row)         eq. 3
    x[9:12]   w_TC_T                                [rad/s]        eq. 4
    x[12:15]  p_PtPc_T                              [m]            eqs. 7, 9
    x[15:18]  v_PtPc_T (derivative seen in T)       [m/s]          eqs. 8, 9
    x[18:21]  xi_T, integral of p_PtPc_T            [m s]          eq. 14
    x[21:30]  R_IT, row-major                                      eq. 1
    x[30:33]  w_IT_T                                [rad/s]        eq. 2
    x[33:36]  p_IT_I                                [m]            eq. 6
    x[36:39]  v_IT_I                                [m/s]          eq. 6

The chaser's absolute state is not stored: it follows from x (`chaser_absolute_state`).

Input u (INPUT_SIZE = 24): the eight thrusters' force vectors on the chaser, expressed in C and
stacked thruster by thruster, u[3k:3k+3] = f_k in C [N], in the order of
`rpod.models.thrusters.gimbaled_cuboid_8` (face y = +2 m then y = -2 m; on each face the
corners (+x,+z), (-x,+z), (-x,-z), (+x,-z)). On a fixed bank (`layout.gimbaled` False; rpod's,
for the shoot-out's rcs_cube_12) u is one thrust per thruster, u_k in [0, f_max] [N], the
force f_k = u_k d_k along its fixed nozzle direction d_k: eqs. 11-12 with the gimbal angles
held at zero (`params.input_size` = n, the layout's command size; 3 n when gimbaled).

Choices where the paper is ambiguous or silent (each shown by a test where one can be):

1. Eq. 3 prints R_c/t-dot = R_c/t w^x without a clear frame superscript. With w_TC_T in the state
   (eq. 15 names w^t_c/t) the exact kinematics are R_TC-dot = [w_TC_T]x R_TC
   (= R_TC [w_TC_C]x); that is what is implemented (tested against two separately integrated
   bodies).
2. Eq. 10's printed form loses the factor 2 of the Coriolis term in our copy; the implemented
   form is the transport theorem applied twice, d2/dt2|_T of R_IT^T d_I =
   R_IT^T d_I'' - 2 w x R_IT^T d_I' - w' x R_IT^T d_I + w x (w x R_IT^T d_I), with
   w = w_IT_T, d_I = r_c/e - r_t/e (tested against two separately integrated orbits).
   The differential gravity is evaluated without the cancellation of two 8.9 m/s^2 numbers
   (`differential_two_body_acceleration`).
3. The input is the thrust vectors in C (the brief; rpod's wrench map takes C). The paper's
   f_tk are in the thruster frames K; R_k/c is constant, so f_k|C = R_CK f_k|K is a fixed linear
   change and eqs. 16-17 keep their form. The force is the one on the chaser, along the nominal
   direction -p_CK/|p_CK| (thrust along -j_K, eq. 13), as `gimbaled_cuboid_8` defines it.
4. Eq. 17 is implemented squared, |f_k|^2 - f_max^2 <= 0: the same set, but differentiable at
   f_k = 0 where |f_k| is not (an NLP starts there).
5. The LOS polyhedron (eq. 18): the paper gives its angle (pi/4) but neither its axis nor n_p.
   Chosen: a 4-face pyramid with apex at the rock and axis the outward radial direction of the
   rock, p_TPt_T/|p_TPt_T| (the surface normal of a round body), faces built like the gimbal
   pyramid of eq. 16. Sec. IV's start lies outside it (64.7 deg off axis), which is why the paper
   softens it with slacks; tested. Slacks s >= 0 enter as A_p p - s <= 0 with an L1 penalty
   rho sum(s), rho = LOS_SLACK_WEIGHT (the paper gives no value).
6. Sec. IV's weights: our copy prints "Q_xi = 109 I3" and "W_tau = 9 x 1013 I3" with the exponent
   signs lost. Read as 1e-9 and 9e-13: with +9 and +13 the integral term (|xi| ~ 1e4 m s on the
   Sec. IV approach) and the torque term (a 180 deg slew needs ~1 N m) would exceed every other
   term by more than ten orders of magnitude. D of eq. 20 is not given: D = I3, so the attitude
   term is Q_R (3 - tr R_TC) = 4 Q_R sin^2(theta / 2). P of eq. 21 is not given: the default is
   blkdiag(T Q_p, T Ts^2 Q_p) with Sec. IV's T = 480 s and Ts = T / N = 60 s (the position
   stage weight held for one horizon; a velocity error held one interval, as position).
7. The target's inertia is not given; J_t defaults to isotropic (a constant w_IT_T, as a steady
   spin w_t/e(0) = 0.0046 [1 1 1] rad/s describes). Only its ratios matter (no target torque).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
import pydrake.math

from rpod.models.frames import cross, cross_rows, skew, skew_rows
from rpod.models.gimbal import (
    force_to_wrench_matrix,
    pyramid_polyhedron,
    wrench_from_forces,
)
from rpod.models.gravity import MU_EARTH_M3_S2, circular_orbit_state, two_body_acceleration
from rpod.models.rigid_body import angular_acceleration
from rpod.models.thrusters import ThrusterLayout, gimbaled_cuboid_8

# --------------------------------------------------------------------------------------------
# Layouts.

STATE_SIZE = 39
INPUT_SIZE = 24
THRUSTER_COUNT = 8

R_TC_SLICE = slice(0, 9)
W_TC_T_SLICE = slice(9, 12)
P_PTPC_T_SLICE = slice(12, 15)
V_PTPC_T_SLICE = slice(15, 18)
XI_T_SLICE = slice(18, 21)
R_IT_SLICE = slice(21, 30)
W_IT_T_SLICE = slice(30, 33)
P_IT_I_SLICE = slice(33, 36)
V_IT_I_SLICE = slice(36, 39)
PAPER_STATE_SIZE = 21
"""x[:21] is paper 001's state of eq. 15; x[21:] the absolute target quantities."""

# --------------------------------------------------------------------------------------------
# Paper 001 Sec. IV data.

CHASER_SIZE_M = (1.5, 4.0, 1.5)
"""Chaser cuboid edges along C's x, y, z (Sec. IV)."""
CHASER_MASS_KG = 4000.0
"""m_c (Sec. IV)."""
CHASER_INERTIA_KG_M2 = np.diag([6.0833e3, 1.5e3, 6.0833e3])
"""J_c (Sec. IV), = a uniform 4000 kg cuboid of 1.5 x 4 x 1.5 m to the 5 digits printed."""
TARGET_FEATURE_POINT_T_M = np.array([1.1404, 3.3462, 5.8907])
"""r^t_pt/t, the rock on the asteroid from its centre of mass, in T (Sec. IV)."""
CHASER_FEATURE_POINT_C_M = np.array([0.0, 0.0, -1.75])
"""r^c_pc/c, the end effector from the chaser's centre of mass, in C (Sec. IV)."""
TARGET_ALTITUDE_M = 300e3
"""Target circular-orbit altitude (Sec. IV)."""
MAX_THRUST_N = 20.0
"""f_max of eq. 17 (Sec. IV)."""
GIMBAL_HALF_ANGLE_RAD = math.pi / 4
"""Gimbal polyhedron angle of eq. 16 (Sec. IV)."""
LOS_HALF_ANGLE_RAD = math.pi / 4
"""LOS polyhedron angle of eq. 18 (Sec. IV)."""
LOS_FACES = 4
"""n_p of eq. 18: not given by the paper; 4, as eq. 16's n (module docstring, choice 5)."""
HORIZON_S = 480.0
"""T of eq. 22 (Sec. IV)."""
HORIZON_INTERVALS = 8
"""N of Sec. III-D (Sec. IV)."""
LOS_SLACK_WEIGHT = 1e3
"""rho of the L1 penalty on the LOS slacks [1/m per unit of cost]: the paper gives none. Large
against the cost's slope in p near the cone (2 Q_p |p| ~ 2.3 per m at Sec. IV's 113 m), so a
feasible trajectory is preferred whenever there is one (exact-penalty argument)."""

# Sec. IV weights of eqs. 20-21 (see the module docstring, choice 6, for the exponent signs).
ATTITUDE_WEIGHT = 70.0
"""Q_R (Sec. IV)."""
ATTITUDE_SHAPE = np.eye(3)
"""D of eq. 20: not given by the paper; identity (choice 6)."""
RATE_WEIGHT = 5.0 * np.eye(3)
"""Q_w (Sec. IV)."""
POSITION_WEIGHT = 0.01 * np.eye(3)
"""Q_p (Sec. IV)."""
INTEGRAL_WEIGHT = 1e-9 * np.eye(3)
"""Q_xi (Sec. IV, exponent sign read as negative: choice 6)."""
TORQUE_WEIGHT = 9e-13 * np.eye(3)
"""W_tau (Sec. IV, exponent sign read as negative: choice 6)."""
FORCE_WEIGHT = np.eye(INPUT_SIZE)
"""W_f (Sec. IV)."""


def _default_terminal_weight() -> np.ndarray:
    """P of eq. 21 (not in the paper): blkdiag(T Q_p, T Ts^2 Q_p), choice 6."""
    Ts = HORIZON_S / HORIZON_INTERVALS
    P = np.zeros((6, 6))
    P[:3, :3] = HORIZON_S * POSITION_WEIGHT
    P[3:, 3:] = HORIZON_S * Ts * Ts * POSITION_WEIGHT
    return P


@dataclass
class CoupledRelativeParams:
    """Physical data of the prediction model (defaults: paper 001 Sec. IV).

    Attributes:
        chaser_mass_kg: m_c [kg].
        J_c: Chaser inertia about its centre of mass, in C (3, 3) [kg m^2].
        J_t: Target inertia about its centre of mass, in T (3, 3) [kg m^2] (not in the paper:
            isotropic, module docstring choice 7; only its ratios matter).
        p_TPt_T: r^t_pt/t, the target feature point from t, in T (3,) [m].
        p_CPc_C: r^c_pc/c, the chaser feature point from c, in C (3,) [m].
        layout: The thrusters (positions, nominal directions, limits): paper 001's eight
            gimbaled ones (force vectors), or a fixed bank (one thrust each, module docstring).
        mu: Gravitational parameter of the central body [m^3/s^2].
    """

    chaser_mass_kg: float = CHASER_MASS_KG
    J_c: np.ndarray = field(default_factory=lambda: CHASER_INERTIA_KG_M2.copy())
    J_t: np.ndarray = field(default_factory=lambda: np.eye(3))
    p_TPt_T: np.ndarray = field(default_factory=lambda: TARGET_FEATURE_POINT_T_M.copy())
    p_CPc_C: np.ndarray = field(default_factory=lambda: CHASER_FEATURE_POINT_C_M.copy())
    layout: ThrusterLayout = field(
        default_factory=lambda: gimbaled_cuboid_8(
            size=CHASER_SIZE_M,
            max_thrust_N=MAX_THRUST_N,
            gimbal_half_angle_rad=GIMBAL_HALF_ANGLE_RAD,
        )
    )
    mu: float = MU_EARTH_M3_S2

    def __post_init__(self):
        self.J_c = np.asarray(self.J_c, dtype=float)
        self.J_t = np.asarray(self.J_t, dtype=float)
        self.p_TPt_T = np.asarray(self.p_TPt_T, dtype=float)
        self.p_CPc_C = np.asarray(self.p_CPc_C, dtype=float)
        if self.layout.gimbaled and self.layout.count != THRUSTER_COUNT:
            raise ValueError(
                f"a gimbaled layout must hold paper 001's {THRUSTER_COUNT} thrusters (the NLP's "
                f"transcriptions are written for them), got {self.layout.count}"
            )
        if self.layout.count < 1:
            raise ValueError("layout must hold at least one thruster")
        self.input_size = int(self.layout.command_size)  # 3 n gimbaled, n fixed
        if not (math.isfinite(self.chaser_mass_kg) and self.chaser_mass_kg > 0.0):
            raise ValueError(f"chaser_mass_kg must be > 0, got {self.chaser_mass_kg!r}")
        self.J_c_inv = np.linalg.inv(self.J_c)
        self.J_t_inv = np.linalg.inv(self.J_t)


@dataclass
class CoupledNmpcWeights:
    """Weights of the stage cost (eq. 20) and terminal cost (eq. 21); defaults: Sec. IV.

    Attributes:
        Q_R: Attitude weight (scalar).
        D: Diagonal positive-definite attitude shape (3, 3) (not in the paper: identity).
        Q_w: Relative angular velocity weight (3, 3).
        Q_p: Feature-point position weight (3, 3).
        Q_xi: Integral-state weight (3, 3).
        W_tau: Chaser torque weight (3, 3).
        W_f: Thrust-vector weight (24, 24).
        P: Terminal weight on [p_PtPc_T; v_PtPc_T] (6, 6) (not in the paper: choice 6).
    """

    Q_R: float = ATTITUDE_WEIGHT
    D: np.ndarray = field(default_factory=lambda: ATTITUDE_SHAPE.copy())
    Q_w: np.ndarray = field(default_factory=lambda: RATE_WEIGHT.copy())
    Q_p: np.ndarray = field(default_factory=lambda: POSITION_WEIGHT.copy())
    Q_xi: np.ndarray = field(default_factory=lambda: INTEGRAL_WEIGHT.copy())
    W_tau: np.ndarray = field(default_factory=lambda: TORQUE_WEIGHT.copy())
    W_f: np.ndarray = field(default_factory=lambda: FORCE_WEIGHT.copy())
    P: np.ndarray = field(default_factory=_default_terminal_weight)


class CoupledState(NamedTuple):
    """The state x unpacked (module docstring for frames and units)."""

    R_TC: np.ndarray
    w_TC_T: np.ndarray
    p_PtPc_T: np.ndarray
    v_PtPc_T: np.ndarray
    xi_T: np.ndarray
    R_IT: np.ndarray
    w_IT_T: np.ndarray
    p_IT_I: np.ndarray
    v_IT_I: np.ndarray


def unpack_state(x: np.ndarray) -> CoupledState:
    """Splits x (39,) into its named parts; rotation matrices come back (3, 3), row-major."""
    x = np.asarray(x)
    return CoupledState(
        R_TC=x[R_TC_SLICE].reshape(3, 3),
        w_TC_T=x[W_TC_T_SLICE],
        p_PtPc_T=x[P_PTPC_T_SLICE],
        v_PtPc_T=x[V_PTPC_T_SLICE],
        xi_T=x[XI_T_SLICE],
        R_IT=x[R_IT_SLICE].reshape(3, 3),
        w_IT_T=x[W_IT_T_SLICE],
        p_IT_I=x[P_IT_I_SLICE],
        v_IT_I=x[V_IT_I_SLICE],
    )


def pack_state(state: CoupledState) -> np.ndarray:
    """The inverse of `unpack_state`: x (39,), rotation matrices flattened row-major."""
    return np.concatenate(
        [
            np.asarray(state.R_TC).reshape(9),
            state.w_TC_T,
            state.p_PtPc_T,
            state.v_PtPc_T,
            state.xi_T,
            np.asarray(state.R_IT).reshape(9),
            state.w_IT_T,
            state.p_IT_I,
            state.v_IT_I,
        ]
    )


# --------------------------------------------------------------------------------------------
# Scalar-generic helpers (products and sums only, so AutoDiffXd and Expression pass through).


def _dot(a, b):
    a0, a1, a2 = np.asarray(a).tolist()
    b0, b1, b2 = np.asarray(b).tolist()
    return a0 * b0 + a1 * b1 + a2 * b2


def differential_two_body_acceleration(p_IT_I, d_I, mu: float = MU_EARTH_M3_S2) -> np.ndarray:
    """g(p_IT_I + d_I) - g(p_IT_I) for point-mass gravity g = -mu r / |r|^3 (eq. 6), in I.

    Written without subtracting the two ~8.9 m/s^2 accelerations: with r_t = |p_IT_I| and
    r_c = |p_IT_I + d_I|, 1/r_c^3 - 1/r_t^3 = -(2 p.d + d.d)(r_t^2 + r_t r_c + r_c^2) /
    ((r_t + r_c) r_c^3 r_t^3), so the result keeps full relative precision for |d| << r_t.
    """
    r_c_I = np.asarray(p_IT_I) + np.asarray(d_I)
    rt2 = _dot(p_IT_I, p_IT_I)
    rc2 = _dot(r_c_I, r_c_I)
    rt = rt2**0.5
    rc = rc2**0.5
    rt3 = rt2 * rt
    rc3 = rc2 * rc
    diff_sq = 2.0 * _dot(p_IT_I, d_I) + _dot(d_I, d_I)  # r_c^2 - r_t^2, no cancellation
    inv_cube_diff = -diff_sq * (rt2 + rt * rc + rc2) / ((rt + rc) * rc3 * rt3)
    return -mu * (np.asarray(d_I) / rc3 + np.asarray(p_IT_I) * inv_cube_diff)


# --------------------------------------------------------------------------------------------
# Thrusters (eqs. 11-12).


def thruster_forces_C(u, params: CoupledRelativeParams | None = None) -> np.ndarray:
    """The input u as rows f_k in C (n, 3) [N]: u reshaped (gimbaled; params None: paper 001's
    24), or on a fixed bank u_k d_k (module docstring). Scalar-generic."""
    if params is not None and not params.layout.gimbaled:
        return np.asarray(u)[:, None] * params.layout.directions_C
    return np.asarray(u).reshape(-1, 3)


def chaser_wrench(params: CoupledRelativeParams, u) -> np.ndarray:
    """Body wrench [tau_C; f_C] (6,) of the eight thrust vectors (eqs. 11-12), in C.

    f_C = sum_k f_k (eq. 11) and tau_C = sum_k p_CK_C x f_k (eq. 12), from
    `rpod.models.gimbal.wrench_from_forces` (scalar-generic).
    """
    return wrench_from_forces(params.layout, thruster_forces_C(u, params))


# --------------------------------------------------------------------------------------------
# Dynamics.


def relative_attitude_rate(R_TC, w_TC_T) -> np.ndarray:
    """R_TC-dot = [w_TC_T]x R_TC = R_TC [w_TC_C]x (eq. 3; module docstring choice 1)."""
    return skew(w_TC_T) @ R_TC


def relative_angular_acceleration(
    params: CoupledRelativeParams, R_TC, w_TC_T, w_IT_T, tau_C
) -> np.ndarray:
    """w_TC_T-dot, the derivative seen in T of w^t_c/t, in T (eq. 4).

    w_TC_T-dot = R_TC J_c^-1 (J_c w_IC_C x w_IC_C + tau_C) - J_t^-1 (J_t w_IT_T x w_IT_T)
                 + w_TC_T x (R_TC w_IC_C),  with w_IC_C = R_TC^T (w_TC_T + w_IT_T) (eq. 4 def.).
    """
    w_IC_T = np.asarray(w_TC_T) + np.asarray(w_IT_T)  # R_c/t w^c_c/e (definition below eq. 3)
    w_IC_C = R_TC.T @ w_IC_T
    w_IC_C_dot = angular_acceleration(params.J_c, w_IC_C, tau_C, params.J_c_inv)  # eq. 2
    w_IT_T_dot = angular_acceleration(params.J_t, w_IT_T, None, params.J_t_inv)  # eq. 2
    return R_TC @ w_IC_C_dot - w_IT_T_dot + cross(w_TC_T, w_IC_T)  # eq. 4


def dynamics(x, u, params: CoupledRelativeParams) -> np.ndarray:
    """x_dot = f(x, u) of the prediction model (eq. 15), same layout as x.

    Args:
        x: State (39,) (module docstring); float or object (AutoDiffXd, Expression) array.
        u: Thrust vectors (24,) in C [N]; float or object array.
        params: Physical data.

    Returns:
        x_dot (39,); an object array when x or u is one.
    """
    s = unpack_state(x)
    R_TC, w_TC_T, w_IT_T, R_IT = s.R_TC, s.w_TC_T, s.w_IT_T, s.R_IT
    wrench = chaser_wrench(params, u)
    tau_C, f_C = wrench[:3], wrench[3:]

    # Attitude (eqs. 1-4).
    R_TC_dot = relative_attitude_rate(R_TC, w_TC_T)  # eq. 3
    w_TC_T_dot = relative_angular_acceleration(params, R_TC, w_TC_T, w_IT_T, tau_C)  # eq. 4
    R_IT_dot = R_IT @ skew(w_IT_T)  # eq. 1 (target)
    w_IT_T_dot = angular_acceleration(params.J_t, w_IT_T, None, params.J_t_inv)  # eq. 2

    # Translation (eqs. 6-10).
    p_PcC_T = R_TC @ params.p_CPc_C  # r_pc/c resolved in T
    d_T = s.p_PtPc_T - p_PcC_T + params.p_TPt_T  # r^t_c/t from eq. 7
    d_T_dot = s.v_PtPc_T - cross(w_TC_T, p_PcC_T)  # t-derivative of r_c/t from eq. 8
    u_T = d_T_dot + cross(w_IT_T, d_T)  # R_t/e^T (r_c/e-dot - r_t/e-dot), transport theorem
    d_I = R_IT @ d_T
    gravity_diff_T = R_IT.T @ differential_two_body_acceleration(s.p_IT_I, d_I, params.mu)
    a_rel_T = gravity_diff_T + (R_TC @ f_C) / params.chaser_mass_kg  # R_t/e^T (eq. 6 c - t)
    d_T_ddot = (
        a_rel_T
        - 2.0 * cross(w_IT_T, u_T)
        - cross(w_IT_T_dot, d_T)
        + cross(w_IT_T, cross(w_IT_T, d_T))
    )  # eq. 10 (module docstring choice 2)
    p_ddot_T = (
        d_T_ddot + cross(w_TC_T_dot, p_PcC_T) + cross(w_TC_T, cross(w_TC_T, p_PcC_T))
    )  # eq. 9
    xi_dot = integral_state_rate(s.p_PtPc_T)  # eq. 14
    p_IT_I_dot = s.v_IT_I  # eq. 6 (target)
    v_IT_I_dot = two_body_acceleration(s.p_IT_I, params.mu)  # eq. 6 (target)

    return np.concatenate(
        [
            R_TC_dot.reshape(9),
            w_TC_T_dot,
            s.v_PtPc_T,
            p_ddot_T,
            xi_dot,
            R_IT_dot.reshape(9),
            w_IT_T_dot,
            p_IT_I_dot,
            v_IT_I_dot,
        ]
    )


def _matvec_rows(R, v) -> np.ndarray:
    """R_b v_b for (B, 3, 3) and (B, 3)."""
    return np.matmul(R, v[:, :, None])[:, :, 0]


def _matTvec_rows(R, v) -> np.ndarray:
    """R_b^T v_b for (B, 3, 3) and (B, 3)."""
    return np.matmul(v[:, None, :], R)[:, 0, :]


def dynamics_batch(
    x: np.ndarray, u: np.ndarray | None, params: CoupledRelativeParams, wrench=None
) -> np.ndarray:
    """`dynamics` for B states at once: x (B, 39), u (B, 24) -> x_dot (B, 39).

    The same equations as `dynamics` (the reference, scalar-generic; tested equal to 1e-15
    relative), vectorised over rows with numpy for the planners' hot path. Every operation is
    complex-analytic (products, sums and a square root of a sum of squares, never abs or
    conjugation), so a complex x + i h e_j gives the exact directional derivative in the
    imaginary part (complex-step differentiation, used by rpod.planners.coupled_shooting).
    `wrench` (B, 6), [tau_C; f_C], replaces u when given: the input enters only through the
    wrench of eqs. 11-12, so derivatives need 6 directions, not 24.
    """
    B = x.shape[0]
    R_TC = x[:, R_TC_SLICE].reshape(B, 3, 3)
    w_TC_T = x[:, W_TC_T_SLICE]
    p_PtPc_T = x[:, P_PTPC_T_SLICE]
    v_PtPc_T = x[:, V_PTPC_T_SLICE]
    R_IT = x[:, R_IT_SLICE].reshape(B, 3, 3)
    w_IT_T = x[:, W_IT_T_SLICE]
    p_IT_I = x[:, P_IT_I_SLICE]
    v_IT_I = x[:, V_IT_I_SLICE]
    if wrench is None:
        wrench = u @ _force_to_wrench_matrix(params).T  # eqs. 11-12
    tau_C, f_C = wrench[:, :3], wrench[:, 3:]

    # Attitude (eqs. 1-4).
    R_TC_dot = np.matmul(skew_rows(w_TC_T), R_TC)  # eq. 3: [w]x R
    w_IC_T = w_TC_T + w_IT_T
    w_IC_C = _matTvec_rows(R_TC, w_IC_T)
    w_IC_C_dot = (cross_rows(w_IC_C @ params.J_c.T, w_IC_C) + tau_C) @ params.J_c_inv.T  # eq. 2
    w_IT_T_dot = cross_rows(w_IT_T @ params.J_t.T, w_IT_T) @ params.J_t_inv.T  # eq. 2
    w_TC_T_dot = _matvec_rows(R_TC, w_IC_C_dot) - w_IT_T_dot + cross_rows(w_TC_T, w_IC_T)  # eq. 4
    R_IT_dot = np.matmul(R_IT, skew_rows(w_IT_T))  # eq. 1: R [w]x

    # Translation (eqs. 6-10), as `dynamics`.
    p_PcC_T = R_TC @ params.p_CPc_C
    d_T = p_PtPc_T - p_PcC_T + params.p_TPt_T  # eq. 7
    d_T_dot = v_PtPc_T - cross_rows(w_TC_T, p_PcC_T)  # eq. 8
    u_T = d_T_dot + cross_rows(w_IT_T, d_T)
    d_I = _matvec_rows(R_IT, d_T)
    rt2 = np.sum(p_IT_I * p_IT_I, axis=1)
    r_c_I = p_IT_I + d_I
    rc2 = np.sum(r_c_I * r_c_I, axis=1)
    rt, rc = rt2**0.5, rc2**0.5
    rc3 = rc2 * rc
    diff_sq = 2.0 * np.sum(p_IT_I * d_I, axis=1) + np.sum(d_I * d_I, axis=1)
    inv_cube_diff = -diff_sq * (rt2 + rt * rc + rc2) / ((rt + rc) * rc3 * rt2 * rt)
    gravity_diff_I = -params.mu * (d_I / rc3[:, None] + p_IT_I * inv_cube_diff[:, None])
    a_rel_T = _matTvec_rows(R_IT, gravity_diff_I) + _matvec_rows(R_TC, f_C) / params.chaser_mass_kg
    d_T_ddot = (
        a_rel_T
        - 2.0 * cross_rows(w_IT_T, u_T)
        - cross_rows(w_IT_T_dot, d_T)
        + cross_rows(w_IT_T, cross_rows(w_IT_T, d_T))
    )  # eq. 10
    p_ddot_T = (
        d_T_ddot + cross_rows(w_TC_T_dot, p_PcC_T) + cross_rows(w_TC_T, cross_rows(w_TC_T, p_PcC_T))
    )  # eq. 9
    v_IT_I_dot = -params.mu * p_IT_I / (rt2 * rt)[:, None]  # eq. 6 (target)

    return np.concatenate(
        [
            R_TC_dot.reshape(B, 9),
            w_TC_T_dot,
            v_PtPc_T,
            p_ddot_T,
            p_PtPc_T,  # eq. 14
            R_IT_dot.reshape(B, 9),
            w_IT_T_dot,
            v_IT_I,
            v_IT_I_dot,
        ],
        axis=1,
    )


def target_dynamics(x_target: np.ndarray, params: CoupledRelativeParams) -> np.ndarray:
    """The derivative of the target's part x[21:] (18,) alone (floats): eqs. 1, 2 and 6 of
    `dynamics`, which no input or chaser state reaches; for propagating the target's
    reference cheaply."""
    R_IT = x_target[0:9].reshape(3, 3)
    w = x_target[9:12]
    p = x_target[12:15]
    out = np.empty(18)
    out[9:12] = params.J_t_inv @ cross(params.J_t @ w, w)  # eq. 2, torque-free
    out[0:9] = (R_IT @ skew(w)).reshape(9)
    r2 = p @ p
    out[12:15] = x_target[15:18]
    out[15:18] = (-params.mu / (r2 * math.sqrt(r2))) * p  # eq. 6
    return out  # eqs. 1, 2, 6


def _force_to_wrench_matrix(params: CoupledRelativeParams) -> np.ndarray:
    """M (6, m) with [tau_C; f_C] = M u (eqs. 11-12 are linear in u): the layout's
    `rpod.models.gimbal.force_to_wrench_matrix`, times the block-diagonal of the nozzle
    directions on a fixed bank (f_k = u_k d_k), cached on params."""
    M = getattr(params, "_wrench_matrix", None)
    if M is None:
        M = force_to_wrench_matrix(params.layout)
        if not params.layout.gimbaled:
            n = params.layout.count
            directions = np.zeros((3 * n, n))
            for k, d in enumerate(params.layout.directions_C):
                directions[3 * k : 3 * k + 3, k] = d
            M = M @ directions
        params._wrench_matrix = M
    return M


def integral_state_rate(p_PtPc_T) -> np.ndarray:
    """xi_T-dot = p_PtPc_T (eq. 14)."""
    return np.asarray(p_PtPc_T)


# --------------------------------------------------------------------------------------------
# Relative <-> absolute (float or generic).


def relative_state_from_absolute(
    params: CoupledRelativeParams,
    R_IT,
    w_IT_T,
    p_IT_I,
    v_IT_I,
    R_IC,
    w_IC_C,
    p_IC_I,
    v_IC_I,
    xi_T=None,
) -> np.ndarray:
    """x (39,) from both bodies' absolute states (eqs. 3, 4 def., 7, 8).

    Args:
        R_IT, R_IC: Attitudes R_t/e, R_c/e (3, 3).
        w_IT_T, w_IC_C: Body angular velocities [rad/s].
        p_IT_I, v_IT_I, p_IC_I, v_IC_I: Centre-of-mass positions and velocities in I.
        xi_T: Integral state (default zero).
    """
    R_IT = np.asarray(R_IT)
    R_TC = R_IT.T @ np.asarray(R_IC)  # R_c/t = R_t/e^T R_c/e
    w_TC_T = R_TC @ np.asarray(w_IC_C) - np.asarray(w_IT_T)  # definition below eq. 3
    d_T = R_IT.T @ (np.asarray(p_IC_I) - np.asarray(p_IT_I))
    p_PcC_T = R_TC @ params.p_CPc_C
    p_PtPc_T = d_T + p_PcC_T - params.p_TPt_T  # eq. 7
    d_T_dot = R_IT.T @ (np.asarray(v_IC_I) - np.asarray(v_IT_I)) - cross(w_IT_T, d_T)
    v_PtPc_T = d_T_dot + cross(w_TC_T, p_PcC_T)  # eq. 8
    return pack_state(
        CoupledState(
            R_TC=R_TC,
            w_TC_T=w_TC_T,
            p_PtPc_T=p_PtPc_T,
            v_PtPc_T=v_PtPc_T,
            xi_T=np.zeros(3) if xi_T is None else np.asarray(xi_T),
            R_IT=R_IT,
            w_IT_T=np.asarray(w_IT_T),
            p_IT_I=np.asarray(p_IT_I),
            v_IT_I=np.asarray(v_IT_I),
        )
    )


def chaser_absolute_state(params: CoupledRelativeParams, x) -> tuple[np.ndarray, ...]:
    """(R_IC, w_IC_C, p_IC_I, v_IC_I) of the chaser from x; the inverse of eqs. 7-8."""
    s = unpack_state(x)
    R_IC = s.R_IT @ s.R_TC
    w_IC_C = s.R_TC.T @ (s.w_TC_T + s.w_IT_T)
    p_PcC_T = s.R_TC @ params.p_CPc_C
    d_T = s.p_PtPc_T - p_PcC_T + params.p_TPt_T
    d_T_dot = s.v_PtPc_T - cross(s.w_TC_T, p_PcC_T)
    p_IC_I = s.p_IT_I + s.R_IT @ d_T
    v_IC_I = s.v_IT_I + s.R_IT @ (d_T_dot + cross(s.w_IT_T, d_T))
    return R_IC, w_IC_C, p_IC_I, v_IC_I


# --------------------------------------------------------------------------------------------
# Attitude error (eq. 5).


def eigenaxis_error(R_TC):
    """theta_c/t = acos((tr R_TC - 1) / 2) in [0, pi] (eq. 5).

    Floats: the argument is clipped to [-1, 1] against round-off. AutoDiffXd / Expression go
    through pydrake.math.acos (its derivative is unbounded at theta = 0 and pi: use the smooth
    tr(D - D R) of eq. 20 in a cost, this function for reporting).
    """
    R = np.asarray(R_TC)
    c = 0.5 * (R[0, 0] + R[1, 1] + R[2, 2] - 1.0)
    if R.dtype == object:
        return pydrake.math.acos(c)
    return float(np.arccos(np.clip(c, -1.0, 1.0)))


# --------------------------------------------------------------------------------------------
# Constraints (eqs. 17-19; eq. 16 is rpod.models.gimbal's): each returns g, g <= 0 satisfied.


def thrust_magnitude_constraints(u, max_thrust_N: float = MAX_THRUST_N) -> np.ndarray:
    """|f_k|^2 - f_max^2 (8,) (eq. 17, squared: module docstring choice 4) [N^2]; <= 0 is OK."""
    F = thruster_forces_C(u)
    return np.array([_dot(F[k], F[k]) for k in range(F.shape[0])]) - max_thrust_N**2


def los_polyhedron(
    p_TPt_T=TARGET_FEATURE_POINT_T_M, half_angle_rad: float = LOS_HALF_ANGLE_RAD
) -> np.ndarray:
    """A_p (4, 3) of eq. 18: {p_PtPc_T : A_p p <= 0} (module docstring choice 5).

    Axis: the outward radial direction of the rock, p_TPt_T / |p_TPt_T|; lateral axes as rpod's
    thruster frames pick them (unit(a x axis) with a the T axis least aligned with the axis,
    then axis x that); the rows are `rpod.models.gimbal.pyramid_polyhedron`'s.
    """
    p = np.asarray(p_TPt_T, dtype=float)
    axis = p / np.linalg.norm(p)
    a = np.zeros(3)
    a[int(np.argmin(np.abs(axis)))] = 1.0
    e1 = np.cross(a, axis)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(e1, axis)
    return pyramid_polyhedron(axis, e1, e2, half_angle_rad)


def los_constraints(A_p: np.ndarray, x, slack=None) -> np.ndarray:
    """A_p p_PtPc_T - s (eq. 18, softened as in Sec. IV); <= 0 when satisfied [m].

    Args:
        A_p: Rows of `los_polyhedron`.
        x: State (39,).
        slack: s >= 0, one per row (None: the hard constraint of eq. 18).
    """
    g = np.asarray(A_p) @ unpack_state(x).p_PtPc_T
    return g if slack is None else g - np.asarray(slack)


def los_slack_penalty(slack, weight: float = LOS_SLACK_WEIGHT):
    """rho sum(s), the L1 penalty on the LOS slacks (s >= 0 is the planner's bound)."""
    return weight * np.sum(np.asarray(slack))


# --------------------------------------------------------------------------------------------
# Cost (eqs. 20-21).


def _quadratic(v, Q):
    v = np.asarray(v)
    return v @ (np.asarray(Q) @ v)


def stage_cost(x, u, weights: CoupledNmpcWeights, params: CoupledRelativeParams):
    """F(x, u) of eq. 20, a scalar of the input's scalar type.

    F = Q_R tr(D - D R_TC) + w^T Q_w w + p^T Q_p p + xi^T Q_xi xi + tau^T W_tau tau + u^T W_f u,
    with tau_C the thrusters' torque (eq. 12).
    """
    s = unpack_state(x)
    D = np.asarray(weights.D)
    DR = D @ s.R_TC
    attitude = weights.Q_R * (np.trace(D) - (DR[0, 0] + DR[1, 1] + DR[2, 2]))
    tau_C = chaser_wrench(params, u)[:3]  # eq. 12
    return (
        attitude
        + _quadratic(s.w_TC_T, weights.Q_w)
        + _quadratic(s.p_PtPc_T, weights.Q_p)
        + _quadratic(s.xi_T, weights.Q_xi)
        + _quadratic(tau_C, weights.W_tau)
        + _quadratic(np.asarray(u), weights.W_f)
    )  # eq. 20


def terminal_cost(x, weights: CoupledNmpcWeights):
    """E(x) = [p; v]^T P [p; v] of eq. 21, with p = p_PtPc_T and v = v_PtPc_T."""
    s = unpack_state(x)
    return _quadratic(np.concatenate([s.p_PtPc_T, s.v_PtPc_T]), weights.P)  # eq. 21


def sec_iv_initial_state(params: CoupledRelativeParams | None = None) -> np.ndarray:
    """Sec. IV's start as this model's state: the target on a circular orbit at
    TARGET_ALTITUDE_M, R_t/e(0) = I and w^t_t/e = 0.0046 [1, 1, 1] rad/s; the chaser 116.43 m
    away (r_c/t(0) as printed), R_c/e(0) = diag(-1, -1, 1), at rest. It reproduces the printed
    p(0) = [-1.1394, 113.0847, -7.6204] m (tested); the printed relative velocity is garbled in
    our copy and not reproduced."""
    params = CoupledRelativeParams() if params is None else params
    p_IT_I, v_IT_I = circular_orbit_state(TARGET_ALTITUDE_M, 0.0, 0.0, 0.0)
    r_ct = np.array([0.001016052, 116.430912621, 0.020321028])
    return relative_state_from_absolute(
        params,
        np.eye(3),
        0.0046 * np.ones(3),
        p_IT_I,
        v_IT_I,
        np.diag([-1.0, -1.0, 1.0]),
        np.zeros(3),
        p_IT_I + r_ct,
        v_IT_I,
    )
