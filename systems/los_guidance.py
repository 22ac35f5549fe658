"""Paper 004's rotating-LOS-corridor guidance (Sec. 7): three regimes and an MPC safety filter.

Owns: `LosGuidanceConfig` and `LosGuidance`, a LeafSystem sampled at 1 Hz (the paper's control
step) that reads the sensed bundle and outputs the chaser's acceleration command in L (the
ideal-acceleration path, paper 004's setting; a box |u_i| <= a_max, eq. 11e), and the regime
laws as plain functions (`regime`, `nominal_command_L`, `brake_command_L`).
Does not own: the corridor (rpod.models.los_corridor), the QP (rpod.planners.los_corridor_mpc),
the prediction model (rpod.planners.los_prediction) or the actuation.

The regimes (paper 004 Sec. 7; r = |p_TC_T|, r_sync = 2 a_max / omega_t^2, eq. 14):
- far approach, r > r_sync: a PD in L on a spiral reference: the corridor axis in L times a
  range rho_ref that shrinks at v_achv = min(a_max t / 2, v_max), so the reference turns with
  the target while it closes in; the commanded velocity in L is capped at v_achv;
- close approach, r <= r_sync: a PD in the body frame T toward the hold point H, its approach
  speed limited to min(v_max, sqrt(a_max d)) at a distance d from H (a stop at a_max / 2);
- hold, within `hold_tolerance_m` of H and slower than `hold_speed_m_s` (left again beyond
  twice the tolerance): the same body-frame PD without the speed limit;
- entry (rpod's, not the paper's; `entry: true`), within r_sync, from when the line of sight is
  outside the corridor's half-angle until it is within `entry_gate_deg` of the axis: the close
  approach's PD toward a reference that goes round the target instead of through it. The
  paper's starts are at rest inside or in front of the corridor; from behind the target the
  close approach's straight line to H runs through it, and the best-effort QP's keep-out held
  the chaser on the keep-out sphere for good (the shoot-out's stalls). The reference R is on the
  line of sight turned toward the axis, at the range it descends to, never below the entry
  sphere (keep-out radius + `entry_margin_m`): R = r_R rotate(u, +y, theta), r_R = max(r_e,
  |p| - l), theta = min(acos(r_ko / min(|p|, r_R)), l / |p|), l = reference_lead_s of travel
  at the speed limit; the first bound keeps the chord from the chaser to R beyond the keep-out
  sphere's tangent plane n . p >= r_ko (n the line of sight: both ends are). The MPC does not
  filter this regime (its corridor cannot be met outside it, and its exact penalty is what
  pulled the chaser at the corridor through the target): the PD flies alone, clipped to the box,
  and no QP is solved.
Every regime cancels the CW terms (the feed-forward of eq. 12) and, in T, the apparent
accelerations of the turning frame, so a body-frame PD is a PD on the body-frame error:

    u_L = R_LT (a_T + 2 w x v_T + w x (w x p_T)) - a_CW(p_L, v_L),   w = w_LT_T,

with v_T = R_TL v_L - w x p_T (eq. 8 written from L). The hold point (the paper leaves it
open) is H = hold_distance_m (default 10 m) along +y_T, on the corridor's axis; v_max (also
open) defaults to 1 m/s.

The MPC (eq. 11, rpod.planners.los_corridor_mpc) filters the regime's command u_nom: it tracks
x_ref in the body frame under the corridor at every predicted step and the input box, its input
weight centred on u_nom, and only u_0 is applied. x_ref is [H, 0] in the hold, the spiral's
point at rest far out, and on the close approach a point reference_lead_s of travel ahead on the
way to H, moving as the PD would move it (the paper tracks H itself: from 100 m its Q = 15-30
against the rate penalty made the MPC rush at twice v_max and brake on the box, and those QPs
took OSQP ten times the iterations). The prediction model is the exact Jacobian of the one-step map of Sec. 4.4
(`prediction: online`), or CW's exact STM and ZOH input matrix carried into T (`cw`), one pair
for the horizon or, for a tumble that changes the body-frame dynamics (`time_varying_model`),
one per predicted step along the predicted attitude. When the QP fails (infeasible, not
converged), the status is kept and the best-effort QP flies: the same QP with the corridor as
an exact L1 penalty (rpod.planners.los_corridor_mpc, `mpc.corridor_penalty`; rpod's, not the
paper's), whose input keeps the predicted excursion as small as the box allows instead of
ignoring the corridor; not in the far regime, beyond r_sync, where no input keeps the chaser in
the corridor (eq. 14) and an input that minimises the excursion over one horizon brakes it in T
and so pushes it out on a spiral (Table 3's outside starts went 1.5-2.4x deeper with it). Only
if that fails too, in the far regime, or with `mpc.corridor_penalty: 0` (the paper's chain) is
the fallback applied: the previous plan's next input while it lasts, else braking to zero
body-frame velocity within the box (eq. 11e). Beyond r_sync no
input can stop the chaser in T (that is what eq. 14 says: the centripetal omega_t^2 r alone
exceeds a_max / 2 r_sync / r), and there the QP is infeasible by construction; so in the far
regime the last fallback is the far approach's own command (clipped to the box), which brings
the chaser in, not the brake, which would push it out on a spiral. `filter: false` flies the
regime's command alone (the comparison of what the filter buys).
"""

import dataclasses
import enum
import math

import numpy as np
from pydrake.common.value import Value
from pydrake.systems.framework import EventStatus

from rpod.models.config import ConfigError, bounded, check_bounds, count, positive
from rpod.models.cw import cw_acceleration
from rpod.models.frames import cross, quaternion_wxyz, rotate_towards, rotation_from_wxyz
from rpod.models.los_corridor import VIOLATION_TOLERANCE_M, LosCorridor, sync_range_m
from rpod.planners.los_corridor_mpc import LosCorridorMpc, LosMpcSettings, MpcStatus
from rpod.planners.los_prediction import BodyFrameStep, TargetState, cw_body_frame_matrices
from rpod.systems.lifetime import LeafSystem, weak_method
from rpod.systems.sensed import Sensed, declare_sensed_input
from rpod.systems.step_timer import StepTimer


class Regime(enum.IntEnum):
    """Paper 004 Sec. 7's regimes (the integer is what the log holds)."""

    FAR = 0
    CLOSE = 1
    HOLD = 2
    ENTRY = 3  # rpod's, not the paper's: round the target into the corridor (`entry`)


class Fallback(enum.IntEnum):
    """What was applied (the integer is what the log holds)."""

    NONE = 0  # the MPC's u_0 (or the regime's command with filter: false)
    PREVIOUS_PLAN = 1  # the previous plan's next input
    BRAKE = 2  # braking to zero body-frame velocity
    NOMINAL = 3  # far out: the far approach's own command (braking is impossible there)
    BEST_EFFORT = 4  # the best-effort QP's u_0 (the corridor as an exact penalty)


# MpcStatus -> the integer the log holds (-1: no solve this step).
MPC_STATUS_CODES = {status: index for index, status in enumerate(MpcStatus)}
PREDICTIONS = ("online", "cw")


@dataclasses.dataclass
class LosGuidanceConfig:
    """Paper 004's guidance (module docstring); defaults: Sec. 6's single-scenario set-up.

    Args:
        control_period_s: the control step (Table 1: 1 s).
        a_max_m_s2: the input bound per axis in L (11e), also in r_sync (eq. 14).
        hold_distance_m: the hold point H along +y_T [m] (the paper leaves it open).
        v_max_m_s: the approach speed limit [m/s] (open in the paper).
        bandwidth_rad_s: the PD's natural frequency.
        damping: the PD's damping ratio.
        hold_tolerance_m: epsilon of the hold regime [m].
        hold_speed_m_s: v_switch of the hold regime [m/s].
        stop_at_violation: end the run at the first control step that finds the chaser
            outside the corridor by more than VIOLATION_TOLERANCE_M (paper 004 Sec. 9 classifies
            such a run infeasible whatever follows: a Monte Carlo campaign need not fly it on).
        fallback_plan_steps: how many steps of the last plan a failed QP may follow (open
            loop) before the last resort (module docstring).
        reference_lead_s: how far ahead of the chaser the close approach's reference point
            runs, in seconds of travel at the speed limit (10 s: the MPC then closes in near
            the limit; half a 40 s horizon made it rush at twice v_max and brake hard).
        half_angle_deg: the corridor's half-angle alpha_c (Table 1: 30 deg).
        faces: the corridor's n_f (Table 1: 8).
        floor_m: the corridor's floor y_min (Table 1: 1 m).
        filter: False applies the regime's command without the MPC.
        prediction: the MPC's model: 'online' (exact Jacobian of the Sec. 4.4 step) or 'cw'.
        time_varying_model: one model per predicted step along the predicted attitude.
        substeps: RK4 steps per control step of the online model.
        skip_hard_qp_outside: while the chaser is further outside the corridor than one
            control step can carry it (|v_T| dt + a_max dt^2 sqrt(3) / 2), do not solve the hard
            QP, which is infeasible there (11d at j = 1 cannot be met), and go on as if it had
            failed (the best-effort QP, else the fallback chain). rpod's, not the paper's
            (False: its chain): the shoot-out's starts, mostly outside the corridor, ran the
            hard QP to OSQP's iteration limit every step (~200 ms a step).
        entry: the entry regime (module docstring; rpod's, not the paper's): within r_sync,
            while the chaser's line of sight is outside the corridor's half-angle (and until it
            is within entry_gate_deg of the axis), go round the target into the corridor
            instead of at the hold point through it. False: the paper's regimes.
        entry_gate_deg: the line of sight's angle from the corridor's axis at which the entry
            regime hands over to the close approach (below the half-angle: inside the corridor).
        entry_margin_m: the entry sphere's radius beyond the keep-out radius [m].
        mpc: horizon, weights and tolerances of eq. 11 (its a_max_m_s2 is a_max_m_s2 above:
            leave it out).

    Bounds (rpod.models.config, checked by `validate()`): the control step in (0, 300] s (the
    scenario bounds the samples of a run); a_max up to 1000 m/s^2 (100 g, the MPC's own bound);
    lengths along the axis (hold point, floor) within the scenario's MAX_RANGE_M, the hold
    tolerance within 1 km; speeds up to the scenario's MAX_RELATIVE_SPEED_M_S, the hold's up to
    100 m/s; the bandwidth in (0, 10] rad/s, the damping ratio in (0, 10]; the lead up to 1e9 s
    (1e9: in effect H itself, the paper's reference, los_monte_carlo_paper.yaml); at most 2000
    fallback steps (the longest plan: mpc.horizon's bound); the half-angle in (0, 90) deg; 3 to
    64 faces (a corridor row per face at every predicted step, and a logged column each:
    measured at 40 steps, a QP takes 0.03 s at 8 faces, 0.08 s at 64, 1.5 s at 360); 1 to 100
    RK4 substeps per step.
    """

    control_period_s: float = positive(1.0, 300.0)
    a_max_m_s2: float = positive(0.10, 1e3)
    hold_distance_m: float = positive(10.0, 1e6)
    v_max_m_s: float = positive(1.0, 1e4)
    bandwidth_rad_s: float = positive(0.2, 10.0)
    damping: float = positive(1.0, 10.0)
    hold_tolerance_m: float = positive(1.0, 1e3)
    hold_speed_m_s: float = positive(0.05, 1e2)
    reference_lead_s: float = positive(10.0, 1e9)
    fallback_plan_steps: int = count(5, 0, 2000)
    stop_at_violation: bool = False
    half_angle_deg: float = bounded(30.0, 0.0, 90.0, low_open=True, high_open=True)
    faces: int = count(8, 3, 64)
    floor_m: float = bounded(1.0, 0.0, 1e6)
    filter: bool = True
    prediction: str = "online"
    time_varying_model: bool = False
    substeps: int = count(2, 1, 100)
    skip_hard_qp_outside: bool = False
    entry: bool = False
    entry_gate_deg: float = bounded(15.0, 0.0, 90.0, low_open=True, high_open=True)
    entry_margin_m: float = bounded(2.0, 0.0, 1e6)
    mpc: LosMpcSettings = dataclasses.field(default_factory=LosMpcSettings)

    def corridor(self) -> LosCorridor:
        """The corridor these fields describe."""
        return LosCorridor(math.radians(self.half_angle_deg), int(self.faces), self.floor_m)

    def mpc_settings(self) -> LosMpcSettings:
        """The MPC's settings with this config's a_max."""
        return dataclasses.replace(self.mpc, a_max_m_s2=self.a_max_m_s2)

    def validate(self) -> None:
        """Raises ConfigError naming the first bad field: its declared bounds (check_bounds,
        `mpc.<field>` included), then the checks that need more than one field."""
        check_bounds(self)
        for name in ("faces", "fallback_plan_steps", "substeps"):
            value = getattr(self, name)
            if int(value) != value:
                raise ConfigError(name, f"must be an integer, got {value}")
        if not self.hold_distance_m > self.floor_m:
            raise ConfigError(
                "hold_distance_m",
                f"must be beyond the floor ({self.floor_m} m), got {self.hold_distance_m}",
            )
        if self.entry and not self.entry_gate_deg < self.half_angle_deg:
            raise ConfigError(
                "entry_gate_deg",
                f"must be below the corridor's half-angle ({self.half_angle_deg} deg), "
                f"got {self.entry_gate_deg}",
            )
        if self.prediction not in PREDICTIONS:
            raise ConfigError(
                "prediction", f"must be one of {PREDICTIONS}, got {self.prediction!r}"
            )
        default_bound = LosMpcSettings().a_max_m_s2
        if self.mpc.a_max_m_s2 not in (default_bound, self.a_max_m_s2):
            raise ConfigError("mpc.a_max_m_s2", "the bound is a_max_m_s2; leave this one out")
        try:
            self.mpc_settings().validate()
        except ConfigError as error:
            raise error.under("mpc") from None


@dataclasses.dataclass(frozen=True)
class BodyFrameView:
    """The relative state seen from the target, and the frames it needs (one sample).

    Attributes:
        p_T, v_T: the chaser in T, its velocity seen in T (eqs. 7-8) [m, m/s].
        p_L, v_L: the chaser in L, its velocity seen in L [m, m/s].
        R_LT: the target's attitude in L.
        w_LT_T: the target's rate relative to L, in T [rad/s].
        n: the orbital rate (w_IL_L's z) [rad/s].
    """

    p_T: np.ndarray
    v_T: np.ndarray
    p_L: np.ndarray
    v_L: np.ndarray
    R_LT: np.ndarray
    w_LT_T: np.ndarray
    n: float

    @classmethod
    def from_sensed(cls, sensed: Sensed) -> "BodyFrameView":
        """From one sample of the sensed bundle."""
        R_IL = rotation_from_wxyz(sensed.q_IL)
        R_IT = rotation_from_wxyz(sensed.q_IT)
        R_LT = R_IL.T @ R_IT
        w_IL_L = np.asarray(sensed.w_IL_L, dtype=float)
        w_LT_T = np.asarray(sensed.w_IT_T, dtype=float) - R_LT.T @ w_IL_L
        p_L = np.array(sensed.p_LC_L, dtype=float)
        v_L = np.array(sensed.v_LC_L, dtype=float)
        p_T = R_LT.T @ p_L
        v_T = R_LT.T @ v_L - cross(w_LT_T, p_T)
        return cls(p_T, v_T, p_L, v_L, R_LT, w_LT_T, float(w_IL_L[2]))

    def command_L(self, a_T: np.ndarray) -> np.ndarray:
        """u_L that gives the body-frame acceleration a_T (module docstring)."""
        w = self.w_LT_T
        apparent = 2.0 * cross(w, self.v_T) + cross(w, cross(w, self.p_T))
        return self.R_LT @ (a_T + apparent) - cw_acceleration(self.n, self.p_L, self.v_L)


def regime(view: BodyFrameView, p_TH_T, r_sync: float, holding: bool, config) -> Regime:
    """The regime of Sec. 7 at this sample; `holding`: the previous sample's was HOLD."""
    distance = float(np.linalg.norm(view.p_T - p_TH_T))
    speed = float(np.linalg.norm(view.v_T))
    if holding and distance <= 2.0 * config.hold_tolerance_m:
        return Regime.HOLD
    if distance <= config.hold_tolerance_m and speed < config.hold_speed_m_s:
        return Regime.HOLD
    return Regime.CLOSE if np.linalg.norm(view.p_T) <= r_sync else Regime.FAR


def _saturate(v: np.ndarray, limit: float) -> np.ndarray:
    norm = float(np.linalg.norm(v))
    return v if norm <= limit else v * (limit / norm)


def nominal_command_L(
    view: BodyFrameView, mode: Regime, p_ref_T: np.ndarray, speed_limit: float, config
) -> np.ndarray:
    """The regime's PD command in L (module docstring), before the MPC and the box.

    FAR: the reference p_ref_T (on the corridor axis at the spiral's range) is tracked in L,
    the correction speed within speed_limit (v_achv). CLOSE: toward p_ref_T = H in T at most
    min(speed_limit, sqrt(a_max d)); ENTRY: the same law toward the entry reference p_ref_T.
    HOLD: toward H without a speed limit.
    """
    w_n, zeta = config.bandwidth_rad_s, config.damping
    error_T = p_ref_T - view.p_T
    if mode is Regime.FAR:
        # In L: the reference turns with the target (v_ref = w x p_ref, seen from L), and the
        # whole commanded velocity is capped at v_achv: beyond r_sync the turning reference
        # cannot be followed, so the law closes in at the cap instead of chasing it round.
        w_L = view.R_LT @ view.w_LT_T
        p_ref_L = view.R_LT @ p_ref_T
        v_ref_L = cross(w_L, p_ref_L)
        v_des = _saturate(v_ref_L + w_n / (2 * zeta) * (p_ref_L - view.p_L), speed_limit)
        return 2 * zeta * w_n * (v_des - view.v_L) - cw_acceleration(view.n, view.p_L, view.v_L)
    v_des_T = w_n / (2 * zeta) * error_T
    if mode in (Regime.CLOSE, Regime.ENTRY):
        distance = float(np.linalg.norm(error_T))
        v_des_T = _saturate(v_des_T, min(speed_limit, math.sqrt(config.a_max_m_s2 * distance)))
    return view.command_L(2 * zeta * w_n * (v_des_T - view.v_T))


def brake_command_L(view: BodyFrameView, dt: float, a_max: float) -> np.ndarray:
    """The fallback's brake: toward zero body-frame velocity within one step, in the box."""
    return np.clip(view.command_L(-view.v_T / dt), -a_max, a_max)


def _target_state(sensed: Sensed) -> TargetState:
    orbit = np.asarray(sensed.target_state_I, dtype=float)
    return TargetState(
        orbit[:3].copy(),
        orbit[3:].copy(),
        rotation_from_wxyz(sensed.q_IT),
        np.array(sensed.w_IT_T, dtype=float),
    )


class LosGuidance(LeafSystem):
    """Paper 004's guidance, sampled (module docstring); outputs held between samples.

    Input port: sensed (33, rpod.systems.sensed).
    Output ports:
        acceleration_command_L (3): the applied command u_0 (or the fallback) [m/s^2].
        nominal_command_L (3): the regime's command before the MPC [m/s^2].
        guidance_status (5): [regime, MPC status code (-1: none), fallback, OSQP iterations,
            solve time s] of the last sample (regime -1 before the first); on a failed step the
            iterations and the time are both QPs' (the hard one and the best-effort one).
        hold_point_L (3): H in L now [m] (from the sensed attitude; no state).
        face_distance_m (n_f + 1): the chaser's signed distance to each corridor plane,
            positive inside (faces, then the floor) [m] (from the sensed state; no state).
    """

    def __init__(
        self,
        config: LosGuidanceConfig,
        inertia_T: np.ndarray,
        gravity: str,
        keep_out_m: float = 0.0,
        R_TK: np.ndarray | None = None,
    ):
        """Args: the config; the target's inertia (the prediction's tumble); the truth's
        gravity ('two_body' | 'two_body_j2'); keep_out_m: the radius about the target that the
        best-effort QP keeps every predicted position beyond, at least the corridor's floor
        (rpod.planners.los_corridor_mpc) [m]; R_TK: the corridor's frame K in T (its +y_K the
        corridor's axis, its origin T's), None for T itself (the paper's +y_T). The guidance
        works in K throughout: the sensed target attitude becomes K's (q_IK = q_IT R_TK,
        w_IK_K = R_KT w_IT_T) and the inertia K's; what this docstring and the module call
        T is K. K is fixed in the body, so the body-frame dynamics keep their form."""
        super().__init__()
        config.validate()
        self.config = config
        self.corridor = config.corridor()
        self.R_TK = None if R_TK is None else np.asarray(R_TK, dtype=float)
        self._keep_out_m = max(keep_out_m, config.floor_m)
        self._p_KH_K = np.array([0.0, config.hold_distance_m, 0.0])
        # H in T itself (what the scene, the metrics and the figures read).
        self.p_TH_T = self._p_KH_K if self.R_TK is None else self.R_TK @ self._p_KH_K
        if self.R_TK is not None:
            inertia_T = self.R_TK.T @ np.asarray(inertia_T, float) @ self.R_TK
        A_c = self.corridor.A_c
        self._row_norms = np.linalg.norm(A_c, axis=1)
        settings = config.mpc_settings()
        self._mpc = LosCorridorMpc(settings, A_c, self.corridor.b_c) if config.filter else None
        self._best_effort = (
            LosCorridorMpc(
                settings,
                A_c,
                self.corridor.b_c,
                soft=True,
                keep_out_m=self._keep_out_m,
            )
            if config.filter and settings.corridor_penalty > 0
            else None
        )
        self._step = BodyFrameStep(
            config.control_period_s, gravity, np.asarray(inertia_T, float), int(config.substeps)
        )
        self._sensed_port = declare_sensed_input(self)
        # Held outputs [command (3), nominal (3), status (5)]; memory [u_prev (3), rho_ref,
        # holding, plan age, entering]; the last successful plan's inputs (abstract).
        self._held = self.DeclareDiscreteState(np.r_[np.zeros(6), -1, -1, 0, 0, 0])
        self._memory = self.DeclareDiscreteState(np.array([0, 0, 0, np.nan, 0, 0, 0], dtype=float))
        self._plan = self.DeclareAbstractState(Value(np.zeros((0, 3))))
        self.step_timer = StepTimer()  # the compute per control step (rpod.systems.step_timer)
        self.DeclarePeriodicUnrestrictedUpdateEvent(
            config.control_period_s, 0.0, self.step_timer.timed(self._update)
        )
        held = {self.discrete_state_ticket(self._held)}
        held_value = weak_method(self._held_value)  # not self in a lambda: lifetime.py
        self.DeclareVectorOutputPort(
            "acceleration_command_L",
            3,
            lambda c, o: o.SetFromVector(held_value(c)[0:3]),
            held,
        )
        self.DeclareVectorOutputPort(
            "nominal_command_L", 3, lambda c, o: o.SetFromVector(held_value(c)[3:6]), held
        )
        self.DeclareVectorOutputPort(
            "guidance_status", 5, lambda c, o: o.SetFromVector(held_value(c)[6:11]), held
        )
        sensed = {self.input_port_ticket(self._sensed_port.get_index())}
        self.DeclareVectorOutputPort("hold_point_L", 3, self._calc_hold_point, sensed)
        self.DeclareVectorOutputPort(
            "face_distance_m", len(self.corridor.b_c), self._calc_face_distance, sensed
        )

    def _held_value(self, context) -> np.ndarray:
        return context.get_discrete_state(self._held).get_value()

    def _sensed(self, context) -> Sensed:
        """The sensed bundle with the target's attitude that of the corridor frame K."""
        sensed = Sensed.from_vector(self._sensed_port.Eval(context))
        if self.R_TK is None:
            return sensed
        return sensed.with_target_attitude(
            quaternion_wxyz(rotation_from_wxyz(sensed.q_IT) @ self.R_TK),
            self.R_TK.T @ np.asarray(sensed.w_IT_T, dtype=float),
        )

    def _view(self, context) -> BodyFrameView:
        return BodyFrameView.from_sensed(self._sensed(context))

    def _calc_hold_point(self, context, output) -> None:
        output.SetFromVector(self._view(context).R_LT @ self._p_KH_K)

    def _calc_face_distance(self, context, output) -> None:
        output.SetFromVector(self.corridor.slack(self._view(context).p_T) / self._row_norms)

    def _model(self, sensed: Sensed, x_T: np.ndarray):
        """(A_d, B_d) of the prediction (module docstring)."""
        target = _target_state(sensed)
        if self.config.prediction == "cw":
            n = float(sensed.w_IL_L[2])
            dt = self.config.control_period_s
            return cw_body_frame_matrices(n, dt, target, self._step.target_next(target))
        if self.config.time_varying_model:
            return self._step.horizon(target, x_T, self._mpc.N)
        return self._step.jacobian(target, x_T)

    def _approach_reference(self, view: BodyFrameView, speed_limit: float) -> np.ndarray:
        """The close approach's x_ref in T: a point on the way to H at most reference_lead_s of
        travel ahead, moving toward H as the PD would move it (module docstring)."""
        config = self.config
        error = self._p_KH_K - view.p_T
        distance = float(np.linalg.norm(error))
        if distance < 1e-9:
            return np.concatenate([self._p_KH_K, np.zeros(3)])
        speed = min(speed_limit, config.v_max_m_s, math.sqrt(config.a_max_m_s2 * distance))
        ahead = min(distance, speed * config.reference_lead_s)
        direction = error / distance
        # The reference point moves as the PD would move it there: at the speed limit far
        # from H, slowing to rest as it reaches H (no velocity asked for at H itself).
        gain = config.bandwidth_rad_s / (2 * config.damping)
        v_ref = _saturate(gain * (distance - ahead) * direction, speed)
        return np.concatenate([view.p_T + ahead * direction, v_ref])

    def _entering(self, view: BodyFrameView, entering: bool) -> bool:
        """Whether the entry regime flies this step (module docstring): the line of sight
        beyond the corridor's half-angle, or beyond the gate while already entering."""
        r = float(np.linalg.norm(view.p_T))
        off_axis = math.degrees(math.acos(min(max(view.p_T[1] / max(r, 1e-9), -1.0), 1.0)))
        gate = self.config.entry_gate_deg if entering else self.config.half_angle_deg
        return off_axis > gate

    def _entry_reference(self, view: BodyFrameView, speed_limit: float) -> np.ndarray:
        """The entry regime's reference point in T (module docstring), at rest in T."""
        config = self.config
        r = max(float(np.linalg.norm(view.p_T)), 1e-9)
        lead = min(speed_limit, config.v_max_m_s) * config.reference_lead_s
        r_entry = self._keep_out_m + config.entry_margin_m
        r_R = max(r_entry, r - lead)
        r_min = min(r, r_R)
        clear = math.acos(self._keep_out_m / r_min) if r_min > self._keep_out_m else 0.0
        u = rotate_towards(view.p_T / r, np.array([0.0, 1.0, 0.0]), min(clear, lead / r))
        return r_R * u

    def _beyond_one_step(self, view: BodyFrameView) -> bool:
        """Whether the chaser is further outside the corridor than one control step can carry
        it (the config's skip_hard_qp_outside)."""
        dt, a_max = self.config.control_period_s, self.config.a_max_m_s2
        outside = -float(np.min(self.corridor.slack(view.p_T) / self._row_norms))
        reach = float(np.linalg.norm(view.v_T)) * dt + 0.5 * math.sqrt(3.0) * a_max * dt * dt
        return outside > reach

    def _last_resort(self, view: BodyFrameView, mode: Regime, u_nom) -> tuple:
        """(command, Fallback) when there is no plan to follow (module docstring): the brake
        when the box can give it, else the regime's own command, clipped."""
        a_max = self.config.a_max_m_s2
        if mode is not Regime.FAR:
            brake = view.command_L(-view.v_T / self.config.control_period_s)
            if np.all(np.abs(brake) <= a_max):
                return brake, Fallback.BRAKE
        return np.clip(u_nom, -a_max, a_max), Fallback.NOMINAL

    def _update(self, context, state) -> None:
        config, t = self.config, context.get_time()
        sensed = self._sensed(context)
        view = BodyFrameView.from_sensed(sensed)
        memory = context.get_discrete_state(self._memory).get_value().copy()
        u_prev, rho_ref, holding, plan_age = memory[0:3], memory[3], memory[4] > 0, memory[5]
        omega = float(np.linalg.norm(sensed.w_IT_T))  # the tumble rate omega_t (eq. 14)
        r_sync = sync_range_m(config.a_max_m_s2, omega) if omega > 0 else math.inf
        mode = regime(view, self._p_KH_K, r_sync, holding, config)
        if config.entry and mode is Regime.CLOSE and self._entering(view, memory[6] > 0):
            mode = Regime.ENTRY

        # The reference: H, or far out the spiral's point on the corridor axis.
        v_achv = min(config.a_max_m_s2 * t / 2.0, config.v_max_m_s)
        if not np.isfinite(rho_ref):
            rho_ref = float(np.linalg.norm(view.p_T))
        v_ref_T = np.zeros(3)
        speed_limit = max(v_achv, 1e-3)
        if mode is Regime.FAR:
            rho_ref = max(rho_ref - v_achv * config.control_period_s, config.hold_distance_m)
            p_ref_T = np.array([0.0, rho_ref, 0.0])
            x_ref = np.concatenate([p_ref_T, v_ref_T])
        elif mode is Regime.ENTRY:
            p_ref_T = self._entry_reference(view, speed_limit)
        else:
            p_ref_T = self._p_KH_K
            x_ref = np.concatenate([p_ref_T, v_ref_T])
            if mode is Regime.CLOSE:
                x_ref = self._approach_reference(view, speed_limit)
        u_nom = nominal_command_L(view, mode, p_ref_T, speed_limit, config)

        status_code, iterations, solve_time, fallback = -1, 0, 0.0, Fallback.NONE
        plan = context.get_abstract_state(self._plan).get_value()
        if self._mpc is None or mode is Regime.ENTRY:
            command = np.clip(u_nom, -config.a_max_m_s2, config.a_max_m_s2)
            if mode is Regime.ENTRY:  # no plan outlives the way round
                plan, plan_age = np.zeros((0, 3)), 0
        else:
            x_T = np.concatenate([view.p_T, view.v_T])
            A_d, B_d = self._model(sensed, x_T)
            result = None
            if not (config.skip_hard_qp_outside and self._beyond_one_step(view)):
                result = self._mpc.solve(x_T, x_ref, u_prev, A_d, B_d, u_nom=u_nom)
                status_code = MPC_STATUS_CODES[result.status]
                iterations, solve_time = result.iterations, result.solve_time_s
            solved = result is not None and result.solved
            best = None
            if not solved and self._best_effort is not None and mode is not Regime.FAR:
                best = self._best_effort.solve(x_T, x_ref, u_prev, A_d, B_d, u_nom=u_nom)
                iterations += best.iterations
                solve_time += best.solve_time_s
            if solved:
                command, plan, plan_age = result.u0, result.u, 0
            elif best is not None and best.solved:
                command, plan, plan_age = best.u0, best.u, 0
                fallback = Fallback.BEST_EFFORT
            elif plan_age + 1 < min(len(plan), config.fallback_plan_steps + 1):
                plan_age += 1
                command, fallback = plan[int(plan_age)], Fallback.PREVIOUS_PLAN
            else:
                command, fallback = self._last_resort(view, mode, u_nom)
        command = np.asarray(command, dtype=float)
        state.get_mutable_discrete_state(self._held).set_value(
            np.concatenate(
                [command, u_nom, [int(mode), status_code, int(fallback), iterations, solve_time]]
            )
        )
        state.get_mutable_discrete_state(self._memory).set_value(
            np.concatenate(
                [command, [rho_ref, float(mode is Regime.HOLD), plan_age, mode is Regime.ENTRY]]
            )
        )
        state.get_mutable_abstract_state(self._plan).set_value(plan)
        if config.stop_at_violation:
            outside = -float(np.min(self.corridor.slack(view.p_T) / self._row_norms))
            if outside > VIOLATION_TOLERANCE_M:
                return EventStatus.ReachedTermination(
                    self, f"corridor violated by {outside:.3f} m at t = {t:.1f} s"
                )
        return EventStatus.Succeeded()
