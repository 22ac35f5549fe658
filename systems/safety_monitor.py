"""Safety monitor: body separation, LOS-corridor violation, relative speed at the capture points.

Owns: `SafetyMonitor`, a feedthrough system with no state, read by loggers (so its outputs are
computed only at log samples, never inside the integrator).
Does not own: the shapes (rpod.models.shapes) or any reaction to a violation.

Definitions.
- separation_m: Euclidean distance between the true convex shapes of chaser and target
  (0 when they touch or overlap), rpod.models.shapes.separation_distance.
- corridor_violation_rad: angle between the docking axis a_T and the line from the docking port
  D to the chaser's centre of mass C, minus the corridor half-angle; <= 0 inside the corridor
  (paper 000's docking cone, eq. 11, whose apex is D_t; the LOS cones of papers 001 eq. 18 and
  004 are about the target's centre, and 004's is polyhedral: rpod.models has it apart). The
  capture point E is not used: it meets D at capture, where the direction D -> E means nothing.
- port_distance_m: |p_DC|, the chaser's centre of mass from the docking port (the corridor's
  extent is measured with it).
- capture_distance_m: |p_DE|, the capture points' distance.
- capture_speed_m_s: |v_E - v_D|, the inertial relative speed of the two capture points,
  v_E = v_C + w_IC x r_CE, v_D = v_T + w_IT x r_TD.
"""

import numpy as np
from pydrake.systems.framework import LeafSystem

from rpod.models.docking import DockingGeometry
from rpod.models.frames import lvlh_to_inertial, rotation_from_wxyz
from rpod.models.shapes import ConvexPolytope, separation_distance
from rpod.systems.sensed import Sensed, declare_sensed_input


class SafetyMonitor(LeafSystem):
    """Monitors separation, corridor and capture-point speed (see the module docstring).

    Input port: sensed (33, the sensed bundle of rpod.systems.sensed).
    Output ports: separation_m (1), corridor_violation_rad (1), capture_speed_m_s (1),
        capture_distance_m (1): |p_DE|, from the docking port D to the chaser's capture point E,
        port_distance_m (1): |p_DC|, from the docking port D to the chaser's centre of mass.
    """

    def __init__(self, docking: DockingGeometry, chaser_shape: ConvexPolytope, capture_point_C):
        """Args:
        docking: the target's docking geometry (port, axis, corridor, hull), in T.
        chaser_shape: the chaser's true shape, in C.
        capture_point_C: the chaser's capture point E, in C [m].
        """
        super().__init__()
        self._docking = docking
        self._target_shape = docking.hull
        self._chaser_shape = chaser_shape
        self._p_TD_T = docking.p_TD_T
        self._p_CE_C = np.asarray(capture_point_C, float)
        self._sensed_port = declare_sensed_input(self)
        self.DeclareVectorOutputPort("separation_m", 1, self._calc_separation)
        self.DeclareVectorOutputPort("corridor_violation_rad", 1, self._calc_corridor)
        self.DeclareVectorOutputPort("capture_speed_m_s", 1, self._calc_capture_speed)
        self.DeclareVectorOutputPort("capture_distance_m", 1, self._calc_capture_distance)
        self.DeclareVectorOutputPort("port_distance_m", 1, self._calc_port_distance)

    def _poses(self, context):
        """(R_LT, R_LC, p_LC_L, v_LC_L, R_IL, w_IL_L, target, chaser) at this context."""
        sensed = Sensed.from_vector(self._sensed_port.Eval(context))
        relative = sensed.relative_state_L
        R_IL = rotation_from_wxyz(sensed.q_IL)
        target = sensed.target_attitude
        chaser = sensed.chaser_attitude
        R_LT = R_IL.T @ rotation_from_wxyz(target[0:4])
        R_LC = R_IL.T @ rotation_from_wxyz(chaser[0:4])
        w_IL_L = sensed.w_IL_L
        return R_LT, R_LC, relative[0:3], relative[3:6], R_IL, w_IL_L, target, chaser

    def _calc_separation(self, context, output):
        R_LT, R_LC, p_LC_L, *_ = self._poses(context)
        distance = separation_distance(
            self._target_shape, R_LT, np.zeros(3), self._chaser_shape, R_LC, p_LC_L
        )
        output.SetAtIndex(0, distance)

    def _calc_corridor(self, context, output):
        R_LT, _, p_LC_L, *_ = self._poses(context)
        p_DC_L = p_LC_L - R_LT @ self._p_TD_T
        output.SetAtIndex(0, self._docking.corridor_violation_rad(R_LT.T @ p_DC_L))

    def _calc_capture_distance(self, context, output):
        R_LT, R_LC, p_LC_L, *_ = self._poses(context)
        p_DE_L = p_LC_L + R_LC @ self._p_CE_C - R_LT @ self._p_TD_T
        output.SetAtIndex(0, float(np.linalg.norm(p_DE_L)))

    def _calc_port_distance(self, context, output):
        R_LT, _, p_LC_L, *_ = self._poses(context)
        output.SetAtIndex(0, float(np.linalg.norm(p_LC_L - R_LT @ self._p_TD_T)))

    def _calc_capture_speed(self, context, output):
        R_LT, R_LC, p_LC_L, v_LC_L, R_IL, w_IL_L, target, chaser = self._poses(context)
        _, v_TC_I = lvlh_to_inertial(R_IL, w_IL_L, p_LC_L, v_LC_L)
        R_IT, R_IC = R_IL @ R_LT, R_IL @ R_LC
        v_E = v_TC_I + R_IC @ np.cross(chaser[4:7], self._p_CE_C)
        v_D = R_IT @ np.cross(target[4:7], self._p_TD_T)
        output.SetAtIndex(0, float(np.linalg.norm(v_E - v_D)))
