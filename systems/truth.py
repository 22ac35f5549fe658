"""The whole continuous truth in one LeafSystem: both orbits, both attitudes, the chaser's mass.

Owns: `Truth`, the one continuous system of a scenario's diagram. Its state holds the target's
orbit, the chaser's orbit relative to it, the chaser's mass and both bodies' attitudes and rates;
its one derivative callback also maps the thruster command (on-levels of a fixed layout, clipped
as `ThrusterBank` clips them) to the body wrench and the propellant mass flow, or takes both from
an actuator outside (`wrench_input`, e.g. `IdealActuator`).
Does not own: the equations, which live in `rpod.models` (gravity, frames, rigid body,
thrusters) and are the ones `OrbitalDynamics`, `RigidBodyAttitude` and `ThrusterBank` integrate
(the first two are test-only references in tests/reference; tests/systems/test_truth.py checks
the derivatives against the three wired as `tests.reference.split_truth.SplitTruth`); the
orbit's set-up (`OrbitConfig`, `initial_orbit_state`, `lvlh_of`: `rpod.models.orbit`); pulse
modulation (`rpod.systems.pwm`); gimbaled thrusters (a `ThrusterBank` outside feeds this
system's `wrench_input`).

Why one system (benchmarks/results/hold_point.md). With PWM every 10 ms slot ends an integrator
step, so a simulated second costs ~100 steps of 3 derivative evaluations each. Split over the
three Python systems, one evaluation cost ~22-36 us: three callbacks, port evaluations between
them (chaser attitude into the orbit, body wrench into both) and numpy on 3-vectors (~1 us a
call). Here it is one callback that reads the state once, does plain float arithmetic and reads
the thrust from a cache entry: ~6.6 us, of which ~2.3 us is the arithmetic itself (the same
equations as a plain Python function) and the rest Drake's state and port access.

Thrust. The cache entry maps the command to (tau_C, f_C, mdot) once per new command, i.e. once
per PWM slot, not at every integrator stage; an ON/OFF pattern met before is looked up (a PWM
repeats a few patterns slot after slot), one met for the first time is computed with B u. The
PWM itself stays a separate system (`PwmModulator`, one discrete update per slot): the
integrator must stop at every slot anyway (pydrake cannot declare data-dependent event times,
and a step must not straddle a switch), and a pulse pattern latched once per period with a C++
slot clock measured only 3% faster on hold_point.

Continuous state (27), in the order the three old systems had in a diagram (so the integrator's
error norm and step sequence are the same):

    x = [p_IT_I, v_IT_I, r, r_dot, m_C, q_IT (w,x,y,z), w_IT_T, q_IC (w,x,y,z), w_IC_C]
         0:3     3:6     6:9 9:12  12   13:17           17:20   20:24           24:27

with (r, r_dot) = (p_TC_I, v_TC_I), the chaser relative to the target in ECI (`OrbitalDynamics`
explains why: the ~100 m separation keeps all its digits), or (p_LC_L, v_LC_L) under 'cw'.

Derivatives (the same as the old systems'):
    d/dt p_IT_I = v_IT_I,   d/dt v_IT_I = g(p_IT_I)
    d/dt p_TC_I = v_TC_I,   d/dt v_TC_I = g(p_IT_I + p_TC_I) - g(p_IT_I) + R_IC f_C / m_C
        ('cw': d/dt [p; v]_L = A_cw [p; v]_L + R_LI R_IC f_C / m_C, paper 004 eq. 4)
    d/dt m_C = -mdot,       mdot = sum_k u_k f_max,k / (Isp_k g0)
    d/dt q = 1/2 q (x) [0, w],   J w_dot = tau - w x (J w)   (paper 000 eq. 2; tau_T = 0)
    [tau_C; f_C] = B u         (paper 003 eqs. 3-4; u the clipped command)

R_IC is the rotation of the normalised q_IC (the old `RigidBodyAttitude` output normalises it
before `OrbitalDynamics` rotates the force; the same here). Quaternions are integrated as free
states and normalised on output only, as `RigidBodyAttitude` does.
"""

from __future__ import annotations

import math

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import BasicVector, Context, ValueProducer

from rpod.models.frames import (
    inertial_to_lvlh,
    lvlh_rotation,
    lvlh_to_inertial,
    quaternion_wxyz,
    rotate_by_wxyz,
)
from rpod.models.gravity import (
    GRAVITY_MODELS,
    gravity_acceleration_xyz,
)
from rpod.models.orbit import OrbitConfig, initial_orbit_state, lvlh_of
from rpod.models.rigid_body import validate_inertia
from rpod.models.thrusters import ThrusterLayout, validate_layout, wrench_matrix
from rpod.systems.lifetime import LeafSystem, weak_method

# The state layout (module docstring).
STATE_SIZE = 27
TARGET_ORBIT, RELATIVE, MASS = slice(0, 6), slice(6, 12), 12
TARGET_ATTITUDE, CHASER_ATTITUDE = slice(13, 20), slice(20, 27)
MEMO_SIZE = 4096  # ON/OFF patterns remembered by the thrust cache (2^12: every rcs_cube_12 one)


def _unit_quaternion(q) -> np.ndarray:
    q = np.asarray(q, dtype=float).reshape(-1)
    norm = np.linalg.norm(q)
    if q.size != 4 or not (np.isfinite(norm) and norm > 0.0):
        raise ValueError(f"a quaternion must be 4 finite numbers with non-zero norm, got {q}")
    return q / norm


def _rate(w) -> np.ndarray:
    w = np.asarray(w, dtype=float).reshape(-1)
    if w.size != 3 or not np.all(np.isfinite(w)):
        raise ValueError(f"an angular velocity must be 3 finite numbers, got {w}")
    return w


class Truth(LeafSystem):
    """Translation, rotation and mass of target and chaser, and the chaser's thrusters.

    Input ports, with a thruster layout:
        thruster_command (n): on-levels in [0, 1] (1.0/0.0 from a PWM, or duty as throttle);
            clipped to [0, 1], NaN read as 0, as `ThrusterBank` does.
    or, with `wrench_input` (an actuator outside, e.g. `IdealActuator`), as `OrbitalDynamics`:
        body_wrench (6): [tau_C; f_C] on the chaser, in C (N m, N), applied as given.
        propellant_mass_flow (1): kg/s drawn from the chaser's mass.
    or none (no thrust).
    Output ports (the old systems' names and layouts):
        target_state_I (6), chaser_state_I (6), relative_state_L (6), q_IL (4), w_IL_L (3),
            chaser_mass (1): as `OrbitalDynamics`.
        target_attitude (7), chaser_attitude (7): [q_wxyz normalised, w_B], as
            `RigidBodyAttitude`.
        body_wrench (6), propellant_mass_flow (1), command_clipped (n): as `ThrusterBank`
            (only with a thruster layout).
    No output depends on an input directly except the three thruster ones.
    """

    def __init__(
        self,
        orbit: OrbitConfig,
        p_LC_L0: np.ndarray,
        v_LC_L0: np.ndarray,
        chaser_mass_kg: float,
        J_T: np.ndarray,
        q_IT0: np.ndarray,
        w_IT_T0: np.ndarray,
        J_C: np.ndarray,
        q_IC0: np.ndarray,
        w_IC_C0: np.ndarray,
        layout: ThrusterLayout | None = None,
        report_tolerance: float = 1e-6,
        wrench_input: bool = False,
    ):
        """Builds the truth.

        Args:
            orbit: The target's orbit and the gravity model.
            p_LC_L0, v_LC_L0: The chaser's initial position and velocity in L (velocity seen in
                the rotating L), m and m/s.
            chaser_mass_kg: Initial chaser mass, kg.
            J_T, J_C: Inertias (3, 3) of target and chaser about their CoM, in their body
                frames, kg m^2.
            q_IT0, q_IC0: Initial attitudes R_IT, R_IC as quaternions (w, x, y, z), normalised
                here. `initial_orbit_state` and `lvlh_of` give R_IL at t = 0 to convert
                attitudes given in L.
            w_IT_T0, w_IC_C0: Initial angular velocities in the body frames, rad/s.
            layout: A fixed (not gimbaled) thruster layout, or None for no thrusters.
            report_tolerance: Command violation below which a clip is not reported in
                `command_clipped` (it is still clipped), as `ThrusterBank`.
            wrench_input: Take the body wrench and the mass flow as inputs instead of a thruster
                command (no layout then).

        Raises:
            ValueError: On an unknown gravity model, a non-physical inertia, a bad quaternion or
                rate, a gimbaled layout, or both a layout and `wrench_input`.
        """
        super().__init__()
        if orbit.gravity not in GRAVITY_MODELS:
            raise ValueError(f"gravity must be one of {GRAVITY_MODELS}, got '{orbit.gravity}'")
        self._gravity = orbit.gravity
        self._cw = orbit.gravity == "cw"
        p_IT_I, v_IT_I = initial_orbit_state(orbit)
        p_LC_L0, v_LC_L0 = np.asarray(p_LC_L0, float), np.asarray(v_LC_L0, float)
        if self._cw:
            # Mean motion of the CW model, as OrbitalDynamics takes it: |v| / |p| at t = 0.
            self._n_cw = math.sqrt(np.dot(v_IT_I, v_IT_I) / np.dot(p_IT_I, p_IT_I))
            relative0 = np.concatenate([p_LC_L0, v_LC_L0])
        else:
            R_IL, w_IL_L = lvlh_of(p_IT_I, v_IT_I, self._gravity)
            relative0 = np.concatenate(lvlh_to_inertial(R_IL, w_IL_L, p_LC_L0, v_LC_L0))
        for J, name in ((J_T, "target_inertia"), (J_C, "chaser_inertia")):
            validate_inertia(J, name)
        self._J_T, self._J_C = np.array(J_T, float), np.array(J_C, float)
        # Inertias and their inverses as flat float tuples for the hot path.
        self._J_T_flat = tuple(self._J_T.ravel().tolist())
        self._J_T_inv_flat = tuple(np.linalg.inv(self._J_T).ravel().tolist())
        self._J_C_flat = tuple(self._J_C.ravel().tolist())
        self._J_C_inv_flat = tuple(np.linalg.inv(self._J_C).ravel().tolist())
        x0 = np.concatenate(
            [
                p_IT_I,
                v_IT_I,
                relative0,
                [float(chaser_mass_kg)],
                _unit_quaternion(q_IT0),
                _rate(w_IT_T0),
                _unit_quaternion(q_IC0),
                _rate(w_IC_C0),
            ]
        )
        # All 27 states are "miscellaneous" (z), as in the old systems: the integrators treat
        # them alike and the error norm is the same.
        self.DeclareContinuousState(BasicVector(x0), 0, 0, STATE_SIZE)

        self._layout = layout
        self._command_port = None
        self._thrust_entry = None
        self._zero_thrust = (0.0,) * 7  # (tau_C, f_C, mdot)
        xc = {self.xc_ticket()}
        if layout is not None and wrench_input:
            raise ValueError("give Truth a thruster layout or wrench_input, not both")
        if wrench_input:
            self._wrench_port = self.DeclareVectorInputPort("body_wrench", 6)
            self._mass_flow_port = self.DeclareVectorInputPort("propellant_mass_flow", 1)
            self._thrust_entry = self.DeclareCacheEntry(
                "applied wrench and mass flow",
                ValueProducer(
                    allocate=lambda zero=self._zero_thrust: AbstractValue.Make((zero,)),
                    calc=weak_method(self._calc_applied_wrench),
                ),
                prerequisites_of_calc={
                    self.input_port_ticket(self._wrench_port.get_index()),
                    self.input_port_ticket(self._mass_flow_port.get_index()),
                },
            )
        if layout is not None:
            validate_layout(layout)
            if layout.gimbaled:
                raise ValueError("Truth takes a fixed layout; gimbaled thrusters need ThrusterBank")
            self._n = layout.count
            self._B = wrench_matrix(layout)
            self._mdot_per_level = layout.max_mass_flows_kg_s  # f_max / (Isp g0), kg/s
            self._report_tolerance = float(report_tolerance)
            # Thrust of each ON/OFF pattern met so far: a pure function of the command, so it is
            # shared by every context of this system.
            self._on_off_memo = {}
            self._command_port = self.DeclareVectorInputPort("thruster_command", self._n)
            # One cache entry holds what the command does: (tau_C (3), f_C (3), mdot) as floats
            # for the derivative, and the applied levels and clip flags for the outputs. It
            # depends on the input port only, so it is computed once per new command (once per
            # PWM slot), not at every integrator stage.
            self._thrust_entry = self.DeclareCacheEntry(
                "thrust of the clipped command",
                ValueProducer(
                    allocate=lambda zero=self._zero_thrust, n=self._n: AbstractValue.Make(
                        (zero, np.zeros(n), np.zeros(n))
                    ),
                    calc=weak_method(self._calc_thrust),
                ),
                prerequisites_of_calc={self.input_port_ticket(self._command_port.get_index())},
            )
            on_command = {self._thrust_entry.ticket()}
            self.DeclareVectorOutputPort("body_wrench", 6, self._calc_body_wrench, on_command)
            self.DeclareVectorOutputPort(
                "propellant_mass_flow", 1, self._calc_mass_flow, on_command
            )
            self.DeclareVectorOutputPort(
                "command_clipped", self._n, self._calc_command_clipped, on_command
            )

        # The LVLH frame and the relative state in L, shared by four outputs (the controller
        # reads them once per control period, the loggers once per sample).
        self._kinematics_entry = self.DeclareCacheEntry(
            "lvlh kinematics",
            ValueProducer(
                allocate=lambda: AbstractValue.Make(()), calc=weak_method(self._calc_kinematics)
            ),
            prerequisites_of_calc=xc,
        )
        kinematics = {self._kinematics_entry.ticket()}
        self.DeclareVectorOutputPort("target_state_I", 6, self._calc_target, xc)
        self.DeclareVectorOutputPort("chaser_state_I", 6, self._calc_chaser, kinematics)
        self.DeclareVectorOutputPort("relative_state_L", 6, self._calc_relative, kinematics)
        self.DeclareVectorOutputPort("q_IL", 4, self._calc_q_IL, kinematics)
        self.DeclareVectorOutputPort("w_IL_L", 3, self._calc_w_IL_L, kinematics)
        self.DeclareVectorOutputPort("chaser_mass", 1, self._calc_mass, xc)
        self.DeclareVectorOutputPort("target_attitude", 7, self._calc_target_attitude, xc)
        self.DeclareVectorOutputPort("chaser_attitude", 7, self._calc_chaser_attitude, xc)

    @property
    def gravity(self) -> str:
        """The truth gravity model name."""
        return self._gravity

    @property
    def layout(self) -> ThrusterLayout | None:
        """The thruster layout (None without thrusters)."""
        return self._layout

    # ---- Thrust: once per new command. ----

    def _calc_thrust(self, context: Context, value: AbstractValue) -> None:
        command = self._command_port.Eval(context)
        key = command.tobytes()
        known = self._on_off_memo.get(key)
        if known is not None:  # an ON/OFF pattern seen before (most PWM slots)
            value.set_value(known)
            return
        if command.min() >= 0.0 and command.max() <= 1.0:
            # Every PWM on/off command: in range and finite (NaN fails both comparisons), so
            # applied = command bit for bit and nothing is reported.
            applied, clipped = command.copy(), np.zeros(self._n)
        else:  # ThrusterBank's clip: to [0, 1], NaN read as 0 and reported.
            violation = np.maximum(np.maximum(-command, command - 1.0), 0.0)
            nan = np.isnan(command)
            if np.any(nan):
                violation[nan] = np.inf
                command = np.where(nan, 0.0, command)
            applied = np.clip(command, 0.0, 1.0)
            clipped = (violation > self._report_tolerance).astype(float)
        wrench = self._B @ applied  # B u (paper 003 eqs. 3-4, paper 001 eqs. 11-12)
        mdot = float(self._mdot_per_level @ applied)  # sum_k u_k f_max,k / (Isp_k g0)
        result = (tuple(wrench.tolist()) + (mdot,), applied, clipped)
        # Remember ON/OFF patterns only (at most 2^n, and few occur): a PWM repeats them slot
        # after slot, while duty used as throttle hardly ever repeats.
        on_off = not clipped.any() and np.all((applied == 0.0) | (applied == 1.0))
        if on_off and len(self._on_off_memo) < MEMO_SIZE:
            self._on_off_memo[key] = result
        value.set_value(result)

    def _calc_applied_wrench(self, context: Context, value: AbstractValue) -> None:
        wrench = self._wrench_port.Eval(context)
        mdot = self._mass_flow_port.Eval(context)[0]
        value.set_value((tuple(wrench.tolist()) + (float(mdot),),))

    def thrust(self, context: Context) -> tuple:
        """(tau_C (3), f_C (3), mdot) as floats: what the derivative applies for the command in
        `context` (N m, N, kg/s; zeros without thrusters)."""
        if self._thrust_entry is None:
            return self._zero_thrust
        return self._thrust_entry.Eval(context)[0]

    def _calc_body_wrench(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(self.thrust(context)[0:6])

    def _calc_mass_flow(self, context: Context, output: BasicVector) -> None:
        output.SetAtIndex(0, self.thrust(context)[6])

    def _calc_command_clipped(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(self._thrust_entry.Eval(context)[2])

    # ---- The derivative: the hot path (3 evaluations per step). ----

    def DoCalcTimeDerivatives(self, context: Context, derivatives) -> None:
        """Every state's rate (see the module docstring), with plain float arithmetic."""
        x = context.get_continuous_state_vector().CopyToVector().tolist()
        px, py, pz, vx, vy, vz, rx, ry, rz, sx, sy, sz, m = x[0:13]
        tw, tx, ty, tz, wtx, wty, wtz = x[13:20]
        cw, cx, cy, cz, wcx, wcy, wcz = x[20:27]
        if self._thrust_entry is None:
            thrust = self._zero_thrust
        else:
            thrust = self._thrust_entry.Eval(context)[0]
        taux, tauy, tauz, fx, fy, fz, mdot = thrust
        gravity = self._gravity

        # Force in I: R_IC f_C with the normalised q_IC (Rodrigues form, rotate_by_wxyz).
        k = 1.0 / math.sqrt(cw * cw + cx * cx + cy * cy + cz * cz)
        fIx, fIy, fIz = rotate_by_wxyz((cw * k, cx * k, cy * k, cz * k), (fx, fy, fz))
        inverse_mass = 1.0 / m

        # Translation (OrbitalDynamics, eq. (13) of its docstring).
        aTx, aTy, aTz = gravity_acceleration_xyz(px, py, pz, gravity)
        if self._cw:
            # CW about the target's two-body orbit (paper 004 eq. 4: the rows of
            # rpod.models.cw.cw_continuous written out), force rotated into L by R_LI = R_IL^T.
            n = self._n_cw
            R = lvlh_rotation(np.array([px, py, pz]), np.array([vx, vy, vz]))
            fLx = (R[0, 0] * fIx + R[1, 0] * fIy + R[2, 0] * fIz) * inverse_mass
            fLy = (R[0, 1] * fIx + R[1, 1] * fIy + R[2, 1] * fIz) * inverse_mass
            fLz = (R[0, 2] * fIx + R[1, 2] * fIy + R[2, 2] * fIz) * inverse_mass
            ax = 3.0 * n * n * rx + 2.0 * n * sy + fLx
            ay = -2.0 * n * sx + fLy
            az = -n * n * rz + fLz
        else:
            aCx, aCy, aCz = gravity_acceleration_xyz(px + rx, py + ry, pz + rz, gravity)
            ax = aCx - aTx + fIx * inverse_mass  # differential gravity + thrust
            ay = aCy - aTy + fIy * inverse_mass
            az = aCz - aTz + fIz * inverse_mass

        # Rotation (paper 000 eq. 2): J w_dot = tau - w x (J w); q_dot = 1/2 q (x) [0, w].
        J = self._J_T_flat
        hx = J[0] * wtx + J[1] * wty + J[2] * wtz
        hy = J[3] * wtx + J[4] * wty + J[5] * wtz
        hz = J[6] * wtx + J[7] * wty + J[8] * wtz
        ex, ey, ez = hy * wtz - hz * wty, hz * wtx - hx * wtz, hx * wty - hy * wtx  # h x w
        Ji = self._J_T_inv_flat
        J = self._J_C_flat
        hx = J[0] * wcx + J[1] * wcy + J[2] * wcz
        hy = J[3] * wcx + J[4] * wcy + J[5] * wcz
        hz = J[6] * wcx + J[7] * wcy + J[8] * wcz
        gx = hy * wcz - hz * wcy + taux
        gy = hz * wcx - hx * wcz + tauy
        gz = hx * wcy - hy * wcx + tauz
        Jc = self._J_C_inv_flat

        xdot = [
            vx,
            vy,
            vz,
            aTx,
            aTy,
            aTz,  # target orbit
            sx,
            sy,
            sz,
            ax,
            ay,
            az,  # chaser relative to the target
            -mdot,  # propellant
            0.5 * (-tx * wtx - ty * wty - tz * wtz),  # q_IT rate: 1/2 L(q) [0; w] (eq. 1-2)
            0.5 * (tw * wtx + ty * wtz - tz * wty),
            0.5 * (tw * wty + tz * wtx - tx * wtz),
            0.5 * (tw * wtz + tx * wty - ty * wtx),
            Ji[0] * ex + Ji[1] * ey + Ji[2] * ez,  # w_IT_T rate: J_T^-1 (h x w), torque-free
            Ji[3] * ex + Ji[4] * ey + Ji[5] * ez,
            Ji[6] * ex + Ji[7] * ey + Ji[8] * ez,
            0.5 * (-cx * wcx - cy * wcy - cz * wcz),  # q_IC rate
            0.5 * (cw * wcx + cy * wcz - cz * wcy),
            0.5 * (cw * wcy + cz * wcx - cx * wcz),
            0.5 * (cw * wcz + cx * wcy - cy * wcx),
            Jc[0] * gx + Jc[1] * gy + Jc[2] * gz,  # w_IC_C rate: J_C^-1 (h x w + tau_C)
            Jc[3] * gx + Jc[4] * gy + Jc[5] * gz,
            Jc[6] * gx + Jc[7] * gy + Jc[8] * gz,
        ]
        derivatives.get_mutable_vector().SetFromVector(np.array(xdot))

    # ---- Outputs. ----

    def separation_of_origins_m(self, context: Context) -> float:
        """|p_TC|: the chaser's origin from the target's [m], read off the state (it is the
        same in ECI and in L), for cheap tests that need no output (the contact watch's)."""
        state = context.get_continuous_state_vector()
        x, y, z = state.GetAtIndex(6), state.GetAtIndex(7), state.GetAtIndex(8)
        return math.sqrt(x * x + y * y + z * z)

    def _state(self, context: Context) -> np.ndarray:
        return context.get_continuous_state_vector().CopyToVector()

    def _calc_kinematics(self, context: Context, value: AbstractValue) -> None:
        """(R_IL, w_IL_L, p_TC_I, v_TC_I, p_LC_L, v_LC_L), as `OrbitalDynamics.relative_state`."""
        x = self._state(context)
        R_IL, w_IL_L = lvlh_of(x[0:3], x[3:6], self._gravity)
        r0, r1 = x[6:9], x[9:12]
        if self._cw:
            relative = (*lvlh_to_inertial(R_IL, w_IL_L, r0, r1), r0, r1)
        else:
            relative = (r0, r1, *inertial_to_lvlh(R_IL, w_IL_L, r0, r1))
        value.set_value((R_IL, w_IL_L, *relative))

    def lvlh_kinematics(self, context: Context) -> tuple:
        """(R_IL, w_IL_L, p_TC_I, v_TC_I, p_LC_L, v_LC_L) of the state in `context`."""
        return self._kinematics_entry.Eval(context)

    def _calc_target(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(self._state(context)[0:6])

    def _calc_chaser(self, context: Context, output: BasicVector) -> None:
        x = self._state(context)
        _, _, p_TC_I, v_TC_I, _, _ = self.lvlh_kinematics(context)
        output.SetFromVector(np.concatenate([x[0:3] + p_TC_I, x[3:6] + v_TC_I]))

    def _calc_relative(self, context: Context, output: BasicVector) -> None:
        *_, p_LC_L, v_LC_L = self.lvlh_kinematics(context)
        output.SetFromVector(np.concatenate([p_LC_L, v_LC_L]))

    def _calc_q_IL(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(quaternion_wxyz(self.lvlh_kinematics(context)[0]))

    def _calc_w_IL_L(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(self.lvlh_kinematics(context)[1])

    def _calc_mass(self, context: Context, output: BasicVector) -> None:
        output.SetAtIndex(0, context.get_continuous_state_vector().GetAtIndex(MASS))

    @staticmethod
    def _attitude(x: np.ndarray) -> np.ndarray:
        x = x.copy()
        x[:4] /= math.sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2] + x[3] * x[3])
        return x

    def _calc_target_attitude(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(self._attitude(self._state(context)[TARGET_ATTITUDE]))

    def _calc_chaser_attitude(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(self._attitude(self._state(context)[CHASER_ATTITUDE]))
