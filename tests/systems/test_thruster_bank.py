"""Tests of rpod.systems.thruster_bank.ThrusterBank: ports, wrench = model, clipping, caching.

Tolerances: the system applies the same few flops as the model functions in a different order
(matrix product vs. sum of cross products), so outputs agree to 1e-12 relative.
"""

import numpy as np
import pytest
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import Integrator, ZeroOrderHold

from rpod.models.gimbal import clip_gimbaled_forces, wrench_from_forces
from rpod.models.thrusters import (
    STANDARD_GRAVITY_M_S2,
    gimbaled_cuboid_8,
    planar_8,
    rcs_cube_12,
    wrench_matrix,
)
from rpod.systems.thruster_bank import ThrusterBank

RTOL = 1e-12


def _evaluate(bank, command):
    context = bank.CreateDefaultContext()
    bank.get_input_port(0).FixValue(context, command)
    return (
        bank.GetOutputPort("body_wrench").Eval(context),
        bank.GetOutputPort("propellant_mass_flow").Eval(context),
        bank.GetOutputPort("command_clipped").Eval(context),
    )


@pytest.mark.parametrize(
    "layout_fn, n, command_size",
    [
        (rcs_cube_12, 12, 12),
        (planar_8, 8, 8),
        (gimbaled_cuboid_8, 8, 24),
    ],
)
def test_ports_and_structure(layout_fn, n, command_size):
    bank = ThrusterBank(layout_fn())
    assert bank.num_input_ports() == 1 and bank.num_output_ports() == 3
    assert bank.GetInputPort("thruster_command").size() == command_size
    assert bank.GetOutputPort("body_wrench").size() == 6
    assert bank.GetOutputPort("propellant_mass_flow").size() == 1
    assert bank.GetOutputPort("command_clipped").size() == n
    context = bank.CreateDefaultContext()
    assert context.num_continuous_states() == 0 and context.num_discrete_state_groups() == 0
    for k in range(3):
        assert bank.HasDirectFeedthrough(0, k)


def test_fixed_layout_wrench_and_mass_flow_equal_the_model():
    layout = rcs_cube_12()
    bank = ThrusterBank(layout)
    rng = np.random.default_rng(0)
    for _ in range(20):
        u = rng.uniform(0, 1, 12)
        wrench, mdot, clipped = _evaluate(bank, u)
        np.testing.assert_allclose(wrench, wrench_matrix(layout) @ u, rtol=RTOL, atol=1e-12)
        # mdot = sum u_k f_max / (Isp g0), written out.
        expected = np.sum(u * 10.0) / (220.0 * STANDARD_GRAVITY_M_S2)
        assert mdot[0] == pytest.approx(expected, rel=RTOL)
        assert np.all(clipped == 0.0)


def test_fixed_layout_clips_and_reports():
    layout = planar_8()
    bank = ThrusterBank(layout)
    command = np.array([1.5, -0.2, np.nan, 0.5, 1.0 + 1e-12, 0.0, 1.0, 0.25])
    applied = np.array([1.0, 0.0, 0.0, 0.5, 1.0, 0.0, 1.0, 0.25])
    wrench, mdot, clipped = _evaluate(bank, command)
    np.testing.assert_allclose(wrench, wrench_matrix(layout) @ applied, rtol=RTOL, atol=1e-15)
    expected_mdot = applied.sum() * 0.03 / (220.0 * STANDARD_GRAVITY_M_S2)
    assert mdot[0] == pytest.approx(expected_mdot, rel=RTOL)
    # 1 + 1e-12 is clipped but below the 1e-6 report tolerance (solver round-off).
    np.testing.assert_array_equal(clipped, [1, 1, 1, 0, 0, 0, 0, 0])


def test_fixed_layout_in_range_commands_take_the_fast_path_unchanged():
    # PWM on/off patterns, the exact bounds and interior levels: applied bit for bit (the
    # wrench is the same matrix product on the same vector), nothing reported. A single
    # out-of-range or non-finite entry still goes through the clipping path.
    layout = rcs_cube_12()
    B = wrench_matrix(layout)
    bank = ThrusterBank(layout)
    context = bank.CreateDefaultContext()
    port = bank.get_input_port(0)
    rng = np.random.default_rng(5)
    commands = [np.zeros(12), np.ones(12), (rng.uniform(size=12) < 0.4).astype(float)]
    commands += [rng.uniform(0, 1, 12) for _ in range(5)]
    for u in commands:
        port.FixValue(context, u)
        np.testing.assert_array_equal(bank.GetOutputPort("body_wrench").Eval(context), B @ u)
        np.testing.assert_array_equal(bank.GetOutputPort("command_clipped").Eval(context), 0.0)
        mdot = bank.GetOutputPort("propellant_mass_flow").Eval(context)[0]
        assert mdot == pytest.approx(np.sum(u) * 10.0 / (220.0 * STANDARD_GRAVITY_M_S2), rel=RTOL)
    for bad, applied in ((np.inf, 1.0), (-np.inf, 0.0), (1.5, 1.0), (-1e-3, 0.0)):
        u = np.full(12, 0.5)
        u[7] = bad
        port.FixValue(context, u)
        expected = np.full(12, 0.5)
        expected[7] = applied
        np.testing.assert_array_equal(bank.GetOutputPort("body_wrench").Eval(context), B @ expected)
        np.testing.assert_array_equal(
            bank.GetOutputPort("command_clipped").Eval(context), np.eye(12)[7]
        )


def test_gimbaled_layout_feasible_forces_pass_unchanged():
    layout = gimbaled_cuboid_8()
    bank = ThrusterBank(layout)
    rng = np.random.default_rng(1)
    # Feasible: scaled nominal directions (0-20 N), plus a small tilt well inside pi/4.
    F = layout.directions_C * rng.uniform(0, 19.0, (8, 1)) + rng.normal(0, 0.5, (8, 3)) * 0.1
    assert np.all(clip_gimbaled_forces(layout, F)[1] == 0.0)
    wrench, mdot, clipped = _evaluate(bank, F.ravel())
    # Independent sum of p x f + f with numpy's cross, and mass flow sum |f| / (Isp g0).
    expected = sum(np.r_[np.cross(p, f), f] for p, f in zip(layout.p_CK_C, F))
    np.testing.assert_allclose(wrench, expected, rtol=RTOL, atol=1e-12)
    assert mdot[0] == pytest.approx(
        np.sum(np.linalg.norm(F, axis=1)) / (220.0 * STANDARD_GRAVITY_M_S2), rel=RTOL
    )
    assert np.all(clipped == 0.0)


def test_gimbaled_layout_clips_and_reports():
    layout = gimbaled_cuboid_8()
    bank = ThrusterBank(layout)
    F = 10.0 * layout.directions_C
    F[1] *= 3.0  # 30 N > 20 N: scaled to 20 N
    F[4] = -F[4]  # backwards: zero
    F[6] = np.array([np.inf, 0.0, 0.0])  # non-finite: zero
    wrench, mdot, clipped = _evaluate(bank, F.ravel())
    F_applied = F.copy()
    F_applied[1] = 20.0 * layout.directions_C[1]
    F_applied[4] = 0.0
    F_applied[6] = 0.0
    np.testing.assert_allclose(wrench, wrench_from_forces(layout, F_applied), rtol=RTOL, atol=1e-12)
    assert mdot[0] == pytest.approx((5 * 10.0 + 20.0) / (220.0 * STANDARD_GRAVITY_M_S2), rel=RTOL)
    np.testing.assert_array_equal(clipped, [0, 1, 0, 0, 1, 0, 1, 0])
    # The applied wrench never exceeds what 8 thrusters at 20 N can give: |f_C| <= 160 N.
    assert np.linalg.norm(wrench[3:]) <= 160.0


class _CountingBank(ThrusterBank):
    calls = 0

    def _calc_body_wrench(self, context, output):
        type(self).calls += 1
        super()._calc_body_wrench(context, output)


def test_outputs_are_cached_across_time_and_continuous_state_changes():
    # Fed by a sampled signal (ZeroOrderHold, as from a discrete controller) in a diagram with
    # unrelated continuous state: the wrench must not be recomputed when time or that state
    # changes (prerequisites = the input port only), and must be when the held input changes.
    # With Drake's default prerequisites (all sources) every change below would recompute.
    builder = DiagramBuilder()
    bank = builder.AddSystem(_CountingBank(rcs_cube_12()))
    hold = builder.AddSystem(ZeroOrderHold(0.1, 12))
    builder.Connect(hold.get_output_port(), bank.get_input_port(0))
    integrator = builder.AddSystem(Integrator(3))
    builder.ExportInput(integrator.get_input_port(0))
    builder.ExportInput(hold.get_input_port())
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()
    diagram.get_input_port(0).FixValue(context, np.ones(3))
    diagram.get_input_port(1).FixValue(context, np.zeros(12))
    hold_context = hold.GetMyMutableContextFromRoot(context)
    hold_context.SetDiscreteState(np.full(12, 0.5))
    bank_context = bank.GetMyContextFromRoot(context)
    port = bank.GetOutputPort("body_wrench")
    _CountingBank.calls = 0
    port.Eval(bank_context)
    for k in range(5):
        context.SetTime(0.1 * k)
        context.SetContinuousState(np.full(3, float(k)))
        port.Eval(bank_context)
    assert _CountingBank.calls == 1
    hold_context.SetDiscreteState(np.full(12, 0.25))
    np.testing.assert_allclose(
        port.Eval(bank_context), wrench_matrix(rcs_cube_12()) @ np.full(12, 0.25), atol=1e-12
    )
    assert _CountingBank.calls == 2
