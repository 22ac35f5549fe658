"""Every bundled method flown on its navigation estimate: truth-fed, then `!Ekf` at zero, the
default and three times the default sensor noise, on the same starts.

    python benchmarks/navigation_methods.py [--jobs 2] [--per-method N]

Writes benchmarks/results/navigation.md. The cases (issue 21):
- soft capture: the first 50 runs of the `soft_capture_250` campaign (paper 000 Sec. VI-B);
- LOS corridor: the 15 inside starts of `los_table3` (paper 004 Table 3), with the pose sensor's
  range window out to 400 m (the starts are up to 300 m away; the default window ends at 200 m);
- hold point and the asteroid grasp: the bundled scenario and 10 dispersed starts each (drawn
  here with a fixed seed: the chaser's start moved, the tumble's axis and rate drawn);
- planar approach: the Sec. V-A scenario and 10 Case Study 1 points (every 268th run of
  `planar_case1`), planned at t = 0 from what the tracker senses then (the estimate). The pose
  sensor is the 3-D one: its out-of-plane noise reaches the planar tracker only through the
  bundle's z components, which it does not read.
Each case flies four times: `!Truth`, then `!Ekf {noise_scale: 0 | 1 | 3}` with the scenario's
seed 0. A run is a success when the mission verdict says so (summary.json's `mission`), which
is never a success with contact of the true shapes.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import multiprocessing
import pathlib
import re
import statistics
import sys
import time

import numpy as np
from machine import machine_line  # benchmarks/machine.py, beside this script

RESULTS = pathlib.Path(__file__).resolve().parent / "results" / "navigation.md"
COMMAND = "python benchmarks/navigation_methods.py"
LEVELS = ("truth", 0.0, 1.0, 3.0)
DISPERSED = 10
SEED = 21


def _ekf(level, **pose):
    from rpod.systems.navigation_config import Ekf

    config = Ekf(noise_scale=level)
    for name, value in pose.items():
        setattr(config.pose_sensor, name, value)
    return config


def cases(per_method: int | None) -> list[tuple[str, str, object, dict]]:
    """(method, case name, scenario, pose-sensor settings) for every case of the study."""
    from rpod.scenarios.campaign import apply_overrides, load_campaign, plan_runs
    from rpod.scenarios.loader import load_scenario

    out = []

    def from_campaign(method, name, select, pose=None):
        campaign = load_campaign(name)
        for run in select(plan_runs(campaign)):
            label = run.case or (
                f"sample {run.sample_index}" if run.sample_index is not None else run.group
            )
            out.append((method, label, apply_overrides(campaign.base, run.overrides), pose or {}))

    from_campaign("soft_capture", "soft_capture_250", lambda runs: runs[:50])
    from_campaign(
        "los_corridor",
        "los_table3",
        lambda runs: [run for run in runs if run.case.endswith("_inside")],
        {"range_max_m": 400.0},
    )
    rng = np.random.default_rng(SEED)
    for method in ("hold_point", "asteroid_grasp"):
        _, base = load_scenario(method)
        out.append((method, "bundled", base, {}))
        for k in range(DISPERSED):
            p = np.asarray(base.chaser.p_LC_L, dtype=float)
            w = np.asarray(base.target.w_IT_T_deg_s, dtype=float)
            if method == "hold_point":  # 20-40 m away in any direction, tumble 0.5-2 deg/s
                direction = rng.standard_normal(3)
                p = rng.uniform(20.0, 40.0) * direction / np.linalg.norm(direction)
                axis = rng.standard_normal(3)
                w = rng.uniform(0.5, 2.0) * axis / np.linalg.norm(axis)
                overrides = {"chaser.p_LC_L": p.tolist(), "target.w_IT_T_deg_s": w.tolist()}
            else:  # the start moved by up to 5 m per axis, the spin's rate by up to 20 %
                p = p + rng.uniform(-5.0, 5.0, 3)
                w = w * rng.uniform(0.8, 1.2)
                overrides = {"chaser.p_LC_L": p.tolist(), "target.w_IT_T_deg_s": w.tolist()}
            out.append((method, f"dispersed {k}", apply_overrides(base, overrides), {}))
    _, planar = load_scenario("planar_approach")
    out.append(("planar_approach", "Sec. V-A", planar, {}))
    from_campaign("planar_approach", "planar_case1", lambda runs: runs[::268][:DISPERSED])
    if per_method is not None:
        counts, kept = {}, []
        for case in out:
            counts[case[0]] = counts.get(case[0], 0) + 1
            if counts[case[0]] <= per_method:
                kept.append(case)
        out = kept
    return out


def fly(job) -> dict:
    """One case at one level: the summary's numbers the table needs."""
    from rpod.diagrams.simulate import simulate
    from rpod.scenarios.loader import parse_scenario

    method, label, text, pose, level = job
    scenario = parse_scenario(text)  # sent as YAML: a Scenario holds unpicklable Drake configs
    if level != "truth":
        scenario = dataclasses.replace(scenario, navigation=_ekf(level, **pose))
    start = time.perf_counter()
    try:
        summary = simulate(scenario).summary
    except (RuntimeError, ValueError) as error:  # a build error (e.g. a lead-in without fixes)
        return {"method": method, "case": label, "level": level, "error": str(error)}
    mission = summary["mission"]
    nav = summary.get("navigation") or {}
    errors = nav.get("errors", {})
    return {
        "method": method,
        "case": label,
        "level": level,
        "success": bool(mission["success"]),
        "contact": bool(mission.get("contact")),
        "outcome": mission["outcome"],
        "delta_v": summary["delta_v_m_s"],
        "min_separation": summary["min_separation_m"],
        "los_violation": summary.get("los_violation"),
        "position_rms": errors.get("position", {}).get("rms"),
        "attitude_rms": errors.get("attitude", {}).get("rms"),
        "rate_rms": errors.get("rate", {}).get("rms"),
        "nees_mean": nav.get("nees_mean"),
        "rejected": nav.get("fixes_rejected"),
        "wall_s": time.perf_counter() - start,
    }


def _median(values):
    values = [v for v in values if v is not None]
    return statistics.median(values) if values else None


def _fmt(value, digits=3):
    if value is None:
        return "-"
    return f"{value:.{digits}g}" if isinstance(value, float) else str(value)


def _case_name(label: str) -> str:
    """A case's label with its numbers to 4 significant digits (a grid point's label carries
    every digit of its values)."""
    return re.sub(r"\d+\.\d{5,}", lambda match: f"{float(match.group()):.4g}", label)


def _level_name(level) -> str:
    return "truth" if level == "truth" else f"Ekf x{level:g}"


def report(results: list[dict], jobs: int, planned: dict) -> str:
    # A case counts once all four levels have flown (a study cut short leaves some half done).
    flown_levels: dict = {}
    for r in results:
        flown_levels.setdefault((r["method"], r["case"]), set()).add(r["level"])
    complete = {key for key, levels in flown_levels.items() if len(levels) == len(LEVELS)}
    results = [r for r in results if (r["method"], r["case"]) in complete]
    methods = list(dict.fromkeys(r["method"] for r in results))
    coverage = ", ".join(
        f"{m} {sum(1 for key in complete if key[0] == m)}/{planned[m]}" for m in planned
    )
    lines = [
        "# Every method on its navigation estimate",
        "",
        (
            f"Command: `{COMMAND}` ({machine_line()}; {len(results)} runs on {jobs} "
            f"processes). Cases flown at every level, of those planned: {coverage}. "
            "Levels: truth-fed, then `navigation: !Ekf` with every "
            "sensor's noise times 0, 1 (the defaults: pose 1 cm / 1 % of range and 2 deg at "
            "2 Hz, 0.1 s latency; star tracker 10 arcsec; gyro 0.15 deg/sqrt(h); GNSS 1 m, "
            "1 cm/s) and 3. The cases are in the script's docstring."
        ),
        "",
        (
            "Success is the mission verdict of summary.json (never with contact). Safety: the "
            "least separation of the true shapes, runs with contact, and (LOS) runs that left "
            "the corridor. Navigation: medians over the cases of each run's RMS error and "
            "kinematic NEES mean (12 states; 12 is consistent)."
        ),
        "",
        (
            "| method | level | success | delta-v median [m/s] | least separation [m] "
            "| contact | corridor left | position RMS [m] | attitude RMS [deg] | NEES mean |"
        ),
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for method in methods:
        for level in LEVELS:
            rows = [r for r in results if r["method"] == method and r["level"] == level]
            if not rows:
                continue
            flown = [r for r in rows if "error" not in r]
            ok = sum(r["success"] for r in flown)
            corridor = (
                str(sum(bool(r["los_violation"]) for r in flown))
                if method == "los_corridor"
                else "-"
            )
            least = min((r["min_separation"] for r in flown), default=None)
            lines.append(
                f"| {method} | {_level_name(level)} | {ok}/{len(rows)} "
                f"| {_fmt(_median(r['delta_v'] for r in flown))} | {_fmt(least)} "
                f"| {sum(r['contact'] for r in flown)} | {corridor} "
                f"| {_fmt(_median(r['position_rms'] for r in flown))} "
                f"| {_fmt(_median(r['attitude_rms'] for r in flown))} "
                f"| {_fmt(_median(r['nees_mean'] for r in flown))} |"
            )
    lines += ["", "## Goals at the default noise", ""]
    by_key = {(r["method"], r["case"], r["level"]): r for r in results}

    def kept(method, level=1.0):
        truth_ok = [
            case
            for (m, case, lev), r in by_key.items()
            if m == method and lev == "truth" and r.get("success")
        ]
        held = [c for c in truth_ok if by_key.get((method, c, level), {}).get("success")]
        return held, truth_ok

    held, truth_ok = kept("soft_capture")
    if truth_ok:
        share = len(held) / len(truth_ok)
        lines.append(
            f"- Soft capture succeeds on {len(held)}/{len(truth_ok)} = {share:.0%} of the cases "
            f"it captures truth-fed (goal: at least 95 %): "
            f"{'met' if share >= 0.95 else 'NOT met'}."
        )
    held, truth_ok = kept("los_corridor")
    if truth_ok:
        clean = [c for c in held if not by_key[("los_corridor", c, 1.0)].get("los_violation")]
        lines.append(
            f"- LOS inside starts held truth-fed: {len(truth_ok)}; held with zero violations "
            f"on the estimate: {len(clean)} (goal: all): "
            f"{'met' if len(clean) == len(truth_ok) else 'NOT met'}."
        )
    bundled = by_key.get(("asteroid_grasp", "bundled", 1.0))
    if bundled and "error" not in bundled:
        lines.append(
            f"- The asteroid grasp on the estimate: {bundled['outcome']} "
            f"({'converges' if bundled['success'] else 'does NOT converge'})."
        )
    failures = [
        r
        for r in results
        if r["level"] != "truth"
        and not r.get("success", False)
        and by_key.get((r["method"], r["case"], "truth"), {}).get("success")
    ]
    lines += [
        "",
        "## Where the estimate costs a success the truth had",
        "",
        (
            "Each run that succeeds truth-fed and fails on the estimate, with its outcome and "
            "its estimate's errors (RMS over the run):"
        ),
        "",
    ]
    if not failures:
        lines.append("None.")
    else:
        lines += [
            (
                "| method | case | level | outcome | position RMS [m] | attitude RMS [deg] "
                "| rate RMS [deg/s] | NEES mean |"
            ),
            "|---|---|---|---|---|---|---|---|",
        ]
        for r in failures:
            outcome = r.get("outcome") or r.get("error", "")
            lines.append(
                f"| {r['method']} | {_case_name(r['case'])} | {_level_name(r['level'])} | {outcome} "
                f"| {_fmt(r.get('position_rms'))} | {_fmt(r.get('attitude_rms'))} "
                f"| {_fmt(r.get('rate_rms'))} | {_fmt(r.get('nees_mean'))} |"
            )
    return "\n".join(lines) + "\n"


def _interleaved(all_cases: list) -> list:
    """The cases taken one per method in turn (so that a study cut short still covers every
    method), each method's in its own order."""
    by_method: dict[str, list] = {}
    for case in all_cases:
        by_method.setdefault(case[0], []).append(case)
    queues = list(by_method.values())
    out = []
    while any(queues):
        for queue in queues:
            if queue:
                out.append(queue.pop(0))
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--per-method", type=int, default=None, help="a quick subset")
    parser.add_argument("--out", type=pathlib.Path, default=RESULTS)
    parser.add_argument(
        "--runs",
        type=pathlib.Path,
        default=pathlib.Path("navigation_runs.jsonl"),
        help="each finished run, one JSON line (resumed from: runs in it are not flown again)",
    )
    parser.add_argument(
        "--report-only",
        action="store_true",
        help="write the report from --runs as it is (the committed runs: "
        "benchmarks/results/navigation_runs.jsonl)",
    )
    args = parser.parse_args(argv)
    from rpod.scenarios.loader import dump_scenario

    all_cases = _interleaved(cases(args.per_method))
    done = {}
    if args.runs.exists():
        for line in args.runs.read_text().splitlines():
            result = json.loads(line)
            done[(result["method"], result["case"], result["level"])] = result
    jobs = [
        (method, label, dump_scenario(scenario), pose, level)
        for method, label, scenario, pose in all_cases
        for level in LEVELS
        if (method, label, level) not in done
    ]
    if not args.report_only and jobs:
        with (
            multiprocessing.get_context("spawn").Pool(args.jobs, maxtasksperchild=20) as pool,
            args.runs.open("a") as runs,
        ):
            for k, result in enumerate(pool.imap(fly, jobs), 1):
                done[(result["method"], result["case"], result["level"])] = result
                runs.write(json.dumps(result) + "\n")
                runs.flush()
                state = "error" if "error" in result else ("ok" if result["success"] else "FAIL")
                print(
                    f"[{k}/{len(jobs)}] {result['method']} {result['case']} "
                    f"{_level_name(result['level'])}: {state}",
                    flush=True,
                )
    order = {(m, c): i for i, (m, c, _, _) in enumerate(all_cases)}
    results = sorted(
        done.values(), key=lambda r: (order[(r["method"], r["case"])], LEVELS.index(r["level"]))
    )
    planned = {m: sum(1 for c in all_cases if c[0] == m) for m, *_ in all_cases}
    text = report(results, args.jobs, planned)
    args.out.write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
