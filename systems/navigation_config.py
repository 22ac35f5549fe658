"""What the controllers read, as a scenario says it: `navigation: !Truth {}` or `!Ekf {...}`.

Owns: the two choices of the scenario's `navigation:` block (chosen by YAML tag, like
`controller:`) and the sensors an `Ekf` block scales by its `noise_scale`.
Does not own: the navigation itself (rpod.systems.navigation), the sensor and filter
mathematics (rpod.models.pose_sensor, .chaser_sensors, .relative_navigation).
"""

from __future__ import annotations

import dataclasses
import typing

import numpy as np

from rpod.models import relative_navigation as rn
from rpod.models.chaser_sensors import Gnss, Gyro, StarTracker
from rpod.models.config import ConfigError, bounded, count, positive
from rpod.models.pose_sensor import PoseSensor


@dataclasses.dataclass
class Truth:
    """Controllers read the true state (what every paper assumes; the default)."""


@dataclasses.dataclass
class Ekf:
    """Controllers read an estimate: the sensors below and the relative-navigation filter.

    update_period_s: the navigation's time grid: every sensor's period is a whole number of
        it, and a fix's latency is rounded up to it. The navigation works only at its events
        (its sensors' samples; a fix's update is shown from its arrival on:
        rpod.systems.navigation), not at every tick.
    lead_in_s: how long the sensors and the filter run before t = 0 (rpod.systems.navigation):
        60 s by default, the time a tumble of a few deg/s takes to show the filter its inertia
        (at 20 s, the first default, paper 000's soft capture captured 45 of 50 sampled cases
        on the estimate and 48 with its planner given the true inertia, the oracle's result at
        commit b2b540d; at 60 s it captures 48 on the estimate, and the true inertia adds none:
        47, benchmarks/results/navigation_inertia_oracle.md). Guidance takes over from an earlier
        phase whose navigation has watched the target for minutes.
    noise_scale: every sensor's noise times this (0: perfect fixes; 3: three times the
        defaults). Outliers and dropouts keep their own probabilities.
    boresight_C: the pose sensor's boresight in C; empty: the capture axis
        (chaser.capture_point_C's direction).
    gyro_window_s: the chaser's rate is the integrating gyro's mean over this window (its
        angle increments over 1 s: 0.0025 deg/s of noise at the default angle random walk,
        against 0.008 deg/s over 0.1 s; the paper 001 NMPC missed its 1 deg grasp tolerance
        on 0.1 s readings).
    pose_sensor, star_tracker, gyro, gnss: the sensors (their own docstrings give defaults
        and sources).
    acceleration_noise, torque_noise, inertia_noise: the filter's process noise densities
        (rpod.models.relative_navigation.ProcessNoise). The filter assumes the target's
        principal axes are T's; where they are not (hold_point's target: a few degrees off),
        raise torque_noise to cover the Euler equations' error (hold_point's kinematic NEES
        mean: 41 at 1e-6, 8 at 3e-5, for 12 expected). The default stays at 1e-6: a larger
        one lets the rate estimate wander, and paper 001's grasp, which predicts the tumble
        over minutes, then misses its 1 deg tolerance (3 deg at 3e-5).
    prior_inertia_parameters, prior_inertia_sigma: what the filter assumes of the target's
        inertia parameters (p_x, p_y) before it sees the tumble (InertiaPrior).
    gate_probability, excitation_sigmas, max_step_s: the filter's tuning (FilterSettings).
    process_model: the relative translation's model: 'cw' (Clohessy-Wiltshire, paper 004
        eq. 4) or 'exact' (the relative motion under the scenario's two-body or two-body + J2
        gravity about the target orbit estimate, rpod.models.relative_orbit), for long
        ranges and eccentric orbits where CW's error shows.
    restart_after_rejections: this many fixes refused in a row are not outliers but a filter
        that has diverged: the part that diverged (translation or rotation) starts again from
        the last fix (rpod.models.relative_navigation.reset_diverged).
    """

    update_period_s: float = positive(0.1, high=1.0)
    lead_in_s: float = bounded(60.0, 0.0, 600.0)
    noise_scale: float = bounded(1.0, 0.0, 100.0)
    boresight_C: list[float] = bounded([], -1e3, 1e3)  # noqa: RUF009 (a field())
    gyro_window_s: float = positive(1.0, high=60.0)
    pose_sensor: PoseSensor = dataclasses.field(default_factory=PoseSensor)
    star_tracker: StarTracker = dataclasses.field(default_factory=StarTracker)
    gyro: Gyro = dataclasses.field(default_factory=Gyro)
    gnss: Gnss = dataclasses.field(default_factory=Gnss)
    acceleration_noise: float = positive(1e-5, high=1.0)
    torque_noise: float = positive(1e-6, high=1.0)
    inertia_noise: float = positive(1e-6, high=1.0)
    prior_inertia_parameters: list[float] = bounded([0.0, 0.0], -0.99, 0.99)  # noqa: RUF009
    prior_inertia_sigma: float = positive(0.15, high=1.0)
    gate_probability: float = bounded(0.9999, 0.5, 1.0, high_open=True)
    excitation_sigmas: float = bounded(10.0, 0.0, 1e3)
    max_step_s: float = positive(0.5, high=10.0)
    process_model: typing.Literal["cw", "exact"] = "cw"
    restart_after_rejections: int = count(4, 1, 1000)

    def validate(self) -> None:
        """Raises ConfigError naming the first field that does not fit the others."""
        if self.boresight_C and (
            len(self.boresight_C) != 3 or not np.linalg.norm(self.boresight_C) > 0
        ):
            raise ConfigError("boresight_C", "must be empty or 3 numbers, not all zero")
        if len(self.prior_inertia_parameters) != 2:
            raise ConfigError("prior_inertia_parameters", "must be 2 numbers (p_x, p_y)")
        for field, period in self.sensor_periods().items():
            ticks = period / self.update_period_s
            if abs(ticks - round(ticks)) > 1e-6 or round(ticks) < 1:
                raise ConfigError(
                    field,
                    f"its period ({period:g} s) must be a whole number of update_period_s "
                    f"({self.update_period_s:g} s)",
                )

    def sensor_periods(self) -> dict[str, float]:
        """Each sensor's sample period [s], by the field that sets it."""
        return {
            "pose_sensor.rate_hz": 1.0 / self.pose_sensor.rate_hz,
            "star_tracker.rate_hz": 1.0 / self.star_tracker.rate_hz,
            "gnss.rate_hz": 1.0 / self.gnss.rate_hz,
        }

    def filter_settings(self) -> rn.FilterSettings:
        """The filter's settings from this block."""
        return rn.FilterSettings(
            noise=rn.ProcessNoise(self.acceleration_noise, self.torque_noise, self.inertia_noise),
            prior=rn.InertiaPrior(tuple(self.prior_inertia_parameters), self.prior_inertia_sigma),
            gate_probability=self.gate_probability,
            excitation_sigmas=self.excitation_sigmas,
            max_step_s=self.max_step_s,
        )


def scaled_sensors(config: Ekf) -> tuple[PoseSensor, StarTracker, Gyro, Gnss]:
    """The sensors with their noise times config.noise_scale."""
    s = config.noise_scale
    pose = dataclasses.replace(
        config.pose_sensor,
        position_floor_m=s * config.pose_sensor.position_floor_m,
        range_noise_fraction=s * config.pose_sensor.range_noise_fraction,
        attitude_sigma_deg=s * config.pose_sensor.attitude_sigma_deg,
        star_tracker_arcsec=s * config.pose_sensor.star_tracker_arcsec,
    )
    star = dataclasses.replace(
        config.star_tracker, sigma_arcsec=s * config.star_tracker.sigma_arcsec
    )
    gyro = dataclasses.replace(
        config.gyro,
        angle_random_walk_deg_rt_h=s * config.gyro.angle_random_walk_deg_rt_h,
        bias_random_walk_deg_h_rt_h=s * config.gyro.bias_random_walk_deg_h_rt_h,
        initial_bias_deg_h=s * config.gyro.initial_bias_deg_h,
    )
    gnss = dataclasses.replace(
        config.gnss,
        sigma_position_m=s * config.gnss.sigma_position_m,
        sigma_velocity_m_s=s * config.gnss.sigma_velocity_m_s,
    )
    return pose, star, gyro, gnss
