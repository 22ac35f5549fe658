"""`rpod run` stopped by SIGTERM or Ctrl-C (SIGINT) mid-simulation: exit status 143 or 130, one
stderr line, the hidden staging folder removed, and what was at --out before untouched (a
previous complete output, or, with --overwrite, a folder rpod did not write).

The run is the real console entry point in a subprocess (its own session, killed with its group
if anything goes wrong), with a scenario that would take ~20 minutes; the signal is sent once
its staging folder exists. Every wait is bounded.
"""

import os
import signal
import subprocess
import sys
import time

import pytest
from test_output_folder import (
    LONG_DURATION_S,
    SHORT_DURATION_S,
    TIMEOUT_S,
    foreign_folder,
    hidden_siblings,
    hold_point_file,
    run_rpod,
    snapshot,
)


def _reset_signals():
    """The child starts with default SIGINT and SIGTERM even if this test's shell ignores them
    (a background job's SIGINT is ignored, and rpod rightly leaves an ignored signal alone)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)


def _wait_for(predicate, process, timeout_s=TIMEOUT_S):
    deadline = time.monotonic() + timeout_s
    while not predicate():
        assert process.poll() is None, process.communicate(timeout=TIMEOUT_S)
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.05)


@pytest.mark.parametrize(
    "signum, status, message, previous",
    [
        # A rerun's own output, kept, by default under SIGINT (the other signal: slow).
        pytest.param(
            signal.SIGTERM,
            143,
            "rpod: terminated (SIGTERM)",
            "own",
            id="sigterm-own_output",
            marks=pytest.mark.slow,
        ),
        pytest.param(
            signal.SIGTERM,
            143,
            "rpod: terminated (SIGTERM)",
            "foreign",
            id="sigterm-overwrite_foreign",
        ),
        pytest.param(signal.SIGTERM, 143, "rpod: terminated (SIGTERM)", None, id="sigterm-nothing"),
        pytest.param(signal.SIGINT, 130, "rpod: interrupted", "own", id="sigint-own_output"),
    ],
)
def test_a_signal_mid_run_cleans_up_and_keeps_what_was_there(
    tmp_path, signum, status, message, previous
):
    out = tmp_path / "out"
    flags = []
    if previous == "own":
        short = hold_point_file(tmp_path, SHORT_DURATION_S)
        done = run_rpod("run", str(short), "--out", str(out), "--no-record", cwd=tmp_path)
        assert done.returncode in (0, 3), done.stderr  # 3: ran; a 5 s hold is no mission
    elif previous == "foreign":
        foreign_folder(out)
        flags = ["--overwrite"]
    before = snapshot(out) if previous else None
    long = hold_point_file(tmp_path, LONG_DURATION_S)
    process = subprocess.Popen(
        [sys.executable, "-m", "rpod.scenarios.cli", "run", str(long), "--out", str(out),
         "--no-record", *flags],
        cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        start_new_session=True, preexec_fn=_reset_signals,  # noqa: PLW1509 (no threads here)
    )  # fmt: skip
    try:
        staging = out.with_name(f".{out.name}.partial-{process.pid}")
        _wait_for(staging.exists, process)
        time.sleep(1.0)  # into the simulation (the test holds wherever the signal lands)
        process.send_signal(signum)
        _, stderr = process.communicate(timeout=TIMEOUT_S)
    finally:
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait(timeout=TIMEOUT_S)
    assert process.returncode == status, stderr
    assert stderr.strip().splitlines() == [message], stderr
    assert hidden_siblings(out) == []
    if previous:
        assert snapshot(out) == before
    else:
        assert not out.exists()
