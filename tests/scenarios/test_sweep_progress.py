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
