"""The sweep's progress line states mission success, not the share of runs that ran."""

import io

from rpod.scenarios.sweep import Progress


def _result(status, success=None):
    metrics = {"mission": {"success": success}} if status == "ok" else None
    return {"status": status, "metrics": metrics}


def test_the_progress_line_counts_mission_verdicts():
    stream = io.StringIO()
    progress = Progress("c", total=5, ok=0, failed=0, stream=stream)
    progress.judge([_result("ok", True), _result("ok", False), _result("failed")])
    progress.judge([_result("ok", None)])  # no mission to judge: not counted
    progress.update(ok=3, failed=1, final=True)
    line = stream.getvalue().strip()
    assert "4/5 done, 1 failed, 1 left" in line
    assert "mission success 33.3% (1/3)" in line and "ok |" not in line


def test_no_verdict_yet_is_said_as_such():
    stream = io.StringIO()
    Progress("c", total=2, ok=0, failed=0, stream=stream).update(0, 0, final=True)
    assert "mission success --" in stream.getvalue()


class _Terminal(io.StringIO):
    def isatty(self):
        return True


def test_on_a_terminal_a_bar_with_rate_eta_and_the_counts(monkeypatch):
    monkeypatch.setenv("COLUMNS", "150")  # the terminal's width (tqdm cuts a longer line)
    stream = _Terminal()
    progress = Progress("camp", total=4, ok=1, failed=0, stream=stream)  # resumed: 1 done
    progress.judge([_result("ok", True), _result("ok", False)])
    progress.update(ok=2, failed=0)
    progress.update(ok=3, failed=1, final=True)
    progress.update(ok=3, failed=1, final=True)  # after the end: nothing more
    text = stream.getvalue()
    assert text.startswith("\rcamp: 1/4 runs |") and text.endswith("\n")  # left on screen
    last = text.rsplit("\r", 1)[-1]
    assert last.startswith("camp: 4/4 runs, 1 failed | mission success 50.0% (1/2) |")
    assert "| 100% [" in last and "run/s]" in last  # the bar, then the ETA and the rate
    assert text.count("\n") == 1  # one line, redrawn: no plain lines on a terminal
