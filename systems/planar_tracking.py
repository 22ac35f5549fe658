"""Planar trajectory tracking by PD on the pose and velocity errors (paper 003 Sec. IV-A).

Owns: `PlanarTrackingConfig` (gains and period), `PlanarTrackingController` (the sampled law
of paper 003 eqs. 11-13, output as a desired body wrench [tau_C; f_C]), `PlanarReference`
(what it flies, given or planned once at start), and the small planar
helpers it is made of (`planar_state_from_sensed`, `wrap_to_pi`, `planar_tracking_error`,
`planar_pd_wrench`, `body_wrench_from_planar`, `critically_damped_gains`).
Does not own: the planner (its plug-in hands the tracker a `plan_at_start` callable), the
allocation to thrusters (eq. 14, `rpod.systems.allocator.WrenchAllocator`, which solves it for
the `planar_8` layout: its rows tau_x, tau_y, f_z are zero, so the 6-row least squares is
eq. 14 on (tau_z, f_x, f_y), with rpod's minimum-fuel tie-break among the optimal duties,
which eq. 14 leaves open) or the pulse modulation (`rpod.systems.pwm`).

Planar world. Paper 003's state x = [x, y, theta, v_x, v_y, omega] (eq. 1) lives in the x-y
plane of the target's LVLH frame L, theta about L's z. Under `free_space` gravity (the paper's
air-bearing setting) L coincides with I, has no rate, and the target sits at its origin
(`rpod.models.orbit`), so L is paper 003's inertial frame with the target at the
origin. From the sensed bundle (`rpod.systems.sensed`): (x, y) = p_LC_L[0:2],
(v_x, v_y) = v_LC_L[0:2], theta = the yaw of R_LC = R_IL^T R_IC (atan2 of its first column),
omega = z component of w_LC_L = R_LC w_IC_C - w_IL_L. Out-of-plane motion (p_z, v_z, roll,
pitch) is neither read nor controlled, as in the paper: the planar_8 thrusters cannot act on
it, and a chaser started in the plane with z a principal axis of its inertia stays there.

The law, at each sample t_k = k T:
    e = x_ref(t_k) - x, e_theta wrapped to (-pi, pi]                             (eq. 11)
    F_L = [K_pP e_x + K_dP e_vx,  K_pP e_y + K_dP e_vy,  K_pA e_theta + K_dA e_omega]
          (+ F_ff(t_k) if a feed-forward wrench is given)                        (eq. 12)
    [F_bx, F_by] = R(theta)^T [F_x, F_y],  tau unchanged                         (eq. 13)
    body_wrench_desired = [tau_C; f_C] = [0, 0, tau, F_bx, F_by, 0]
Paper 003 uses no feed-forward: eq. 12 is the PD alone, and the planner's wrench is not fed to
the tracker. A feed-forward (the planner's world wrench) is accepted here as an option; it is
added in L before the rotation of eq. 13. Outside the reference's time span the reference is its
nearest end pose at rest (velocities 0) and the feed-forward is 0, so a finished reference is
held as a station-keeping point. Given a release time, the tracker commands no wrench from
then on (the errors are still computed and output): the chaser coasts.

Gains (defaults, `critically_damped_gains`). Each axis is a double integrator
(m for x and y, I_zz for theta) sampled with a zero-order hold at T. The gains put both
closed-loop poles of the sampled loop at z = exp(-w_n T), the discrete critically damped loop:
    K_p = J (1 - r)^2 / T^2,   K_d = J (1 - r)(3 + r) / (2 T),   r = exp(-w_n T)
(-> J w_n^2 and 2 J w_n as T -> 0). Defaults at paper 003's scale: m = 10 kg, I_zz = 0.15 kg m^2
(a 0.3 m square of 10 kg), T = 0.1 s (Sec. V), w_n = 0.4 rad/s for position and 0.8 rad/s for
attitude: K_pP = 1.54 N/m, K_dP = 7.77 N s/m, K_pA = 0.0887 N m/rad, K_dA = 0.226 N m s/rad.
Chosen on this plant with planar_8 (0.3 m), the allocator and the PWM (N = 10), thrusters of
0.03-1 N (a plain-numpy simulation, pose bandwidths 0.2/0.5 to 0.8/1.6 rad/s): from a 5 cm,
0.2 rad offset 1% of the samples saturate at 0.03 N (2% at 0.5/1.0, 4% at 0.8/1.6), and a
0.55 m, 90 deg rest-to-rest reference of 60 s is tracked within 5 mm (2.3 mm rms after 30 s)
and 0.2 deg without feed-forward (8 mm rms at 0.2/0.5, 0.6 mm at 0.8/1.6). Higher bandwidths
track tighter, but with 1 N thrusters spend more propellant on limit cycles of the minimum
impulse (one 10 ms slot of one thruster turns this chaser by 0.01 rad/s): 1.8 against 0.8 N s
from that offset at 0.8/1.6 against 0.4/0.8. tests/systems/test_planar_tracking.py flies the
offset. For another chaser call `PlanarTrackingConfig.critically_damped` with its mass and inertia.

Timing. A periodic unrestricted update at T (and one at initialisation) holds the outputs in
discrete state, as `HoldPointController` does: the allocator downstream is evaluated once per
sample, and Drake runs unrestricted updates before the PWM's discrete ones at the same instant,
so the PWM latches this sample's duty (see `rpod.systems.pwm`).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from pydrake.common.value import Value
from pydrake.systems.framework import Context, State
from pydrake.trajectories import PiecewisePolynomial

from rpod.models.config import ConfigError
from rpod.models.frames import rotation_from_wxyz
from rpod.systems.lifetime import LeafSystem
from rpod.systems.plan_at_start import PlannedPath, declare_planned_path_output
from rpod.systems.sensed import Sensed, declare_sensed_input

DEFAULT_CHASER_MASS_KG = 10.0
"""Paper 003's scale: the chaser mass the default gains are tuned for (kg)."""

DEFAULT_CHASER_INERTIA_ZZ_KG_M2 = 0.15
"""A 0.3 m square of 10 kg about its normal, m (a^2 + b^2) / 12 (kg m^2)."""

DEFAULT_POSITION_BANDWIDTH_RAD_S = 0.4
"""w_n of the position loops behind the default gains (rad/s)."""

DEFAULT_ATTITUDE_BANDWIDTH_RAD_S = 0.8
"""w_n of the attitude loop behind the default gains (rad/s)."""

DEFAULT_CONTROL_PERIOD_S = 0.1
"""Paper 003 Sec. V: a 10 Hz control cycle."""


def critically_damped_gains(
    inertia: float, bandwidth_rad_s: float, period_s: float
) -> tuple[float, float]:
    """(K_p, K_d) putting both poles of a ZOH-sampled double integrator at exp(-w_n T).

    The plant q'' = u / J sampled at T with u = K_p e_q + K_d e_v held over each period has the
    characteristic polynomial z^2 - (2 - (K_p T^2 / 2 + K_d T) / J) z + 1 - (K_d T - K_p T^2 / 2)
    / J; equating it with (z - r)^2 gives the module docstring's formulas.

    Args:
        inertia: J, the mass (kg) or moment of inertia (kg m^2) of the axis.
        bandwidth_rad_s: w_n (> 0).
        period_s: T (> 0).
    """
    if not (inertia > 0 and bandwidth_rad_s > 0 and period_s > 0):
        raise ValueError(
            f"inertia, bandwidth and period must be positive, got {inertia}, "
            f"{bandwidth_rad_s}, {period_s}"
        )
    r = math.exp(-bandwidth_rad_s * period_s)
    kp = inertia * (1.0 - r) ** 2 / period_s**2
    kd = inertia * (1.0 - r) * (3.0 + r) / (2.0 * period_s)
    return kp, kd


_DEFAULT_KP_P, _DEFAULT_KD_P = critically_damped_gains(
    DEFAULT_CHASER_MASS_KG, DEFAULT_POSITION_BANDWIDTH_RAD_S, DEFAULT_CONTROL_PERIOD_S
)
_DEFAULT_KP_A, _DEFAULT_KD_A = critically_damped_gains(
    DEFAULT_CHASER_INERTIA_ZZ_KG_M2, DEFAULT_ATTITUDE_BANDWIDTH_RAD_S, DEFAULT_CONTROL_PERIOD_S
)


@dataclasses.dataclass
class PlanarTrackingConfig:
    """Gains and period of the planar PD tracker (paper 003 eq. 12).

    Args:
        control_period_s: sample period T of the law (paper 003 Sec. V: 0.1 s).
        position_kp_N_per_m: K_pP, on the position errors e_x, e_y.
        position_kd_N_s_per_m: K_dP, on the velocity errors e_vx, e_vy.
        attitude_kp_N_m_per_rad: K_pA, on the heading error e_theta.
        attitude_kd_N_m_s_per_rad: K_dA, on the rate error e_omega.
    Defaults: critically damped at 0.4 rad/s (position) and 0.8 rad/s (attitude) for a 10 kg,
    0.15 kg m^2 chaser at 10 Hz (module docstring).
    """

    control_period_s: float = DEFAULT_CONTROL_PERIOD_S
    position_kp_N_per_m: float = _DEFAULT_KP_P
    position_kd_N_s_per_m: float = _DEFAULT_KD_P
    attitude_kp_N_m_per_rad: float = _DEFAULT_KP_A
    attitude_kd_N_m_s_per_rad: float = _DEFAULT_KD_A

    @classmethod
    def critically_damped(
        cls,
        mass_kg: float,
        inertia_zz_kg_m2: float,
        position_bandwidth_rad_s: float = DEFAULT_POSITION_BANDWIDTH_RAD_S,
        attitude_bandwidth_rad_s: float = DEFAULT_ATTITUDE_BANDWIDTH_RAD_S,
        control_period_s: float = DEFAULT_CONTROL_PERIOD_S,
    ) -> PlanarTrackingConfig:
        """The config whose gains are `critically_damped_gains` for this chaser."""
        kp_p, kd_p = critically_damped_gains(mass_kg, position_bandwidth_rad_s, control_period_s)
        kp_a, kd_a = critically_damped_gains(
            inertia_zz_kg_m2, attitude_bandwidth_rad_s, control_period_s
        )
        return cls(control_period_s, kp_p, kd_p, kp_a, kd_a)

    def validate(self) -> None:
        """Raises ConfigError naming the first bad field."""
        if not (math.isfinite(self.control_period_s) and self.control_period_s > 0):
            raise ConfigError("control_period_s", f"must be positive, got {self.control_period_s}")
        for name in (
            "position_kp_N_per_m",
            "position_kd_N_s_per_m",
            "attitude_kp_N_m_per_rad",
            "attitude_kd_N_m_s_per_rad",
        ):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise ConfigError(name, f"must be finite and >= 0, got {value}")


def wrap_to_pi(angle: float) -> float:
    """The angle plus a multiple of 2 pi that lies in (-pi, pi]."""
    return angle - 2.0 * math.pi * math.ceil((angle - math.pi) / (2.0 * math.pi))


def planar_state_from_sensed(sensed: Sensed) -> np.ndarray:
    """Paper 003's x = [x, y, theta, v_x, v_y, omega] (eq. 1) in the x-y plane of L.

    (x, y, v_x, v_y) from the relative state in L; theta the yaw of R_LC; omega the z
    component of w_LC_L = R_LC w_IC_C - w_IL_L (module docstring).
    """
    R_IL = rotation_from_wxyz(sensed.q_IL)
    R_LC = R_IL.T @ rotation_from_wxyz(sensed.q_IC)
    theta = math.atan2(R_LC[1, 0], R_LC[0, 0])
    omega = float(R_LC[2] @ sensed.w_IC_C) - float(sensed.w_IL_L[2])
    p, v = sensed.p_LC_L, sensed.v_LC_L
    return np.array([p[0], p[1], theta, v[0], v[1], omega])


def planar_tracking_error(x_ref: np.ndarray, x: np.ndarray) -> np.ndarray:
    """e = x_ref - x with the heading error wrapped to (-pi, pi] (paper 003 eq. 11)."""
    e = np.asarray(x_ref, dtype=float) - np.asarray(x, dtype=float)
    e[2] = wrap_to_pi(e[2])
    return e


def planar_pd_wrench(e: np.ndarray, config: PlanarTrackingConfig) -> np.ndarray:
    """[F_x, F_y, tau] in L = the PD of the error (paper 003 eq. 12)."""
    kp, kd = config.position_kp_N_per_m, config.position_kd_N_s_per_m
    kp_a, kd_a = config.attitude_kp_N_m_per_rad, config.attitude_kd_N_m_s_per_rad
    return np.array(
        [
            kp * e[0] + kd * e[3],  # F_x,ref = K_pP e_x + K_dP e_vx
            kp * e[1] + kd * e[4],  # F_y,ref = K_pP e_y + K_dP e_vy
            kp_a * e[2] + kd_a * e[5],  # tau_ref = K_pA e_theta + K_dA e_omega
        ]
    )


def body_wrench_from_planar(wrench_L: np.ndarray, theta: float) -> np.ndarray:
    """[tau_C; f_C] (6) of a planar wrench [F_x, F_y, tau] in L for a chaser at heading theta.

    f_C = [R(theta)^T [F_x, F_y], 0] (paper 003 eq. 13), tau_C = [0, 0, tau]: the torque about
    the plane's normal is the same in both frames.
    """
    c, s = math.cos(theta), math.sin(theta)
    f_x, f_y, tau = wrench_L[0], wrench_L[1], wrench_L[2]
    return np.array([0.0, 0.0, tau, c * f_x + s * f_y, -s * f_x + c * f_y, 0.0])  # eq. 13


@dataclasses.dataclass(frozen=True)
class PlanarReference:
    """What the tracker flies: a reference, its feed-forward and release, and the plan behind.

    Attributes:
        state: x_ref(t), 6 x 1: [x, y, theta, v_x, v_y, omega] in the plane of L (theta need
            not be wrapped; a planner's continuous heading is fine).
        wrench_L: Optional feed-forward [F_x, F_y, tau](t), 3 x 1, in L (None: none, as in
            paper 003).
        release_time_s: From this time on the tracker commands no wrench (the chaser is
            released and coasts); None: it tracks to the end.
        path: The planned positions, for the ``planned_path`` output (index 0: none drawn).
        plan: Whatever the planner made it from (read back by its plug-in; not the tracker's).
    """

    state: PiecewisePolynomial
    wrench_L: PiecewisePolynomial | None = None
    release_time_s: float | None = None
    path: PlannedPath = dataclasses.field(default_factory=PlannedPath)
    plan: object = None

    def validate(self) -> None:
        """ValueError on a bad shape or release time."""
        state, wrench = self.state, self.wrench_L
        if (state.rows(), state.cols()) != (6, 1):
            raise ValueError(
                "reference_state must be 6 x 1 [x, y, theta, v_x, v_y, omega], got "
                f"{state.rows()} x {state.cols()}"
            )
        if wrench is not None and (wrench.rows(), wrench.cols()) != (3, 1):
            raise ValueError(
                f"reference_wrench_L must be 3 x 1 [F_x, F_y, tau], got {wrench.rows()} x "
                f"{wrench.cols()}"
            )
        release = self.release_time_s
        if release is not None and not math.isfinite(release):
            raise ValueError(f"release_time_s must be finite or None, got {release!r}")

    def at(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """(x_ref (6), feed-forward [F_x, F_y, tau] in L (3)) at time t (module docstring)."""
        trajectory = self.state
        start, end = trajectory.start_time(), trajectory.end_time()
        x_ref = trajectory.value(t).reshape(6)
        feedforward = np.zeros(3)
        if t < start or t > end:  # before or after the reference: its end pose, at rest
            x_ref[3:6] = 0.0
        elif self.wrench_L is not None:
            wrench = self.wrench_L
            if wrench.start_time() <= t <= wrench.end_time():
                feedforward = wrench.value(t).reshape(3)
        return x_ref, feedforward

    def __deepcopy__(self, memo):
        """Itself: never changed in place (Drake clones abstract state by deep copy)."""
        return self


class PlanarTrackingController(LeafSystem):
    """Sampled planar PD tracker of a reference trajectory (module docstring), outputs held.

    The reference is given, or planned once at start: `plan_at_start(sensed)` is called in
    the initialization event with the bundle read at t = 0 and returns the `PlanarReference`
    (rpod.diagrams.controller_seam, "Planning once at start"); either way it is held in an
    abstract state (`reference(context)`).

    Input port:
        sensed (33): the sensed bundle (rpod.systems.sensed).
    Output ports:
        body_wrench_desired (6): [tau_C; f_C], N m and N: the BODY_WRENCH actuation path.
        planar_wrench_L (3): [F_x, F_y, tau] in L, eq. 12 plus the feed-forward if any.
        tracking_error (6): e of eq. 11, heading wrapped.
        reference_state (6): x_ref at the sample (at rest outside the reference's span).
        planar_state (6): the sensed x = [x, y, theta, v_x, v_y, omega] at the sample.
        planned_path (abstract): the reference's `PlannedPath` (rpod.systems.plan_at_start).
    Discrete state (27): the five vector outputs above, in that order.
    """

    def __init__(
        self,
        config: PlanarTrackingConfig,
        reference_state: PiecewisePolynomial | None = None,
        reference_wrench_L: PiecewisePolynomial | None = None,
        release_time_s: float | None = None,
        *,
        plan_at_start=None,
    ):
        """Builds the tracker.

        Args:
            config: Gains and period (validated here).
            reference_state, reference_wrench_L, release_time_s: a given reference
                (`PlanarReference`'s state, wrench_L and release_time_s).
            plan_at_start: Or a callable (Sensed) -> PlanarReference, called once at t = 0
                (then reference_state must be None).

        Raises:
            ValueError: On a bad config or reference shape, or both or neither reference given.
        """
        super().__init__()
        config.validate()
        if (reference_state is None) == (plan_at_start is None):
            raise ValueError("give either reference_state or plan_at_start")
        given = PlanarReference(
            reference_state if reference_state is not None else _AT_REST,
            reference_wrench_L,
            release_time_s,
        )
        given.validate()
        self._config = config
        self._plan_at_start = plan_at_start

        self._sensed_port = declare_sensed_input(self)
        self._held_index = self.DeclareDiscreteState(27)
        self._reference_index = self.DeclareAbstractState(Value[object](given))
        self._path_index = declare_planned_path_output(self)
        self.DeclarePeriodicUnrestrictedUpdateEvent(config.control_period_s, 0.0, self._update)
        self.DeclareInitializationUnrestrictedUpdateEvent(self._initialize)
        held = {self.discrete_state_ticket(self._held_index)}
        for name, start, size in (
            ("body_wrench_desired", 0, 6),
            ("planar_wrench_L", 6, 3),
            ("tracking_error", 9, 6),
            ("reference_state", 15, 6),
            ("planar_state", 21, 6),
        ):
            self.DeclareVectorOutputPort(
                name,
                size,
                lambda context, output, a=start, b=start + size, i=self._held_index: (
                    output.SetFromVector(context.get_discrete_state(i).get_value()[a:b])
                ),
                held,
            )

    @property
    def config(self) -> PlanarTrackingConfig:
        """The gains and period."""
        return self._config

    def reference(self, context: Context) -> PlanarReference:
        """The reference flown (planned at start, or the one given)."""
        return context.get_abstract_state(self._reference_index).get_value()

    def _initialize(self, context: Context, state: State) -> None:
        """Plans (when asked to), then makes the outputs valid at t = 0."""
        reference = self.reference(context)
        if self._plan_at_start is not None:
            reference = self._plan_at_start(Sensed.from_vector(self._sensed_port.Eval(context)))
            reference.validate()
            state.get_mutable_abstract_state(self._reference_index).set_value(reference)
            state.get_mutable_abstract_state(self._path_index).set_value(reference.path)
        self._hold(context, state, reference)

    def _update(self, context: Context, state: State) -> None:
        self._hold(context, state, self.reference(context))

    def _hold(self, context: Context, state: State, reference: PlanarReference) -> None:
        sensed = Sensed.from_vector(self._sensed_port.Eval(context))
        x = planar_state_from_sensed(sensed)
        x_ref, feedforward = reference.at(context.get_time())
        e = planar_tracking_error(x_ref, x)  # eq. 11
        wrench_L = planar_pd_wrench(e, self._config) + feedforward  # eq. 12 (+ feed-forward)
        release = reference.release_time_s
        if release is not None and context.get_time() >= release - 1e-9:
            wrench_L = np.zeros(3)  # released: the thrusters stay off
        body_wrench = body_wrench_from_planar(wrench_L, x[2])  # eq. 13
        state.get_mutable_discrete_state(self._held_index).set_value(
            np.concatenate([body_wrench, wrench_L, e, x_ref, x])
        )


# The placeholder reference of a tracker that plans at start (replaced before any output).
_AT_REST = PiecewisePolynomial(np.zeros((6, 1)))
