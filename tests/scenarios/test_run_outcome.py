"""What a user reads first (issue 9): the line `rpod run` prints and summary.json say whether the
mission succeeded, apart from whether the simulation ran; a controller can end the run at its
planned end, and a plan that outlasts the run is a warning.

Each case is a real soft-capture run of the bundled scenario, cut short or moved; each takes a
few seconds.
"""

import json

import pytest

from rpod.scenarios import cli
from rpod.scenarios.loader import bundled_scenarios


def _scenario(tmp_path, replacements: dict, name="case.yaml"):
    text = bundled_scenarios()["soft_capture"].read_text()
    for old, new in replacements.items():
        assert old in text
        text = text.replace(old, new)
    path = tmp_path / name
    path.write_text(text)
    return path


def _run(tmp_path, path, capsys):
    out = tmp_path / "out"
    code = cli.main(["run", str(path), "--out", str(out), "--no-record", "--no-plots"])
    captured = capsys.readouterr()
    return code, json.loads((out / "summary.json").read_text()), captured


def test_a_missed_capture_says_so_and_exits_3(tmp_path, capsys):
    """30 s of a 49 s plan: the run is fine, the mission is not (and the plan outlasts it)."""
    path = _scenario(tmp_path, {"duration_s: 70.0": "duration_s: 30.0"})
    code, summary, captured = _run(tmp_path, path, capsys)
    assert code == cli.EXIT_MISSION_FAILED == 3
    assert summary["status"] == "ok"  # the simulation ran
    assert summary["plots"] == [] and not (tmp_path / "out" / "plots").exists()  # --no-plots
    assert summary["mission"]["success"] is False
    assert summary["mission"]["outcome"].startswith("NOT captured: ")
    (line,) = captured.out.strip().splitlines()
    assert line.startswith("case: NOT captured: ")
    assert "the controller's plan ends at 49.0 s, after the run's end at 30.0 s" in captured.err
    assert summary["warnings"] and "raise duration_s" in summary["warnings"][0]


def test_a_capture_says_when_and_how_close(soft_capture_flown):
    """The bundled scenario's run (conftest.soft_capture_flown, shared with
    test_run_soft_capture): the line and the summary."""
    out, stdout, code = soft_capture_flown
    summary = json.loads((out / "summary.json").read_text())
    assert code == 0 and summary["mission"]["success"] is True
    capture = summary["capture"]
    expected = (
        f"captured at {capture['time_s']:.1f} s to {capture['position_error_m']:.3f} m and "
        f"{capture['speed_error_m_s']:.3f} m/s"
    )
    assert summary["mission"]["outcome"] == expected
    assert stdout.startswith(f"soft_capture: {expected}; ")
    # What the top-level planner status is read for: the plan being flown (the initial one
    # here, whose late replans may fail), never a failed late replan's status.
    accepted = [p for p in summary["plans"] if p["accepted"]]
    assert summary["planner_status"] == accepted[-1]["status"] == "success"
    assert summary["last_planner_call_status"] == summary["plans"][-1]["status"]
    # The chaser starts ~20 m away and swings round the target, 80-130 deg off the docking
    # axis; what the plan promises, and what is read, is paper 000's docking cone (eq. 11) over
    # its last N_dock knots: inside it up to the capture.
    start, end = summary["corridor_window_s"]
    assert end == capture["time_s"] and end - start < 5.0
    assert summary["max_corridor_violation_deg"] < 0.0


def test_stop_at_plan_end_ends_the_run_at_the_planned_capture_plus_the_hold(tmp_path, capsys):
    path = _scenario(
        tmp_path,
        {"duration_s: 70.0": "duration_s: 300.0\nstop: {at_plan_end: true, hold_s: 4.0}"},
    )
    code, summary, _ = _run(tmp_path, path, capsys)
    assert code == 0 and summary["mission"]["success"] is True
    assert summary["sim_time_s"] == pytest.approx(summary["capture"]["planned_time_s"] + 4.0)
    assert summary["warnings"] == []
