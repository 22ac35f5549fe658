"""Paper 004's guidance config: the YAML tag `!LosCorridor`.

Owns: `LosCorridor` (the fields of rpod.systems.los_guidance.LosGuidanceConfig plus how the
guidance is flown and how far the scene draws the corridor) and its `validate()`; the choices
of `actuation` and the PWM period of `actuation: thrusters`.
Does not own: the guidance's own fields and checks (LosGuidanceConfig), the wiring (plugin.py).
"""

import dataclasses

from rpod.models.config import ConfigError, bounded, positive
from rpod.systems.los_guidance import LosGuidanceConfig

ACTUATIONS = ("ideal", "thrusters")
CORRIDOR_AXES = ("y_T", "docking")
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
        corridor_axis: 'y_T' (paper 004: the corridor about the target's +y body axis) or
            'docking' (about the scenario's target.docking_axis_T, its apex still the target's
            centre: the port must lie on that axis; rpod.models.los_corridor.corridor_frame_R_TK).
            The shoot-out's option (issue 22): its target docks along +z_T.
        capture: fly the chaser's capture point onto the port (the shoot-out's final regime;
            the paper's guidance stops at a hold point): the hold point H is then where the
            chaser's centre is when its capture point is hold_distance_m beyond the port (0:
            on it) with the capture axis on the corridor's axis, and the chaser's attitude
            points the capture axis at the target's centre, its roll following the target's
            (rpod.systems.capture_pointing), instead of being held in L. Needs `actuation:
            thrusters` and `corridor_axis: docking`. The last metres are the guidance's own
            close approach and hold regimes onto that H, under the corridor and the MPC; the
            capture is judged by the scenario's mission (`mission: !Capture`).
    """

    # With capture, 0 (the capture point on the port) is allowed; without, the guidance's own
    # check (beyond the floor) still refuses it.
    hold_distance_m: float = bounded(10.0, 0.0, 1e6)
    actuation: str = "ideal"
    drawn_length_m: float = positive(60.0, 1e6)
    corridor_axis: str = "y_T"
    capture: bool = False

    def validate(self) -> None:
        """Raises ConfigError naming the first bad field (LosGuidanceConfig's first). With
        `capture`, hold_distance_m is the capture point's beyond the port, in [0, 1e6] m; the
        centre's distance the guidance flies to is checked when the plug-in builds it."""
        if self.capture:
            if not 0.0 <= self.hold_distance_m <= 1e6:
                raise ConfigError(
                    "hold_distance_m",
                    f"with capture: beyond the port, in [0, 1e6] m, got {self.hold_distance_m}",
                )
            # The other fields as the paper's guidance checks them.
            dataclasses.replace(self, capture=False, hold_distance_m=self.floor_m + 1.0).validate()
        else:
            super().validate()
        if self.actuation not in ACTUATIONS:
            raise ConfigError("actuation", f"must be one of {ACTUATIONS}, got {self.actuation!r}")
        if not self.drawn_length_m > self.floor_m:
            raise ConfigError("drawn_length_m", f"must be beyond the floor ({self.floor_m} m)")
        if self.corridor_axis not in CORRIDOR_AXES:
            raise ConfigError(
                "corridor_axis", f"must be one of {CORRIDOR_AXES}, got {self.corridor_axis!r}"
            )
        if self.capture and self.actuation != "thrusters":
            raise ConfigError("capture", "needs actuation: thrusters (the attitude is flown)")
        if self.capture and self.corridor_axis != "docking":
            raise ConfigError("capture", "needs corridor_axis: docking (the port's axis)")
