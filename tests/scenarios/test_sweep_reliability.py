"""`rpod sweep` when things go wrong around the runs: the store on disk after a stop, failed runs
retried, a second sweep or a bad --out refused before any cluster starts, a Ctrl-C while the
local cluster starts, and the local cluster's security (TLS, no HTTP server).

Processes run in their own sessions and are killed with their groups at teardown
(conftest.spawn, or the module's `hanging_sweep`, which the tests that only look at a running
sweep share); every wait has a timeout, and no test asserts a duration.
"""

import asyncio
import fcntl
import os
import pathlib
import shutil
import signal
import socket
import sqlite3
import subprocess
import time

import psutil
import pytest
from campaign_helpers import (
    CLI_TIMEOUT_S,
    SLOW_COAST_CAMPAIGN,
    SMALL_CAMPAIGN,
    group_gone,
    kill_group,
    run_rpod,
    start_detached_sweep,
    store_counts,
    wait_until,
)

from rpod.scenarios import sweep
from rpod.scenarios.campaign import load_campaign, plan_runs
from rpod.scenarios.loader import ScenarioFileError
from rpod.scenarios.store import STORE_NAME, ResultStore

# Two runs that never end (the harness's test hook): a sweep that stays up until stopped.
HANG_CAMPAIGN = """\
base: coast
overrides: {duration_s: 20.0, log_period_s: 5.0}
cases:
  - {name: h1, overrides: {chaser.mass_kg: 400.0}}
  - {name: h2, overrides: {chaser.mass_kg: 410.0}}
"""
HANG_ENV = dict(os.environ, RPOD_CAMPAIGN_FAULTS="hang:h1,hang:h2")


def start_sweep(spawn, tmp_path, text, *args, env=None, name="campaign"):
    """`rpod sweep` of the campaign `text` in its own session, killed with the test (spawn);
    its output in NAME.out/.err."""
    return start_detached_sweep(tmp_path, text, *args, env=env, name=name, start=spawn)


@pytest.fixture(scope="module")
def hanging_sweep(tmp_path_factory):
    """(driver, folder, out): one `rpod sweep` of HANG_CAMPAIGN on 2 local workers, both runs
    pending for ever, shared by the tests that only look at a running sweep (a second sweep
    refused, its servers probed); killed with its group at the module's end."""
    folder = tmp_path_factory.mktemp("hanging")
    out = folder / "out"
    driver = start_detached_sweep(
        folder, HANG_CAMPAIGN, "--out", str(out), "--workers", "2", env=HANG_ENV
    )
    try:
        wait_until(lambda: store_counts(out / STORE_NAME)["pending"] == 2, 240, "the sweep to run")
        yield driver, folder, out
    finally:
        kill_group(driver)


def rows_of(results) -> list[dict]:
    with ResultStore.open_existing(results) as store:
        return store.rows()


def one_line_error(process) -> str:
    assert process.returncode == 2, (process.returncode, process.stderr)
    lines = process.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("rpod: error: "), process.stderr
    return lines[0]


# ------------------------------------------------------------------------------ the store on disk


def test_results_sqlite_alone_holds_every_result_after_the_sweep(spawn, tmp_path):
    """A reader open during the sweep (a user's sqlite3) keeps SQLite from checkpointing on
    close; the sweep checkpoints itself, so the file copied alone holds every result."""
    out = tmp_path / "out"
    store_file = out / STORE_NAME
    driver = start_sweep(spawn, tmp_path, SLOW_COAST_CAMPAIGN, "--out", str(out), "--workers", "2")
    wait_until(lambda: sum(store_counts(store_file).values()) == 10, 240, "the plan")
    reader = sqlite3.connect(f"file:{store_file}?mode=ro", uri=True)
    try:
        pending = reader.execute("SELECT COUNT(*) FROM runs WHERE status = 'pending'").fetchone()
        assert pending[0] > 0  # it opened mid-campaign
        assert driver.wait(timeout=CLI_TIMEOUT_S) == 0, (tmp_path / "campaign.err").read_text()
        copy = tmp_path / "copy" / STORE_NAME
        copy.parent.mkdir()
        shutil.copyfile(store_file, copy)  # the one file, not its -wal
    finally:
        reader.close()
    rows = rows_of(copy)
    assert len(rows) == 10 and all(r["status"] == "ok" for r in rows)
    assert rows == rows_of(out)


@pytest.mark.slow  # the family's default member: after the sweep, above
def test_results_sqlite_alone_holds_every_result_after_sigterm(spawn, tmp_path):
    out = tmp_path / "out"
    store_file = out / STORE_NAME
    driver = start_sweep(spawn, tmp_path, SLOW_COAST_CAMPAIGN, "--out", str(out), "--workers", "2")
    wait_until(lambda: sum(store_counts(store_file).values()) == 10, 240, "the plan")
    reader = sqlite3.connect(f"file:{store_file}?mode=ro", uri=True)
    try:
        reader.execute("SELECT COUNT(*) FROM runs").fetchone()
        wait_until(lambda: store_counts(store_file)["ok"] >= 1, 240, "a finished run")
        os.kill(driver.pid, signal.SIGTERM)
        assert driver.wait(timeout=120) == 130
        copy = tmp_path / "copy" / STORE_NAME
        copy.parent.mkdir()
        shutil.copyfile(store_file, copy)
    finally:
        reader.close()
    rows = rows_of(copy)
    assert rows == rows_of(out)  # the copy has every recorded run the folder has
    assert sum(r["status"] == "ok" for r in rows) >= 1
    assert sum(r["status"] == "pending" for r in rows) > 0  # it really was stopped mid-way


# ------------------------------------------------------------------------------ --retry-failed

RETRY_CAMPAIGN = """\
base: coast
overrides: {duration_s: 20.0, log_period_s: 5.0}
cases:
  - {name: good, overrides: {chaser.mass_kg: 400.0}}
  - {name: boom, overrides: {chaser.mass_kg: 410.0}}
"""


def test_retry_failed_runs_the_failed_runs_again_and_keeps_their_old_reason(tmp_path):
    campaign = tmp_path / "retry.yaml"
    campaign.write_text(RETRY_CAMPAIGN)
    out = tmp_path / "out"
    faulty = dict(os.environ, RPOD_CAMPAIGN_FAULTS="raise:boom")
    first = run_rpod(
        "sweep", str(campaign), "--out", str(out), "--workers", "2", cwd=tmp_path, env=faulty
    )
    assert first.returncode == 1, first.stderr
    failed = {r["case_name"]: r for r in rows_of(out)}["boom"]
    assert failed["status"] == "failed"

    again = run_rpod("sweep", str(campaign), "--out", str(out), cwd=tmp_path)
    assert again.returncode == 1 and "(0 run now)" in again.stdout  # resume: not retried

    retried = run_rpod(
        "sweep", str(campaign), "--out", str(out), "--workers", "2", "--retry-failed", cwd=tmp_path
    )
    assert retried.returncode == 0, retried.stderr
    assert "2 runs: 2 ok, 0 failed, 0 pending (1 run now)" in retried.stdout
    rows = {r["case_name"]: r for r in rows_of(out)}
    assert rows["boom"]["status"] == "ok" and rows["boom"]["reason"] is None
    connection = sqlite3.connect(f"file:{out / STORE_NAME}?mode=ro", uri=True)
    kept = connection.execute("SELECT run_id, reason, detail FROM retries").fetchall()
    connection.close()
    assert kept == [(failed["run_id"], failed["reason"], failed["detail"])]
    assert failed["reason"].startswith("error: RuntimeError: injected fault")

    # The plan check still applies: another plan in the same folder is refused.
    campaign.write_text(RETRY_CAMPAIGN.replace("410.0", "420.0"))
    other = run_rpod("sweep", str(campaign), "--out", str(out), "--retry-failed", cwd=tmp_path)
    assert "different plan" in one_line_error(other)


# ------------------------------------------------------------------------------ refused up front


@pytest.fixture
def no_cluster(monkeypatch):
    """run_campaign in this process, with starting or reaching a cluster an error."""

    def refuse(*args, **kwargs):
        raise AssertionError("a cluster was started")

    monkeypatch.setattr(sweep, "_start_local_cluster", refuse)
    monkeypatch.setattr(sweep, "_connect_scheduler", refuse)


def small_plan(tmp_path):
    path = tmp_path / "small.yaml"
    path.write_text(SMALL_CAMPAIGN)
    campaign = load_campaign(str(path))
    return campaign, plan_runs(campaign)


def test_a_locked_folder_is_refused_before_any_cluster(no_cluster, tmp_path):
    campaign, runs = small_plan(tmp_path)
    out = tmp_path / "out"
    out.mkdir()
    with open(out / sweep.LOCK_NAME, "a+") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)  # another driver holds the folder
        with pytest.raises(ScenarioFileError, match="another `rpod sweep` is writing"):
            sweep.run_campaign(campaign, runs, out, workers=1)
    assert [p.name for p in out.iterdir()] == [sweep.LOCK_NAME]


@pytest.mark.parametrize(
    "out, message",
    [
        ("afile.txt", "is not a folder"),
        ("afile.txt/out", "afile.txt is not a folder"),
        ("/proc/rpod-test", "cannot create the folder"),
    ],
    ids=["a_file", "under_a_file", "proc"],
)
def test_an_out_that_cannot_be_a_folder_is_refused_before_any_cluster(
    no_cluster, tmp_path, monkeypatch, out, message
):
    campaign, runs = small_plan(tmp_path)
    (tmp_path / "afile.txt").write_text("keep me")
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ScenarioFileError, match=f"^--out {out}: .*{message}"):
        sweep.run_campaign(campaign, runs, out, workers=1)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["afile.txt", "small.yaml"]


@pytest.mark.parametrize(
    "out, message",
    [
        ("afile.txt", "is not a folder"),
        ("afile.txt/out", "afile.txt is not a folder"),
        ("/proc/rpod-test/out", "cannot create the folder"),
    ],
    ids=["a_file", "under_a_file", "proc"],
)
def test_cli_sweep_out_that_cannot_be_a_folder_exits_2(tmp_path, out, message):
    campaign = tmp_path / "small.yaml"
    campaign.write_text(SMALL_CAMPAIGN)
    (tmp_path / "afile.txt").write_text("keep me")
    process = run_rpod("sweep", str(campaign), "--out", out, cwd=tmp_path)
    line = one_line_error(process)
    assert line.startswith(f"rpod: error: --out {out}: ") and message in line, line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["afile.txt", "small.yaml"]
    assert (tmp_path / "afile.txt").read_text() == "keep me"


def test_a_second_sweep_into_a_busy_folder_is_refused_in_one_line(hanging_sweep):
    first, folder, out = hanging_sweep
    assert (out / STORE_NAME).exists()  # the first sweep's store
    second = run_rpod("sweep", str(folder / "campaign.yaml"), "--out", str(out), cwd=folder)
    assert "another `rpod sweep` is writing to this folder" in one_line_error(second)
    assert first.poll() is None  # the first one goes on


# ------------------------------------------------------------------------------ Ctrl-C at startup


def starting_workers(pid: int) -> list[psutil.Process]:
    """The worker processes (multiprocessing spawns) the driver has started so far."""
    try:
        children = psutil.Process(pid).children(recursive=True)
    except psutil.NoSuchProcess:
        return []
    found = []
    for child in children:
        try:
            if "--multiprocessing-fork" in child.cmdline():
                found.append(child)
        except psutil.Error:
            pass
    return found


# One Ctrl-C and the SIGTERM by default; the Ctrl-C 0.2 s later (the same signal, the same
# assertions) is slow.
@pytest.mark.parametrize(
    "signum, whole_group, delay_s",
    [
        # Ctrl-C once the sweep runs: test_sweep_local.test_ctrl_c_stops_cleanly_and_keeps_...
        pytest.param(signal.SIGINT, True, 0.0, id="ctrl_c_at_first_worker", marks=pytest.mark.slow),
        pytest.param(signal.SIGINT, True, 0.2, id="ctrl_c_soon_after", marks=pytest.mark.slow),
        pytest.param(signal.SIGTERM, False, 0.1, id="sigterm"),
    ],
)
def test_a_stop_while_the_local_cluster_starts_is_honoured(
    spawn, tmp_path, signum, whole_group, delay_s
):
    """The signal arrives as the first worker process starts (before, it was ignored there and
    the sweep ran on, here forever): exit 130, one line, nothing left running."""
    out = tmp_path / "out"
    driver = start_sweep(
        spawn, tmp_path, HANG_CAMPAIGN, "--out", str(out), "--workers", "2", env=HANG_ENV
    )
    wait_until(
        lambda: starting_workers(driver.pid) or driver.poll() is not None,
        240,
        "a worker process",
        poll_s=0.01,
    )
    time.sleep(delay_s)
    if whole_group:
        os.killpg(driver.pid, signum)  # a terminal's Ctrl-C: the workers get it too
    else:
        os.kill(driver.pid, signum)
    try:
        code = driver.wait(timeout=120)
    except subprocess.TimeoutExpired:
        pytest.fail("the sweep did not stop")
    error = (tmp_path / "campaign.err").read_text()
    assert code == 130, error
    assert "Traceback" not in error and "interrupted" in error.splitlines()[-1], error
    wait_until(lambda: group_gone(driver.pid), 60, "every process of the sweep to exit")
    if not (out / STORE_NAME).exists():  # stopped before anything was stored
        assert not out.exists()


# ------------------------------------------------------------------------------ security


def listening(pid: int) -> dict[int, list]:
    """pid -> the TCP (ip, port) it listens on, for the driver and every descendant."""
    found = {}
    try:
        root = psutil.Process(pid)
        processes = [root, *root.children(recursive=True)]
    except psutil.NoSuchProcess:
        return found
    for process in processes:
        try:
            found[process.pid] = [
                (c.laddr.ip, c.laddr.port)
                for c in process.net_connections(kind="tcp")
                if c.status == psutil.CONN_LISTEN
            ]
        except psutil.Error:
            pass
    return found


async def dask_identity(address: str, security=None):
    """The `identity` a Dask server answers over its protocol (raises if it does not)."""
    from distributed.comm import connect

    kwargs = security.get_connection_args("client") if security else {}
    comm = await connect(address, timeout=3, **kwargs)
    try:
        await comm.write({"op": "identity"})
        return await asyncio.wait_for(comm.read(), 3)
    finally:
        comm.abort()


def http_answer(port: int) -> bytes:
    with socket.create_connection(("127.0.0.1", port), timeout=3) as connection:
        connection.sendall(b"GET /health HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n")
        try:
            return connection.recv(64)
        except (TimeoutError, ConnectionError):
            return b""


def test_local_cluster_needs_its_certificate_and_serves_no_http(hanging_sweep):
    from distributed.security import Security

    driver, _, _ = hanging_sweep  # its 2 runs pending: the cluster is up
    # The scheduler and the 2 nannies (in the driver) and the 2 workers: 5 servers.
    ports = wait_until(
        lambda: (found := listening(driver.pid)) and sum(map(len, found.values())) >= 5 and found,
        60,
        "the cluster's servers",
    )
    addresses = [address for addresses in ports.values() for address in addresses]
    assert len(ports[driver.pid]) == 3, ports
    assert all(ip == "127.0.0.1" for ip, _ in addresses), addresses
    assert 8787 not in {port for _, port in addresses}
    stranger = Security.temporary()  # a valid certificate, but not the cluster's
    for _, port in addresses:
        for address, security in [
            (f"tcp://127.0.0.1:{port}", None),
            (f"tls://127.0.0.1:{port}", stranger),
        ]:
            with pytest.raises(Exception):  # noqa: B017 - refused, closed or timed out
                asyncio.run(dask_identity(address, security))
        assert not http_answer(port).startswith(b"HTTP/"), port
    # A plain client cannot use the scheduler (one of the driver's 3 servers) to run anything.
    from distributed import Client

    for _, port in ports[driver.pid]:
        with pytest.raises(Exception):  # noqa: B017 - refused, closed or timed out
            Client(f"tcp://127.0.0.1:{port}", timeout=3)
    # Workers and their runners ignore SIGINT (Ctrl-C is the driver's business).
    for pid in ports:
        if pid != driver.pid:
            status = pathlib.Path(f"/proc/{pid}/status").read_text()
            ignored = int(
                next(line for line in status.splitlines() if line.startswith("SigIgn")).split()[1],
                16,
            )
            assert ignored & (1 << (signal.SIGINT - 1)), pid
    assert driver.poll() is None
