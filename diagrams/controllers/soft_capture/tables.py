"""A soft-capture campaign beside paper 000's Sec. VI-B numbers (for `rpod report`).

Owns: `campaign_table` (the plug-in's `campaign_table`) and `soft_capture_rows`: reading the
planner records and capture outcomes out of the stored run summaries and turning them into the
paper's quantities. Does not own: formatting (rpod.scenarios.report) or the store.

What is counted, over the runs that finished `ok` and have planner records (`plans`):
- The initial plan of each run (its first planner call, at t = 0, full horizon search) is the
  "planning" sample. In a closed-loop run it is planned with the controller's margins (hulls
  scaled by 1 + collision_margin, eps_p and eps_v by plan_tolerance_fraction), so it is a
  slightly harder problem than the paper's; `benchmarks/study_problem2_share.py` plans the
  same starts without them.
- Planning success: the plan was accepted, i.e. the planner succeeded and the independent
  checker passed it. Shares of SCP iterations are of those successes, as in the paper.
- Time per SCP iteration: the mean of the step times of every SCP iteration (linearisation,
  Problem 3 solve, alpha check) of the successful initial plans. Cumulative time after i
  iterations: the mean, over the plans that needed at least i, of Problem 2's step plus their
  first i iterations (the paper: 0.336 s after one, 0.889 s after five).
- Closed-loop capture: `capture_success` of the run (eps_p, eps_v, no contact before).
"""

from __future__ import annotations

import collections

import numpy as np

PAPER = {  # paper 000, Sec. VI-B
    "success": "93.2%",
    "problem2_alone": "8.6%",
    "le1": "54.9%",
    "le5": "90.5%",
    "per_iteration": "0.15 s",
    "cumulative_1": "0.336 s",
    "cumulative_5": "0.889 s",
}


def _share(count: int, total: int) -> str:
    return f"{100.0 * count / total:.1f}% ({count}/{total})" if total else "--"


def _seconds(values) -> str:
    return f"{np.mean(values):.3f} s (n = {len(values)})" if len(values) else "--"


def soft_capture_rows(rows: list[dict]) -> list[list[str]] | None:
    """[quantity, this campaign, paper 000] rows, or None when no run has planner records."""
    runs = [r["metrics"] for r in rows if r["status"] == "ok" and (r["metrics"] or {}).get("plans")]
    if not runs:
        return None
    initial = [m["plans"][0] for m in runs]
    ok = [p for p in initial if p.get("accepted")]
    scp = [int(p["scp_iterations"]) for p in ok]
    steps = [p.get("step_time_s") or [] for p in ok]
    per_iteration = [t for s in steps for t in s[1:]]
    cumulative = {
        i: [sum(s[: i + 1]) for s, n in zip(steps, scp) if n >= i and len(s) > i] for i in (1, 5)
    }
    walls = [float(p["wall_time_s"]) for p in initial]
    checked = sum(int(m.get("plans_checked", 0)) for m in runs)
    rejected = sum(int(m.get("plans_check_failed", 0)) for m in runs)
    captured = sum(1 for m in runs if m.get("capture_success"))
    after = sum(1 for m in runs if m.get("contact_after_capture"))
    table = [
        [
            "initial plans accepted (planner + checker)",
            _share(len(ok), len(initial)),
            PAPER["success"],
        ],
        ["  solved by Problem 2 alone", _share(scp.count(0), len(ok)), PAPER["problem2_alone"]],
        ["  <= 1 SCP iteration", _share(sum(n <= 1 for n in scp), len(ok)), PAPER["le1"]],
        ["  <= 5 SCP iterations", _share(sum(n <= 5 for n in scp), len(ok)), PAPER["le5"]],
        ["time per SCP iteration (mean)", _seconds(per_iteration), PAPER["per_iteration"]],
        ["Problem 2 step (mean)", _seconds([s[0] for s in steps if s]), ""],
        ["cumulative after 1 SCP iteration (mean)", _seconds(cumulative[1]), PAPER["cumulative_1"]],
        [
            "cumulative after 5 SCP iterations (mean)",
            _seconds(cumulative[5]),
            PAPER["cumulative_5"],
        ],
        [
            "initial plan wall time, whole N search (median / p95 / max)",
            " / ".join(f"{v:.3f}" for v in np.percentile(walls, [50, 95, 100])) + " s",
            "",
        ],
        [
            "plans checked by the independent checker (all calls)",
            f"{checked}, {rejected} rejected",
            "",
        ],
        ["closed-loop capture", _share(captured, len(runs)), "(not in the paper)"],
        ["  contact after a capture", _share(after, captured), ""],
    ]
    failures = collections.Counter(
        m.get("capture", {}).get("reason", "?").split(":")[0]
        for m in runs
        if not m.get("capture_success")
    )
    for reason, count in failures.most_common():
        table.append([f"  capture failed: {reason}", str(count), ""])
    return table


def campaign_table(rows: list[dict]) -> tuple[str, list[str], list[list[str]]] | None:
    """The `rpod report` table of a soft-capture campaign (soft_capture_rows), or None."""
    table = soft_capture_rows(rows)
    if not table:
        return None
    title = "Soft capture beside paper 000 Sec. VI-B (initial plans; soft_capture/tables.py):"
    return title, ["quantity", "this campaign", "paper 000"], table
