"""Paper 001's coupled 6-DOF NMPC config: the YAML tag `!CoupledNmpc`.

Owns: `CoupledNmpc` (how the NMPC of Sec. III-D is sampled, the plan's thrust limit, the feature
points when not the scenario's, the attitude goal, the weights of eqs. 20-21, the integral
weight Q_xi and the transcription settings) and its `validate()`; `CostWeights`;
`INTEGRAL_WEIGHT`, rpod's default Q_xi; `ATTITUDE_GOALS`.
Does not own: the problem data derived from the scenario (problem.py), the NLP's settings
(rpod.planners.coupled_nmpc.CoupledNmpcSettings) or the wiring (plugin.py).

Q_xi: a config field (`integral_weight`) whose default is rpod's 1e-6, not the 1e-9 our copy's
"109" reads as: with 1e-9 the integral term never removes the steady offset (1.4-1.6 m from the
rock; tests/planners/test_coupled_sqp.py shows it), against Sec. IV's claim of an offset-free
steady state, which 1e-6 delivers.
"""

import dataclasses

from rpod.models import coupled_relative as cr
from rpod.models.config import ConfigError, bounded, check_bounds
from rpod.planners.coupled_nmpc import CoupledNmpcSettings

INTEGRAL_WEIGHT = 1e-6  # Q_xi / I3: rpod's, not the printed 1e-9 (module docstring)
ATTITUDE_GOALS = ("aligned", "facing")
MIN_INTEGRAL_STEP_S = 0.01
"""The shortest trapezoid step of xi_T: each step is a discrete update of the diagram, so a run
of the scenario's MAX_DURATION_S (1e6 s) holds at most its MAX_EVENTS (1e8) of them."""


@dataclasses.dataclass
class CostWeights:
    """The weights of eqs. 20-21 (defaults: Sec. IV's, as rpod reads them; each times I3 but
    the attitude's, and the force weight times the identity of the input's size).

    Args:
        attitude: Q_R. rate: Q_w. position: Q_p. force: W_f (per N^2 of each thruster's force
            vector, or of its thrust on a fixed bank). torque: W_tau.
        terminal_position, terminal_velocity: P = blkdiag(terminal_position I3,
            terminal_velocity I3) of eq. 21 (rpod's defaults: T Q_p and T T_s^2 Q_p at Sec. IV's
            T = 480 s, T_s = 60 s; the paper gives no P).

    Bounds: each in [0, 1e9] (the NLP's weights).
    """

    attitude: float = bounded(cr.ATTITUDE_WEIGHT, 0.0, 1e9)
    rate: float = bounded(5.0, 0.0, 1e9)
    position: float = bounded(0.01, 0.0, 1e9)
    force: float = bounded(1.0, 0.0, 1e9)
    torque: float = bounded(9e-13, 0.0, 1e9)
    terminal_position: float = bounded(4.8, 0.0, 1e9)
    terminal_velocity: float = bounded(17280.0, 0.0, 1e9)


@dataclasses.dataclass
class CoupledNmpc:
    """Paper 001's NMPC (Sec. III-D) and how it is sampled; problem data: module docstring.

    Args:
        control_period_s: T_c, the receding-horizon period (eq. 23): u*(0) is held for T_c,
            then (22) is solved again. Sec. IV: T_s = T / N = 60 s. 0: T / N (`period_s`).
        integral_step_s: the trapezoid step of the integral state xi_T (eq. 14) [s], at most
            the control period.
        max_thrust_N: f_max of eq. 17 in the plan; 0 (default): the thrusters' own
            (thrusters.max_thrust_N). A positive value, at most that, plans with a margin
            below the limit the bank enforces.
        target_feature_point_T_m: r^t_pt/t, the rock on the target, in T [m]; empty
            (default): target.docking_port_T.
        chaser_feature_point_C_m: r^c_pc/c, the end effector on the chaser, in C [m]; empty
            (default): chaser.capture_point_C.
        integral_weight: Q_xi = integral_weight I3 of eq. 20 [1 / (m s)^2 per s]; module
            docstring for why the default is not the paper's printed value.
        attitude_goal: 'aligned' (paper 001: R_TC -> I, the chaser's axes on the target's) or
            'facing' (rpod's, the shoot-out's): the chaser's capture axis (its feature point's
            direction in C) against the target's feature point's outward axis, as a docking
            chaser faces a port: the planner then works in a chaser frame C' turned so that
            the goal is R_TC' = I (problem.py).
        weights: the weights of eqs. 20-21 (CostWeights; Sec. IV's by default).
        nmpc: the transcription and solver of (22) (horizon_s T, intervals N, solver, ...;
            rpod.planners.coupled_nmpc.CoupledNmpcSettings, defaults Sec. IV: T = 480 s, N = 8).

    Bounds (rpod.models.config, checked by `validate()`): the control period and the integral
    step up to the scenario's MAX_DURATION_S (as the horizon), the step at least
    MIN_INTEGRAL_STEP_S (it sets the number of discrete updates of a run); the thrust limit up
    to 1e6 N (and the thrusters', checked with the scenario); feature points within 1 km of
    their body's centre of mass; the integral weight up to 1e9, as the NLP's weights.
    """

    control_period_s: float = bounded(cr.HORIZON_S / cr.HORIZON_INTERVALS, 0.0, 1e6)
    integral_step_s: float = bounded(1.0, MIN_INTEGRAL_STEP_S, 1e6)
    max_thrust_N: float = bounded(0.0, 0.0, 1e6)
    target_feature_point_T_m: list[float] = bounded([], -1e3, 1e3)  # noqa: RUF009 (a field())
    chaser_feature_point_C_m: list[float] = bounded([], -1e3, 1e3)  # noqa: RUF009
    integral_weight: float = bounded(INTEGRAL_WEIGHT, 0.0, 1e9)
    attitude_goal: str = "aligned"
    weights: CostWeights = dataclasses.field(default_factory=CostWeights)
    nmpc: CoupledNmpcSettings = dataclasses.field(default_factory=CoupledNmpcSettings)

    def period_s(self) -> float:
        """T_c [s]: control_period_s, or T / N when it is 0."""
        if self.control_period_s == 0:
            return self.nmpc.horizon_s / self.nmpc.intervals
        return float(self.control_period_s)

    def validate(self) -> None:
        """Raises ConfigError naming the first bad field: its declared bounds (check_bounds,
        `nmpc.<field>` included), then the checks that need more than one field."""
        check_bounds(self)
        if self.attitude_goal not in ATTITUDE_GOALS:
            raise ConfigError(
                "attitude_goal", f"must be one of {ATTITUDE_GOALS}, got {self.attitude_goal!r}"
            )
        try:
            self.nmpc.validate()
        except ConfigError as error:
            raise error.under("nmpc") from None
        if self.integral_step_s > self.period_s():
            raise ConfigError(
                "integral_step_s",
                f"must not exceed the control period ({self.period_s():g} s), "
                f"got {self.integral_step_s:g}",
            )
        for name in ("target_feature_point_T_m", "chaser_feature_point_C_m"):
            value = getattr(self, name)
            if value and len(value) != 3:
                raise ConfigError(name, f"must be empty or 3 finite numbers, got {value}")
