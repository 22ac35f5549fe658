"""Tests of rpod.models.modulation: the four schemes' slot sequences from duty sequences.

Truths: the ON count is an integer and the commanded one is sum(duty * N); pwm_carry and
delta_sigma promise |cumulative commanded - delivered| <= 1/2 slot (at period ends; delta_sigma
at every slot), round and schmitt carry nothing and have the biases their docstring states,
asserted here to the slot. The delta_sigma closed form is checked against the plain recursion
it stands for. Tolerances: 1e-9 slot covers the round-off of summing a few thousand duties.
"""

import numpy as np
import pytest

from rpod.models.modulation import (
    DEFAULT_SCHEME,
    SCHEMES,
    ModulationScheme,
    clean_duty,
    delta_sigma_slots,
    leading_edge_slots,
    modulate,
    parse_scheme,
    pwm_carry_period,
    round_period,
    schmitt_slots,
    schmitt_thresholds,
)

N = 10  # slots per period (rpod's default)


def _switches(slots: np.ndarray) -> np.ndarray:
    """Number of OFF->ON and ON->OFF changes per thruster, starting from OFF."""
    padded = np.vstack([np.zeros((1, slots.shape[1])), slots])
    return np.abs(np.diff(padded, axis=0)).sum(axis=0)


def _delta_sigma_recursion(duty_slots, v):
    """u = v + d, y = [u >= 1/2], v <- u - y, one slot at a time (the definition)."""
    v = np.array(v, dtype=float)
    out = np.empty_like(duty_slots)
    for j, d in enumerate(duty_slots):
        u = v + d
        out[j] = u >= 0.5
        v = u - out[j]
    return out, v


def _counts(slots, n):
    return slots.reshape(-1, N, n).sum(axis=1)


def test_scheme_names_and_parsing():
    assert SCHEMES == ("pwm_carry", "round", "schmitt", "delta_sigma")
    assert DEFAULT_SCHEME is ModulationScheme.PWM_CARRY
    assert parse_scheme("delta_sigma") is ModulationScheme.DELTA_SIGMA
    assert parse_scheme(ModulationScheme.ROUND) == "round"  # a str enum
    with pytest.raises(ValueError, match="scheme must be one of"):
        parse_scheme("sigma_delta")
    with pytest.raises(ValueError, match="min_on_slots: delta_sigma"):
        modulate("delta_sigma", [[0.5]], N, min_on_slots=2)
    with pytest.raises(ValueError, match="hysteresis"):
        modulate("schmitt", [[0.5]], N, hysteresis=1.0)
    with pytest.raises(ValueError, match="subdivisions"):
        modulate("round", [[0.5]], 0)
    assert schmitt_thresholds(0.2) == (0.4, 0.6)


def test_clean_duty_reads_nan_as_zero_and_clips():
    np.testing.assert_array_equal(clean_duty([np.nan, -0.5, 0.3, 1.7]), [0.0, 0.0, 0.3, 1.0])


@pytest.mark.parametrize("scheme", SCHEMES)
def test_duty_zero_one_and_nan(scheme):
    # Columns: duty 0, 1, NaN (read as 0), 2 (clipped to 1), every period.
    duties = np.tile([0.0, 1.0, np.nan, 2.0], (20, 1))
    slots, _ = modulate(scheme, duties, N)
    assert slots.shape == (200, 4)
    np.testing.assert_array_equal(slots.sum(axis=0), [0, 200, 0, 200])
    np.testing.assert_array_equal(_switches(slots), [0, 1, 0, 1])


def test_pwm_carry_long_run_average_is_exact_and_drift_within_half_a_slot():
    rng = np.random.default_rng(0)
    duties = rng.uniform(0, 1, (400, 5))
    slots, remainder = modulate("pwm_carry", duties, N)
    counts = _counts(slots, 5)
    error = np.cumsum(duties * N, axis=0) - np.cumsum(counts, axis=0)
    assert np.max(np.abs(error)) <= 0.5 + 1e-9
    np.testing.assert_allclose(remainder, error[-1], atol=1e-9)  # e is that error
    # Leading edge within every period.
    assert np.all(np.diff(slots.reshape(400, N, 5), axis=1) <= 0)
    # A constant duty: exact average, two switches per period at most.
    const, _ = modulate("pwm_carry", np.full((100, 1), 0.37), N)
    assert const.sum() == 370.0
    assert _switches(const)[0] <= 2 * 100


def test_round_has_the_stated_bias_and_no_memory():
    # Constant duty d delivers round(d N) / N (halves up) every period, nothing carried.
    for duty, per_period in ((0.37, 4), (0.04, 0), (0.05, 1), (0.96, 10), (0.5, 5)):
        slots, memory = modulate("round", np.full((50, 1), duty), N)
        counts = _counts(slots, 1)[:, 0]
        assert np.all(counts == per_period)
        assert slots.mean() == pytest.approx(per_period / N, abs=1e-15)  # bias per_period/N - d
        np.testing.assert_array_equal(memory, [0.0])
    # The error grows linearly (no bound), unlike pwm_carry's.
    slots, _ = modulate("round", np.full((100, 1), 0.04), N)
    assert 0.04 * N * 100 - slots.sum() == pytest.approx(40.0)
    # One period is within 1/2 slot of its command; leading edge; two switches per period.
    rng = np.random.default_rng(1)
    duties = rng.uniform(0, 1, (200, 3))
    slots, _ = modulate("round", duties, N)
    assert np.max(np.abs(_counts(slots, 3) - duties * N)) <= 0.5 + 1e-12
    np.testing.assert_array_equal(
        leading_edge_slots(round_period(duties[7], N), N), slots[7 * N : 8 * N]
    )
    const, _ = modulate("round", np.full((30, 1), 0.3), N)
    assert _switches(const)[0] == 2 * 30


def test_schmitt_has_the_stated_bias_and_hysteresis():
    # Default band H = 0.2: ON above 0.6, OFF below 0.4, unchanged in between.
    for duty, average in ((0.37, 0.0), (0.45, 0.0), (0.55, 0.0), (0.65, 1.0)):
        slots, _ = modulate("schmitt", np.full((20, 1), duty), N)  # starts OFF
        assert slots.mean() == average  # bias average - duty
    slots, _ = modulate("schmitt", np.full((20, 1), 0.55), N, memory=[1.0])  # starts ON
    assert slots.mean() == 1.0
    # Hysteresis: inside the band the state is the last decision.
    duties = np.array([[0.7], [0.5], [0.41], [0.3], [0.5], [0.59], [0.61], [0.4], [0.39]])
    slots, state = modulate("schmitt", duties, N)
    np.testing.assert_array_equal(_counts(slots, 1)[:, 0], [10, 10, 10, 0, 0, 0, 10, 10, 0])
    np.testing.assert_array_equal(state, [0.0])
    assert _switches(slots)[0] == 4  # whole-period pulses: few switches
    # H = 0: a plain comparator with a hold at exactly 1/2.
    slots, _ = modulate("schmitt", [[0.51], [0.5], [0.49], [0.5]], N, hysteresis=0.0)
    np.testing.assert_array_equal(_counts(slots, 1)[:, 0], [10, 10, 0, 0])
    # Per-slot decisions on a duty that changes inside a period (the model allows it).
    y, state = schmitt_slots(np.array([[0.5], [0.7], [0.5], [0.2], [0.5]]), np.array([0.0]))
    np.testing.assert_array_equal(y[:, 0], [0, 1, 1, 0, 0])
    np.testing.assert_array_equal(state, [0.0])


def test_delta_sigma_closed_form_equals_the_recursion():
    rng = np.random.default_rng(2)
    # Dyadic duties (exact arithmetic both ways, with exact ties at 1/2) and random ones,
    # changing every slot, from random starting integrators in [-1/2, 1/2).
    dyadic = rng.integers(0, 9, (500, 6)) / 8.0
    uniform = rng.uniform(0, 1, (500, 6))
    for duty_slots in (dyadic, uniform):
        v0 = rng.uniform(-0.5, 0.5, 6)
        y, v = delta_sigma_slots(duty_slots, v0)
        y_ref, v_ref = _delta_sigma_recursion(duty_slots, v0)
        np.testing.assert_array_equal(y, y_ref)
        np.testing.assert_allclose(v, v_ref, atol=1e-12)
        assert np.all((v >= -0.5) & (v < 0.5))


def test_delta_sigma_drift_within_half_a_slot_at_every_slot_and_spread_pulses():
    rng = np.random.default_rng(3)
    duties = rng.uniform(0, 1, (300, 4))
    slots, v = modulate("delta_sigma", duties, N)
    commanded = np.cumsum(np.repeat(duties, N, axis=0), axis=0)
    error = commanded - np.cumsum(slots, axis=0)
    assert np.max(np.abs(error)) <= 0.5 + 1e-9  # at every slot, not only at period ends
    np.testing.assert_allclose(v, error[-1], atol=1e-9)
    # Same ON count per period as pwm_carry (same rule at period ends), spread differently.
    carry, _ = modulate("pwm_carry", duties, N)
    np.testing.assert_array_equal(_counts(slots, 4), _counts(carry, 4))
    # Constant duties: the exact average; 1/2 alternates ON/OFF (N switches per period),
    # 0.3 gives three isolated one-slot pulses per period (six switches) where PWM gives two.
    for duty, switches_per_period in ((0.5, 10), (0.3, 6), (0.1, 2)):
        const, _ = modulate("delta_sigma", np.full((40, 1), duty), N)
        assert const.sum() == duty * N * 40
        assert abs(_switches(const)[0] - switches_per_period * 40) <= 1
        carry, _ = modulate("pwm_carry", np.full((40, 1), duty), N)
        assert _switches(carry)[0] <= 2 * 40


def test_min_on_slots_in_each_scheme():
    rng = np.random.default_rng(4)
    duties = rng.uniform(0, 0.4, (200, 3))
    for scheme in ("pwm_carry", "round"):
        counts = _counts(modulate(scheme, duties, N, min_on_slots=3)[0], 3)
        assert np.all((counts == 0) | (counts >= 3))
    # pwm_carry keeps its bound max(1/2, M/2); round carries nothing.
    counts = _counts(modulate("pwm_carry", duties, N, min_on_slots=3)[0], 3)
    error = np.cumsum(duties * N, axis=0) - np.cumsum(counts, axis=0)
    assert np.max(np.abs(error)) <= 1.5 + 1e-9
    # schmitt: whole periods, so any M <= N holds by construction.
    slots, _ = modulate("schmitt", rng.uniform(0, 1, (200, 3)), N, min_on_slots=N)
    assert set(np.unique(_counts(slots, 3))) <= {0.0, float(N)}


def test_period_kernels_match_modulate():
    rng = np.random.default_rng(5)
    duties = rng.uniform(0, 1, (30, 4))
    slots, _ = modulate("pwm_carry", duties, N, min_on_slots=2)
    remainder = np.zeros(4)
    for k in range(30):
        on_slots, remainder = pwm_carry_period(duties[k], remainder, N, 2)
        np.testing.assert_array_equal(leading_edge_slots(on_slots, N), slots[k * N : (k + 1) * N])
    # Empty sequences return the memory unchanged.
    for scheme in SCHEMES:
        slots, memory = modulate(scheme, np.zeros((0, 2)), N, memory=[0.25, 0.0])
        assert slots.shape == (0, 2)
        np.testing.assert_array_equal(memory, [0.25, 0.0])
