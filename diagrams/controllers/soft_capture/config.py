"""Paper 000's soft capture config: the YAML tag `!SoftCapture`.

Owns: `SoftCapture`, the closed loop's fields (rpod.systems.soft_capture_controller's
SoftCaptureControllerConfig) and the planner's *settings* (`planner:`: Table I weights,
bounds, tolerances, horizon search); the planner's problem data come from the scenario
(problem.py), never written twice.
Does not own: the closed loop's and the planner's own fields and checks, or the wiring
(plugin.py).
"""

import dataclasses

from rpod.planners.soft_capture import SoftCaptureSettings
from rpod.systems.soft_capture_controller import SoftCaptureControllerConfig


@dataclasses.dataclass
class SoftCapture(SoftCaptureControllerConfig):
    """Plan and fly paper 000's soft capture (closed-loop fields: see the base class).

    Args:
        planner: the planner's settings (Table I weights, bounds, tolerances, horizon search);
            its problem data come from the scenario (`planner_config`).
    """

    planner: SoftCaptureSettings = dataclasses.field(default_factory=SoftCaptureSettings)
