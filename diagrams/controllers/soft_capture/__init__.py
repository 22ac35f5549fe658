"""Paper 000's soft capture, one package: `controller: !SoftCapture {...}`.

Plan the approach to a tumbling target's docking port (SOCP + SCP, rpod.planners.soft_capture)
and fly it in closed loop with replanning (rpod.systems.soft_capture_controller). Importing this
package registers the plug-in; no module here imports matplotlib at load except plan_figures.py,
which only `rpod plan` and the benchmarks import.

  config.py        the YAML tag's config `SoftCapture` (closed loop and planner settings).
  problem.py       the planner's problem data derived from the scenario.
  planning.py      `plan_scenario`: the plan from the initial state (`rpod plan`).
  plan_file.py     what `rpod plan` writes of it: plan.npz's arrays, the summary, the figures.
  plugin.py        `SoftCapturePlugin`: checks, wiring (path 1), scene overlay, hooks.
  metrics.py       the capture criterion, the plans' knots, summary.json's entries, outcome.
  tables.py        `rpod report`: a campaign beside paper 000 Sec. VI-B.
  plan_figures.py  the figures of plans (paper 000's Figs. 5-9).
"""

from rpod.diagrams.controller_seam import register_controller
from rpod.diagrams.controllers.soft_capture.config import SoftCapture
from rpod.diagrams.controllers.soft_capture.metrics import (
    capture_outcome,
    plan_knots,
    soft_capture_results,
)
from rpod.diagrams.controllers.soft_capture.plan_file import plan_arrays, plan_output, plan_summary
from rpod.diagrams.controllers.soft_capture.planning import ScenarioPlan, plan_scenario
from rpod.diagrams.controllers.soft_capture.plugin import LOGGED, SoftCapturePlugin
from rpod.diagrams.controllers.soft_capture.problem import controller_config, planner_config
from rpod.diagrams.controllers.soft_capture.tables import campaign_table, soft_capture_rows

__all__ = [
    "LOGGED",
    "ScenarioPlan",
    "SoftCapture",
    "SoftCapturePlugin",
    "campaign_table",
    "capture_outcome",
    "controller_config",
    "plan_arrays",
    "plan_knots",
    "plan_output",
    "plan_scenario",
    "plan_summary",
    "planner_config",
    "soft_capture_results",
    "soft_capture_rows",
]

register_controller(SoftCapturePlugin())
