"""rpod.scenarios.store: a run planned on another CPU (its start differing in the last bits, so
its run id too) is the same scenario, found by its place in the plan and its overrides; a
start that truly differs is not, and `ResultStore.reuse` records only the same scenarios."""

import numpy as np
import pytest

from rpod.scenarios.campaign import PlannedRun
from rpod.scenarios.store import (
    START_RTOL,
    STORE_NAME,
    ResultStore,
    counterparts,
    same_overrides,
)

# A start as the shoot-out's sampler writes it: the rpy's last digit is what another CPU changes.
START = {
    "controller": {"!tag": "LosCorridor", "mpc": {"horizon": 40}},
    "chaser.p_LC_L": [-5.640524388693006, -34.39611850499749, 17.094700507709316],
    "chaser.rpy_LC_deg": [-116.42714875354147, 8.35421525570351, -13.443025372421223],
    "target.w_IT_T_deg_s": [5.778264846227433, 0.0, -0.015636033897817054],
}


def _other_cpu(overrides: dict) -> dict:
    """The same start as the AVX-512 machine of the shoot-out's first flight sampled it."""
    shifted = {**overrides, "chaser.rpy_LC_deg": list(overrides["chaser.rpy_LC_deg"])}
    shifted["chaser.rpy_LC_deg"][0] = float(np.nextafter(shifted["chaser.rpy_LC_deg"][0], 0.0))
    shifted["chaser.rpy_LC_deg"][2] = -13.443025372421216  # as stored by that flight
    shifted["target.w_IT_T_deg_s"] = [5.778264846227433, 3e-17, -0.015636033897817054]
    return shifted


def test_the_same_start_to_its_last_bits_is_the_same_scenario_and_another_start_is_not():
    assert same_overrides(START, _other_cpu(START))
    moved = _other_cpu(START)
    moved["chaser.p_LC_L"] = [-5.640524388693006 * (1 + 10 * START_RTOL), -34.4, 17.09]
    assert not same_overrides(START, moved)
    assert not same_overrides(START, {**START, "controller": {"!tag": "CoupledNmpc"}})
    assert not same_overrides(START, {**START, "chaser.mass_kg": 300.0})  # another field
    assert not same_overrides({"n": 3}, {"n": 3.0})  # another type is another scenario


def _row(run_id, overrides, sample_index=7, case="los_corridor", status="ok", flown="t1"):
    return {
        "run_id": run_id,
        "grp": "g",
        "case_name": case,
        "grid_point": {},
        "sample_index": sample_index,
        "overrides": overrides,
        "status": status,
        "finished_at": flown,
    }


def test_counterparts_match_by_id_then_by_place_and_start():
    other_cpu = [
        _row("same-id", START, sample_index=1),
        _row("avx512-id", _other_cpu(START), sample_index=2),
        _row("elsewhere", _other_cpu(START), sample_index=3, case="soft_capture"),
    ]
    planned = [
        _row("same-id", START, sample_index=1),
        _row("this-cpu-id", START, sample_index=2),
        _row("not-there", START, sample_index=3),  # same start, another case: not the same run
    ]
    matches = counterparts(planned, other_cpu)
    assert {key: row["run_id"] for key, row in matches.items()} == {
        "same-id": "same-id",
        "this-cpu-id": "avx512-id",
    }


def test_without_a_shared_base_only_ids_pair():
    """The same overrides on another base (a default of the base scenario changed) may be
    another scenario: pairing by start needs the base in common."""
    others = [_row("avx512-id", _other_cpu(START), sample_index=2)]
    assert counterparts([_row("this-cpu-id", START, sample_index=2)], others, by_start=False) == {}


@pytest.mark.parametrize("fingerprints, paired", [(("b1", "b1"), 2), (("b1", "b2"), 0)])
def test_reuse_records_a_start_planned_on_another_cpu_from_the_same_base(
    tmp_path, fingerprints, paired
):
    def store(folder, overrides_of, fingerprint):
        folder.mkdir()
        runs = [
            PlannedRun(f"{folder.name}-{i}", i, "g", "los_corridor", {}, i, overrides_of(i))
            for i in range(3)
        ]
        result = ResultStore(folder / STORE_NAME)
        result.write_plan({"campaign_name": "t", "base_fingerprint": fingerprint}, runs)
        return result

    def start(i):
        return {**START, "chaser.p_LC_L": [float(i), -34.0, 17.0]}

    with store(tmp_path / "avx512", lambda i: _other_cpu(start(i)), fingerprints[0]) as earlier:
        for i in (0, 2):
            earlier.record(f"avx512-{i}", {"status": "ok", "metrics": {"k": i}, "worker": "w"})
        with store(tmp_path / "here", start, fingerprints[1]) as here:
            assert here.reuse(earlier, "first") == paired
            rows = {row["run_id"]: row for row in here.rows()}
    if paired:
        assert [rows[f"here-{i}"]["status"] for i in range(3)] == ["ok", "pending", "ok"]
        assert rows["here-2"]["metrics"] == {"k": 2}
        assert rows["here-2"]["worker"] == "reused from first"
    else:
        assert all(row["status"] == "pending" for row in rows.values())
