"""`rpod run --set a.b=value` (the campaigns' dotted paths from the command line, with the same
one-line errors) and `rpod sweep --rerun RUN_ID` (one stored case again, with every output)."""

import json

import numpy as np
import pytest

from rpod.diagrams.simulate import simulate
from rpod.scenarios import cli
from rpod.scenarios.campaign import apply_overrides, load_campaign, plan_runs

SHORT_HOLD = ["--set", "duration_s=20.0", "--set", "log_period_s=1.0", "--no-record", "--no-plots"]


def test_set_overrides_fields_with_yaml_values(tmp_path):
    out = tmp_path / "out"
    argv = ["run", "hold_point", "--out", str(out), *SHORT_HOLD,
            "--set", "chaser.mass_kg=4e2", "--set", "chaser.p_LC_L=[0.0, -35.0, 1.0]",
            "--set", "controller.hold_distance_m=12"]  # fmt: skip
    assert cli.main(argv) in (0, 3)  # 20 s is too short to reach the hold point: exit 3
    written = (out / "scenario.yaml").read_text()
    assert "mass_kg: 400.0" in written and "hold_distance_m: 12.0" in written
    log = np.load(out / "log.npz")
    np.testing.assert_allclose(log["p_LC_L"][0], [0.0, -35.0, 1.0], atol=1e-12)  # via ECI
    assert log["t"][-1] == pytest.approx(20.0)


@pytest.mark.parametrize(
    "setting, phrase",
    [
        ("chaser.mas_kg=1", "unknown field 'mas_kg' of chaser"),
        ("chaser.mass_kg=-5", "chaser.mass_kg: must be positive"),
        ("chaser.mass_kg=heavy", "chaser.mass_kg: expected a number"),
        ("no_equals_sign", "expected FIELD=VALUE"),
        ("controller.planner.dt_s=2", "controller is !HoldPoint, which has no field 'planner'"),
        ("chaser.p_LC_L=[1, 2", "YAML syntax error"),
    ],
)
def test_a_bad_set_is_one_line_naming_the_flag(tmp_path, capsys, setting, phrase):
    out = tmp_path / "out"
    assert cli.main(["run", "hold_point", "--out", str(out), "--set", setting]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith("rpod: error: ") and phrase in line and "--set" in line
    assert not out.exists()


CAMPAIGN = """\
base: coast
overrides: {duration_s: 60.0, log_period_s: 5.0}
grid:
  chaser.p_LC_L[1]: [-50.0, -80.0]
"""


def test_rerun_replays_one_case_with_every_output_and_leaves_the_store_alone(tmp_path, capsys):
    campaign_file = tmp_path / "c.yaml"
    campaign_file.write_text(CAMPAIGN)
    runs = plan_runs(load_campaign(str(campaign_file)))
    wanted = runs[1]
    out = tmp_path / "out"
    argv = ["sweep", str(campaign_file), "--out", str(out), "--rerun", wanted.run_id[:6]]
    assert cli.main(argv) == 0
    folder = out / "rerun" / wanted.run_id
    assert {"summary.json", "log.npz", "recording.html", "scenario.yaml", "plots"} <= {
        p.name for p in folder.iterdir()
    }
    assert not (out / "results.sqlite").exists()  # a rerun is not a campaign run
    summary = json.loads((folder / "summary.json").read_text())
    # The same case simulated here: the same numbers (bit-identical on one machine).
    expected = simulate(apply_overrides(load_campaign(str(campaign_file)).base, wanted.overrides))
    assert summary["final_p_LC_L"] == expected.summary["final_p_LC_L"]
    assert wanted.run_id in capsys.readouterr().out


def test_rerun_of_an_unknown_id_is_one_line(tmp_path, capsys):
    campaign_file = tmp_path / "c.yaml"
    campaign_file.write_text(CAMPAIGN)
    argv = ["sweep", str(campaign_file), "--out", str(tmp_path / "out"), "--rerun", "zzzz"]
    assert cli.main(argv) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert "--rerun zzzz: matches no run" in line and "2 runs" in line
    assert not (tmp_path / "out").exists()
