"""The chaser's sensor models against their stated statistics: the star tracker's angle, the
gyro's white noise (from the Allan variance's slope at short averaging) and bias random walk
(the spread of the bias over many independent gyros), the GNSS fix's sigmas."""

import numpy as np
import pytest

from rpod.models.chaser_sensors import ARCSEC_RAD, Gnss, Gyro, StarTracker
from rpod.models.frames import attitude_error

Q_IC = np.array([0.5, 0.5, -0.5, 0.5])


def mean_square_is_one(normalised) -> bool:
    """A sample of standard normals: its mean square is 1 within 5 of its own sigmas."""
    normalised = np.ravel(normalised)
    return abs(np.mean(normalised**2) - 1.0) < 5 * np.sqrt(2 / normalised.size)


def test_the_star_tracker_has_its_sigma():
    tracker, rng = StarTracker(), np.random.default_rng(0)
    angles = np.array([attitude_error(Q_IC, tracker.measure(rng, Q_IC)) for _ in range(3000)])
    assert mean_square_is_one(angles / (tracker.sigma_arcsec * ARCSEC_RAD))


@pytest.mark.parametrize("interval_s", [0.1, 0.4])
def test_the_gyro_has_its_white_noise_and_its_bias_walk(interval_s):
    gyro, rng = Gyro(), np.random.default_rng(1)
    w = np.array([0.01, -0.02, 0.003])
    bias = np.zeros(3)
    samples = []
    for _ in range(5000):
        sample, bias_next = gyro.measure(rng, w, bias, interval_s)
        samples.append(sample - w - bias)  # the white part alone
        bias = bias_next
    arw = np.radians(gyro.angle_random_walk_deg_rt_h) / 60.0
    assert mean_square_is_one(np.array(samples) / (arw / np.sqrt(interval_s)))
    # 300 gyros for 100 s through the model: the bias spreads as the random walk's sqrt(t).
    rrw = np.radians(gyro.bias_random_walk_deg_h_rt_h) / 3600.0 / 60.0
    biases = []
    for _ in range(300):
        bias = np.zeros(3)
        for _ in range(round(100.0 / interval_s)):
            _, bias = gyro.measure(rng, w, bias, interval_s)
        biases.append(bias)
    assert mean_square_is_one(np.array(biases) / (rrw * np.sqrt(100.0)))


def test_the_initial_bias_has_its_spread():
    gyro, rng = Gyro(), np.random.default_rng(3)
    biases = np.array([gyro.initial_bias(rng) for _ in range(3000)])
    assert mean_square_is_one(biases / np.radians(gyro.initial_bias_deg_h / 3600.0))


def test_the_gnss_fix_has_its_sigmas():
    gnss, rng = Gnss(), np.random.default_rng(4)
    p, v = np.array([6.9e6, 0.0, 0.0]), np.array([0.0, 7.6e3, 0.0])
    fixes = [gnss.measure(rng, p, v) for _ in range(3000)]
    assert mean_square_is_one(np.array([f[0] - p for f in fixes]) / gnss.sigma_position_m)
    assert mean_square_is_one(np.array([f[1] - v for f in fixes]) / gnss.sigma_velocity_m_s)
