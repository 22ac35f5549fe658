"""The `rpod` console script's entry point (rpod.scenarios.entry): a Ctrl-C while the command
line is still importing pydrake and numpy (1-3 s) is `rpod: interrupted` and exit status 130,
not a KeyboardInterrupt traceback.

Each process is started as the console script starts it (`from rpod.scenarios.entry import
main; sys.exit(main())`) and says when it has reached that line, so the Ctrl-C lands in the
import of the command line whatever the machine's load, not in the interpreter's own start.
"""

import contextlib
import pathlib
import re
import signal
import subprocess
import sys
import time

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
# As the console script does, after saying it has started.
LAUNCH = (
    "import sys\n"
    "from rpod.scenarios.entry import main\n"
    "print('started', flush=True)\n"
    "sys.exit(main(sys.argv[1:]))\n"
)


@contextlib.contextmanager
def _sigint_deliverable():
    """SIGINT neither blocked nor ignored while the child is started, as a shell starts it: a
    child inherits its parent thread's signal mask and an ignored SIGINT, and in the full suite
    an earlier test had left the test process so (a local Dask worker built in-process ignores
    SIGINT): the Ctrl-C then never arrived (empty stderr, exit 0)."""
    mask = signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
    handler = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, handler)
        signal.pthread_sigmask(signal.SIG_SETMASK, mask)


def _interrupt(command: list[str], delay_s: float, cwd, wait_for_start: bool = True):
    """(exit status, stderr) of the command, sent SIGINT delay_s after it started."""
    with _sigint_deliverable():
        process = subprocess.Popen(
            command, cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
        )
    try:
        if wait_for_start:
            assert process.stdout.readline().strip() == "started"
        time.sleep(delay_s)
        assert process.poll() is None, "it ended before the Ctrl-C"
        process.send_signal(signal.SIGINT)
        _, stderr = process.communicate(timeout=60)
    finally:
        process.kill()
        process.wait()
    return process.returncode, stderr


# Across the import: in Python code, and inside pydrake's compiled modules' initialisation,
# where pybind11 turned the KeyboardInterrupt into `ImportError: initialization failed`.
@pytest.mark.parametrize("delay_s", [0.3, 0.6, 0.9, 1.2])
def test_ctrl_c_while_the_command_line_imports_is_one_line_and_130(tmp_path, delay_s):
    out = tmp_path / "out"
    status, stderr = _interrupt(
        [sys.executable, "-c", LAUNCH, "run", "hold_point", "--no-record", "--out", str(out)],
        delay_s,
        tmp_path,
    )
    assert stderr.splitlines() == ["rpod: interrupted"], stderr
    assert status == 130
    assert not out.exists()


def test_the_console_script_is_the_entry_module():
    scripts = (ROOT / "pyproject.toml").read_text().split("[project.scripts]")[1]
    assert re.search(r'^rpod = "rpod\.scenarios\.entry:main"$', scripts, re.MULTILINE), scripts


def test_the_installed_console_script_says_one_line_on_an_early_ctrl_c(tmp_path):
    script = pathlib.Path(sys.executable).parent / "rpod"
    if not script.is_file() or "rpod.scenarios.entry" not in script.read_text():
        pytest.skip(
            "the rpod console script is not installed from this pyproject (pip install -e .)"
        )
    # 0.8 s: past the interpreter's own start on a loaded machine, inside the import of a run
    # (pydrake, ~1.5 s). Not `rpod list`: since its imports got lazy it can be finishing at 0.8 s,
    # and a SIGINT during the interpreter's exit is never seen (CI: empty stderr).
    out = tmp_path / "out"
    command = [str(script), "run", "hold_point", "--no-record", "--out", str(out)]
    status, stderr = _interrupt(command, 0.8, tmp_path, wait_for_start=False)
    assert stderr.splitlines() == ["rpod: interrupted"], stderr
    assert status == 130
    assert not out.exists()


def test_the_entry_point_runs_the_command_line(tmp_path):
    process = subprocess.run(
        [sys.executable, "-m", "rpod.scenarios.entry", "list"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert process.returncode == 0, process.stderr
    assert "Scenarios (rpod run NAME):" in process.stdout


@pytest.mark.parametrize("wrapper", [RuntimeError, ImportError])
def test_an_interrupt_wrapped_by_an_import_is_still_one_line(monkeypatch, capsys, wrapper):
    """A Ctrl-C inside a class's `__set_name__` at import (matplotlib's) reaches the entry point
    as a RuntimeError caused by the KeyboardInterrupt on Python 3.11, inside a compiled module's
    initialisation as an ImportError: both are the one line and 130; anything else is raised."""
    from rpod.scenarios import cli, entry

    def interrupted_import(argv):
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt as interrupt:
            raise wrapper("Error calling __set_name__") from interrupt

    def end_now(status):  # as the real one ends the process, without os._exit
        raise SystemExit(status)

    monkeypatch.setattr(cli, "main", interrupted_import)
    monkeypatch.setattr(entry, "_end_now", end_now)
    with pytest.raises(SystemExit) as ended:
        entry.main(["run", "hold_point"])
    assert ended.value.code == 130 and capsys.readouterr().err == "rpod: interrupted\n"

    monkeypatch.setattr(cli, "main", lambda argv: (_ for _ in ()).throw(wrapper("real")))
    with pytest.raises(wrapper, match="real"):
        entry.main(["run", "hold_point"])
