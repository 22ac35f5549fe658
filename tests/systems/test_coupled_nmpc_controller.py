"""Paper 001's receding-horizon controller (rpod.systems.coupled_nmpc_controller).

Independent references: x0 from the sensed bundle against
`coupled_relative.relative_state_from_absolute` of the absolute states the bundle was made from
(the bundle built here by rpod.models.frames.inertial_to_lvlh, a separate path); the integral
state against the closed form xi_T = p t of a constant offset (the trapezoid is exact there);
the fallback sequence against a scripted planner whose every input is distinct, so each output
names the plan and interval it came from; a real IPOPT solve cut at one iteration for the
failure path.
"""

import dataclasses

import numpy as np
import pytest
from pydrake.math import RollPitchYaw, RotationMatrix
from pydrake.systems.analysis import Simulator

from rpod.models import coupled_relative as cr
from rpod.models.frames import inertial_to_lvlh, quaternion_wxyz
from rpod.models.gravity import circular_orbit_state
from rpod.models.orbit import lvlh_of
from rpod.planners.coupled_nmpc import CoupledNmpc, CoupledNmpcSettings, NmpcStatus
from rpod.systems.coupled_nmpc_controller import (
    EXCEPTION_STATUS,
    NO_SOLVE_CODE,
    STATUS_CODES,
    CoupledNmpcController,
    NmpcFallback,
    coupled_state_from_sensed,
    feature_point_offset_T,
)
from rpod.systems.sensed import Sensed, sensed_vector


def _absolute_state(seed: int):
    """A target on an inclined 300 km orbit at a random attitude and rate, the chaser ~100 m
    away at a random attitude, rate and relative velocity (all in I)."""
    rng = np.random.default_rng(seed)
    p_IT_I, v_IT_I = circular_orbit_state(300e3, 0.9, 0.3, rng.uniform(0, 6))
    R_IT = RotationMatrix(RollPitchYaw(rng.uniform(-3, 3, 3))).matrix()
    R_IC = RotationMatrix(RollPitchYaw(rng.uniform(-3, 3, 3))).matrix()
    w_IT_T = rng.normal(scale=0.005, size=3)
    w_IC_C = rng.normal(scale=0.01, size=3)
    p_IC_I = p_IT_I + rng.normal(scale=60.0, size=3)
    v_IC_I = v_IT_I + rng.normal(scale=0.3, size=3)
    return R_IT, w_IT_T, p_IT_I, v_IT_I, R_IC, w_IC_C, p_IC_I, v_IC_I


def _sensed_from_absolute(R_IT, w_IT_T, p_IT_I, v_IT_I, R_IC, w_IC_C, p_IC_I, v_IC_I):
    R_IL, w_IL_L = lvlh_of(p_IT_I, v_IT_I, "two_body")
    p_L, v_L = inertial_to_lvlh(R_IL, w_IL_L, p_IC_I - p_IT_I, v_IC_I - v_IT_I)
    return sensed_vector(
        np.r_[p_L, v_L],
        quaternion_wxyz(R_IL),
        w_IL_L,
        np.r_[quaternion_wxyz(R_IT), w_IT_T],
        np.r_[quaternion_wxyz(R_IC), w_IC_C],
        np.r_[p_IT_I, v_IT_I],
    )


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_x0_from_the_sensed_bundle_equals_the_model_state_of_the_absolute_state(seed):
    params = cr.CoupledRelativeParams()
    state = _absolute_state(seed)
    sensed = Sensed.from_vector(_sensed_from_absolute(*state))
    xi = np.array([10.0, -20.0, 30.0])
    x = coupled_state_from_sensed(params, sensed, xi)
    x_ref = cr.relative_state_from_absolute(params, *state, xi_T=xi)
    # Tolerances: the bundle goes through quaternions (~1e-16) and LVLH (7e6 m coordinates
    # subtracted: ~1e-9 m); velocities ~1e-12 m/s.
    for name, sl, tol in (
        ("R_TC", cr.R_TC_SLICE, 1e-12),
        ("w_TC_T", cr.W_TC_T_SLICE, 1e-14),
        ("p_PtPc_T", cr.P_PTPC_T_SLICE, 1e-8),
        ("v_PtPc_T", cr.V_PTPC_T_SLICE, 1e-10),
        ("xi_T", cr.XI_T_SLICE, 0.0),
        ("R_IT", cr.R_IT_SLICE, 1e-12),
        ("p_IT_I", cr.P_IT_I_SLICE, 0.0),
    ):
        np.testing.assert_allclose(x[sl], x_ref[sl], rtol=0, atol=tol, err_msg=name)
    np.testing.assert_allclose(
        feature_point_offset_T(params, sensed), x_ref[cr.P_PTPC_T_SLICE], rtol=0, atol=1e-8
    )


# ------------------------------------------------------------------------ scripted planner


@dataclasses.dataclass
class _Plan:
    """What the controller reads of a result."""

    status: NmpcStatus
    u: np.ndarray
    usable: bool
    solver_message: str = "stub"
    iterations: int | None = 7
    solve_time_s: float = 0.01
    cost: float = 1.5
    shifts: int = 0


class _ScriptedPlanner:
    """Returns, at call k, a plan whose input on interval j is 100 k + j (every entry), usable
    or not as the script says ('raise': it raises); records x0 and the warm start."""

    def __init__(self, script, N=3, interval_s=10.0):
        self.params = cr.CoupledRelativeParams()
        self.N, self.interval_s = N, interval_s
        self.script = script
        self.calls = []

    def solve(self, x0, warm_start=None):
        k = len(self.calls)
        self.calls.append((np.array(x0), warm_start))
        what = self.script[k]
        if what == "raise":
            raise RuntimeError("solver crashed\nsecond line")
        u = 100.0 * k + np.repeat(np.arange(self.N, dtype=float)[:, None], cr.INPUT_SIZE, 1)
        status = NmpcStatus.SOLVED if what else NmpcStatus.MAX_ITERATIONS
        return _Plan(status, u, bool(what))

    def shifted_warm_start(self, result):
        return dataclasses.replace(result, u=np.vstack([result.u[1:], result.u[-1:]]),
                                   shifts=result.shifts + 1)  # fmt: skip


def _run(controller, sensed, times):
    """Simulates the controller alone on a fixed sensed input; its outputs just after each t."""
    simulator = Simulator(controller)
    context = simulator.get_mutable_context()
    controller.GetInputPort("sensed").FixValue(context, sensed)
    simulator.Initialize()
    forces, status = [], []
    for t in times:
        simulator.AdvanceTo(t)
        forces.append(controller.GetOutputPort("thruster_forces_C").Eval(context).copy())
        status.append(controller.GetOutputPort("nmpc_status").Eval(context).copy())
    return context, np.array(forces), np.array(status)


def test_ports_and_the_held_output_before_the_first_solve():
    controller = CoupledNmpcController(_ScriptedPlanner([True]), 10.0)
    assert controller.GetInputPort("sensed").size() == 33
    assert controller.GetOutputPort("thruster_forces_C").size() == 24
    assert controller.GetOutputPort("nmpc_status").size() == 5
    assert controller.GetOutputPort("integral_state_T").size() == 3
    context = controller.CreateDefaultContext()
    status = controller.GetOutputPort("nmpc_status").Eval(context)
    assert status[0] == NO_SOLVE_CODE
    assert not np.any(controller.GetOutputPort("thruster_forces_C").Eval(context))


def test_fallback_flies_the_previous_plan_while_it_lasts_then_zero_thrust():
    """Steps at 0, 10, ..., 50 s with T_s = 10 s and N = 3: solved, three failures (the last
    plan's intervals 1 and 2, then nothing left: zero), the planner raising (zero), solved."""
    planner = _ScriptedPlanner([True, False, False, False, "raise", True])
    controller = CoupledNmpcController(planner, 10.0)
    sensed = _sensed_from_absolute(*_absolute_state(3))
    context, forces, status = _run(controller, sensed, [5.0, 15.0, 25.0, 35.0, 45.0, 55.0])
    expected = [0.0, 1.0, 2.0, 0.0, 0.0, 500.0]  # plan 0's u[0], u[1], u[2]; zero; zero; plan 5
    np.testing.assert_array_equal(forces, np.repeat(np.array(expected)[:, None], 24, axis=1))
    fallback = [NmpcFallback.NONE, *[NmpcFallback.PREVIOUS_PLAN] * 2]
    fallback += [NmpcFallback.ZERO_THRUST] * 2 + [NmpcFallback.NONE]
    np.testing.assert_array_equal(status[:, 1], fallback)
    solved, cut = STATUS_CODES["solved"], STATUS_CODES["max_iterations"]
    np.testing.assert_array_equal(
        status[:, 0], [solved, cut, cut, cut, STATUS_CODES["failed"], solved]
    )
    records = controller.solve_records(context)
    assert [r.status for r in records] == ["solved"] + ["max_iterations"] * 3 + [
        EXCEPTION_STATUS,
        "solved",
    ]
    assert records[4].message == "solver crashed" and not records[4].usable
    assert [r.t_s for r in records] == [0.0, 10.0, 20.0, 30.0, 40.0, 50.0]
    # Warm starts: plan 0 shifted once, twice, then run out (None) until the next usable plan.
    warm = [call[1] for call in planner.calls]
    assert warm[0] is None
    assert warm[1].shifts == 1 and warm[2].shifts == 2
    assert warm[3] is None and warm[4] is None and warm[5] is None


def test_integral_state_is_the_trapezoid_integral_of_the_feature_point_offset():
    """A fixed sensed input keeps p_PtPc_T constant: xi_T(t) = p t at each solve (completed to
    the solve's instant whatever the order of the two events) and at each 1 s step."""
    planner = _ScriptedPlanner([True] * 4)
    controller = CoupledNmpcController(planner, 10.0, integral_step_s=1.0)
    sensed = _sensed_from_absolute(*_absolute_state(4))
    p = feature_point_offset_T(planner.params, Sensed.from_vector(sensed))
    context, _, _ = _run(controller, sensed, [7.5, 30.5])
    for k, (x0, _) in enumerate(planner.calls):
        np.testing.assert_allclose(x0[cr.XI_T_SLICE], 10.0 * k * p, rtol=1e-12, atol=1e-9)
        np.testing.assert_allclose(x0[cr.P_PTPC_T_SLICE], p, rtol=0, atol=1e-9)
    xi = controller.GetOutputPort("integral_state_T").Eval(context)
    np.testing.assert_allclose(xi, 30.0 * p, rtol=1e-12)  # the last 1 s step, at t = 30


def test_an_ipopt_solve_cut_at_one_iteration_is_a_status_and_zero_thrust():
    """The real planner with max_iterations = 1 (IPOPT stops at its iteration limit): each step
    is logged as max_iterations and flies zero thrust; nothing raises."""
    params = cr.CoupledRelativeParams()
    settings = CoupledNmpcSettings(horizon_s=80.0, intervals=8, max_iterations=1)
    controller = CoupledNmpcController(CoupledNmpc(params, settings=settings), 10.0)
    x = cr.sec_iv_initial_state(params)
    R_IC, w_IC_C, p_IC_I, v_IC_I = cr.chaser_absolute_state(params, x)
    s = cr.unpack_state(x)
    sensed = _sensed_from_absolute(
        s.R_IT, s.w_IT_T, s.p_IT_I, s.v_IT_I, R_IC, w_IC_C, p_IC_I, v_IC_I
    )
    context, forces, status = _run(controller, sensed, [5.0, 15.0])
    assert not np.any(forces)
    np.testing.assert_array_equal(status[:, 0], STATUS_CODES["max_iterations"])
    np.testing.assert_array_equal(status[:, 1], NmpcFallback.ZERO_THRUST)
    np.testing.assert_array_equal(status[:, 2], 1)  # IPOPT's own iteration count
    records = controller.solve_records(context)
    assert len(records) == 2 and not any(r.usable for r in records)
    assert all(r.message == "Max iteration exceeded" for r in records)  # IPOPT's own word
