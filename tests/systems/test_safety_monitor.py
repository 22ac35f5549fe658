"""SafetyMonitor against hand-computed geometry.

Set-up: q_IL = identity (so L = I for orientation), target box 2 m at the origin, chaser box
1 m. Truths: face-to-face gaps of axis-aligned boxes, the angle of a point from an axis, and
rigid-body velocity of a point (v + w x r) computed by hand.
"""

import math

import numpy as np
import pytest

from rpod.models.docking import DockingGeometry
from rpod.models.shapes import ConvexPolytope
from rpod.systems.safety_monitor import SafetyMonitor
from rpod.systems.sensed import sensed_vector

IDENTITY_Q = np.array([1.0, 0.0, 0.0, 0.0])


def make(corridor_deg=30.0):
    docking = DockingGeometry(
        p_TD_T=[0.0, 0.0, 1.0],
        axis_T=[0.0, 0.0, 1.0],
        corridor_half_angle_rad=math.radians(corridor_deg),
        corridor_length_m=20.0,
        hull=ConvexPolytope.box([2.0, 2.0, 2.0]),
    )
    monitor = SafetyMonitor(docking, ConvexPolytope.box([1.0, 1.0, 1.0]), [0.0, 0.0, -0.5])
    return monitor, monitor.CreateDefaultContext()


def feed(
    monitor,
    context,
    p_LC_L,
    v_LC_L=(0, 0, 0),
    q_IT=IDENTITY_Q,
    w_IT_T=(0, 0, 0),
    q_IC=IDENTITY_Q,
    w_IC_C=(0, 0, 0),
    w_IL_L=(0, 0, 0),
):
    monitor.GetInputPort("sensed").FixValue(
        context,
        sensed_vector(np.r_[p_LC_L, v_LC_L], IDENTITY_Q, np.asarray(w_IL_L, float),
                      np.r_[q_IT, w_IT_T], np.r_[q_IC, w_IC_C]),
    )  # fmt: skip


def read(monitor, context, name):
    return monitor.GetOutputPort(name).Eval(context)[0]


def test_separation_of_axis_aligned_boxes_is_the_face_gap():
    monitor, context = make()
    feed(monitor, context, [0.0, 0.0, 5.0])  # faces at z = 1 and z = 4.5
    assert read(monitor, context, "separation_m") == pytest.approx(3.5, abs=1e-6)
    feed(monitor, context, [0.0, 1.2, 0.0])  # overlapping boxes
    assert read(monitor, context, "separation_m") == pytest.approx(0.0, abs=1e-9)


def test_separation_follows_the_target_rotation():
    """Target turned 45 deg about x: its corner reaches sqrt(2) along z, gap 5 - 0.5 - sqrt 2."""
    monitor, context = make()
    half = math.radians(45.0) / 2
    q_IT = np.array([math.cos(half), math.sin(half), 0.0, 0.0])
    feed(monitor, context, [0.0, 0.0, 5.0], q_IT=q_IT)
    assert read(monitor, context, "separation_m") == pytest.approx(4.5 - math.sqrt(2), abs=1e-6)


def test_corridor_violation_is_angle_from_docking_axis_minus_half_angle():
    monitor, context = make(corridor_deg=30.0)
    # Chaser centre of mass C at (3, 0, 4); port D at (0, 0, 1): D->C = (3, 0, 3): 45 deg.
    # (paper 000's docking cone, eq. 11, has its apex at the port and constrains the centre of
    # mass; the capture point E, 0.5 m below C here, is not used.)
    feed(monitor, context, [3.0, 0.0, 4.0])
    assert read(monitor, context, "corridor_violation_rad") == pytest.approx(
        math.radians(45.0 - 30.0), abs=1e-12
    )
    feed(monitor, context, [0.0, 0.0, 10.0])  # on the axis: 30 deg inside
    assert read(monitor, context, "corridor_violation_rad") == pytest.approx(
        -math.radians(30.0), abs=1e-7
    )


def test_capture_speed_is_relative_velocity_of_the_two_capture_points():
    monitor, context = make()
    w_IT_T = np.array([0.0, 0.1, 0.0])  # port D = (0,0,1): v_D = w x D = (0.1, 0, 0)
    w_IC_C = np.array([0.2, 0.0, 0.0])  # E = (0,0,-0.5) from C: w x E = (0, 0.1, 0)
    v_LC_L = np.array([0.05, 0.0, -0.02])
    feed(monitor, context, [0.0, 0.0, 5.0], v_LC_L=v_LC_L, w_IT_T=w_IT_T, w_IC_C=w_IC_C)
    expected = np.linalg.norm(v_LC_L + [0.0, 0.1, 0.0] - [0.1, 0.0, 0.0])
    assert read(monitor, context, "capture_speed_m_s") == pytest.approx(expected, abs=1e-12)


def test_capture_speed_includes_the_lvlh_transport_velocity():
    """A chaser fixed in the rotating L at p moves in I at w_IL x p."""
    monitor, context = make()
    w_IL_L = np.array([0.0, 0.0, 0.001])
    feed(monitor, context, [0.0, 0.0, 5.0], w_IL_L=w_IL_L)
    # p_LC_L = (0,0,5) is along w: no transport; move it to x.
    feed(monitor, context, [5.0, 0.0, 0.0], w_IL_L=w_IL_L)
    assert read(monitor, context, "capture_speed_m_s") == pytest.approx(0.005, abs=1e-12)
