"""Tests of the wrench allocation (paper 003 eq. 14): rpod.models.thrusters.allocate_duty and
rpod.systems.allocator.WrenchAllocator.

Truths: (1) a feasible wrench w = B u_true must be reproduced exactly (1e-9 relative: bvls and
the polished LP vertex are exact up to round-off, ~1e-15; 1e-9 leaves margin for conditioning);
(2) on infeasible wrenches the KKT conditions of min ||W(Bu - w)||^2, 0 <= u <= 1 must hold,
checked here independently from the gradient g = B^T W^2 (B u - w) (tolerance 1e-9 of the
gradient scale ||B^T W^2 w||); (3) a second solver (Drake's Clarabel QP, tolerance ~1e-8) reaches
the same optimal cost to 1e-6 relative; (4) among optimal allocations, the one returned uses
the least fuel (HiGHS LP on the optimal set, to 1e-7); (5) the fast `DutyAllocator` (behind
`allocate_duty`) gives the same fit as the former scipy implementation, kept as
`allocate_duty_reference`, to 1e-9 and never more fuel (1e-9, scaled costs), breaks exact fuel
ties by its documented rule (checked by a HiGHS LP), answers independently of call history, and
hands what it cannot certify to the reference (`fallback_count`).
"""

import numpy as np
import pytest
import scipy.optimize
from pydrake.solvers import ClarabelSolver, MathematicalProgram

from rpod.models.thrusters import (
    DutyAllocator,
    allocate_duty,
    allocate_duty_reference,
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


# ----------------------------------------------------------------------------- DutyAllocator
# The fast allocator (enumerated optimal LP bases + an active-set box least squares) against
# the scipy reference (bvls + HiGHS), kept in the model as `allocate_duty_reference`.


def _random_case(rng, B, kind):
    """A wrench of the given kind: 'feasible' (B u for u in the box, some thrusters off),
    'boundary' (just outside the box image) or 'infeasible' (far outside)."""
    n = B.shape[1]
    if kind == "feasible":
        return B @ (rng.uniform(0, 1, n) * (rng.uniform(size=n) < 0.7))
    scale = np.abs(B).sum(axis=1).max()
    if kind == "boundary":
        return B @ rng.uniform(0, 1, n) + rng.normal(size=6) * 0.05 * scale
    return rng.normal(size=6) * rng.choice([0.5, 2.0, 10.0]) * scale


@pytest.mark.parametrize("layout_fn", LAYOUTS)
def test_matches_the_reference_on_200_random_cases(layout_fn):
    # Same fit (to round-off), never more fuel (HiGHS's vertex is within ~1e-9 of optimal) and
    # KKT-optimal, over feasible, near-boundary and far infeasible wrenches, with and without
    # weights and mass-flow fuel costs. The fast path answers them all (no fallback).
    layout = layout_fn()
    B = wrench_matrix(layout)
    n = B.shape[1]
    rng = np.random.default_rng(7)
    allocators = {}
    unique_mismatch = 0
    for case in range(200):
        kind = ("feasible", "boundary", "infeasible")[case % 3]
        weighted = case % 2 == 1
        weights = rng.uniform(0.5, 5.0, 6) if weighted else None
        fuel_cost = layout.max_mass_flows_kg_s if case % 4 < 2 else None
        w = _random_case(rng, B, kind)
        key = (weighted, fuel_cost is None)
        if key not in allocators or weighted:
            allocators[key] = DutyAllocator(B, weights, fuel_cost)
        allocator = allocators[key]
        u = allocator.solve(w)
        u_ref = allocate_duty_reference(B, w, weights, fuel_cost=fuel_cost)
        W = np.ones(6) if weights is None else weights
        c = np.ones(n) if fuel_cost is None else fuel_cost / fuel_cost.max()
        scale = np.linalg.norm(W * w) + np.linalg.norm(W * (B @ u_ref))
        np.testing.assert_allclose(W * (B @ u), W * (B @ u_ref), rtol=0, atol=1e-9 * scale)
        assert c @ u <= c @ u_ref + 1e-9
        violation, kkt_scale = _kkt_violation(B, w, u, W)
        assert violation <= 1e-9 * kkt_scale
        if kind == "feasible":
            assert np.linalg.norm(B @ u - w) <= 1e-9 * np.linalg.norm(w)
        unique_mismatch += np.max(np.abs(u - u_ref)) > 1e-8
        assert allocator.fallback_count == 0
    if layout_fn is rcs_cube_12:
        # Its random wrenches have a unique fuel-optimal allocation: the same u as HiGHS.
        # (planar_8 has exact ties, e.g. pure torque from thrusters 0+4 or 3+7; see below.)
        assert unique_mismatch == 0


def test_ties_follow_the_documented_rule_and_not_the_call_history():
    # planar_8, pure torque tau_z: thrusters {0, 4} or {3, 7} (or any mix) give it with the same
    # fuel. The documented rule picks the least sum_k sqrt(p_k) u_k among the fuel-optimal u
    # (p_k the k-th prime), checked by an independent HiGHS LP on the fuel-optimal set.
    B = wrench_matrix(planar_8())
    n = B.shape[1]
    c2 = np.sqrt([2.0, 3.0, 5.0, 7.0, 11.0, 13.0, 17.0, 19.0])
    rng = np.random.default_rng(3)
    wrenches = [np.array([0, 0, 0.004, 0, 0, 0])] + [
        _random_case(rng, B, kind) for kind in ("feasible", "infeasible") * 10
    ]
    for w in wrenches:
        u = allocate_duty(B, w)
        y = B @ u  # the optimal wrench (unique)
        fuel = scipy.optimize.linprog(
            np.ones(n), A_eq=B[[2, 3, 4]], b_eq=y[[2, 3, 4]], bounds=(0, 1), method="highs"
        ).fun
        best = scipy.optimize.linprog(
            c2,
            A_ub=np.ones((1, n)),
            b_ub=[fuel + 1e-12],
            A_eq=B[[2, 3, 4]],
            b_eq=y[[2, 3, 4]],
            bounds=(0, 1),
            method="highs",
        )
        assert best.status == 0
        assert u.sum() <= fuel + 1e-9
        np.testing.assert_allclose(u, best.x, atol=1e-6)
    # tau_z = 0.004 N m from thrusters 0 and 4 (0.15 m x 0.03 N each): 4/9 each, as
    # sqrt(2) + sqrt(11) < sqrt(7) + sqrt(19).
    np.testing.assert_allclose(
        allocate_duty(B, wrenches[0]), np.array([1, 0, 0, 0, 1, 0, 0, 0]) * 4 / 9, atol=1e-12
    )
    # Bit-identical answers whatever was solved before (a fresh allocator, reversed order).
    first = [DutyAllocator(B).solve(w) for w in wrenches]
    shared = DutyAllocator(B)
    later = [shared.solve(w) for w in reversed(wrenches)][::-1]
    for a, b in zip(first, later):
        np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("layout_fn", LAYOUTS)
def test_without_fuel_tie_break_infeasible_wrenches_are_still_optimal(layout_fn):
    B = wrench_matrix(layout_fn())
    rng = np.random.default_rng(11)
    allocator = DutyAllocator(B)
    for _ in range(30):
        w = _random_case(rng, B, "infeasible")
        u = allocator.solve(w, minimize_fuel=False)
        violation, scale = _kkt_violation(B, w, u, np.ones(6))
        assert violation <= 1e-9 * scale
        cost = np.sum((B @ u - w) ** 2)
        assert cost == pytest.approx(_clarabel_cost(B, w, np.ones(6)), rel=1e-6)
        np.testing.assert_array_equal(u, allocator.solve(w, minimize_fuel=False))  # repeatable
    assert allocator.fallback_count == 0


def test_zero_weights_ignore_those_components():
    # Forces only: torques are free, so any force within reach is exact and fuel-minimal.
    layout = rcs_cube_12()
    B = wrench_matrix(layout)
    weights = np.array([0.0, 0.0, 0.0, 1.0, 1.0, 1.0])
    allocator = DutyAllocator(B, weights)
    assert allocator.rank == 3
    rng = np.random.default_rng(5)
    for kind in ("feasible", "infeasible") * 10:
        w = _random_case(rng, B, kind)
        u = allocator.solve(w)
        u_ref = allocate_duty_reference(B, w, weights)
        np.testing.assert_allclose(B[3:] @ u, B[3:] @ u_ref, atol=1e-9 * np.linalg.norm(w))
        assert u.sum() <= u_ref.sum() + 1e-9
    assert allocator.fallback_count == 0


def test_fallback_to_the_reference_when_the_fast_path_cannot_certify():
    B = wrench_matrix(rcs_cube_12())
    rng = np.random.default_rng(9)
    feasible = _random_case(rng, B, "feasible")
    infeasible = _random_case(rng, B, "infeasible")
    # Too many candidate bases to enumerate (a big custom layout): the scipy path, verbatim.
    big = DutyAllocator(B, max_bases=0)
    assert big.basis_count == 0
    for w in (feasible, infeasible):
        np.testing.assert_array_equal(big.solve(w), allocate_duty_reference(B, w))
    assert big.fallback_count == 2
    # The active-set iteration cap hit: only the infeasible wrench needs that stage.
    capped = DutyAllocator(B)
    capped._max_ls_iterations = 0
    capped.solve(feasible)
    assert capped.fallback_count == 0
    np.testing.assert_array_equal(capped.solve(infeasible), allocate_duty_reference(B, infeasible))
    np.testing.assert_array_equal(
        capped.solve(infeasible, minimize_fuel=False),
        allocate_duty_reference(B, infeasible, minimize_fuel=False),
    )
    assert capped.fallback_count == 2


def test_degenerate_inputs():
    B = wrench_matrix(rcs_cube_12())
    allocator = DutyAllocator(B)
    np.testing.assert_array_equal(allocator.solve(np.zeros(6)), np.zeros(12))
    np.testing.assert_array_equal(allocator.solve([np.inf, 0, 0, 0, 0, 0]), np.zeros(12))
    # A tiny feasible wrench is still exact relative to its size.
    w = B @ np.r_[1e-9, np.zeros(11)]
    assert np.linalg.norm(B @ allocator.solve(w) - w) <= 1e-9 * np.linalg.norm(w)
    np.testing.assert_array_equal(DutyAllocator(np.zeros((6, 4))).solve(np.ones(6)), 0.0)
    with pytest.raises(ValueError, match="fuel_cost"):
        DutyAllocator(B, fuel_cost=np.zeros(12))
    with pytest.raises(ValueError, match="weights"):
        DutyAllocator(B, weights=np.array([1, 1, 1, 1, 1, np.nan]))
    with pytest.raises(ValueError, match="B must be"):
        DutyAllocator(np.ones(6))


def test_system_without_fuel_tie_break_equals_the_model():
    layout = planar_8()
    allocator = WrenchAllocator(layout, minimize_fuel=False)
    context = allocator.CreateDefaultContext()
    w = np.array([0.0, 0.0, 0.02, 0.5, -0.4, 0.0])  # beyond reach: saturates
    allocator.get_input_port().FixValue(context, w)
    u = allocator.get_output_port().Eval(context)
    B = wrench_matrix(layout)
    np.testing.assert_array_equal(u, DutyAllocator(B).solve(w, minimize_fuel=False))
    violation, scale = _kkt_violation(B, w, u, np.ones(6))
    assert violation <= 1e-9 * scale
    assert allocator.solver.fallback_count == 0
