"""AccelerationToWrench: an acceleration command in L flown by a chaser whose attitude is held.

Owns: the adapter that lets an acceleration-level guidance law (paper 004's, made for an ideal
actuator) drive real thrusters through the body-wrench path (path 1: allocator -> PWM ->
thruster bank): the force f_C = m R_CL a_L and an attitude PD torque that holds the chaser's
attitude fixed in L at the one it had at the first sample (an LVLH-held bus, the usual choice
for a translation-only guidance law: the thrusters then see a slowly turning command).
Does not own: the guidance (its command is an input), the allocation or the PWM.

With `capture_point_C` given, the attitude is not held in L but pointed: the capture axis at
the target's centre, the roll the target's (rpod.systems.capture_pointing), what flying the
capture point onto a tumbling target's port needs (paper 004's guidance in the shoot-out).

Sampled at `period_s` (the PWM period) and held: the allocator downstream runs once per period.
The mass m is the chaser's nominal (initial) mass, as a flight law knows it: the propellant
burned since shows up as a small thrust surplus, which the guidance's feedback absorbs.

    f_C   = m R_CL a_L                                            (paper 003 eq. 13)
    tau_C = J (w_a^2 e + 2 zeta w_a (w_des - w)) + w x J w         (rpod.models.rigid_body)
    R_ICdes = R_IL R_LC0,  w_des = R_CI w_IL_I
"""

import numpy as np
from pydrake.common.value import Value
from pydrake.math import RotationMatrix

from rpod.models.frames import rotation_from_wxyz
from rpod.models.rigid_body import attitude_pd_torque
from rpod.systems.capture_pointing import CapturePointing
from rpod.systems.lifetime import LeafSystem
from rpod.systems.sensed import Sensed, declare_sensed_input


class AccelerationToWrench(LeafSystem):
    """a_L command -> desired body wrench [tau_C; f_C], the attitude held in L or, with
    capture_point_C, pointed at the target (module docstring).

    Input ports: acceleration_command_L (3) [m/s^2], sensed (33).
    Output port: body_wrench_desired (6) [N m; N], held between samples.
    """

    def __init__(
        self,
        mass_kg: float,
        inertia_C: np.ndarray,
        period_s: float,
        attitude_bandwidth_rad_s: float = 0.5,
        attitude_damping: float = 1.0,
        capture_point_C=None,
    ):
        super().__init__()
        if not (
            mass_kg > 0 and period_s > 0 and attitude_bandwidth_rad_s > 0 and attitude_damping > 0
        ):
            raise ValueError("mass_kg, period_s and the attitude gains must be positive")
        self._mass = float(mass_kg)
        self._J = np.asarray(inertia_C, dtype=float)
        self._w_a, self._zeta = attitude_bandwidth_rad_s, attitude_damping
        self._command_port = self.DeclareVectorInputPort("acceleration_command_L", 3)
        self._sensed_port = declare_sensed_input(self)
        self._wrench = self.DeclareDiscreteState(6)
        self._R_LC0 = self.DeclareAbstractState(Value(np.zeros((0, 3))))
        self._pointing = None
        if capture_point_C is not None:
            self._R_ICdes = self.DeclareAbstractState(Value(np.zeros(0)))  # the last desired
            self._pointing = CapturePointing(
                capture_point_C, self._J, attitude_bandwidth_rad_s, attitude_damping, period_s
            )
        self.DeclarePeriodicUnrestrictedUpdateEvent(period_s, 0.0, self._update)
        self.DeclareVectorOutputPort(
            "body_wrench_desired",
            6,
            lambda c, o, i=self._wrench: o.SetFromVector(c.get_discrete_state(i).get_value()),
            {self.discrete_state_ticket(self._wrench)},
        )

    def _update(self, context, state) -> None:
        sensed = Sensed.from_vector(self._sensed_port.Eval(context))
        R_IL = rotation_from_wxyz(sensed.q_IL)
        R_IC = rotation_from_wxyz(sensed.q_IC)
        w_IC_C = np.asarray(sensed.w_IC_C, dtype=float)
        a_L = np.asarray(self._command_port.Eval(context), dtype=float)
        f_C = self._mass * (R_IC.T @ (R_IL @ a_L))
        if self._pointing is not None:
            p_L = np.asarray(sensed.p_LC_L, dtype=float)
            tau_C, R_ICdes = self._pointing.torque(
                R_IL,
                p_L / max(np.linalg.norm(p_L), 1e-9),
                rotation_from_wxyz(sensed.q_IT),
                R_IC,
                w_IC_C,
                context.get_abstract_state(self._R_ICdes).get_value(),
            )
            state.get_mutable_abstract_state(self._R_ICdes).set_value(R_ICdes)
            state.get_mutable_discrete_state(self._wrench).set_value(np.concatenate([tau_C, f_C]))
            return
        R_LC0 = context.get_abstract_state(self._R_LC0).get_value()
        if R_LC0.size == 0:  # the attitude to hold: the one at the first sample
            R_LC0 = R_IL.T @ R_IC
            state.get_mutable_abstract_state(self._R_LC0).set_value(R_LC0)
        R_ICdes = R_IL @ R_LC0
        error = RotationMatrix(R_IC.T @ R_ICdes).ToAngleAxis()
        e_C = error.axis() * error.angle()
        w_des_C = R_IC.T @ (R_IL @ np.asarray(sensed.w_IL_L, dtype=float))
        tau_C = attitude_pd_torque(self._J, e_C, w_des_C - w_IC_C, w_IC_C, self._w_a, self._zeta)
        state.get_mutable_discrete_state(self._wrench).set_value(np.concatenate([tau_C, f_C]))
