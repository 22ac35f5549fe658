"""`rpod run` on an estimate: one `--set` flies any scenario on `navigation: !Ekf`, and the line,
summary.json and the plots say that it did and how good the estimate was; a sensor that never
sees the target is one line naming the field."""

import json

from campaign_helpers import run_rpod_in_process


def test_a_run_on_the_estimate_says_so(tmp_path):
    out = tmp_path / "out"
    process = run_rpod_in_process(
        "run", "hold_point", "--no-record", "--out", out,
        "--set", "navigation=!Ekf {}", "--set", "duration_s=30",
        cwd=tmp_path,
    )  # fmt: skip
    assert process.returncode in (0, 3), process.stderr
    line = process.stdout.strip().splitlines()[-1]
    assert "on the EKF's estimate (position RMS" in line and "fixes rejected" in line
    summary = json.loads((out / "summary.json").read_text())
    assert list(summary)[:2] == ["scenario", "status"]
    assert summary["navigation"]["estimator"] == "ekf"
    assert "navigation.png" in summary["plots"]
    assert "navigation: !Ekf" in (out / "scenario.yaml").read_text()


def test_a_sensor_that_never_sees_the_target_is_one_line(tmp_path):
    process = run_rpod_in_process(
        "run", "hold_point", "--no-record", "--out", tmp_path / "out",
        "--set", "navigation=!Ekf {boresight_C: [0, -1, 0], pose_sensor: {half_fov_deg: 1}}",
        cwd=tmp_path,
    )  # fmt: skip
    assert process.returncode == 2, process.stderr
    (line,) = process.stderr.strip().splitlines()
    assert line.startswith("rpod: error: hold_point") and "navigation.lead_in_s" in line
    assert not (tmp_path / "out").exists()  # nothing left behind


def test_a_campaign_reaches_into_the_navigation_block_and_the_seed(tmp_path):
    from rpod.scenarios.campaign import apply_overrides, load_campaign, plan_runs

    campaign = tmp_path / "nav.yaml"
    campaign.write_text(
        "base: hold_point\n"
        "overrides:\n"
        "  navigation: !Ekf {lead_in_s: 10.0}\n"
        "grid:\n"
        "  navigation.noise_scale: [0.0, 3.0]\n"
        "  seed: [0, 1]\n"
    )
    loaded = load_campaign(str(campaign))
    flown = [apply_overrides(loaded.base, run.overrides) for run in plan_runs(loaded)]
    assert [(s.navigation.noise_scale, s.seed) for s in flown] == [
        (0.0, 0), (0.0, 1), (3.0, 0), (3.0, 1)
    ]  # fmt: skip
    assert all(s.navigation.lead_in_s == 10.0 for s in flown)
