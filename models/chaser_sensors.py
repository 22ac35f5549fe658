"""The chaser's own sensors as measurement models: a star tracker, a rate gyro, a GNSS receiver.

Defaults are those of small-satellite hardware in common use: a star tracker of 10 arcsec
(1 sigma, cross-boresight; e.g. the Sodern Auriga and Blue Canyon NST class), a MEMS/FOG-class
gyro with angle random walk 0.15 deg/sqrt(h) and a bias instability of ~1 deg/h modelled as a
random walk, and a GNSS fix of 1 m and 1 cm/s per axis (a single-frequency receiver in low
orbit). The relative-navigation filter rotates pose fixes by the star tracker's attitude and
forms the target's orbit from the GNSS fix and its relative estimate.

Every draw comes from the generator passed in, in a fixed order, so runs are deterministic.
"""

import dataclasses

import numpy as np

from rpod.models.config import bounded, positive
from rpod.models.frames import quaternion_product, rotation_vector_quaternion

ARCSEC_RAD = np.pi / (180.0 * 3600.0)


@dataclasses.dataclass
class StarTracker:
    """Attitude fixes q_IC at rate_hz with sigma_arcsec of noise about each axis (2 Hz: read
    with the pose sensor, which the navigation's events follow; trackers give 1-10 Hz)."""

    rate_hz: float = positive(2.0, high=100.0)
    sigma_arcsec: float = bounded(10.0, 0.0, 3600.0)

    def measure(self, rng: np.random.Generator, q_IC) -> np.ndarray:
        """q_IC (x) exp(n / 2), n ~ N(0, sigma^2 I) in C."""
        noise = self.sigma_arcsec * ARCSEC_RAD * rng.standard_normal(3)
        return quaternion_product(q_IC, rotation_vector_quaternion(noise))


@dataclasses.dataclass
class Gyro:
    """An integrating rate gyro: read over any interval, it gives the body's mean rate over it
    plus its bias plus white noise (its angle increment over the interval, divided by it).

    angle_random_walk_deg_rt_h: the white noise's density (deg/sqrt(h)); its 1-sigma on the
        mean rate over an interval T is that density / sqrt(T).
    bias_random_walk_deg_h_rt_h: the bias's random walk density (deg/h/sqrt(h)).
    initial_bias_deg_h: the 1-sigma of each axis's bias at the start (deg/h).
    """

    angle_random_walk_deg_rt_h: float = bounded(0.15, 0.0, 100.0)
    bias_random_walk_deg_h_rt_h: float = bounded(0.1, 0.0, 100.0)
    initial_bias_deg_h: float = bounded(1.0, 0.0, 3600.0)

    def initial_bias(self, rng: np.random.Generator) -> np.ndarray:
        """A bias (3,) rad/s drawn from its starting spread."""
        return np.radians(self.initial_bias_deg_h / 3600.0) * rng.standard_normal(3)

    def measure(
        self, rng: np.random.Generator, mean_rate_C, bias, interval_s: float
    ) -> tuple[np.ndarray, np.ndarray]:
        """(the mean rate read over interval_s (3,) rad/s, the bias after it (3,) rad/s), from
        the true mean rate over the interval."""
        arw = np.radians(self.angle_random_walk_deg_rt_h) / 60.0  # rad/sqrt(s)
        rrw = np.radians(self.bias_random_walk_deg_h_rt_h) / 3600.0 / 60.0  # rad/s/sqrt(s)
        white = arw / np.sqrt(interval_s) * rng.standard_normal(3)
        walk = rrw * np.sqrt(interval_s) * rng.standard_normal(3)
        return np.asarray(mean_rate_C) + bias + white, bias + walk


@dataclasses.dataclass
class Gnss:
    """Fixes of the chaser's orbit, p_IC_I and v_IC_I, at rate_hz."""

    rate_hz: float = positive(1.0, high=100.0)
    sigma_position_m: float = bounded(1.0, 0.0, 1e4)
    sigma_velocity_m_s: float = bounded(0.01, 0.0, 100.0)

    def measure(self, rng: np.random.Generator, p_IC_I, v_IC_I) -> tuple[np.ndarray, np.ndarray]:
        """(p_IC_I, v_IC_I) with white noise of the stated sigmas per axis."""
        noise_p, noise_v = rng.standard_normal(3), rng.standard_normal(3)
        return (
            np.asarray(p_IC_I) + self.sigma_position_m * noise_p,
            np.asarray(v_IC_I) + self.sigma_velocity_m_s * noise_v,
        )
