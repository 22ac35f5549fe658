"""Paper 004's rotating-LOS-corridor guidance, one package: `controller: !LosCorridor {...}`.

The guidance (rpod.systems.los_guidance: a PD law filtered by an MPC QP that keeps the chaser
in a corridor turning with the target) flown on an ideal acceleration or on the thrusters.
Importing this package registers the plug-in; no module here imports matplotlib at load.

  config.py                the YAML tag's config `LosCorridor` and its validate().
  plugin.py                `LosCorridorPlugin`: checks, load warnings, wiring, scene, hooks.
  metrics.py               `violation_summary`, the log arrays, summary and mission outcome.
  tables.py                `rpod report`: Table 3 and the Monte Carlo set beside the paper.
  figures.py               the run figures (los_corridor.png, los_body_frame.png).
  reachability_figures.py  the safe-start sets (Secs. 8-11; benchmarks/bench_reachability.py).
  monte_carlo_figures.py   the Monte Carlo set X_MC (Figs. 2-3; los_monte_carlo_report.py).
"""

from rpod.diagrams.controller_seam import register_controller
from rpod.diagrams.controllers.los_corridor.config import (
    ACTUATIONS,
    THRUSTER_PERIOD_S,
    LosCorridor,
)
from rpod.diagrams.controllers.los_corridor.metrics import (
    applied_acceleration_L,
    los_results,
    violation_summary,
)
from rpod.diagrams.controllers.los_corridor.plugin import LOG_SHAPES, LosCorridorPlugin
from rpod.diagrams.controllers.los_corridor.tables import (
    PAPER_TABLE_3,
    campaign_table,
    controller_variants,
    monte_carlo_rows,
    table3_rows,
)

__all__ = [
    "ACTUATIONS",
    "LOG_SHAPES",
    "PAPER_TABLE_3",
    "THRUSTER_PERIOD_S",
    "LosCorridor",
    "LosCorridorPlugin",
    "applied_acceleration_L",
    "campaign_table",
    "controller_variants",
    "los_results",
    "monte_carlo_rows",
    "table3_rows",
    "violation_summary",
]

register_controller(LosCorridorPlugin())
