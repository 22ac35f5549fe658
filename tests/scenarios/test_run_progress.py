"""Tests of rpod.scenarios.run_progress: `rpod run`'s progress, a bar on a terminal, plain
lines in a log once a run is long, nothing for a short run off a terminal."""

import io

from rpod.scenarios.run_progress import RunProgress


class _Terminal(io.StringIO):
    def isatty(self):
        return True


def test_off_a_terminal_a_short_run_writes_nothing_and_a_long_one_plain_lines():
    quiet = io.StringIO()
    progress = RunProgress("coast", stream=quiet)  # 10 s before the first line
    progress.phase("building")
    progress(100.0, 3000.0)
    progress.done()
    assert quiet.getvalue() == ""
    log = io.StringIO()
    progress = RunProgress("coast", stream=log, quiet_s=0.0, every_s=0.0)
    progress(1500.0, 3000.0)
    (line,) = log.getvalue().splitlines()
    assert line.startswith("rpod: coast: 1500/3000 s simulated (50 %), ") and "x real time" in line
    assert "\r" not in log.getvalue()


def test_on_a_terminal_a_bar_once_the_run_lasts_then_cleared_for_the_result_line():
    stream = _Terminal()
    progress = RunProgress("coast", stream=stream, bar_after_s=1e9)
    progress.phase("building and planning")
    progress(10.0, 3000.0)  # too early for a bar: the phase line stays
    assert "%|" not in stream.getvalue() and "building and planning ..." in stream.getvalue()
    progress._bar_after_s = 0.0
    progress(1500.0, 3000.0)
    text = stream.getvalue()
    assert "rpod: coast:  50%|" in text and "1500/3000 s simulated, " in text
    assert "x real time [" in text
    progress.done()
    assert stream.getvalue().endswith("\r\033[K") or stream.getvalue().endswith("\r")
    assert "\n" not in stream.getvalue()  # nothing stays but the result line, printed next
