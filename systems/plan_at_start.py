"""What a controller that plans once at start shows of its plan (rpod.diagrams.controller_seam,
"Planning once at start").

Owns: `PlannedPath`, the value of a planning controller's `planned_path` output (drawn by
rpod.systems.scene.PlannedPathOverlay), and `declare_planned_path_output`, which declares that
output on an abstract state the controller sets whenever it accepts a plan.
Does not own: any planner, or when a controller plans (its own initialization and periodic
events: rpod.systems.soft_capture_controller, rpod.systems.planar_tracking).
"""

import dataclasses

import numpy as np
from pydrake.common.value import AbstractValue, Value


@dataclasses.dataclass(frozen=True)
class PlannedPath:
    """The active plan's knots, for drawing (the ``planned_path`` output).

    Attributes:
        index: 0 before any plan; then 1, 2, ... for each accepted plan.
        t0_s: Simulated time of the plan's first knot [s].
        p_LC_L: Planned chaser positions at the knots (N, 3) in L [m].
    """

    index: int = 0
    t0_s: float = 0.0
    p_LC_L: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros((0, 3)))

    def __deepcopy__(self, memo):
        """Itself: never changed in place (Drake clones abstract state by deep copy)."""
        return self


def declare_planned_path_output(system) -> int:
    """Declares an abstract state holding a `PlannedPath` (none yet) and the ``planned_path``
    output that reads it; returns the state's index (set it with
    ``state.get_mutable_abstract_state(index).set_value(PlannedPath(...))``)."""
    index = system.DeclareAbstractState(Value[object](PlannedPath()))
    system.DeclareAbstractOutputPort(
        "planned_path",
        lambda: AbstractValue.Make(PlannedPath()),
        lambda context, output: output.set_value(context.get_abstract_state(index).get_value()),
        {system.abstract_state_ticket(index)},
    )
    return index
