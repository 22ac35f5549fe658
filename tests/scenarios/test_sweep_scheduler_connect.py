"""`rpod sweep --scheduler ADDRESS` where no Dask scheduler answers: the connect honours
--connect-timeout-s and ends with one line, exit status 2, whatever is at the address.

Dask's Client bounds the TCP connect but not the handshake read after it, so a port that
accepts and says nothing (a plain TCP server, an HTTP server waiting for a request line) kept
the sweep waiting forever. The servers here are threads of the test, on 127.0.0.1.
"""

import contextlib
import http.server
import socket
import threading
import time

from campaign_helpers import SLOW_CAMPAIGN, run_rpod

from rpod.scenarios.loader import ScenarioFileError
from rpod.scenarios.sweep import _connect_scheduler


@contextlib.contextmanager
def silent_server():
    """A TCP server on 127.0.0.1 that accepts every connection and never sends a byte."""
    listener = socket.socket()
    listener.bind(("127.0.0.1", 0))
    listener.listen(16)
    accepted = []
    stop = threading.Event()

    def serve():
        listener.settimeout(0.1)
        while not stop.is_set():
            with contextlib.suppress(OSError):
                accepted.append(listener.accept()[0])

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    try:
        yield f"tcp://127.0.0.1:{listener.getsockname()[1]}", accepted
    finally:
        stop.set()
        thread.join(5)
        for connection in accepted:
            connection.close()
        listener.close()


@contextlib.contextmanager
def http_server():
    """Python's HTTP server on 127.0.0.1 (it waits for a request line Dask never sends)."""
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), http.server.BaseHTTPRequestHandler)
    server.daemon_threads = True
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"tcp://127.0.0.1:{server.server_address[1]}"
    finally:
        server.shutdown()
        server.server_close()
        thread.join(5)


def refused(address: str, timeout_s: float) -> tuple[ScenarioFileError, float]:
    """(the error of _connect_scheduler(address, timeout_s), seconds it took); it runs in a
    thread so that a connect that hangs fails the test after 60 s instead of hanging it."""
    outcome = {}

    def connect():
        start = time.monotonic()
        try:
            _connect_scheduler(address, timeout_s).close()
        except BaseException as error:  # noqa: BLE001 - handed to the test
            outcome["error"] = error
        outcome["took"] = time.monotonic() - start

    thread = threading.Thread(target=connect, daemon=True)
    thread.start()
    thread.join(60)
    assert not thread.is_alive(), f"the connect to {address} still waits after 60 s"
    assert isinstance(outcome.get("error"), ScenarioFileError), outcome
    return outcome["error"], outcome["took"]


def test_a_server_that_accepts_and_says_nothing_is_refused_within_the_timeout():
    with silent_server() as (address, accepted):
        error, took = refused(address, 0.5)
        assert accepted, "the connection was not even made"
    message = str(error)
    assert message.startswith(f"--scheduler {address}: not a Dask scheduler"), message
    assert "\n" not in message
    assert took < 5.0, took  # the 0.5 s timeout, and one quick TCP check to say why


def test_an_http_server_is_refused_within_the_timeout():
    with http_server() as address:
        error, took = refused(address, 0.5)
    assert str(error).startswith(f"--scheduler {address}: "), str(error)
    assert took < 5.0, took


def test_a_long_address_is_cut_in_the_error():
    error, _ = refused("tcp://" + "h" * 4000 + ":8786", 0.5)
    assert len(str(error)) < 400, str(error)


def test_cli_sweep_against_a_silent_server_exits_2_with_one_line_and_starts_nothing(tmp_path):
    campaign = tmp_path / "slow.yaml"
    campaign.write_text(SLOW_CAMPAIGN)
    with silent_server() as (address, _):
        process = run_rpod(
            "sweep",
            str(campaign),
            "--out",
            str(tmp_path / "out"),
            "--scheduler",
            address,
            "--connect-timeout-s",
            "1",
            cwd=tmp_path,
            timeout=120,  # a hang is a failure here, not a stuck test run
        )
    assert process.returncode == 2, process.stderr
    lines = process.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"rpod: error: --scheduler {address}: "), lines
    assert sorted(p.name for p in tmp_path.iterdir()) == ["slow.yaml"]  # nothing started
