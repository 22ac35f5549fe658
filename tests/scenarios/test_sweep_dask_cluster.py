"""`rpod sweep --scheduler`: a real Dask scheduler and workers, each a separate process on
127.0.0.1 started by the test (conftest.dask_cluster), killed with their process groups at
teardown.
"""

import os
import signal
import socket

from campaign_helpers import (
    DETERMINISTIC,
    SLOW_CAMPAIGN,
    assert_same_metric,
    rpod_command,
    run_rpod,
    store_counts,
    wait_until,
)

from rpod.scenarios.campaign import load_campaign, plan_runs
from rpod.scenarios.store import ResultStore


def stored(out) -> dict:
    with ResultStore.open_existing(out) as store:
        return {row["run_id"]: row for row in store.rows()}


def test_scheduler_run_gives_the_same_results_as_the_local_run(
    dask_cluster, small_campaign_local, tmp_path
):
    cluster = dask_cluster(workers=2)
    campaign_file, local_out, _ = small_campaign_local
    out = tmp_path / "out"
    process = run_rpod(
        "sweep", str(campaign_file), "--out", str(out), "--scheduler", cluster.address, cwd=tmp_path
    )
    assert process.returncode == 0, process.stderr
    remote, local = stored(out), stored(local_out)
    assert remote.keys() == local.keys()  # the same runs (ids) ...
    for run_id, row in remote.items():
        assert row["status"] == local[run_id]["status"] == "ok"
        assert row["worker"].startswith(cluster.address.rsplit(":", 1)[0])  # ran on the cluster
        # ... with the same results. Same code and inputs on this machine: bit-identical; the
        # 1e-12 only allows for a different libm on a remote worker.
        for key in DETERMINISTIC:
            assert_same_metric(row["metrics"][key], local[run_id]["metrics"][key], key)


def test_killing_a_worker_mid_campaign_loses_no_run(dask_cluster, spawn, tmp_path):
    cluster = dask_cluster(workers=2)
    campaign = tmp_path / "slow.yaml"
    campaign.write_text(SLOW_CAMPAIGN)
    out = tmp_path / "out"
    with open(tmp_path / "driver.out", "w") as stdout, open(tmp_path / "driver.err", "w") as err:
        driver = spawn(
            rpod_command("sweep", str(campaign), "--out", str(out), "--scheduler", cluster.address),
            cwd=tmp_path,
            stdout=stdout,
            stderr=err,
        )  # the driver holds its own copies of the two files
    wait_until(lambda: store_counts(out / "results.sqlite")["ok"] >= 2, 240, "two finished runs")
    os.killpg(cluster.workers[0].pid, signal.SIGKILL)  # the worker, its nanny and its runner
    assert store_counts(out / "results.sqlite")["pending"] > 0  # it really was mid-campaign
    assert driver.wait(timeout=300) == 0, (tmp_path / "driver.err").read_text()
    rows = stored(out)
    planned = {r.run_id for r in plan_runs(load_campaign(str(campaign)))}
    assert rows.keys() == planned  # every run accounted for ...
    # ... and finished: one worker death is within Dask's allowed-failures, so the runs the
    # dead worker held were rescheduled on the other worker.
    assert all(row["status"] == "ok" for row in rows.values()), [
        row["reason"] for row in rows.values()
    ]


def test_unreachable_scheduler_exits_2_and_starts_nothing(tmp_path):
    with socket.socket() as probe:  # a port on 127.0.0.1 where nothing listens
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    campaign = tmp_path / "slow.yaml"
    campaign.write_text(SLOW_CAMPAIGN)
    process = run_rpod(
        "sweep",
        str(campaign),
        "--out",
        str(tmp_path / "out"),
        "--scheduler",
        f"tcp://127.0.0.1:{port}",
        "--connect-timeout-s",
        "2",
        cwd=tmp_path,
        timeout=120,
    )
    assert process.returncode == 2
    lines = process.stderr.strip().splitlines()
    assert len(lines) == 1, lines
    assert lines[0].startswith(f"rpod: error: --scheduler tcp://127.0.0.1:{port}: "), lines
    assert sorted(p.name for p in tmp_path.iterdir()) == ["slow.yaml"]  # nothing started
