"""Fixtures of the campaign tests: processes in their own sessions, killed with their group at
teardown whatever the outcome; a real Dask cluster on 127.0.0.1; the small campaign run once;
a sweep whose driver was SIGKILLed mid-campaign, once; both shared by the xdist workers and
handed out as copies.
Every wait has a bounded timeout.
"""

import contextlib
import io
import os
import shutil
import signal
import subprocess

import pytest
from campaign_helpers import (
    SLOW_COAST_CAMPAIGN,
    SMALL_CAMPAIGN,
    DaskCluster,
    group_gone,
    kill_group,
    run_rpod,
    start_detached_sweep,
    store_counts,
    wait_until,
)

from rpod.scenarios import cli


@pytest.fixture
def spawn():
    """Starts processes in their own sessions; kills every group at teardown."""
    started = []

    def start(command, **kwargs) -> subprocess.Popen:
        process = subprocess.Popen(command, start_new_session=True, **kwargs)
        started.append(process)
        return process

    yield start
    for process in reversed(started):
        kill_group(process)


@pytest.fixture
def dask_cluster(spawn, tmp_path):
    """start(workers) -> a DaskCluster on 127.0.0.1, torn down with the test."""
    clusters = []

    def start(workers: int = 2) -> DaskCluster:
        folder = tmp_path / f"cluster{len(clusters)}"
        folder.mkdir()
        cluster = DaskCluster(spawn, folder, workers)
        clusters.append(cluster)
        return cluster

    yield start
    for cluster in clusters:
        for handle in cluster.logs:
            handle.close()


@pytest.fixture(scope="session")
def small_campaign_local(made_once, tmp_path_factory):
    """The small campaign run locally once per session through the CLI (its folder shared by
    the xdist workers: tests/conftest.made_once): (campaign file, output folder, the completed
    process), a copy of them per worker, since some tests sweep into the folder again."""

    def make(folder):
        campaign = folder / "small.yaml"
        campaign.write_text(SMALL_CAMPAIGN)
        process = run_rpod(
            "sweep", str(campaign), "--out", str(folder / "out"), "--workers", "2", cwd=folder
        )
        assert process.returncode == 0, process.stderr
        (folder / "sweep.stdout").write_text(process.stdout)
        (folder / "sweep.stderr").write_text(process.stderr)

    shared = made_once("small_local", make)
    folder = tmp_path_factory.mktemp("small_local")
    shutil.copy2(shared / "small.yaml", folder / "small.yaml")
    shutil.copytree(shared / "out", folder / "out")  # bytes and mtimes
    process = subprocess.CompletedProcess(
        ["rpod", "sweep"],
        0,
        (shared / "sweep.stdout").read_text(),
        (shared / "sweep.stderr").read_text(),
    )
    return folder / "small.yaml", folder / "out", process


@pytest.fixture(scope="session")
def soft_capture_flown(made_once) -> tuple:
    """`rpod run soft_capture` of the bundled scenario, once per session (shared by the xdist
    workers: tests/conftest.made_once): (its output folder, what it printed, its exit status).
    Read it, never change it."""

    def make(folder):
        stdout = io.StringIO()
        with contextlib.redirect_stdout(stdout):
            code = cli.main(["run", "soft_capture", "--out", str(folder / "run")])
        (folder / "stdout.txt").write_text(stdout.getvalue())
        (folder / "exit_status.txt").write_text(str(code))

    folder = made_once("soft_capture_run", make)
    stdout = (folder / "stdout.txt").read_text()
    return folder / "run", stdout, int((folder / "exit_status.txt").read_text())


@pytest.fixture(scope="session")
def sweep_killed_mid_campaign(made_once, tmp_path_factory):
    """copy() -> (campaign file, output folder): a fresh copy of one sweep's folder (its store,
    with the results still in its -wal, and every other file) as `kill -9` of the driver left it.

    The sweep (10 coasting runs, 2 local workers) runs once per session (shared by the xdist
    workers: tests/conftest.made_once): its driver alone is SIGKILLed after two finished runs,
    while runs are pending, and its workers and runners notice the driver is gone and exit by
    themselves. Each test gets its own copy, so one can sweep into it again and another can
    check that a report changes none of its bytes.
    """

    def make(folder):
        out = folder / "out"
        store = out / "results.sqlite"
        args = ("--out", str(out), "--workers", "2")
        driver = start_detached_sweep(folder, SLOW_COAST_CAMPAIGN, *args, name="slow")
        try:
            wait_until(lambda: store_counts(store)["ok"] >= 2, 240, "two finished runs")
            os.kill(driver.pid, signal.SIGKILL)  # the driver only, as `kill -9 PID` would
            driver.wait(timeout=30)
            wait_until(lambda: group_gone(driver.pid), 60, "the killed driver's workers to exit")
        finally:
            kill_group(driver)
        counts = store_counts(store)
        assert counts["pending"] > 0, counts  # it really was mid-campaign

    shared = made_once("killed_sweep", make)

    def copy():
        destination = tmp_path_factory.mktemp("killed_sweep_copy")
        shutil.copy2(shared / "slow.yaml", destination / "slow.yaml")
        shutil.copytree(shared / "out", destination / "out")  # bytes and mtimes, -wal, -shm
        return destination / "slow.yaml", destination / "out"

    return copy
