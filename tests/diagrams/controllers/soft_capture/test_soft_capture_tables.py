"""The paper 000 comparison of `rpod report`, on synthetic stored runs with known answers."""

import pytest

from rpod.diagrams.controllers.soft_capture import soft_capture_rows
from rpod.scenarios.report import summary_text


def _run(scp: int, steps: list[float], accepted=True, captured=True, after=False, status="ok"):
    plan = {"accepted": accepted, "scp_iterations": scp, "step_time_s": steps,
            "wall_time_s": sum(steps) + 0.1}  # fmt: skip
    metrics = {
        "plans": [plan, {"accepted": True}],
        "plans_checked": 2 if accepted else 1,
        "plans_check_failed": 0 if accepted else 1,
        "capture_success": captured,
        "contact_after_capture": after,
        "capture": {"reason": "capture points within" if captured else "contact: at t = 9 s"},
    }
    return {"status": status, "metrics": metrics, "grp": "all", "reason": None}


def _table(rows) -> dict:
    return {quantity.strip(): measured for quantity, measured, _ in soft_capture_rows(rows)}


def test_shares_times_and_capture_are_counted_as_the_paper_defines_them():
    rows = [
        _run(0, [0.05]),
        _run(1, [0.05, 0.1]),
        _run(5, [0.05, 0.1, 0.1, 0.1, 0.1, 0.3]),
        _run(0, [0.05], accepted=False, captured=False),  # rejected by the checker
        _run(0, [0.05], captured=True, after=True),
        _run(0, [9.9], status="failed"),  # not an ok run: not counted
    ]
    table = _table(rows)
    assert table["initial plans accepted (planner + checker)"] == "80.0% (4/5)"
    assert table["solved by Problem 2 alone"] == "50.0% (2/4)"
    assert table["<= 1 SCP iteration"] == "75.0% (3/4)"
    assert table["<= 5 SCP iterations"] == "100.0% (4/4)"
    # Iterations: 0.1 (run 2) and 0.1, 0.1, 0.1, 0.1, 0.3 (run 3): mean 0.8 / 6.
    assert table["time per SCP iteration (mean)"] == f"{0.8 / 6:.3f} s (n = 6)"
    # After one iteration: 0.15 for both runs that needed one or more; after five: run 3 only.
    assert table["cumulative after 1 SCP iteration (mean)"] == "0.150 s (n = 2)"
    assert table["cumulative after 5 SCP iterations (mean)"] == "0.750 s (n = 1)"
    assert table["plans checked by the independent checker (all calls)"] == "9, 1 rejected"
    assert table["closed-loop capture"] == "80.0% (4/5)"
    assert table["contact after a capture"] == "25.0% (1/4)"
    assert table["capture failed: contact"] == "1"


def test_campaigns_without_planner_records_get_no_section():
    rows = [{"status": "ok", "metrics": {"hold_reached": True}, "grp": "all", "reason": None}]
    assert soft_capture_rows(rows) is None
    text = summary_text({"campaign_name": "c", "base_name": "hold_point"}, rows, ["hold_reached"])
    assert "paper 000" not in text


def test_the_report_text_carries_the_section():
    text = summary_text({"campaign_name": "c", "base_name": "soft_capture"}, [_run(1, [0.05, 0.1])],
                        ["capture_success"])  # fmt: skip
    assert "Soft capture beside paper 000" in text
    assert "93.2%" in text and "0.336 s" in text


@pytest.mark.parametrize("steps", [[], None])
def test_plans_without_step_times_do_not_break_the_table(steps):
    run = _run(1, [0.05, 0.1])
    run["metrics"]["plans"][0]["step_time_s"] = steps
    table = _table([run])
    assert table["time per SCP iteration (mean)"] == "--"
