"""Paper 004's MPC (eq. 11) through one persistent OSQP problem: the same QP solved by Clarabel
(through Drake) agrees to OSQP's tolerance, before and after the data are updated in place; an
independent check evaluates every constraint on the solution; an infeasible QP is a status."""

import numpy as np
import pytest
from pydrake.solvers import ClarabelSolver, MathematicalProgram

from rpod.models.cw import cw_state_transition, cw_zoh_input
from rpod.models.los_corridor import LosCorridor
from rpod.planners.los_corridor_mpc import LosCorridorMpc, LosMpcSettings, MpcStatus

N_ORBIT = 1.131e-3  # paper 004 Table 1: 500 km
DT = 1.0
CORRIDOR = LosCorridor()
TIGHT = {"eps_abs": 1e-9, "eps_rel": 1e-9, "max_iter": 200000}
PAPER_11D = {"margin_m": 0.0, "recovery_steps": 0}  # eq. 11d as the paper writes it


def _model(dt=DT):
    return cw_state_transition(N_ORBIT, dt), cw_zoh_input(N_ORBIT, dt)


def _clarabel(P, q, A, l, u) -> tuple[np.ndarray, float]:
    """The same QP by Clarabel: (z*, objective)."""
    prog = MathematicalProgram()
    z = prog.NewContinuousVariables(P.shape[0])
    P_full = (P + P.T).toarray() - np.diag(P.diagonal())  # P is upper triangular
    prog.AddQuadraticCost(P_full, q, z, is_convex=True)
    A = A.toarray()
    finite_l, finite_u = np.where(np.isfinite(l), l, -1e30), np.where(np.isfinite(u), u, 1e30)
    prog.AddLinearConstraint(A, finite_l, finite_u, z)
    result = ClarabelSolver().Solve(prog)
    assert result.is_success()
    return result.GetSolution(z), result.get_optimal_cost()


def _check_solution(result, x_k, A_d, B_d, a_max, tolerance=1e-6):
    """Every constraint of eq. 11 on the returned trajectory."""
    x, u = result.x, result.u
    np.testing.assert_allclose(x[0], x_k, atol=tolerance)  # (11c)
    residual = x[1:] - (x[:-1] @ A_d.T + u @ B_d.T)  # (11b)
    assert np.max(np.abs(residual)) < tolerance
    assert np.all(CORRIDOR.slack(x[:, :3]) >= -tolerance)  # (11d), every predicted step
    assert np.all(np.abs(u) <= a_max + tolerance)  # (11e)


@pytest.mark.parametrize("horizon", [20, 40])
def test_osqp_persistent_solve_equals_clarabel_before_and_after_an_update(horizon):
    settings = LosMpcSettings(horizon=horizon, **TIGHT)
    mpc = LosCorridorMpc(settings, CORRIDOR.A_c, CORRIDOR.b_c)
    A_d, B_d = _model()
    x_ref = np.array([0.0, 10.0, 0.0, 0.0, 0.0, 0.0])  # a hold point 10 m up the axis
    cases = [
        (np.array([3.0, 25.0, -2.0, 0.05, -0.2, 0.01]), np.zeros(3), A_d, B_d),
        # An update in place: another start, another last input, another A_d, B_d (dt 1.2 s).
        (np.array([-4.0, 30.0, 5.0, 0.0, -0.1, -0.05]), np.array([0.01, -0.02, 0.0]), *_model(1.2)),
    ]
    for x_k, u_prev, A, B in cases:
        result = mpc.solve(x_k, x_ref, u_prev, A, B)
        assert result.status is MpcStatus.SOLVED
        _check_solution(result, x_k, A, B, settings.a_max_m_s2)
        z_ref, _ = _clarabel(*mpc.qp(x_k, x_ref, u_prev, A, B))
        u_ref = z_ref[6 * (horizon + 1) :].reshape(horizon, 3)
        # OSQP at eps 1e-9 against an interior-point solution: 1e-6 m/s^2 on inputs of 1e-1.
        np.testing.assert_allclose(result.u0, u_ref[0], atol=1e-6)
        np.testing.assert_allclose(result.u, u_ref, atol=1e-5)


def test_per_step_models_and_a_nominal_command_equal_clarabel():
    """One A_d, B_d per predicted step (a non-principal tumble's model) and the input weight
    centred on a nominal command: the same QP by Clarabel agrees, every constraint holds.

    R_u = 10 I here: at the paper's 1e-2 the centre moves u_0 by ~1e-8 m/s^2 only."""
    horizon = 20
    settings = LosMpcSettings(horizon=horizon, R_u_diag=[10.0] * 3, **TIGHT)
    mpc = LosCorridorMpc(settings, CORRIDOR.A_c, CORRIDOR.b_c)
    models = [_model(DT * (1.0 + 0.02 * j)) for j in range(horizon)]  # a different one each step
    A_d, B_d = np.array([m[0] for m in models]), np.array([m[1] for m in models])
    x_k = np.array([2.0, 40.0, 1.0, 0.0, -0.3, 0.0])
    x_ref, u_nom = np.array([0.0, 10.0, 0.0, 0.0, 0.0, 0.0]), np.array([0.05, -0.08, 0.0])
    result = mpc.solve(x_k, x_ref, np.zeros(3), A_d, B_d, u_nom=u_nom)
    assert result.status is MpcStatus.SOLVED
    x, u = result.x, result.u
    residual = x[1:] - (np.einsum("jik,jk->ji", A_d, x[:-1]) + np.einsum("jik,jk->ji", B_d, u))
    assert np.max(np.abs(residual)) < 1e-6  # (11b), each step with its own model
    assert np.all(CORRIDOR.slack(x[:, :3]) >= -1e-6) and np.all(np.abs(u) <= 0.1 + 1e-6)
    z_ref, _ = _clarabel(*mpc.qp(x_k, x_ref, np.zeros(3), A_d, B_d, u_nom=u_nom))
    np.testing.assert_allclose(u, z_ref[6 * (horizon + 1) :].reshape(horizon, 3), atol=1e-5)
    # The nominal command moves the solution (u_nom = 0 is the paper's 11a).
    plain = mpc.solve(x_k, x_ref, np.zeros(3), A_d, B_d)
    assert np.max(np.abs(plain.u - result.u)) > 1e-4
    with pytest.raises(ValueError, match="A_d, B_d"):
        mpc.solve(x_k, x_ref, np.zeros(3), A_d[:5], B_d[:5])


def test_the_input_bound_and_the_corridor_are_active_when_the_reference_pulls_out():
    """A reference outside the corridor: the solution rides the corridor, inputs bounded."""
    settings = LosMpcSettings(horizon=20, a_max_m_s2=0.02, **TIGHT, **PAPER_11D)
    mpc = LosCorridorMpc(settings, CORRIDOR.A_c, CORRIDOR.b_c)
    A_d, B_d = _model()
    x_k = np.array([10.0, 20.0, 0.0, 0.0, 0.0, 0.0])  # 26.6 deg off the axis, toward +x
    result = mpc.solve(x_k, np.array([30.0, 20.0, 0.0, 0, 0, 0]), np.zeros(3), A_d, B_d)
    assert result.status is MpcStatus.SOLVED
    _check_solution(result, x_k, A_d, B_d, 0.02)
    assert np.max(np.abs(result.u)) == pytest.approx(0.02, abs=1e-6)  # saturated
    assert np.min(CORRIDOR.slack(result.x[:, :3])) < 1e-5  # on a face


def test_a_start_outside_the_corridor_is_an_infeasible_status_not_an_exception():
    mpc = LosCorridorMpc(LosMpcSettings(horizon=20, **PAPER_11D), CORRIDOR.A_c, CORRIDOR.b_c)
    A_d, B_d = _model()
    outside = np.array([0.0, -5.0, 0.0, 0.0, 0.0, 0.0])  # behind the target: x_0 violates 11d
    result = mpc.solve(outside, np.zeros(6), np.zeros(3), A_d, B_d)
    assert result.status is MpcStatus.PRIMAL_INFEASIBLE and not result.solved
    assert result.u0 is None
    # The same solver solves the next, feasible step (the persistent problem is not broken).
    inside = np.array([0.0, 15.0, 0.0, 0.0, 0.0, 0.0])
    assert mpc.solve(inside, inside, np.zeros(3), A_d, B_d).status is MpcStatus.SOLVED


def test_bad_settings_name_the_field():
    for bad, field in (
        ({"horizon": 0}, "horizon"),
        ({"Q_diag": [1, 2]}, "Q_diag"),
        ({"a_max_m_s2": 0.0}, "a_max_m_s2"),
    ):
        with pytest.raises(ValueError, match=field):
            LosCorridorMpc(LosMpcSettings(**bad), CORRIDOR.A_c, CORRIDOR.b_c)


def test_the_recovery_funnel_brings_a_chaser_outside_back_in_within_its_steps():
    """Outside a face, the paper's 11d is infeasible; the funnel relaxes each step's bound by
    the excess times max(0, 1 - (j / R)^2), so the plan is back inside (with the margin) by
    j = R: checked on the returned trajectory, and against the model."""
    R = 10
    settings = LosMpcSettings(horizon=20, margin_m=0.1, recovery_steps=R, **TIGHT)
    mpc = LosCorridorMpc(settings, CORRIDOR.A_c, CORRIDOR.b_c)
    A_d, B_d = _model()
    outside = np.array([14.0, 20.0, 0.0, 0.0, 0.0, 0.0])  # 35 deg off the axis: 2.1 m out
    distance = CORRIDOR.slack(outside[:3]) / np.linalg.norm(CORRIDOR.A_c, axis=1)
    assert distance.min() < -1.0
    result = mpc.solve(outside, np.array([0.0, 10.0, 0.0, 0, 0, 0]), np.zeros(3), A_d, B_d)
    assert result.status is MpcStatus.SOLVED
    x = result.x
    residual = x[1:] - (x[:-1] @ A_d.T + result.u @ B_d.T)
    assert np.max(np.abs(residual)) < 1e-6
    inside = CORRIDOR.slack(x[:, :3]) / np.linalg.norm(CORRIDOR.A_c, axis=1)
    assert np.all(inside[R:] >= 0.1 - 1e-6)  # from j = R on: inside by the margin
    excess = np.maximum(-distance + 0.1, 0.0)
    for j in range(1, R):  # never further out than the funnel allows
        assert np.all(0.1 - inside[j] <= excess * (1 - (j / R) ** 2) + 1e-6)
    # The paper's 11d: the same start is an infeasible QP.
    paper = LosCorridorMpc(LosMpcSettings(horizon=20, **PAPER_11D), CORRIDOR.A_c, CORRIDOR.b_c)
    assert not paper.solve(outside, np.zeros(6), np.zeros(3), A_d, B_d).solved


def test_the_best_effort_qp_is_exact_where_the_hard_one_is_feasible():
    """The corridor as an exact L1 penalty: where eq. 11 is feasible, the soft QP's optimum is
    the hard one's (every slack zero, the same inputs), here with the reference pulling the plan
    onto a face so that the corridor's multipliers are not zero."""
    settings = LosMpcSettings(horizon=20, a_max_m_s2=0.02, **TIGHT, **PAPER_11D)
    hard = LosCorridorMpc(settings, CORRIDOR.A_c, CORRIDOR.b_c)
    soft = LosCorridorMpc(settings, CORRIDOR.A_c, CORRIDOR.b_c, soft=True)
    A_d, B_d = _model()
    x_k, x_ref = np.array([10.0, 20.0, 0.0, 0.0, 0.0, 0.0]), np.array([30.0, 20.0, 0, 0, 0, 0])
    on_face = hard.solve(x_k, x_ref, np.zeros(3), A_d, B_d)
    best = soft.solve(x_k, x_ref, np.zeros(3), A_d, B_d)
    assert on_face.status is MpcStatus.SOLVED and best.status is MpcStatus.SOLVED
    assert best.excess_m < 1e-6
    _check_solution(best, x_k, A_d, B_d, 0.02)
    np.testing.assert_allclose(best.u, on_face.u, atol=1e-6)


def test_the_best_effort_qp_answers_where_the_hard_one_is_infeasible():
    """A chaser 12 m up the axis rushing sideways at 1 m/s (in T) cannot stay inside with
    0.02 m/s^2: eq. 11 is infeasible. The soft QP still returns an input inside the box, its
    planned excursion s_j equals what its own trajectory leaves the corridor by, and no input
    could do much better: braking flat out (the least-excursion input along the rush) leaves it
    at least as far out."""
    settings = LosMpcSettings(horizon=20, a_max_m_s2=0.02, **TIGHT, **PAPER_11D)
    hard = LosCorridorMpc(settings, CORRIDOR.A_c, CORRIDOR.b_c)
    soft = LosCorridorMpc(settings, CORRIDOR.A_c, CORRIDOR.b_c, soft=True)
    A_d, B_d = _model()
    x_k, x_ref = np.array([0.0, 12.0, 0.0, 1.0, 0.0, 0.0]), np.array([0.0, 12.0, 0, 0, 0, 0])
    assert not hard.solve(x_k, x_ref, np.zeros(3), A_d, B_d).solved
    best = soft.solve(x_k, x_ref, np.zeros(3), A_d, B_d)
    assert best.solved and best.status is MpcStatus.SOLVED
    assert np.all(np.abs(best.u) <= 0.02 + 1e-9)
    residual = best.x[1:] - (best.x[:-1] @ A_d.T + best.u @ B_d.T)
    assert np.max(np.abs(residual)) < 1e-6  # (11b) still holds exactly
    outside = np.max(-CORRIDOR.slack(best.x[:, :3]) / np.linalg.norm(CORRIDOR.A_c, axis=1))
    assert best.excess_m == pytest.approx(outside, abs=1e-5) and best.excess_m > 0.1
    brake = np.tile([-0.02, 0.0, 0.0], (20, 1))
    x = [x_k]
    for u in brake:
        x.append(A_d @ x[-1] + B_d @ u)
    braked = np.max(-CORRIDOR.slack(np.array(x)[:, :3]) / np.linalg.norm(CORRIDOR.A_c, axis=1))
    assert best.excess_m <= braked + 1e-3


def test_the_best_effort_qp_keeps_its_plan_beyond_the_keep_out_plane():
    """Outside a face near the floor, the soft corridor's shortest way back runs past the
    target: every predicted position keeps n . p_j >= r_ko, n = p_0 / |p_0| (module docstring),
    and with r_ko = 0 the same start plans inside that plane's 3 m."""
    settings = LosMpcSettings(horizon=20, **TIGHT, **PAPER_11D)
    A_d, B_d = _model()
    x_k = np.array([4.0, 1.5, 0.0, -0.5, -0.1, 0.0])  # 69 deg off the axis, heading across
    x_ref = np.array([0.0, 10.0, 0.0, 0.0, 0.0, 0.0])
    n = x_k[:3] / np.linalg.norm(x_k[:3])
    for keep_out, holds in ((3.0, True), (0.0, False)):
        soft = LosCorridorMpc(settings, CORRIDOR.A_c, CORRIDOR.b_c, soft=True, keep_out_m=keep_out)
        best = soft.solve(x_k, x_ref, np.zeros(3), A_d, B_d)
        assert best.solved
        along = best.x[1:, :3] @ n
        assert bool(np.min(along) >= 3.0 - 1e-6) == holds, np.min(along)


@pytest.mark.parametrize("solver", ["piqp", "daqp"])
@pytest.mark.parametrize("soft", [False, True])
def test_other_qp_solvers_give_clarabels_answer_through_every_update(solver, soft):
    """qp_solver: piqp (an interior point, no warm start) and daqp (an active set on the QP
    condensed onto the inputs, warm-started by the shifted working set) on the same QP, its
    data rewritten each step (another start, last input, model and, soft, keep-out
    direction): Clarabel's answer to 1e-6, every constraint of eq. 11 on the hard QP."""
    horizon = 20
    settings = LosMpcSettings(horizon=horizon, qp_solver=solver, **PAPER_11D)
    mpc = LosCorridorMpc(settings, CORRIDOR.A_c, CORRIDOR.b_c, soft=soft, keep_out_m=3.0)
    x_ref = np.array([0.0, 10.0, 0.0, 0.0, 0.0, 0.0])
    cases = [
        (np.array([3.0, 25.0, -2.0, 0.05, -0.2, 0.01]), np.zeros(3), *_model()),
        (np.array([-4.0, 30.0, 5.0, 0.0, -0.1, -0.05]), np.array([0.01, -0.02, 0.0]), *_model(1.2)),
        (np.array([10.0, 20.0, 0.0, 0.0, 0.0, 0.0]), np.zeros(3), *_model()),
    ]
    for x_k, u_prev, A_d, B_d in cases + cases[:1]:  # the last: a warm start on old data
        result = mpc.solve(x_k, x_ref, u_prev, A_d, B_d)
        assert result.status is MpcStatus.SOLVED
        if not soft:
            _check_solution(result, x_k, A_d, B_d, settings.a_max_m_s2)
        z_ref, _ = _clarabel(*mpc.qp(x_k, x_ref, u_prev, A_d, B_d))
        u_ref = z_ref[6 * (horizon + 1) : 6 * (horizon + 1) + 3 * horizon].reshape(horizon, 3)
        np.testing.assert_allclose(result.u, u_ref, atol=1e-6)


@pytest.mark.parametrize("solver", ["piqp", "daqp"])
def test_other_qp_solvers_say_infeasible_and_solve_the_next_step(solver):
    settings = LosMpcSettings(horizon=20, qp_solver=solver, **PAPER_11D)
    mpc = LosCorridorMpc(settings, CORRIDOR.A_c, CORRIDOR.b_c)
    A_d, B_d = _model()
    outside = np.array([0.0, -5.0, 0.0, 0.0, 0.0, 0.0])
    result = mpc.solve(outside, np.zeros(6), np.zeros(3), A_d, B_d)
    assert result.status is MpcStatus.PRIMAL_INFEASIBLE and result.u0 is None
    inside = np.array([0.0, 15.0, 0.0, 0.0, 0.0, 0.0])
    assert mpc.solve(inside, inside, np.zeros(3), A_d, B_d).status is MpcStatus.SOLVED
    with pytest.raises(ValueError, match="qp_solver"):
        LosCorridorMpc(LosMpcSettings(qp_solver="qpoases"), CORRIDOR.A_c, CORRIDOR.b_c)
