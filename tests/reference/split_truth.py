"""The truth as it was before `Truth`: four systems wired into one Diagram with Truth's ports.

Test-only reference (tests/reference, not part of the rpod package).
Owns: `SplitTruth`, a Diagram of `OrbitalDynamics`, two `RigidBodyAttitude` and (with thrusters)
`ThrusterBank`, connected as rpod.diagrams.builder connected them before the truth became one
system (chaser attitude into the orbit's force rotation, the bank's torque into the chaser
attitude, its force and mass flow into the orbit). It has `Truth`'s constructor, state layout and
port names, so it can stand in for `Truth` in a diagram.
Does not own any equation: it only wires the four systems.

What it is for: the independent reference the fast `Truth` is checked and measured against
(tests/systems/test_truth.py compares derivatives, trajectories and closed-loop runs;
benchmarks/bench_hold_point.py times both). The diagrams rpod builds do not use it.
"""

from __future__ import annotations

import numpy as np
from pydrake.systems.framework import Diagram, DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource, Demultiplexer

from rpod.models.orbit import OrbitConfig
from rpod.models.thrusters import ThrusterLayout
from rpod.systems.thruster_bank import ThrusterBank

from .orbital_dynamics import OrbitalDynamics
from .rigid_body_attitude import RigidBodyAttitude


class SplitTruth(Diagram):
    """`Truth` as four systems (see the module docstring); same arguments, state and ports."""

    def __init__(
        self,
        orbit: OrbitConfig,
        p_LC_L0: np.ndarray,
        v_LC_L0: np.ndarray,
        chaser_mass_kg: float,
        J_T: np.ndarray,
        q_IT0: np.ndarray,
        w_IT_T0: np.ndarray,
        J_C: np.ndarray,
        q_IC0: np.ndarray,
        w_IC_C0: np.ndarray,
        layout: ThrusterLayout | None = None,
        report_tolerance: float = 1e-6,
        wrench_input: bool = False,
    ):
        """Builds the four systems and wires them; arguments as `Truth`."""
        super().__init__()
        builder = DiagramBuilder()
        orbital = builder.AddNamedSystem(
            "orbital_dynamics",
            OrbitalDynamics(
                orbit,
                np.asarray(p_LC_L0, float),
                np.asarray(v_LC_L0, float),
                chaser_mass_kg,
                force_frame="C",
            ),
        )
        target = builder.AddNamedSystem(
            "target_attitude", RigidBodyAttitude(J_T, q_IT0, w_IT_T0, with_torque_input=False)
        )
        chaser = builder.AddNamedSystem(
            "chaser_attitude", RigidBodyAttitude(J_C, q_IC0, w_IC_C0, with_torque_input=True)
        )
        connect = builder.Connect
        connect(chaser.GetOutputPort("attitude"), orbital.GetInputPort("chaser_attitude"))
        if layout is not None:
            bank = builder.AddNamedSystem("thruster_bank", ThrusterBank(layout, report_tolerance))
            split = builder.AddNamedSystem("body_wrench_split", Demultiplexer([3, 3]))
            connect(bank.GetOutputPort("body_wrench"), split.get_input_port(0))
            connect(split.get_output_port(0), chaser.GetInputPort("body_torque"))
            connect(bank.GetOutputPort("body_wrench"), orbital.GetInputPort("body_wrench"))
            connect(
                bank.GetOutputPort("propellant_mass_flow"),
                orbital.GetInputPort("propellant_mass_flow"),
            )
            builder.ExportInput(bank.GetInputPort("thruster_command"), "thruster_command")
            for name in ("body_wrench", "propellant_mass_flow", "command_clipped"):
                builder.ExportOutput(bank.GetOutputPort(name), name)
        elif wrench_input:  # the wrench and the mass flow come from outside
            split = builder.AddNamedSystem("body_wrench_split", Demultiplexer([3, 3]))
            builder.ExportInput(split.get_input_port(0), "body_wrench")
            builder.ConnectInput("body_wrench", orbital.GetInputPort("body_wrench"))
            connect(split.get_output_port(0), chaser.GetInputPort("body_torque"))
            builder.ExportInput(
                orbital.GetInputPort("propellant_mass_flow"), "propellant_mass_flow"
            )
        else:
            zero_wrench = builder.AddNamedSystem("no_thrust", ConstantVectorSource(np.zeros(6)))
            zero_flow = builder.AddNamedSystem("no_mass_flow", ConstantVectorSource(np.zeros(1)))
            zero_torque = builder.AddNamedSystem("no_torque", ConstantVectorSource(np.zeros(3)))
            connect(zero_wrench.get_output_port(), orbital.GetInputPort("body_wrench"))
            connect(zero_flow.get_output_port(), orbital.GetInputPort("propellant_mass_flow"))
            connect(zero_torque.get_output_port(), chaser.GetInputPort("body_torque"))
        for name in (
            "target_state_I",
            "chaser_state_I",
            "relative_state_L",
            "q_IL",
            "w_IL_L",
            "chaser_mass",
        ):
            builder.ExportOutput(orbital.GetOutputPort(name), name)
        builder.ExportOutput(target.GetOutputPort("attitude"), "target_attitude")
        builder.ExportOutput(chaser.GetOutputPort("attitude"), "chaser_attitude")
        builder.BuildInto(self)
        self.orbital, self.target_attitude, self.chaser_attitude = orbital, target, chaser
