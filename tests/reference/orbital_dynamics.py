"""Translational truth of target and chaser: two-body + J2, two-body, CW, or free space.

Test-only reference (tests/reference, not part of the rpod package).
Owns: the `OrbitalDynamics` system.
Does not own: the orbit set-up (`OrbitConfig`, `initial_orbit_state`, `lvlh_of`:
rpod.models.orbit), attitude (tests.reference.rigid_body_attitude) or the thrusters
(rpod.systems.thruster_bank).

Formulation (why it keeps the digits). Integrating target and chaser separately in ECI and
subtracting leaves the ~100 m separation as the difference of two 7,000 km numbers, and the
integrator's error control acts on the 7,000 km numbers: a relative tolerance of 1e-12 already
means ~7 um per step on each body, uncorrelated between them. Instead the continuous state is

    x = [p_IT_I, v_IT_I, p_TC_I, v_TC_I, m_C]     (13)

with the chaser integrated *relative to the target* (p_TC_I = p_IC_I - p_IT_I) and
    d/dt v_TC_I = g(p_IT_I + p_TC_I) - g(p_IT_I) + f_I / m_C.
The gravity difference is computed in double: each term carries ~1e-15 m/s^2 of rounding, which
integrates to ~1e-8 m over 3,000 s, far below the 1 mm requirement. Error control on the relative
components (weights set by rpod.diagrams) then bounds the relative-position error directly.

For gravity == 'cw' the relative part is the LVLH state [p_LC_L, v_LC_L] and obeys the
Clohessy-Wiltshire equations (paper 004 eq. 4) about the target's two-body circular orbit; for
'free_space' (the planar air-bearing case of paper 003) there is no gravity, the target is
fixed at the origin and L coincides with I.

Where it is used. rpod.diagrams builds `rpod.systems.truth.Truth`, which integrates these
equations together with both attitudes in one system (for speed; see its docstring). This system
is part of the tested reference it is checked against (`tests.reference.split_truth.SplitTruth`),
and stays usable on its own, e.g. with a force given in L or I.
"""

import math

import numpy as np
from pydrake.systems.framework import BasicVector, LeafSystem

from rpod.models.cw import cw_continuous
from rpod.models.frames import (
    inertial_to_lvlh,
    lvlh_rotation,
    lvlh_to_inertial,
    quaternion_wxyz,
    rotate_by_wxyz,
)
from rpod.models.gravity import GRAVITY_MODELS, gravity_acceleration_xyz
from rpod.models.orbit import OrbitConfig, initial_orbit_state, lvlh_of

FORCE_FRAMES = ("C", "L", "I")


class OrbitalDynamics(LeafSystem):
    """Translational truth of target and chaser (see the module docstring for the state).

    Input ports:
        body_wrench (6): [tau; f] on the chaser; f is expressed in `force_frame` ('C' body,
            'L' LVLH or 'I' inertial); the torque part is ignored here.
        chaser_attitude (7): [q_IC (w,x,y,z), w_IC_C]; only when force_frame == 'C'.
        propellant_mass_flow (1): kg/s drawn from the chaser's mass.
    Output ports:
        target_state_I (6): [p_IT_I, v_IT_I].
        chaser_state_I (6): [p_IC_I, v_IC_I].
        relative_state_L (6): [p_LC_L, v_LC_L], velocity seen in the rotating L.
        q_IL (4): LVLH attitude in ECI (w, x, y, z).
        w_IL_L (3): LVLH angular velocity in I, expressed in L.
        chaser_mass (1): kg.
    """

    def __init__(
        self,
        orbit: OrbitConfig,
        p_LC_L0: np.ndarray,
        v_LC_L0: np.ndarray,
        chaser_mass_kg: float,
        force_frame: str = "C",
    ):
        super().__init__()
        if orbit.gravity not in GRAVITY_MODELS:
            raise ValueError(f"gravity must be one of {GRAVITY_MODELS}, got '{orbit.gravity}'")
        if force_frame not in FORCE_FRAMES:
            raise ValueError(f"force_frame must be one of {FORCE_FRAMES}, got '{force_frame}'")
        self._gravity = orbit.gravity
        self._force_frame = force_frame
        p_IT_I, v_IT_I = initial_orbit_state(orbit)
        self._A_cw = None
        if orbit.gravity == "cw":
            n = math.sqrt(np.dot(v_IT_I, v_IT_I) / np.dot(p_IT_I, p_IT_I))
            self._A_cw = cw_continuous(n)[0]
            relative0 = np.concatenate([p_LC_L0, v_LC_L0])
        else:
            R_IL, w_IL_L = self._lvlh(p_IT_I, v_IT_I)
            relative0 = np.concatenate(lvlh_to_inertial(R_IL, w_IL_L, p_LC_L0, v_LC_L0))
        x0 = np.concatenate([p_IT_I, v_IT_I, relative0, [chaser_mass_kg]])
        self.DeclareContinuousState(BasicVector(x0), 0, 0, 13)
        self._xdot = np.empty(13)  # reused by DoCalcTimeDerivatives (no per-step allocation)

        self._wrench_port = self.DeclareVectorInputPort("body_wrench", 6)
        self._attitude_port = None
        if force_frame == "C":
            self._attitude_port = self.DeclareVectorInputPort("chaser_attitude", 7)
        self._mass_flow_port = self.DeclareVectorInputPort("propellant_mass_flow", 1)

        xc = {self.xc_ticket()}
        self.DeclareVectorOutputPort("target_state_I", 6, self._calc_target, xc)
        self.DeclareVectorOutputPort("chaser_state_I", 6, self._calc_chaser, xc)
        self.DeclareVectorOutputPort("relative_state_L", 6, self._calc_relative, xc)
        self.DeclareVectorOutputPort("q_IL", 4, self._calc_q_IL, xc)
        self.DeclareVectorOutputPort("w_IL_L", 3, self._calc_w_IL_L, xc)
        self.DeclareVectorOutputPort("chaser_mass", 1, self._calc_mass, xc)

    @property
    def gravity(self) -> str:
        """The truth gravity model name."""
        return self._gravity

    def _lvlh(self, p_IT_I, v_IT_I):
        """(R_IL, w_IL_L) of the target's LVLH frame; identity and zero in free space."""
        return lvlh_of(p_IT_I, v_IT_I, self._gravity)

    def _split(self, context):
        x = context.get_continuous_state_vector().CopyToVector()
        return x[0:3], x[3:6], x[6:9], x[9:12], x[12]

    def relative_state(self, context) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(p_TC_I, v_TC_I, p_LC_L, v_LC_L) from the state, whichever the formulation."""
        p_IT_I, v_IT_I, r0, r1, _ = self._split(context)
        R_IL, w_IL_L = self._lvlh(p_IT_I, v_IT_I)
        if self._gravity == "cw":
            return (*lvlh_to_inertial(R_IL, w_IL_L, r0, r1), r0, r1)
        return (r0, r1, *inertial_to_lvlh(R_IL, w_IL_L, r0, r1))

    def DoCalcTimeDerivatives(self, context, derivatives):
        """Two-body/J2/CW/free-space motion of the target and of the chaser relative to it.

        Written with plain floats: it runs at every integrator stage, and numpy on 3-vectors
        costs ~5x more than the arithmetic itself.
        """
        x = context.get_continuous_state_vector().CopyToVector()
        f = self._wrench_port.Eval(context)
        inverse_mass = 1.0 / x[12]
        if self._force_frame == "C":
            q = self._attitude_port.Eval(context)[0:4]
            f_I = rotate_by_wxyz(q / math.sqrt(q @ q), (f[3], f[4], f[5]))
        elif self._force_frame == "I" or self._gravity == "free_space":
            f_I = (f[3], f[4], f[5])
        else:
            f_I = lvlh_rotation(x[0:3], x[3:6]) @ f[3:6]
        xdot = self._xdot
        xdot[0:3] = x[3:6]
        xdot[3:6] = a_T = gravity_acceleration_xyz(x[0], x[1], x[2], self._gravity)
        if self._gravity == "cw":
            xdot[6:12] = self._A_cw @ x[6:12]
            xdot[9:12] += lvlh_rotation(x[0:3], x[3:6]).T @ f_I * inverse_mass  # 004 eq. 4
        else:
            a_C = gravity_acceleration_xyz(x[0] + x[6], x[1] + x[7], x[2] + x[8], self._gravity)
            xdot[6:9] = x[9:12]
            xdot[9] = a_C[0] - a_T[0] + f_I[0] * inverse_mass  # differential gravity, eq. (13)
            xdot[10] = a_C[1] - a_T[1] + f_I[1] * inverse_mass
            xdot[11] = a_C[2] - a_T[2] + f_I[2] * inverse_mass
        xdot[12] = -self._mass_flow_port.Eval(context)[0]
        derivatives.get_mutable_vector().SetFromVector(xdot)

    def _calc_target(self, context, output):
        p_IT_I, v_IT_I, *_ = self._split(context)
        output.SetFromVector(np.concatenate([p_IT_I, v_IT_I]))

    def _calc_chaser(self, context, output):
        p_IT_I, v_IT_I, *_ = self._split(context)
        p_TC_I, v_TC_I, _, _ = self.relative_state(context)
        output.SetFromVector(np.concatenate([p_IT_I + p_TC_I, v_IT_I + v_TC_I]))

    def _calc_relative(self, context, output):
        _, _, p_LC_L, v_LC_L = self.relative_state(context)
        output.SetFromVector(np.concatenate([p_LC_L, v_LC_L]))

    def _calc_q_IL(self, context, output):
        p_IT_I, v_IT_I, *_ = self._split(context)
        output.SetFromVector(quaternion_wxyz(self._lvlh(p_IT_I, v_IT_I)[0]))

    def _calc_w_IL_L(self, context, output):
        p_IT_I, v_IT_I, *_ = self._split(context)
        output.SetFromVector(self._lvlh(p_IT_I, v_IT_I)[1])

    def _calc_mass(self, context, output):
        output.SetAtIndex(0, self._split(context)[4])
