"""rpod's built-in controller plug-ins (rpod.diagrams.controller_seam); importing registers them.

`!HoldPoint` (hold_point.py, the default), `!SoftCapture` (soft_capture.py), `!LosCorridor`
(los_corridor.py, paper 004) and `!CoupledNmpc` (coupled_nmpc.py, paper 001). Other packages
add controllers through the entry point group `rpod.controllers`, or by calling
`rpod.diagrams.controller_seam.register_controller` before loading a scenario.
"""

from rpod.diagrams.controllers import (  # noqa: F401
    coupled_nmpc,
    hold_point,
    los_corridor,
    planar_approach,
    soft_capture,
)
