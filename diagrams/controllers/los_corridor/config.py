"""Paper 004's guidance config: the YAML tag `!LosCorridor`.

Owns: `LosCorridor` (the fields of rpod.systems.los_guidance.LosGuidanceConfig plus how the
guidance is flown and how far the scene draws the corridor) and its `validate()`; the choices
of `actuation` and the PWM period of `actuation: thrusters`.
Does not own: the guidance's own fields and checks (LosGuidanceConfig), the wiring (plugin.py).
"""

import dataclasses

from rpod.models.config import ConfigError, positive
from rpod.systems.los_guidance import LosGuidanceConfig

ACTUATIONS = ("ideal", "thrusters")
THRUSTER_PERIOD_S = 0.1  # the PWM period of `actuation: thrusters` (10 Hz, as the hold point)


@dataclasses.dataclass
class LosCorridor(LosGuidanceConfig):
    """Paper 004's guidance (fields: see LosGuidanceConfig) and how it is flown.

    Args:
        actuation: 'ideal' (paper 004: an ideal acceleration in L, box-bounded by a_max) or
            'thrusters' (the scenario's fixed thruster bank through the allocator and PWM at
            10 Hz, the chaser's attitude held in L).
        drawn_length_m: how far along +y_T the scene draws the LOS corridor [m]: beyond the
            floor, within the scenario's MAX_RANGE_M (1000 km). Only the scene's; the docking
            corridor of the summary's violation metric is target.corridor_length_m.
    """

    actuation: str = "ideal"
    drawn_length_m: float = positive(60.0, 1e6)

    def validate(self) -> None:
        """Raises ConfigError naming the first bad field (LosGuidanceConfig's first)."""
        super().validate()
        if self.actuation not in ACTUATIONS:
            raise ConfigError("actuation", f"must be one of {ACTUATIONS}, got {self.actuation!r}")
        if not self.drawn_length_m > self.floor_m:
            raise ConfigError("drawn_length_m", f"must be beyond the floor ({self.floor_m} m)")
