"""Hold-point controller: track a point on the target's rotating docking axis, face the target.

Owns: `HoldPointControllerConfig` and `HoldPointController`, a discrete-time (sampled) law that
turns the relative state and both attitudes into a desired chaser body wrench [tau_C; f_C].
Does not own: allocation to thrusters (allocator.py) or pulse modulation (pwm.py).

Translation (paper 004 Sec. 7, paper 003 eqs. 12-13). The hold point H sits on the target's
docking axis, `hold_distance_m` beyond the docking port: p_TH_T = p_TD_T + d * a_T, so in L it
turns with the target, p_LH_L = R_LT p_TH_T. The reference R moves towards H along the sphere of
the chaser's current range, at most `max_reference_step_deg` ahead of the chaser's line of sight
(so the chord to it never cuts through the target), and descends to the hold range once the line
of sight is within `descent_gate_deg` of the docking axis. The law is a velocity-limited PD in L
with the CW gravity-gradient/Coriolis terms cancelled (paper 004 eq. 12) and the centripetal
acceleration of the co-rotating reference fed forward:
    v_des = v_R + sat(w_n / (2 zeta) (p_R - p), v_max)
    a     = 2 zeta w_n (v_des - v) + w_LT x (w_LT x p_R) - a_CW(p, v)
and the force is rotated into the chaser body frame, f_C = m R_CL a   (paper 003 eq. 13).

Attitude. The capture axis c_C points at the target's centre of mass; roll about it follows the
target's x axis, so that at the hold point the chaser is synchronised with the tumble. The
desired angular velocity is the finite difference of the desired attitude over one period, and
    tau_C = J (w_n^2 e_R + 2 zeta w_n (w_des - w)) + w x J w,
with e_R the rotation vector of R_CCdes.

The output is held between samples (discrete state) so that the allocator and the thruster bank
downstream are evaluated once per control period, not at every integrator stage.
"""

import dataclasses
import math

import numpy as np
from pydrake.common.value import Value

from rpod.models.config import bounded, check_bounds, positive
from rpod.models.cw import cw_acceleration
from rpod.models.docking import DockingGeometry
from rpod.models.frames import cross, rotate_towards, rotation_from_wxyz
from rpod.systems.capture_pointing import CapturePointing
from rpod.systems.lifetime import LeafSystem, weak_method
from rpod.systems.sensed import Sensed, declare_sensed_input
from rpod.systems.step_timer import StepTimer


@dataclasses.dataclass
class HoldPointControllerConfig:
    """Gains and geometry of the hold-point controller.

    Args:
        control_period_s: sample period of the law (the PWM period downstream).
        hold_distance_m: distance of the hold point beyond the docking port, along the axis.
        capture: hold the chaser's capture point E (chaser.capture_point_C), not its centre,
            hold_distance_m beyond the port: the centre's hold point moves |r_CE| further out
            (p_TH_T = p_TD_T + (d + |r_CE|) a_T), where, with the capture axis pointed at the
            target's centre along a docking axis through it, E is d beyond the port. With
            hold_distance_m 0 the law flies E onto the port, matching its motion: the PD
            baseline of a capture (judged by `mission: !Capture`, rpod.diagrams.mission).
        translation_bandwidth_rad_s: natural frequency w_n of the position loop.
        translation_damping: damping ratio zeta of the position loop.
        max_speed_m_s: limit on the commanded speed relative to the reference.
        attitude_bandwidth_rad_s: natural frequency of the attitude loop.
        attitude_damping: damping ratio of the attitude loop.
        descent_gate_deg: the reference descends to the hold range only within this angle of
            the docking axis; outside, it moves around the target at the chaser's range.
        max_reference_step_deg: how far ahead of the chaser's line of sight the reference may be.

    Bounds (rpod.models.config, checked by `validate()`): the period in (0, 300] s (the
    scenario bounds the samples of a run); the hold distance within the scenario's MAX_RANGE_M
    (1000 km; 0 is the port itself); bandwidths in (0, 10] rad/s and damping ratios in (0, 10];
    the speed limit up to the scenario's MAX_RELATIVE_SPEED_M_S; the gate and the reference step
    in (0, 180] deg (an angle between two directions).

    The capture axis is not configured here: it is the direction of the chaser's capture point
    (the scenario's chaser.capture_point_C), given to the controller.
    """

    control_period_s: float = positive(0.1, 300.0)
    hold_distance_m: float = bounded(10.0, 0.0, 1e6)
    capture: bool = False
    translation_bandwidth_rad_s: float = positive(0.15, 10.0)
    translation_damping: float = positive(1.0, 10.0)
    max_speed_m_s: float = positive(0.5, 1e4)
    attitude_bandwidth_rad_s: float = positive(0.5, 10.0)
    attitude_damping: float = positive(1.0, 10.0)
    descent_gate_deg: float = positive(10.0, 180.0)
    max_reference_step_deg: float = positive(20.0, 180.0)

    def validate(self) -> None:
        """Raises ConfigError naming the first field outside its declared bounds."""
        check_bounds(self)


class HoldPointController(LeafSystem):
    """Sampled hold-point law (module docstring), output held between samples.

    Input port: sensed (33, the sensed bundle of rpod.systems.sensed).
    Output ports: body_wrench_desired (6, [tau_C; f_C]), hold_point_L (3), reference_L (3).
    Built from the config, the chaser's mass and inertia, the target's docking geometry and the
    chaser's capture point in C (its direction is the capture axis the law points at the
    target; non-zero).
    """

    def __init__(
        self,
        config: HoldPointControllerConfig,
        chaser_mass_kg: float,
        chaser_inertia: np.ndarray,
        docking: DockingGeometry,
        capture_point_C,
    ):
        super().__init__()
        self._config = config
        self._mass = chaser_mass_kg
        self._J = np.asarray(chaser_inertia, dtype=float)
        distance = config.hold_distance_m
        if config.capture:  # the capture point d beyond the port (the config's docstring)
            distance = distance + float(np.linalg.norm(capture_point_C))
        self._p_TH_T = docking.p_TD_T + distance * docking.axis_T
        self._pointing = CapturePointing(
            capture_point_C,
            self._J,
            config.attitude_bandwidth_rad_s,
            config.attitude_damping,
            config.control_period_s,
        )

        self._sensed_port = declare_sensed_input(self)

        # Discrete state: [wrench (6), hold point (3), reference (3)]; abstract: last R_IKdes.
        self._output_state = self.DeclareDiscreteState(12)
        self._previous_desired = self.DeclareAbstractState(Value(np.zeros(0)))
        self.step_timer = StepTimer()  # the compute per control step (rpod.systems.step_timer)
        update = self.step_timer.timed(self._update)
        self.DeclarePeriodicUnrestrictedUpdateEvent(config.control_period_s, 0.0, update)
        self.DeclareInitializationUnrestrictedUpdateEvent(update)  # valid output at t=0
        xd = {self.discrete_state_ticket(self._output_state)}
        held = weak_method(self._held)  # not self in a lambda: rpod.systems.lifetime
        self.DeclareVectorOutputPort(
            "body_wrench_desired", 6, lambda c, o: o.SetFromVector(held(c)[0:6]), xd
        )
        self.DeclareVectorOutputPort(
            "hold_point_L", 3, lambda c, o: o.SetFromVector(held(c)[6:9]), xd
        )
        self.DeclareVectorOutputPort(
            "reference_L", 3, lambda c, o: o.SetFromVector(held(c)[9:12]), xd
        )

    def _held(self, context) -> np.ndarray:
        return context.get_discrete_state(self._output_state).get_value()

    def _update(self, context, state):
        cfg = self._config
        sensed = Sensed.from_vector(self._sensed_port.Eval(context))
        relative = sensed.relative_state_L
        p, v = relative[0:3], relative[3:6]
        R_IL = rotation_from_wxyz(sensed.q_IL)
        w_IL_L = sensed.w_IL_L
        target = sensed.target_attitude
        chaser = sensed.chaser_attitude
        R_IT = rotation_from_wxyz(target[0:4])
        R_LT = R_IL.T @ R_IT
        w_IT_L = R_LT @ target[4:7]
        w_LT_L = w_IT_L - w_IL_L  # target rate seen from the rotating LVLH frame

        # Reference on the rotating docking axis (module docstring).
        p_H = R_LT @ self._p_TH_T
        range_H, range_C = np.linalg.norm(p_H), max(np.linalg.norm(p), 1e-9)
        u_C, u_H = p / range_C, p_H / range_H
        off_axis = math.acos(min(max(float(u_C @ u_H), -1.0), 1.0))
        gate = math.radians(cfg.descent_gate_deg)
        blend = min(max((off_axis - gate) / gate, 0.0), 1.0)  # 0 inside the gate, 1 beyond 2x
        range_R = range_H + blend * max(range_C - range_H, 0.0)
        p_R = range_R * rotate_towards(u_C, u_H, math.radians(cfg.max_reference_step_deg))
        v_R = cross(w_LT_L, p_R)

        # Velocity-limited PD with CW and centripetal feed-forward (paper 004 eq. 12).
        w_n, zeta = cfg.translation_bandwidth_rad_s, cfg.translation_damping
        v_correction = w_n / (2 * zeta) * (p_R - p)
        speed = np.linalg.norm(v_correction)
        if speed > cfg.max_speed_m_s:
            v_correction *= cfg.max_speed_m_s / speed
        n = w_IL_L[2]
        a_L = (
            2 * zeta * w_n * (v_R + v_correction - v)
            + cross(w_LT_L, cross(w_LT_L, p_R))
            - cw_acceleration(n, p, v)
        )
        R_IC = rotation_from_wxyz(chaser[0:4])
        w_IC_C = chaser[4:7]
        f_C = self._mass * (R_IC.T @ (R_IL @ a_L))  # paper 003 eq. 13

        # Attitude: capture axis at the target, roll following the target's x axis.
        previous = context.get_abstract_state(self._previous_desired).get_value()
        tau_C, R_ICdes = self._pointing.torque(R_IL, u_C, R_IT, R_IC, w_IC_C, previous)

        state.get_mutable_discrete_state(self._output_state).set_value(
            np.concatenate([tau_C, f_C, p_H, p_R])
        )
        state.get_mutable_abstract_state(self._previous_desired).set_value(R_ICdes)
