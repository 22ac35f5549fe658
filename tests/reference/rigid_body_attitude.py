"""Rotational dynamics of one rigid body (e.g. the tumbling target) as a Drake LeafSystem.

Test-only reference (tests/reference, not part of the rpod package).
Owns: integrating the attitude state ``[q_wxyz, w_B]`` of ``rpod.models.rigid_body`` in time,
with an optional body torque input. Does not own: the equations (they live in
``rpod.models.rigid_body``), translation, or where the torque comes from.

The quaternion is integrated as four free states; the torque-free flow preserves its norm, and
the ``attitude`` output normalises it so downstream systems always receive a unit quaternion.
The state is not renormalised in place: with the error-controlled integrators used by rpod the
norm drift stays at the integration tolerance, and a discrete projection would make the system
hybrid for little gain.

Where it is used. rpod.diagrams builds `rpod.systems.truth.Truth`, which integrates both bodies'
attitudes with the orbits in one system (for speed). This system is part of the tested
reference it is checked against (`tests.reference.split_truth.SplitTruth`), and stays usable on
its own.
"""

import numpy as np
from pydrake.systems.framework import BasicVector, Context, ContinuousState, LeafSystem

from rpod.models.rigid_body import angular_acceleration, quaternion_rate, validate_inertia


class RigidBodyAttitude(LeafSystem):
    """Euler's equations plus quaternion kinematics (paper 000 eq. (2)).

    Continuous state (7): ``[q_wxyz (R_IB), w_B]``, ``w_B`` the angular velocity of body B in
    the inertial frame I, expressed in B [rad/s].

    Ports:
        body_torque (input, 3, only if ``with_torque_input``): torque about the centre of mass,
            expressed in B [N m].
        attitude (output, 7): ``[q_wxyz normalised, w_B]``; depends on the continuous state only.
    """

    def __init__(
        self,
        J_B: np.ndarray,
        q0_wxyz: np.ndarray,
        w0_B: np.ndarray,
        with_torque_input: bool = True,
    ):
        """Builds the system.

        Args:
            J_B: Inertia (3, 3) about the centre of mass, expressed in B [kg m^2].
            q0_wxyz: Default initial attitude quaternion (4,) of ``R_IB``; normalised here.
            w0_B: Default initial angular velocity (3,) in B [rad/s].
            with_torque_input: Declare the ``body_torque`` input port; without it the body is
                torque-free.

        Raises:
            ValueError: On a non-physical inertia, a zero/non-finite quaternion or a
                wrongly sized initial state.
        """
        super().__init__()
        validate_inertia(J_B)
        self._J_B = np.array(J_B, dtype=float)
        self._J_inv_B = np.linalg.inv(self._J_B)
        x0 = np.concatenate([self._normalised_quaternion(q0_wxyz), self._checked_rate(w0_B)])
        # All seven states are declared "miscellaneous" (z): q_dot is not w, so Drake's
        # second-order (q, v) structure would be a false promise to integrators.
        self.DeclareContinuousState(BasicVector(x0))
        self._torque_port = (
            self.DeclareVectorInputPort("body_torque", 3) if with_torque_input else None
        )
        self._attitude_port = self.DeclareVectorOutputPort(
            "attitude", 7, self._calc_attitude, prerequisites_of_calc={self.xc_ticket()}
        )

    @staticmethod
    def _normalised_quaternion(q_wxyz) -> np.ndarray:
        q = np.asarray(q_wxyz, dtype=float).reshape(-1)
        norm = np.linalg.norm(q)
        if q.size != 4 or not (np.isfinite(norm) and norm > 0.0):
            raise ValueError(f"q_wxyz must be 4 finite numbers with non-zero norm, got {q_wxyz}")
        return q / norm

    @staticmethod
    def _checked_rate(w_B) -> np.ndarray:
        w = np.asarray(w_B, dtype=float).reshape(-1)
        if w.size != 3 or not np.all(np.isfinite(w)):
            raise ValueError(f"w_B must be 3 finite numbers, got {w_B}")
        return w

    @property
    def inertia(self) -> np.ndarray:
        """Inertia J_B (3, 3) [kg m^2] (a copy)."""
        return self._J_B.copy()

    def get_body_torque_input_port(self):
        """The ``body_torque`` input port (raises if declared without it)."""
        if self._torque_port is None:
            raise RuntimeError("RigidBodyAttitude was built with with_torque_input=False")
        return self._torque_port

    def get_attitude_output_port(self):
        """The ``attitude`` output port."""
        return self._attitude_port

    def set_initial_state(self, context: Context, q_wxyz: np.ndarray, w_B: np.ndarray) -> None:
        """Writes ``[q_wxyz normalised, w_B]`` into the continuous state of ``context``.

        Args:
            context: This system's context (not a diagram's).
            q_wxyz: Attitude quaternion (4,) of ``R_IB``; normalised here.
            w_B: Angular velocity (3,) in B [rad/s].
        """
        context.SetContinuousState(
            np.concatenate([self._normalised_quaternion(q_wxyz), self._checked_rate(w_B)])
        )

    def DoCalcTimeDerivatives(self, context: Context, derivatives: ContinuousState) -> None:
        """Writes ``[q_dot, w_dot]`` from paper 000 eq. (2) plus the body torque."""
        x = context.get_continuous_state_vector().CopyToVector()
        w_B = x[4:]
        tau_B = self._torque_port.Eval(context) if self._torque_port is not None else None
        derivatives.SetFromVector(
            np.concatenate(
                [
                    quaternion_rate(x[:4], w_B),  # paper 000 eq. (2), kinematics
                    angular_acceleration(self._J_B, w_B, tau_B, self._J_inv_B),  # eq. (2), Euler
                ]
            )
        )

    def _calc_attitude(self, context: Context, output: BasicVector) -> None:
        x = context.get_continuous_state_vector().CopyToVector()
        x[:4] /= np.sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2] + x[3] * x[3])
        output.SetFromVector(x)
