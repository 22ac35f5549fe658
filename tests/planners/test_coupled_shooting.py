"""Tests of rpod.planners.coupled_shooting (the vectorised RK4 transcription and its
complex-step derivatives) and of rpod.models.coupled_relative's batched dynamics.

Independent references: the scalar-generic model `coupled_relative.dynamics` (the reference
implementation), `coupled_nmpc.interval_defect` evaluated on AutoDiffXd (exact derivatives by a
different mechanism), and central finite differences.
"""

import numpy as np
import pytest
from pydrake.autodiffutils import ExtractGradient, ExtractValue, InitializeAutoDiff

from rpod.models import coupled_relative as cr
from rpod.planners import coupled_nmpc as cn
from rpod.planners import coupled_shooting as cs

H, SUBSTEPS, N = 60.0, 2, 4


@pytest.fixture(scope="module")
def problem():
    params = cr.CoupledRelativeParams(J_t=np.diag([1.0, 1.6, 2.1]))  # a torque-free tumble
    weights = cr.CoupledNmpcWeights()
    x0 = cr.sec_iv_initial_state(params)
    rng = np.random.default_rng(3)
    nodes = np.tile(x0[: cs.NX], (N + 1, 1))
    nodes[:, cr.W_TC_T_SLICE] += 3e-3 * rng.standard_normal((N + 1, 3))
    nodes[:, cr.P_PTPC_T_SLICE] += rng.standard_normal((N + 1, 3))
    nodes[:, cr.XI_T_SLICE] = 1e3 * rng.standard_normal((N + 1, 3))
    u = 0.5 * rng.standard_normal((N, cr.INPUT_SIZE))
    target = cs.target_reference(x0, N, H, SUBSTEPS, params)
    return params, weights, x0, nodes, u, target


def test_batched_dynamics_equals_the_reference_model(problem):
    params, _, x0, nodes, u, target = problem
    x = np.hstack([nodes[:N], target[:N]])
    reference = np.stack([cr.dynamics(x[k], u[k], params) for k in range(N)])
    np.testing.assert_allclose(cr.dynamics_batch(x, u, params), reference, rtol=1e-13, atol=0)
    np.testing.assert_array_equal(
        cr.target_dynamics(x0[cs.NX :], params), cr.dynamics(x0, u[0], params)[cs.NX :]
    )


def test_shoot_equals_interval_defect_values_and_autodiff_jacobians(problem):
    params, weights, _, nodes, u, target = problem
    shooting = cs.shoot(nodes, u, target, H, SUBSTEPS, params, weights)
    gradient = cs.cost_gradient(shooting, u, weights, params)
    for k in range(N):
        z = np.concatenate([nodes[k], u[k], nodes[k + 1], [0.0]])
        defect = cn.interval_defect(
            InitializeAutoDiff(z).reshape(-1), target[k], H, SUBSTEPS, params, weights
        )
        value, J = ExtractValue(defect).reshape(-1), ExtractGradient(defect)
        # defect = [x_k+1 - Phi; c_k - q]: Phi and q, and their Jacobians, are minus these.
        np.testing.assert_allclose(
            shooting.x_end[k], nodes[k + 1] - value[: cs.NX], rtol=1e-12, atol=1e-14
        )
        assert shooting.q[k] == pytest.approx(-value[cs.NX], rel=1e-13)
        scale = np.max(np.abs(J[: cs.NX, : cs.NZ]))
        np.testing.assert_allclose(shooting.A[k], -J[: cs.NX, : cs.NX], atol=1e-12 * scale)
        np.testing.assert_allclose(shooting.B[k], -J[: cs.NX, cs.NX : cs.NZ], atol=1e-12 * scale)
        np.testing.assert_allclose(
            gradient[k], -J[cs.NX, : cs.NZ], atol=1e-12 * np.max(np.abs(J[cs.NX]))
        )


def test_complex_step_jacobian_agrees_with_central_differences(problem):
    params, weights, _, nodes, u, target = problem
    shooting = cs.shoot(nodes[:2], u[:1], target, H, SUBSTEPS, params, weights)
    J = np.hstack([shooting.A[0], shooting.B[0]])
    for j in range(cs.NZ):
        step = 1e-6 * max(1.0, abs(np.concatenate([nodes[0], u[0]])[j]))
        plus_x, minus_x = nodes[:1].copy(), nodes[:1].copy()
        plus_u, minus_u = u[:1].copy(), u[:1].copy()
        if j < cs.NX:
            plus_x[0, j] += step
            minus_x[0, j] -= step
        else:
            plus_u[0, j - cs.NX] += step
            minus_u[0, j - cs.NX] -= step
        fd = (
            cs.shoot(plus_x, plus_u, target, H, SUBSTEPS, params, weights, False).x_end[0]
            - cs.shoot(minus_x, minus_u, target, H, SUBSTEPS, params, weights, False).x_end[0]
        ) / (2.0 * step)
        # Central differences: truncation ~step^2, round-off ~eps |x| / step.
        np.testing.assert_allclose(J[:, j], fd, rtol=1e-5, atol=1e-6 * np.max(np.abs(J)))


def test_stage_points_carry_the_quadrature(problem):
    params, weights, _, nodes, u, target = problem
    shooting = cs.shoot(nodes, u, target, H, SUBSTEPS, params, weights, derivatives=False)
    assert shooting.stage_weights.sum() == pytest.approx(H, rel=1e-15)
    # The first stage point of each interval is its node.
    np.testing.assert_array_equal(shooting.stage_x[:, 0], nodes[:N])
    F = [
        [
            cr.stage_cost(
                np.concatenate([shooting.stage_x[k, j], target[k]]), u[k], weights, params
            )
            for j in range(4 * SUBSTEPS)
        ]
        for k in range(N)
    ]
    np.testing.assert_allclose(np.asarray(F) @ shooting.stage_weights, shooting.q, rtol=1e-13)


def test_target_reference_stays_on_so3_and_follows_the_model(problem):
    params, _, x0, _, _, target = problem
    R = target[:, :9].reshape(-1, 3, 3)
    np.testing.assert_allclose(
        np.einsum("kji,kjl->kil", R, R), np.broadcast_to(np.eye(3), R.shape), atol=1e-14
    )
    # One interval by the scalar reference RK4 (no projection) agrees to its SO(3) drift.
    x_end, _ = cn.rk4_interval(
        x0, np.zeros(cr.INPUT_SIZE), H, SUBSTEPS, params, cr.CoupledNmpcWeights()
    )
    np.testing.assert_allclose(target[1, 9:], x_end[cs.NX + 9 :], rtol=1e-12)
    # R_IT: the projection removes RK4's drift off SO(3), 2e-6 over one interval here.
    np.testing.assert_allclose(target[1, :9], x_end[cs.NX : cs.NX + 9], atol=1e-5)


def test_batch_projection_matches_the_single_one():
    rng = np.random.default_rng(0)
    R = np.eye(3) + 0.05 * rng.standard_normal((5, 3, 3))
    expected = np.stack([cs.project_to_so3(M) for M in R])
    np.testing.assert_allclose(cs.project_to_so3_batch(R), expected, atol=1e-14)
