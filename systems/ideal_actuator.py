"""IdealActuator: a bounded ideal force or acceleration, applied straight to the truth.

Owns the third actuation path (rpod.diagrams.controller_seam.Actuation.IDEAL): a command of
3 numbers, an acceleration or a force, in L or in C, is bounded (each component within
+-limit, paper 004 eq. 11e, or its norm within limit) and becomes the chaser's body wrench
[0; f_C] (no torque) and a propellant mass flow |f| / (g0 Isp). It is the setting of paper
004 (a chaser that can accelerate in any direction up to a_max) and of reference runs that
separate guidance from actuation.
Does not own: the truth that integrates the wrench and the mass, or the attitude (which an
ideal command does not need: the force is rotated into C with the sensed attitude).

    acceleration in L:  f_C = m R_CL a_L          acceleration in C:  f_C = m a_C
    force in L:         f_C = R_CL f_L            force in C:         f_C = f_C
    R_CL = R_IC^T R_IL  (sensed q_IC, q_IL)       mdot = |f_C| / (g0 Isp)

The bound applies to the command as given (in its own frame and unit): a box bound on an
acceleration in L is paper 004's |a_i| <= a_max.
"""

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import ValueProducer

from rpod.models.frames import rotation_from_wxyz
from rpod.models.thrusters import STANDARD_GRAVITY_M_S2
from rpod.systems.lifetime import LeafSystem, weak_method
from rpod.systems.sensed import Sensed, declare_sensed_input

QUANTITIES = ("acceleration", "force")
FRAMES = ("L", "C")
BOUNDS = ("box", "norm")


def bound_command(command: np.ndarray, bound: str, limit: float) -> tuple[np.ndarray, bool]:
    """(the bounded command, whether it was clipped); NaN components are read as 0."""
    command = np.nan_to_num(np.asarray(command, dtype=float), nan=0.0, posinf=0.0, neginf=0.0)
    if bound == "box":
        bounded = np.clip(command, -limit, limit)
        return bounded, bool(np.any(bounded != command))
    norm = float(np.linalg.norm(command))
    if norm > limit:
        return command * (limit / norm), True
    return command, False


class IdealActuator(LeafSystem):
    """Ideal bounded force or acceleration -> body wrench and propellant flow (module docstring).

    Input ports:
        command (3): acceleration [m/s^2] or force [N], in L or C.
        sensed (33): the sensed bundle (rpod.systems.sensed), for R_CL.
        chaser_mass (1): the chaser's current mass [kg].
    Output ports:
        body_wrench (6): [0; f_C] [N m; N].
        propellant_mass_flow (1): |f_C| / (g0 Isp) [kg/s].
        command_clipped (1): 1.0 when the bound changed the command, else 0.0.
    """

    def __init__(self, quantity: str, frame: str, bound: str, limit: float, isp_s: float):
        super().__init__()
        if quantity not in QUANTITIES or frame not in FRAMES or bound not in BOUNDS:
            raise ValueError(f"bad ideal command: {quantity}, {frame}, {bound}")
        if not (limit > 0 and isp_s > 0):
            raise ValueError(f"limit and isp_s must be positive, got {limit}, {isp_s}")
        self._quantity, self._frame, self._bound, self._limit = quantity, frame, bound, limit
        self._exhaust_speed = STANDARD_GRAVITY_M_S2 * isp_s
        self._command_port = self.DeclareVectorInputPort("command", 3)
        self._sensed_port = declare_sensed_input(self)
        self._mass_port = self.DeclareVectorInputPort("chaser_mass", 1)
        # One cache entry, [f_C (3), clipped (1)], shared by the three outputs: the truth reads
        # the wrench and the flow at every integrator stage.
        inputs = {
            self.input_port_ticket(port.get_index())
            for port in (self._command_port, self._sensed_port, self._mass_port)
        }
        self._force_entry = self.DeclareCacheEntry(
            "bounded force in C",
            ValueProducer(
                allocate=lambda: AbstractValue.Make(np.zeros(4)), calc=weak_method(self._calc_force)
            ),
            prerequisites_of_calc=inputs,
        )
        uses = {self._force_entry.ticket()}
        self.DeclareVectorOutputPort("body_wrench", 6, self._calc_wrench, uses)
        self.DeclareVectorOutputPort("propellant_mass_flow", 1, self._calc_flow, uses)
        self.DeclareVectorOutputPort("command_clipped", 1, self._calc_clipped, uses)

    def _calc_force(self, context, value) -> None:
        f_C, clipped = self.force_C(context)
        value.get_mutable_value()[:] = [*f_C, 1.0 if clipped else 0.0]

    def force_C(self, context) -> tuple[np.ndarray, bool]:
        """(f_C, clipped) at this context, computed (the outputs read the cached one)."""
        command, clipped = bound_command(self._command_port.Eval(context), self._bound, self._limit)
        if self._quantity == "acceleration":
            command = self._mass_port.Eval(context)[0] * command
        if self._frame == "L":
            sensed = Sensed.from_vector(self._sensed_port.Eval(context))
            R_CL = rotation_from_wxyz(sensed.q_IC).T @ rotation_from_wxyz(sensed.q_IL)
            command = R_CL @ command
        return command, clipped

    def _calc_wrench(self, context, output):
        output.SetFromVector(np.concatenate([np.zeros(3), self._force_entry.Eval(context)[:3]]))

    def _calc_flow(self, context, output):
        f_C = self._force_entry.Eval(context)[:3]
        output.SetAtIndex(0, float(np.linalg.norm(f_C)) / self._exhaust_speed)

    def _calc_clipped(self, context, output):
        output.SetAtIndex(0, self._force_entry.Eval(context)[3])
