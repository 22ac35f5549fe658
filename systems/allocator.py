"""WrenchAllocator: desired body wrench in, thruster duty levels out (paper 003 eq. 14).

Owns only the Drake wrapping; the optimisation is `rpod.models.thrusters.DutyAllocator`
(box-constrained least squares, then an exact minimum-fuel tie-break; the same answer as
`allocate_duty`), kept in `models` so planners can reuse it. It does not modulate
(`rpod.systems.pwm`) nor apply limits in time (`rpod.systems.thruster_bank`).

Cost. The output is a direct feedthrough of the input. The allocator's bases are enumerated once
in the constructor (a few ms); each recomputation then costs ~30 us for a feasible wrench and
~80 us for an infeasible one (benchmarks/bench_allocator.py; the scipy path it replaced took
~2 ms). Drake's cache recomputes it only when the input changes, so feed it from a
discrete (sampled) controller output, e.g. a controller with a periodic update or a
ZeroOrderHold, whose value is constant between control instants; fed by a continuous signal it
would be re-solved at every integrator stage.
"""

from __future__ import annotations

import numpy as np
from pydrake.systems.framework import BasicVector, Context

from rpod.models.thrusters import DutyAllocator, ThrusterLayout, validate_layout, wrench_matrix
from rpod.systems.lifetime import LeafSystem


class WrenchAllocator(LeafSystem):
    """Duty levels of fixed thrusters that best produce a desired body wrench.

    u = argmin ||W (B u - w)||^2 s.t. 0 <= u <= 1 (paper 003 eq. 14), B = wrench_matrix(layout);
    among equally good u, the one of least propellant mass flow (exact lexicographic
    tie-break; see `DutyAllocator`, built once here). The answer depends on the input only,
    not on earlier evaluations. A non-finite desired wrench gives u = 0.

    Input ports:
        body_wrench_desired (6): [tau_C; f_C] in the chaser body frame C, N m and N.

    Output ports:
        thruster_duty (n): levels in [0, 1].
    """

    def __init__(
        self,
        layout: ThrusterLayout,
        weights: np.ndarray | None = None,
        minimize_fuel: bool = True,
    ):
        """Builds the allocator.

        Args:
            layout: A fixed (not gimbaled) layout.
            weights: Diagonal of W, 6 numbers >= 0 ordered like the wrench (None: ones).
                Torque is in N m and force in N, so weights set their relative importance.
            minimize_fuel: Run the minimum-propellant tie-break among optimal allocations.

        Raises:
            ValueError: For a gimbaled layout or bad weights.
        """
        super().__init__()
        validate_layout(layout)
        if layout.gimbaled:
            raise ValueError("WrenchAllocator needs a fixed layout (gimbaled=False)")
        self._B = wrench_matrix(layout)
        self._weights = None if weights is None else np.asarray(weights, dtype=float).reshape(6)
        bad_weights = self._weights is not None and (
            np.any(self._weights < 0) or not np.any(self._weights > 0)
        )
        if bad_weights:
            raise ValueError(f"weights must be 6 numbers >= 0, not all 0; got {weights!r}")
        self._minimize_fuel = bool(minimize_fuel)
        self._solver = DutyAllocator(self._B, self._weights, layout.max_mass_flows_kg_s)
        self._wrench_port = self.DeclareVectorInputPort("body_wrench_desired", 6)
        self.DeclareVectorOutputPort(
            "thruster_duty",
            layout.count,
            self._calc_duty,
            prerequisites_of_calc={self.input_port_ticket(self._wrench_port.get_index())},
        )

    @property
    def wrench_matrix(self) -> np.ndarray:
        """B (6 x n), wrench = B @ duty."""
        return self._B

    @property
    def solver(self) -> DutyAllocator:
        """The allocator solving each evaluation (its `fallback_count` is a diagnostic)."""
        return self._solver

    def _calc_duty(self, context: Context, output: BasicVector) -> None:
        w = self._wrench_port.Eval(context)
        output.SetFromVector(self._solver.solve(w, minimize_fuel=self._minimize_fuel))
