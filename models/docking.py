"""The target's docking geometry: one object that every user of it takes.

Owns: `DockingGeometry` (the docking port D, the docking axis, the approach corridor's circular
cone and extent, and the target's true hull, all in the target body frame T) and the corridor's
angle law, so that the safety monitor, the controllers and the scene read the same numbers; and
paper 000's capture pose (`R_TC_CAPTURE`, `capture_reach_T`), which the planner, its checker and
the closed loop share.
Does not own: the scenario fields it is built from (rpod.diagrams.scenario.docking_geometry),
or paper 004's polyhedral corridor (a different shape, kept apart when it comes).
"""

import dataclasses
import math

import numpy as np

from rpod.models.shapes import ConvexPolytope


@dataclasses.dataclass(frozen=True)
class DockingGeometry:
    """The docking port, axis, corridor and hull of the target, in T.

    Attributes:
        p_TD_T: the docking port D from the target's centre of mass, in T [m].
        axis_T: the docking axis, a unit vector in T (normalised here); the corridor opens
            along it from D.
        corridor_half_angle_rad: the corridor cone's half-angle about the axis.
        corridor_length_m: the corridor's extent from D [m] (what counts as inside it).
        hull: the target's true convex shape, in T.
    """

    p_TD_T: np.ndarray
    axis_T: np.ndarray
    corridor_half_angle_rad: float
    corridor_length_m: float
    hull: ConvexPolytope

    def __post_init__(self):
        axis = np.asarray(self.axis_T, dtype=float)
        norm = float(np.linalg.norm(axis))
        if not (axis.shape == (3,) and math.isfinite(norm) and norm > 1e-12):
            raise ValueError(f"axis_T must be a non-zero 3-vector, got {self.axis_T}")
        object.__setattr__(self, "axis_T", axis / norm)
        object.__setattr__(self, "p_TD_T", np.asarray(self.p_TD_T, dtype=float))
        if not 0.0 < self.corridor_half_angle_rad < math.pi / 2:
            raise ValueError("corridor_half_angle_rad must be in (0, pi/2)")
        if not (math.isfinite(self.corridor_length_m) and self.corridor_length_m > 0):
            raise ValueError("corridor_length_m must be positive")

    def corridor_violation_rad(self, p_DX_T) -> float:
        """Angle between the axis and the line D -> X, minus the half-angle (<= 0: inside)."""
        p = np.asarray(p_DX_T, dtype=float)
        cos_angle = float(self.axis_T @ p) / max(float(np.linalg.norm(p)), 1e-12)
        return math.acos(min(1.0, max(-1.0, cos_angle))) - self.corridor_half_angle_rad


# Paper 000's capture pose: the chaser turned by 180 deg about the target's y axis, Q_y(pi), so
# that its capture axis D_c faces the target's D_t (Table I: D_c = D_t = [0, 0, 2.7] m).
R_TC_CAPTURE = np.diag([-1.0, 1.0, -1.0])


def capture_reach_T(p_CDc_C, p_TDt_T) -> np.ndarray:
    """The chaser's centre of mass at capture, from the target's, in T: the capture points meet,
    D_t = p_TC + R_TC D_c, so p_TC = D_t - R_TC_CAPTURE D_c (= D_t + D_c for Table I)."""
    return np.asarray(p_TDt_T, dtype=float) - R_TC_CAPTURE @ np.asarray(p_CDc_C, dtype=float)
