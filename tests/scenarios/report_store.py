"""A small results store with what a real campaign stores: mission verdicts (success, failure,
none), contact, nested summary blocks, vectors, a failed simulation, a pending run and a
whole-config override; shared by the tests of the run tables and of the HTML report."""

import pathlib

from rpod.scenarios.campaign import PlannedRun
from rpod.scenarios.store import STORE_NAME, ResultStore

META = {"campaign_name": "fake", "base_name": "coast", "grid": {}}


def summary(i: int, success: bool | None, contact: bool = False) -> dict:
    """A run's summary as simulate writes it (the parts the tables read)."""
    outcome = "captured" if success else "NOT captured: position"
    return {
        "status": "ok",
        "delta_v_m_s": 1.5 + 0.1 * i,
        "final_p_LC_L": [float(i), -2.0, 0.25],
        "clipped_command_samples": i,
        "hold_reached": bool(i % 2),
        "planner_status": "success",
        "capture": {"success": success, "time_s": 40.0 + i},
        "mission": {"success": success, "outcome": outcome, "criterion": "capture"},
        "contact": {"occurred": contact, "max_depth_m": 0.01 if contact else 0.0},
        "solves_by_status": {"QP: maximum iterations reached": 2},  # keyed by data
        "plan_records": [{"t_s": 0.0, "N": 50}],  # records: not a column
    }


def make_store(folder: pathlib.Path) -> pathlib.Path:
    """Seven runs: 0-2 succeed, 3 fails its mission with contact, 4 has no verdict, 5's
    simulation failed, 6 is pending. Returns the folder."""
    folder.mkdir(parents=True, exist_ok=True)
    runs = []
    for i in range(7):
        overrides = {"target.w_IT_T_deg_s": [0.0, 1.0 + i, 0.0], "chaser.mass_kg": 300.0 + i}
        if i == 0:
            overrides["controller"] = {"!tag": "HoldPoint", "hold_distance_m": 10.0}
        runs.append(PlannedRun(f"{i:016x}", i, f"g{i % 2}", "case", {}, i, overrides))
    with ResultStore(folder / STORE_NAME) as store:
        store.write_plan(META, runs)
        verdicts = [True, True, True, False, None]
        for i, verdict in enumerate(verdicts):
            metrics = summary(i, verdict, contact=i == 3)
            store.record(runs[i].run_id, {"status": "ok", "metrics": metrics, "wall_time_s": 0.5})
        store.record(
            runs[5].run_id,
            {"status": "failed", "reason": "timeout after 600 s", "wall_time_s": 600.0},
        )
    return folder
