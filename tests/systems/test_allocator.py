"""Tests of the wrench allocation (paper 003 eq. 14): rpod.models.thrusters.allocate_duty and
rpod.systems.allocator.WrenchAllocator.

Truths: (1) a feasible wrench w = B u_true must be reproduced exactly (1e-9 relative: bvls and
the polished LP vertex are exact up to round-off, ~1e-15; 1e-9 leaves margin for conditioning);
(2) on infeasible wrenches the KKT conditions of min ||W(Bu - w)||^2, 0 <= u <= 1 must hold,
checked here independently from the gradient g = B^T W^2 (B u - w) (tolerance 1e-9 of the
gradient scale ||B^T W^2 w||); (3) a second solver (Drake's Clarabel QP, tolerance ~1e-8) reaches
the same optimal cost to 1e-6 relative; (4) among optimal allocations, the one returned uses
the least fuel (HiGHS LP on the optimal set, to 1e-7).
"""

import numpy as np
import pytest
import scipy.optimize
from pydrake.solvers import ClarabelSolver, MathematicalProgram

from rpod.models.thrusters import (
    allocate_duty,
    gimbaled_cuboid_8,
    planar_8,
    rcs_cube_12,
    wrench_matrix,
)
from rpod.systems.allocator import WrenchAllocator

LAYOUTS = [rcs_cube_12, planar_8]


def _kkt_violation(B, w, u, weights):
    """Largest violation of the box-constrained LS optimality conditions, and the scale."""
    W2 = np.asarray(weights) ** 2
    g = B.T @ (W2 * (B @ u - w))
    scale = np.linalg.norm(B.T @ (W2 * w)) + 1e-300
    viol = np.where(
        u <= 1e-12, np.maximum(-g, 0.0), np.where(u >= 1 - 1e-12, np.maximum(g, 0.0), np.abs(g))
    )
    assert np.all(u >= 0.0) and np.all(u <= 1.0)
    return np.max(viol), scale


def _clarabel_cost(B, w, weights):
    """Optimal cost of the same problem from Drake's Clarabel solver (independent of scipy)."""
    prog = MathematicalProgram()
    u = prog.NewContinuousVariables(B.shape[1], "u")
    Bw, ww = weights[:, None] * B, weights * w
    prog.AddQuadraticCost(2 * Bw.T @ Bw, -2 * Bw.T @ ww, ww @ ww, u, is_convex=True)
    prog.AddBoundingBoxConstraint(0.0, 1.0, u)
    result = ClarabelSolver().Solve(prog)
    assert result.is_success()
    return result.get_optimal_cost()


@pytest.mark.parametrize("layout_fn", LAYOUTS)
def test_feasible_wrenches_are_exact_and_fuel_optimal(layout_fn):
    B = wrench_matrix(layout_fn())
    n = B.shape[1]
    rng = np.random.default_rng(0)
    for _ in range(40):
        u_true = rng.uniform(0, 1, n) * (rng.uniform(size=n) < 0.7)
        w = B @ u_true
        u = allocate_duty(B, w)
        assert np.all((u >= 0) & (u <= 1))
        assert np.linalg.norm(B @ u - w) <= 1e-9 * np.linalg.norm(w)
        # Least fuel among all exact allocations: an LP over {u : B u = w, 0 <= u <= 1}.
        lp = scipy.optimize.linprog(np.ones(n), A_eq=B, b_eq=w, bounds=(0, 1), method="highs")
        assert u.sum() <= lp.fun + 1e-7
        assert u.sum() <= u_true.sum() + 1e-9
        # Without the tie-break the fit is still exact.
        u_plain = allocate_duty(B, w, minimize_fuel=False)
        assert np.linalg.norm(B @ u_plain - w) <= 1e-9 * np.linalg.norm(w)


@pytest.mark.parametrize("layout_fn", LAYOUTS)
@pytest.mark.parametrize("weighted", [False, True])
def test_infeasible_wrenches_are_optimal(layout_fn, weighted):
    B = wrench_matrix(layout_fn())
    n = B.shape[1]
    rng = np.random.default_rng(1)
    weights = rng.uniform(0.5, 5.0, 6) if weighted else np.ones(6)
    for _ in range(15):
        # Far outside the reachable box: ~5x the full-on wrench along random directions.
        w = rng.normal(size=6) * 5.0 * np.abs(B).sum(axis=1).max()
        u = allocate_duty(B, w, weights if weighted else None)
        violation, scale = _kkt_violation(B, w, u, weights)
        assert violation <= 1e-9 * scale
        cost = np.sum((weights * (B @ u - w)) ** 2)
        assert cost > 1e-3 * np.sum((weights * w) ** 2)  # really infeasible
        assert cost == pytest.approx(_clarabel_cost(B, w, weights), rel=1e-6)
        # Perturbing u inside the box never lowers the cost (a direct optimality spot check).
        for _ in range(20):
            v = np.clip(u + rng.normal(0, 1e-3, n), 0, 1)
            assert np.sum((weights * (B @ v - w)) ** 2) >= cost - 1e-12 * cost


def test_bad_weights_and_nan_wrench():
    B = wrench_matrix(rcs_cube_12())
    with pytest.raises(ValueError, match="weights"):
        allocate_duty(B, np.zeros(6), -np.ones(6))
    np.testing.assert_array_equal(allocate_duty(B, np.full(6, np.nan)), np.zeros(12))


def test_system_ports_and_output_equal_the_function():
    layout = rcs_cube_12()
    weights = np.array([2.0, 2.0, 2.0, 1.0, 1.0, 1.0])
    allocator = WrenchAllocator(layout, weights)
    assert allocator.GetInputPort("body_wrench_desired").size() == 6
    assert allocator.GetOutputPort("thruster_duty").size() == 12
    assert allocator.HasDirectFeedthrough(0, 0)
    np.testing.assert_array_equal(allocator.wrench_matrix, wrench_matrix(layout))
    context = allocator.CreateDefaultContext()
    w = np.array([1.0, -2.0, 0.5, 3.0, 0.0, -4.0])
    allocator.get_input_port().FixValue(context, w)
    u = allocator.get_output_port().Eval(context)
    B = wrench_matrix(layout)
    np.testing.assert_allclose(B @ u, w, atol=1e-12 * np.linalg.norm(w))  # feasible: exact
    np.testing.assert_allclose(
        u, allocate_duty(B, w, weights, fuel_cost=layout.max_mass_flows_kg_s), atol=0
    )
    with pytest.raises(ValueError, match="fixed layout"):
        WrenchAllocator(gimbaled_cuboid_8())
