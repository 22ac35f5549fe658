"""Soft-capture controller: plan with paper 000's planner, track the plan, replan on a schedule.

Owns: ``SoftCaptureControllerConfig`` (the planner's Table I config plus the closed-loop
settings) and ``SoftCaptureController``, a sampled (10 Hz by default) system that turns the
measured relative state and both attitudes into a desired chaser body wrench [tau_C; f_C], and
keeps the record of every plan it asked for. Does not own: the planner (``rpod.planners``),
allocation (allocator.py), pulse modulation (pwm.py), or drawing the plan (scene.py).

Measurements. There is no estimator yet: the controller reads the true relative state, the true
target attitude and rate and the true chaser attitude (the same truth signals the hold-point
controller reads). The target prediction integrates the torque-free Euler equations from the
measured target state with the target inertia the controller is given (the truth's).

Planning (paper 000 Fig. 4). At the first sample (t0, through the initialization event) the
controller plans from the measured state with the full horizon search of ``SoftCapturePlanner``
and the chaser's measured attitude as the pointing law's start. Planning takes no simulated time
(the computation delay is not modelled; the wall time of every solve is recorded). The plan is
made with the terminal tolerances eps_p, eps_v (13, 14) scaled by ``plan_tolerance_fraction``:
the fuel-optimal plan lands on the boundary of its terminal ball, so planning to the capture
tolerances themselves would leave no margin for tracking error. For the same reason the planner
sees both hulls scaled about their origins by ``1 + collision_margin`` (b -> (1 + m) b): the
scaling metric then scales exactly, alpha_true = (1 + m) alpha_planned, so the hard test
alpha_planned > 1 (Sec. V-C) guarantees alpha_true > 1 + m at every knot. The paper's test
alone (alpha_true > 1 at the knots) leaves no margin at all: plans that pass it with
min alpha ~1.0002 exist, and between knots (1 s apart) a target tumbling at a few deg/s turns
its corners by decimetres, so flown on truth such a plan can touch (found in closed-loop runs
of random Sec. VI-B starts; the margin is the fix).

Plan check. Every plan the planner calls a success is re-evaluated by the independent checker
(``rpod.planners.plan_check.check_plan``: expm dynamics, the nonlinear constraints, its own LP for
alpha) against exactly what it was planned with -- the planning config (scaled eps_p, eps_v), the
scaled hulls the planner holds, the prediction and the measured start -- with the checker's
default tolerances; alpha against the true hulls is (1 + collision_margin) times the checker's
(the hulls are scaled about their origins, so alpha scales exactly). A plan the checker
rejects is not accepted: the call counts as failed with status "check_failed" and a reason naming
the violations, worst first, so the same fallback as for any failed call applies (keep the
previous plan on a replan; zero thrust, and a retry if configured, otherwise) and a warning is
logged. Plans the planner did not call a success are not checked (they are never flown). The
check's wall time is recorded apart from the planning's: ~0.13 s at N = 50 (measured on one
core), nearly all of it N HiGHS LPs through scipy's ``linprog`` at ~1.3 ms each, a few times
the planning's own time; like the planning, it takes no simulated time.

Replanning (shrinking horizon). Every ``replan_period_s`` (an integer number of knots) after a
plan's start, while at least ``min_replan_knots`` knots remain, the controller replans from the
measured state with the *same final time*: a single horizon N_rem = (t_f - t) / dt + 1, no
search. This rejects what the plan's CW model does not see (two-body + J2 truth, PWM quantisation,
attitude coupling) without letting the capture time slip. A replan that fails keeps the previous
plan (still feasible for the nominal model, and the feedback keeps the chaser near it); the
failure is recorded. Near the end (fewer than ``min_replan_knots`` knots left) the plan is only
tracked: a replan there could not correct much, and the docking-cone knots (11) are the last few.

Tracking (between samples the output is held). Within step k of the active plan the reference is
the plan's own CW motion under its zero-order-hold force, exactly (paper 000 eq. (5) with
``tau = t - t_k`` in place of dt): ``x_ref = Phi(tau) x_k + B_d(tau) u_k / m``. The commanded
acceleration in L is the planned feed-forward plus a PD on the error,

    a_L = u_k / m + w_n^2 (p_ref - p) + 2 zeta w_n (v_ref - v),

and the force is rotated into the chaser body frame with the measured attitudes,
``f_C = m R_CL a_L = m R_IC^T R_IL a_L`` (paper 003 eq. 13).

After the plan's final knot the controller holds the capture pose: the reference is the chaser
centre of mass at p* = R_LT (D_t - R_y(pi) D_c) (13), moving with the target (its velocity (14)
and acceleration as a point fixed in T), with the CW terms cancelled; this keeps the capture
points together until the (unmodelled) capture mechanism would close.

Attitude (the pointing law of paper 000 Sec. IV, from the measured position). The desired
attitude turns the capture axis D_c onto the line of sight -p/|p| by the minimum-norm increment
from the previous sample's desired attitude (no roll about the line of sight, as in the plan); at
t0 it starts from the measured attitude. Its rate is the line-of-sight rate, w_LCdes = p x v /
|p|^2, plus the LVLH rate. A PD law with gyroscopic compensation and the reference's angular
acceleration as feed-forward drives the chaser toward it:

    tau_C = J (a_des_C + w_a^2 e_C + 2 zeta_a w_a (w_des_C - w_IC_C)) + w_IC_C x J w_IC_C,

with e_C the rotation vector of R_IC^T R_ICdes and a_des_C the inertial derivative of the
desired rate: d/dt (p x v / |p|^2) = p x a / |p|^2 - 2 (p . v / |p|^2) w_LCdes, plus
w_IL x w_LCdes, where a is the reference's relative acceleration in L (its thrust acceleration
a_ff plus the CW terms at the measured state). Why the feed-forward (``attitude_feedforward``):
at the end of an approach to a fast tumble the line of sight spins up to the target's rate in
a few seconds (sample 61 of the soft_capture_250 campaign: 1 to 8.8 deg/s over the last 10 s,
~90 N m about x_C), and the PD alone lags it (2.5 deg of pointing error at the final knot, the
2.7 m capture lever turning that into ~0.1 m and ~0.01 m/s at the capture point: the capture
points closed at 0.034 m/s > eps_v and the run was not captured). The torque is needed while
the planned force, at the planner's 100 N, uses the same thrusters (rcs_cube_12: the y
thrusters give both f_y and tau_x), so a lag that builds up there cannot be caught up. With the
feed-forward the torque comes as the line of sight turns, and the pointing error at that final
knot is 0.8 deg (capture at 59 s, 0.018 m/s).

Fallback (DESIGN.md: planners never raise, controllers fall back to a safe action). When no plan
succeeded (an infeasible start, a tumble above min(omega_max, v_max / |D_c + D_t|), a solver
failure), the controller commands zero wrench: the scenario starts the chaser on a passively safe
(bounded, drift-free, eq. (6)) relative orbit, on which zero thrust is the safe action -- the
chaser keeps circling the target without approaching it (to the accuracy of the CW model: J2 and
the target's eccentricity make the ellipse drift slowly, over many orbits). The attitude is left
free too (zero torque), so that no thruster fires at all. The status is on the ``planner_status``
and ``controller_mode`` ports and in the plan record; with ``retry_period_s`` > 0 the full search
is tried again at that period.
"""

import dataclasses
import logging
import math

import numpy as np
from pydrake.common.value import Value
from pydrake.math import RotationMatrix

from rpod.models.config import ConfigError, bounded, check_bounds, count, positive
from rpod.models.cw import cw_acceleration, cw_state_transition, cw_zoh_input
from rpod.models.docking import capture_reach_T
from rpod.models.frames import cross, rotation_from_wxyz
from rpod.models.rigid_body import angular_acceleration, attitude_pd_torque
from rpod.models.shapes import (
    ConvexPolytope,
    soft_capture_chaser_hull,
    soft_capture_target_hull,
)
from rpod.planners.checked_plan import CheckedPlan, predict_plan_check
from rpod.planners.pointing import min_rotation
from rpod.planners.soft_capture import PlanStatus, SoftCaptureConfig, SoftCapturePlanner
from rpod.systems.lifetime import LeafSystem
from rpod.systems.plan_at_start import PlannedPath, declare_planned_path_output
from rpod.systems.sensed import Sensed, declare_sensed_input
from rpod.systems.step_timer import StepTimer

# Controller modes (the ``controller_mode`` output, logged; MODES[code] is the name).
MODES = ("tracking", "capture_hold", "fallback")
MODE_TRACKING, MODE_CAPTURE_HOLD, MODE_FALLBACK = range(3)

# Planner statuses (the ``planner_status`` output holds the code of the last planner call's
# status; PLANNER_STATUSES[code] is the name). "none": no plan asked yet; "prediction_failed":
# the target prediction raised on the measured target state (e.g. non-finite); "check_failed":
# the planner returned success but the independent plan checker rejected the plan (module
# docstring, "Plan check"); "other": a status not in this list.
# Log codes of the planner status: "none" (no call yet), the planner's PlanStatus in its fixed
# order, and "other" (anything else).
PLANNER_STATUSES = ("none", *(status.value for status in PlanStatus), "other")
_logger = logging.getLogger(__name__)
# Times within this of a knot or a replan instant count as on it (the periodic event times are
# k * period in floating point, e.g. 10.000000000000002).
_TIME_TOLERANCE_S = 1e-6


def planner_status_code(status: str) -> int:
    """The ``planner_status`` code of a planner status string."""
    return (
        PLANNER_STATUSES.index(status) if status in PLANNER_STATUSES else len(PLANNER_STATUSES) - 1
    )


@dataclasses.dataclass
class SoftCaptureControllerConfig:
    """The soft-capture planner's problem data and the closed-loop settings.

    Args:
        planner: Paper 000's problem data (Table I defaults) and its horizon search.
        control_period_s: sample period of the law (the PWM period downstream); the knot
            spacing planner.dt_s must be an integer number of periods.
        plan_tolerance_fraction: the plans are made with eps_p and eps_v scaled by this, in
            (0, 1]; the capture criterion uses the unscaled ones (module docstring).
        collision_margin: the planner sees both hulls scaled by 1 + this about their origins,
            so every planned knot keeps the true alpha above 1 + this (module docstring); >= 0.
        replan_period_s: shrinking-horizon replanning period, an integer number of knots
            (0: never replan).
        min_replan_knots: no replan when fewer knots than this remain to the final one.
        retry_period_s: after a failed plan, retry the full search at this period (0: never;
            the chaser then stays on its passively safe orbit).
        translation_bandwidth_rad_s: natural frequency w_n of the position feedback.
        translation_damping: damping ratio zeta of the position feedback.
        attitude_bandwidth_rad_s: natural frequency w_a of the attitude loop.
        attitude_damping: damping ratio zeta_a of the attitude loop.
        attitude_feedforward: add the pointing reference's angular acceleration (from the
            reference's relative acceleration) to the attitude law (module docstring); False
            gives the PD with gyroscopic compensation alone.

    Bounds (rpod.models.config, checked by `validate()`): the period in (0, 200] s (it divides
    planner.dt_s, at most 200 s); the tolerance fraction in (0, 1]; the margin in [0, 100]
    (hulls at most 101 times their size, as the planner's alpha_min); the replanning and retry
    periods (0: never) up to the scenario's MAX_DURATION_S; min_replan_knots in [2, 5000] (the
    planner's longest horizon); bandwidths in (0, 10] rad/s and damping ratios in (0, 10].
    """

    planner: SoftCaptureConfig = dataclasses.field(default_factory=SoftCaptureConfig)
    control_period_s: float = positive(0.1, 200.0)
    plan_tolerance_fraction: float = positive(0.5, 1.0)
    collision_margin: float = bounded(0.1, 0.0, 100.0)
    replan_period_s: float = bounded(10.0, 0.0, 1e6)
    min_replan_knots: int = count(10, 2, 5000)
    retry_period_s: float = bounded(0.0, 0.0, 1e6)
    translation_bandwidth_rad_s: float = positive(0.4, 10.0)
    translation_damping: float = positive(1.0, 10.0)
    attitude_bandwidth_rad_s: float = positive(0.8, 10.0)
    attitude_damping: float = positive(1.0, 10.0)
    attitude_feedforward: bool = True

    def planning_config(self) -> SoftCaptureConfig:
        """The planner config the controller plans with: eps_p, eps_v scaled (docstring)."""
        return dataclasses.replace(
            self.planner,
            capture_position_tol_m=self.planner.capture_position_tol_m
            * self.plan_tolerance_fraction,
            capture_speed_tol_m_s=self.planner.capture_speed_tol_m_s * self.plan_tolerance_fraction,
        )

    def planning_hulls(self, chaser_hull, target_hull):
        """The (chaser, target) hulls the controller plans with: scaled by 1 + collision_margin."""
        scale = 1.0 + self.collision_margin
        return tuple(
            ConvexPolytope(A=hull.A, b=scale * hull.b, vertices=scale * hull.vertices)
            for hull in (chaser_hull, target_hull)
        )

    def validate(self) -> None:
        """Raises ConfigError naming the first bad field (the planner's as 'planner.<field>'):
        the declared bounds (check_bounds, the planner's included), the planner's own checks,
        then the checks that need more than one field."""
        check_bounds(self)
        try:
            self.planner.validate()
        except ConfigError as error:
            raise error.under("planner") from None
        if self.attitude_feedforward not in (True, False):
            raise ConfigError(
                "attitude_feedforward", f"must be true or false, got {self.attitude_feedforward!r}"
            )
        dt = self.planner.dt_s
        if not _is_multiple(dt, self.control_period_s):
            raise ConfigError(
                "control_period_s",
                f"planner.dt_s = {dt} must be an integer number of control periods, got "
                f"{self.control_period_s}",
            )
        if self.replan_period_s > 0.0 and not _is_multiple(self.replan_period_s, dt):
            raise ConfigError(
                "replan_period_s",
                f"must be an integer number of knots (planner.dt_s = {dt}), got "
                f"{self.replan_period_s}",
            )
        if self.retry_period_s > 0.0 and not _is_multiple(
            self.retry_period_s, self.control_period_s
        ):
            raise ConfigError("retry_period_s", "must be an integer number of control periods")
        if int(self.min_replan_knots) != self.min_replan_knots:
            raise ConfigError(
                "min_replan_knots", f"must be an integer >= 2, got {self.min_replan_knots}"
            )


def _is_multiple(value: float, period: float) -> bool:
    ratio = value / period
    if not math.isfinite(ratio):  # a period of 1e-320: round() would overflow
        return False
    return ratio >= 1.0 - 1e-9 and abs(ratio - round(ratio)) < 1e-9 * max(1.0, ratio)


def plan_from_sensed(
    planner: SoftCapturePlanner,
    target_inertia,
    sensed: Sensed,
    t0_s: float = 0.0,
    *,
    horizons: list[int] | None = None,
    check_unsuccessful: bool = False,
) -> CheckedPlan:
    """Predicts, plans and checks from a sensed bundle (rpod.planners.checked_plan): the call
    the controller makes at every plan, and `rpod plan` on the bundle at t = 0
    (rpod.diagrams.controller_seam, "Planning once at start").

    Args:
        planner: the planner (its config and hulls).
        target_inertia: (3, 3) in T [kg m^2], for the tumble's prediction.
        sensed: what the controller reads at t0_s (rpod.systems.sensed).
        t0_s: the plan's start [s].
        horizons, check_unsuccessful: as `predict_plan_check`'s.
    """
    R_IL = rotation_from_wxyz(sensed.q_IL)
    R_LT = R_IL.T @ rotation_from_wxyz(sensed.q_IT)
    return predict_plan_check(
        planner,
        sensed.relative_state_L,
        RotationMatrix(R_LT).ToQuaternion().wxyz(),
        sensed.w_IT_T,
        target_inertia,
        t0_s=t0_s,
        R_LC0=R_IL.T @ rotation_from_wxyz(sensed.q_IC),
        horizons=horizons,
        check_unsuccessful=check_unsuccessful,
    )


@dataclasses.dataclass(frozen=True)
class _ActivePlan:
    """The plan being tracked: knots from t0_s at the planner's dt."""

    index: int
    t0_s: float
    x: np.ndarray  # (N, 6)
    u: np.ndarray  # (N-1, 3) force in L [N]
    next_replan_s: float

    @property
    def N(self) -> int:
        return len(self.x)


@dataclasses.dataclass(frozen=True)
class _Memory:
    """Everything the controller remembers between samples (one abstract state, replaced whole)."""

    plan: _ActivePlan | None = None
    attempted: bool = False
    next_retry_s: float = math.inf
    R_LC_des: np.ndarray | None = None
    records: tuple = ()  # one dict per planner call, in order (``plan_records``)

    def __deepcopy__(self, memo):
        """Itself: Drake clones abstract state by deep copy (several times per control period),
        and a _Memory is never changed in place (frozen, its arrays and records never written
        after creation; every update replaces it whole), so clones can share it. Copying the
        growing plan records made the bundled 70 s run 1.25x slower (3.8 s against 3.0 s)."""
        return self


class SoftCaptureController(LeafSystem):
    """Sampled soft-capture law (module docstring), output held between samples.

    Input port: sensed (33, the sensed bundle of rpod.systems.sensed).
    Output ports: body_wrench_desired (6, [tau_C; f_C]), reference_L (3, the planned position
        at the sample; NaN in fallback), force_feedforward_L (3, the planned force in L [N]),
        controller_mode (1, a ``MODES`` code), planner_status (1, a ``PLANNER_STATUSES`` code of
        the last planner call), planned_path (abstract ``PlannedPath``).

    Args:
        config: Planner data and closed-loop settings; validated here.
        chaser_inertia: Chaser inertia (3, 3) in C [kg m^2] (the attitude law's model).
        target_inertia: Target inertia (3, 3) in T [kg m^2] (the target prediction's model).
        chaser_hull: True chaser ``ConvexPolytope`` in C (default: paper 000's); the planner
            sees it scaled by 1 + collision_margin.
        target_hull: True target ``ConvexPolytope`` in T (default: paper 000's); likewise.
    """

    def __init__(
        self,
        config: SoftCaptureControllerConfig,
        chaser_inertia: np.ndarray,
        target_inertia: np.ndarray,
        chaser_hull=None,
        target_hull=None,
    ):
        super().__init__()
        config.validate()
        self._config = config
        self._planning = config.planning_config()
        chaser_hull = chaser_hull if chaser_hull is not None else soft_capture_chaser_hull()
        target_hull = target_hull if target_hull is not None else soft_capture_target_hull()
        self._planner = SoftCapturePlanner(
            self._planning, *config.planning_hulls(chaser_hull, target_hull)
        )
        self._J_C = np.asarray(chaser_inertia, dtype=float)
        self._J_T = np.asarray(target_inertia, dtype=float)
        self._mass = float(config.planner.chaser_mass_kg)
        self._n = float(self._planning.mean_motion)
        self._dt = float(self._planning.dt_s)
        self._D_c = np.asarray(self._planning.p_CDc_C, dtype=float)
        self._c_C = self._D_c / np.linalg.norm(self._D_c)
        self._reach_T = capture_reach_T(self._D_c, self._planning.p_TDt_T)

        self._sensed_port = declare_sensed_input(self)

        # Held outputs: [wrench (6), reference (3), feed-forward (3), mode (1), status (1)].
        self._held = self.DeclareDiscreteState(14)
        self._memory = self.DeclareAbstractState(Value[object](_Memory()))
        self._path = declare_planned_path_output(self)  # the active plan's knots
        self.step_timer = StepTimer()  # the compute per control step (rpod.systems.step_timer)
        update = self.step_timer.timed(self._update)
        self.DeclarePeriodicUnrestrictedUpdateEvent(config.control_period_s, 0.0, update)
        self.DeclareInitializationUnrestrictedUpdateEvent(update)  # plan at t0
        xd = {self.discrete_state_ticket(self._held)}
        for name, start, size in (
            ("body_wrench_desired", 0, 6),
            ("reference_L", 6, 3),
            ("force_feedforward_L", 9, 3),
            ("controller_mode", 12, 1),
            ("planner_status", 13, 1),
        ):
            self.DeclareVectorOutputPort(
                name,
                size,
                lambda context, output, a=start, b=start + size, i=self._held: output.SetFromVector(
                    context.get_discrete_state(i).get_value()[a:b]
                ),
                xd,
            )

    @property
    def config(self) -> SoftCaptureControllerConfig:
        """The controller's config."""
        return self._config

    @property
    def planner(self) -> SoftCapturePlanner:
        """The planner it calls (its programs are cached per horizon length)."""
        return self._planner

    def plan_records(self, context) -> list[dict]:
        """One dict per planner call so far, in order (for the run's summary).

        Keys: ``t_s``, ``kind`` ("initial", "replan", "retry"), ``status``, ``reason``, ``N``,
        ``scp_iterations``, ``solve_time_s`` (each SOCP solve at the returned N),
        ``total_solve_time_s`` (all solves of the call), ``wall_time_s`` (prediction + planning),
        ``min_alpha`` (the planner's, against the scaled hulls), ``min_alpha_true`` (the true
        hulls' alpha at that knot, (1 + collision_margin) min_alpha), ``fuel_l1_N``,
        ``accepted`` (the plan became the active one), ``index`` (the ``PlannedPath`` index when
        accepted, else 0), and when accepted ``x`` (the knots' states [p_LC_L, v_LC_L], N lists
        of 6) and ``u`` (the forces in L, N-1 lists of 3).

        The independent plan check (module docstring), for every plan the planner called a
        success: ``check_passed`` (bool; None when the call was not checked),
        ``check_violations`` (name -> worst value of each check above its tolerance; empty when
        passed), ``check_min_alpha`` (the checker's LP against the planning hulls),
        ``check_min_alpha_true`` ((1 + collision_margin) check_min_alpha: the true hulls'),
        ``check_dynamics_residual`` (m and m/s) and ``check_time_s`` (wall time of the check);
        NaN / 0 when not checked.
        """
        return [dict(r) for r in context.get_abstract_state(self._memory).get_value().records]

    # ------------------------------------------------------------------------------------------
    # Planning

    def _predict_and_plan(self, t, sensed: Sensed, horizons):
        """(plan or None, record fields) -- never raises on a bad measurement.

        The one predict-plan-check path (`plan_from_sensed`), as `rpod plan` uses it: a plan
        the planner calls a success is checked (module docstring, "Plan check"); when the check
        rejects it, the fields say status "check_failed" and name the violations.
        """
        result = plan_from_sensed(self._planner, self._J_T, sensed, t, horizons=horizons)
        plan = result.plan
        fields = {
            "status": result.status.value,
            "reason": result.reason,
            "wall_time_s": result.wall_time_s,
        }
        if plan is None:
            return None, fields
        fields.update(
            N=int(plan.N),
            scp_iterations=int(plan.scp_iterations),
            solve_time_s=[float(s) for s in plan.solve_time_s],
            step_time_s=[float(s) for s in plan.step_time_s],
            total_solve_time_s=float(plan.total_solve_time_s),
            min_alpha=float(plan.min_alpha),
            min_alpha_true=float(plan.min_alpha) * (1.0 + self._config.collision_margin),
            fuel_l1_N=float(plan.fuel_l1_N),
        )
        report = result.report
        if report is not None:  # against what it was planned with: config, hulls, prediction
            fields.update(
                check_passed=report.passed(),
                check_violations=result.worst_violations(),
                check_min_alpha=float(report.min_alpha),
                # Uniform scaling about the origins: alpha_true = (1 + margin) alpha exactly.
                check_min_alpha_true=float(report.min_alpha)
                * (1.0 + self._config.collision_margin),
                check_dynamics_residual=float(report.dynamics_residual),
                check_time_s=result.check_time_s,
            )
        return plan, fields

    def _plan(self, memory: _Memory, t, kind, sensed: Sensed) -> _Memory:
        """Calls the planner; returns the memory with the record and, on success, the plan.

        Accepted only when the planner succeeded and the plan check passed; a rejected plan is
        handled as any failed call (module docstring, "Plan check").
        """
        cfg = self._config
        horizons = None
        if kind == "replan":
            active = memory.plan
            t_final = active.t0_s + (active.N - 1) * self._dt
            horizons = [round((t_final - t) / self._dt) + 1]  # same final time
        plan, fields = self._predict_and_plan(t, sensed, horizons)
        accepted = plan is not None and plan.success and fields["check_passed"]
        record = {
            "t_s": float(t),
            "kind": kind,
            "N": 0,
            "scp_iterations": 0,
            "solve_time_s": [],
            "total_solve_time_s": 0.0,
            "min_alpha": float("nan"),
            "min_alpha_true": float("nan"),
            "fuel_l1_N": 0.0,
            "check_passed": None,
            "check_violations": {},
            "check_min_alpha": float("nan"),
            "check_min_alpha_true": float("nan"),
            "check_dynamics_residual": float("nan"),
            "check_time_s": 0.0,
            **fields,
            "accepted": accepted,
            "index": 0,
            "x": [],
            "u": [],
        }
        new_plan = memory.plan
        next_retry = memory.next_retry_s
        if accepted:
            index = 1 + sum(1 for r in memory.records if r["accepted"])
            next_replan = t + cfg.replan_period_s if cfg.replan_period_s > 0 else math.inf
            new_plan = _ActivePlan(index, float(t), plan.x.copy(), plan.u.copy(), next_replan)
            record.update(index=index, x=plan.x.tolist(), u=plan.u.tolist())
            next_retry = math.inf
        elif kind == "replan":
            new_plan = dataclasses.replace(memory.plan, next_replan_s=t + cfg.replan_period_s)
            level = logging.WARNING if record["status"] == "check_failed" else logging.INFO
            _logger.log(
                level,
                "soft capture: replan at t = %.1f s failed (%s: %s); keeping the plan",
                t,
                record["status"],
                record["reason"],
            )
        else:
            next_retry = t + cfg.retry_period_s if cfg.retry_period_s > 0 else math.inf
            _logger.warning(
                "soft capture: no plan at t = %.1f s (%s: %s); zero thrust on the "
                "passively safe orbit",
                t,
                record["status"],
                record["reason"],
            )
        return dataclasses.replace(
            memory,
            plan=new_plan,
            attempted=True,
            next_retry_s=next_retry,
            records=memory.records + (record,),
        )

    # ------------------------------------------------------------------------------------------
    # The law

    def _update(self, context, state):
        cfg = self._config
        t = context.get_time()
        sensed = Sensed.from_vector(self._sensed_port.Eval(context))
        relative = sensed.relative_state_L
        p, v = relative[0:3], relative[3:6]
        R_IL = rotation_from_wxyz(sensed.q_IL)
        w_IL_L = sensed.w_IL_L
        target = sensed.target_attitude
        chaser = sensed.chaser_attitude
        R_LT = R_IL.T @ rotation_from_wxyz(target[0:4])
        w_IT_T = target[4:7]
        R_IC = rotation_from_wxyz(chaser[0:4])
        w_IC_C = chaser[4:7]
        R_LC = R_IL.T @ R_IC

        memory = context.get_abstract_state(self._memory).get_value()
        previous_index = memory.plan.index if memory.plan is not None else 0
        if not memory.attempted:
            memory = self._plan(memory, t, "initial", sensed)
        elif memory.plan is None and t >= memory.next_retry_s - _TIME_TOLERANCE_S:
            memory = self._plan(memory, t, "retry", sensed)
        elif memory.plan is not None and t >= memory.plan.next_replan_s - _TIME_TOLERANCE_S:
            active = memory.plan
            remaining = active.N - round((t - active.t0_s) / self._dt)
            if remaining >= cfg.min_replan_knots:
                memory = self._plan(memory, t, "replan", sensed)
            else:
                memory = dataclasses.replace(
                    memory, plan=dataclasses.replace(active, next_replan_s=math.inf)
                )
        status = planner_status_code(memory.records[-1]["status"]) if memory.records else 0

        if memory.plan is None:  # fallback: zero wrench on the passively safe orbit
            held = np.concatenate([np.zeros(12), [MODE_FALLBACK, status]])
            held[6:9] = np.nan
            state.get_mutable_discrete_state(self._held).set_value(held)
            state.get_mutable_abstract_state(self._memory).set_value(memory)
            return

        p_ref, v_ref, u_ff, a_ff, mode = self._reference(memory.plan, t, R_LT, w_IT_T)
        w_n, zeta = cfg.translation_bandwidth_rad_s, cfg.translation_damping
        a_L = a_ff + w_n * w_n * (p_ref - p) + 2.0 * zeta * w_n * (v_ref - v)
        f_C = self._mass * (R_IC.T @ (R_IL @ a_L))  # paper 003 eq. 13

        # Pointing law from the measured position (module docstring).
        los = -p / max(np.linalg.norm(p), 1e-9)
        R_prev = memory.R_LC_des if memory.R_LC_des is not None else R_LC
        R_LC_des = min_rotation(R_prev @ self._c_C, los) @ R_prev
        p_squared = max(p @ p, 1e-18)
        w_LC_des_L = cross(p, v) / p_squared  # line-of-sight rate, no roll
        R_IC_des = R_IL @ R_LC_des
        error = RotationMatrix(R_IC.T @ R_IC_des).ToAngleAxis()
        e_C = error.axis() * error.angle()
        w_des_C = R_IC.T @ (R_IL @ (w_IL_L + w_LC_des_L))
        w_a, zeta_a = cfg.attitude_bandwidth_rad_s, cfg.attitude_damping
        alpha_des_C = None
        if cfg.attitude_feedforward:  # the desired rate's inertial derivative (module docstring)
            a_rel = a_ff + cw_acceleration(self._n, p, v)
            w_dot_L = cross(p, a_rel) / p_squared - 2.0 * (p @ v) / p_squared * w_LC_des_L
            alpha_des_C = R_IC.T @ (R_IL @ (w_dot_L + cross(w_IL_L, w_LC_des_L)))
        tau_C = attitude_pd_torque(
            self._J_C, e_C, w_des_C - w_IC_C, w_IC_C, w_a, zeta_a, alpha_des_C
        )

        held = np.concatenate([tau_C, f_C, p_ref, u_ff, [mode, status]])
        state.get_mutable_discrete_state(self._held).set_value(held)
        state.get_mutable_abstract_state(self._memory).set_value(
            dataclasses.replace(memory, R_LC_des=R_LC_des)
        )
        if memory.plan.index != previous_index:
            state.get_mutable_abstract_state(self._path).set_value(
                PlannedPath(memory.plan.index, memory.plan.t0_s, memory.plan.x[:, :3].copy())
            )

    def _reference(self, plan: _ActivePlan, t, R_LT, w_IT_T):
        """(p_ref, v_ref, u_ff [N], a_ff [m/s^2], mode) at time t (module docstring)."""
        n, dt = self._n, self._dt
        elapsed = t - plan.t0_s
        k = math.floor((elapsed + _TIME_TOLERANCE_S) / dt)
        if k < plan.N - 1:  # inside step k: the plan's exact ZOH motion, eq. (5)
            tau = max(elapsed - k * dt, 0.0)
            u = plan.u[k]
            x_ref = cw_state_transition(n, tau) @ plan.x[k] + cw_zoh_input(n, tau) @ u / self._mass
            return x_ref[:3], x_ref[3:], u, u / self._mass, MODE_TRACKING
        # After the final knot: hold the capture pose, a point fixed in T (module docstring).
        z_L_in_T = R_LT.T @ np.array([0.0, 0.0, n])
        w_LT_T = w_IT_T - z_L_in_T  # the target's rate relative to L
        w_dot_LT_T = angular_acceleration(self._J_T, w_IT_T) + cross(w_LT_T, z_L_in_T)
        w_LT_L = R_LT @ w_LT_T
        p_ref = R_LT @ self._reach_T  # (13): p* = R_LT (D_t - R_y(pi) D_c)
        v_ref = cross(w_LT_L, p_ref)  # (14) with the chaser capture point's lever
        a_ref = R_LT @ cross(w_dot_LT_T, self._reach_T) + cross(w_LT_L, cross(w_LT_L, p_ref))
        a_ff = a_ref - cw_acceleration(n, p_ref, v_ref)  # the unforced CW part, cancelled
        return p_ref, v_ref, self._mass * a_ff, a_ff, MODE_CAPTURE_HOLD
