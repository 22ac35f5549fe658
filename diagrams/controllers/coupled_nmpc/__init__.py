"""Paper 001's coupled 6-DOF NMPC, one package: `controller: !CoupledNmpc {...}`.

A nonlinear MPC of the chaser's relative attitude and feature-point motion (the rock on a
tumbling asteroid, the end effector on the chaser) commanding eight gimbaled thrusters' force
vectors (rpod.systems.coupled_nmpc_controller). Importing this package registers the plug-in;
no module here imports matplotlib at load.

  config.py   the YAML tag's config `CoupledNmpc` and its validate().
  problem.py  the problem data derived from the scenario, and the planner built on it.
  plugin.py   `CoupledNmpcPlugin`: checks, wiring (path 2), scene, hooks.
  metrics.py  the measures (truth state, applied forces and limits, gimbal face-angles, LOS),
              the log arrays and summary.json's entries.
  mission.py  the mission's verdict and its line.
  figures.py  the run figures (coupled_state.png, coupled_thrusters.png, coupled_nmpc.png).
"""

from rpod.diagrams.controller_seam import register_controller
from rpod.diagrams.controllers.coupled_nmpc.config import INTEGRAL_WEIGHT, CoupledNmpc
from rpod.diagrams.controllers.coupled_nmpc.metrics import (
    ATTITUDE_TOLERANCE_DEG,
    CONSTRAINT_TOLERANCE_N,
    DISTANCE_TOLERANCE_M,
    LOS_TOLERANCE_M,
    STATUS_LOG_KEY,
    applied_forces,
    constraint_excess,
    gimbal_face_angles,
    los_counted_outside,
    outside_summary,
    truth_relative_states,
)
from rpod.diagrams.controllers.coupled_nmpc.mission import coupled_outcome
from rpod.diagrams.controllers.coupled_nmpc.plugin import (
    GRAVITIES,
    LAYOUT,
    LOG_SHAPES,
    CoupledNmpcPlugin,
)
from rpod.diagrams.controllers.coupled_nmpc.problem import (
    coupled_params,
    feature_points,
    make_planner,
)

__all__ = [
    "ATTITUDE_TOLERANCE_DEG",
    "CONSTRAINT_TOLERANCE_N",
    "DISTANCE_TOLERANCE_M",
    "GRAVITIES",
    "INTEGRAL_WEIGHT",
    "LAYOUT",
    "LOG_SHAPES",
    "LOS_TOLERANCE_M",
    "STATUS_LOG_KEY",
    "CoupledNmpc",
    "CoupledNmpcPlugin",
    "applied_forces",
    "constraint_excess",
    "coupled_outcome",
    "coupled_params",
    "feature_points",
    "gimbal_face_angles",
    "los_counted_outside",
    "make_planner",
    "outside_summary",
    "truth_relative_states",
]

register_controller(CoupledNmpcPlugin())
