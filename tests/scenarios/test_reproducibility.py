"""rpod.scenarios.reproducibility: what a run's reproducible record keeps, and that comparing two
flights finds a changed value, names its cell, and does not count one flight twice."""

import copy

from rpod.scenarios.reproducibility import compare_runs, run_record


def _row(run_id: str, index: int, status: str = "ok", flown: str = "2026-12-06T04:00") -> dict:
    summary = {
        "delta_v_m_s": 0.1 + 0.2 * index,  # not exactly representable: compared exactly
        "capture_time_s": 58.72,
        "final_p_LC_L": [1.0 / 3.0, -2.0, 7.5],
        "plans": [{"t_s": 0.0, "solve_time_s": [0.03]}],  # nested: not compared
        "mission": {"success": True, "outcome": "captured  at\n58.7 s"},
        "contact": {"occurred": False, "first_s": None},
        "wall_time_s": 2.05,
        "real_time_factor": 28.6,
        "control_step_ms_p99": 5.07,
        "initial_plan_solve_time_s": 0.098,
        "los_mpc_solve_ms_max": 3.2,
    }
    return {
        "run_id": run_id,
        "grp": "g",
        "case_name": "c",
        "grid_point": {},
        "sample_index": index,
        "overrides": {"chaser.rpy_LC_deg": [-116.42714875354147 + index, 8.35421525570351]},
        "status": status,
        "reason": "boom" if status == "failed" else None,
        "metrics": summary if status == "ok" else None,
        "finished_at": None if status == "pending" else f"{flown}:0{index}",
    }


def test_a_record_keeps_the_flight_and_drops_the_machine():
    record = run_record(_row("a", 0))
    assert record["status"] == "ok" and record["mission_success"] == "true"
    assert record["final_p_LC_L[0]"] == repr(1.0 / 3.0)  # every digit, not printed ones
    assert record["mission.outcome"] == "captured at 58.7 s" and record["contact.first_s"] == ""
    for dropped in (
        "wall_time_s",
        "real_time_factor",
        "control_step_ms_p99",
        "plans",
        "los_mpc_solve_ms_max",
    ):
        assert dropped not in record
    assert not any("solve_time" in key for key in record)
    failed = run_record(_row("b", 1, status="failed"))
    assert failed == {"status": "failed", "mission_success": "false", "reason": "boom"}


def test_two_flights_compare_equal_and_a_changed_value_is_named():
    first = [_row("a", 0), _row("b", 1), _row("c", 2, status="pending"), _row("d", 3)]
    one_flight = compare_runs(copy.deepcopy(first), first)  # reused: not a second flight
    assert (one_flight.compared, one_flight.same_flight) == (0, 3)

    second = [
        _row(r["run_id"], i, r["status"], flown="2026-12-07T01:00") for i, r in enumerate(first)
    ]
    second[3]["metrics"]["wall_time_s"] = 99.0  # the machine changed: not a difference
    same = compare_runs(second, first)
    assert (same.compared, same.same, same.differing, same.same_flight) == (3, 3, {}, 0)

    second[1]["metrics"]["delta_v_m_s"] += 1e-15
    second[1]["metrics"]["final_p_LC_L"] = [1.0 / 3.0, -2.0, 7.25]
    second[2] = _row("c", 2, flown="2026-12-07T01:00")  # finished here, pending there
    del second[0]  # finished there only
    changed = compare_runs(second, first)
    assert changed.compared == 2 and changed.same == 1
    assert changed.differing == {"b": ["delta_v_m_s", "final_p_LC_L[2]"]}
    assert (changed.only_here, changed.only_there) == (1, 1)


def test_a_start_planned_on_another_cpu_is_compared_with_its_counterpart():
    """Its run id differs (the hash of a start whose last bits another CPU's kernels round
    otherwise); it is the same run all the same, and a second flight of it."""
    first = [_row("a", 0), _row("b", 1)]
    second = [_row("a", 0, flown="2026-12-07T01:00"), _row("b-other-cpu", 1, flown="2026-12-07")]
    second[1]["overrides"]["chaser.rpy_LC_deg"][0] = -115.42714875354145  # two ulps away
    result = compare_runs(second, first, by_start=True)  # the two plans share their base
    assert (result.compared, result.same, result.only_here, result.only_there) == (2, 2, 0, 0)
    assert compare_runs(second, first).compared == 1  # another base: ids only
    second[1]["overrides"]["chaser.rpy_LC_deg"][0] = -115.4271  # another start
    result = compare_runs(second, first, by_start=True)
    assert (result.compared, result.only_here, result.only_there) == (1, 1, 1)
