"""The capture-axis attitude law: the chaser's capture axis at the target, its roll the target's.

Owns: `CapturePointing`, the attitude law of a chaser flying its capture point onto a tumbling
target's port (the PD baseline's, rpod.systems.hold_point_controller, and the LOS corridor's
final regime through thrusters, rpod.systems.acceleration_to_wrench): the capture axis c_C
points at the target's centre of mass, and the roll about it follows the target's x axis, so
that at the port the chaser turns with the tumble. The desired angular velocity is the finite
difference of the desired attitude over one period, and

    tau_C = J (w_a^2 e_R + 2 zeta w_a (w_des - w)) + w x J w          (rpod.models.rigid_body)

with e_R the rotation vector of R_CCdes.
Does not own: the translation, or the memory of the last desired attitude (the caller keeps
it in its Context and passes it back).
"""

import numpy as np
from pydrake.math import RotationMatrix

from rpod.models.frames import cross
from rpod.models.rigid_body import attitude_pd_torque


def unit(v: np.ndarray) -> np.ndarray:
    """v / |v|."""
    return v / np.linalg.norm(v)


def pointing_rotation(z_axis: np.ndarray, x_hint: np.ndarray, fallback: np.ndarray) -> np.ndarray:
    """Rotation whose z column is z_axis and whose x column is x_hint made orthogonal to it."""
    x = x_hint - (x_hint @ z_axis) * z_axis
    if np.linalg.norm(x) < 1e-6:  # the hint is (anti)parallel to the axis: use the fallback
        x = fallback - (fallback @ z_axis) * z_axis
    x = unit(x)
    return np.column_stack((x, cross(z_axis, x), z_axis))


class CapturePointing:
    """The law of the module docstring for one chaser.

    Args:
        capture_point_C: the chaser's capture point in C; its direction is the capture axis
            (non-zero).
        inertia_C: the chaser's inertia about its centre of mass, in C [kg m^2].
        bandwidth_rad_s, damping: the attitude loop's natural frequency and damping ratio.
        period_s: the law's sample period (the finite difference of the desired attitude).
    """

    def __init__(self, capture_point_C, inertia_C, bandwidth_rad_s, damping, period_s):
        self._J = np.asarray(inertia_C, dtype=float)
        self._w_a, self._zeta, self._period = bandwidth_rad_s, damping, period_s
        # R_CK: a fixed frame K in C whose z axis is the capture axis; the law points K.
        capture_C = unit(np.asarray(capture_point_C, float))
        self._R_CK = pointing_rotation(capture_C, np.array([1.0, 0.0, 0.0]), np.eye(3)[1])

    def torque(self, R_IL, u_LC_L, R_IT, R_IC, w_IC_C, previous_R_ICdes: np.ndarray):
        """(tau_C, R_ICdes): the torque now and the desired attitude (pass it back next time;
        an empty array the first time, when the desired rate is taken as zero).

        Args:
            R_IL: the LVLH frame's attitude; u_LC_L: the unit direction from the target's
                centre to the chaser's, in L; R_IT: the target's attitude; R_IC, w_IC_C: the
                chaser's attitude and rate.
        """
        R_IKdes = pointing_rotation(-(R_IL @ u_LC_L), R_IT[:, 0], R_IT[:, 1])
        R_ICdes = R_IKdes @ self._R_CK.T
        w_des_C = np.zeros(3)
        if previous_R_ICdes.size:
            dR = RotationMatrix(previous_R_ICdes.T @ R_ICdes).ToAngleAxis()
            w_des_Cdes = dR.axis() * dR.angle() / self._period
            w_des_C = R_IC.T @ R_ICdes @ w_des_Cdes
        error = RotationMatrix(R_IC.T @ R_ICdes).ToAngleAxis()
        e_C = error.axis() * error.angle()
        tau_C = attitude_pd_torque(self._J, e_C, w_des_C - w_IC_C, w_IC_C, self._w_a, self._zeta)
        return tau_C, R_ICdes
