"""ThrusterBank: thruster commands in, body wrench and propellant mass flow out.

Owns the clipping of commands to the thruster limits and the map to the chaser body wrench,
every integrator stage. The equations live in `rpod.models`: the fixed-thruster wrench map and
mass flow in `rpod.models.thrusters`, the gimbaled thrusters' force-to-wrench matrix, gimbal
pyramid and magnitude limit in `rpod.models.gimbal`; this file only puts them in a Drake system.
It does not integrate propellant mass (feed `propellant_mass_flow` to whatever owns the chaser's
mass) and does not model thrust build-up or decay: the wrench follows the command instantly.

Where it is used. For fixed layouts, rpod.diagrams builds `rpod.systems.truth.Truth`, which
applies the same clip and wrench map inside the truth (for speed); this system is part of the
test-only reference it is checked against (`tests.reference.split_truth.SplitTruth`) and the
bank rpod.diagrams builds for gimbaled layouts.
"""

from __future__ import annotations

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import BasicVector, Context, ValueProducer

from rpod.models.gimbal import GimbalLimits, force_to_wrench_matrix
from rpod.models.thrusters import (
    STANDARD_GRAVITY_M_S2,
    ThrusterLayout,
    validate_layout,
    wrench_matrix,
)
from rpod.systems.lifetime import LeafSystem, weak_method


class ThrusterBank(LeafSystem):
    """Applies a thruster layout's limits and wrench map to a command.

    Input ports:
        thruster_command: n on-levels in [0, 1] (fixed layout) or 3n force components in C,
            thruster by thruster [f_1; f_2; ...] in N (gimbaled layout).

    Output ports:
        body_wrench (6): [tau_C; f_C], torque about the chaser CoM then force, in C
            (N m, N), of the clipped command (paper 001 eqs. 11-12, paper 003 eqs. 3-4).
        propellant_mass_flow (1): sum_k |f_k| / (Isp_k g0) of the clipped command, kg/s, >= 0.
        command_clipped (n): 1.0 where thruster k's command broke a limit by more than
            `report_tolerance` (levels: absolute; forces: relative to f_max) or was not finite,
            else 0.0.

    Clipping always happens (no out-of-limit command reaches the wrench): levels are clamped to
    [0, 1] (NaN -> 0); gimbaled forces are mapped into the feasible set by the rule of
    `rpod.models.gimbal.clip_gimbaled_forces` (pyramid eq. 16, then magnitude eq. 17). The
    tolerance only keeps solver round-off from being reported as clipping. Fixed-layout
    commands already in [0, 1] (every PWM on/off command) are copied as they are, skipping the
    clip arithmetic.

    All outputs depend on the input port only (declared, through one cache entry holding the
    clipped command), so Drake's cache computes them once per new command and keeps them across
    integrator stages and state changes (when fed by a sampled controller or PWM).
    """

    def __init__(self, layout: ThrusterLayout, report_tolerance: float = 1e-6):
        """Builds the bank.

        Args:
            layout: The thrusters (validated here).
            report_tolerance: Violation below which a clip is not reported in
                `command_clipped` (it is still clipped).
        """
        super().__init__()
        validate_layout(layout)
        self._layout = layout
        self._n = layout.count
        self._gimbaled = layout.gimbaled
        self._command_size = layout.command_size
        self._report_tolerance = float(report_tolerance)
        self._B = wrench_matrix(layout)
        self._mdot_per_level = layout.max_mass_flows_kg_s  # f_max / (Isp g0), kg/s
        self._inv_isp_g0 = 1.0 / (layout.isps_s * STANDARD_GRAVITY_M_S2)
        # Gimbaled: wrench = M @ [f_1; ...; f_n], M = [skew(p_1) ... skew(p_n); I ... I]
        # (paper 001 eqs. 11-12 as one precomputed matrix).
        self._M = force_to_wrench_matrix(layout) if self._gimbaled else None
        self._geometry = GimbalLimits(layout) if self._gimbaled else None
        self._force_report_tolerance_N = self._report_tolerance * layout.max_thrusts_N

        self._command_port = self.DeclareVectorInputPort("thruster_command", layout.command_size)
        # One cache entry holds the clipped command: [applied levels (n) or forces (3n);
        # whether each thruster's clip is reported (n)]. It depends on the input port only, and
        # the three outputs depend on it only, so they are computed once per new command.
        self._clipped_size = layout.command_size + self._n
        self._clipped_entry = self.DeclareCacheEntry(
            "clipped thruster command",
            ValueProducer(
                allocate=lambda size=self._clipped_size: AbstractValue.Make(np.zeros(size)),
                calc=weak_method(self._calc_clipped),
            ),
            prerequisites_of_calc={self.input_port_ticket(self._command_port.get_index())},
        )
        depends_on_command = {self._clipped_entry.ticket()}
        self.DeclareVectorOutputPort(
            "body_wrench", 6, self._calc_body_wrench, prerequisites_of_calc=depends_on_command
        )
        self.DeclareVectorOutputPort(
            "propellant_mass_flow",
            1,
            self._calc_mass_flow,
            prerequisites_of_calc=depends_on_command,
        )
        self.DeclareVectorOutputPort(
            "command_clipped",
            self._n,
            self._calc_command_clipped,
            prerequisites_of_calc=depends_on_command,
        )

    @property
    def layout(self) -> ThrusterLayout:
        """The thruster layout."""
        return self._layout

    def _calc_clipped(self, context: Context, value: AbstractValue) -> None:
        command = self._command_port.Eval(context)
        stored = value.get_mutable_value()
        m = self._command_size
        if not self._gimbaled and command.min() >= 0.0 and command.max() <= 1.0:
            # Fast path (every PWM on/off command): in range and finite (NaN fails both
            # comparisons), so applied = command bit for bit and nothing is reported.
            stored[:m] = command
            stored[m:] = 0.0
            return
        if self._gimbaled:
            # Pyramid (paper 001 eq. 16) then magnitude (eq. 17), see clip_gimbaled_forces.
            F, violation = self._geometry.clip(command.reshape(self._n, 3))
            stored[:m] = F.ravel()
            stored[m:] = violation > self._force_report_tolerance_N
        else:
            violation = np.maximum(np.maximum(-command, command - 1.0), 0.0)
            nan = np.isnan(command)
            if np.any(nan):
                violation[nan] = np.inf
                command = np.where(nan, 0.0, command)
            np.clip(command, 0.0, 1.0, out=stored[:m])
            stored[m:] = violation > self._report_tolerance

    def _applied(self, context: Context) -> np.ndarray:
        """Clipped levels (n) or forces (3n), read from the cache."""
        return self._clipped_entry.Eval(context)[: self._command_size]

    def _calc_body_wrench(self, context: Context, output: BasicVector) -> None:
        if self._gimbaled:
            # sum_k [p_k x f_k; f_k] (paper 001 eqs. 12, 11)
            output.SetFromVector(self._M @ self._applied(context))
        else:
            # B u (paper 003 eqs. 3-4, paper 001 eqs. 11-12)
            output.SetFromVector(self._B @ self._applied(context))

    def _calc_mass_flow(self, context: Context, output: BasicVector) -> None:
        if self._gimbaled:
            F = self._applied(context).reshape(self._n, 3)
            magnitudes = np.sqrt(np.einsum("ij,ij->i", F, F))
            mdot = magnitudes @ self._inv_isp_g0  # sum_k |f_k| / (Isp_k g0)
        else:
            mdot = self._mdot_per_level @ self._applied(context)  # u_k f_max / (Isp g0)
        output.SetAtIndex(0, float(mdot))

    def _calc_command_clipped(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(self._clipped_entry.Eval(context)[self._command_size :])
