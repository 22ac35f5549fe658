"""Paper 001: why rpod's chaser approaches while it slews, where the paper's matches the spin first.

    python benchmarks/study_coupled_spin_match.py

Issue 19. Sec. IV says of Fig. 5 that "the chaser matches the angular velocity of the target as a
first step before approaching the target"; rpod's asteroid_grasp closes most of the 113 m while
its 180 deg slew is still under way. The NMPC's cost (eq. 20-21) has no term that orders the two:
the plan does both at once, each at its own pace, so the order seen is which of the two is
faster. This study flies asteroid_grasp (SQP solver, N = 8, T = 480 s, every 60 s) with rpod's
formulation and with one thing changed at a time, and measures from each log when the attitude
is matched and when the end effector has approached:

- rpod: Sec. IV's weights (Q_R = 70, Q_w = 5 I, Q_p = 0.01 I, W_tau = 9e-13 I, W_f = I), rpod's
  choices where the paper gives none or is garbled: terminal P = blkdiag(T Q_p, T Ts^2 Q_p),
  Q_xi = 1e-6 I, LOS slack weight rho = 1e3, the box |w_TC_T| entries <= 0.02 rad/s;
- box 0.05 rad/s (RK4 at 6 sub-steps, so that a step still turns less than ~1 rad);
- Q_R x 10 (700): a heavier attitude term;
- rho = 1, Q_xi = 1e-9 I (the printed "109" read as rpod reads it), P = 0: each suspected driver of
  the approach taken away alone, then all three, then all three with the 0.05 rad/s box.

Weights that are not config fields (Q_R, P) are changed by building the planner in this script
(`make_planner` of the plug-in, replaced while the variant flies): no default in the package moves.
Writes benchmarks/results/coupled_spin_match.md and coupled_spin_match.png.
"""

import contextlib
import dataclasses
import pathlib
import sys

import matplotlib.pyplot as plt
import numpy as np
from machine import machine_line, write_results  # benchmarks/machine.py, beside this script

from rpod.diagrams.controllers.coupled_nmpc import problem as plugin  # make_planner
from rpod.diagrams.simulate import simulate
from rpod.models import coupled_relative as cr
from rpod.planners.coupled_nmpc import CoupledNmpc as CoupledNmpcPlanner
from rpod.scenarios.campaign import apply_overrides
from rpod.scenarios.loader import load_scenario

RESULTS = pathlib.Path(__file__).resolve().parent / "results" / "coupled_spin_match.md"
FIGURE = RESULTS.with_suffix(".png")
COMMAND = "python benchmarks/study_coupled_spin_match.py"
ATTITUDE_MATCHED_DEG = 5.0
"""Spin matched: the eigenaxis error (eq. 5) first below this."""
RATE_MATCHED_FRACTION = 0.25
"""Rate matched: |w_TC_T| first below this fraction of the target's |w_IT_T| (0.008 rad/s)."""
APPROACHED_FRACTION = 0.10
"""Approached: the end effector's distance to the rock first below this fraction of its start."""
HALF_WAY_FRACTION = 0.5
FAST_BOX = {"controller.nmpc.max_relative_rate_rad_s": 0.05, "controller.nmpc.rk4_substeps": 6}
NO_DRIVERS = {"controller.nmpc.los_slack_weight": 1.0, "controller.integral_weight": 1e-9}

VARIANTS = [
    # (name, scenario overrides, CoupledNmpcWeights fields)
    ("rpod", {}, {}),
    ("box 0.05 rad/s", FAST_BOX, {}),
    ("Q_R x 10", {}, {"Q_R": 10 * cr.ATTITUDE_WEIGHT}),
    ("rho = 1", {"controller.nmpc.los_slack_weight": 1.0}, {}),
    ("Q_xi = 1e-9", {"controller.integral_weight": 1e-9}, {}),
    ("P = 0", {}, {"P": np.zeros((6, 6))}),
    ("rho = 1, Q_xi = 1e-9, P = 0", NO_DRIVERS, {"P": np.zeros((6, 6))}),
    ("same + box 0.05 rad/s", {**NO_DRIVERS, **FAST_BOX}, {"P": np.zeros((6, 6))}),
]


@contextlib.contextmanager
def planner_weights(changes: dict):
    """While open, the plug-in builds its planner with these CoupledNmpcWeights fields changed
    (Q_xi stays the config's integral_weight, as in the plug-in's own make_planner)."""
    original = plugin.make_planner

    def make_planner(scenario):
        config = scenario.controller
        weights = cr.CoupledNmpcWeights(Q_xi=config.integral_weight * np.eye(3), **changes)
        settings = dataclasses.replace(config.nmpc)
        return CoupledNmpcPlanner(plugin.coupled_params(scenario), weights, settings)

    plugin.make_planner = make_planner if changes else original
    try:
        yield
    finally:
        plugin.make_planner = original


def first_below(t: np.ndarray, values: np.ndarray, threshold: float) -> float | None:
    """The first sample time at which values < threshold (None: never)."""
    hits = np.flatnonzero(values < threshold)
    return float(t[hits[0]]) if len(hits) else None


def measure(result) -> dict:
    """The numbers of one run (module docstring) and its traces for the figure."""
    log, summary = result.log, result.summary
    t = log["t"]
    error_deg = np.degrees(log["coupled_eigenaxis_error_rad"])
    distance = np.linalg.norm(log["coupled_p_PtPc_T_m"], axis=1)
    rate = np.linalg.norm(log["coupled_w_TC_T_rad_s"], axis=1)
    spin = float(np.linalg.norm(log["w_IT_T"][0]))
    t_att = first_below(t, error_deg, ATTITUDE_MATCHED_DEG)
    t_rate = first_below(t, rate, RATE_MATCHED_FRACTION * spin)
    t_half = first_below(t, distance, HALF_WAY_FRACTION * distance[0])
    t_near = first_below(t, distance, APPROACHED_FRACTION * distance[0])
    closed = None if t_att is None else 1.0 - float(np.interp(t_att, t, distance)) / distance[0]
    error_half = None if t_half is None else float(np.interp(t_half, t, error_deg))
    if t_att is None or t_near is None:
        order = "?"
    elif t_att < t_near:
        order = "spin first" if closed < HALF_WAY_FRACTION else "together"
    else:
        order = "approach first"
    return {
        "t": t,
        "error_deg": error_deg,
        "distance_fraction": distance / distance[0],
        "t_att": t_att,
        "t_rate": t_rate,
        "t_half": t_half,
        "t_near": t_near,
        "closed": closed,
        "error_half": error_half,
        "order": order,
        "peak_rate": float(np.max(np.abs(log["coupled_w_TC_T_rad_s"]))),
        "converged_at": summary.get("coupled_converged_at_s"),
        "final_distance": float(distance[-1]),
        "delta_v": summary["delta_v_m_s"],
        "los_after": summary.get("coupled_los_last_violation_s"),
        "not_usable": summary.get("nmpc_not_usable", 0),
        "wall": summary["wall_time_s"],
    }


def held_still_costs(scenario) -> list[tuple[str, float]]:
    """What each term of (22) charges over one horizon if the chaser holds Sec. IV's start (the
    attitude 180 deg off, p_PtPc_T as at t = 0, at rest in T, xi growing as p t), with rpod's
    weights: the pull of each term at t = 0, before any plan."""
    params = plugin.coupled_params(scenario)
    weights = cr.CoupledNmpcWeights(Q_xi=scenario.controller.integral_weight * np.eye(3))
    nmpc = scenario.controller.nmpc
    T, N = nmpc.horizon_s, nmpc.intervals
    s = cr.unpack_state(cr.sec_iv_initial_state(params))
    p = s.p_PtPc_T
    A_p = cr.los_polyhedron(params.p_TPt_T, nmpc.los_half_angle_rad)
    return [
        ("attitude, Q_R tr(I - R_TC) T", weights.Q_R * (3.0 - np.trace(s.R_TC)) * T),
        ("position, p^T Q_p p T", float(p @ weights.Q_p @ p) * T),
        ("terminal, [p; 0]^T P [p; 0]", float(p @ weights.P[:3, :3] @ p)),
        ("integral, Q_xi |p|^2 T^3 / 3", float(p @ weights.Q_xi @ p) * T**3 / 3.0),
        (
            "LOS slack, rho N sum max(A_p p, 0)",
            nmpc.los_slack_weight * N * np.sum(np.maximum(A_p @ p, 0)),
        ),
    ]


def fmt(value, spec: str = ".0f", unit: str = " s") -> str:
    return "never" if value is None else f"{value:{spec}}{unit}"


def what_this_says(m: dict, held: dict) -> list[str]:
    """The answer, with this run's numbers (the variants' names as in VARIANTS)."""
    rpod, box, q_r, p0 = m["rpod"], m["box 0.05 rad/s"], m["Q_R x 10"], m["P = 0"]
    rho, q_xi = m["rho = 1"], m["Q_xi = 1e-9"]
    weak, both = m["rho = 1, Q_xi = 1e-9, P = 0"], m["same + box 0.05 rad/s"]
    attitude = held["attitude, Q_R tr(I - R_TC) T"]
    integral = held["integral, Q_xi |p|^2 T^3 / 3"]
    los = held["LOS slack, rho N sum max(A_p p, 0)"]
    boxed = [run["peak_rate"] for name, run in m.items() if "box" not in name]
    slew = first_below(rpod["t"], rpod["error_deg"], 20.0)

    def pct(value):
        return fmt(None if value is None else 100 * value, ".0f", " %")

    return [
        (
            "Nothing in eq. 20-21 orders the two motions: the plan slews and translates at once, "
            "each at the pace its terms and limits set, and the order seen is which is faster. "
            "In rpod the approach is faster: the end effector is half-way at "
            f"{fmt(rpod['t_half'])} "
            f"with the attitude still {fmt(rpod['error_half'], '.0f', ' deg')} off, and "
            f"{pct(rpod['closed'])} of the distance is flown before the error first drops below "
            f"{ATTITUDE_MATCHED_DEG:g} deg ({fmt(rpod['t_att'])}). Two things make it so, both "
            "rpod's choices where the paper gives no number or a garbled one; Sec. IV's printed "
            "Q_R, Q_w, Q_p and W_f are kept in every row but one (Q_R x 10):"
        ),
        "",
        (
            "1. The approach is driven by two terms much larger than the attitude's at t = 0: "
            f"held still for a horizon, the integral term (Q_xi = 1e-6) would cost {integral:,.0f} "
            "and the LOS slack penalty (rho = 1e3; the start is 64.7 deg off the pi/4 pyramid's "
            f"axis) {los:,.0f}, against {attitude:,.0f} for the 180 deg attitude error. Weakened, "
            f"the approach slows: half-way at {fmt(rho['t_half'])} with rho = 1, "
            f"{fmt(q_xi['t_half'])} with Q_xi = 1e-9, {fmt(weak['t_half'])} with both (and P = 0), "
            f"where the attitude is matched at {fmt(weak['t_att'])} with {pct(weak['closed'])} "
            f"flown. The terminal weight P (rpod's, blkdiag(T Q_p, T Ts^2 Q_p)) is not a driver: "
            f"P = 0 flies the same (half-way {fmt(p0['t_half'])}, "
            f"{fmt(p0['error_half'], '.0f', ' deg')} off then)."
        ),
        (
            "2. The slew is capped by rpod's rate box (|w_TC_T| entries <= 0.02 rad/s at the "
            "nodes, not in the paper; it keeps RK4 at 30 s steps honest): every 0.02 row peaks at "
            f"{min(boxed):.3f}-{max(boxed):.3f} rad/s, and rpod's error first drops below 20 deg "
            f"at {fmt(slew)}, whatever the weight. A heavier attitude weight (Q_R x 10) does not "
            "turn faster "
            f"({fmt(q_r['error_half'], '.0f', ' deg')} off at half-way, as rpod's "
            f"{fmt(rpod['error_half'], '.0f', ' deg')}); it only settles the attitude sooner "
            f"({fmt(q_r['t_att'])}). A 0.05 rad/s box (peak {box['peak_rate']:.3f}) turns it "
            f"faster ({fmt(box['error_half'], '.0f', ' deg')} off at half-way) but does not "
            f"slow the approach (half-way {fmt(box['t_half'])}), so the motions still overlap."
        ),
        "",
        (
            "With both (the drivers weakened and the 0.05 rad/s box) the run is Fig. 5's: the "
            f"attitude is matched at {fmt(both['t_att'])} with {pct(both['closed'])} of the "
            f"distance flown, {fmt(both['error_half'], '.0f', ' deg')} off at half-way "
            f"({fmt(both['t_half'])}), on {both['delta_v']:.2f} m/s of delta-v against rpod's "
            f"{rpod['delta_v']:.2f}. It does not hold the grasp pose (final distance "
            f"{both['final_distance']:.2f} m): Q_xi = 1e-9 leaves the steady offset rpod's "
            "1e-6 removes (README), and the end effector is still outside the LOS pyramid at the "
            f"end (LOS after {fmt(both['los_after'])}). So "
            "rpod's order is the price of its choices for an offset-free grasp (Q_xi), a firmly "
            "held LOS (rho) and an honest integrator (the box), not a defect in the model; "
            "the paper's own values of these (its P, rho, and a Q_xi that is offset-free) are "
            "not in our copy."
        ),
    ]


def figure(runs: list[tuple[str, dict]]) -> None:
    """Left: attitude error against the fraction of the range left (spin first: down, then
    left). Right: both against time for rpod and the last variant."""
    fig, (phase, time) = plt.subplots(1, 2, figsize=(12, 4.8))
    for name, m in runs:
        style = "-" if name in ("rpod", runs[-1][0]) else ":"
        phase.plot(m["distance_fraction"], m["error_deg"], style, label=name)
    phase.invert_xaxis()
    phase.set_xlabel("end-effector distance / its start")
    phase.set_ylabel("eigenaxis attitude error [deg]")
    phase.axhline(ATTITUDE_MATCHED_DEG, color="grey", lw=0.5)
    phase.axvline(APPROACHED_FRACTION, color="grey", lw=0.5)
    phase.set_title("order: spin first runs down the right edge, then left")
    phase.legend(fontsize=7)
    for (name, m), color in zip((runs[0], runs[-1]), ("C0", "C7")):
        time.plot(
            m["t"], m["error_deg"] / 180.0, "-", color=color, label=f"{name}: error / 180 deg"
        )
        time.plot(
            m["t"], m["distance_fraction"], "--", color=color, label=f"{name}: distance / start"
        )
    time.set_xlim(0, 1200)
    time.set_xlabel("t [s]")
    time.set_ylabel("fraction of the start")
    time.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(FIGURE, dpi=110)


def main() -> None:
    _, base = load_scenario("asteroid_grasp")
    runs = []
    for name, overrides, weights in VARIANTS:
        scenario = apply_overrides(base, overrides)
        with planner_weights(weights):
            m = measure(simulate(scenario))
        runs.append((name, m))
        print(
            f"{name}: attitude {fmt(m['t_att'])}, half-way {fmt(m['t_half'])}, "
            f"near {fmt(m['t_near'])}, {m['wall']:.0f} s wall",
            file=sys.stderr,
            flush=True,
        )
    figure(runs)
    rows = [
        f"| {name} | {fmt(m['t_att'])} | {fmt(m['t_rate'])} | {fmt(m['t_half'])} | "
        f"{fmt(m['t_near'])} | {fmt(m['closed'] and 100 * m['closed'], '.0f', ' %')} | "
        f"{fmt(m['error_half'], '.0f', ' deg')} | {m['order']} | {m['peak_rate']:.3f} | "
        f"{fmt(m['converged_at'])} | {m['final_distance']:.3f} | {m['delta_v']:.2f} | "
        f"{fmt(m['los_after'])} | "
        f"{m['not_usable']} |"
        for name, m in runs
    ]
    held = held_still_costs(base)
    costs = [f"| {term} | {value:,.0f} |" for term, value in held]
    lines = [
        "# Paper 001: spin matched first, or approach while slewing (issue 19)",
        "",
        f"Machine: {machine_line()}; `{COMMAND}`.",
        "",
        (
            "Formulation: asteroid_grasp, the coupled NMPC of eq. 22 solved by rpod's "
            "Gauss-Newton SQP (`solver: sqp`, N = 8, T = 480 s, every 60 s). rpod's weights: "
            "Sec. IV's Q_R = 70, Q_w = 5 I, Q_p = 0.01 I, W_tau = 9e-13 I, W_f = I; rpod's "
            "P = blkdiag(4.8 I, 17280 I), Q_xi = 1e-6 I, LOS slack rho = 1e3, and the box "
            "|w_TC_T| entries <= 0.02 rad/s at the nodes (not in the paper). Each other row "
            "changes what it names (the script's docstring); no package default is changed."
        ),
        "",
        (
            f"Columns: attitude = the eigenaxis error first below {ATTITUDE_MATCHED_DEG:g} deg; "
            f"rate = |w_TC_T| first below {RATE_MATCHED_FRACTION:g} of the spin |w_IT_T|; "
            "half-way / near = the end effector's distance to the rock first below 50 % / "
            f"{100 * APPROACHED_FRACTION:.0f} % of its start (113.35 m); closed = the share of "
            "that distance flown by the time the attitude is matched; error at half-way = the "
            "attitude error then; order: spin first when the attitude is matched before "
            "half-way, together when after half-way but before near; peak rate = the largest "
            "|w_TC_T| entry [rad/s] (the box holds it at the nodes only); converged = the "
            "plug-in's grasp pose (1 deg, 0.1 m) from then on; LOS after = the last sample "
            "outside the LOS pyramid; not usable = solves not flown."
        ),
        "",
        (
            "| variant | attitude | rate | half-way | near | closed | error at half-way | order "
            "| peak rate | converged | final distance (m) | delta-v (m/s) | LOS after "
            "| not usable |"
        ),
        "| --- " + "| ---: " * 6 + "| --- " + "| ---: " * 6 + "|",
        *rows,
        "",
        (
            "What each term charges over one horizon if the chaser holds the start (rpod's "
            "weights; the integral as xi = p t): the pull on each side at t = 0."
        ),
        "",
        "| term | cost |",
        "| --- | ---: |",
        *costs,
        "",
        "## What this says",
        "",
        *what_this_says(dict(runs), dict(held)),
        "",
        (
            "The figure: the attitude error against the distance left (P = 0 lies under rpod), "
            "and both against time for rpod and the last row."
        ),
        "",
        f"![attitude error against the distance left]({FIGURE.name})",
    ]
    write_results(RESULTS, lines)


if __name__ == "__main__":
    main()
