"""Rigid-body rotational dynamics: Euler's equations and quaternion kinematics.

Owns: inertia validation, the attitude state derivative (paper 000 eq. (2), with an optional
body torque), kinetic energy and angular momentum, and the closed-form torque-free motion of an
axisymmetric body. Does not own: translational dynamics, time integration (see
``rpod.systems.truth``), the cross product (``rpod.models.frames.cross``) or any Drake System.

Conventions: ``q_wxyz`` is the unit quaternion of ``R_IB`` (maps vectors expressed in body frame
B to the inertial frame I, Hamilton product, as ``pydrake.common.eigen_geometry.Quaternion``);
``w_B`` is the angular velocity of B in I, expressed in B [rad/s]; ``J`` is the inertia about
the centre of mass, expressed in B [kg m^2]; torques ``tau_B`` are about the centre of mass,
expressed in B [N m].

``angular_acceleration`` and ``quaternion_rate`` use only products and sums, so ``w_B``,
``tau_B`` and ``q_wxyz`` may be numpy object arrays of ``AutoDiffXd`` (``J`` stays float).
"""

import numpy as np
from pydrake.common.eigen_geometry import Quaternion
from pydrake.math import RotationMatrix

from rpod.models.config import ConfigError
from rpod.models.frames import cross

# Relative tolerance for the symmetry and triangle-inequality checks of an inertia matrix.
_INERTIA_RTOL = 1e-9


def validate_inertia(J: np.ndarray, field: str = "inertia") -> None:
    """Checks that ``J`` is a physical rotational inertia.

    Args:
        J: Candidate inertia matrix.
        field: The config field it comes from, named in the error.

    Raises:
        ConfigError: (a ValueError) If ``J`` is not a finite 3x3 symmetric positive-definite
            matrix whose principal moments satisfy the triangle inequality (each <= the sum of
            the other two, to a relative tolerance of 1e-9).
    """
    J = np.asarray(J, dtype=float)
    if J.shape != (3, 3):
        raise ConfigError(field, f"must be a 3x3 matrix, got shape {J.shape}")
    if not np.all(np.isfinite(J)):
        raise ConfigError(field, f"has non-finite entries: {J.tolist()}")
    scale = np.max(np.abs(J))
    if not np.allclose(J, J.T, rtol=0.0, atol=_INERTIA_RTOL * scale):
        raise ConfigError(field, f"is not symmetric: {J.tolist()}")
    moments = np.linalg.eigvalsh(0.5 * (J + J.T))
    if moments[0] <= 0.0:
        raise ConfigError(field, f"is not positive definite, principal moments {moments.tolist()}")
    # eigvalsh sorts ascending, so the largest moment is the only one that can break it.
    if moments[2] > (moments[0] + moments[1]) * (1.0 + _INERTIA_RTOL):
        raise ConfigError(
            field,
            f"violates the triangle inequality J3 <= J1 + J2, principal moments {moments.tolist()}",
        )


def angular_acceleration(J, w_B, tau_B=None, J_inv=None) -> np.ndarray:
    """Euler's equations ``J w_dot = tau - w x (J w)`` solved for ``w_dot``.

    Args:
        J: Inertia (3, 3) about the centre of mass, in B [kg m^2].
        w_B: Angular velocity (3,) of B in I, expressed in B [rad/s].
        tau_B: Torque (3,) about the centre of mass, in B [N m]; None means torque-free.
        J_inv: Precomputed ``inv(J)``; pass it in hot loops to skip the inversion.

    Returns:
        ``w_dot_B`` (3,) [rad/s^2].
    """
    if J_inv is None:
        J_inv = np.linalg.inv(np.asarray(J, dtype=float))
    h_B = J @ w_B
    rhs = cross(h_B, w_B)  # -w x (J w), paper 000 eq. (2), gyroscopic term
    if tau_B is not None:
        rhs = rhs + tau_B
    return J_inv @ rhs  # paper 000 eq. (2)


def quaternion_rate(q_wxyz, w_B) -> np.ndarray:
    """Quaternion kinematics ``q_dot = 1/2 q (x) [0, w_B]`` (body-frame rate).

    Args:
        q_wxyz: Quaternion (4,) of ``R_IB``; need not be exactly unit (the rate is linear in q).
        w_B: Angular velocity (3,) of B in I, expressed in B [rad/s].

    Returns:
        ``q_dot`` (4,).
    """
    w, x, y, z = np.asarray(q_wxyz).tolist()  # Python floats are faster than numpy scalars
    wx, wy, wz = np.asarray(w_B).tolist()
    # 1/2 L(q) [0; w] with L(q) of paper 000 eq. (1), expanded; paper 000 eq. (2).
    return np.array(
        [
            0.5 * (-x * wx - y * wy - z * wz),
            0.5 * (w * wx + y * wz - z * wy),
            0.5 * (w * wy + z * wx - x * wz),
            0.5 * (w * wz + x * wy - y * wx),
        ]
    )


def attitude_pd_torque(
    J, e_B, w_error_B, w_IB_B, bandwidth_rad_s: float, damping: float, alpha_ff_B=None
) -> np.ndarray:
    """Attitude PD torque with gyroscopic compensation and an optional feed-forward.

    tau_B = J (alpha_ff + w_a^2 e + 2 zeta w_a (w_des - w)) + w x (J w): with the gyroscopic
    term cancelled, the attitude error of Euler's equations (paper 000 eq. 2) obeys a
    second-order system of natural frequency w_a and damping zeta (small errors).

    Args:
        J: Inertia (3, 3) in B [kg m^2].
        e_B: Attitude error as a rotation vector (axis times angle) in B [rad].
        w_error_B: Desired minus actual angular velocity, in B [rad/s].
        w_IB_B: Actual angular velocity of B in I, in B [rad/s].
        bandwidth_rad_s: Natural frequency w_a.
        damping: Damping ratio zeta.
        alpha_ff_B: Desired angular acceleration in B [rad/s^2] (None: zero).
    """
    J = np.asarray(J, dtype=float)
    w_a = bandwidth_rad_s
    command = w_a * w_a * np.asarray(e_B)
    if alpha_ff_B is not None:  # added first: the controllers' results stay bit-identical
        command = alpha_ff_B + command
    command = command + 2.0 * damping * w_a * np.asarray(w_error_B)
    return J @ command + cross(w_IB_B, J @ w_IB_B)


def rotational_kinetic_energy(J, w_B) -> float:
    """Rotational kinetic energy ``1/2 w^T J w`` [J].

    Args:
        J: Inertia (3, 3) in B [kg m^2].
        w_B: Angular velocity (3,) in B [rad/s].
    """
    w_B = np.asarray(w_B)
    return 0.5 * w_B @ (np.asarray(J) @ w_B)


def rotation_from_quaternion(q_wxyz) -> RotationMatrix:
    """``RotationMatrix`` of a (possibly non-unit, non-zero) float quaternion.

    Args:
        q_wxyz: Quaternion (4,); it is normalised first.

    Raises:
        ValueError: If the quaternion has zero or non-finite norm.
    """
    q = np.asarray(q_wxyz, dtype=float)
    norm = np.linalg.norm(q)
    if not (np.isfinite(norm) and norm > 0.0):
        raise ValueError(f"quaternion must have a finite non-zero norm, got {q.tolist()}")
    return RotationMatrix(Quaternion(q / norm))


def angular_momentum_in_inertial(q_wxyz, J, w_B) -> np.ndarray:
    """Angular momentum about the centre of mass, expressed in I: ``h_I = R_IB J w_B``.

    Args:
        q_wxyz: Quaternion (4,) of ``R_IB`` (normalised internally).
        J: Inertia (3, 3) in B [kg m^2].
        w_B: Angular velocity (3,) in B [rad/s].

    Returns:
        ``h_I`` (3,) [kg m^2/s].
    """
    R_IB = rotation_from_quaternion(q_wxyz)
    return R_IB.multiply(np.asarray(J, dtype=float) @ np.asarray(w_B, dtype=float))


def _axis_angle_quaternion(axis, angle) -> Quaternion:
    """Quaternion of a rotation by ``angle`` about the unit vector ``axis``."""
    half = 0.5 * angle
    return Quaternion(np.concatenate([[np.cos(half)], np.sin(half) * np.asarray(axis)]))


def axisymmetric_torque_free_solution(
    J_t: float, J_a: float, w0_B, q0_wxyz, t
) -> tuple[np.ndarray, np.ndarray]:
    """Closed-form torque-free motion of an axisymmetric body, symmetry axis = body z.

    With ``J = diag(J_t, J_t, J_a)``, Euler's equations give a constant axial rate ``w_z`` and a
    transverse rate that turns about body z at ``lambda = (J_a - J_t) / J_t * w_z``:
    ``w_B(t) = Rz(lambda t) w0_B``. Writing ``w_B = (|h| / J_t) h_hat_B - lambda z_hat`` splits
    the motion into a spin about the inertially fixed momentum direction ``h_hat_I`` at
    ``Omega = |h| / J_t`` and a spin about body z at ``-lambda``, so
    ``R_IB(t) = Rot(h_hat_I, Omega t) R_IB(0) Rz(-lambda t)``.

    Args:
        J_t: Transverse moment of inertia (about body x and y) [kg m^2].
        J_a: Axial moment of inertia (about body z) [kg m^2].
        w0_B: Initial angular velocity (3,) in B [rad/s].
        q0_wxyz: Initial attitude quaternion (4,) of ``R_IB`` (normalised internally).
        t: Time [s], scalar or 1-D array.

    Returns:
        ``(q_wxyz, w_B)``: shapes (4,) and (3,) for scalar ``t``, (N, 4) and (N, 3) for an
        array. The quaternion sign is continuous in t and starts at the normalised ``q0``.
    """
    validate_inertia(np.diag([J_t, J_t, J_a]))
    w0_B = np.asarray(w0_B, dtype=float)
    q0_norm = np.linalg.norm(q0_wxyz)
    if not (np.isfinite(q0_norm) and q0_norm > 0.0):
        raise ValueError(f"q0 must have a finite non-zero norm, got {q0_wxyz}")
    q0 = Quaternion(np.asarray(q0_wxyz, dtype=float) / q0_norm)
    times = np.atleast_1d(np.asarray(t, dtype=float))

    lam = (J_a - J_t) / J_t * w0_B[2]  # body-cone precession rate
    h_B0 = np.array([J_t * w0_B[0], J_t * w0_B[1], J_a * w0_B[2]])
    h_norm = np.linalg.norm(h_B0)
    Omega = h_norm / J_t  # spin rate about the momentum axis
    h_hat_I = q0.rotation() @ h_B0 / h_norm if h_norm > 0.0 else np.array([0.0, 0.0, 1.0])
    z_hat = np.array([0.0, 0.0, 1.0])

    q_out = np.empty((times.size, 4))
    w_out = np.empty((times.size, 3))
    for k, tk in enumerate(times):
        q_out[k] = (
            _axis_angle_quaternion(h_hat_I, Omega * tk)
            .multiply(q0)
            .multiply(_axis_angle_quaternion(z_hat, -lam * tk))
            .wxyz()
        )
        c, s = np.cos(lam * tk), np.sin(lam * tk)
        w_out[k] = [c * w0_B[0] - s * w0_B[1], s * w0_B[0] + c * w0_B[1], w0_B[2]]
    if np.ndim(t) == 0:
        return q_out[0], w_out[0]
    return q_out, w_out
