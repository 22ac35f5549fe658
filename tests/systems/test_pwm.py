"""Tests of rpod.systems.pwm.PwmModulator, simulated alone with a Drake Simulator and a log.

The schemes' math is tested in tests/models/test_modulation.py; here, that the system delivers
exactly the model's slots for each scheme, and that the default is the PWM rpod had before the
schemes (a frozen copy of its update rule below), bit for bit.

Truths: the delivered impulse (ON-slot count) is an integer and the commanded one is
sum(duty * N); the module promises |commanded - delivered| <= 1/2 slot at every period end
(max(1/2, M/2) with a minimum ON time of M slots). The brief's requirement is <= 1 slot; both
are asserted (the 1e-9 slack covers the round-off of summing ~2000 products).

Logging: a periodic log with the slot period h samples at t = j h the output held over the
slot [(j - 1) h, j h) (Drake publishes at the end of a step, updates at its start).
"""

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import LogVectorOutput, TrajectorySource
from pydrake.trajectories import PiecewisePolynomial

from rpod.models.modulation import SCHEMES, modulate
from rpod.systems.pwm import PwmModulator

T = 0.1  # control period, s (paper 003: 10 Hz)


def _simulate(duties, subdivisions, min_on_slots=0, period=T, **pwm_options):
    """Feeds duties[k] (periods x n) during period k; returns ON slots (slots x n).

    pwm_options go to PwmModulator (scheme, schmitt_hysteresis).
    """
    duties = np.asarray(duties, dtype=float)
    num_periods, n = duties.shape
    # Zero-order hold with breaks half a period early, so the sample at k T is duties[k].
    breaks = (np.arange(num_periods + 1) - 0.5) * period
    samples = np.vstack([duties, duties[-1:]]).T
    builder = DiagramBuilder()
    source = builder.AddSystem(TrajectorySource(PiecewisePolynomial.ZeroOrderHold(breaks, samples)))
    pwm = builder.AddSystem(PwmModulator(n, period, subdivisions, min_on_slots, **pwm_options))
    builder.Connect(source.get_output_port(), pwm.GetInputPort("thruster_duty"))
    logger = LogVectorOutput(pwm.GetOutputPort("thruster_on"), builder, pwm.slot_period_s)
    diagram = builder.Build()
    simulator = Simulator(diagram)
    num_slots = num_periods * subdivisions
    simulator.AdvanceTo(num_slots * pwm.slot_period_s)
    log = logger.FindLog(simulator.get_context())
    times, data = log.sample_times(), log.data().T
    expected_times = np.arange(1, num_slots + 1) * pwm.slot_period_s
    np.testing.assert_allclose(times[1 : num_slots + 1], expected_times)
    return data[1 : num_slots + 1]  # row j: the slot [j h, (j + 1) h)


def test_ports_and_state():
    pwm = PwmModulator(8, T, 10, min_on_slots=2)
    assert pwm.GetInputPort("thruster_duty").size() == 8
    assert pwm.GetOutputPort("thruster_on").size() == 8
    context = pwm.CreateDefaultContext()
    assert context.num_discrete_state_groups() == 1
    assert context.get_discrete_state(0).size() == 17
    assert not pwm.HasAnyDirectFeedthrough()  # output from state only
    assert pwm.slot_period_s == pytest.approx(0.01, rel=1e-15)
    assert pwm.remainder_bound_slots == 1.0
    for bad in ({"subdivisions": 0}, {"min_on_slots": 11}, {"control_period_s": 0.0}):
        args = {"num_thrusters": 8, "control_period_s": T, "subdivisions": 10} | bad
        with pytest.raises(ValueError, match=next(iter(bad))):
            PwmModulator(**args)


def test_random_duties_never_drift_more_than_half_a_slot():
    rng = np.random.default_rng(0)
    N, periods = 10, 250
    duties = rng.uniform(0, 1, (periods, 3))
    duties[rng.uniform(size=duties.shape) < 0.2] = 0.0  # some exact zeros and ones
    duties[rng.uniform(size=duties.shape) < 0.1] = 1.0
    on = _simulate(duties, N)
    assert set(np.unique(on)) <= {0.0, 1.0}
    delivered = np.cumsum(on.reshape(periods, N, 3).sum(axis=1), axis=0)
    commanded = np.cumsum(duties * N, axis=0)
    error = np.abs(delivered - commanded)
    assert np.max(error) <= 0.5 + 1e-9  # the module's bound
    assert np.max(error) <= 1.0  # the requirement
    # Leading edge: inside every period the ON slots come first.
    per_period = on.reshape(periods, N, 3)
    assert np.all(np.diff(per_period, axis=1) <= 0.0)


def test_constant_duty_gives_the_exact_long_run_average():
    periods = 100
    on = _simulate(np.full((periods, 1), 0.37), 10)
    assert on.sum() == 370.0  # 0.37 * 10 * 100, exactly (|error| <= 1/2 and it is an integer)
    assert on.mean() == pytest.approx(0.37, abs=1e-15)
    # Over any 10 consecutive periods the count is within one slot of 37.
    counts = on.reshape(periods, 10).sum(axis=1)
    windowed = np.convolve(counts, np.ones(10), mode="valid")
    assert np.all(np.abs(windowed - 37.0) <= 1.0)


def test_first_period_is_leading_edge_and_duty_is_sampled_at_period_start_only():
    # Duty 0.3 from t = 0 then 0.9 from mid-period: period 0 still uses 0.3 -> slots 0-2 ON.
    breaks = np.array([0.0, 0.5 * T, 3 * T])
    samples = np.array([[0.3, 0.9, 0.9]])
    builder = DiagramBuilder()
    source = builder.AddSystem(TrajectorySource(PiecewisePolynomial.ZeroOrderHold(breaks, samples)))
    pwm = builder.AddSystem(PwmModulator(1, T, 10))
    builder.Connect(source.get_output_port(), pwm.get_input_port())
    logger = LogVectorOutput(pwm.GetOutputPort("thruster_on"), builder, pwm.slot_period_s)
    simulator = Simulator(builder.Build())
    simulator.AdvanceTo(2 * T)
    on = logger.FindLog(simulator.get_context()).data()[0, 1:21]
    np.testing.assert_array_equal(on[:10], [1, 1, 1, 0, 0, 0, 0, 0, 0, 0])
    np.testing.assert_array_equal(on[10:], [1] * 9 + [0])


def test_out_of_range_duties_are_clipped():
    on = _simulate(np.array([[1.7, -0.5, np.nan, 0.5]] * 3), 4)
    np.testing.assert_array_equal(on.sum(axis=0), [12, 0, 0, 6])


def test_min_on_time_is_respected_and_drift_stays_bounded():
    rng = np.random.default_rng(1)
    N, M, periods = 10, 3, 250
    duties = rng.uniform(0, 0.4, (periods, 4))  # many would-be 1- and 2-slot pulses
    on = _simulate(duties, N, min_on_slots=M)
    counts = on.reshape(periods, N, 4).sum(axis=1)
    assert np.all((counts == 0) | (counts >= M))
    # Every maximal ON run, over the whole record, lasts at least M slots.
    for k in range(4):
        padded = np.r_[0.0, on[:, k], 0.0]
        edges = np.flatnonzero(np.diff(padded))
        run_lengths = edges[1::2] - edges[0::2]
        assert run_lengths.size > 50 and np.all(run_lengths >= M)
    error = np.abs(np.cumsum(counts, axis=0) - np.cumsum(duties * N, axis=0))
    assert np.max(error) <= M / 2 + 1e-9  # the documented bound max(1/2, M/2)
    # Without the limit the same duties would produce short pulses: the test is not vacuous.
    free = _simulate(duties, N).reshape(periods, N, 4).sum(axis=1)
    assert np.any((free > 0) & (free < M))


def test_delivered_duty_equals_on_slots_of_each_period():
    """delivered_duty, read once per period, is the ON-slot count of that period over N."""
    rng = np.random.default_rng(7)
    n, subdivisions, num_periods = 3, 10, 40
    duties = rng.uniform(0.0, 1.0, size=(num_periods, n))
    on = _simulate(duties, subdivisions)  # slots x n, independent evidence of the pulses
    on_slots_per_period = on.reshape(num_periods, subdivisions, n).sum(axis=1)

    builder = DiagramBuilder()
    breaks = (np.arange(num_periods + 1) - 0.5) * T
    samples = np.vstack([duties, duties[-1:]]).T
    source = builder.AddSystem(TrajectorySource(PiecewisePolynomial.ZeroOrderHold(breaks, samples)))
    pwm = builder.AddSystem(PwmModulator(n, T, subdivisions))
    builder.Connect(source.get_output_port(), pwm.GetInputPort("thruster_duty"))
    simulator = Simulator(builder.Build())
    pwm_context = pwm.GetMyContextFromRoot(simulator.get_mutable_context())
    delivered = []
    for k in range(num_periods):
        simulator.AdvanceTo(k * T + 0.5 * pwm.slot_period_s)  # inside period k
        delivered.append(pwm.GetOutputPort("delivered_duty").Eval(pwm_context).copy())
    # Exact: both are integers over N computed from the same state machine.
    np.testing.assert_array_equal(np.array(delivered) * subdivisions, on_slots_per_period)


def _driven(pwm, duties):
    """A Simulator of pwm fed duties[k] during period k (as _simulate), without a log."""
    breaks = (np.arange(len(duties) + 1) - 0.5) * T
    samples = np.vstack([duties, duties[-1:]]).T
    builder = DiagramBuilder()
    source = builder.AddSystem(TrajectorySource(PiecewisePolynomial.ZeroOrderHold(breaks, samples)))
    builder.AddSystem(pwm)
    builder.Connect(source.get_output_port(), pwm.GetInputPort("thruster_duty"))
    return Simulator(builder.Build())


def _legacy_pwm(duties, subdivisions, min_on_slots=0):
    """The PWM update rule as it was before the schemes (frozen copy): slots and remainders."""
    n = duties.shape[1]
    remainder, slots, remainders = np.zeros(n), [], []
    for duty in duties:
        duty = np.clip(np.where(np.isnan(duty), 0.0, duty), 0.0, 1.0)
        want = remainder + duty * subdivisions
        on_slots = np.clip(np.floor(want + 0.5), 0.0, subdivisions)
        if min_on_slots > 1:
            short = (on_slots > 0.0) & (on_slots < min_on_slots)
            on_slots = np.where(
                short, np.where(want >= 0.5 * min_on_slots, min_on_slots, 0.0), on_slots
            )
        remainder = want - on_slots
        remainders.append(remainder)
        slots.append(np.arange(subdivisions)[:, None] < on_slots[None, :])
    return np.vstack(slots).astype(float), np.array(remainders)


@pytest.mark.parametrize("min_on_slots", [0, 3])
def test_default_scheme_is_the_legacy_pwm_bit_for_bit(min_on_slots):
    rng = np.random.default_rng(11)
    periods, n = 120, 5
    duties = rng.uniform(-0.2, 1.2, (periods, n))
    duties[rng.uniform(size=duties.shape) < 0.05] = np.nan
    pwm = PwmModulator(n, T, 10, min_on_slots)
    assert pwm.scheme == "pwm_carry"
    assert pwm.CreateDefaultContext().get_discrete_state(0).size() == 2 * n + 1  # same layout
    legacy_slots, legacy_remainders = _legacy_pwm(duties, 10, min_on_slots)
    np.testing.assert_array_equal(_simulate(duties, 10, min_on_slots), legacy_slots)
    # The carried remainder, read from the state inside the last period, is the same double.
    simulator = _driven(pwm, duties)
    simulator.AdvanceTo((periods - 0.5) * T)
    state = pwm.GetMyContextFromRoot(simulator.get_context()).get_discrete_state(0).get_value()
    np.testing.assert_array_equal(state[:n], legacy_remainders[-1])


@pytest.mark.parametrize("scheme", SCHEMES)
def test_each_scheme_delivers_the_model_slots(scheme):
    rng = np.random.default_rng(12)
    periods, n = 60, 4
    duties = rng.uniform(0.0, 1.0, (periods, n))
    duties[::7] = 0.5  # exact ties
    duties[3::11, 0] = np.nan
    options = {"scheme": scheme, "schmitt_hysteresis": 0.1}
    on = _simulate(duties, 10, **options)
    expected, _ = modulate(scheme, duties, 10, hysteresis=0.1)
    np.testing.assert_array_equal(on, expected)


@pytest.mark.parametrize("scheme", SCHEMES)
def test_state_size_delivered_duty_and_bounds_per_scheme(scheme):
    n, subdivisions, num_periods = 3, 10, 12
    pwm = PwmModulator(n, T, subdivisions, scheme=scheme)
    leading_edge = scheme in ("pwm_carry", "round")
    size = 2 * n + 1 if leading_edge else (subdivisions + 2) * n + 1
    assert pwm.CreateDefaultContext().get_discrete_state(0).size() == size
    assert not pwm.HasAnyDirectFeedthrough()
    assert (
        pwm.remainder_bound_slots
        == {"pwm_carry": 0.5, "round": np.inf, "schmitt": np.inf, "delta_sigma": 0.5}[scheme]
    )
    # delivered_duty, read inside each period, is that period's ON-slot count over N.
    duties = np.random.default_rng(13).uniform(0.0, 1.0, (num_periods, n))
    on = _simulate(duties, subdivisions, scheme=scheme)
    simulator = _driven(pwm, duties)
    pwm_context = pwm.GetMyContextFromRoot(simulator.get_mutable_context())
    delivered = []
    for k in range(num_periods):
        simulator.AdvanceTo(k * T + 0.5 * pwm.slot_period_s)
        delivered.append(pwm.GetOutputPort("delivered_duty").Eval(pwm_context).copy())
    np.testing.assert_array_equal(
        np.array(delivered) * subdivisions, on.reshape(num_periods, subdivisions, n).sum(axis=1)
    )


def test_scheme_arguments_are_checked():
    with pytest.raises(ValueError, match="scheme must be one of"):
        PwmModulator(2, T, 10, scheme="pdm")
    with pytest.raises(ValueError, match="min_on_slots: delta_sigma"):
        PwmModulator(2, T, 10, 2, scheme="delta_sigma")
    with pytest.raises(ValueError, match="hysteresis"):
        PwmModulator(2, T, 10, scheme="schmitt", schmitt_hysteresis=-0.1)
    PwmModulator(2, T, 10, 10, scheme="schmitt")  # whole-period pulses meet any M <= N
