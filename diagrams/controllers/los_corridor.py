"""Paper 004's rotating-LOS-corridor guidance as a plug-in: `controller: !LosCorridor {...}`.

Owns: the `LosCorridor` config type (the YAML tag; the fields of
rpod.systems.los_guidance.LosGuidanceConfig plus the actuation), how the guidance is wired
(path 3, the ideal acceleration in L with paper 004's box |u_i| <= a_max; or, with
`actuation: thrusters`, path 1 through rpod.systems.acceleration_to_wrench, the allocator,
the PWM and the thruster bank), the drawing of the corridor, and the results: the corridor
violations (how deep, how long), the regimes, the MPC's statuses and fallbacks, and the
mission outcome.
Does not own: the guidance (systems/los_guidance.py), the corridor model
(rpod.models.los_corridor) or the MPC (rpod.planners.los_corridor_mpc).

Mission (paper 004 Sec. 9's classification): success is zero corridor violations beyond
VIOLATION_TOLERANCE_M (1e-3 m, at every log sample) AND the hold point held at the end (the
hold regime at the last control step). An infeasible QP is logged and counted; it fails the
mission only through what it leads to (a violation, or no hold).
"""

import dataclasses
import math

import numpy as np

from rpod.diagrams.controller_seam import (
    Actuation,
    ControllerPlugin,
    ControllerResults,
    ControllerWiring,
    IdealCommand,
    MissionOutcome,
    register_controller,
)
from rpod.diagrams.plots_los import violation_summary
from rpod.diagrams.scenario import ScenarioError, body_polytopes
from rpod.diagrams.target_frame import chaser_in_target_frame
from rpod.models.frames import rotations_from_wxyz
from rpod.models.los_corridor import (
    VIOLATION_TOLERANCE_M,
    holding_range_m,
    suggested_hold_distance_m,
    sync_range_m,
)
from rpod.planners.los_corridor_mpc import MpcStatus
from rpod.systems.acceleration_to_wrench import AccelerationToWrench
from rpod.systems.los_guidance import (
    MPC_STATUS_CODES,
    Fallback,
    LosGuidance,
    LosGuidanceConfig,
    Regime,
)
from rpod.systems.sensed import SENSED_PORT

ACTUATIONS = ("ideal", "thrusters")
LOG_SHAPES = {  # the keys the figures read (rpod.diagrams.plots_los documents each)
    "los_range_m": None,
    "los_sync_range_m": None,
    "los_hold_point_T": 3,
    "los_face_distance_m": -1,  # faces 1..n_f, then the floor
    "los_command_L": 3,
    "los_nominal_L": 3,
    "los_applied_L": 3,
    "los_regime": None,
    "los_mpc_status": None,
    "los_fallback": None,
    "los_a_max_m_s2": None,
    "los_half_angle_deg": None,
}
THRUSTER_PERIOD_S = 0.1  # the PWM period of `actuation: thrusters` (10 Hz, as the hold point)


@dataclasses.dataclass
class LosCorridor(LosGuidanceConfig):
    """Paper 004's guidance (fields: see LosGuidanceConfig) and how it is flown.

    Args:
        actuation: 'ideal' (paper 004: an ideal acceleration in L, box-bounded by a_max) or
            'thrusters' (the scenario's fixed thruster bank through the allocator and PWM at
            10 Hz, the chaser's attitude held in L).
        corridor_length_m: how far along +y_T the scene draws the corridor [m].
    """

    actuation: str = "ideal"
    corridor_length_m: float = 60.0

    def validate(self) -> None:
        """Raises ValueError('field: message') naming the first bad field."""
        super().validate()
        if self.actuation not in ACTUATIONS:
            raise ValueError(f"actuation: must be one of {ACTUATIONS}, got {self.actuation!r}")
        if not (math.isfinite(self.corridor_length_m) and self.corridor_length_m > self.floor_m):
            raise ValueError(f"corridor_length_m: must be beyond the floor ({self.floor_m} m)")


def _bounding_radius_sum_m(scenario) -> float:
    """The radii of the spheres about the two bodies' centres that hold their true shapes,
    added: closer than this, the bodies may touch [m]."""
    return sum(
        float(np.max(np.linalg.norm(shape.vertices, axis=1))) for shape in body_polytopes(scenario)
    )


def applied_acceleration_L(log: dict) -> np.ndarray:
    """The acceleration the truth received, in L: R_LI R_IC f_C / m (N, 3) [m/s^2]."""
    R_IC = rotations_from_wxyz(log["q_IC"])
    R_IL = rotations_from_wxyz(log["q_IL"])
    f_I = np.einsum("nij,nj->ni", R_IC, log["body_wrench"][:, 3:6])
    return np.einsum("nji,nj->ni", R_IL, f_I) / log["chaser_mass_kg"][:, None]


class LosCorridorPlugin(ControllerPlugin):
    """Plug-in of rpod.systems.los_guidance.LosGuidance."""

    config_type = LosCorridor
    system_name = "los_guidance"
    actuation = Actuation.IDEAL
    log_shapes = LOG_SHAPES

    def run_figures(self) -> dict:
        """los_corridor.png and los_body_frame.png (rpod.diagrams.plots_los)."""
        from rpod.diagrams import plots_los  # only when drawing: no matplotlib at load

        return plots_los.run_figures()

    def actuation_for(self, config) -> Actuation:
        return Actuation.IDEAL if config.actuation == "ideal" else Actuation.BODY_WRENCH

    def validate(self, config, scenario) -> None:
        super().validate(config, scenario)
        if scenario.orbit.gravity in ("cw", "free_space"):
            raise ScenarioError(
                "orbit.gravity",
                f"the LOS guidance linearises an orbit ({scenario.orbit.gravity} has none "
                "in ECI): use two_body or two_body_j2",
            )
        if config.actuation == "thrusters" and not math.isclose(
            THRUSTER_PERIOD_S * round(config.control_period_s / THRUSTER_PERIOD_S),
            config.control_period_s,
        ):
            raise ScenarioError(
                "controller.control_period_s",
                f"with thrusters it must be a multiple of the {THRUSTER_PERIOD_S} s PWM period",
            )

    def load_warnings(self, config, scenario) -> list[str]:
        """A hold point the box cannot hold at rest in the tumbling frame (omega_t^2 |p_TH| >
        a_max, rpod.models.los_corridor.holding_range_m), with the hold distance that can."""
        omega = float(np.linalg.norm(np.radians(scenario.target.w_IT_T_deg_s)))
        if omega == 0.0:
            return []
        a_max, hold = config.a_max_m_s2, config.hold_distance_m
        r_hold = holding_range_m(a_max, omega)
        if hold <= r_hold:
            return []
        offer = suggested_hold_distance_m(a_max, omega)
        text = (
            f"controller.hold_distance_m: the hold point {hold:g} m up the axis cannot be held: "
            f"at rest in the tumbling frame it needs omega_t^2 r = {omega**2 * hold:.3g} m/s^2, "
            f"more than a_max = {a_max:g} m/s^2 (the box holds out to r_sync / 2 = "
            f"{r_hold:.2f} m); "
        )
        if offer > config.floor_m:
            text += (
                f"hold_distance_m = {offer:.2f} (r_sync / 4, half the box left for control) "
                "can be held"
            )
        else:
            text += f"no point beyond the corridor's {config.floor_m:g} m floor can be held"
        return [text]

    def add_to_diagram(self, builder, scenario, sensed) -> ControllerWiring:
        config = scenario.controller
        guidance = builder.AddNamedSystem(
            self.system_name,
            LosGuidance(
                config,
                np.asarray(scenario.target.inertia_kg_m2),
                scenario.orbit.gravity,
                keep_out_m=_bounding_radius_sum_m(scenario),
            ),
        )
        builder.Connect(sensed, guidance.GetInputPort(SENSED_PORT))
        logged = {
            "los_command_L": guidance.GetOutputPort("acceleration_command_L"),
            "los_nominal_L": guidance.GetOutputPort("nominal_command_L"),
            "los_guidance_status": guidance.GetOutputPort("guidance_status"),
            "hold_point_L": guidance.GetOutputPort("hold_point_L"),
            "los_face_distance_m": guidance.GetOutputPort("face_distance_m"),
        }
        command = guidance.GetOutputPort("acceleration_command_L")
        if config.actuation == "ideal":
            ideal = IdealCommand("acceleration", "L", "box", config.a_max_m_s2)
            return ControllerWiring(
                guidance, Actuation.IDEAL, command, config.control_period_s, logged, ideal
            )
        adapter = builder.AddNamedSystem(
            "acceleration_to_wrench",
            AccelerationToWrench(
                scenario.chaser.mass_kg,
                np.asarray(scenario.chaser.inertia_kg_m2),
                THRUSTER_PERIOD_S,
            ),
        )
        builder.Connect(command, adapter.GetInputPort("acceleration_command_L"))
        builder.Connect(sensed, adapter.GetInputPort(SENSED_PORT))
        wrench = adapter.GetOutputPort("body_wrench_desired")
        logged["body_wrench_desired"] = wrench
        return ControllerWiring(guidance, Actuation.BODY_WRENCH, wrench, THRUSTER_PERIOD_S, logged)

    def add_scene_extras(self, builder, meshcat, scenario, wiring, scene=None) -> None:
        if scene is None:
            return
        from rpod.systems.los_corridor_scene import add_los_corridor_to_scene  # only when drawing

        guidance = wiring.system
        add_los_corridor_to_scene(
            scene, guidance.corridor, scenario.controller.corridor_length_m, guidance.p_TH_T
        )

    def campaign_table(self, rows):
        """A campaign of LOS-corridor runs beside paper 004: its Monte Carlo set (Sec. 9, when
        a combination has more than two starts: monte_carlo_rows) or Table 3 (table3_rows).
        A campaign that flies several controller variants on the same starts (e.g.
        los_monte_carlo_paper) gets one block of Monte Carlo rows per variant."""
        variants = controller_variants(rows)
        table = []
        for label, group in variants.items():
            block = monte_carlo_rows(group)
            if block:
                table += [[label, *line] for line in block] if len(variants) > 1 else block
        if table:
            title = (
                "Paper 004 Sec. 9 beside this campaign: X_MC (the starts' outcomes by Sibson "
                "interpolation on the 300 x 300 grid) and the analytical sets, % of the cone "
                "(rpod.planners.reachability_mc):"
            )
            header = ["omega_t deg/s", "a_max m/s^2", "feasible starts", "X_MC %"]
            header += ["X_nom % (paper)", "X_stoch %", "X_rob %", "X_nom not in X_MC"]
            return title, ["controller variant", *header] if len(variants) > 1 else header, table
        table = table3_rows(rows)
        if not table:
            return None
        title = (
            "Paper 004 Table 3 beside this campaign (ours: r_sync exact, eq. 14, and beside it "
            "r_hold = a_max / omega_t^2 = r_sync / 2, the farthest a chaser at rest in the "
            "tumbling frame can stay; each start's outcome over the run; paper: r_sync / Hold / "
            "r_min as printed):"
        )
        header = ["omega_t deg/s", "a_max m/s^2", "r_sync m", "r_hold m"]
        header += ["start inside", "start outside"]
        return title, [*header, "paper 004"], table

    def results(self, scenario, wiring, context, log) -> ControllerResults:
        config = scenario.controller
        status = log.pop("los_guidance_status")
        n = len(log["t"])
        log["los_regime"] = status[:, 0].astype(np.int64)
        log["los_mpc_status"] = status[:, 1].astype(np.int64)
        log["los_fallback"] = status[:, 2].astype(np.int64)
        log["los_mpc_iterations"] = status[:, 3].astype(np.int64)
        log["los_mpc_solve_time_s"] = status[:, 4]
        p_T = chaser_in_target_frame(log["q_IT"], log["q_IL"], log["p_LC_L"])
        log["los_range_m"] = np.linalg.norm(p_T, axis=1)
        omega = float(np.linalg.norm(np.radians(scenario.target.w_IT_T_deg_s)))
        r_sync = sync_range_m(config.a_max_m_s2, omega) if omega > 0 else math.inf
        log["los_sync_range_m"] = np.full(n, r_sync)
        log["los_hold_point_T"] = np.tile(wiring.system.p_TH_T, (n, 1))
        log["los_a_max_m_s2"] = np.full(n, config.a_max_m_s2)
        log["los_half_angle_deg"] = np.full(n, config.half_angle_deg)
        log["los_applied_L"] = applied_acceleration_L(log)

        depth, duration, first = violation_summary(
            log["t"], log["los_face_distance_m"], VIOLATION_TOLERANCE_M
        )
        # One sample per control step: the samples at k period_s hold step k - 1's status
        # (the t = 0 sample holds the initial -1s, left out of the counts).
        steps = _control_step_samples(log["t"], config.control_period_s)
        steps = steps[log["los_regime"][steps] >= 0]
        codes = log["los_mpc_status"][steps]
        # OSQP's verdict other than 'solved' (an unfinished iterate may still have passed the
        # rollout check and flown), and the steps flown on a fallback.
        not_solved = int(
            np.count_nonzero((codes >= 0) & (codes != MPC_STATUS_CODES[MpcStatus.SOLVED]))
        )
        fallbacks = log["los_fallback"][steps]
        on_fallback = int(np.count_nonzero(fallbacks != Fallback.NONE))
        hold_distance = float(np.linalg.norm(p_T[-1] - wiring.system.p_TH_T))
        held = bool(log["los_regime"][-1] == Regime.HOLD)
        # The hold reached: the first sample of the final run of hold samples.
        not_holding = np.flatnonzero(log["los_regime"] != Regime.HOLD)
        reached = int(not_holding[-1]) + 1 if len(not_holding) else 0
        min_distance = float(np.nanmin(log["los_face_distance_m"]))
        summary = {
            "los_sync_range_m": r_sync,
            "los_start_inside_sync_range": bool(log["los_range_m"][0] <= r_sync),
            "los_violation": depth > 0,
            "los_violation_depth_m": depth,
            "los_violation_duration_s": duration,
            "los_first_violation_s": first,
            "los_min_face_distance_m": min_distance,
            "los_min_range_m": float(np.min(log["los_range_m"])),
            "los_held": held,
            "los_hold_reached_s": float(log["t"][reached]) if held else None,
            "los_final_hold_error_m": hold_distance,
            "los_qp_not_solved": not_solved,
            "los_fallback_steps": on_fallback,
            "los_fallback_previous_plan": int(
                np.count_nonzero(fallbacks == Fallback.PREVIOUS_PLAN)
            ),
            "los_fallback_brake": int(np.count_nonzero(fallbacks == Fallback.BRAKE)),
            "los_fallback_far_command": int(np.count_nonzero(fallbacks == Fallback.NOMINAL)),
            "los_fallback_best_effort": int(np.count_nonzero(fallbacks == Fallback.BEST_EFFORT)),
            "los_regime_steps": {
                regime.name.lower(): int(np.count_nonzero(log["los_regime"][steps] == regime))
                for regime in Regime
            },
            "los_mpc_solve_ms_median": float(1e3 * np.median(log["los_mpc_solve_time_s"][steps])),
            "los_mpc_solve_ms_max": float(1e3 * np.max(log["los_mpc_solve_time_s"][steps])),
        }
        success = depth == 0.0 and held
        solver = _solver_text(summary)
        if success:
            text = (
                f"held at {config.hold_distance_m:g} m on the corridor axis from "
                f"{summary['los_hold_reached_s']:.0f} s, zero corridor violations (least margin "
                f"{min_distance:.2f} m); {solver}"
            )
        else:
            parts = []
            if depth > 0:
                parts.append(
                    f"corridor violated {depth:.3f} m deep for {duration:.1f} s from {first:.1f} s"
                )
            if not held:
                parts.append(f"not holding at the end ({hold_distance:.1f} m from the hold point)")
            text = "NOT a success: " + "; ".join(parts) + f"; {solver}"
        return ControllerResults(summary=summary, outcome=MissionOutcome(success, text))


# Paper 004 Table 3: (omega_t deg/s, a_max m/s^2) -> (r_sync m, Hold, r_min m) as printed.
PAPER_TABLE_3 = {
    (1, 0.10): (656.6, "No", 0.0),
    (1, 0.05): (328.3, "No", 143.7),
    (1, 0.02): (131.3, "No", 145.3),
    (2, 0.10): (164.1, "No", 143.0),
    (2, 0.05): (82.1, "No", 141.9),
    (2, 0.02): (32.8, "No", 111.8),
    (3, 0.10): (73.0, "No", 138.2),
    (3, 0.05): (36.5, "No", 111.4),
    (3, 0.02): (14.6, "No", 67.1),
    (4, 0.10): (41.0, "No", 113.2),
    (4, 0.05): (20.5, "No", 67.3),
    (4, 0.02): (8.2, "No", 62.1),
    (5, 0.10): (26.3, "No", 75.0),
    (5, 0.05): (13.1, "No", 63.9),
    (5, 0.02): (5.3, "No", 51.1),
}


def _solver_text(summary: dict) -> str:
    """How the filter fared: unsolved QPs and the steps each fallback flew (README promise)."""
    text = f"{summary['los_qp_not_solved']} QPs not solved, {summary['los_fallback_steps']} steps on a fallback"
    if summary["los_fallback_steps"]:
        kinds = [
            ("best-effort QP", summary["los_fallback_best_effort"]),
            ("previous plan", summary["los_fallback_previous_plan"]),
            ("brake", summary["los_fallback_brake"]),
            ("far command", summary["los_fallback_far_command"]),
        ]
        text += " (" + ", ".join(f"{name} {count}" for name, count in kinds if count) + ")"
    return text


def _start_outcome(metrics: dict | None) -> str:
    """One start's cell: held or not, the violation (depth), the least range and whether the
    true shapes touched."""
    if not metrics:
        return "failed run"
    held = "hold" if metrics.get("los_held") else "no hold"
    depth = metrics.get("los_violation_depth_m") or 0.0
    violation = f"violated {depth:.2f} m" if depth > 0 else "0 violations"
    contact = ", CONTACT" if metrics.get("min_separation_m", 1.0) <= 0.0 else ""
    r_min = metrics.get("los_min_range_m", float("nan"))
    return f"{held}, {violation}, r_min {r_min:.1f} m{contact}"


def table3_rows(rows: list[dict]) -> list[list[str]] | None:
    """Paper 004 Table 3 beside this campaign: one line per (omega_t, a_max), the start inside
    and the start outside r_sync; None when the rows are not such a campaign."""
    cells: dict[tuple, dict] = {}
    for row in rows:
        overrides, metrics = row.get("overrides") or {}, row.get("metrics")
        spin = overrides.get("target.w_IT_T_deg_s")
        a_max = overrides.get("controller.a_max_m_s2")
        if spin is None or a_max is None or not metrics or "los_sync_range_m" not in metrics:
            continue
        key = (round(float(np.linalg.norm(spin)), 6), round(float(a_max), 6))
        where = "inside" if metrics["los_start_inside_sync_range"] else "outside"
        cells.setdefault(key, {})[where] = metrics
    if not cells:
        return None
    table = []
    for (omega, a_max), starts in sorted(cells.items()):
        r_sync = sync_range_m(a_max, math.radians(omega))
        paper = PAPER_TABLE_3.get((round(omega), round(a_max, 2)))
        paper_text = f"{paper[0]:.1f} / {paper[1]} / {paper[2]:.1f}" if paper else "-"
        table.append(
            [
                f"{omega:g}",
                f"{a_max:.2f}",
                f"{r_sync:.1f}",
                f"{holding_range_m(a_max, math.radians(omega)):.1f}",
                _start_outcome(starts.get("inside")),
                _start_outcome(starts.get("outside")),
                paper_text,
            ]
        )
    return table


# Overrides that place a run in the Monte Carlo (its combination and start), not its controller.
_PER_START = (
    "target.w_IT_T_deg_s",
    "controller.a_max_m_s2",
    "controller.hold_distance_m",
    "chaser.p_LC_L",
)


def controller_variants(rows: list[dict]) -> dict[str, list[dict]]:
    """The rows split by what else their overrides set, each group labelled by it ('defaults'
    for none): a campaign that flies two controllers on the same starts is two Monte Carlos."""
    groups: dict[tuple, list[dict]] = {}
    for row in rows:
        overrides = row.get("overrides") or {}
        key = tuple(sorted((k, repr(v)) for k, v in overrides.items() if k not in _PER_START))
        groups.setdefault(key, []).append(row)
    return {
        ", ".join(f"{k.removeprefix('controller.')}={v}" for k, v in key) or "defaults": group
        for key, group in groups.items()
    }


def monte_carlo_rows(rows: list[dict]) -> list[list[str]] | None:
    """One line per (omega_t, a_max) of a Monte Carlo campaign (more than two starts in some
    combination), or None (rpod.planners.reachability_mc.mc_report)."""
    from rpod.planners.reachability_mc import mc_outcomes, mc_report  # only for a report

    outcomes = mc_outcomes(rows)
    if not outcomes or max(len(feasible) for _, feasible in outcomes.values()) <= 2:
        return None
    table = []
    for record in mc_report(rows):
        feasible = sum(1 for start in record.starts if start.feasible)
        paper = record.paper_nominal_percent
        table.append(
            [
                f"{record.omega_deg:g}",
                f"{record.a_max_m_s2:.2f}",
                f"{feasible}/{len(record.starts)}",
                f"{record.mc_percent:.1f}",
                f"{record.nominal_percent:.1f} ({'-' if paper is None else f'{paper:.1f}'})",
                f"{record.stochastic_percent:.1f}",
                f"{record.robust_percent:.1f}",
                f"{record.nominal_not_mc} ({record.nominal_not_mc_extrapolated} extrapolated)",
            ]
        )
    return table


def _control_step_samples(t: np.ndarray, period_s: float) -> np.ndarray:
    """The indices of the log samples nearest each control step k period_s (unique)."""
    steps = np.arange(0.0, t[-1] + 0.5 * period_s, period_s)
    index = np.clip(np.searchsorted(t, steps - 1e-9), 0, len(t) - 1)
    return np.unique(index)


register_controller(LosCorridorPlugin())
