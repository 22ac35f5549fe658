"""The passively safe sampler's options: `start_range_m` (rejection on the start distance) and
`point_at_target` (the chaser's initial capture axis on the line of sight); nothing is run.
"""

import math

import numpy as np
import pytest

from rpod.diagrams.scenario import ScenarioError
from rpod.models.cw import safe_ellipse_semi_axes
from rpod.models.frames import rotation_from_rpy_deg
from rpod.models.gravity import R_EARTH_M, mean_motion
from rpod.scenarios import sampling
from rpod.scenarios.campaign import draw_sample, load_campaign, plan_runs
from rpod.scenarios.loader import ScenarioFileError

# A0 from 5 m and B0 up to 30 m: starts from 5 m to ~85 m, so both bounds reject.
WIDE = """\
base: coast
sample:
  count: {count}
  seed: 5
  passively_safe:
    radial_m: {{dist: uniform, low: 5.0, high: 40.0}}
    cross_track_m: {{dist: uniform, low: 0.0, high: 30.0}}
{extra}"""
RANGE = "    start_range_m: {low: 15.0, high: 50.0}\n"


def campaign_from(text: str, tmp_path, name: str = "c"):
    path = tmp_path / f"{name}.yaml"
    path.write_text(text)
    return load_campaign(str(path))


def ranges(runs) -> np.ndarray:
    return np.array([np.linalg.norm(r.overrides["chaser.p_LC_L"]) for r in runs])


def test_every_start_is_within_the_range(tmp_path):
    campaign = campaign_from(WIDE.format(count=200, extra=RANGE), tmp_path)
    runs = plan_runs(campaign)
    assert len(runs) == 200
    r = ranges(runs)
    assert np.all((r >= 15.0) & (r <= 50.0)), (r.min(), r.max())
    draws = [draw_sample(campaign.sample, k)[1] for k in range(200)]
    assert max(d["attempts"] for d in draws) > 1  # both bounds do reject here
    # Without the bound, the same seed puts many starts outside: the bound is what holds them.
    unbounded = ranges(plan_runs(campaign_from(WIDE.format(count=200, extra=""), tmp_path, "u")))
    assert np.mean((unbounded < 15.0) | (unbounded > 50.0)) > 0.2


def test_the_recorded_draw_is_the_accepted_one(tmp_path):
    campaign = campaign_from(WIDE.format(count=40, extra=RANGE), tmp_path)
    for run in plan_runs(campaign):
        draw = draw_sample(campaign.sample, run.sample_index)[1]
        state = np.array(run.overrides["chaser.p_LC_L"] + run.overrides["chaser.v_LC_L"])
        n = mean_motion(R_EARTH_M + campaign.base.orbit.altitude_m)
        A0, _, B0 = safe_ellipse_semi_axes(state, n)
        assert A0 == pytest.approx(draw["radial_m"], rel=1e-12)
        assert B0 == pytest.approx(draw["cross_track_m"], rel=1e-9, abs=1e-9)
        assert sampling.start_range(draw) == pytest.approx(np.linalg.norm(state[:3]), rel=1e-12)
        assert draw["attempts"] >= 1


def test_same_seed_same_draws_and_first_attempts_unchanged(tmp_path):
    text = WIDE.format(count=60, extra=RANGE)
    first = plan_runs(campaign_from(text, tmp_path, "a"))
    second = plan_runs(campaign_from(text, tmp_path, "b"))
    assert [(r.run_id, r.overrides) for r in first] == [(r.run_id, r.overrides) for r in second]
    # A sample accepted at its first attempt is the draw the sampler makes without the bound,
    # so adding start_range_m only changes the rejected samples.
    bounded = campaign_from(text, tmp_path, "a").sample
    plain = campaign_from(WIDE.format(count=60, extra=""), tmp_path, "p").sample
    accepted_first = 0
    for k in range(60):
        draw = draw_sample(bounded, k)[1]
        other = draw_sample(plain, k)[1]
        if draw["attempts"] == 1:
            accepted_first += 1
            assert draw == other
        else:
            assert draw != other
    assert 0 < accepted_first < 60
    other_seed = plan_runs(campaign_from(text, tmp_path, "a").with_seed(6))
    assert not {r.run_id for r in first} & {r.run_id for r in other_seed}


def passively_safe(options: str) -> str:
    return (
        "base: coast\nsample:\n  count: 3\n  passively_safe:\n"
        "    radial_m: {dist: uniform, low: 15.0, high: 25.0}\n"
        "    cross_track_m: 10.0\n" + options
    )


BAD = [
    (
        "low_not_below_high",
        passively_safe("    start_range_m: {low: 50.0, high: 50.0}\n"),
        "sample.passively_safe.start_range_m.high",
    ),
    (
        "low_negative",
        passively_safe("    start_range_m: {low: -1.0, high: 50.0}\n"),
        "sample.passively_safe.start_range_m.low",
    ),
    (
        "unknown_bound",
        passively_safe("    start_range_m: {low: 15.0, mid: 20.0, high: 50.0}\n"),
        "sample.passively_safe.start_range_m.mid",
    ),
    (
        "missing_bound",
        passively_safe("    start_range_m: {low: 15.0}\n"),
        "sample.passively_safe.start_range_m.high",
    ),
    (
        "not_a_mapping",
        passively_safe("    start_range_m: [15.0, 50.0]\n"),
        "sample.passively_safe.start_range_m",
    ),
    (
        "not_a_number",
        passively_safe("    start_range_m: {low: near, high: 50.0}\n"),
        "sample.passively_safe.start_range_m.low",
    ),
    (
        "unknown_key",
        passively_safe("    start_range: {low: 15.0, high: 50.0}\n"),
        "sample.passively_safe.start_range",
    ),
    (
        # A0 <= 25 m and B0 = 10 m: never beyond sqrt(4 * 25^2 + 10^2) ~ 51 m.
        "range_out_of_reach",
        passively_safe("    start_range_m: {low: 60.0, high: 80.0}\n"),
        "sample.passively_safe.start_range_m",
    ),
    (
        # A0 >= 15 m: never closer than 15 m.
        "range_below_reach",
        passively_safe("    start_range_m: {low: 1.0, high: 10.0}\n"),
        "sample.passively_safe.start_range_m",
    ),
    (
        # Fixed phases: the start is always A0 = 10 m away, which the parse-time check cannot
        # see; the sampler gives up after its attempts.
        "range_never_met",
        (
            "base: coast\nsample:\n  count: 3\n  passively_safe:\n    radial_m: 10.0\n"
            "    phase_deg: 0.0\n    cross_track_phase_deg: 0.0\n"
            "    start_range_m: {low: 12.0, high: 15.0}\n"
        ),
        "sample.passively_safe.start_range_m: sample 0: no draw",
    ),
    (
        "point_at_target_not_bool",
        passively_safe("    point_at_target: 1\n"),
        "sample.passively_safe.point_at_target",
    ),
    (
        "point_at_target_conflict",
        passively_safe("    point_at_target: true\n")
        + "  fields: {chaser.rpy_LC_deg: {dist: uniform, low: 0.0, high: 1.0}}\n",
        "sample.fields.chaser.rpy_LC_deg",
    ),
    (
        "point_at_target_grid_conflict",
        passively_safe("    point_at_target: true\n") + "grid: {'chaser.rpy_LC_deg[0]': [1.0]}\n",
        "sample.passively_safe",
    ),
]


@pytest.mark.parametrize("case, text, where", BAD, ids=[c[0] for c in BAD])
def test_bad_sampler_options_name_the_field(tmp_path, case, text, where):
    path = tmp_path / f"{case}.yaml"
    path.write_text(text)
    with pytest.raises(ScenarioFileError) as error:
        plan_runs(load_campaign(str(path)))
    message = str(error.value)
    assert message.startswith(f"{path}: {where}"), message
    assert "\n" not in message


def test_parse_errors_are_scenario_errors_with_the_location():
    with pytest.raises(ScenarioError) as error:
        sampling.parse_passively_safe(
            {"radial_m": 10.0, "start_range_m": {"low": 5.0, "high": 1.0}}, "ps"
        )
    assert error.value.field == "ps.start_range_m.high"


def test_point_at_target_puts_the_capture_axis_on_the_line_of_sight(tmp_path):
    campaign = campaign_from(
        WIDE.format(count=30, extra=RANGE + "    point_at_target: true\n")
        + "grid: {chaser.capture_point_C: [[0.0, 0.0, 0.75], [0.5, -0.3, 0.2]]}\n",
        tmp_path,
    )
    runs = plan_runs(campaign)
    assert len(runs) == 60
    for run in runs:
        c = np.array(run.grid_point["chaser.capture_point_C"])
        c = c / np.linalg.norm(c)
        p = np.array(run.overrides["chaser.p_LC_L"])
        los = -p / np.linalg.norm(p)
        R_LC = rotation_from_rpy_deg(run.overrides["chaser.rpy_LC_deg"])
        np.testing.assert_allclose(R_LC @ c, los, atol=1e-9)
        # The least rotation: its angle is the angle between the capture axis and the line of
        # sight (any other rotation taking c onto los turns further).
        angle = math.acos(np.clip((np.trace(R_LC) - 1.0) / 2.0, -1.0, 1.0))
        assert angle == pytest.approx(math.acos(np.clip(c @ los, -1.0, 1.0)), abs=1e-7)
    # Off (or absent), the attitude is the base's and the runs are the same as without the key.
    off = plan_runs(
        campaign_from(
            WIDE.format(count=5, extra=RANGE + "    point_at_target: false\n"), tmp_path, "off"
        )
    )
    absent = plan_runs(campaign_from(WIDE.format(count=5, extra=RANGE), tmp_path, "absent"))
    assert all("chaser.rpy_LC_deg" not in r.overrides for r in off)
    assert [r.run_id for r in off] == [r.run_id for r in absent]


def test_pointing_handles_the_antiparallel_case():
    # The capture axis +z_C at the identity attitude points away from the target.
    rpy = sampling.pointing_rpy_deg([0.0, 0.0, 10.0], [0.0, 0.0, 2.7])
    R_LC = rotation_from_rpy_deg(rpy)
    np.testing.assert_allclose(R_LC @ [0.0, 0.0, 1.0], [0.0, 0.0, -1.0], atol=1e-9)
    np.testing.assert_allclose(R_LC @ R_LC.T, np.eye(3), atol=1e-12)
    # Parallel: the identity.
    np.testing.assert_allclose(
        sampling.pointing_rpy_deg([0.0, 0.0, -10.0], [0, 0, 2.7]), 0.0, atol=1e-9
    )


def test_bundled_soft_capture_250_starts_15_to_50_m_away_on_the_line_of_sight():
    campaign = load_campaign("soft_capture_250")
    runs = plan_runs(campaign)
    assert len(runs) == 250
    r = ranges(runs)
    assert np.all((r >= 15.0) & (r <= 50.0)), (r.min(), r.max())
    c = np.array(campaign.base.chaser.capture_point_C)
    c = c / np.linalg.norm(c)
    for run in runs:
        p = np.array(run.overrides["chaser.p_LC_L"])
        R_LC = rotation_from_rpy_deg(run.overrides["chaser.rpy_LC_deg"])
        np.testing.assert_allclose(R_LC @ c, -p / np.linalg.norm(p), atol=1e-9)
