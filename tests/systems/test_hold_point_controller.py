"""HoldPointController in closed form: equilibria, feed-forward terms and the reference.

The law is evaluated once through its initialization event (Simulator.Initialize), with fixed
inputs. Truths: at rest on the hold point of a still target the wrench is zero; a co-rotating
hold needs exactly the centripetal force m w x (w x p); in a rotating LVLH the CW terms are
cancelled (paper 004 eq. 12); far off the axis the reference keeps the chaser's range and leads
its line of sight by the configured step.
"""

import math

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator

from rpod.models.docking import DockingGeometry
from rpod.models.shapes import ConvexPolytope
from rpod.systems.hold_point_controller import HoldPointController, HoldPointControllerConfig
from rpod.systems.sensed import sensed_vector

MASS = 500.0
J = np.diag([190.0, 190.0, 190.0])
Q_IDENTITY = np.array([1.0, 0.0, 0.0, 0.0])
DOCKING = DockingGeometry(  # the port 1 m up the target's z axis, the axis along z
    p_TD_T=[0.0, 0.0, 1.0],
    axis_T=[0.0, 0.0, 1.0],
    corridor_half_angle_rad=math.radians(30.0),
    corridor_length_m=20.0,
    hull=ConvexPolytope.box([2.0, 2.0, 2.0]),
)
Q_FLIP_X = np.array([0.0, 1.0, 0.0, 0.0])  # 180 deg about x: z_C = -z, x_C = x


def evaluate(
    p_LC_L,
    v_LC_L=(0, 0, 0),
    w_IT_T=(0, 0, 0),
    w_IL_L=(0, 0, 0),
    q_IC=Q_FLIP_X,
    w_IC_C=(0, 0, 0),
    config=None,
):
    config = config or HoldPointControllerConfig()
    controller = HoldPointController(config, MASS, J, DOCKING, [0.0, 0.0, 0.75])
    context = controller.CreateDefaultContext()
    controller.GetInputPort("sensed").FixValue(
        context,
        sensed_vector(np.r_[p_LC_L, v_LC_L], Q_IDENTITY, np.asarray(w_IL_L, float),
                      np.r_[Q_IDENTITY, w_IT_T], np.r_[q_IC, w_IC_C]),
    )  # fmt: skip
    simulator = Simulator(controller, context)
    simulator.Initialize()
    out = {
        name: controller.GetOutputPort(name).Eval(simulator.get_context()).copy()
        for name in ("body_wrench_desired", "hold_point_L", "reference_L")
    }
    return out


def test_structure():
    controller = HoldPointController(
        HoldPointControllerConfig(), MASS, J, DOCKING, [0.0, 0.0, 0.75]
    )
    sizes = {
        controller.get_input_port(i).get_name(): controller.get_input_port(i).size()
        for i in range(controller.num_input_ports())
    }
    assert sizes == {"sensed": 33}  # the sensed bundle, rpod.systems.sensed
    assert controller.GetOutputPort("body_wrench_desired").size() == 6
    assert not controller.HasAnyDirectFeedthrough()  # held between samples


def test_at_rest_on_the_hold_point_of_a_still_target_the_wrench_is_zero():
    out = evaluate([0.0, 0.0, 11.0])  # port at 1 m + hold distance 10 m along z_T
    np.testing.assert_allclose(out["hold_point_L"], [0, 0, 11.0], atol=1e-12)
    np.testing.assert_allclose(out["reference_L"], [0, 0, 11.0], atol=1e-12)
    np.testing.assert_allclose(out["body_wrench_desired"], np.zeros(6), atol=1e-9)


def test_with_capture_the_capture_point_is_held_beyond_the_port_and_its_centre_further_out():
    # The capture point 0.75 m up z_C, the chaser turned to face the port: at rest with its
    # centre 1 + 2 + 0.75 m up z_T, its capture point is 2 m beyond the port, and the law is
    # at equilibrium there.
    config = HoldPointControllerConfig(hold_distance_m=2.0, capture=True)
    out = evaluate([0.0, 0.0, 3.75], config=config)
    np.testing.assert_allclose(out["hold_point_L"], [0, 0, 3.75], atol=1e-12)
    np.testing.assert_allclose(out["body_wrench_desired"], np.zeros(6), atol=1e-9)
    onto_the_port = HoldPointControllerConfig(hold_distance_m=0.0, capture=True)
    out = evaluate([0.0, 0.0, 1.75], config=onto_the_port)
    np.testing.assert_allclose(out["hold_point_L"], [0, 0, 1.75], atol=1e-12)


def test_co_rotating_hold_needs_exactly_the_centripetal_force():
    w = np.array([0.02, 0.0, 0.0])  # about x_T: the hold point (0, 0, 11) moves along -y
    p = np.array([0.0, 0.0, 11.0])
    v = np.cross(w, p)
    out = evaluate(p, v_LC_L=v, w_IT_T=w)
    f_L = MASS * np.cross(w, np.cross(w, p))  # m w x (w x p) = (0, 0, -m w^2 11)
    f_C = np.diag([1.0, -1.0, -1.0]) @ f_L  # R_CL for the chaser turned 180 deg about x
    np.testing.assert_allclose(out["body_wrench_desired"][3:6], f_C, atol=1e-9)


def test_cw_gravity_gradient_is_cancelled():
    n = 1.1e-3
    out = evaluate([0.0, 0.0, 11.0], w_IL_L=[0.0, 0.0, n])
    # Hold point on the orbit normal: no relative rotation of it, a_CW = (0, 0, -n^2 z).
    f_L = np.array([0.0, 0.0, MASS * n * n * 11.0])
    np.testing.assert_allclose(
        out["body_wrench_desired"][3:6], np.diag([1, -1, -1]) @ f_L, atol=1e-9
    )


def test_far_off_axis_the_reference_keeps_range_and_leads_by_the_step():
    config = HoldPointControllerConfig(max_reference_step_deg=20.0)
    p = np.array([0.0, -30.0, 0.0])  # 90 deg from the docking axis (z)
    out = evaluate(p, config=config)
    reference = out["reference_L"]
    assert np.linalg.norm(reference) == pytest.approx(30.0, rel=1e-12)
    angle = math.degrees(math.acos(reference @ p / (30.0 * 30.0)))
    assert angle == pytest.approx(20.0, abs=1e-9)
    assert reference[2] > 0  # towards the docking axis


def test_commanded_speed_is_limited():
    """Far from the reference, the PD term saturates: |f| <= m (2 zeta w_n v_max)."""
    config = HoldPointControllerConfig(max_speed_m_s=0.3)
    out = evaluate([0.0, -30.0, 0.0], config=config, q_IC=Q_IDENTITY)
    bound = MASS * 2 * config.translation_damping * config.translation_bandwidth_rad_s * 0.3
    assert np.linalg.norm(out["body_wrench_desired"][3:6]) == pytest.approx(bound, rel=1e-9)


def test_attitude_error_gives_a_restoring_torque():
    """Chaser turned 10 deg about x from the desired attitude: torque J w_n^2 e, e along -x."""
    config = HoldPointControllerConfig()
    half = math.radians(190.0) / 2  # desired is 180 deg about x; this is 190 deg
    q_IC = np.array([math.cos(half), math.sin(half), 0.0, 0.0])
    out = evaluate([0.0, 0.0, 11.0], q_IC=q_IC, config=config)
    expected = J @ np.array([-math.radians(10.0), 0, 0]) * config.attitude_bandwidth_rad_s**2
    np.testing.assert_allclose(out["body_wrench_desired"][0:3], expected, atol=1e-9)
