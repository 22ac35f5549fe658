"""Worker side of a campaign: each run executes in a child process that can be killed.

Owns: `run_case`, the Dask task that runs one planned run and always returns a result record
(it never raises for a run's failure), the runner child process (`python -m
rpod.scenarios.harness`) that builds and simulates the scenario, and `LocalWorker`, the worker
class of the local cluster (sweep.py): no HTTP server, SIGINT ignored.
Does not own: planning, scheduling, storing (campaign.py, sweep.py, store.py).

Why a child process. A Python thread cannot be killed, and a Dask task runs in a thread of the
worker. So a run that hangs (a stiff integration, a solver loop) could only be abandoned, never
stopped, and it would hold its core forever. Each worker thread therefore keeps one long-lived
runner child and talks to it over pipes (one JSON line per request and per reply):
- Timeout: past `timeout_s` the worker kills the runner (SIGKILL) and records the run as
  failed ("timeout: ..."). The next run starts a fresh runner.
- Crash: a run that kills its process (a segfault, the OOM killer, os._exit) kills only the
  runner. The worker records "crashed: run process killed by signal ...", with the tail of
  the runner's stderr as the detail.
- Reuse: the runner is kept between runs, so pydrake is imported once per worker thread
  (~1 s), not once per run. The base scenario is parsed once per campaign and cached.
- Hygiene: the runner ignores SIGINT (Ctrl-C is the driver's business), exits when its stdin
  closes, and exits when its parent dies (a watchdog thread polls the parent pid), so a killed
  worker leaves no runner behind.

A run that kills its *worker* process is handled by Dask, not here. The scheduler reschedules
the task on another worker. After `distributed.scheduler.allowed-failures` worker deaths, the
future raises KilledWorker, and the driver records "worker died: ...".

Plain data only crosses the wire: the request is a dict of strings, numbers and lists (the
base scenario as YAML text from loader.dump_scenario, and the run's dotted-path overrides). The
diagram is built inside the runner.

Test hook (honoured here only, never by a campaign file): the environment variable
RPOD_CAMPAIGN_FAULTS="raise:CASE,hang:CASE,crash:CASE,kill_worker:CASE" makes the runner
misbehave on the runs of the named campaign cases. It raises an exception, sleeps forever,
SIGKILLs itself, or SIGKILLs its worker process. The tests use it to check that each kind of
failure is recorded and that the campaign goes on.
"""

import collections
import importlib
import json
import os
import select
import signal
import socket
import subprocess
import sys
import threading
import time
import traceback

from rpod.scenarios.entry import BLAS_THREAD_VARIABLES

FAULTS_ENV = "RPOD_CAMPAIGN_FAULTS"
RUNNER_STARTUP_TIMEOUT_S = 300.0  # importing pydrake on a cold, slow file system
STDERR_KEPT_BYTES = 16384
DETAIL_CHARS = 4000
MAX_WAIT_S = 3600.0  # longest single select(): a huge timeout_s is waited for in slices
# A runner that has grown past this is retired after its run (and a fresh one started for the
# next): a guard only since simulate() frees its diagram (rpod.systems.lifetime; before, each
# run left 1-3 MB behind, several GB over a 3,900-run campaign on 2 runners;
# benchmarks/results/memory.md).
RUNNER_MAX_RSS_BYTES = 1 << 30


def __getattr__(name: str):
    """`LocalWorker`, made on first use, so that the runner child never imports distributed."""
    if name != "LocalWorker":
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    from distributed import Worker

    class LocalWorker(Worker):
        """A worker of the local cluster (sweep.py): no HTTP server, and SIGINT ignored.

        The driver starts the cluster with SIGINT blocked, so this process starts with it
        blocked; here it becomes ignored (a Ctrl-C already pending is dropped), as in the runners.
        Ctrl-C is the driver's business: it closes the cluster.
        """

        def __init__(self, *args, **kwargs):
            if threading.current_thread() is threading.main_thread():
                signal.signal(signal.SIGINT, signal.SIG_IGN)
                signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
            super().__init__(*args, **kwargs)

        def start_http_server(self, *args, **kwargs):
            """None: a worker starts one even without a dashboard (metrics, health), and the
            campaign uses none of it."""

    LocalWorker.__qualname__ = "LocalWorker"  # pickled by reference, as harness.LocalWorker
    globals()[name] = LocalWorker
    return LocalWorker


class _Timeout(Exception):
    pass


class _Died(Exception):
    pass


class _Runner:
    """One runner child process and its pipes (used by one worker thread at a time)."""

    def __init__(self):
        env = dict(os.environ)
        for name in BLAS_THREAD_VARIABLES:
            env.setdefault(name, "1")  # one process per core: no hidden thread pools
        self.process = subprocess.Popen(
            [sys.executable, "-m", "rpod.scenarios.harness"],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            env=env,
        )
        self._buffer = b""
        self._stderr = collections.deque()
        self._stderr_bytes = 0  # total ever read, to take the tail written during one request
        self._stderr_kept = 0
        self._reader = threading.Thread(target=self._drain_stderr, daemon=True)
        self._reader.start()
        try:
            ready = json.loads(self._read_line(time.monotonic() + RUNNER_STARTUP_TIMEOUT_S))
        except _Timeout:
            self.kill()
            raise _Died(f"did not start within {RUNNER_STARTUP_TIMEOUT_S:.0f} s") from None
        self.pid = ready["pid"]

    def _drain_stderr(self) -> None:
        """Keeps the last STDERR_KEPT_BYTES of the runner's stderr (so the pipe never fills)."""
        for chunk in iter(lambda: self.process.stderr.read1(4096), b""):
            self._stderr.append(chunk)
            self._stderr_bytes += len(chunk)
            self._stderr_kept += len(chunk)
            while self._stderr_kept - len(self._stderr[0]) >= STDERR_KEPT_BYTES:
                self._stderr_kept -= len(self._stderr.popleft())

    def stderr_since(self, mark: int) -> str:
        """What the runner wrote to stderr since `mark` (as far as it was kept)."""
        if self.process.poll() is not None:
            self._reader.join(timeout=0.5)  # a dead runner: let the reader take the last bytes
        text = b"".join(self._stderr)
        wanted = self._stderr_bytes - mark
        return text[-wanted:].decode(errors="replace") if wanted > 0 else ""

    def _read_line(self, deadline: float | None) -> str:
        """The next line of the runner's stdout; _Timeout past deadline, _Died on EOF."""
        descriptor = self.process.stdout.fileno()
        while b"\n" not in self._buffer:
            remaining = None if deadline is None else deadline - time.monotonic()
            if remaining is not None and remaining <= 0:
                raise _Timeout()
            wait = None if remaining is None else min(remaining, MAX_WAIT_S)
            readable, _, _ = select.select([descriptor], [], [], wait)
            if not readable:
                continue  # the deadline is checked above
            chunk = os.read(descriptor, 65536)
            if not chunk:
                raise _Died(self.exit_reason())
            self._buffer += chunk
        line, _, self._buffer = self._buffer.partition(b"\n")
        return line.decode()

    def request(self, payload: dict, timeout_s: float | None) -> dict:
        """Sends one run and waits for its reply; _Timeout or _Died when there is none."""
        try:
            self.process.stdin.write(json.dumps(payload).encode() + b"\n")
            self.process.stdin.flush()
        except (BrokenPipeError, OSError):
            raise _Died(self.exit_reason()) from None
        deadline = None if timeout_s is None else time.monotonic() + timeout_s
        return json.loads(self._read_line(deadline))

    def exit_reason(self) -> str:
        try:
            code = self.process.wait(timeout=10)
        except subprocess.TimeoutExpired:
            return "stopped answering"
        if code < 0:
            return f"killed by signal {signal.Signals(-code).name}"
        return f"exited with status {code}"

    def kill(self) -> None:
        if self.process.poll() is None:
            self.process.kill()
        try:
            self.process.wait(timeout=10)
        except subprocess.TimeoutExpired:  # pragma: no cover - SIGKILL does not fail
            pass
        for stream in (self.process.stdin, self.process.stdout):
            try:
                stream.close()
            except OSError:
                pass


_idle_runners: list[_Runner] = []
_idle_lock = threading.Lock()


def _take_runner() -> _Runner:
    with _idle_lock:
        while _idle_runners:
            runner = _idle_runners.pop()
            if runner.process.poll() is None:
                return runner
    return _Runner()


def _worker_name() -> str:
    try:
        from distributed import get_worker

        return get_worker().address
    except (ImportError, ValueError):
        return socket.gethostname()


def run_case(request: dict) -> dict:
    """The Dask task: runs one planned run; returns its result record, never raises for a run.

    Args:
        request: plain data; run_id, case, base_yaml, overrides, timeout_s (None: no limit),
            save_dir (None, or a folder for the run's outputs) and record.

    Returns:
        {'status': 'ok' | 'failed', 'reason', 'detail', 'metrics', 'wall_time_s', 'worker'}.
    """
    start = time.perf_counter()
    worker = _worker_name()
    try:
        runner = _take_runner()
    except (_Died, OSError) as error:
        return {
            "status": "failed",
            "reason": f"crashed: the run process {error}",
            "wall_time_s": time.perf_counter() - start,
            "worker": worker,
        }
    worker = f"{worker} (runner pid {runner.pid})"
    mark = runner._stderr_bytes
    timeout_s = request.get("timeout_s")
    try:
        reply = runner.request(request, timeout_s)
    except _Timeout:
        runner.kill()
        return {
            "status": "failed",
            "reason": f"timeout: no result within {timeout_s:g} s (run process killed)",
            "wall_time_s": time.perf_counter() - start,
            "worker": worker,
        }
    except _Died as error:
        runner.kill()
        return {
            "status": "failed",
            "reason": f"crashed: the run process {error}",
            "detail": runner.stderr_since(mark)[-DETAIL_CHARS:] or None,
            "wall_time_s": time.perf_counter() - start,
            "worker": worker,
        }
    if reply.pop("runner_rss_bytes", 0) > RUNNER_MAX_RSS_BYTES:
        runner.kill()  # retired: the next run starts a fresh one
    else:
        with _idle_lock:
            _idle_runners.append(runner)
    reply["worker"] = worker
    return reply


# ---------------------------------------------------------------------------------------------
# The runner child.


def _watch_parent() -> None:
    """Exits this process as soon as its parent (the worker) is gone."""
    parent = os.getppid()

    def watch():
        while True:
            time.sleep(0.5)
            if os.getppid() != parent:
                os._exit(70)

    threading.Thread(target=watch, daemon=True).start()


def _inject_fault(case: str) -> None:
    """The test hook described in the module docstring."""
    for item in filter(None, os.environ.get(FAULTS_ENV, "").split(",")):
        kind, _, name = item.partition(":")
        if name != case:
            continue
        if kind == "raise":
            raise RuntimeError(f"injected fault ({FAULTS_ENV}) in case {case}")
        if kind == "hang":
            while True:
                time.sleep(3600)
        if kind == "crash":
            os.kill(os.getpid(), signal.SIGKILL)
        if kind == "kill_worker":
            os.kill(os.getppid(), signal.SIGKILL)
            while True:  # the watchdog ends this process once the parent is gone
                time.sleep(3600)


def _execute(request: dict, bases: dict) -> dict:
    """Runs one request in this process; the reply record (failures included)."""
    import pathlib

    from rpod.diagrams.scenario import validate_scenario
    from rpod.diagrams.simulate import simulate
    from rpod.scenarios.campaign import apply_overrides
    from rpod.scenarios.loader import build_scenario
    from rpod.scenarios.run import run_to_folder

    start = time.perf_counter()
    try:
        _inject_fault(request.get("case", ""))
        base_yaml = request["base_yaml"]
        if base_yaml not in bases:
            bases.clear()  # one campaign at a time: keep one base
            bases[base_yaml] = build_scenario(base_yaml, "the campaign's base")
        scenario = apply_overrides(bases[base_yaml], request["overrides"])
        validate_scenario(scenario)
        if request.get("save_dir"):
            summary = run_to_folder(
                request["run_id"],
                scenario,
                pathlib.Path(request["save_dir"]),
                record=bool(request.get("record")),
            )
        else:
            summary = simulate(scenario).summary
    except Exception as error:  # noqa: BLE001 - a failed run, not a failed campaign
        message = (str(error).strip().splitlines() or [""])[0]
        return {
            "status": "failed",
            "reason": f"error: {type(error).__name__}: {message}",
            "detail": traceback.format_exc()[-DETAIL_CHARS:],
            "wall_time_s": time.perf_counter() - start,
        }
    ok = summary.get("status") == "ok"
    return {
        "status": "ok" if ok else "failed",
        "reason": None if ok else f"simulation {summary.get('status')}",
        "metrics": summary,
        "wall_time_s": time.perf_counter() - start,
    }


def _resident_bytes() -> int:
    """This process's resident memory [bytes] (Linux /proc; 0 where there is none)."""
    try:
        with open("/proc/self/statm") as statm:
            return int(statm.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        return 0


def _serve() -> None:
    """The runner's loop: one JSON request per stdin line, one JSON reply per stdout line."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    protocol = os.fdopen(os.dup(1), "w", buffering=1)
    os.dup2(2, 1)  # anything else printed goes to stderr, never into the protocol
    _watch_parent()
    import logging

    logging.getLogger("drake").setLevel(logging.WARNING)
    for module in ("rpod.diagrams.simulate", "rpod.scenarios.campaign", "rpod.scenarios.run"):
        importlib.import_module(module)  # the heavy imports, once, before saying ready

    protocol.write(json.dumps({"ready": True, "pid": os.getpid()}) + "\n")
    bases = {}
    for line in sys.stdin:
        if line.strip():
            reply = _execute(json.loads(line), bases)
            reply["runner_rss_bytes"] = _resident_bytes()
            protocol.write(json.dumps(reply) + "\n")


if __name__ == "__main__":
    _serve()
