"""Paper 003's planar approach, one package: `controller: !PlanarApproach {...}`.

Plan paper 003's approach to a spinning square target (eqs. 5-9, rpod.planners.planar_approach)
when the diagram is built, and fly it with the PD tracker (eqs. 11-13,
rpod.systems.planar_tracking) on eight PWM thrusters. Importing this package registers the
plug-in; no module here imports matplotlib at load except figures.py and campaign_maps.py,
which the plug-in imports only when drawing.

  config.py         the YAML tag's config `PlanarApproach` (and `PlanarPlannerSettings`).
  problem.py        the planner's problem data derived from the scenario; the tracker's gains.
  reference.py      what is flown after and around the plan (co-rotating hold, face-aligned).
  planning.py       the plan at build time and the reference flown (`PlanarApproachRun`).
  plan_file.py      what `rpod plan` writes of the plan (plan.npz, summary, a figure).
  plugin.py         `PlanarApproachPlugin` and `PlanarWiring`: checks, wiring, scene, hooks.
  metrics.py        the log arrays and summary.json's entries.
  mission.py        the mission's verdict and its line.
  tables.py         `rpod report`: Case Studies 1-2 and the modulation comparison.
  figures.py        the run figures (Figs. 4-7).
  campaign_maps.py  the campaign maps (Figs. 8-9-like).
"""

from rpod.diagrams.controller_seam import register_controller
from rpod.diagrams.controllers.planar_approach.config import (
    AFTER_PLAN,
    ATTITUDE_REFERENCES,
    HOLD_FORCE_SHARE,
    PlanarApproach,
    PlanarPlannerSettings,
)
from rpod.diagrams.controllers.planar_approach.metrics import (
    formulation_text,
    plan_separation,
    planar_log,
    planar_summary,
    switch_count,
)
from rpod.diagrams.controllers.planar_approach.mission import outcome
from rpod.diagrams.controllers.planar_approach.planning import (
    PlanarApproachRun,
    make_run,
    plan_scenario,
)
from rpod.diagrams.controllers.planar_approach.plugin import (
    LOG_SHAPES,
    LOGGED,
    PlanarApproachPlugin,
    PlanarWiring,
)
from rpod.diagrams.controllers.planar_approach.problem import (
    DERIVED_FIELDS,
    PLANAR_TOLERANCE,
    initial_planar_state,
    planner_config,
    tracking_config,
)
from rpod.diagrams.controllers.planar_approach.reference import (
    HOLD_KNOT_STEP_S,
    co_rotating_hold,
    contact_reach_m,
    face_aligned_reference,
    hold_force_ratio,
)
from rpod.diagrams.controllers.planar_approach.tables import (
    UNRECORDED,
    campaign_rows,
    metric_rows,
)

__all__ = [
    "AFTER_PLAN",
    "ATTITUDE_REFERENCES",
    "DERIVED_FIELDS",
    "HOLD_FORCE_SHARE",
    "HOLD_KNOT_STEP_S",
    "LOGGED",
    "LOG_SHAPES",
    "PLANAR_TOLERANCE",
    "UNRECORDED",
    "PlanarApproach",
    "PlanarApproachPlugin",
    "PlanarApproachRun",
    "PlanarPlannerSettings",
    "PlanarWiring",
    "campaign_rows",
    "co_rotating_hold",
    "contact_reach_m",
    "face_aligned_reference",
    "formulation_text",
    "hold_force_ratio",
    "initial_planar_state",
    "make_run",
    "metric_rows",
    "outcome",
    "plan_scenario",
    "plan_separation",
    "planar_log",
    "planar_summary",
    "planner_config",
    "switch_count",
    "tracking_config",
]

register_controller(PlanarApproachPlugin())
