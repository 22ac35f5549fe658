"""Paper 000's Figs. 5-9 from rpod's planner: the Sec. VI-A example and the Sec. VI-B campaign.

A study, not a speed benchmark (planner only, no simulation, single process):
- Figs. 5-7 (Sec. VI-A): the bundled `soft_capture` scenario planned as `rpod plan soft_capture`
  plans it (rpod.scenarios.plan.plan_scenario: the scenario's tolerances, true hulls, checked).
  The planner returns only its last iterate, so Problem 2's solution and every SCP iterate are
  re-solved here through the planner's public API at the returned N, with i_max = 0, 1, ...,
  i (the SCP is deterministic: the iterate after i iterations is what a planner stopped at
  i_max = i returns); the last must equal the plan, which is asserted.
- Figs. 8-9 (Sec. VI-B): the 250 starts of the bundled campaign `soft_capture_250`, each planned
  at t = 0 with the planner's config as the scenario gives it (Table I as printed, the true
  hulls; the `paper` variant of study_problem2_share.py) through the same predict-plan-check
  path as `rpod plan`, so a success is also a plan the independent checker passed.

Usage: python benchmarks/soft_capture_figures.py [--samples 250]
Writes benchmarks/results/soft_capture_figures/*.png and benchmarks/results/soft_capture_figures.md.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import pathlib
import time

import numpy as np
from machine import machine_line, write_results  # benchmarks/machine.py, beside this script

from rpod.diagrams.controllers.soft_capture import (
    controller_config,
    plan_arrays,
    plan_scenario,
    plan_summary,
)
from rpod.diagrams.controllers.soft_capture.plan_figures import (
    write_alpha_overlay_plot,
    write_scp_correction_plots,
    write_start_outcomes_plot,
)
from rpod.diagrams.scenario import (
    body_polytopes,
    chaser_rotation_in_lvlh,
    initial_relative_state_L,
    target_rotation_in_lvlh,
)
from rpod.models.frames import quaternion_wxyz
from rpod.models.statistics import SuccessShare
from rpod.planners.checked_plan import predict_plan_check
from rpod.planners.soft_capture import SoftCapturePlanner
from rpod.scenarios.campaign import apply_overrides, load_campaign, plan_runs
from rpod.scenarios.loader import load_scenario

RESULTS = pathlib.Path(__file__).parent / "results"
FIGURES = RESULTS / "soft_capture_figures"
REPORT = RESULTS / "soft_capture_figures.md"
NOTES = "## Where ours differ"
PAPER = {  # paper 000, Sec. VI
    "success": (233, 250),
    "problem2_alone": 8.6,
    "le1": 54.9,
    "le5": 90.5,
    "example_scp_iterations": 4,
}


def delta_v(u: np.ndarray, dt_s: float, mass_kg: float) -> float:
    """sum_k |u_k| dt / m [m/s], as summary.json's delta_v_m_s."""
    return float(np.linalg.norm(u, axis=1).sum() * dt_s / mass_kg)


def scp_iterates(result, scenario) -> list[dict]:
    """Problem 2's solution and each SCP iterate at the plan's N, as plan.npz-like dicts."""
    plan, config = result.plan, result.config
    base = plan_arrays(result)
    iterates = []
    for i in range(plan.scp_iterations + 1):
        planner = SoftCapturePlanner(
            dataclasses.replace(config, max_scp_iterations=i),
            result.chaser_hull,
            result.target_hull,
        )
        iterate = planner.plan(
            result.x0,
            result.checked.prediction,
            horizons=[plan.N],
            R_LC0=chaser_rotation_in_lvlh(scenario),
        )
        assert iterate.N == plan.N and iterate.scp_iterations == i, (iterate.N, i)
        iterates.append(
            base
            | {
                "t": iterate.t,
                "x": iterate.x,
                "u": iterate.u,
                "q_LC": iterate.q_LC,
                "alpha": iterate.alpha,
            }
        )
    last = iterates[-1]
    assert np.allclose(last["x"], plan.x, atol=1e-9) and np.allclose(last["u"], plan.u, atol=1e-9)
    return iterates


def example(figures: pathlib.Path) -> dict:
    """Plans `soft_capture` as `rpod plan` does and writes Figs. 5-7; returns its numbers."""
    name, scenario = load_scenario("soft_capture")
    result = plan_scenario(scenario)
    report = result.checked.report
    summary = plan_summary(result, report) | {"status": result.checked.status.value}
    iterates = scp_iterates(result, scenario)
    write_scp_correction_plots(iterates, figures, title=f"{name} (rpod plan)")
    config = result.config
    p2 = iterates[0]
    return {
        "status": summary["status"],
        "check": summary["check"]["passed"] if summary["check"] else None,
        "N": summary["N"],
        "scp": summary["scp_iterations"],
        "range_m": float(np.linalg.norm(result.x0[:3])),
        "tumble_deg_s": float(np.linalg.norm(scenario.target.w_IT_T_deg_s)),
        "dv": summary["delta_v_m_s"],
        "dv_p2": delta_v(p2["u"], config.dt_s, config.chaser_mass_kg),
        "min_alpha": summary["min_alpha"],
        "min_alpha_p2": float(np.min(p2["alpha"])),
        "bad_knots_p2": np.flatnonzero(p2["alpha"] <= 1.0),
        "burns_p2": burns(p2["u"]),
        "burns": burns(iterates[-1]["u"]),
        "wall_s": summary["wall_time_s"],
    }


def burns(u: np.ndarray, threshold_N: float = 1.0) -> int:
    """Number of runs of consecutive steps with |u_k| > threshold_N (the paper's "burns")."""
    on = np.linalg.norm(u, axis=1) > threshold_N
    return int(np.sum(on[1:] & ~on[:-1]) + (1 if len(on) and on[0] else 0))


def campaign(samples: int) -> list[dict]:
    """Plans the campaign's starts (planner only, t = 0); one row per start."""
    loaded = load_campaign("soft_capture_250")
    runs = plan_runs(loaded)[:samples]
    planners: dict = {}
    rows = []
    for run in runs:
        scenario = apply_overrides(loaded.base, run.overrides)
        config = controller_config(scenario).planner  # Table I as the scenario gives it
        chaser_hull, target_hull = body_polytopes(scenario)
        key = (repr(config), chaser_hull.b.tobytes(), target_hull.b.tobytes())
        if key not in planners:  # one planner (and its programs) for every start
            planners[key] = SoftCapturePlanner(config, chaser_hull, target_hull)
        x0 = np.concatenate(initial_relative_state_L(scenario))
        w_IT_T = np.radians(np.asarray(scenario.target.w_IT_T_deg_s, float))
        start, cpu = time.perf_counter(), time.process_time()
        checked = predict_plan_check(
            planners[key],
            x0,
            quaternion_wxyz(target_rotation_in_lvlh(scenario)),
            w_IT_T,
            np.asarray(scenario.target.inertia_kg_m2, float),
            R_LC0=chaser_rotation_in_lvlh(scenario),
        )
        plan = checked.plan
        rows.append(
            {
                "index": run.sample_index,
                "status": checked.status.value,
                "range_m": float(np.linalg.norm(x0[:3])),
                "tumble_deg_s": float(np.degrees(np.linalg.norm(w_IT_T))),
                "N": plan.N if plan is not None else 0,
                "scp": plan.scp_iterations if plan is not None else 0,
                "t": None if plan is None else plan.t,
                "alpha": None if plan is None else plan.alpha,
                "wall_s": time.perf_counter() - start,
                "cpu_s": time.process_time() - cpu,
                "reason": checked.reason,
            }
        )
        if len(rows) % 25 == 0:
            print(f"{len(rows)}/{len(runs)} planned", flush=True)
    return rows


def _percent(count: int, total: int) -> str:
    return f"{100.0 * count / total:.1f} % ({count}/{total})" if total else "--"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=250)
    args = parser.parse_args()
    load0, start = os.getloadavg(), time.perf_counter()

    ex = example(FIGURES)
    rows = campaign(args.samples)
    ok = [r for r in rows if r["status"] == "success"]
    share = SuccessShare(len(ok), len(rows))
    paper_share = SuccessShare(*PAPER["success"])
    least = min(ok, key=lambda r: r["alpha"].min()) if ok else None
    least_alpha = float(least["alpha"].min()) if least else float("nan")
    below_min = sum(1 for r in ok if r["alpha"].min() < 1.3)
    statuses = sorted({r["status"] for r in rows if r["status"] != "success"})
    counts = {s: sum(1 for r in rows if r["status"] == s) for s in statuses}

    write_start_outcomes_plot(
        FIGURES / "fig8_starts.png",
        [r["range_m"] for r in rows],
        [r["tumble_deg_s"] for r in rows],
        [r["status"] for r in rows],
        title=(
            f"Paper 000 Fig. 8, {len(rows)} starts of soft_capture_250 (planner only)\n"
            f"success: ours {share.percent_text()}; paper 93.2 % (233/250)"
        ),
    )
    fig9 = None
    if ok:
        fig9 = write_alpha_overlay_plot(
            FIGURES / "fig9_alpha.png",
            [(r["t"], r["alpha"]) for r in ok],
            alpha_min=1.3,
            title=(
                f"Paper 000 Fig. 9: alpha_k of the {len(ok)} successful plans of "
                f"soft_capture_250's starts (planner only)"
            ),
            colour_values=[r["range_m"] for r in ok],
            colour_label="start range [m]",
            labels=[f"start {r['index']}" for r in ok],
        )
    wall = time.perf_counter() - start
    scp = [r["scp"] for r in ok]
    N_ok = [r["N"] for r in ok]
    walls = [r["wall_s"] for r in rows]
    cpus = [r["cpu_s"] for r in rows]
    bad_p2 = ", ".join(f"{k:d}" for k in ex["bad_knots_p2"]) or "none"
    other = ", ".join(f"{s} {c}" for s, c in counts.items()) or "none"
    table = [
        (
            "Sec. VI-A example: start",
            (
                f"{ex['range_m']:.1f} m away, tumble {ex['tumble_deg_s']:.2f} deg/s (the "
                "bundled scenario, a Sec. VI-B-like start)"
            ),
            "not given",
        ),
        ("Sec. VI-A example: planner status", ex["status"], "success"),
        ("Sec. VI-A example: N (time to capture)", f"{ex['N']} ({ex['N'] - 1} s)", "not given"),
        ("Sec. VI-A example: SCP iterations", ex["scp"], PAPER["example_scp_iterations"]),
        (
            "Sec. VI-A example: min alpha_k of Problem 2 / of the plan",
            f"{ex['min_alpha_p2']:.3f} (alpha_k <= 1 at t = {bad_p2} s) / {ex['min_alpha']:.3f}",
            "below 1 at the end / above 1 (Fig. 7)",
        ),
        (
            "Sec. VI-A example: delta-v, sum_k abs(u_k) dt / m, of Problem 2 / of the plan",
            f"{ex['dv_p2']:.3f} / {ex['dv']:.3f} m/s",
            "not given",
        ),
        (
            "Sec. VI-A example: burns (runs of abs(u_k) > 1 N) of Problem 2 / of the plan",
            f"{ex['burns_p2']} / {ex['burns']}",
            "2 / more (Fig. 6)",
        ),
        ("Sec. VI-B: plans that succeed", share.percent_text(), paper_share.percent_text()),
        ("Sec. VI-B: other statuses", other, "17 infeasible within N = 40..350"),
        (
            "Sec. VI-B: least alpha_k over the successful plans",
            f"{least_alpha:.4f} (start {least['index'] if least else '--'})",
            "> 1 (Fig. 9)",
        ),
        (
            "Sec. VI-B: successful plans with some alpha_k < alpha_min = 1.3",
            _percent(below_min, len(ok)),
            "some (Fig. 9)",
        ),
        (
            "Sec. VI-B: Problem 2 alone (0 SCP iterations), of the successes",
            _percent(sum(1 for s in scp if s == 0), len(ok)),
            f"{PAPER['problem2_alone']} %",
        ),
        (
            "Sec. VI-B: <= 1 SCP iteration",
            _percent(sum(1 for s in scp if s <= 1), len(ok)),
            f"{PAPER['le1']} %",
        ),
        (
            "Sec. VI-B: <= 5 SCP iterations",
            _percent(sum(1 for s in scp if s <= 5), len(ok)),
            f"{PAPER['le5']} %",
        ),
        (
            "Sec. VI-B: N of the successful plans (median, min-max)",
            f"{np.median(N_ok):.0f}, {min(N_ok)}-{max(N_ok)}" if ok else "--",
            "not given",
        ),
        (
            "Sec. VI-B: plan + check time per start, CPU (median, max) / wall (median, max)",
            f"{np.median(cpus):.2f} s, {max(cpus):.2f} s / {np.median(walls):.2f} s, {max(walls):.2f} s",
            "0.15 s per SCP iteration (MOSEK, i7 laptop)",
        ),
    ]
    fig9_text = (
        "- `fig9_alpha.png` (Fig. 9): alpha_k against t of every successful plan, coloured by "
        "the start range, with alpha = 1 (hard) and alpha_min = 1.3 (soft buffer); the least "
        "alpha_k is circled."
        if fig9
        else "- `fig9_alpha.png`: not drawn (no successful plan)."
    )
    lines = [
        "# Paper 000's Figs. 5-9 from rpod's planner",
        "",
        (
            f"Machine: {machine_line()}; load average {load0[0]:.2f} at the start, "
            f"{os.getloadavg()[0]:.2f} at the end; {wall:.0f} s in all (single process)."
        ),
        "",
        (
            f"Command: `python benchmarks/soft_capture_figures.py --samples {args.samples}` "
            "(planner only, no simulation)."
        ),
        "",
        "## Figures (benchmarks/results/soft_capture_figures/)",
        "",
        (
            "Sec. VI-A: the bundled `soft_capture` scenario planned as `rpod plan soft_capture` "
            "plans it (the scenario's tolerances, the true hulls, Table I; the independent check "
            f"{'passed' if ex['check'] else 'FAILED'}). Problem 2's solution and the SCP "
            "iterates are re-solved at the returned N with i_max = 0, 1, ... (the planner "
            "returns only its last iterate); the last equals the plan (asserted)."
        ),
        "",
        (
            "- `fig5_trajectory.png` (Fig. 5): Problem 2's path (left) beside the SCP's (right) "
            "in the target frame T, where the target and the docking cone stand still; knots "
            "with alpha_k <= 1 are red crosses; the chaser hull is drawn at Problem 2's worst "
            "knot and at the final knot."
        ),
        (
            "- `fig6_thrust.png` (Fig. 6): u_k in L of Problem 2 and of the plan, then both "
            "norms with U_max."
        ),
        (
            "- `fig7_alpha.png` (Fig. 7): alpha_k of Problem 2 and of each SCP iterate, all "
            "knots (log scale) and the final knots (linear), with alpha = 1 and alpha_min = 1.3."
        ),
        "",
        (
            f"Sec. VI-B: the {len(rows)} starts of the bundled campaign `soft_capture_250` (seed "
            "2000), each planned at t = 0 with Table I as printed and the true hulls (the "
            "`paper` variant of benchmarks/study_problem2_share.py), through the same "
            "predict-plan-check path as `rpod plan`: a success is a plan that passed the hard "
            "test alpha_k > 1 and the independent checker."
        ),
        "",
        (
            "- `fig8_starts.png` (Fig. 8): each start's tumble rate |w_IT_T| against its range, "
            "coloured by the planner's status, with the count of each status in the legend."
        ),
        fig9_text,
        "",
        "## Ours beside the paper's",
        "",
        "| quantity | rpod | paper 000 |",
        "| --- | --- | --- |",
        *(f"| {quantity} | {ours} | {paper} |" for quantity, ours, paper in table),
        "",
        "Starts that did not succeed (sample index, range, tumble rate, status: reason):",
        "",
        *(
            f"- {r['index']}: {r['range_m']:.1f} m, {r['tumble_deg_s']:.2f} deg/s, "
            f"{r['status']}: {r['reason']}"
            for r in rows
            if r["status"] != "success"
        ),
        *([] if len(ok) < len(rows) else ["- none"]),
        "",
    ]
    # Hand-written interpretation below NOTES in an existing file is kept.
    if REPORT.exists() and NOTES in REPORT.read_text():
        lines.append(NOTES + REPORT.read_text().split(NOTES, 1)[1].rstrip("\n"))
    write_results(REPORT, lines)


if __name__ == "__main__":
    main()
