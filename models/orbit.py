"""The target's orbit as a scenario sets it up: its config, its state at t = 0, its LVLH frame.

Owns: `OrbitConfig` (the circular orbit of the target, the truth gravity model a scenario
names and the UTC epoch of t = 0), `epoch_utc_datetime64` (that epoch, checked),
`initial_orbit_state` (the target's ECI state at t = 0 from it) and `lvlh_of` (the LVLH
attitude and rate of a target state under a gravity model, with free space's convention).
Does not own: the gravity models (rpod.models.gravity), the LVLH construction itself
(rpod.models.frames), or integrating any of it in time (rpod.systems.truth).

Why here and not beside a system. DESIGN.md puts a system's config beside the system, but this
one configures the orbit model, not one system: the truth (rpod.systems.truth), the scenario
(rpod.diagrams.scenario), the builder and the controllers' predictions all read it, and planners
(which must not import rpod.systems) may need it too. It is plain data with its two functions of
the model, so it lives with the models it parameterises.

The epoch labels time only: the truth has no epoch-dependent force (no Sun, Moon or Earth
rotation), so the simulation is the same whatever it is. It places the run in calendar time
for tools that read its trajectory (rpod.scenarios.export, CCSDS OEM/AEM).

Free space (`gravity == 'free_space'`, the planar air-bearing case of paper 003): no gravity,
the target rests at the origin and L coincides with I (identity attitude, zero rate).
"""

from __future__ import annotations

import dataclasses
import math
import re

import numpy as np

from rpod.models.frames import lvlh_angular_velocity, lvlh_rotation
from rpod.models.gravity import circular_orbit_state, gravity_acceleration


@dataclasses.dataclass
class OrbitConfig:
    """The target's orbit and the truth gravity model.

    Args:
        altitude_m: circular-orbit altitude above the equatorial radius (>= 100 km).
        inclination_deg: orbit inclination.
        raan_deg: right ascension of the ascending node.
        arg_latitude_deg: argument of latitude of the target at t = 0.
        gravity: one of 'two_body_j2', 'two_body', 'cw', 'free_space'.
        epoch_utc: the UTC date and time of t = 0, ISO 8601 (`YYYY-MM-DDTHH:MM:SS[.fff]`, an
            optional `Z`; rpod reads YAML dates as text, quoted or not); the default is
            J2000.0 (2000-01-01T12:00:00 TT) in UTC. It labels exported trajectories and
            changes no physics.
    """

    altitude_m: float = 500e3
    inclination_deg: float = 51.6
    raan_deg: float = 0.0
    arg_latitude_deg: float = 0.0
    gravity: str = "two_body_j2"
    epoch_utc: str = "2000-01-01T11:58:55.816"


EPOCH_UTC_PATTERN = re.compile(r"\d{4}-\d{2}-\d{2}T\d{2}:\d{2}:\d{2}(\.\d{1,9})?Z?")


def epoch_utc_datetime64(epoch_utc: str) -> np.datetime64:
    """The epoch as numpy.datetime64 in ns; ValueError with a one-line reason if it is not a
    valid `YYYY-MM-DDTHH:MM:SS[.fffffffff][Z]` (no leap second 60: numpy has none)."""
    if not isinstance(epoch_utc, str) or not EPOCH_UTC_PATTERN.fullmatch(epoch_utc):
        raise ValueError(
            f"expected a UTC date and time YYYY-MM-DDTHH:MM:SS[.fff][Z], got {epoch_utc!r}"
        )
    try:
        return np.datetime64(epoch_utc.removesuffix("Z"), "ns")
    except ValueError as error:  # month 13, February 30, second 60
        raise ValueError(f"not a valid date and time: {error}") from None


def initial_orbit_state(orbit: OrbitConfig) -> tuple[np.ndarray, np.ndarray]:
    """(p_IT_I, v_IT_I) at t = 0: the circular orbit of `orbit`, or rest at the origin in free
    space."""
    if orbit.gravity == "free_space":
        return np.zeros(3), np.zeros(3)
    return circular_orbit_state(
        orbit.altitude_m,
        math.radians(orbit.inclination_deg),
        math.radians(orbit.raan_deg),
        math.radians(orbit.arg_latitude_deg),
    )


def lvlh_of(p_IT_I: np.ndarray, v_IT_I: np.ndarray, gravity: str) -> tuple[np.ndarray, np.ndarray]:
    """(R_IL, w_IL_L) of the target's LVLH frame; identity and zero in free space."""
    if gravity == "free_space":
        return np.eye(3), np.zeros(3)
    a_IT_I = gravity_acceleration(p_IT_I, gravity)
    return lvlh_rotation(p_IT_I, v_IT_I), lvlh_angular_velocity(p_IT_I, v_IT_I, a_IT_I)
