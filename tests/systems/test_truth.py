"""Tests of rpod.systems.truth.Truth, the one-system truth, against independent references.

References (test-only, in tests/reference; conftest.py here puts the root on sys.path):
- `SplitTruth` (tests.reference.split_truth): the four systems the truth replaced
  (`OrbitalDynamics`, two `RigidBodyAttitude`, `ThrusterBank`), each tested on its own
  (tests/reference, tests/systems/test_thruster_bank.py), wired as the builder wired them.
  Derivatives and outputs must agree at random states, and a closed-loop run must reproduce the
  same trajectory, pulse pattern and propellant.
- The DOP853 reference of tests/reference/eci_reference.py (two-body + J2, both bodies
  integrated absolutely in ECI at rtol 1e-13): the bundled coast scenario, built and run
  through `build_diagram`, must stay within 1 mm of it over 3000 s.

Tolerances (and why):
- Derivatives and outputs: 1e-12 relative to each 3- or 4-vector's norm. Both sides compute the
  same formulas in double; they differ in the order of a few sums (matrix products vs. written
  out) and in normalising q_IC once instead of twice: a few ulps.
- Closed loop: the same integrator takes the same steps on derivatives equal to a few ulps, so
  the trajectories agree to round-off growth (measured 5e-14 m over 300 s); asserted 1e-9 m and
  1e-12 m/s. The PWM's ON/OFF pattern must be identical (a rounding could flip only if a duty
  fell within ~1e-13 of a half-slot boundary), and the propellant equal to 1e-12 relative.
"""

import dataclasses
import math

import numpy as np
import pytest

import rpod.diagrams.builder as builder_module
from rpod.diagrams.builder import build_diagram
from rpod.diagrams.simulate import simulate
from rpod.models.frames import quaternion_wxyz, rotation_from_rpy_deg
from rpod.models.gravity import R_EARTH_M
from rpod.models.orbit import OrbitConfig
from rpod.models.thrusters import planar_8, rcs_cube_12
from rpod.scenarios.loader import load_scenario
from rpod.systems.truth import STATE_SIZE, Truth
from tests.reference.eci_reference import eci_reference
from tests.reference.split_truth import SplitTruth

RTOL = 1e-12
GRAVITIES = ("two_body_j2", "two_body", "cw", "free_space")
J_T = np.array([[1200.0, 50.0, -30.0], [50.0, 1000.0, 20.0], [-30.0, 20.0, 800.0]])
J_C = np.array([[190.0, 3.0, -1.0], [3.0, 210.0, 2.0], [-1.0, 2.0, 170.0]])
STATE_OUTPUTS = {
    "target_state_I": 6,
    "chaser_state_I": 6,
    "relative_state_L": 6,
    "q_IL": 4,
    "w_IL_L": 3,
    "chaser_mass": 1,
    "target_attitude": 7,
    "chaser_attitude": 7,
}
THRUST_OUTPUTS = {"body_wrench": 6, "propellant_mass_flow": 1, "command_clipped": 12}


def _arguments(gravity="two_body_j2", layout=None):
    """Constructor arguments shared by Truth and SplitTruth."""
    orbit = OrbitConfig(inclination_deg=51.6, raan_deg=30.0, arg_latitude_deg=40.0, gravity=gravity)
    return (
        orbit,
        np.array([10.0, -100.0, 5.0]),
        np.array([0.01, 0.0, -0.02]),
        500.0,
        J_T,
        quaternion_wxyz(rotation_from_rpy_deg([10.0, -20.0, 90.0])),
        np.radians([0.5, 0.0, 1.0]),
        J_C,
        quaternion_wxyz(rotation_from_rpy_deg([0.0, 45.0, 30.0])),
        np.radians([0.1, -0.2, 0.3]),
        layout,
    )


def _pair(gravity, layout):
    """(Truth, its context, SplitTruth, its context), built from the same arguments."""
    fast = Truth(*_arguments(gravity, layout))
    split = SplitTruth(*_arguments(gravity, layout))
    return fast, fast.CreateDefaultContext(), split, split.CreateDefaultContext()


def _random_state(rng, gravity):
    """A random state: an orbit from 300 to 2000 km, eccentric and inclined at random, a chaser
    up to 1 km away, quaternions of norm 0.9 to 1.1 (the integrated quaternion is not exactly
    unit), rates up to 10 deg/s and a mass of 100 to 1000 kg."""
    radius = R_EARTH_M + rng.uniform(300e3, 2000e3)
    p = radius * _unit(rng.normal(size=3))
    speed = math.sqrt(3.986004418e14 / radius) * rng.uniform(0.9, 1.1)
    v = speed * _unit(np.cross(p, rng.normal(size=3))) + rng.normal(scale=50.0, size=3)
    if gravity == "free_space":
        p, v = np.zeros(3), np.zeros(3)
    relative = np.concatenate([rng.uniform(-1000, 1000, 3), rng.uniform(-1, 1, 3)])
    q_T = _unit(rng.normal(size=4)) * rng.uniform(0.9, 1.1)
    q_C = _unit(rng.normal(size=4)) * rng.uniform(0.9, 1.1)
    w_T, w_C = np.radians(rng.uniform(-10, 10, 3)), np.radians(rng.uniform(-10, 10, 3))
    mass = rng.uniform(100.0, 1000.0)
    return np.concatenate([p, v, relative, [mass], q_T, w_T, q_C, w_C])


def _unit(v):
    return v / np.linalg.norm(v)


def _random_command(rng, n):
    """ON/OFF, in-range levels, or levels out of range with a NaN (clipped and reported)."""
    kind = rng.integers(3)
    if kind == 0:
        return rng.integers(0, 2, n).astype(float)
    if kind == 1:
        return rng.uniform(0.0, 1.0, n)
    command = rng.uniform(-0.5, 1.5, n)
    command[rng.integers(n)] = np.nan
    return command


def _assert_close_by_blocks(new, old, blocks, what):
    """Each block (a 3- or 4-vector, or a scalar) agrees to RTOL of its own norm."""
    for block in blocks:
        scale = np.linalg.norm(old[block])
        np.testing.assert_allclose(
            new[block], old[block], rtol=0, atol=RTOL * scale + 1e-300, err_msg=f"{what} {block}"
        )


DERIVATIVE_BLOCKS = [slice(0, 3), slice(3, 6), slice(6, 9), slice(9, 12), slice(12, 13),
                     slice(13, 17), slice(17, 20), slice(20, 24), slice(24, 27)]  # fmt: skip


# ---- Structure. ----


@pytest.mark.parametrize("actuation", ["thrusters", "wrench_input", "none"])
def test_ports_state_and_feedthrough(actuation):
    with_thrusters = actuation == "thrusters"
    layout = rcs_cube_12() if with_thrusters else None
    truth = Truth(*_arguments(layout=layout), wrench_input=actuation == "wrench_input")
    outputs = STATE_OUTPUTS | (THRUST_OUTPUTS if with_thrusters else {})
    assert {truth.get_output_port(i).get_name(): truth.get_output_port(i).size()
            for i in range(truth.num_output_ports())} == outputs  # fmt: skip
    inputs = {"thrusters": {"thruster_command": 12}, "none": {},
              "wrench_input": {"body_wrench": 6, "propellant_mass_flow": 1}}[actuation]  # fmt: skip
    assert {truth.get_input_port(i).get_name(): truth.get_input_port(i).size()
            for i in range(truth.num_input_ports())} == inputs  # fmt: skip
    context = truth.CreateDefaultContext()
    assert context.num_continuous_states() == STATE_SIZE == 27
    assert context.num_discrete_state_groups() == 0 and context.num_abstract_states() == 0
    # Only the thruster outputs depend on an input; the state outputs (what controllers read)
    # do not, so closing the loop through the truth makes no algebraic loop.
    for i in range(truth.num_input_ports()):
        for o in range(truth.num_output_ports()):
            name = truth.get_output_port(o).get_name()
            assert truth.HasDirectFeedthrough(i, o) == (name in THRUST_OUTPUTS), name


def test_constructor_validation():
    arguments = list(_arguments())
    with pytest.raises(ValueError, match="gravity"):
        Truth(OrbitConfig(gravity="j4"), *arguments[1:])
    with pytest.raises(ValueError, match="triangle"):
        Truth(*arguments[:4], np.diag([1.0, 1.0, 3.0]), *arguments[5:])
    with pytest.raises(ValueError, match="quaternion"):
        Truth(*arguments[:5], np.zeros(4), *arguments[6:])
    gimbaled = rcs_cube_12()
    gimbaled.gimbaled = True
    with pytest.raises(ValueError, match="gimbaled"):
        Truth(*arguments[:10], gimbaled)
    with pytest.raises(ValueError, match="not both"):
        Truth(*arguments[:10], rcs_cube_12(), wrench_input=True)


# ---- Against the four systems it replaced. ----


@pytest.mark.parametrize("gravity", GRAVITIES)
def test_initial_state_and_outputs_equal_the_split_truth(gravity):
    layout = rcs_cube_12()
    fast, fast_context, split, split_context = _pair(gravity, layout)
    x_fast = fast_context.get_continuous_state_vector().CopyToVector()
    x_split = split_context.get_continuous_state_vector().CopyToVector()
    np.testing.assert_array_equal(x_fast, x_split)  # the same numbers in the same order
    command = np.linspace(0.0, 1.0, 12)
    fast.GetInputPort("thruster_command").FixValue(fast_context, command)
    split.GetInputPort("thruster_command").FixValue(split_context, command)
    for name in {**STATE_OUTPUTS, **THRUST_OUTPUTS}:
        np.testing.assert_array_equal(
            fast.GetOutputPort(name).Eval(fast_context),
            split.GetOutputPort(name).Eval(split_context),
            err_msg=name,
        )


@pytest.mark.parametrize("gravity", GRAVITIES)
@pytest.mark.parametrize("actuation", ["rcs_cube_12", "planar_8", "wrench_input"])
def test_derivatives_and_outputs_equal_the_split_truth_at_random_states(gravity, actuation):
    layout = {"rcs_cube_12": rcs_cube_12, "planar_8": planar_8}.get(actuation, lambda: None)()
    wrench_input = layout is None
    fast = Truth(*_arguments(gravity, layout), wrench_input=wrench_input)
    split = SplitTruth(*_arguments(gravity, layout), wrench_input=wrench_input)
    fast_context, split_context = fast.CreateDefaultContext(), split.CreateDefaultContext()
    fast_derivatives = fast.AllocateTimeDerivatives()
    split_derivatives = split.AllocateTimeDerivatives()
    outputs = dict(STATE_OUTPUTS)
    if not wrench_input:
        outputs |= THRUST_OUTPUTS | {"command_clipped": layout.count}
    rng = np.random.default_rng(GRAVITIES.index(gravity) * 10 + len(actuation))
    for _ in range(50):
        x = _random_state(rng, gravity)
        if wrench_input:
            inputs = {
                "body_wrench": rng.uniform(-20.0, 20.0, 6),
                "propellant_mass_flow": rng.uniform(0.0, 0.01, 1),
            }
        else:
            inputs = {"thruster_command": _random_command(rng, layout.count)}
        for system, context in ((fast, fast_context), (split, split_context)):
            context.SetContinuousState(x)
            for name, value in inputs.items():
                system.GetInputPort(name).FixValue(context, value)
        fast.CalcTimeDerivatives(fast_context, fast_derivatives)
        split.CalcTimeDerivatives(split_context, split_derivatives)
        new = fast_derivatives.CopyToVector()
        old = split_derivatives.CopyToVector()
        assert np.all(np.isfinite(new))
        _assert_close_by_blocks(new, old, DERIVATIVE_BLOCKS, f"{gravity} derivative")
        for name, size in outputs.items():
            blocks = [slice(i, min(i + 3, size)) for i in range(0, size, 3)]
            if name in ("q_IL", "target_attitude", "chaser_attitude"):
                blocks = [slice(0, 4)] + [slice(4, size)] * (size > 4)
            _assert_close_by_blocks(
                fast.GetOutputPort(name).Eval(fast_context),
                split.GetOutputPort(name).Eval(split_context),
                blocks,
                f"{gravity} output {name}",
            )


def test_an_on_off_pattern_seen_before_gives_the_same_thrust():
    """The thrust cache remembers ON/OFF patterns; a remembered one must equal a fresh one."""
    layout = rcs_cube_12()
    fast, context, split, split_context = _pair("two_body_j2", layout)
    derivatives = fast.AllocateTimeDerivatives()
    first = np.array([1.0, 0.0] * 6)
    for command in (first, np.ones(12), first.copy()):
        fast.GetInputPort("thruster_command").FixValue(context, command)
        split.GetInputPort("thruster_command").FixValue(split_context, command)
        fast.CalcTimeDerivatives(context, derivatives)
        for name in THRUST_OUTPUTS:
            np.testing.assert_array_equal(
                fast.GetOutputPort(name).Eval(context),
                split.GetOutputPort(name).Eval(split_context),
            )


# ---- Accuracy: the coast through the diagram the scenarios use. ----


def test_coast_scenario_within_1mm_of_the_dop853_reference_over_3000_s():
    _, coast = load_scenario("coast")
    assert coast.orbit.gravity == "two_body_j2" and not coast.thrusters.enabled
    scenario = dataclasses.replace(coast, duration_s=3000.0, log_period_s=300.0)
    assert isinstance(build_diagram(scenario)[1].orbital, Truth)
    log = simulate(scenario).log
    times = log["t"][1:]
    np.testing.assert_allclose(times, np.arange(300.0, 3000.1, 300.0))
    p0, v0 = np.asarray(coast.chaser.p_LC_L, float), np.asarray(coast.chaser.v_LC_L, float)
    reference = eci_reference(scenario.orbit, p0, v0, times)
    errors_p = np.linalg.norm(log["p_LC_L"][1:] - reference[:, 0:3], axis=1)
    errors_v = np.linalg.norm(log["v_LC_L"][1:] - reference[:, 3:6], axis=1)
    # The requirement (tests/reference/test_orbital_dynamics.py): 1 mm and 1 um/s. Measured with
    # the bundled integrator (runge_kutta5, accuracy 1e-8): 6.3e-9 m and 6.7e-12 m/s, below the
    # reference's own uncertainty (~1e-7 m: 7,000 km absolute positions subtracted).
    assert max(errors_p) < 1e-3, errors_p
    assert max(errors_v) < 1e-6, errors_v
    assert np.linalg.norm(reference[-1, 0:3] - p0) > 100.0  # it drifted: not a trivial test


# ---- Closed loop: the same run as with the four systems. ----


def test_closed_loop_hold_point_equals_the_split_truth(monkeypatch):
    _, hold = load_scenario("hold_point")
    scenario = dataclasses.replace(hold, duration_s=60.0)
    fast = simulate(scenario)
    monkeypatch.setattr(builder_module, "Truth", SplitTruth)
    assert isinstance(build_diagram(scenario)[1].orbital, SplitTruth)
    split = simulate(scenario)
    new, old = fast.log, split.log
    assert fast.summary["integrator_steps"] == split.summary["integrator_steps"]
    assert old["propellant_kg"][-1] > 0.1  # the chaser did fly
    np.testing.assert_array_equal(new["thruster_on"], old["thruster_on"])
    np.testing.assert_allclose(new["p_LC_L"], old["p_LC_L"], rtol=0, atol=1e-9)
    np.testing.assert_allclose(new["v_LC_L"], old["v_LC_L"], rtol=0, atol=1e-12)
    np.testing.assert_allclose(new["q_IC"], old["q_IC"], rtol=0, atol=1e-12)
    np.testing.assert_allclose(new["q_IT"], old["q_IT"], rtol=0, atol=1e-12)
    np.testing.assert_allclose(new["propellant_kg"], old["propellant_kg"], rtol=1e-12)
    np.testing.assert_allclose(new["body_wrench"], old["body_wrench"], rtol=0, atol=1e-12)
