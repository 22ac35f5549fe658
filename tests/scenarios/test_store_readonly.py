"""Reading a results store never writes it, and a damaged store is one line (exit 2).

`rpod report` opens results.sqlite read-only (store.py: `mode=ro` when a -wal file holds
committed results, else `immutable=1`). These tests check the file's bytes and mtime before and
after, on a store whose sweep finished, on one whose driver was SIGKILLed mid-sweep (results
still in the -wal), and on empty, truncated, garbage and partly damaged files, which `report`
and `sweep` both refuse with one line.
"""

import sqlite3

import pytest
from campaign_helpers import SMALL_CAMPAIGN, store_counts
from campaign_helpers import run_rpod_in_process as run_rpod

from rpod.scenarios.campaign import PlannedRun
from rpod.scenarios.loader import ScenarioFileError
from rpod.scenarios.report import read_results
from rpod.scenarios.store import STORE_NAME, ResultStore


def make_store(folder, count: int = 300):
    """A store of `count` finished fake runs (about 50 pages), written and closed cleanly."""
    folder.mkdir(parents=True, exist_ok=True)
    runs = [
        PlannedRun(f"{i:016x}", i, f"g{i % 3}", "", {"x": i}, None, {"chaser.mass_kg": 300.0 + i})
        for i in range(count)
    ]
    with ResultStore(folder / STORE_NAME) as store:
        store.write_plan({"campaign_name": "fake", "base_name": "coast", "grid": {}}, runs)
        for i, run in enumerate(runs):
            failed = i % 7 == 0
            store.record(
                run.run_id,
                {
                    "status": "failed" if failed else "ok",
                    "reason": "error: RuntimeError: x" if failed else None,
                    "metrics": {"final_range_m": float(i), "padding": "x" * 400},
                    "wall_time_s": 0.1,
                    "worker": "w",
                },
            )
    return folder / STORE_NAME


def snapshot(folder) -> dict:
    """Every file of a folder with its bytes and mtime."""
    return {
        path.name: (path.read_bytes(), path.stat().st_mtime_ns)
        for path in sorted(folder.iterdir())
        if path.is_file()
    }


def assert_one_line_error(process, *must_contain):
    assert process.returncode == 2, (process.returncode, process.stderr)
    lines = process.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in process.stderr, process.stderr
    assert lines[0].startswith("rpod: error: "), lines
    for text in must_contain:
        assert text in lines[0], lines[0]


# ------------------------------------------------------------------------------ the API


def test_reading_a_clean_store_changes_nothing_and_makes_no_wal(tmp_path):
    make_store(tmp_path / "out")
    before = snapshot(tmp_path / "out")
    assert list(before) == [STORE_NAME]  # closed cleanly: the WAL was checkpointed away
    meta, rows = read_results(tmp_path / "out")
    assert meta["campaign_name"] == "fake" and len(rows) == 300
    assert [r["status"] for r in rows].count("failed") == 43
    assert snapshot(tmp_path / "out") == before  # same files, same bytes, same mtimes


def test_reader_sees_results_still_in_the_wal_and_leaves_the_file_alone(tmp_path):
    store_file = make_store(tmp_path / "out", count=20)
    writer = ResultStore(store_file)  # a running sweep: its results are in the -wal
    try:
        with writer._connection:
            writer._connection.execute("UPDATE runs SET status = 'pending' WHERE plan_index = 3")
        assert writer.record(f"{3:016x}", {"status": "ok", "metrics": {"final_range_m": -1.0}})
        assert (tmp_path / "out" / f"{STORE_NAME}-wal").stat().st_size > 0
        before = store_file.read_bytes(), store_file.stat().st_mtime_ns
        _, rows = read_results(tmp_path / "out")
        assert rows[3]["metrics"] == {"final_range_m": -1.0}  # read from the WAL
        assert (store_file.read_bytes(), store_file.stat().st_mtime_ns) == before
    finally:
        writer.close()


def test_a_read_only_store_notices_a_writer_that_came_meanwhile(tmp_path):
    store_file = make_store(tmp_path / "out", count=5)
    with ResultStore.open_existing(tmp_path / "out") as reader:  # immutable: no -wal there
        assert not reader.changed()
        with ResultStore(store_file) as writer:
            writer.retry_failed()
            assert reader.changed()  # so read_results reads again, through the WAL
    with ResultStore.open_existing(tmp_path / "out", use_wal=True) as reader:
        assert reader.counts()["failed"] == 0


def test_retry_failed_sets_failures_back_to_pending_and_keeps_them(tmp_path):
    store_file = make_store(tmp_path / "out", count=14)
    with ResultStore(store_file) as store:
        failed = {r["run_id"]: r for r in store.rows() if r["status"] == "failed"}
        assert store.retry_failed() == len(failed) == 2
        assert store.counts() == {"pending": 2, "ok": 12, "failed": 0}
        assert set(store.pending_ids()) == set(failed)
        kept = store._connection.execute("SELECT run_id, reason, worker FROM retries").fetchall()
    assert sorted(kept) == sorted((i, r["reason"], r["worker"]) for i, r in failed.items())


def damage_empty(path):
    path.write_bytes(b"")


def damage_truncated(path):
    with open(path, "r+b") as handle:
        handle.truncate(path.stat().st_size // 2)


def damage_garbage(path):
    path.write_bytes(bytes((i * 7919 + 13) % 251 for i in range(path.stat().st_size)))


def damage_a_page(path):
    """Overwrites a leaf page of the runs table in the middle of the file."""
    connection = sqlite3.connect(f"{path.resolve().as_uri()}?immutable=1", uri=True)
    page_size = connection.execute("PRAGMA page_size").fetchone()[0]
    page_count = connection.execute("PRAGMA page_count").fetchone()[0]
    leaves = [
        page
        for (page,) in connection.execute(
            "SELECT pageno FROM dbstat WHERE name = 'runs' AND pagetype = 'leaf' ORDER BY pageno"
        )
    ]
    connection.close()
    page = leaves[len(leaves) // 2]
    assert 1 < page < page_count  # mid-file
    with open(path, "r+b") as handle:
        handle.seek((page - 1) * page_size)
        handle.write(b"\xff" * page_size)


DAMAGES = [damage_empty, damage_truncated, damage_garbage, damage_a_page]


@pytest.mark.parametrize("damage", DAMAGES, ids=[d.__name__ for d in DAMAGES])
def test_damaged_store_is_a_one_line_error_in_the_api(tmp_path, damage):
    store_file = make_store(tmp_path / "out")
    damage(store_file)
    before = snapshot(tmp_path / "out")
    with pytest.raises(ScenarioFileError) as error:
        read_results(tmp_path / "out")
    assert str(error.value).startswith(f"{store_file}: ") and "\n" not in str(error.value)
    with pytest.raises(ScenarioFileError):
        ResultStore.check_compatible(store_file, "some plan", 1)
    assert snapshot(tmp_path / "out") == before


# ------------------------------------------------------------------------------ the CLI


@pytest.mark.parametrize("damage", DAMAGES, ids=[d.__name__ for d in DAMAGES])
def test_report_and_sweep_refuse_a_damaged_store_and_leave_it_as_it_is(tmp_path, damage):
    store_file = make_store(tmp_path / "out")
    damage(store_file)
    before = snapshot(tmp_path / "out")
    report = run_rpod(
        "report", str(tmp_path / "out"), "--out", str(tmp_path / "plots"), cwd=tmp_path
    )
    assert_one_line_error(report, str(store_file))
    campaign = tmp_path / "small.yaml"
    campaign.write_text(SMALL_CAMPAIGN)
    sweep = run_rpod("sweep", str(campaign), "--out", str(tmp_path / "out"), cwd=tmp_path)
    assert_one_line_error(sweep, str(store_file))
    assert snapshot(tmp_path / "out") == before  # no schema, no lock file, no -wal
    assert not (tmp_path / "plots").exists()
    if damage is damage_empty:
        assert store_file.stat().st_size == 0  # an empty file stays empty


def test_report_of_a_finished_sweep_changes_nothing(small_campaign_local, tmp_path):
    _, out, _ = small_campaign_local
    before = snapshot(out)
    process = run_rpod("report", str(out), "--out", str(tmp_path / "report"), cwd=tmp_path)
    assert process.returncode == 0, process.stderr
    assert "8 runs" in process.stdout
    assert snapshot(out) == before  # results.sqlite's bytes and mtime; no -wal or -shm made


def test_report_of_a_sweep_killed_mid_campaign_reads_the_wal_and_changes_nothing(
    sweep_killed_mid_campaign, tmp_path
):
    """The folder as `kill -9` of the driver left it after two finished runs (a copy of the
    session's: conftest.sweep_killed_mid_campaign, shared with test_sweep_local)."""
    _, out = sweep_killed_mid_campaign()
    store_file = out / STORE_NAME
    counts = store_counts(store_file)
    assert counts["pending"] > 0 and (out / f"{STORE_NAME}-wal").exists(), counts
    before = store_file.read_bytes(), store_file.stat().st_mtime_ns
    process = run_rpod("report", str(out), "--out", str(tmp_path / "report"), cwd=tmp_path)
    assert process.returncode == 0, process.stderr
    assert "Campaign slow: 10 runs" in process.stdout
    groups_table = process.stdout.split("Metrics over")[0]  # the group table comes first
    group_lines = [line for line in groups_table.splitlines() if line.startswith("chaser.")]
    # One run a group: the finished ones (read through the WAL) have no run pending.
    finished = counts["ok"] + counts["failed"]
    assert sum(line.split()[-1] == "0" for line in group_lines) == finished, group_lines
    assert (store_file.read_bytes(), store_file.stat().st_mtime_ns) == before


def test_report_of_an_empty_file_exits_2_and_keeps_it_empty(tmp_path):
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / STORE_NAME).write_bytes(b"")
    process = run_rpod("report", str(tmp_path / "out"), cwd=tmp_path)
    assert_one_line_error(process, "not a results store")
    assert [p.name for p in (tmp_path / "out").iterdir()] == [STORE_NAME]
    assert (tmp_path / "out" / STORE_NAME).stat().st_size == 0


@pytest.mark.parametrize(
    "out, message",
    [
        ("afile.txt", "is not a folder"),
        ("afile.txt/plots", "afile.txt is not a folder"),
        ("/proc/rpod-test/plots", "cannot create the folder"),
    ],
    ids=["a_file", "under_a_file", "proc"],
)
def test_report_out_that_cannot_be_a_folder_exits_2(tmp_path, out, message):
    make_store(tmp_path / "results", count=10)
    (tmp_path / "afile.txt").write_text("keep me")
    before = snapshot(tmp_path)
    process = run_rpod("report", str(tmp_path / "results"), "--out", out, cwd=tmp_path)
    assert_one_line_error(process, f"--out {out}: ", message)
    assert snapshot(tmp_path) == before and (tmp_path / "afile.txt").read_text() == "keep me"
    assert sorted(p.name for p in (tmp_path / "results").iterdir()) == [STORE_NAME]
