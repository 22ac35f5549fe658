"""IdealActuator (actuation path 3): the bound, the frame rotation and the propellant flow,
each against a hand computation."""

import numpy as np
import pytest
from pydrake.math import RollPitchYaw, RotationMatrix

from rpod.models.thrusters import STANDARD_GRAVITY_M_S2
from rpod.systems.ideal_actuator import IdealActuator, bound_command
from rpod.systems.sensed import sensed_vector

MASS_KG, ISP_S = 400.0, 220.0


def _evaluate(actuator, command, R_IL, R_IC):
    context = actuator.CreateDefaultContext()
    q_IL = RotationMatrix(R_IL).ToQuaternion().wxyz()
    q_IC = RotationMatrix(R_IC).ToQuaternion().wxyz()
    actuator.GetInputPort("command").FixValue(context, np.asarray(command, float))
    actuator.GetInputPort("chaser_mass").FixValue(context, [MASS_KG])
    actuator.GetInputPort("sensed").FixValue(
        context, sensed_vector(np.zeros(6), q_IL, np.zeros(3), np.r_[1, 0, 0, 0, 0, 0, 0],
                               np.r_[q_IC, 0, 0, 0])
    )  # fmt: skip
    wrench = actuator.GetOutputPort("body_wrench").Eval(context)
    flow = actuator.GetOutputPort("propellant_mass_flow").Eval(context)[0]
    clipped = actuator.GetOutputPort("command_clipped").Eval(context)[0]
    return wrench, flow, clipped


def test_box_bound_clips_each_component_as_paper_004_eq_11e():
    bounded, clipped = bound_command([0.3, -0.05, -0.2], "box", 0.1)
    np.testing.assert_array_equal(bounded, [0.1, -0.05, -0.1])
    assert clipped
    bounded, clipped = bound_command([0.05, -0.05, 0.1], "box", 0.1)
    assert not clipped and np.array_equal(bounded, [0.05, -0.05, 0.1])


def test_norm_bound_scales_the_vector_and_nan_reads_as_zero():
    bounded, clipped = bound_command([3.0, 4.0, 0.0], "norm", 1.0)
    np.testing.assert_allclose(bounded, [0.6, 0.8, 0.0], rtol=1e-15)
    assert clipped
    bounded, clipped = bound_command([np.nan, 0.5, 0.0], "norm", 1.0)
    np.testing.assert_array_equal(bounded, [0.0, 0.5, 0.0])


def test_acceleration_in_L_becomes_the_force_in_C_and_its_mass_flow():
    R_IL = RotationMatrix(RollPitchYaw(0.1, -0.4, 1.2)).matrix()
    R_IC = RotationMatrix(RollPitchYaw(-0.7, 0.2, 0.3)).matrix()
    a_L = np.array([0.02, -0.05, 0.08])
    actuator = IdealActuator("acceleration", "L", "box", 0.1, ISP_S)
    wrench, flow, clipped = _evaluate(actuator, a_L, R_IL, R_IC)
    f_C = MASS_KG * R_IC.T @ R_IL @ a_L  # f_C = m R_CL a_L
    np.testing.assert_allclose(wrench, np.r_[0.0, 0.0, 0.0, f_C], atol=1e-12)
    assert flow == pytest.approx(np.linalg.norm(f_C) / (STANDARD_GRAVITY_M_S2 * ISP_S), rel=1e-14)
    assert clipped == 0.0


def test_force_in_C_passes_through_and_the_bound_is_on_the_command():
    actuator = IdealActuator("force", "C", "norm", 10.0, ISP_S)
    wrench, flow, clipped = _evaluate(actuator, [30.0, 0.0, 40.0], np.eye(3), np.eye(3))
    np.testing.assert_allclose(wrench[3:], [6.0, 0.0, 8.0], rtol=1e-15)
    assert clipped == 1.0
    assert flow == pytest.approx(10.0 / (STANDARD_GRAVITY_M_S2 * ISP_S), rel=1e-14)


def test_bad_settings_are_refused():
    for args in (("jerk", "L", "box", 1.0), ("force", "I", "box", 1.0), ("force", "L", "box", 0.0)):
        with pytest.raises(ValueError):
            IdealActuator(*args, ISP_S)
