"""Methods compared on the same starts (rpod.scenarios.comparison): which cases are which
method and column, the failure classes, the disagreements, the tables and the figures."""

import math

import numpy as np
from matplotlib.image import imread

from rpod.scenarios import comparison
from rpod.scenarios.report import summary_text

EKF = {"!tag": "Ekf"}


def _row(case, index, overrides, success, **metrics):
    """A stored run as ResultStore.rows gives it (the fields the comparison reads)."""
    capture = metrics.pop("capture", {})
    status = metrics.pop("status", "ok")
    contact = metrics.pop("contact", False)
    return {
        "run_id": f"{case}-{index}",
        "grp": case,
        "case_name": case,
        "sample_index": index,
        "status": status,
        "reason": None if status == "ok" else "crashed",
        "overrides": {
            "target.w_IT_T_deg_s": [0.0, 0.0, 1.0 + index],
            "chaser.p_LC_L": [0.0, 20.0 + 5 * index, 0.0],
            **overrides,
        },
        "metrics": None
        if status != "ok"
        else {
            "mission": {"success": success, "capture": capture},
            "contact": {"occurred": contact},
            "delta_v_m_s": 1.0 + index,
            "min_separation_m": 2.0 - 0.1 * index,
            "real_time_factor": 10.0,
            **metrics,
        },
    }


def _campaign():
    """Two methods on 4 starts, each truth-fed and on the estimate (method B: `b` and `b_nav`)."""
    a = {"controller": {"!tag": "SoftCapture"}}
    b = {"controller": {"!tag": "HoldPoint", "capture": True}}
    rows = []
    for i in range(4):
        rows.append(_row("a", i, a, True, solver_failures=0, control_step_ms_p50=0.5))
        rows.append(_row("a_ekf", i, {**a, "navigation": EKF}, i != 3, solver_failures=int(i == 3)))
    for i in range(4):
        rows.append(_row("b", i, b, i < 2, final_range_m=100.0 if i == 2 else 5.0))
        rows.append(
            _row("b_nav", i, {**b, "navigation": EKF}, i == 0, final_range_m=5.0)
            if i != 3
            else _row("b_nav", i, {**b, "navigation": EKF}, False, status="failed")
        )
    return rows


def test_cases_are_grouped_into_methods_and_columns_by_their_overrides():
    methods = comparison.find_methods(_campaign())
    assert [(m.name, m.cases) for m in methods] == [
        ("a", {"truth-fed": "a", "estimated": "a_ekf"}),
        ("b", {"truth-fed": "b", "estimated": "b_nav"}),
    ]


def test_a_campaign_without_common_starts_is_not_compared():
    rows = _campaign()
    assert comparison.compared_methods([r for r in rows if r["case_name"] == "a"]) == []
    unsampled = [dict(r, sample_index=None) for r in rows]
    assert comparison.find_methods(unsampled) == []
    missing = [r for r in rows if not (r["case_name"] == "b" and r["sample_index"] == 0)]
    assert comparison.find_methods(missing) == []


def test_each_failure_gets_the_first_class_that_holds():
    rows = _campaign()
    cells = comparison.cells(rows, comparison.find_methods(rows))
    counts = {(c.method, c.column): comparison.failure_counts(c, cells) for c in cells}
    assert counts[("a", "truth-fed")] == {}
    assert counts[("a", "estimated")] == {"solver failure": 1}
    # b, start 2: driven away (final range 100 m > the 30 m start); start 3: on its way.
    assert counts[("b", "truth-fed")] == {"tracking": 1, "timeout": 1}
    # b_nav: start 1 captured truth-fed -> navigation; 2 failed both ways; 3 crashed.
    assert counts[("b", "estimated")] == {"sim failed": 1, "navigation": 1, "timeout": 1}


def test_contact_and_an_infeasible_plan_come_first():
    contact = _row("x", 0, {}, False, contact=True, solver_failures=3)
    assert comparison.failure_class(contact, None) == "contact"
    infeasible = _row("x", 0, {}, False, initial_plan_success=False, solver_failures=3)
    assert comparison.failure_class(infeasible, None) == "plan infeasible"
    too_fast = _row("x", 0, {}, False, capture={"reason": "speed: within 0.35 m ..."})
    assert comparison.failure_class(too_fast, None) == "tracking"
    assert comparison.failure_class(_row("x", 0, {}, True), None) is None


def test_the_statistics_of_a_cell():
    rows = _campaign()
    cells = comparison.cells(rows, comparison.find_methods(rows))
    a = comparison.cell_statistics(cells[0])
    assert (a["success"].successes, a["success"].n) == (4, 4)
    # Starts 0-3 tumble at 1, 2, 3, 4 deg/s: all up to 5.
    assert a["success_slow"].n == 4
    assert a["delta_v_p50"] == np.median([1.0, 2.0, 3.0, 4.0])
    assert math.isclose(a["least_clearance"], 1.7)
    assert a["solver_failure_runs"] == 0 and a["step_ms_p50"] == 0.5
    b = comparison.cell_statistics(cells[2])
    assert b["delta_v_p50"] == 1.5  # over the captured runs only (starts 0, 1)
    assert b["solver_failure_runs"] is None  # a PD has no solver: no figure, not zero


def test_disagreements_name_the_start_and_a_rerunnable_run():
    rows = _campaign()
    found = comparison.disagreements(comparison.cells(rows, comparison.find_methods(rows)))
    assert [(d["sample_index"], d["column"]) for d in found] == [
        (2, "truth-fed"),
        (3, "truth-fed"),
        (1, "estimated"),
        (2, "estimated"),
    ]
    assert found[0]["captured"] == ["a"] and found[0]["failed"] == {"b": "b-2"}
    assert found[0]["tumble_deg_s"] == 3.0 and found[0]["start_range_m"] == 30.0


def test_the_report_leads_with_the_comparison_and_draws_its_figures(tmp_path):
    rows = _campaign()
    text = summary_text({"campaign_name": "shoot", "base_name": "x"}, rows, [], "runs/shoot")
    assert "Methods compared on the same 4 starts" in text
    assert "rpod sweep shoot --out runs/shoot --rerun b-2" in text
    assert text.index("Methods compared") < text.index("Failed runs by class")
    paths = comparison.comparison_figures(rows, tmp_path)
    assert [p.name for p in paths] == [
        "success_vs_tumble.png",
        "success_vs_range.png",
        "delta_v_vs_range.png",
    ]
    for path in paths:
        pixels = imread(path)
        assert pixels.shape[0] > 300 and pixels[..., :3].std() > 0.05  # drawn, not blank


def test_a_column_with_runs_pending_is_named_not_drawn(tmp_path):
    """Six flown runs of 200 would draw as the method's curve; a partly flown column is left
    out of the success curves and its legend entry says how many runs are pending."""
    rows = _campaign()
    rows = [
        dict(r, status="pending", metrics=None) if r["grp"] == "b" and r["sample_index"] > 0 else r
        for r in rows
    ]
    cells = comparison.cells(rows, comparison.compared_methods(rows))
    labels = {(c.method, c.column): comparison.success_curve_label(c) for c in cells}
    assert labels[("b", comparison.TRUTH_FED)].endswith("not drawn, 3 of 4 runs pending")
    assert "pending" not in labels[("a", comparison.TRUTH_FED)]
    assert len(comparison.comparison_figures(rows, tmp_path)) == 3
