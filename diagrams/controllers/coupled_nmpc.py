"""Paper 001's coupled 6-DOF NMPC as a plug-in: `controller: !CoupledNmpc {...}`.

Owns: the `CoupledNmpc` config type (the YAML tag), the problem data derived from the scenario
(`coupled_params`), how the controller (rpod.systems.coupled_nmpc_controller) is wired (path 2:
eight force vectors in C, 24 numbers, straight to the gimbaled bank, which clips them to the
gimbal pyramid and the magnitude limit: the truth, not the controller, decides what is produced),
and the results: the truth's relative attitude and feature-point state, the forces the bank
applied, the constraints measured on them, the solver's record and the mission outcome.
Does not own: the controller (systems/coupled_nmpc_controller.py), the NLP
(rpod.planners.coupled_nmpc), the prediction model (rpod.models.coupled_relative), the plots
(rpod.diagrams.plots_coupled) or the scene (rpod.systems.coupled_nmpc_scene).

Problem data from the scenario, never re-typed: the chaser's mass and inertia
(chaser.mass_kg, chaser.inertia_kg_m2), the target's inertia (target.inertia_kg_m2, J_t of eq. 2),
the thrusters (make_thruster_layout: positions, nominal directions, gimbal angle, f_max; the
layout must be gimbaled_cuboid_8 on a chaser box of the cuboid it assumes), and the two feature
points: the rock r^t_pt/t is target.docking_port_T and the end effector r^c_pc/c is
chaser.capture_point_C (so the run's own capture_distance_m and capture_speed_m_s measure the
feature points too), unless `target_feature_point_T_m` / `chaser_feature_point_C_m` name others.
The weights of eqs. 20-21 are Sec. IV's (rpod.models.coupled_relative.CoupledNmpcWeights, with
its stated reading of the printed exponents and its choice of P), except the integral weight
Q_xi, a config field (`integral_weight`) whose default is rpod's 1e-6, not the 1e-9 our copy's
"109" reads as: with 1e-9 the integral term never removes the steady offset (1.4-1.6 m from the
rock; tests/planners/test_coupled_sqp.py shows it), against Sec. IV's claim of an offset-free
steady state, which 1e-6 delivers.
The chaser mass is the scenario's wet mass at t = 0: the prediction does not see the propellant
burned (~0.1 % of it on Sec. IV's manoeuvre).

Mission (thresholds): converged when the truth's eigenaxis error (eq. 5) is below
ATTITUDE_TOLERANCE_DEG (1 deg) and the feature points are within DISTANCE_TOLERANCE_M (0.1 m);
`coupled_converged_at_s` is the first log sample from which both hold at every later sample.
Success = converged at the end (and so from converged_at_s on) AND no constraint excess: at every
log sample the applied forces stay in each thruster's gimbal pyramid (eq. 16, from
rpod.models.thrusters.gimbal_polyhedron) and within f_max (eq. 17) to CONSTRAINT_TOLERANCE_N
(1e-6 N, round-off). Every step whose solve was not usable is counted and named in the outcome
(status and fallback); it fails the mission only through what it leads to. The LOS polyhedron
(eq. 18, soft in the paper) is reported, not judged: the last sample outside it by more than
LOS_TOLERANCE_M (1 mm), the samples within DISTANCE_TOLERANCE_M of the rock left out (the
pyramid's apex is the rock: there the margin is a fraction of a distance already below the
tolerance), and the least margin after it (outside that ball).

Applied forces. The bank's clipped forces are not an output port of ThrusterBank; they are
recomputed here from the logged command (`thruster_force_C`) by the bank's own rule
(rpod.models.thrusters.GimbalLimits.clip, which the bank calls), and checked against the bank's
own logged output: the resultant wrench of the recomputed forces must equal `body_wrench`
(`coupled_applied_wrench_mismatch`, ~1e-13 N).
"""

import dataclasses
import math

import numpy as np

from rpod.diagrams.controller_seam import (
    Actuation,
    ControllerPlugin,
    ControllerResults,
    ControllerWiring,
    MissionOutcome,
    register_controller,
)
from rpod.diagrams.scenario import ScenarioError, make_thruster_layout
from rpod.models import coupled_relative as cr
from rpod.models.frames import lvlh_to_inertial, rotations_from_wxyz
from rpod.models.thrusters import (
    GimbalLimits,
    ThrusterLayout,
    gimbal_polyhedron,
    wrench_from_forces,
)
from rpod.planners.coupled_nmpc import CoupledNmpc as CoupledNmpcPlanner
from rpod.planners.coupled_nmpc import CoupledNmpcSettings
from rpod.systems.coupled_nmpc_controller import (
    STATUS_SIZE,
    CoupledNmpcController,
    NmpcFallback,
)
from rpod.systems.sensed import SENSED_PORT

LAYOUT = "gimbaled_cuboid_8"
GRAVITIES = ("two_body", "two_body_j2")  # the prediction propagates a two-body orbit in I
ATTITUDE_TOLERANCE_DEG = 1.0
DISTANCE_TOLERANCE_M = 0.1
CONSTRAINT_TOLERANCE_N = 1e-6
LOS_TOLERANCE_M = 1e-3


def los_counted_outside(margin_m: np.ndarray, distance_m: np.ndarray) -> np.ndarray:
    """The samples counted outside the LOS pyramid (eq. 18): more than LOS_TOLERANCE_M out, and
    not within DISTANCE_TOLERANCE_M of the rock (there the pyramid's apex is mm away and its
    margin is noise). The outcome line and coupled_nmpc.png both count these."""
    return (np.asarray(margin_m) < -LOS_TOLERANCE_M) & (
        np.asarray(distance_m) >= DISTANCE_TOLERANCE_M
    )


INTEGRAL_WEIGHT = 1e-6  # Q_xi / I3: rpod's, not the printed 1e-9 (module docstring)
STATUS_LOG_KEY = "coupled_nmpc_status_vector"  # the raw (n, 5) log, split in results()
LOG_SHAPES = {  # the keys the figures read (rpod.diagrams.plots_coupled documents each)
    "coupled_eigenaxis_error_rad": None,
    "coupled_w_TC_T_rad_s": 3,
    "coupled_p_PtPc_T_m": 3,
    "coupled_v_PtPc_T_m_s": 3,
    "coupled_thruster_forces_C_N": -1,  # 3 per thruster
    "coupled_force_C_N": 3,
    "coupled_torque_C_Nm": 3,
    "coupled_los_margin_m": None,
    "coupled_max_thrust_N": None,
    "coupled_gimbal_half_angle_rad": None,
    "nmpc_status": None,
    "nmpc_fallback": None,
    "nmpc_solve_time_s": None,
}


@dataclasses.dataclass
class CoupledNmpc:
    """Paper 001's NMPC (Sec. III-D) and how it is sampled; problem data: module docstring.

    Args:
        control_period_s: T_c, the receding-horizon period (eq. 23): u*(0) is held for T_c,
            then (22) is solved again. Sec. IV: T_s = T / N = 60 s. 0 would mean T / N
            (`period_s`), but the scenario's check on controller.control_period_s refuses 0.
        integral_step_s: the trapezoid step of the integral state xi_T (eq. 14) [s].
        max_thrust_N: f_max of eq. 17 in the plan; 0 (default): the thrusters' own
            (thrusters.max_thrust_N). A positive value, at most that, plans with a margin
            below the limit the bank enforces.
        target_feature_point_T_m: r^t_pt/t, the rock on the target, in T [m]; empty
            (default): target.docking_port_T.
        chaser_feature_point_C_m: r^c_pc/c, the end effector on the chaser, in C [m]; empty
            (default): chaser.capture_point_C.
        integral_weight: Q_xi = integral_weight I3 of eq. 20 [1 / (m s)^2 per s]; module
            docstring for why the default is not the paper's printed value.
        nmpc: the transcription and solver of (22) (horizon_s T, intervals N, solver, ...;
            rpod.planners.coupled_nmpc.CoupledNmpcSettings, defaults Sec. IV: T = 480 s, N = 8).
    """

    control_period_s: float = cr.HORIZON_S / cr.HORIZON_INTERVALS
    integral_step_s: float = 1.0
    max_thrust_N: float = 0.0
    target_feature_point_T_m: list[float] = dataclasses.field(default_factory=list)
    chaser_feature_point_C_m: list[float] = dataclasses.field(default_factory=list)
    integral_weight: float = INTEGRAL_WEIGHT
    nmpc: CoupledNmpcSettings = dataclasses.field(default_factory=CoupledNmpcSettings)

    def period_s(self) -> float:
        """T_c [s]: control_period_s, or T / N when it is 0."""
        if self.control_period_s == 0:
            return self.nmpc.horizon_s / self.nmpc.intervals
        return float(self.control_period_s)

    def validate(self) -> None:
        """Raises ValueError('field: message') naming the first bad field."""
        try:
            self.nmpc.validate()
        except ValueError as error:
            raise ValueError(f"nmpc.{error}") from None
        if not (math.isfinite(self.control_period_s) and self.control_period_s >= 0):
            raise ValueError(
                f"control_period_s: must be positive (or 0: T / N), got {self.control_period_s}"
            )
        if not (math.isfinite(self.integral_step_s) and self.integral_step_s > 0):
            raise ValueError(f"integral_step_s: must be positive, got {self.integral_step_s}")
        if self.integral_step_s > self.period_s():
            raise ValueError(
                f"integral_step_s: must not exceed the control period ({self.period_s():g} s), "
                f"got {self.integral_step_s:g}"
            )
        if not (math.isfinite(self.integral_weight) and self.integral_weight >= 0):
            raise ValueError(f"integral_weight: must be >= 0, got {self.integral_weight}")
        if not (math.isfinite(self.max_thrust_N) and self.max_thrust_N >= 0):
            raise ValueError(
                f"max_thrust_N: must be positive (or 0: the thrusters'), got {self.max_thrust_N}"
            )
        for name in ("target_feature_point_T_m", "chaser_feature_point_C_m"):
            value = getattr(self, name)
            if value and (len(value) != 3 or not all(math.isfinite(v) for v in value)):
                raise ValueError(f"{name}: must be empty or 3 finite numbers, got {value}")


def _planning_layout(layout: ThrusterLayout, max_thrust_N: float) -> ThrusterLayout:
    """The layout with every f_max set to max_thrust_N (0: unchanged)."""
    if max_thrust_N == 0:
        return layout
    thrusters = [dataclasses.replace(t, max_thrust_N=max_thrust_N) for t in layout.thrusters]
    return ThrusterLayout(thrusters=thrusters, gimbaled=layout.gimbaled)


def feature_points(scenario) -> tuple[np.ndarray, np.ndarray]:
    """(p_TPt_T, p_CPc_C): the config's, or the scenario's docking port and capture point."""
    config = scenario.controller
    p_TPt_T = config.target_feature_point_T_m or scenario.target.docking_port_T
    p_CPc_C = config.chaser_feature_point_C_m or scenario.chaser.capture_point_C
    return np.asarray(p_TPt_T, dtype=float), np.asarray(p_CPc_C, dtype=float)


def coupled_params(scenario) -> cr.CoupledRelativeParams:
    """The prediction model's data from the scenario (module docstring)."""
    config = scenario.controller
    p_TPt_T, p_CPc_C = feature_points(scenario)
    return cr.CoupledRelativeParams(
        chaser_mass_kg=float(scenario.chaser.mass_kg),
        J_c=np.asarray(scenario.chaser.inertia_kg_m2, dtype=float),
        J_t=np.asarray(scenario.target.inertia_kg_m2, dtype=float),
        p_TPt_T=p_TPt_T,
        p_CPc_C=p_CPc_C,
        layout=_planning_layout(make_thruster_layout(scenario), config.max_thrust_N),
    )


def make_planner(scenario) -> CoupledNmpcPlanner:
    """The NMPC of the scenario's `!CoupledNmpc` block, on the scenario's problem data."""
    config = scenario.controller
    weights = cr.CoupledNmpcWeights(Q_xi=config.integral_weight * np.eye(3))
    return CoupledNmpcPlanner(coupled_params(scenario), weights, dataclasses.replace(config.nmpc))


def truth_relative_states(params: cr.CoupledRelativeParams, log: dict) -> np.ndarray:
    """x (n, 39) of the truth at every log sample, by cr.relative_state_from_absolute.

    The chaser is placed relative to the target (p_IT_I = 0 in the call, p_TC_I from the
    logged relative state), so no 7,000 km coordinates are subtracted; x[:, 21:] is then not
    the target's orbit (not used here).
    """
    R_IT = rotations_from_wxyz(log["q_IT"])
    R_IC = rotations_from_wxyz(log["q_IC"])
    R_IL = rotations_from_wxyz(log["q_IL"])
    zero = np.zeros(3)
    states = np.empty((len(log["t"]), cr.STATE_SIZE))
    for i in range(len(states)):
        p_TC_I, v_TC_I = lvlh_to_inertial(
            R_IL[i], log["w_IL_L"][i], log["p_LC_L"][i], log["v_LC_L"][i]
        )
        states[i] = cr.relative_state_from_absolute(
            params, R_IT[i], log["w_IT_T"][i], zero, zero, R_IC[i], log["w_IC_C"][i], p_TC_I, v_TC_I
        )
    return states


def applied_forces(layout: ThrusterLayout, commanded: np.ndarray) -> np.ndarray:
    """The forces the bank applies (n, 24) for logged commands (n, 24), by its own clip."""
    limits = GimbalLimits(layout)
    forces = np.empty_like(commanded, dtype=float)
    for i, command in enumerate(commanded):
        clipped, _ = limits.clip(np.asarray(command, dtype=float).reshape(layout.count, 3))
        forces[i] = clipped.ravel()
    return forces


def constraint_excess(layout: ThrusterLayout, forces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(gimbal excess, magnitude excess) (n,) [N] of forces (n, 24): the largest A_k f_k - b_k
    over thrusters (eq. 16, gimbal_polyhedron) and the largest |f_k| - f_max (eq. 17)."""
    F = forces.reshape(len(forces), layout.count, 3)
    gimbal = np.full(len(forces), -np.inf)
    for k, thruster in enumerate(layout.thrusters):
        A, b = gimbal_polyhedron(thruster)
        gimbal = np.maximum(gimbal, np.max(F[:, k] @ A.T - b, axis=1))
    magnitude = np.max(np.linalg.norm(F, axis=2) - layout.max_thrusts_N, axis=1)
    return gimbal, magnitude


def _converged_at(t: np.ndarray, ok: np.ndarray) -> float | None:
    """The first sample from which ok holds to the end (None when not at the end)."""
    if not ok[-1]:
        return None
    bad = np.flatnonzero(~ok)
    return float(t[bad[-1] + 1]) if len(bad) else float(t[0])


class CoupledNmpcPlugin(ControllerPlugin):
    """Plug-in of rpod.systems.coupled_nmpc_controller.CoupledNmpcController."""

    config_type = CoupledNmpc
    system_name = "coupled_nmpc"
    actuation = Actuation.THRUSTER_COMMANDS
    log_shapes = LOG_SHAPES

    def run_figures(self) -> dict:
        """coupled_state.png, coupled_thrusters.png, coupled_nmpc.png (rpod.diagrams.plots_coupled)."""
        from rpod.diagrams import plots_coupled  # only when drawing: no matplotlib at load

        return plots_coupled.run_figures()

    def validate(self, config, scenario) -> None:
        super().validate(config, scenario)
        if scenario.orbit.gravity not in GRAVITIES:
            raise ScenarioError(
                "orbit.gravity",
                f"!CoupledNmpc predicts two-body orbits in ECI: use one of {GRAVITIES}, "
                f"got {scenario.orbit.gravity!r}",
            )
        thrusters = scenario.thrusters
        if thrusters.layout != LAYOUT:
            raise ScenarioError(
                "thrusters.layout",
                f"!CoupledNmpc commands force vectors of paper 001's gimbaled thrusters: "
                f"must be {LAYOUT}, got {thrusters.layout!r}",
            )
        if config.max_thrust_N > thrusters.max_thrust_N:
            raise ScenarioError(
                "controller.max_thrust_N",
                f"must not exceed thrusters.max_thrust_N ({thrusters.max_thrust_N:g} N), "
                f"got {config.max_thrust_N:g}",
            )
        chaser = scenario.chaser
        if chaser.shape == "box":
            cuboid = 2.0 * np.max(np.abs(make_thruster_layout(scenario).p_CK_C), axis=0)
            if not np.allclose(chaser.size_m, cuboid, rtol=0.0, atol=1e-9):
                raise ScenarioError(
                    "chaser.size_m",
                    f"{LAYOUT} puts its thrusters on the corners of a {cuboid.tolist()} m "
                    f"cuboid: the chaser box must be that, got {list(chaser.size_m)}",
                )

    def add_to_diagram(self, builder, scenario, sensed) -> ControllerWiring:
        config = scenario.controller
        planner = make_planner(scenario)
        controller = builder.AddNamedSystem(
            self.system_name,
            CoupledNmpcController(planner, config.period_s(), config.integral_step_s),
        )
        builder.Connect(sensed, controller.GetInputPort(SENSED_PORT))
        logged = {
            STATUS_LOG_KEY: controller.GetOutputPort("nmpc_status"),
            "coupled_xi_T_m_s": controller.GetOutputPort("integral_state_T"),
        }
        return ControllerWiring(
            controller,
            Actuation.THRUSTER_COMMANDS,
            controller.GetOutputPort("thruster_forces_C"),
            config.period_s(),
            logged,
        )

    def add_scene_extras(self, builder, meshcat, scenario, wiring, scene=None) -> None:
        """The LOS pyramid and the rock on T, the end effector on C, and each thruster's force
        as an arrow, the commands drawn as the bank clips them (rpod.systems.coupled_nmpc_scene)."""
        if scene is None:
            return
        from rpod.systems.coupled_nmpc_scene import add_coupled_scene  # only when drawing

        p_TPt_T, p_CPc_C = feature_points(scenario)
        add_coupled_scene(
            builder,
            meshcat,
            scene,
            make_thruster_layout(scenario),  # the bank's limits
            p_TPt_T,
            p_CPc_C,
            scenario.controller.nmpc.los_half_angle_rad,
            wiring.command,
            publish_period_s=scenario.visualization.publish_period_s,
            clip=True,
        )

    def results(self, scenario, wiring, context, log) -> ControllerResults:
        config = scenario.controller
        controller = wiring.system
        params = controller.params
        truth_layout = make_thruster_layout(scenario)  # the bank's limits, not the plan's
        t = log["t"]
        n = len(t)
        out = {}

        # The truth's relative state (eqs. 3-8) and the eigenaxis error (eq. 5).
        x = truth_relative_states(params, log)
        R_TC = x[:, cr.R_TC_SLICE].reshape(n, 3, 3)
        out["coupled_eigenaxis_error_rad"] = np.array([cr.eigenaxis_error(R) for R in R_TC])
        out["coupled_w_TC_T_rad_s"] = x[:, cr.W_TC_T_SLICE]
        out["coupled_p_PtPc_T_m"] = x[:, cr.P_PTPC_T_SLICE]
        out["coupled_v_PtPc_T_m_s"] = x[:, cr.V_PTPC_T_SLICE]

        # The forces the bank applied, their wrench, and the limits measured on them.
        commanded = log.get("thruster_force_C", np.zeros((n, 3 * truth_layout.count)))
        forces = applied_forces(truth_layout, commanded)
        wrench = np.array([wrench_from_forces(truth_layout, f) for f in forces])
        out["coupled_thruster_forces_C_N"] = forces
        out["coupled_torque_C_Nm"] = wrench[:, :3]  # eq. 12
        out["coupled_force_C_N"] = wrench[:, 3:]  # eq. 11
        gimbal, magnitude = constraint_excess(truth_layout, forces)
        out["coupled_max_thrust_N"] = np.full(n, float(np.max(truth_layout.max_thrusts_N)))
        out["coupled_gimbal_half_angle_rad"] = np.full(
            n, float(np.max(truth_layout.gimbal_half_angles_rad))
        )

        # The LOS polyhedron (eq. 18): margin > 0 inside.
        half_angle = config.nmpc.los_half_angle_rad
        A_p = cr.los_polyhedron(params.p_TPt_T, half_angle)
        out["coupled_los_margin_m"] = -np.max(out["coupled_p_PtPc_T_m"] @ A_p.T, axis=1)
        out["coupled_target_feature_point_T_m"] = np.tile(params.p_TPt_T, (n, 1))
        out["coupled_los_half_angle_rad"] = np.full(n, half_angle)

        # The controller's status, sampled.
        status = log.pop(STATUS_LOG_KEY, np.full((n, STATUS_SIZE), np.nan))
        out["nmpc_status"] = status[:, 0].astype(np.int64)
        out["nmpc_fallback"] = status[:, 1].astype(np.int64)
        out["nmpc_iterations"] = status[:, 2].astype(np.int64)
        out["nmpc_solve_time_s"] = status[:, 3]
        out["nmpc_cost"] = status[:, 4]

        summary = self._summary(scenario, controller, context, log, out, gimbal, magnitude, wrench)
        outcome = self._outcome(summary)
        return ControllerResults(summary=summary, log=out, outcome=outcome)

    def _summary(self, scenario, controller, context, log, out, gimbal, magnitude, wrench):
        t = log["t"]
        error_deg = np.degrees(out["coupled_eigenaxis_error_rad"])
        distance = np.linalg.norm(out["coupled_p_PtPc_T_m"], axis=1)
        speed = np.linalg.norm(out["coupled_v_PtPc_T_m_s"], axis=1)
        ok = (error_deg < ATTITUDE_TOLERANCE_DEG) & (distance < DISTANCE_TOLERANCE_M)
        converged_at = _converged_at(t, ok)
        margin = out["coupled_los_margin_m"]
        outside = np.flatnonzero(los_counted_outside(margin, distance))
        last_violation = float(t[outside[-1]]) if len(outside) else None
        start = outside[-1] + 1 if len(outside) else 0
        after = margin[start:][distance[start:] >= DISTANCE_TOLERANCE_M]
        mismatch = (
            float(np.max(np.abs(wrench - log["body_wrench"]))) if "body_wrench" in log else None
        )

        records = controller.solve_records(controller.GetMyContextFromRoot(context))
        times = np.array([r.solve_time_s for r in records if math.isfinite(r.solve_time_s)])
        by_status, failed_by_status, messages = {}, {}, {}
        for record in records:
            by_status[record.status] = by_status.get(record.status, 0) + 1
            if not record.usable:
                failed_by_status[record.status] = failed_by_status.get(record.status, 0) + 1
                messages[record.message] = messages.get(record.message, 0) + 1
        fallbacks = [r.fallback for r in records]

        def stat(fn):
            return float(fn(times)) if len(times) else None

        return {
            "coupled_final_eigenaxis_error_deg": float(error_deg[-1]),
            "coupled_final_distance_m": float(distance[-1]),
            "coupled_final_speed_m_s": float(speed[-1]),
            "coupled_converged": converged_at is not None,
            "coupled_converged_at_s": converged_at,
            "coupled_max_gimbal_excess_N": float(np.max(gimbal)),
            "coupled_max_magnitude_excess_N": float(np.max(magnitude)),
            "coupled_constraint_excess": bool(
                max(np.max(gimbal), np.max(magnitude)) > CONSTRAINT_TOLERANCE_N
            ),
            "coupled_applied_wrench_mismatch": mismatch,
            "coupled_los_last_violation_s": last_violation,
            "coupled_los_violation_samples": len(outside),
            "coupled_los_violated_at_end": bool(len(outside) and outside[-1] == len(t) - 1),
            "coupled_los_min_margin_after_m": float(np.min(after)) if len(after) else None,
            "nmpc_solves": len(records),
            "nmpc_solves_by_status": by_status,
            "nmpc_not_usable": sum(1 for r in records if not r.usable),
            "nmpc_not_usable_by_status": failed_by_status,
            "nmpc_failure_messages": messages,
            "nmpc_fallback_steps": sum(1 for f in fallbacks if f != NmpcFallback.NONE),
            "nmpc_fallback_previous_plan": fallbacks.count(NmpcFallback.PREVIOUS_PLAN),
            "nmpc_fallback_zero_thrust": fallbacks.count(NmpcFallback.ZERO_THRUST),
            "nmpc_solve_time_s_median": stat(np.median),
            "nmpc_solve_time_s_p95": stat(lambda v: np.percentile(v, 95)),
            "nmpc_solve_time_s_max": stat(np.max),
        }

    @staticmethod
    def _outcome(summary: dict) -> MissionOutcome:
        converged = summary["coupled_converged"]
        excess = summary["coupled_constraint_excess"]
        failed = summary["nmpc_not_usable"]
        solver = f"{summary['nmpc_solves']} solves, {failed} not usable"
        if failed:
            kinds = ", ".join(
                f"{status} {count}"
                for status, count in summary["nmpc_not_usable_by_status"].items()
            )
            solver += (
                f" ({kinds}; fallback: {summary['nmpc_fallback_previous_plan']} previous plan, "
                f"{summary['nmpc_fallback_zero_thrust']} zero thrust)"
            )
        los = summary["coupled_los_last_violation_s"]
        if los is None:
            los_text = "LOS never violated"
        elif summary["coupled_los_violated_at_end"]:
            los_text = "LOS violated at the end"
        else:
            los_text = f"LOS held after {los:.0f} s"
        final = (
            f"{summary['coupled_final_eigenaxis_error_deg']:.3g} deg, "
            f"{summary['coupled_final_distance_m']:.3g} m, "
            f"{summary['coupled_final_speed_m_s']:.3g} m/s at the end"
        )
        parts = []
        if converged:
            parts.append(f"grasp pose from {summary['coupled_converged_at_s']:.0f} s: {final}")
        else:
            parts.append(
                f"grasp pose NOT held at the end ({final}; tolerance {ATTITUDE_TOLERANCE_DEG:g} "
                f"deg, {DISTANCE_TOLERANCE_M:g} m)"
            )
        if excess:
            parts.append(
                f"thruster limits exceeded (gimbal {summary['coupled_max_gimbal_excess_N']:.3g} N, "
                f"magnitude {summary['coupled_max_magnitude_excess_N']:.3g} N)"
            )
        parts += [los_text, solver]
        return MissionOutcome(bool(converged and not excess), "; ".join(parts))


register_controller(CoupledNmpcPlugin())
