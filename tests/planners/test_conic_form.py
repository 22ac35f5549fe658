"""rpod.planners.conic_form: a program's standard form is the program (a closed form; Drake's
own Clarabel and Clarabel's package on the form take the same iterations to the same optimum),
ECOS and QOCO solve it, and a refresh outside the form's pattern or rows is refused."""

import dataclasses

import numpy as np
import pytest
from pydrake.solvers import MathematicalProgram

from rpod.planners.conic_form import ConicForm, solve_conic
from rpod.planners.soft_capture import SoftCaptureConfig, sample_sec_vib_start, terminal_targets
from rpod.planners.soft_capture_socp import SocpData, SoftCaptureSocp


def _disc_program():
    """max x0 + x1 on the unit disc with x0 <= 0.5, 0.1 <= x2 <= 0.1 + x0 and x3 = 2:
    x0 = 0.5, x1 = sqrt(3)/2; every kind of row the form writes."""
    prog = MathematicalProgram()
    x = prog.NewContinuousVariables(4, "x")
    disc = prog.AddLorentzConeConstraint(
        np.vstack([np.zeros((1, 2)), np.eye(2)]), np.array([1.0, 0.0, 0.0]), x[:2]
    )
    upper = prog.AddLinearConstraint(np.array([[1.0, 0.0]]), [-np.inf], [0.5], x[:2])
    two_sided = prog.AddLinearConstraint(np.array([[-1.0, 1.0]]), [0.1], [0.1], x[[0, 2]])
    prog.AddBoundingBoxConstraint(2.0, 2.0, x[3])
    prog.AddLinearEqualityConstraint(np.array([[1.0, 1.0]]), [2.6], x[[2, 3]])
    prog.AddLinearCost(np.array([-1.0, -1.0]), 3.0, x[:2])
    return prog, disc, upper, two_sided


@pytest.mark.parametrize("solver", ["ecos", "qoco", "clarabel"])
def test_a_small_program_meets_its_closed_form(solver):
    prog, *_ = _disc_program()
    form = ConicForm(prog)
    assert (form.zero, form.orthant, form.soc) == (3, 1, [3])  # x0 - x2 = -0.1 is an equality
    solution = solve_conic(form, solver)
    assert solution.status == "solved", solution.solver_status
    expected = np.array([0.5, np.sqrt(0.75), 0.6, 2.0])
    np.testing.assert_allclose(solution.z, expected, atol=1e-6)
    assert solution.cost == pytest.approx(3.0 - 0.5 - np.sqrt(0.75), abs=1e-6)


def test_refresh_reads_new_coefficients_and_refuses_what_the_form_cannot_hold():
    prog, disc, upper, two_sided = _disc_program()
    form = ConicForm(prog, dynamic=[disc.evaluator(), upper.evaluator(), two_sided.evaluator()])
    disc.evaluator().UpdateCoefficients(
        np.vstack([np.zeros((1, 2)), np.eye(2)]), np.array([2.0, 0.0, 0.0])
    )  # radius 2
    upper.evaluator().UpdateCoefficients(np.array([[1.0, 0.0]]), [-np.inf], [1.0])
    two_sided.evaluator().UpdateCoefficients(np.array([[-1.0, 1.0]]), [-0.4], [-0.4])  # x0 = 1
    form.refresh()
    solution = solve_conic(form, "ecos")
    np.testing.assert_allclose(solution.z[:2], [1.0, np.sqrt(3.0)], atol=1e-6)
    upper.evaluator().UpdateCoefficients(np.array([[1.0, 1.0]]), [-np.inf], [1.0])
    with pytest.raises(ValueError, match="outside the binding's pattern"):
        form.refresh()
    upper.evaluator().UpdateCoefficients(np.array([[1.0, 0.0]]), [0.0], [1.0])
    with pytest.raises(ValueError, match="finite bounds changed"):
        form.refresh()


def test_a_program_the_form_cannot_write_is_refused():
    prog = MathematicalProgram()
    x = prog.NewContinuousVariables(2, "x")
    prog.AddQuadraticCost(np.eye(2), np.zeros(2), x)
    with pytest.raises(ValueError, match="not linear"):
        ConicForm(prog)


def _socp_data(config, N, seed):
    from pydrake.common.eigen_geometry import Quaternion
    from pydrake.math import RotationMatrix

    x0, prediction = sample_sec_vib_start(np.random.default_rng(seed), config)
    R_LT = np.array(
        [RotationMatrix(Quaternion(q / np.linalg.norm(q))).matrix() for q in prediction.q_LT[:N]]
    )
    p_star, v_star = terminal_targets(
        config, R_LT[-1], prediction.w_IT_T[N - 1], float(prediction.n_orbit)
    )
    return SocpData(x0, R_LT[max(0, N - config.docking_knots) :], p_star, v_star)


@pytest.mark.parametrize("N, feasible", [(100, True), (40, False)])
def test_problem_2_as_standard_form_is_drakes_problem(N, feasible):
    """Clarabel on the form takes Drake's Clarabel's iterations to its optimum (the same
    problem, row for row); ECOS and QOCO agree to 1e-6, and QOCO, which cannot prove
    infeasibility, ends an infeasible horizon at its iteration limit."""
    config = SoftCaptureConfig(socp_iterative_refinement=True)
    socp = SoftCaptureSocp(config, N, with_collision=False)
    socp.set_data(_socp_data(config, N, seed=7 if feasible else 1))
    drake = socp.solve()
    assert drake.success is feasible, drake.solver_status
    form = ConicForm(socp.prog)
    raw = solve_conic(form, "clarabel")
    assert raw.iterations == drake.iterations
    assert raw.status == ("solved" if feasible else "infeasible")
    for solver in ("ecos", "qoco"):
        other = solve_conic(form, solver)
        if feasible:
            assert other.status == "solved"
            assert other.cost * socp.cost_scale == pytest.approx(drake.cost, rel=1e-6)
        else:
            assert other.status == ("infeasible" if solver == "ecos" else "iteration_limit")


def test_problem_3_solved_by_ecos_and_qoco_through_the_planner_setting():
    """socp_solver: the SCP step's program (collision rows, (FOV-i) cones rewritten per
    linearisation) by ECOS and QOCO reaches Clarabel's optimum."""
    base = SoftCaptureConfig()
    N = 60
    data = _socp_data(base, N, seed=3)
    problem2 = SoftCaptureSocp(base, N, with_collision=False)
    problem2.set_data(data)
    first = problem2.solve()
    assert first.success
    r = first.x[:, :3]
    alpha = np.full(N, 1.25)  # below alpha_min = 1.3: the rows bind, the optimum depends on J
    linearisations = [np.tile([0.1, -0.05, 0.08], (N, 1)), np.tile([0.3, 0.2, -0.1], (N, 1))]
    for J in linearisations:
        J[0] = 0.0
    costs = {}
    for solver in ("clarabel", "ecos", "qoco"):
        problem3 = SoftCaptureSocp(dataclasses.replace(base, socp_solver=solver), N, True)
        costs[solver] = []
        for J in linearisations:  # the second solve must read the rewritten rows
            problem3.set_data(data)
            problem3.set_linearisation(alpha, J, r)
            solution = problem3.solve()
            assert solution.success, (solver, solution.solver_status)
            costs[solver].append(solution.cost)
        assert solution.solver == {"clarabel": "Clarabel", "ecos": "ECOS", "qoco": "QOCO"}[solver]
    assert costs["clarabel"][0] != pytest.approx(costs["clarabel"][1], rel=1e-3)
    assert costs["ecos"] == pytest.approx(costs["clarabel"], rel=1e-6)
    assert costs["qoco"] == pytest.approx(costs["clarabel"], rel=1e-6)


def test_a_dynamic_evaluator_foreign_to_the_program_is_refused():
    prog = _disc_program()[0]
    foreign = _disc_program()[1]  # another program's cone
    with pytest.raises(ValueError, match="not one of the program's"):
        ConicForm(prog, dynamic=[foreign.evaluator()])
