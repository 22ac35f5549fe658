"""Safety monitor: body separation and contact, corridor violation, capture-point speed.

Owns: `SafetyMonitor`, a feedthrough system with no state, read by loggers (so its outputs are
computed only at log samples, never inside the integrator), and `ContactWatch`, the contact
check of the true shapes at every integrator step end (simulate calls it from the
Simulator's monitor, which adds no event and so never changes a step).
Does not own: the shapes (rpod.models.shapes) or any reaction to a violation.

Definitions.
- separation_m: Euclidean distance between the true convex shapes of chaser and target
  (0 when they touch or overlap), rpod.models.shapes.separation_distance.
- penetration_m: how deep the true shapes overlap (the shortest translation that separates
  them; 0 when apart or touching), rpod.models.shapes.ContactTest.
- contact (ContactWatch): the shapes touch or overlap (ContactTest depth >= 0), checked at
  every integrator step end and at every log sample. Contact is one event for every method:
  simulate fails the mission on it, whatever the controller says.
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

import math

import numpy as np

from rpod.models.docking import DockingGeometry
from rpod.models.frames import cross, lvlh_to_inertial, rotation_from_wxyz
from rpod.models.shapes import ContactTest, ConvexPolytope, separation_distance
from rpod.systems.lifetime import LeafSystem
from rpod.systems.sensed import SENSED_PORT, Sensed, declare_sensed_input


class SafetyMonitor(LeafSystem):
    """Monitors separation, corridor and capture-point speed (see the module docstring).

    Input port: sensed (33, the sensed bundle of rpod.systems.sensed).
    Output ports: separation_m (1), penetration_m (1), corridor_violation_rad (1),
        capture_speed_m_s (1),
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
        self.contact_test = ContactTest(self._target_shape, chaser_shape)
        self._sensed_port = declare_sensed_input(self)
        self.DeclareVectorOutputPort("separation_m", 1, self._calc_separation)
        self.DeclareVectorOutputPort("penetration_m", 1, self._calc_penetration)
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

    def contact_depth_m(self, context) -> float:
        """ContactTest's depth of the true shapes at this context (> 0 overlap, 0 touching,
        < 0 apart), in L with the target at the origin."""
        R_LT, R_LC, p_LC_L, *_ = self._poses(context)
        return self.contact_test.depth(R_LT, np.zeros(3), R_LC, p_LC_L)

    def _calc_penetration(self, context, output):
        output.SetAtIndex(0, max(0.0, self.contact_depth_m(context)))

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
        v_E = v_TC_I + R_IC @ cross(chaser[4:7], self._p_CE_C)
        v_D = R_IT @ cross(target[4:7], self._p_TD_T)
        output.SetAtIndex(0, float(np.linalg.norm(v_E - v_D)))


class ContactWatch:
    """Contact of the true shapes over a whole run, checked at every integrator step end.

    `observe(root_context)` is called by simulate's Simulator monitor after every step (and
    after Initialize); it reads the safety monitor's inputs, so it adds no event and changes
    no step. Between step ends nothing is checked: the steps end at every PWM slot (10 ms),
    control period and log sample, so a contact shorter than a step can be missed, never one
    that lasts a step. A bounding-sphere test skips the separating-axis test while the bodies
    are far apart.
    """

    MAX_INTERVALS = 20  # intervals kept in the summary (their count is always exact)

    def __init__(self, monitor: SafetyMonitor, truth=None):
        """Args:
        monitor: the diagram's SafetyMonitor (its shapes and inputs are used).
        truth: the diagram's Truth: its `separation_of_origins_m` skips the test cheaply while
            the bodies' bounding spheres are apart (None, or a truth without it such as the
            tested reference tests.reference.split_truth.SplitTruth: the monitor's input is
            read instead).
        """
        self._monitor = monitor
        self._truth = truth if hasattr(truth, "separation_of_origins_m") else None
        self._far_m = monitor.contact_test.bounding_radius_sum_m
        self.intervals: list[list[float]] = []  # [first, last] step-end times in contact
        self.interval_count = 0
        self.max_depth_m = 0.0
        self.max_depth_t_s = None
        self.checks = 0
        self.origin_distance_m = math.inf  # |p_TC| at the last step checked
        self._in_contact = False

    def observe(self, root_context) -> None:
        """Checks the shapes at this step end (root_context: the diagram's context)."""
        t = root_context.get_time()
        self.checks += 1
        context = None
        if self._truth is not None:
            distance = self._truth.separation_of_origins_m(
                self._truth.GetMyContextFromRoot(root_context)
            )
        else:
            context = self._monitor.GetMyContextFromRoot(root_context)
            x, y, z = self._monitor.GetInputPort(SENSED_PORT).Eval(context)[0:3]  # p_LC_L
            distance = math.sqrt(x * x + y * y + z * z)
        self.origin_distance_m = distance
        if distance > self._far_m:
            self._in_contact = False  # beyond the bounding spheres: no rotation needed
            return
        context = context or self._monitor.GetMyContextFromRoot(root_context)
        depth = self._monitor.contact_depth_m(context)
        if depth < 0.0:
            self._in_contact = False
            return
        if not self._in_contact:
            self.interval_count += 1
            if len(self.intervals) < self.MAX_INTERVALS:
                self.intervals.append([t, t])
        elif self.interval_count <= self.MAX_INTERVALS:
            self.intervals[-1][1] = t
        self._in_contact = True
        if self.max_depth_t_s is None or depth > self.max_depth_m:
            self.max_depth_m, self.max_depth_t_s = depth, t

    def summary(self, log: dict | None = None) -> dict:
        """summary.json's `contact`: whether, when and how deep (log samples included).

        Args:
            log: the run's log; its `penetration_m` and `separation_m` at the samples are
                folded in (a sample is a step end too, so they agree; both are checked).
        """
        occurred = self.interval_count > 0
        first = self.intervals[0][0] if occurred else None
        last = self.intervals[-1][1] if occurred else None
        max_depth, max_t = self.max_depth_m, self.max_depth_t_s
        if log is not None:
            touching = np.flatnonzero(log["separation_m"] <= 0.0)
            if touching.size:
                t = log["t"][touching]
                depth = log["penetration_m"][touching]
                first = float(t[0]) if first is None else min(first, float(t[0]))
                last = float(t[-1]) if last is None else max(last, float(t[-1]))
                if max_t is None or float(depth.max()) > max_depth:
                    max_depth, max_t = float(depth.max()), float(t[int(np.argmax(depth))])
                occurred = True
        return {
            "occurred": bool(occurred),
            "first_s": first,
            "last_s": last,
            "intervals": self.interval_count if self.interval_count else int(occurred),
            "intervals_s": [list(map(float, i)) for i in self.intervals],
            "time_in_contact_s": float(sum(b - a for a, b in self.intervals)),
            "max_depth_m": float(max_depth) if occurred else 0.0,
            "max_depth_t_s": max_t if occurred else None,
            "checks": self.checks,
            "checked_at": "every integrator step end and every log sample",
        }
