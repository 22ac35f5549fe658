"""Pulse modulation of thruster duties: slot sequences (ON/OFF) from duty sequences.

Owns the per-scheme math of rpod's modulators as plain numpy functions, vectorised over
thrusters (and over slots where the scheme allows): the four `ModulationScheme`s, their
per-period kernels (what `rpod.systems.pwm.PwmModulator` calls once per control period) and
`modulate`, which runs a whole duty sequence through a scheme (analysis and tests).
Does not own time: the Drake system that samples the duty, holds the pattern and steps the
slots is `rpod.systems.pwm`; the duties come from `rpod.models.thrusters` (allocation).

Setting (paper 003 Sec. IV-B). The control period T is split into N slots; a duty d in [0, 1]
is held over a period (sampled at its start) and each thruster is ON or OFF for whole slots.
The schemes (the first is paper 003's PWM with rpod's carried remainder; the others go beyond
the paper):

- `pwm_carry`: leading-edge PWM, m ON slots at the start of the period, with the rounding
  remainder carried to the next period (first-order sigma-delta at the period rate):
      x = e + d N,   m = clamp(floor(x + 1/2), 0, N),   e <- x - m.
  |e| <= 1/2 after every period, so the cumulative ON count is within 1/2 slot of the
  cumulative commanded slots, forever; a constant duty is reproduced exactly on average.
- `round`: leading-edge PWM, m = clamp(floor(d N + 1/2), 0, N) with nothing carried. Each
  period is within 1/2 slot of its command, but the error is systematic: a constant duty d
  delivers round(d N) / N on average (bias round(d N)/N - d, |bias| <= 1/(2N); e.g. 0.04 at
  N = 10 delivers nothing at all).
- `schmitt`: a Schmitt trigger per thruster on the duty, one decision per slot: ON when
  d > 1/2 + H/2, OFF when d < 1/2 - H/2, unchanged in between (H = hysteresis, 0 <= H < 1).
  With the duty held over a period, pulses are whole periods. A bang-bang modulator: a constant
  duty delivers 0 below the band, 1 above it and the previous state inside it (bias -d, 1 - d,
  or either).
- `delta_sigma`: a first-order delta-sigma modulator per thruster at the slot rate: each slot
  the integrator v takes the duty, the thruster fires when it reaches 1/2, and the output is
  fed back:   u = v + d,   y = [u >= 1/2],   v <- u - y.
  |v| <= 1/2 after every slot (u lies in [-1/2, 3/2)), so the cumulative ON count is within
  1/2 slot of the cumulative command at every slot, not only at period ends; the pulses are
  spread over the period (more switches than `pwm_carry`). With the duty held over a period,
  its ON count per period equals `pwm_carry`'s (same rule, v = e, up to round-off at ties).

Tie rule: every threshold crossing is `>=` (a half slot rounds up), as floor(x + 1/2) does.
Duties are cleaned by `clean_duty` (NaN read as 0, clipped to [0, 1]) before any scheme sees
them; the kernels below assume clean duties.

Minimum ON time M (slots): `pwm_carry` and `round` round a pulse 0 < m < M to the nearer of
{0, M} (m <- M if x >= M/2, else 0; `pwm_carry` carries what that costs, so |e| <= max(1/2,
M/2)); `schmitt` pulses are whole periods (>= N >= M slots) with duties held per period;
`delta_sigma` has no minimum ON time (M > 1 is rejected).
"""

from __future__ import annotations

import enum

import numpy as np


class ModulationScheme(str, enum.Enum):
    """How duties become ON/OFF slots (module docstring); values are the config strings."""

    PWM_CARRY = "pwm_carry"
    ROUND = "round"
    SCHMITT = "schmitt"
    DELTA_SIGMA = "delta_sigma"


SCHEMES = tuple(scheme.value for scheme in ModulationScheme)
"""The scheme names, in declaration order."""

DEFAULT_SCHEME = ModulationScheme.PWM_CARRY
"""rpod's PWM (paper 003 Sec. IV-B with the carried remainder)."""

LEADING_EDGE_SCHEMES = (ModulationScheme.PWM_CARRY, ModulationScheme.ROUND)
"""Schemes whose period pattern is m ON slots then OFF (described by the count m alone)."""

DEFAULT_SCHMITT_HYSTERESIS = 0.2
"""Width H of the Schmitt trigger's band, in duty: ON above 0.6, OFF below 0.4."""


def parse_scheme(scheme: str | ModulationScheme) -> ModulationScheme:
    """The ModulationScheme of a name; ValueError listing the known ones otherwise."""
    try:
        return ModulationScheme(scheme)
    except ValueError:
        raise ValueError(f"scheme must be one of {SCHEMES}, got {scheme!r}") from None


def clean_duty(duty) -> np.ndarray:
    """Duty as the modulators read it: NaN -> 0, then clipped to [0, 1] (any shape)."""
    duty = np.asarray(duty, dtype=float)
    return np.clip(np.where(np.isnan(duty), 0.0, duty), 0.0, 1.0)


def schmitt_thresholds(hysteresis: float) -> tuple[float, float]:
    """(lower, upper) thresholds of the Schmitt trigger: 1/2 -+ H/2, for 0 <= H < 1."""
    if not 0.0 <= hysteresis < 1.0:
        raise ValueError(f"schmitt hysteresis must be in [0, 1), got {hysteresis!r}")
    return 0.5 - 0.5 * hysteresis, 0.5 + 0.5 * hysteresis


def _round_slots(want: np.ndarray, subdivisions: int, min_on_slots: int) -> np.ndarray:
    """m = clamp(floor(x + 1/2), 0, N), short pulses to the nearer of {0, M}."""
    on_slots = np.clip(np.floor(want + 0.5), 0.0, subdivisions)
    if min_on_slots > 1:  # round a too-short pulse to the nearer of 0 and M
        short = (on_slots > 0.0) & (on_slots < min_on_slots)
        on_slots = np.where(
            short, np.where(want >= 0.5 * min_on_slots, min_on_slots, 0.0), on_slots
        )
    return on_slots


def pwm_carry_period(
    duty: np.ndarray, remainder: np.ndarray, subdivisions: int, min_on_slots: int = 0
) -> tuple[np.ndarray, np.ndarray]:
    """One period of `pwm_carry`: ON-slot counts and the new carried remainder.

    Args:
        duty: Clean duties (n,) in [0, 1].
        remainder: Carried remainder e (n,), slots (commanded - delivered so far).
        subdivisions: Slots per period N.
        min_on_slots: Shortest pulse M (0 or 1: none).

    Returns:
        (m, e'): ON slots at the start of the period (n,), integers as floats; remainder (n,).
    """
    want = remainder + duty * subdivisions  # x = e + d N (carried + commanded slots)
    on_slots = _round_slots(want, subdivisions, min_on_slots)  # m = clamp(floor(x + 1/2))
    return on_slots, want - on_slots  # e <- x - m


def round_period(duty: np.ndarray, subdivisions: int, min_on_slots: int = 0) -> np.ndarray:
    """One period of `round`: ON-slot counts m = clamp(floor(d N + 1/2), 0, N), none carried."""
    return _round_slots(duty * subdivisions, subdivisions, min_on_slots)


def leading_edge_slots(on_slots: np.ndarray, subdivisions: int) -> np.ndarray:
    """The slot pattern (N, n) of leading-edge pulses: slot j ON iff j < m."""
    return (np.arange(subdivisions)[:, None] < np.asarray(on_slots)[None, :]).astype(float)


def schmitt_slots(
    duty_slots: np.ndarray, on: np.ndarray, hysteresis: float = DEFAULT_SCHMITT_HYSTERESIS
) -> tuple[np.ndarray, np.ndarray]:
    """Schmitt trigger per thruster, one decision per slot.

    Args:
        duty_slots: Clean duty seen at each slot (S, n).
        on: Trigger state (n,) before the first slot, 1.0 ON or 0.0 OFF.
        hysteresis: Band width H, 0 <= H < 1 (thresholds 1/2 -+ H/2).

    Returns:
        (y, on'): ON/OFF of each slot (S, n) as 0.0/1.0; the state after the last slot (n,).
    """
    lower, upper = schmitt_thresholds(hysteresis)
    duty_slots = np.asarray(duty_slots, dtype=float)
    switch_on = duty_slots > upper
    decided = switch_on | (duty_slots < lower)
    # The state at slot j is the last decision at or before j (forward fill), else `on`.
    index = np.where(decided, np.arange(duty_slots.shape[0])[:, None], -1)
    last = np.maximum.accumulate(index, axis=0)
    decision = np.take_along_axis(switch_on, np.maximum(last, 0), axis=0)
    y = np.where(last >= 0, decision, np.asarray(on, dtype=float)[None, :] > 0.5).astype(float)
    return y, (y[-1].copy() if y.shape[0] else np.asarray(on, dtype=float).copy())


def _round_half_up(x: np.ndarray) -> np.ndarray:
    """The integer nearest x, halves up, without the round-off of floor(x + 1/2): x - floor(x)
    is exact, so x - result is exactly in [-1/2, 1/2)."""
    whole = np.floor(x)
    return whole + (x - whole >= 0.5)


def delta_sigma_slots(
    duty_slots: np.ndarray, integrator: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """First-order delta-sigma modulator per thruster, one decision per slot.

    u_j = v_{j-1} + d_j, y_j = [u_j >= 1/2], v_j = u_j - y_j (module docstring). Evaluated in
    closed form, vectorised over slots: with S_j = v_0 + sum_{i<=j} d_i and v_0 in [-1/2, 1/2),
    the ON count after j slots is round(S_j) (halves up) and v_j = S_j - round(S_j);
    tests/models/test_modulation.py checks it against the recursion.

    Args:
        duty_slots: Clean duty seen at each slot (S, n).
        integrator: v_0 (n,), slots, in [-1/2, 1/2) (what this function returned last; an
            integrator outside is first brought into it by whole slots, which are dropped).

    Returns:
        (y, v): ON/OFF of each slot (S, n) as 0.0/1.0; the integrator after the last slot (n,),
        in [-1/2, 1/2).
    """
    duty_slots = np.asarray(duty_slots, dtype=float)
    integrator = np.asarray(integrator, dtype=float)
    demand = integrator + np.cumsum(duty_slots, axis=0)  # S_j = v_0 + sum of duties
    count = _round_half_up(np.vstack([integrator[None, :], demand]))  # ON count + round(v_0)
    # Each step of S is one duty in [0, 1], so each count step is 0 or 1; the clip only guards
    # against a round-off double step, and v is kept from the ON slots actually given.
    y = np.clip(np.diff(count, axis=0), 0.0, 1.0)
    if duty_slots.shape[0] == 0:
        return y, integrator - count[0]
    return y, demand[-1] - count[0] - y.sum(axis=0)  # v = v_0 + sum d - sum y


def modulate(
    scheme: str | ModulationScheme,
    duty_periods,
    subdivisions: int,
    *,
    min_on_slots: int = 0,
    hysteresis: float = DEFAULT_SCHMITT_HYSTERESIS,
    memory=None,
) -> tuple[np.ndarray, np.ndarray]:
    """Runs a duty sequence, one duty per period, through a scheme.

    The reference for `rpod.systems.pwm.PwmModulator`, which computes the same thing one
    period at a time (tests check they agree slot for slot).

    Args:
        scheme: A `ModulationScheme` or its name.
        duty_periods: Duties (P, n), row k held over period k; cleaned (`clean_duty`) here.
        subdivisions: Slots per period N (>= 1).
        min_on_slots: Shortest pulse M, 0 <= M <= N (module docstring; delta_sigma: M <= 1).
        hysteresis: Schmitt band width H (schmitt only).
        memory: The scheme's state (n,) before the first period (None: zeros): the carried
            remainder (pwm_carry), the trigger state (schmitt), the integrator (delta_sigma);
            unused by round.

    Returns:
        (slots, memory): ON/OFF of every slot (P N, n) as 0.0/1.0, slot-major; the scheme's
        state after the last period (n,).

    Raises:
        ValueError: On an unknown scheme or a bad N, M or H.
    """
    scheme = parse_scheme(scheme)
    check_modulation_arguments(scheme, subdivisions, min_on_slots, hysteresis)
    duty = clean_duty(np.atleast_2d(duty_periods))
    num_periods, n = duty.shape
    memory = np.zeros(n) if memory is None else np.asarray(memory, dtype=float).copy()
    if scheme is ModulationScheme.PWM_CARRY:
        counts = np.empty((num_periods, n))
        for k in range(num_periods):  # the remainder is carried period to period
            counts[k], memory = pwm_carry_period(duty[k], memory, subdivisions, min_on_slots)
    elif scheme is ModulationScheme.ROUND:
        counts = round_period(duty, subdivisions, min_on_slots)
    else:
        duty_slots = np.repeat(duty, subdivisions, axis=0)  # held over each period
        if scheme is ModulationScheme.SCHMITT:
            return schmitt_slots(duty_slots, memory, hysteresis)
        return delta_sigma_slots(duty_slots, memory)
    slots = np.arange(subdivisions)[None, :, None] < counts[:, None, :]  # (P, N, n)
    return slots.reshape(num_periods * subdivisions, n).astype(float), memory


def check_modulation_arguments(
    scheme: str | ModulationScheme, subdivisions: int, min_on_slots: int, hysteresis: float
) -> None:
    """ValueError naming the argument if N, M or H is not valid for the scheme."""
    scheme = parse_scheme(scheme)
    if int(subdivisions) != subdivisions or subdivisions < 1:
        raise ValueError(f"subdivisions must be a positive integer, got {subdivisions!r}")
    if int(min_on_slots) != min_on_slots or not 0 <= min_on_slots <= subdivisions:
        raise ValueError(
            f"min_on_slots must be an integer in [0, subdivisions={subdivisions}], "
            f"got {min_on_slots!r}"
        )
    if scheme is ModulationScheme.DELTA_SIGMA and min_on_slots > 1:
        raise ValueError(
            f"min_on_slots: delta_sigma has no minimum ON time (0 or 1), got {min_on_slots!r}"
        )
    if scheme is ModulationScheme.SCHMITT:
        schmitt_thresholds(hysteresis)
