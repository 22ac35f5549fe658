"""A multiplicative EKF of a tumbling target's relative motion, attitude, rate and inertia.

The filter GNC engineers know from Aghili's work on free-floating space objects (F. Aghili and
K. Parsa, "Motion and parameter estimation of space objects using laser-vision data", JGCD 32(2),
2009): the relative translation in LVLH with a Clohessy-Wiltshire process model or the exact
relative motion under two-body (+ J2) gravity (rpod.models.relative_orbit), the target's
attitude as a small error rotation about a reference quaternion (the multiplicative EKF,
Markley & Crassidis, "Fundamentals of Spacecraft Attitude Determination and Control", 2014,
Sec. 6.2), its body rate, and the two inertia parameters on which the torque-free Euler
equations alone depend (ratios of the principal moments; the scale of the inertia is
unobservable from motion and not estimated).

State (nominal, 15 numbers): p_LC_L, v_LC_L (the chaser from the target, in L, v seen in L),
q_IT (w, x, y, z), w_IT_T, and Aghili's inertia parameters k = (p_x, p_y) =
((J_yy - J_zz) / J_xx, (J_zz - J_xx) / J_yy), the target's principal axes along T's (p_z
follows from them; `ratios_from_parameters` gives J_yy / J_xx and J_zz / J_xx). Error state
(14): [dp, dv, dtheta_T, dw_T, dk], with q_IT = q_IT_ref (x) dq(dtheta_T) (the error in the
body frame).

Measurements (`PoseMeasurement`): the relative position p_LC_L and the target attitude q_IT,
the pose sensor's output rotated by the chaser's attitude estimate (star tracker) and LVLH's.

Written with numpy: at 14 error states a library adds nothing, and none of those on the registry
(filterpy, for one) does the multiplicative reset, which is the part that needs care here.
"""

import dataclasses
import functools
import math

import numpy as np

from rpod.models.cw import cw_acceleration, cw_continuous
from rpod.models.frames import (
    attitude_error,
    quaternion_product,
    rotation_vector_quaternion,
    skew,
)
from rpod.models.relative_orbit import TargetOrbit, relative_acceleration_L, relative_jacobian_L
from rpod.models.rigid_body import quaternion_rate

ERROR_SIZE = 14
P_SLICE, V_SLICE, THETA_SLICE, W_SLICE, K_SLICE = (
    slice(0, 3),
    slice(3, 6),
    slice(6, 9),
    slice(9, 12),
    slice(12, 14),
)
GROUPS = {
    "position": P_SLICE,
    "velocity": V_SLICE,
    "attitude": THETA_SLICE,
    "rate": W_SLICE,
    "inertia": K_SLICE,
}
"""The error state's groups, as summary.json and the figures name them."""


# ------------------------------------------------------------------------------------- dynamics


def z_parameter(k) -> float:
    """p_z of the inertia parameters k = (p_x, p_y), from the identity
    p_x + p_y + p_z + p_x p_y p_z = 0 that every inertia satisfies."""
    return -(k[0] + k[1]) / (1.0 + k[0] * k[1])


def parameters_from_ratios(ratios) -> np.ndarray:
    """Aghili's inertia parameters (p_x, p_y) = ((J_yy - J_zz) / J_xx, (J_zz - J_xx) / J_yy) of
    the principal ratios (J_yy / J_xx, J_zz / J_xx)."""
    ry, rz = ratios
    return np.array([ry - rz, (rz - 1.0) / ry])


def ratios_from_parameters(k) -> np.ndarray:
    """The principal ratios (J_yy / J_xx, J_zz / J_xx) of the parameters (p_x, p_y)."""
    ry = (1.0 + k[0]) / (1.0 - k[1])
    return np.array([ry, ry - k[0]])


def euler_rate(w_T, k) -> np.ndarray:
    """Torque-free Euler equations in Aghili's parameters: w_dot = (p_x w_y w_z, p_y w_z w_x,
    p_z w_x w_y), linear in them (the ratios' form, (r_z - 1) / r_y w_z w_x, ..., is not, and
    its curvature over a prior's spread left the filter overconfident)."""
    wx, wy, wz = w_T
    return np.array([k[0] * wy * wz, k[1] * wz * wx, z_parameter(k) * wx * wy])


def euler_jacobians(w_T, k) -> tuple[np.ndarray, np.ndarray]:
    """(d euler_rate / d w_T (3, 3), d euler_rate / d k (3, 2))."""
    wx, wy, wz = np.asarray(w_T, dtype=float).tolist()  # Python floats: the same IEEE operations
    px, py = np.asarray(k, dtype=float).tolist()
    pz = z_parameter((px, py))
    A = np.array([[0.0, px * wz, px * wy], [py * wz, 0.0, py * wx], [pz * wy, pz * wx, 0.0]])
    d = (1.0 + px * py) ** 2
    B = np.array(
        [
            [wy * wz, 0.0],
            [0.0, wz * wx],
            [-(1.0 - py * py) / d * wx * wy, -(1.0 - px * px) / d * wx * wy],
        ]
    )
    return A, B


@dataclasses.dataclass(frozen=True)
class ProcessNoise:
    """Continuous white-noise densities of what the model leaves out.

    acceleration: translational, m/s^2/sqrt(Hz) (J2's differential pull at 50 m is ~1e-7 m/s^2,
        thrust errors of the chaser more); torque: the target's angular acceleration,
        rad/s^2/sqrt(Hz) (gravity gradient on a 1 m body: ~1e-8); inertia: the parameters'
        random walk, 1/sqrt(s) (a rigid body's are constant; a small value keeps the filter
        from freezing them)."""

    acceleration: float = 1e-5
    torque: float = 1e-6
    inertia: float = 1e-6


@dataclasses.dataclass
class FilterState:
    """The nominal state, its error covariance (14, 14) and the time it holds at."""

    t: float
    p_LC_L: np.ndarray
    v_LC_L: np.ndarray
    q_IT: np.ndarray
    w_IT_T: np.ndarray
    inertia_parameters: np.ndarray
    P: np.ndarray

    def copy(self) -> "FilterState":
        return FilterState(
            self.t,
            self.p_LC_L.copy(),
            self.v_LC_L.copy(),
            self.q_IT.copy(),
            self.w_IT_T.copy(),
            self.inertia_parameters.copy(),
            self.P.copy(),
        )


def _rates_list(motion, x: list, a_L) -> list:
    """d/dt of the nominal [p, v, q, w, k] (15 Python floats, to a list): the translation (CW
    with mean motion `motion`, or the exact relative motion about a TargetOrbit) with the known
    acceleration a_L, quaternion kinematics, torque-free Euler, constant inertia parameters."""
    # On Python floats: the same equations as cw_acceleration, quaternion_rate and euler_rate
    # (tests/models/test_relative_navigation.py checks them against each other), ~4x cheaper
    # than numpy on 3-vectors, and this runs 4 times a step.
    px, py, pz, vx, vy, vz, qw, qx, qy, qz, wx, wy, wz, kx, ky = x
    ax, ay, az = a_L[0], a_L[1], a_L[2]
    if isinstance(motion, TargetOrbit):
        gx, gy, gz = relative_acceleration_L(
            motion, np.array([px, py, pz]), np.array([vx, vy, vz])
        ).tolist()
    else:
        n = motion
        gx, gy, gz = 3.0 * n * n * px + 2.0 * n * vy, -2.0 * n * vx, -n * n * pz
    kz = -(kx + ky) / (1.0 + kx * ky)
    return [
        vx,
        vy,
        vz,
        gx + ax,
        gy + ay,
        gz + az,
        0.5 * (-qx * wx - qy * wy - qz * wz),
        0.5 * (qw * wx + qy * wz - qz * wy),
        0.5 * (qw * wy + qz * wx - qx * wz),
        0.5 * (qw * wz + qx * wy - qy * wx),
        kx * wy * wz,
        ky * wz * wx,
        kz * wx * wy,
        0.0,
        0.0,
    ]


def rates_reference(n, x: np.ndarray, a_L) -> np.ndarray:
    """`_rates_list` from the shared laws (cw_acceleration, quaternion_rate, euler_rate): the
    reference its float form is tested against."""
    p, v, q, w, k = x[0:3], x[3:6], x[6:10], x[10:13], x[13:15]
    a = cw_acceleration(n, p, v) + np.asarray(a_L)
    return np.concatenate([v, a, quaternion_rate(q, w), euler_rate(w, k), np.zeros(2)])


@functools.lru_cache(maxsize=8)
def _translation_dynamics(n: float) -> np.ndarray:
    """F (14, 14) with only its translation block: CW, or a free particle in free space (n 0).
    Read-only: `_error_dynamics` copies it."""
    F = np.zeros((ERROR_SIZE, ERROR_SIZE))
    if n > 0.0:
        F[0:6, 0:6] = cw_continuous(n)[0]
    else:
        F[P_SLICE, V_SLICE] = np.eye(3)
    F.flags.writeable = False
    return F


def _error_dynamics(motion, w_T, k, p_L=None) -> np.ndarray:
    """F (14, 14) of the error state's linear dynamics about the nominal (p_L: the relative
    position, which the exact relative motion's Jacobian needs)."""
    if isinstance(motion, TargetOrbit):
        F = np.zeros((ERROR_SIZE, ERROR_SIZE))
        F[0:6, 0:6] = relative_jacobian_L(motion, p_L)
    else:
        F = _translation_dynamics(float(motion)).copy()
    F[THETA_SLICE, THETA_SLICE] = -skew(w_T)  # dtheta_dot = -w x dtheta + dw (body error)
    F[THETA_SLICE, W_SLICE] = np.eye(3)
    A_w, B_k = euler_jacobians(w_T, k)
    F[W_SLICE, W_SLICE] = A_w
    F[W_SLICE, K_SLICE] = B_k
    return F


@functools.lru_cache(maxsize=8)
def _noise_density(noise: ProcessNoise) -> np.ndarray:
    """Q_c (14, 14): ProcessNoise's densities on the error state (read-only)."""
    Q = np.zeros((ERROR_SIZE, ERROR_SIZE))
    Q[V_SLICE, V_SLICE] = noise.acceleration**2 * np.eye(3)
    Q[W_SLICE, W_SLICE] = noise.torque**2 * np.eye(3)
    Q[K_SLICE, K_SLICE] = noise.inertia**2 * np.eye(2)
    Q.flags.writeable = False
    return Q


_IDENTITY = np.eye(ERROR_SIZE)


EULER_NOISE_TIME_S = 1.0
"""The correlation time of the Euler acceleration of inertia parameters not being learned,
carried as white noise on the rate."""


def excited_parameters(w_T, P, sigmas: float) -> np.ndarray:
    """Which inertia parameters the motion reveals, (2,) bools: p_x acts through w_y w_z, p_y
    through w_z w_x, p_z (a function of both) through w_x w_y. A parameter is learned while one
    of its products stands `sigmas` standard deviations clear of zero, given the rate's
    uncertainty. Spinning about a principal axis, none does: linearising the Euler terms about
    a rate estimate whose small components are noise would make the filter "learn" an inertia
    the motion says nothing about (the classic EKF inconsistency in unobservable directions),
    and converge to a wrong value with a small sigma."""
    wx, wy, wz = np.asarray(w_T, dtype=float).tolist()  # Python floats: the same IEEE operations
    var = np.diag(P)[W_SLICE].tolist()

    def clear(a, b, var_a, var_b):
        return abs(a * b) > sigmas * math.sqrt(b * b * var_a + a * a * var_b + var_a * var_b)

    by_x = clear(wy, wz, var[1], var[2])
    by_y = clear(wz, wx, var[2], var[0])
    by_z = clear(wx, wy, var[0], var[1])
    return np.array([by_x or by_z, by_y or by_z])


def predict(
    state: FilterState,
    t: float,
    motion,
    noise: ProcessNoise,
    a_L=(0.0, 0.0, 0.0),
    max_step_s: float = 0.25,
    excitation_sigmas: float = 0.0,
) -> FilterState:
    """The state and covariance carried to time t: RK4 on the nominal, and the covariance by
    the error dynamics' transition over each step (second order) with the noise of
    Van Loan's first-order approximation Phi Q Phi^T dt. `motion` is the translation's model:
    a mean motion n [rad/s] (CW; 0 in free space) or a TargetOrbit (the exact relative motion
    under the truth's gravity, rpod.models.relative_orbit). a_L is the chaser's known
    acceleration in L (its commanded thrust); inertia parameters that `excited_parameters`
    (with excitation_sigmas) says the motion does not reveal enter as rate noise."""
    out = state.copy()
    if t < state.t:
        raise ValueError(f"predict: t {t} is before the state's {state.t}")
    steps = max(1, int(np.ceil((t - state.t) / max_step_s - 1e-9)))
    dt = (t - state.t) / steps
    Qc = _noise_density(noise)
    x = nominal_vector(out)
    P = out.P
    for _ in range(steps):
        F = _error_dynamics(motion, x[10:13], x[13:15], x[0:3])
        Q = Qc
        quiet = ~excited_parameters(x[10:13], P, excitation_sigmas)
        if quiet.any():  # their Euler terms as white noise on the rate, not as information
            B = F[W_SLICE, K_SLICE][:, quiet]
            sigma = np.sqrt(np.diag(P)[K_SLICE][quiet])
            Q = Qc.copy()
            Q[W_SLICE, W_SLICE] += (
                np.diag(((B * 3.0 * sigma) ** 2).sum(axis=1)) * EULER_NOISE_TIME_S
            )
            F[W_SLICE, K_SLICE.start + np.flatnonzero(quiet)] = 0.0
        Fdt = F * dt
        Phi = _IDENTITY + Fdt + 0.5 * Fdt @ Fdt
        P = Phi @ (P + Q * dt) @ Phi.T  # Phi P Phi^T + Phi Q Phi^T dt
        x = _rk4_step(motion, x, a_L, dt)
    _set_nominal(out, t, x)
    out.P = 0.5 * (P + P.T)
    return out


def nominal_vector(state: FilterState) -> np.ndarray:
    """The nominal state (15): [p_LC_L, v_LC_L, q_IT, w_IT_T, inertia parameters]."""
    return np.concatenate(
        [state.p_LC_L, state.v_LC_L, state.q_IT, state.w_IT_T, state.inertia_parameters]
    )


def _set_nominal(state: FilterState, t: float, x: np.ndarray) -> None:
    state.t = t
    state.p_LC_L, state.v_LC_L, state.q_IT = x[0:3], x[3:6], x[6:10]
    state.w_IT_T, state.inertia_parameters = x[10:13], x[13:15]


def _rk4_step(motion, x: np.ndarray, a_L, dt: float) -> np.ndarray:
    """One RK4 step of the nominal (15), its quaternion renormalised; on Python floats (a
    third of numpy's cost on 15 numbers)."""
    a_L = [float(a) for a in a_L]
    x0 = x.tolist()
    half = 0.5 * dt
    k1 = _rates_list(motion, x0, a_L)
    k2 = _rates_list(motion, [xi + half * ki for xi, ki in zip(x0, k1)], a_L)
    k3 = _rates_list(motion, [xi + half * ki for xi, ki in zip(x0, k2)], a_L)
    k4 = _rates_list(motion, [xi + dt * ki for xi, ki in zip(x0, k3)], a_L)
    sixth = dt / 6.0
    x1 = [xi + sixth * (a + 2.0 * b + 2.0 * c + d) for xi, a, b, c, d in zip(x0, k1, k2, k3, k4)]
    qw, qx, qy, qz = x1[6:10]
    norm = math.sqrt(qw * qw + qx * qx + qy * qy + qz * qz)
    x1[6:10] = qw / norm, qx / norm, qy / norm, qz / norm
    return np.array(x1)


def propagate_nominal(
    state: FilterState, t: float, motion, a_L=(0.0, 0.0, 0.0), max_step_s: float = 0.25
) -> FilterState:
    """The nominal state carried to t (covariance unchanged): what the estimate says at an
    instant between two of the filter's steps, at the cost of a few RK4 steps."""
    out = state.copy()
    if t <= state.t:
        return out
    _set_nominal(out, t, nominal_at(state, t, motion, a_L, max_step_s))
    return out


def nominal_at(
    state: FilterState, t: float, motion, a_L=(0.0, 0.0, 0.0), max_step_s: float = 0.25
) -> np.ndarray:
    """`propagate_nominal`'s nominal vector (15) alone, for t > state.t: no state object made."""
    steps = max(1, int(np.ceil((t - state.t) / max_step_s - 1e-9)))
    x = nominal_vector(state)
    for _ in range(steps):
        x = _rk4_step(motion, x, a_L, (t - state.t) / steps)
    return x


# ---------------------------------------------------------------------------------- measurement


@dataclasses.dataclass(frozen=True)
class PoseMeasurement:
    """One pose fix: the relative position and the target attitude with their 1-sigma noise."""

    t: float
    p_LC_L: np.ndarray
    q_IT: np.ndarray
    sigma_position_m: float
    sigma_attitude_rad: float


@dataclasses.dataclass(frozen=True)
class UpdateResult:
    """The updated state, the innovation (6), its covariance S (6, 6), the normalised
    innovation squared and whether the gate accepted the measurement."""

    state: FilterState
    innovation: np.ndarray
    S: np.ndarray
    nis: float
    accepted: bool


MEASUREMENT_SIZE = 6
H = np.zeros((MEASUREMENT_SIZE, ERROR_SIZE))
H[0:3, P_SLICE] = np.eye(3)
H[3:6, THETA_SLICE] = np.eye(3)


def update(
    state: FilterState, z: PoseMeasurement, gate: float, excitation_sigmas: float = 0.0
) -> UpdateResult:
    """The Joseph-form update by one pose fix, gated by its normalised innovation squared (NIS
    above `gate`, a chi-square quantile with 6 degrees of freedom: rejected, state unchanged),
    then the multiplicative reset of the attitude (the error folded into q_IT, and the
    covariance moved to the new reference by G = I - [dtheta/2 x])."""
    innovation = np.concatenate([z.p_LC_L - state.p_LC_L, attitude_error(state.q_IT, z.q_IT)])
    R = np.diag([z.sigma_position_m**2] * 3 + [z.sigma_attitude_rad**2] * 3)
    PHt = state.P @ H.T
    S = H @ PHt + R
    S = 0.5 * (S + S.T)
    S_inv = np.linalg.inv(S)  # 6 x 6 and well conditioned (R's floor): one LAPACK call
    nis = float(innovation @ S_inv @ innovation)
    if not nis <= gate:
        return UpdateResult(state, innovation, S, nis, False)
    K = PHt @ S_inv
    quiet = ~excited_parameters(state.w_IT_T, state.P, excitation_sigmas)
    K[K_SLICE.start + np.flatnonzero(quiet)] = 0.0  # not learned; the Joseph form holds for any K
    dx = K @ innovation
    I_KH = np.eye(ERROR_SIZE) - K @ H
    P = I_KH @ state.P @ I_KH.T + K @ R @ K.T
    out = state.copy()
    out.p_LC_L = state.p_LC_L + dx[P_SLICE]
    out.v_LC_L = state.v_LC_L + dx[V_SLICE]
    out.q_IT = quaternion_product(state.q_IT, rotation_vector_quaternion(dx[THETA_SLICE]))
    out.w_IT_T = state.w_IT_T + dx[W_SLICE]
    # |p_x|, |p_y| < 1 for every rigid body (each principal moment below the other two's sum).
    out.inertia_parameters = np.clip(state.inertia_parameters + dx[K_SLICE], -0.999, 0.999)
    G = np.eye(ERROR_SIZE)
    G[THETA_SLICE, THETA_SLICE] -= 0.5 * skew(dx[THETA_SLICE])
    P = G @ P @ G.T
    out.P = 0.5 * (P + P.T)
    return UpdateResult(out, innovation, S, nis, True)


def chi_square_quantile(probability: float, dof: int) -> float:
    """The chi-square quantile (scipy.stats.chi2.ppf), through scipy.special's inverse
    incomplete gamma function: scipy.stats costs ~0.6 s to import, scipy.special ~0.15 s."""
    from scipy.special import gammaincinv  # at use

    return 2.0 * float(gammaincinv(0.5 * dof, probability))


def reset_diverged(
    state: FilterState,
    fix: PoseMeasurement,
    fix_period_s: float,
    prior: "InertiaPrior",
    probability: float,
) -> tuple[FilterState, tuple[str, ...]]:
    """The filter after it has refused fix after fix: the part whose innovation is out of its
    own bounds starts again from the fix, the rest keeps what it knew. (the state, the parts
    reset: 'translation', 'rotation').

    Divergence is nearly always one part's: the tumble's model (principal axes not the
    filter's, an inertia learned wrong) while the translation is fine, or a manoeuvre it was
    not told of while the tumble is fine. Starting everything again from two fixes would throw
    the good part away, and a velocity from two fixes at long range (1 % of 800 m, 0.5 s
    apart) is metres per second off. A part is reset when its 3-dof NIS passes the
    chi-square quantile at `probability` (the rotation when neither does alone): its pose
    from the fix, its rate kept with the uncertainty two fixes would give, the inertia kept
    with at least the prior's sigma, its cross-covariances zeroed."""
    gate3 = chi_square_quantile(probability, 3)
    innovation = np.concatenate([fix.p_LC_L - state.p_LC_L, attitude_error(state.q_IT, fix.q_IT)])
    P = state.P
    R_p, R_a = fix.sigma_position_m**2, fix.sigma_attitude_rad**2
    nis_p = innovation[:3] @ np.linalg.solve(P[P_SLICE, P_SLICE] + R_p * np.eye(3), innovation[:3])
    S_a = P[THETA_SLICE, THETA_SLICE] + R_a * np.eye(3)
    nis_a = innovation[3:] @ np.linalg.solve(S_a, innovation[3:])
    reset_translation = nis_p > gate3
    reset_rotation = nis_a > gate3 or not reset_translation
    out = state.copy()
    P = P.copy()

    def restart(block_a, block_b, variance_a, variance_b):
        for block in (block_a, block_b):
            P[block, :] = 0.0
            P[:, block] = 0.0
        P[block_a, block_a] = variance_a * np.eye(3)
        P[block_b, block_b] = variance_b * np.eye(3)

    parts = []
    if reset_translation:
        out.p_LC_L = np.array(fix.p_LC_L, dtype=float)
        restart(P_SLICE, V_SLICE, R_p, 2.0 * R_p / fix_period_s**2)
        parts.append("translation")
    if reset_rotation:
        out.q_IT = np.array(fix.q_IT, dtype=float)
        restart(THETA_SLICE, W_SLICE, R_a, 2.0 * R_a / fix_period_s**2)
        sigma_k = max(prior.sigma, *np.sqrt(np.diag(state.P)[K_SLICE]))
        P[K_SLICE, :] = 0.0
        P[:, K_SLICE] = 0.0
        P[K_SLICE, K_SLICE] = sigma_k**2 * np.eye(2)
        parts.append("rotation")
    out.P = P
    return out, tuple(parts)


# ------------------------------------------------------------------------------- initialisation


@dataclasses.dataclass(frozen=True)
class InertiaPrior:
    """What the filter assumes of the inertia parameters (p_x, p_y) before it has seen the tumble:
    a mean and a 1-sigma. Every rigid body has |p| < 1; (0, 0) is a sphere or a cube, and 0.3
    spans bodies from about 1 : 1.3 : 1.6 to their mirror images at 1 sigma."""

    parameters: tuple[float, float] = (0.0, 0.0)
    sigma: float = 0.15


def initial_state(
    first: PoseMeasurement, second: PoseMeasurement, prior: InertiaPrior
) -> FilterState:
    """The filter at the second fix, started from two fixes alone, never from the truth: the
    position and attitude from the second, the velocity and rate from their differences, the
    inertia parameters from the prior; the covariance says each of these (differences of two noisy fixes:
    2 sigma^2 / dt^2), so the rate's and velocity's first uncertainty are honest."""
    dt = second.t - first.t
    if not dt > 0.0:
        raise ValueError("initial_state: the second fix must come after the first")
    v = (second.p_LC_L - first.p_LC_L) / dt
    w = attitude_error(first.q_IT, second.q_IT) / dt  # body rate over dt, about the first
    P = np.zeros((ERROR_SIZE, ERROR_SIZE))
    sp, sa = second.sigma_position_m, second.sigma_attitude_rad
    P[P_SLICE, P_SLICE] = sp**2 * np.eye(3)
    P[V_SLICE, V_SLICE] = (first.sigma_position_m**2 + sp**2) / dt**2 * np.eye(3)
    P[P_SLICE, V_SLICE] = P[V_SLICE, P_SLICE] = sp**2 / dt * np.eye(3)
    P[THETA_SLICE, THETA_SLICE] = sa**2 * np.eye(3)
    # The rate is the mean over dt: add what a tumble of that rate can change in it (the
    # Euler terms over half the interval), so a fast nutation does not make it overconfident.
    rate_sigma2 = (first.sigma_attitude_rad**2 + sa**2) / dt**2 + (0.5 * dt * np.dot(w, w)) ** 2
    P[W_SLICE, W_SLICE] = rate_sigma2 * np.eye(3)
    P[THETA_SLICE, W_SLICE] = P[W_SLICE, THETA_SLICE] = sa**2 / dt * np.eye(3)
    P[K_SLICE, K_SLICE] = prior.sigma**2 * np.eye(2)
    return FilterState(
        t=second.t,
        p_LC_L=np.array(second.p_LC_L, dtype=float),
        v_LC_L=v,
        q_IT=np.array(second.q_IT, dtype=float),
        w_IT_T=w,
        inertia_parameters=np.array(prior.parameters, dtype=float),
        P=P,
    )


def nees(state: FilterState, p_LC_L, v_LC_L, q_IT, w_IT_T, k) -> tuple[float, np.ndarray]:
    """(the normalised estimation error squared against the truth, the error (14))."""
    error = np.concatenate(
        [
            np.asarray(p_LC_L) - state.p_LC_L,
            np.asarray(v_LC_L) - state.v_LC_L,
            attitude_error(state.q_IT, q_IT),
            np.asarray(w_IT_T) - state.w_IT_T,
            np.asarray(k) - state.inertia_parameters,
        ]
    )
    return float(error @ np.linalg.solve(state.P, error)), error


# ----------------------------------------------------------------------------------- the filter


@dataclasses.dataclass(frozen=True)
class FilterSettings:
    """The filter's tuning, each with its reason.

    gate_probability: a fix whose NIS is above this chi-square(6) quantile is an outlier and is
        rejected (0.9999: one good fix in 10,000 rejected; a 2 m or 30 deg outlier always).
    excitation_sigmas: an inertia parameter is learned while the rate products it acts through
        stand this many standard deviations clear of zero (`excited_parameters`). At the start
        the rate is the coarse difference of two fixes (2 deg of attitude noise at 2 Hz: ~6
        deg/s, more than the tumble itself), and on a principal-axis spin the small components
        are noise: linearising the Euler terms about either leaves the filter overconfident.
    max_step_s: the longest prediction step (RK4 and the covariance's transition): 0.5 s, the
        pose sensor's period at 2 Hz, so one step a fix. At a 10 deg/s tumble the step turns
        0.09 rad: RK4's error is ~(w dt)^5 / 120 ~ 4e-8 rad, the second-order transition's
        ~(w dt)^3 / 6 ~ 1e-4 of the covariance's rotation; noise-free hold_point's error is the
        same as at 0.25 s (0.017 mm), and a prediction between fixes is one step, not two
        (benchmarks/results/navigation_cost.md).
    """

    noise: ProcessNoise = ProcessNoise()
    prior: InertiaPrior = InertiaPrior()
    gate_probability: float = 0.9999
    excitation_sigmas: float = 10.0
    max_step_s: float = 0.5


class RelativeNavigationFilter:
    """The filter over a run: it starts from its first two fixes, then carries the state to each
    fix's time and updates by it (or only predicts, with no fix: a dropout).

    `state` is None until it has started; `rejected` counts the fixes the gate refused.
    """

    def __init__(self, mean_motion_rad_s: float, settings: FilterSettings = FilterSettings()):
        self.n = mean_motion_rad_s
        self.settings = settings
        self.gate = chi_square_quantile(settings.gate_probability, MEASUREMENT_SIZE)
        self.state: FilterState | None = None
        self.rejected = 0
        self._first: PoseMeasurement | None = None

    def step(self, t: float, fix: PoseMeasurement | None, a_L=(0.0, 0.0, 0.0)):
        """Advances to t and applies the fix (None: none at t). Returns the UpdateResult, or None
        when the filter has not started or there was no fix."""
        if self.state is None:
            if fix is None:
                return None
            if self._first is None:
                self._first = fix
                return None
            self.state = initial_state(self._first, fix, self.settings.prior)
            return None
        sigmas = self.settings.excitation_sigmas
        self.state = predict(
            self.state, t, self.n, self.settings.noise, a_L, self.settings.max_step_s, sigmas
        )
        if fix is None:
            return None
        result = update(self.state, fix, self.gate, sigmas)
        self.state = result.state
        self.rejected += not result.accepted
        return result
