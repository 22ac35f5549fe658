"""`rpod sweep` on this machine (Dask LocalCluster), through the real console entry point.

Each test drives the CLI in a subprocess, so exit status, stderr and the process tree are what
a user gets. Processes are started in their own session and killed with their group at
teardown (conftest.spawn).
"""

import json
import os
import re
import signal
import sqlite3

import numpy as np
import pytest
from campaign_helpers import (
    DETERMINISTIC,
    SLOW_CAMPAIGN,
    assert_same_metric,
    group_gone,
    rpod_command,
    run_rpod,
    run_rpod_in_process,
    store_counts,
    wait_until,
)

from rpod.diagrams.simulate import simulate
from rpod.scenarios.campaign import apply_overrides, load_campaign, plan_runs
from rpod.scenarios.store import ResultStore, same_base


def stored_rows(out):
    with ResultStore.open_existing(out) as store:
        return store.rows()


def test_local_run_stores_every_run(small_campaign_local):
    campaign_file, out, process = small_campaign_local
    campaign = load_campaign(str(campaign_file))
    planned = plan_runs(campaign)
    rows = stored_rows(out)
    assert [r["run_id"] for r in rows] == [r.run_id for r in planned]  # every run, once
    assert all(r["status"] == "ok" and r["reason"] is None for r in rows)
    # The progress line ends with the totals; the summary line names the store.
    assert "8/8 done, 0 failed, 0 left" in process.stderr.strip().splitlines()[-1]
    assert "8 runs: 8 ok, 0 failed, 0 pending (8 run now)" in process.stdout
    # Each stored summary is the run's own: the same scenario simulated here gives the same
    # numbers. Same code and inputs on one machine give bit-identical IEEE results; 1e-12 only
    # leaves room for a different libm if the workers ran elsewhere.
    for row, run in zip(rows, planned):
        expected = simulate(apply_overrides(campaign.base, run.overrides)).summary
        for key in DETERMINISTIC:
            assert_same_metric(row["metrics"][key], expected[key], key)
        assert row["overrides"] == run.overrides and row["grp"] == run.group


def test_rerun_runs_nothing_and_duplicates_nothing(small_campaign_local, tmp_path):
    campaign_file, out, _ = small_campaign_local
    before = stored_rows(out)
    process = run_rpod(
        "sweep", str(campaign_file), "--out", str(out), "--workers", "1", cwd=tmp_path
    )
    assert process.returncode == 0, process.stderr
    assert "(0 run now)" in process.stdout
    assert stored_rows(out) == before  # same rows, same finish times: nothing ran again


def test_rerun_with_another_plan_into_the_same_folder_is_refused(small_campaign_local, tmp_path):
    campaign_file, out, _ = small_campaign_local
    before = stored_rows(out)
    process = run_rpod("sweep", str(campaign_file), "--out", str(out), "--seed", "99", cwd=tmp_path)
    assert process.returncode == 2
    lines = process.stderr.strip().splitlines()
    assert len(lines) == 1 and "different plan" in lines[0] and "--out" in lines[0], lines
    assert stored_rows(out) == before


def test_report_prints_groups_and_writes_plots(small_campaign_local, tmp_path):
    _, out, _ = small_campaign_local
    report_dir = tmp_path / "report"
    process = run_rpod_in_process("report", str(out), "--out", str(report_dir), cwd=tmp_path)
    assert process.returncode == 0, process.stderr
    rows = stored_rows(out)
    groups = sorted({r["grp"] for r in rows})
    table = process.stdout
    for group in groups:
        # A coast has no mission to judge; nothing touched, nothing failed, nothing pending.
        line = next(l for l in table.splitlines() if l.startswith(group + " ") and "%" in l)
        assert "no runs judged" in line and line.split()[-5:] == ["0", "(0.0", "%)", "0", "0"]
        # The median printed for final_range_m is the median of the stored values (4 digits).
        values = [r["metrics"]["final_range_m"] for r in rows if r["grp"] == group]
        metric_line = next(
            l for l in table.splitlines() if l.startswith(group + " ") and " final_range_m " in l
        )
        assert float(metric_line.split()[-3]) == pytest.approx(np.median(values), rel=1e-3)
    names = {p.name for p in report_dir.iterdir()}
    assert {
        "report.md",
        "hist_final_range_m.png",
        "map_final_range_m.png",
    } <= names  # 2-parameter grid: 2-D maps
    assert "map_mission_success.png" not in names  # no mission, no map of it
    assert (report_dir / "map_final_range_m.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_report_of_a_missing_folder_exits_2(tmp_path):
    process = run_rpod_in_process("report", str(tmp_path / "nothing"), cwd=tmp_path, timeout=120)
    assert process.returncode == 2
    assert len(process.stderr.strip().splitlines()) == 1 and "no results store" in process.stderr


FAULTS_CAMPAIGN = """\
base: coast
overrides: {duration_s: 20.0, log_period_s: 5.0}
cases:
  - {name: good1, overrides: {chaser.mass_kg: 400.0}}
  - {name: boom, overrides: {chaser.mass_kg: 410.0}}
  - {name: stuck, overrides: {chaser.mass_kg: 420.0}}
  - {name: segv, overrides: {chaser.mass_kg: 430.0}}
  - {name: killer, overrides: {chaser.mass_kg: 440.0}}
  - {name: good2, overrides: {chaser.mass_kg: 450.0}}
"""


def test_failed_runs_are_recorded_with_their_reasons_and_the_campaign_goes_on(tmp_path):
    """raise / hang past the timeout / kill the run process / kill the worker process.

    The faults are injected by the worker harness's test hook (harness.FAULTS_ENV), by case name.
    """
    campaign = tmp_path / "faults.yaml"
    campaign.write_text(FAULTS_CAMPAIGN)
    env = dict(
        os.environ, RPOD_CAMPAIGN_FAULTS="raise:boom,hang:stuck,crash:segv,kill_worker:killer"
    )
    process = run_rpod(
        "sweep",
        str(campaign),
        "--out",
        str(tmp_path / "out"),
        "--workers",
        "2",
        "--timeout-s",  # ample for the good runs, which also write plots (--save-runs)
        "10",
        "--save-runs",
        cwd=tmp_path,
        env=env,
    )
    assert process.returncode == 1, process.stderr  # all recorded, some failed
    rows = {r["case_name"]: r for r in stored_rows(tmp_path / "out")}
    assert rows["good1"]["status"] == rows["good2"]["status"] == "ok"
    assert rows["boom"]["status"] == "failed"
    assert rows["boom"]["reason"].startswith("error: RuntimeError: injected fault")
    assert "Traceback" in rows["boom"]["detail"]
    assert rows["stuck"]["reason"] == "timeout: no result within 10 s (run process killed)"
    assert rows["segv"]["reason"] == "crashed: the run process killed by signal SIGKILL"
    assert rows["killer"]["reason"].startswith("worker died:")
    assert all(rows[c]["metrics"] is None for c in ("boom", "stuck", "segv", "killer"))
    # --save-runs: the ok runs wrote their outputs, the failed ones left nothing.
    runs_dir = tmp_path / "out" / "runs"
    assert {p.name for p in runs_dir.iterdir()} == {
        rows["good1"]["run_id"],
        rows["good2"]["run_id"],
    }
    summary = json.loads((runs_dir / rows["good1"]["run_id"] / "summary.json").read_text())
    assert summary["final_p_LC_L"] == rows["good1"]["metrics"]["final_p_LC_L"]


def _driver(spawn, campaign, out, tmp_path):
    return spawn(
        rpod_command("sweep", str(campaign), "--out", str(out), "--workers", "2"),
        cwd=tmp_path,
        stdout=open(tmp_path / "driver.out", "w"),
        stderr=open(tmp_path / "driver.err", "w"),
    )


def test_sigkill_of_the_driver_then_rerun_loses_and_duplicates_nothing(
    sweep_killed_mid_campaign, tmp_path
):
    """The sweep killed (`kill -9` of the driver alone, its workers and runners exited by
    themselves: conftest.sweep_killed_mid_campaign, shared with test_store_readonly), then
    swept again into its folder."""
    campaign, out = sweep_killed_mid_campaign()
    store = out / "results.sqlite"
    counts = store_counts(store)
    assert counts["pending"] > 0, counts  # it really was mid-campaign
    finished_before = [r for r in stored_rows(out) if r["status"] != "pending"]

    process = run_rpod("sweep", str(campaign), "--out", str(out), "--workers", "2", cwd=tmp_path)
    assert process.returncode == 0, process.stderr
    assert f"({counts['pending']} run now)" in process.stdout  # only the unfinished ones ran
    rows = stored_rows(out)
    planned = [r.run_id for r in plan_runs(load_campaign(str(campaign)))]
    assert sorted(r["run_id"] for r in rows) == sorted(planned)  # none lost, none duplicated
    assert all(r["status"] == "ok" for r in rows)
    by_id = {r["run_id"]: r for r in rows}
    for row in finished_before:  # recorded before the kill: kept exactly as they were
        assert by_id[row["run_id"]] == row
    connection = sqlite3.connect(store)
    assert connection.execute("PRAGMA integrity_check").fetchone() == ("ok",)
    connection.close()


def test_ctrl_c_stops_cleanly_and_keeps_what_finished(spawn, tmp_path):
    campaign = tmp_path / "slow.yaml"
    campaign.write_text(SLOW_CAMPAIGN)
    out = tmp_path / "out"
    driver = _driver(spawn, campaign, out, tmp_path)
    wait_until(lambda: store_counts(out / "results.sqlite")["ok"] >= 1, 240, "a finished run")
    os.killpg(driver.pid, signal.SIGINT)  # what a terminal's Ctrl-C does: the whole group
    assert driver.wait(timeout=60) == 130
    error = (tmp_path / "driver.err").read_text()
    assert "interrupted; finished runs are kept" in error and "Traceback" not in error, error
    counts = store_counts(out / "results.sqlite")
    assert counts["ok"] >= 1 and counts["pending"] > 0 and counts["failed"] == 0, counts
    assert counts["ok"] + counts["pending"] == 10
    finished = re.search(r"(\d+) ok, 0 failed, (\d+) pending", error)
    assert finished and int(finished.group(1)) == counts["ok"]  # what it said is what it kept
    wait_until(lambda: group_gone(driver.pid), 60, "the workers to exit")  # nothing left over


def test_reuse_records_the_runs_another_store_finished_and_flies_the_rest(
    small_campaign_local, tmp_path
):
    campaign_file, out, _ = small_campaign_local
    before = {row["run_id"]: row for row in stored_rows(out)}
    # The same campaign with one grid value changed: half its runs are the small campaign's.
    extended = tmp_path / "extended.yaml"
    extended.write_text(campaign_file.read_text().replace("-100.0]", "-120.0]"))
    new_out = tmp_path / "extended_out"
    process = run_rpod(
        "sweep",
        str(extended),
        "--out",
        str(new_out),
        "--reuse",
        str(out),
        "--workers",
        "1",
        cwd=tmp_path,
    )
    assert process.returncode == 0, process.stderr
    assert f"4 finished runs reused from {out}" in process.stderr
    assert "(4 run now)" in process.stdout
    rows = stored_rows(new_out)
    reused = [row for row in rows if row["run_id"] in before]
    assert len(reused) == 4 and len(rows) == 8
    with ResultStore.open_existing(out) as first, ResultStore.open_existing(new_out) as second:
        assert same_base(first.meta(), second.meta())  # the same base: starts may pair
    for row in reused:
        assert row["worker"] == f"reused from {out}"
        assert row["metrics"] == before[row["run_id"]]["metrics"]
    assert all(
        r["status"] == "ok" and not r["worker"].startswith("reused")
        for r in rows
        if r["run_id"] not in before
    )


def test_reuse_of_a_folder_without_a_store_is_one_line_and_exit_2(small_campaign_local, tmp_path):
    campaign_file, _, _ = small_campaign_local
    process = run_rpod(
        "sweep",
        str(campaign_file),
        "--out",
        str(tmp_path / "o"),
        "--reuse",
        str(tmp_path),
        cwd=tmp_path,
    )
    assert process.returncode == 2
    lines = process.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("rpod: error: --reuse:"), lines
    assert not (tmp_path / "o").exists()
