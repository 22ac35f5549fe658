"""The pose sensor's measurement model: its noise has the stated sigmas (checked on 4,000 draws
against the chi-square and normal spreads, not just the mean), it sees only inside its cone
and window, and its dropouts and outliers come at their rates."""

import numpy as np
import pytest

from rpod.models.frames import attitude_error
from rpod.models.pose_sensor import PoseSensor

BORESIGHT_C = np.array([0.0, 1.0, 0.0])  # the chaser behind the target on V-bar looks along +y
P_LC_L = np.array([0.0, -20.0, 0.0])
Q_IT = np.array([0.9, 0.1, -0.3, 0.2]) / np.linalg.norm([0.9, 0.1, -0.3, 0.2])


def draws(sensor, count, seed=0, p_LC_L=P_LC_L, R_LC=None):
    rng = np.random.default_rng(seed)
    R_LC = np.eye(3) if R_LC is None else R_LC
    return [sensor.measure(rng, 0.0, p_LC_L, Q_IT, R_LC, BORESIGHT_C) for _ in range(count)]


def test_position_sigma_is_the_floor_or_the_fraction_of_range():
    sensor = PoseSensor(star_tracker_arcsec=0.0)
    assert sensor.position_sigma_m(0.5) == pytest.approx(0.01)  # the 1 cm floor
    assert sensor.position_sigma_m(20.0) == pytest.approx(0.2)  # 1 % of range
    with_tracker = PoseSensor().position_sigma_m(20.0)
    assert 0.2 < with_tracker < 0.2 * (1 + 1e-4)  # 10 arcsec at 20 m: 1 mm, in quadrature


def test_the_noise_has_the_stated_sigmas():
    sensor = PoseSensor()
    fixes = [fix for fix, status in draws(sensor, 4000) if status == "ok"]
    assert len(fixes) == 4000
    sigma_p = sensor.position_sigma_m(20.0)
    errors = np.array([fix.p_LC_L - P_LC_L for fix in fixes]) / sigma_p
    angles = np.array([attitude_error(Q_IT, fix.q_IT) for fix in fixes])
    angles /= np.radians(sensor.attitude_sigma_deg)
    for normalised in (errors, angles):
        # 4,000 x 3 standard normals: the mean square is 1 within 5 sigma of its spread.
        assert abs(np.mean(normalised**2) - 1.0) < 5 * np.sqrt(2 / normalised.size)
        assert np.all(np.abs(normalised.mean(axis=0)) < 5 / np.sqrt(len(normalised)))
    assert all(fix.sigma_position_m == sigma_p for fix in fixes)


def test_outside_the_cone_or_the_window_there_is_no_fix():
    sensor = PoseSensor(half_fov_deg=20.0, range_max_m=50.0)
    turned = np.array([[np.cos(0.5), -np.sin(0.5), 0], [np.sin(0.5), np.cos(0.5), 0], [0, 0, 1]])
    assert draws(sensor, 1, R_LC=turned)[0] == (None, "fov")  # boresight 29 deg off the target
    assert draws(sensor, 1, p_LC_L=np.array([0.0, -60.0, 0.0]))[0] == (None, "range")
    assert draws(sensor, 1, p_LC_L=np.array([0.0, -0.1, 0.0]))[0] == (None, "range")
    assert draws(sensor, 1)[0][1] == "ok"


def test_dropouts_and_outliers_come_at_their_rates_and_sizes():
    sensor = PoseSensor(dropout_probability=0.1, outlier_probability=0.05)
    results = draws(sensor, 4000, seed=3)
    statuses = [status for _, status in results]
    # Binomial counts within 4 sigma of their means.
    assert abs(statuses.count("dropout") - 400) < 4 * np.sqrt(4000 * 0.1 * 0.9)
    outliers = [fix for fix, status in results if status == "outlier"]
    assert abs(len(outliers) - 4000 * 0.9 * 0.05) < 4 * np.sqrt(4000 * 0.045 * 0.955)
    offsets = np.array([np.linalg.norm(fix.p_LC_L - P_LC_L) for fix in outliers])
    assert np.all(offsets > 2.0 - 5 * sensor.position_sigma_m(20.0))
    turns = np.degrees([np.linalg.norm(attitude_error(Q_IT, fix.q_IT)) for fix in outliers])
    assert np.median(turns) > 25.0


def test_the_same_seed_gives_the_same_fixes_whatever_was_seen():
    a = draws(PoseSensor(), 50, seed=5)
    b = draws(PoseSensor(), 50, seed=5)
    assert all(np.array_equal(x.p_LC_L, y.p_LC_L) for (x, _), (y, _) in zip(a, b))
    # A sensor that loses fixes draws the same numbers for the ones it keeps.
    lossy = draws(PoseSensor(dropout_probability=0.5), 50, seed=5)
    for (kept, status), (full, _) in zip(lossy, a):
        if status == "ok":
            assert np.array_equal(kept.p_LC_L, full.p_LC_L)
