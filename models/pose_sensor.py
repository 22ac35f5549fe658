"""The relative pose sensor: a lidar or camera pose estimator on the chaser, as a measurement model.

It returns the target's position and attitude, seen from the chaser's sensor, with the errors
that published pose estimators show: position errors of 1-2 % of range with a floor of about
a centimetre, attitude errors of 2-10 deg (e.g. Opromolla et al., "A review of cooperative and
uncooperative spacecraft pose determination techniques for close-proximity operations",
Prog. Aerosp. Sci. 93, 2017; the SPEED+ results of Park et al., Adv. Space Res. 2023), a field
of view and a range window outside which it returns nothing, dropouts, and outliers (a wrong
match: metres and tens of degrees off).

The fix is given in L and I (`relative_navigation.PoseMeasurement`): the sensor's own
measurement rotated by the chaser's attitude and LVLH's, whose errors (a star tracker's 10
arcsec) are ~1e-3 of the sensor's at these ranges and are added to its position sigma.
"""

import dataclasses

import numpy as np

from rpod.models.config import bounded, positive
from rpod.models.frames import quaternion_product, rotation_vector_quaternion
from rpod.models.relative_navigation import PoseMeasurement


@dataclasses.dataclass
class PoseSensor:
    """The pose sensor's settings (defaults: a lidar pose estimator at close range).

    rate_hz, latency_s: fixes per second, and the age of a fix when it arrives.
    position_floor_m, range_noise_fraction: position 1-sigma = max(floor, fraction x range).
    attitude_sigma_deg: attitude 1-sigma about each axis.
    half_fov_deg, range_min_m, range_max_m: outside the cone about the boresight or the window,
        no fix. The default field of view is the whole sphere (180 deg): most scenarios do not
        slew the chaser to face the target; a single camera's is 15-30 deg, set it with the
        boresight (rpod.systems.navigation.Ekf.boresight_C) to fly one.
    dropout_probability: a fix lost at random (a frame without a match).
    outlier_probability, outlier_position_m, outlier_attitude_deg: a wrong fix, that far off.
    star_tracker_arcsec: the chaser's attitude knowledge, by which the fix is rotated into L.
    """

    rate_hz: float = positive(2.0, high=100.0)
    latency_s: float = bounded(0.1, 0.0, 10.0)
    position_floor_m: float = bounded(0.01, 0.0, 10.0)
    range_noise_fraction: float = bounded(0.01, 0.0, 1.0)
    attitude_sigma_deg: float = bounded(2.0, 0.0, 90.0)
    half_fov_deg: float = bounded(180.0, 0.0, 180.0)
    range_min_m: float = bounded(0.3, 0.0, 1e4)
    range_max_m: float = bounded(200.0, 0.0, 1e5)
    dropout_probability: float = bounded(0.0, 0.0, 1.0)
    outlier_probability: float = bounded(0.0, 0.0, 1.0)
    outlier_position_m: float = bounded(2.0, 0.0, 1e3)
    outlier_attitude_deg: float = bounded(30.0, 0.0, 180.0)
    star_tracker_arcsec: float = bounded(10.0, 0.0, 3600.0)

    def position_sigma_m(self, range_m: float) -> float:
        """The 1-sigma of each position component at a range, the chaser's attitude error
        included (it turns the fix about the chaser)."""
        sensor = max(self.position_floor_m, self.range_noise_fraction * range_m)
        attitude = range_m * np.radians(self.star_tracker_arcsec / 3600.0)
        return float(np.hypot(sensor, attitude))

    def why_unseen(self, p_CT_C: np.ndarray, boresight_C: np.ndarray) -> str | None:
        """Why the target at p_CT_C (from the sensor, in C) gives no fix: "range" outside the
        window, "fov" outside the cone about the boresight; None when it is seen."""
        range_m = float(np.linalg.norm(p_CT_C))
        if not self.range_min_m <= range_m <= self.range_max_m:
            return "range"
        cosine = float(p_CT_C @ boresight_C) / (range_m * float(np.linalg.norm(boresight_C)))
        return None if cosine >= np.cos(np.radians(self.half_fov_deg)) else "fov"

    def measure(
        self,
        rng: np.random.Generator,
        t: float,
        p_LC_L: np.ndarray,
        q_IT: np.ndarray,
        R_LC: np.ndarray,
        boresight_C: np.ndarray,
    ) -> tuple[PoseMeasurement | None, str]:
        """One fix of the truth (p_LC_L, q_IT; the chaser's attitude in L, R_LC), taken at t:
        (the fix, "ok"), or (None, why: "range", "fov", "dropout"), or (a wrong fix, "outlier").

        The draws come from `rng` in a fixed order whatever the outcome, so a run's fixes do
        not depend on which earlier ones were seen."""
        noise_p = rng.standard_normal(3)
        noise_q = rng.standard_normal(3)
        u_dropout, u_outlier = rng.random(2)
        direction = rng.standard_normal(3)
        unseen = self.why_unseen(R_LC.T @ (-np.asarray(p_LC_L, dtype=float)), boresight_C)
        if unseen:
            return None, unseen
        if u_dropout < self.dropout_probability:
            return None, "dropout"
        sigma_p = self.position_sigma_m(float(np.linalg.norm(p_LC_L)))
        sigma_q = np.radians(self.attitude_sigma_deg)
        p = np.asarray(p_LC_L, dtype=float) + sigma_p * noise_p
        q = quaternion_product(q_IT, rotation_vector_quaternion(sigma_q * noise_q))
        status = "ok"
        if u_outlier < self.outlier_probability:
            unit = direction / np.linalg.norm(direction)
            p = p + self.outlier_position_m * unit
            q = quaternion_product(
                q, rotation_vector_quaternion(np.radians(self.outlier_attitude_deg) * unit)
            )
            status = "outlier"
        return PoseMeasurement(t, p, q, sigma_p, sigma_q), status
