"""The hold-point controller, one package: `controller: !HoldPoint {...}` (the default).

The chaser flies to and holds a point on the target's rotating docking axis
(rpod.systems.hold_point_controller). Importing this package registers the plug-in.

  config.py   `HoldPoint`, the YAML tag's config.
  plugin.py   `HoldPointPlugin`: the law on path 1 (body wrench -> allocator -> PWM ->
              thrusters), what it logs, its results.
  metrics.py  the hold errors, when the hold was reached, the mission outcome.
It draws no figures of its own (the generic ones show the hold point: hold_point_L).
"""

from rpod.diagrams.controller_seam import register_controller
from rpod.diagrams.controllers.hold_point.config import HoldPoint
from rpod.diagrams.controllers.hold_point.metrics import (
    HOLD_POSITION_TOLERANCE_M,
    HOLD_SPEED_TOLERANCE_M_S,
    hold_errors,
    hold_results,
)
from rpod.diagrams.controllers.hold_point.plugin import HoldPointPlugin

__all__ = [
    "HOLD_POSITION_TOLERANCE_M",
    "HOLD_SPEED_TOLERANCE_M_S",
    "HoldPoint",
    "HoldPointPlugin",
    "hold_errors",
    "hold_results",
]

register_controller(HoldPointPlugin(), default=True)
