"""The hold-point controller's config: the YAML tag `!HoldPoint`.

Owns: `HoldPoint`, the fields of rpod.systems.hold_point_controller.HoldPointControllerConfig
under the tag (their meanings and `validate()` are the law's).
Does not own: the law (systems/hold_point_controller.py) or its wiring (plugin.py).
"""

import dataclasses

from rpod.systems.hold_point_controller import HoldPointControllerConfig


@dataclasses.dataclass
class HoldPoint(HoldPointControllerConfig):
    """Fly to and hold a point on the target's rotating docking axis (fields: see the base)."""
