"""rpod's built-in controller plug-ins (rpod.diagrams.controller_seam); importing registers them.

Each method is one package here that owns its config, wiring, metrics, figures, scene extras and
campaign tables; nothing above it names it (DESIGN.md, "Guidance seam"):
`!HoldPoint` (hold_point/, the default), `!SoftCapture` (soft_capture/, paper 000),
`!CoupledNmpc` (coupled_nmpc/, paper 001), `!PlanarApproach` (planar_approach/, paper 003) and
`!LosCorridor` (los_corridor/, paper 004). Other packages add controllers through the entry
point group `rpod.controllers`, or by calling
`rpod.diagrams.controller_seam.register_controller` before loading a scenario.
"""

from rpod.diagrams.controllers import (  # noqa: F401
    coupled_nmpc,
    hold_point,
    los_corridor,
    planar_approach,
    soft_capture,
)
