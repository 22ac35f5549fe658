"""rpod.planners.soft_capture_socp in units: the same statuses and optima as the program in SI
(Problems 2 and 3, feasible and infeasible horizons), in fewer iterations, and without
Clarabel's iterative refinement as with it."""

import dataclasses

import numpy as np
import pytest
from test_conic_form import _socp_data

from rpod.planners.soft_capture import SoftCaptureConfig
from rpod.planners.soft_capture_socp import SoftCaptureSocp

SI = SoftCaptureConfig(socp_scaled=False, socp_iterative_refinement=True)
VARIANTS = {
    "units": dataclasses.replace(SI, socp_scaled=True),
    "units, unrefined": dataclasses.replace(SI, socp_scaled=True, socp_iterative_refinement=False),
}


@pytest.mark.parametrize("N, seeds", [(100, range(7, 11)), (40, range(4))])
def test_problem_2_in_units_is_the_problem_in_si(N, seeds):
    programs = {name: SoftCaptureSocp(config, N, False) for name, config in VARIANTS.items()}
    reference = SoftCaptureSocp(SI, N, False)
    fewer = 0
    for seed in seeds:
        data = _socp_data(SI, N, seed)
        reference.set_data(data)
        expected = reference.solve()
        for program in programs.values():
            program.set_data(data)
            solution = program.solve()
            assert solution.solution_result == expected.solution_result
            if expected.success:
                assert solution.cost == pytest.approx(expected.cost, rel=1e-6)
                # Every constraint in SI, on the returned (SI) solution: the units undone.
                assert np.linalg.norm(solution.x[:, 3:], axis=1).max() <= SI.max_speed_m_s + 1e-6
                assert np.linalg.norm(solution.u, axis=1).max() <= SI.max_thrust_N + 1e-6
                assert np.all(np.linalg.norm(solution.x[:, :3], axis=1) <= solution.rho + 1e-6)
                np.testing.assert_allclose(solution.x[0], data.x0, atol=1e-7)
                gap = np.linalg.norm(solution.x[-1, :3] - data.p_terminal_L)
                assert gap <= SI.capture_position_tol_m + 1e-6
            fewer += solution.iterations < expected.iterations
    assert fewer >= len(seeds)  # most solves in units take fewer iterations (2 per seed)


def test_problem_3_in_units_is_the_problem_in_si():
    N = 60
    data = _socp_data(SI, N, seed=3)
    first = SoftCaptureSocp(SI, N, False)
    first.set_data(data)
    r = first.solve().x[:, :3]
    alpha = np.full(N, 1.2)  # below alpha_min: the slacks are active
    J = np.tile([0.05, -0.02, 0.03], (N, 1))
    J[0] = 0.0
    costs = []
    for config in (SI, *VARIANTS.values()):
        program = SoftCaptureSocp(config, N, True)
        program.set_data(data)
        program.set_linearisation(alpha, J, r)
        solution = program.solve()
        assert solution.success
        costs.append(solution.cost)
        assert solution.slack.max() > 0.0
    assert costs[1:] == pytest.approx([costs[0]] * 2, rel=1e-6)
