"""Paper 001's receding-horizon policy (eq. 23): the coupled 6-DOF NMPC as a Drake system.

Owns: `CoupledNmpcController`, a LeafSystem that reads the sensed bundle, keeps the integral
state xi_T of eq. 14, calls the NLP of eq. 22 every control period and outputs the eight
thrusters' force vectors in C (24 numbers, the gimbaled bank's command), or on a fixed bank each
thruster's level u_k / f_max in [0, 1] (the fixed bank's per-thruster command, through the PWM);
`coupled_state_from_sensed`
(the prediction model's state x from one sensed sample); the status codes and fallbacks it logs.
Does not own: the prediction model, its constraints and costs (rpod.models.coupled_relative), the
NLP and its solver (rpod.planners.coupled_nmpc), the thrusters' limits (the bank clips whatever
it is given: rpod.systems.thruster_bank), or the scenario (rpod.diagrams.controllers.coupled_nmpc).

Receding horizon (eq. 23; Sec. III-D). At t = k T_c (T_c = `control_period_s`, Sec. IV: T_c =
T_s = T / N = 60 s) the controller builds x0 from the sensed bundle, solves (22) from it with the
previous plan shifted as the warm start, and holds the plan's first input u*(0) until the next
solve. Solving takes no simulated time (the computation delay is not modelled); its wall time is
logged.

x0 from the sensed bundle (`coupled_state_from_sensed`). The bundle has the target's orbit
(p_IT_I, v_IT_I), both attitudes and rates, and the chaser relative to the target in L
(p_LC_L, v_LC_L seen in L). The chaser's absolute state is p_IC_I = p_IT_I + R_IL p_LC_L,
v_IC_I = v_IT_I + R_IL (v_LC_L + w_IL_L x p_LC_L) (transport theorem), and x follows from
`coupled_relative.relative_state_from_absolute` (eqs. 3, 4, 7, 8).

The integral state xi_T (eq. 14) is not measured: the controller integrates p_PtPc_T itself by
the trapezoid rule on a fixed step (`integral_step_s`, default 1 s, a periodic discrete update
from t = 0, xi_T(0) = 0). At a solve the integral is completed up to the solve's instant with
the last trapezoid piece, so the result does not depend on the order in which Drake runs the
two events due at the same time. Error: the trapezoid's dt^3 |p''| / 12 per step, < 1e-2 m s
per second at the bank's ~0.04 m/s^2, against |xi| ~ 1e4 m s on Sec. IV's approach.

Fallback (DESIGN.md: never an exception on solver failure). When a solve is not usable
(`NmpcResult.usable` is False: not converged, infeasible, no solver, a non-finite input), or the
planner raises (RuntimeError, ValueError: e.g. a non-finite x0), the controller flies the last
usable plan's input for the current instant, u[k] with k = floor((t - t_plan) / T_s), while the
plan lasts (k < N), else zero thrust. Each step's status code, fallback, iterations, solve time
and cost are output (`nmpc_status`) for the log, and every solve is recorded (`solve_records`).

The planner's chaser frame. A planner whose goal attitude is not R_TC = I works in a chaser
frame C' fixed in the chaser (R_CC', rpod.diagrams.controllers.coupled_nmpc.problem): the
controller gives it the chaser's attitude as C''s, q_IC' = q_IC R_CC', w_IC'_C' = R_CC'^T
w_IC_C; its thrust per thruster is the same in either frame.

Warm start: the last usable plan shifted by the whole intervals elapsed since it was made
(`CoupledNmpc.shifted_warm_start`, once per interval), None (the planner's zero-thrust rollout)
when there is none or it has run out. A failed solve's iterate is not used as a guess.
"""

import dataclasses
import enum
import math

import numpy as np
from pydrake.common.value import Value

from rpod.models import coupled_relative as cr
from rpod.models.frames import cross, quaternion_wxyz, rotation_from_wxyz
from rpod.planners.coupled_nmpc import NmpcStatus
from rpod.systems.lifetime import LeafSystem
from rpod.systems.sensed import Sensed, declare_sensed_input
from rpod.systems.step_timer import StepTimer


class NmpcFallback(enum.IntEnum):
    """What the controller flew at a step (the integer is what the log holds)."""

    NONE = 0  # the new plan's u*(0)
    PREVIOUS_PLAN = 1  # the last usable plan's input for this instant
    ZERO_THRUST = 2  # no usable plan


STATUS_CODES = {
    "solved": 0,
    "max_iterations": 1,
    "infeasible": 2,
    "solver_unavailable": 3,
    "failed": 4,
    "rti_step": 5,
    "acceptable": 6,
}
"""NmpcStatus value -> the status code the log holds (stable: a new status does not shift them).
Whether a step's plan was flown is `NmpcResult.usable`'s call (e.g. rti_step is), not the code's."""
NO_SOLVE_CODE = -1
"""The status code before the first solve."""
OTHER_STATUS_CODE = 9
"""The code of an NmpcStatus added after this table (its name is in `solve_records`)."""
EXCEPTION_STATUS = "exception"
"""The status recorded when the planner raised (code: that of NmpcStatus.FAILED)."""
STATUS_SIZE = 5
"""nmpc_status: [status code, fallback, iterations (-1: unknown), solve time s, cost]."""


def status_code(status: str) -> int:
    """The log's code of an NmpcStatus value (or EXCEPTION_STATUS)."""
    if status == EXCEPTION_STATUS:
        return STATUS_CODES["failed"]
    return STATUS_CODES.get(status, OTHER_STATUS_CODE)


def chaser_inertial_state(sensed: Sensed) -> tuple[np.ndarray, np.ndarray]:
    """(p_IC_I, v_IC_I) of the chaser: p_IT_I + R_IL p_LC_L, v_IT_I + R_IL (v_LC_L + w x p)."""
    R_IL = rotation_from_wxyz(sensed.q_IL)
    p_LC_L = np.asarray(sensed.p_LC_L, dtype=float)
    w_IL_L = np.asarray(sensed.w_IL_L, dtype=float)
    target = np.asarray(sensed.target_state_I, dtype=float)
    p_IC_I = target[:3] + R_IL @ p_LC_L
    v_IC_I = target[3:] + R_IL @ (np.asarray(sensed.v_LC_L, float) + cross(w_IL_L, p_LC_L))
    return p_IC_I, v_IC_I


def coupled_state_from_sensed(
    params: cr.CoupledRelativeParams, sensed: Sensed, xi_T=None
) -> np.ndarray:
    """The prediction model's state x (39,) from one sample of the sensed bundle (module
    docstring), with the integral state xi_T (default zero)."""
    p_IC_I, v_IC_I = chaser_inertial_state(sensed)
    target = np.asarray(sensed.target_state_I, dtype=float)
    return cr.relative_state_from_absolute(
        params,
        rotation_from_wxyz(sensed.q_IT),
        np.asarray(sensed.w_IT_T, dtype=float),
        target[:3],
        target[3:],
        rotation_from_wxyz(sensed.q_IC),
        np.asarray(sensed.w_IC_C, dtype=float),
        p_IC_I,
        v_IC_I,
        xi_T,
    )


def feature_point_offset_T(params: cr.CoupledRelativeParams, sensed: Sensed) -> np.ndarray:
    """p_PtPc_T (eq. 7) from one sensed sample: R_IT^T (R_IL p_LC_L + R_IC p_CPc_C) - p_TPt_T."""
    R_IT = rotation_from_wxyz(sensed.q_IT)
    p_TPc_I = rotation_from_wxyz(sensed.q_IL) @ np.asarray(sensed.p_LC_L, dtype=float)
    p_TPc_I = p_TPc_I + rotation_from_wxyz(sensed.q_IC) @ params.p_CPc_C
    return R_IT.T @ p_TPc_I - params.p_TPt_T


@dataclasses.dataclass(frozen=True)
class SolveRecord:
    """One control step (one call of the planner).

    Attributes:
        t_s: simulated time of the step [s].
        status: the NmpcStatus value, or EXCEPTION_STATUS when the planner raised.
        message: the solver's own word (or the exception's text).
        usable: whether the new plan was flown.
        fallback: the NmpcFallback flown.
        iterations: the solver's iterations (-1: unknown).
        solve_time_s: the planner's wall time [s].
        cost: the objective (NaN without one).
    """

    t_s: float
    status: str
    message: str
    usable: bool
    fallback: int
    iterations: int
    solve_time_s: float
    cost: float


@dataclasses.dataclass(frozen=True)
class _Memory:
    """The last usable plan, when it was made, and the record of every step (never changed in
    place: each update replaces it, so Drake's clones may share it)."""

    plan: object = None  # NmpcResult | None
    plan_time_s: float = math.nan
    records: tuple = ()

    def __deepcopy__(self, memo):
        return self


class CoupledNmpcController(LeafSystem):
    """Paper 001's receding-horizon NMPC (eq. 23), sampled; outputs held between samples.

    Input port: sensed (33, rpod.systems.sensed).
    Output ports:
        thruster_forces_C (24): the eight force vectors in C [N], thruster by thruster in the
            order of rpod.models.thrusters.gimbaled_cuboid_8 (u*(0) or the fallback); on a
            fixed bank instead
        thruster_levels (n): each thruster's u_k / f_max, clipped to [0, 1].
        nmpc_status (5): [status code (STATUS_CODES; -1 before the first solve), NmpcFallback,
            iterations (-1: unknown), solve time s, cost] of the last step.
        integral_state_T (3): xi_T (eq. 14) at the last integration step [m s].
    A logger sampling at an update instant records the values from before that update (Drake
    publishes at the end of a step, the updates run at the start of the next).

    Args:
        nmpc: the planner (rpod.planners.coupled_nmpc.CoupledNmpc): its `params`, `N`,
            `interval_s`, `solve(x0, warm_start)` and `shifted_warm_start(result)` are used.
        control_period_s: T_c, the solve period [s] (> 0).
        integral_step_s: the trapezoid step of xi_T [s] (> 0).
        R_CCp: R_CC' of the planner's chaser frame (module docstring); None: C itself.
    """

    def __init__(self, nmpc, control_period_s: float, integral_step_s: float = 1.0, R_CCp=None):
        super().__init__()
        for name, value in (
            ("control_period_s", control_period_s),
            ("integral_step_s", integral_step_s),
        ):
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name}: must be positive, got {value}")
        self._nmpc = nmpc
        self._params = nmpc.params
        self._R_CCp = None if R_CCp is None else np.asarray(R_CCp, dtype=float)
        self._input_size = int(self._params.input_size)
        layout = self._params.layout
        self._control_period_s = float(control_period_s)
        self._sensed_port = declare_sensed_input(self)
        # Held outputs [u (m), status (5)]; the integral [xi_T (3), p_last (3), t_last].
        held0 = np.concatenate(
            [np.zeros(self._input_size), [NO_SOLVE_CODE, NmpcFallback.NONE, -1, 0.0, math.nan]]
        )
        self._held = self.DeclareDiscreteState(held0)
        integral0 = np.concatenate([np.zeros(3), np.full(3, math.nan), [math.nan]])
        self._integral = self.DeclareDiscreteState(integral0)
        self._memory = self.DeclareAbstractState(Value[object](_Memory()))
        self.step_timer = StepTimer()  # the compute per control step (rpod.systems.step_timer)
        self.DeclarePeriodicUnrestrictedUpdateEvent(
            self._control_period_s, 0.0, self.step_timer.timed(self._control)
        )
        self.DeclarePeriodicDiscreteUpdateEvent(float(integral_step_s), 0.0, self._integrate)
        held = {self.discrete_state_ticket(self._held)}
        # The lambdas capture the state indices, never self (rpod.systems.lifetime).
        size, held_index, integral_index = self._input_size, self._held, self._integral
        if layout.gimbaled:
            self.DeclareVectorOutputPort(
                "thruster_forces_C",
                size,
                lambda c, o: o.SetFromVector(c.get_discrete_state(held_index).get_value()[:size]),
                held,
            )
        else:
            f_max = layout.max_thrusts_N
            self.DeclareVectorOutputPort(
                "thruster_levels",
                size,
                lambda c, o: o.SetFromVector(
                    np.clip(c.get_discrete_state(held_index).get_value()[:size] / f_max, 0, 1)
                ),
                held,
            )
        self.DeclareVectorOutputPort(
            "nmpc_status",
            STATUS_SIZE,
            lambda c, o: o.SetFromVector(c.get_discrete_state(held_index).get_value()[size:]),
            held,
        )
        self.DeclareVectorOutputPort(
            "integral_state_T",
            3,
            lambda c, o: o.SetFromVector(c.get_discrete_state(integral_index).get_value()[:3]),
            {self.discrete_state_ticket(self._integral)},
        )

    @property
    def nmpc(self):
        """The planner it calls."""
        return self._nmpc

    @property
    def params(self) -> cr.CoupledRelativeParams:
        """The prediction model's data."""
        return self._params

    @property
    def control_period_s(self) -> float:
        """T_c [s]."""
        return self._control_period_s

    def solve_records(self, context) -> tuple[SolveRecord, ...]:
        """Every control step so far, in order (`context`: this system's)."""
        return context.get_abstract_state(self._memory).get_value().records

    # ------------------------------------------------------------------------------ events

    def _sensed(self, context) -> Sensed:
        """The sensed bundle, the chaser's attitude that of the planner's frame C'."""
        sensed = Sensed.from_vector(self._sensed_port.Eval(context))
        if self._R_CCp is None:
            return sensed
        return sensed.with_chaser_attitude(
            quaternion_wxyz(rotation_from_wxyz(sensed.q_IC) @ self._R_CCp),
            self._R_CCp.T @ np.asarray(sensed.w_IC_C, dtype=float),
        )

    def _integrate(self, context, discrete_state) -> None:
        """One trapezoid step of xi_T-dot = p_PtPc_T (eq. 14)."""
        t = context.get_time()
        xi, p_last, t_last = self._integral_parts(context)
        p = feature_point_offset_T(self._params, self._sensed(context))
        if np.all(np.isfinite(p_last)):
            xi = xi + 0.5 * (t - t_last) * (p_last + p)  # trapezoid
        discrete_state.get_mutable_vector(self._integral).SetFromVector(np.r_[xi, p, t])

    def _integral_parts(self, context):
        value = context.get_discrete_state(self._integral).get_value()
        return value[:3].copy(), value[3:6].copy(), float(value[6])

    def _integral_now(self, context, p_now: np.ndarray) -> np.ndarray:
        """xi_T at this instant: the stored integral plus the last trapezoid piece to now."""
        xi, p_last, t_last = self._integral_parts(context)
        t = context.get_time()
        if np.all(np.isfinite(p_last)) and t > t_last:
            xi = xi + 0.5 * (t - t_last) * (p_last + p_now)
        return xi

    def _warm_start(self, memory: _Memory, t: float):
        """The last usable plan shifted by the whole intervals elapsed (module docstring)."""
        if memory.plan is None:
            return None
        shifts = math.floor((t - memory.plan_time_s) / self._nmpc.interval_s + 1e-9)
        if shifts >= self._nmpc.N:
            return None
        guess = memory.plan
        for _ in range(shifts):
            guess = self._nmpc.shifted_warm_start(guess)
        return guess

    def _fallback(self, memory: _Memory, t: float) -> tuple[np.ndarray, NmpcFallback]:
        """The last usable plan's input for now, while it lasts; else zero thrust."""
        if memory.plan is not None:
            k = math.floor((t - memory.plan_time_s) / self._nmpc.interval_s + 1e-9)
            if k < self._nmpc.N:
                return np.asarray(memory.plan.u[k], dtype=float), NmpcFallback.PREVIOUS_PLAN
        return np.zeros(self._input_size), NmpcFallback.ZERO_THRUST

    def _control(self, context, state) -> None:
        """One receding-horizon step (eq. 23)."""
        t = context.get_time()
        memory = context.get_abstract_state(self._memory).get_value()
        x0 = coupled_state_from_sensed(self._params, self._sensed(context))
        x0[cr.XI_T_SLICE] = self._integral_now(context, x0[cr.P_PTPC_T_SLICE])
        try:
            result = self._nmpc.solve(x0, self._warm_start(memory, t))
        except (RuntimeError, ValueError) as error:  # a failure is a status, never a crash
            result, status, message = None, EXCEPTION_STATUS, str(error).splitlines()[0]
            iterations, solve_time, cost = -1, math.nan, math.nan
        else:
            status, message = NmpcStatus(result.status).value, str(result.solver_message)
            iterations = -1 if result.iterations is None else int(result.iterations)
            solve_time, cost = float(result.solve_time_s), float(result.cost)
        usable = result is not None and bool(result.usable)
        if usable:
            u0, fallback = np.asarray(result.u[0], dtype=float), NmpcFallback.NONE
            plan, plan_time = result, t
        else:
            u0, fallback = self._fallback(memory, t)
            plan, plan_time = memory.plan, memory.plan_time_s
        record = SolveRecord(
            t, status, message, usable, int(fallback), iterations, solve_time, cost
        )
        state.get_mutable_abstract_state(self._memory).set_value(
            _Memory(plan, plan_time, memory.records + (record,))
        )
        state.get_mutable_discrete_state(self._held).set_value(
            np.r_[u0, status_code(status), int(fallback), iterations, solve_time, cost]
        )
