"""Helpers of the campaign tests: the `rpod` CLI in a subprocess, small campaign files, polling
the results store, killing process groups. Fixtures are in conftest.py.
"""

import contextlib
import io
import json
import os
import signal
import sqlite3
import subprocess
import sys
import time
import traceback

import numpy as np

CLI_TIMEOUT_S = 300  # an upper bound against hangs, far above the ~10 s these campaigns take

# 8 fast runs: a 2 x 2 grid x 2 samples of a short coast (~30 ms of simulation each).
SMALL_CAMPAIGN = """\
description: "test: 2 x 2 grid x 2 samples of a short coast"
base: coast
overrides: {duration_s: 40.0, log_period_s: 5.0}
grid:
  chaser.p_LC_L[1]: [-50.0, -100.0]
  duration_s: [20.0, 40.0]
sample:
  count: 2
  seed: 11
  fields:
    target.w_IT_T_deg_s: {dist: direction, scale: {dist: uniform, low: 0.5, high: 5.0}}
    chaser.v_LC_L[2]: {dist: normal, mean: 0.0, std: 0.01}
"""

# 10 runs of ~0.4 s each (15 s of the closed-loop hold-point approach): slow enough to be
# killed mid-campaign by polling the store every 0.1 s (the tests check that runs were pending).
SLOW_CAMPAIGN = """\
description: "test: 10 short hold-point runs"
base: hold_point
overrides: {duration_s: 15.0, log_period_s: 1.0}
grid:
  chaser.p_LC_L[1]: [-20.0, -22.0, -24.0, -26.0, -28.0, -30.0, -32.0, -34.0, -36.0, -38.0]
"""

# The same shape with coasting runs (~0.5 s each here: 3000 s of coast), for tests of the engine
# that should not depend on a controller: after two finished runs, ~2 s of runs are pending.
SLOW_COAST_CAMPAIGN = """\
description: "test: 10 coasting runs of 3000 s"
base: coast
overrides: {duration_s: 3000.0, log_period_s: 10.0}
grid:
  chaser.p_LC_L[1]: [-20.0, -22.0, -24.0, -26.0, -28.0, -30.0, -32.0, -34.0, -36.0, -38.0]
"""

# Metrics that depend only on the scenario, not on timing.
DETERMINISTIC = [
    "final_p_LC_L",
    "final_range_m",
    "final_speed_m_s",
    "min_separation_m",
    "max_corridor_violation_deg",
    "delta_v_m_s",
    "integrator_steps",
    "derivative_evaluations",
    "sim_time_s",
]


def assert_same_metric(value, expected, key: str) -> None:
    """Equal to 1e-12 relative; a metric that is None (e.g. max_corridor_violation_deg of a
    chaser that never came within the corridor's extent) must be None on both sides."""
    if expected is None or value is None:
        assert value is expected is None, key
        return
    np.testing.assert_allclose(value, expected, rtol=1e-12, err_msg=key)


def rpod_command(*args) -> list[str]:
    return [sys.executable, "-m", "rpod.scenarios.cli", *args]


def run_rpod(*args, cwd, env=None, timeout=CLI_TIMEOUT_S) -> subprocess.CompletedProcess:
    """Runs the real console entry point and returns the completed process."""
    return subprocess.run(
        rpod_command(*args),
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
        timeout=timeout,
        check=False,
    )


class _TimedOut(BaseException):
    """Raised by SIGALRM in an in-process command that ran past its timeout."""


@contextlib.contextmanager
def _deadline(seconds: float):
    """Raises _TimedOut after `seconds` (SIGALRM: the main thread, where pytest runs tests)."""

    def expire(signum, frame):
        raise _TimedOut(f"the command ran past its {seconds:g} s timeout")

    previous = signal.signal(signal.SIGALRM, expire)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def run_rpod_in_process(*args, cwd, env=None, timeout=CLI_TIMEOUT_S) -> subprocess.CompletedProcess:
    """`rpod ARGS` through `cli.main` in this process, as `run_rpod` reports it: the exit
    status, stdout and stderr (an escaped exception is a traceback on stderr and status 1, as
    in a real process). It saves the ~1.3 s of imports a new interpreter pays, so tests of what
    a command says and writes use it; tests of the process itself (signals, the console entry
    point, plug-ins, sweeps) keep `run_rpod`. `env` replaces os.environ for the call."""
    from rpod.scenarios import cli

    stdout, stderr = io.StringIO(), io.StringIO()
    saved_cwd, saved_env = os.getcwd(), dict(os.environ)
    try:
        os.chdir(cwd)
        if env is not None:
            os.environ.clear()
            os.environ.update(env)
        with contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(stderr):
            try:
                with _deadline(timeout):
                    code = cli.main([str(arg) for arg in args])
            except SystemExit as exit_:  # argparse's usage errors
                code = exit_.code if isinstance(exit_.code, int) else 1
            except _TimedOut:
                raise subprocess.TimeoutExpired(["rpod", *args], timeout) from None
            except Exception:  # noqa: BLE001 - a real process prints it and exits 1
                traceback.print_exc()
                code = 1
    finally:
        os.chdir(saved_cwd)
        os.environ.clear()
        os.environ.update(saved_env)
    return subprocess.CompletedProcess(["rpod", *args], code, stdout.getvalue(), stderr.getvalue())


def store_counts(store_file) -> dict:
    """{'ok': n, 'failed': n, 'pending': n} read from a results store (zeros if absent)."""
    counts = {"ok": 0, "failed": 0, "pending": 0}
    if not os.path.exists(store_file):
        return counts
    try:
        connection = sqlite3.connect(f"file:{store_file}?mode=ro", uri=True, timeout=5)
        try:
            for status, count in connection.execute(
                "SELECT status, COUNT(*) FROM runs GROUP BY status"
            ):
                counts[status] = count
        finally:
            connection.close()
    except sqlite3.OperationalError:  # the table is not there yet
        pass
    return counts


def wait_until(predicate, timeout_s: float, what: str, poll_s: float = 0.1):
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        value = predicate()
        if value:
            return value
        time.sleep(poll_s)
    raise AssertionError(f"timed out after {timeout_s} s waiting for {what}")


def kill_group(process: subprocess.Popen) -> None:
    """SIGKILLs a process started with start_new_session=True, with all its children."""
    try:
        os.killpg(process.pid, signal.SIGKILL)
    except ProcessLookupError:
        pass
    try:
        process.wait(timeout=10)
    except subprocess.TimeoutExpired:  # pragma: no cover - SIGKILL does not fail
        pass


def group_gone(pgid: int) -> bool:
    """Whether no process of the group (a session started with start_new_session) is left."""
    try:
        os.killpg(pgid, 0)
    except ProcessLookupError:
        return True
    return False


def _detached(command, **kwargs) -> subprocess.Popen:
    return subprocess.Popen(command, start_new_session=True, **kwargs)


def start_detached_sweep(
    folder, text: str, *args, env=None, name="campaign", start=_detached
) -> subprocess.Popen:
    """`rpod sweep` of the campaign `text` (written to folder/NAME.yaml) in its own session,
    not waited for; its output in folder/NAME.out and .err. `start(command, **kwargs)` starts
    it (conftest.spawn's, to have it killed with the test); otherwise the caller kills its
    group."""
    campaign = folder / f"{name}.yaml"
    campaign.write_text(text)
    with open(folder / f"{name}.out", "w") as out, open(folder / f"{name}.err", "w") as err:
        return start(
            rpod_command("sweep", str(campaign), *args), cwd=folder, env=env, stdout=out, stderr=err
        )


class DaskCluster:
    """A scheduler and workers, each a separate `python -m distributed.cli...` process."""

    def __init__(self, spawn, folder, workers: int):
        self.folder = folder
        scheduler_file = folder / "scheduler.json"
        self.logs = []
        self.scheduler = spawn(
            [
                sys.executable,
                "-m",
                "distributed.cli.dask_scheduler",
                "--host",
                "127.0.0.1",
                "--port",
                "0",
                "--no-dashboard",
                "--scheduler-file",
                str(scheduler_file),
            ],
            stdout=self._log("scheduler"),
            stderr=subprocess.STDOUT,
        )
        wait_until(
            lambda: scheduler_file.is_file() and scheduler_file.stat().st_size > 0,
            60,
            "the scheduler file",
        )
        self.address = json.loads(scheduler_file.read_text())["address"]
        assert self.address.startswith("tcp://127.0.0.1:"), self.address
        self.workers = [
            spawn(
                [
                    sys.executable,
                    "-m",
                    "distributed.cli.dask_worker",
                    self.address,
                    "--nthreads",
                    "1",
                    "--nworkers",
                    "1",
                    "--no-dashboard",
                    "--host",
                    "127.0.0.1",
                    "--name",
                    f"test-worker-{index}",
                    "--death-timeout",
                    "60",
                ],
                stdout=self._log(f"worker{index}"),
                stderr=subprocess.STDOUT,
            )
            for index in range(workers)
        ]
        from distributed import Client

        with Client(self.address, timeout=30) as client:
            client.wait_for_workers(workers, timeout=60)

    def _log(self, name):
        handle = open(self.folder / f"{name}.log", "w")  # noqa: SIM115 - closed at teardown
        self.logs.append(handle)
        return handle
