"""The navigation's schedule: it works at its sensors' events only, each schedule meets t = 0,
and an event met by two schedules at once is computed once."""

import numpy as np
import pytest

from rpod.systems.navigation import NavigationComputer
from rpod.systems.navigation_config import Ekf


def _computer(config: Ekf) -> NavigationComputer:
    return NavigationComputer(config, 0, 0.0011, "two_body_j2", np.array([1.0, 0.0, 0.0]))


def test_the_default_events_are_the_pose_fix_s_sample_and_arrival_and_the_gnss_fix():
    computer = _computer(Ekf())
    assert computer.event_schedule() == [(0.5, 0.0), (0.5, pytest.approx(0.1)), (1.0, 0.0)]
    first = computer.tick_at(0.0)
    events = [computer.time_of(k) for k in range(first, first + 20) if computer.is_event(k)]
    np.testing.assert_allclose(events, [0.0, 0.1, 0.5, 0.6, 1.0, 1.1, 1.5, 1.6])


@pytest.mark.parametrize("lead_in_s", [0.0, 0.3, 20.0, 21.7])
def test_the_lead_in_starts_a_whole_number_of_sensor_cycles_before_zero(lead_in_s):
    config = Ekf(update_period_s=0.05, lead_in_s=lead_in_s)
    config.pose_sensor.rate_hz = 4.0  # 0.25 s; with the star tracker's 0.5 s, GNSS's 1 s
    computer = _computer(config)
    assert computer.start_s <= -lead_in_s + 1e-9
    cycles = -computer.start_s / 1.0
    assert cycles == pytest.approx(round(cycles))
    assert computer.tick_at(0.0) * computer.period_s == pytest.approx(-computer.start_s)


def test_a_latency_longer_than_the_fix_period_arrives_on_its_own_schedule():
    config = Ekf()
    config.pose_sensor.latency_s = 0.7  # arrives after the next fix is taken
    computer = _computer(config)
    assert (0.5, pytest.approx(0.2)) in computer.event_schedule()
    assert computer.latency_ticks == 7
