"""The campaign harness's runner processes: a runner that has grown past its memory limit is
retired after its run, and the next run gets a fresh one (each simulate() leaves some memory
behind; a long campaign must not pile it up)."""

from rpod.diagrams.scenario import Scenario
from rpod.scenarios import harness
from rpod.scenarios.loader import dump_scenario


def _request(run_id: str) -> dict:
    base = Scenario(controller=None, duration_s=1.0, log_period_s=0.5)
    return {
        "run_id": run_id,
        "case": "",
        "base_yaml": dump_scenario(base),
        "overrides": {},
        "timeout_s": 120.0,
        "save_dir": None,
        "record": False,
    }


def test_a_runner_over_its_memory_limit_is_retired_and_replaced(monkeypatch):
    try:
        first = harness.run_case(_request("a"))
        second = harness.run_case(_request("b"))
        assert first["status"] == second["status"] == "ok"
        assert "runner_rss_bytes" not in first  # the harness's own business
        assert first["worker"] == second["worker"]  # under the limit: the runner is kept

        monkeypatch.setattr(harness, "RUNNER_MAX_RSS_BYTES", 0)  # every runner is over it
        third = harness.run_case(_request("c"))
        fourth = harness.run_case(_request("d"))
        assert third["worker"] == second["worker"]  # the kept runner ran it, then retired
        assert fourth["worker"] != third["worker"] and fourth["status"] == "ok"
    finally:
        while harness._idle_runners:
            harness._idle_runners.pop().kill()
