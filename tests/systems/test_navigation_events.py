"""The navigation's schedule: it works at its sensors' samples only (a fix's arrival is no event:
its update is shown from then on, tests/diagrams/test_navigation.py), and each schedule meets
t = 0."""

import numpy as np
import pytest

from rpod.systems.navigation import NavigationComputer
from rpod.systems.navigation_config import Ekf


def _computer(config: Ekf) -> NavigationComputer:
    return NavigationComputer(config, 0, 0.0011, "two_body_j2", np.array([1.0, 0.0, 0.0]))


def test_the_default_events_are_the_samples_of_the_pose_sensor_star_tracker_and_gnss():
    computer = _computer(Ekf())
    assert computer.event_schedule() == [(0.5, 0.0), (1.0, 0.0)]
    first = computer.tick_at(0.0)
    events = [computer.time_of(k) for k in range(first, first + 20) if computer.is_event(k)]
    np.testing.assert_allclose(events, [0.0, 0.5, 1.0, 1.5])


@pytest.mark.parametrize("lead_in_s", [0.0, 0.3, 20.0, 21.7])
def test_the_lead_in_starts_a_whole_number_of_sensor_cycles_before_zero(lead_in_s):
    config = Ekf(update_period_s=0.05, lead_in_s=lead_in_s)
    config.pose_sensor.rate_hz = 4.0  # 0.25 s; with the star tracker's 0.5 s, GNSS's 1 s
    computer = _computer(config)
    assert computer.start_s <= -lead_in_s + 1e-9
    cycles = -computer.start_s / 1.0
    assert cycles == pytest.approx(round(cycles))
    assert computer.tick_at(0.0) * computer.period_s == pytest.approx(-computer.start_s)


def test_a_latency_is_rounded_up_to_the_grid_and_adds_no_event():
    config = Ekf()
    config.pose_sensor.latency_s = 0.65  # arrives after the next fix is taken
    computer = _computer(config)
    assert computer.latency_ticks == 7
    assert computer.event_schedule() == [(0.5, 0.0), (1.0, 0.0)]
