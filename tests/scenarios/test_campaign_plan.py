"""Campaign files without running anything: the plan, run ids, overrides, samplers, bad input.

Statistical checks draw many samples with fixed seeds; their tolerances are 5 standard errors
of the estimated quantity, so a correct sampler fails them with probability < 1e-6 (and, the
seed being fixed, the outcome is deterministic).
"""

import dataclasses
import json
import math
import subprocess
import sys

import numpy as np
import pytest
from campaign_helpers import SMALL_CAMPAIGN, run_rpod

from rpod.diagrams.scenario import ScenarioError
from rpod.diagrams.simulate import simulate
from rpod.models.cw import cw_state_transition, safe_ellipse_semi_axes
from rpod.models.frames import rotation_from_wxyz
from rpod.models.gravity import R_EARTH_M, mean_motion
from rpod.scenarios import sampling
from rpod.scenarios.campaign import (
    apply_overrides,
    bundled_campaigns,
    draw_sample,
    load_campaign,
    plan_runs,
)
from rpod.scenarios.loader import ScenarioFileError, dump_scenario, load_scenario


def campaign_from(text: str, tmp_path, name: str = "c"):
    path = tmp_path / f"{name}.yaml"
    path.write_text(text)
    return load_campaign(str(path))


# ------------------------------------------------------------------------------ plan and ids


def test_small_campaign_plan_is_the_full_product(tmp_path):
    runs = plan_runs(campaign_from(SMALL_CAMPAIGN, tmp_path))
    assert len(runs) == 2 * 2 * 2
    assert len({r.run_id for r in runs}) == len(runs)
    assert len({r.group for r in runs}) == 4  # the grid points; samples share a group
    assert {r.sample_index for r in runs} == {0, 1}
    # Common random numbers: sample k has the same draws in every grid point.
    for k in (0, 1):
        draws = {
            json.dumps(r.overrides["target.w_IT_T_deg_s"]) for r in runs if r.sample_index == k
        }
        assert len(draws) == 1


def test_same_file_and_seed_give_the_same_runs_and_ids(tmp_path):
    first = plan_runs(campaign_from(SMALL_CAMPAIGN, tmp_path, "a"))
    second = plan_runs(campaign_from(SMALL_CAMPAIGN, tmp_path, "b"))  # another file, same text
    assert [(r.run_id, r.overrides) for r in first] == [(r.run_id, r.overrides) for r in second]


def test_different_seed_gives_different_runs(tmp_path):
    campaign = campaign_from(SMALL_CAMPAIGN, tmp_path)
    first = plan_runs(campaign)
    other = plan_runs(campaign.with_seed(12))
    assert not {r.run_id for r in first} & {r.run_id for r in other}
    for a, b in zip(first, other):
        assert a.overrides["target.w_IT_T_deg_s"] != b.overrides["target.w_IT_T_deg_s"]
        assert a.grid_point == b.grid_point  # only the draws change


def test_ids_are_the_same_in_another_process(tmp_path):
    """No dependence on hash randomisation or on anything but the file (PYTHONHASHSEED differs)."""
    path = tmp_path / "c.yaml"
    path.write_text(SMALL_CAMPAIGN)
    code = (
        "import json, sys; from rpod.scenarios.campaign import load_campaign, plan_runs; "
        "print(json.dumps([r.run_id for r in plan_runs(load_campaign(sys.argv[1]))]))"
    )
    process = subprocess.run(
        [sys.executable, "-c", code, str(path)],
        capture_output=True,
        text=True,
        timeout=120,
        env={"PYTHONHASHSEED": "12345", **__import__("os").environ},
        check=False,
    )
    assert process.returncode == 0, process.stderr
    assert json.loads(process.stdout) == [r.run_id for r in plan_runs(load_campaign(str(path)))]


def test_id_of_a_run_does_not_depend_on_the_other_runs(tmp_path):
    base = "base: coast\noverrides: {duration_s: 20.0}\n"
    one = plan_runs(
        campaign_from(
            base + "cases:\n  - {name: b, overrides: {chaser.mass_kg: 300.0}}\n", tmp_path, "one"
        )
    )
    two = plan_runs(
        campaign_from(
            base + "cases:\n  - {name: a, overrides: {chaser.mass_kg: 200.0}}\n"
            "  - {name: b, overrides: {chaser.mass_kg: 300.0}}\n",
            tmp_path,
            "two",
        )
    )
    assert one[0].run_id == two[1].run_id
    # A grid listing the same value gives the same run as the case (same base + overrides).
    grid = plan_runs(
        campaign_from(base + "grid: {chaser.mass_kg: [100.0, 300.0]}\n", tmp_path, "g")
    )
    assert grid[1].run_id == one[0].run_id


def test_more_samples_keep_the_first_ones(tmp_path):
    text = SMALL_CAMPAIGN.replace("count: 2", "count: 5")
    longer = plan_runs(campaign_from(text, tmp_path, "long"))
    shorter = plan_runs(campaign_from(SMALL_CAMPAIGN, tmp_path, "short"))
    long_ids = {r.run_id for r in longer}
    assert {r.run_id for r in shorter} <= long_ids


def test_an_extra_sampled_field_does_not_change_the_others(tmp_path):
    campaign = campaign_from(SMALL_CAMPAIGN, tmp_path, "a")
    extra = campaign_from(
        SMALL_CAMPAIGN + "    chaser.mass_kg: {dist: uniform, low: 400, high: 600}\n", tmp_path, "b"
    )
    for k in range(3):
        assert (
            draw_sample(campaign.sample, k)[0]["target.w_IT_T_deg_s"]
            == draw_sample(extra.sample, k)[0]["target.w_IT_T_deg_s"]
        )


def test_id_changes_with_the_base(tmp_path):
    first = plan_runs(campaign_from(SMALL_CAMPAIGN, tmp_path, "a"))
    changed = plan_runs(
        campaign_from(
            SMALL_CAMPAIGN.replace("log_period_s: 5.0", "log_period_s: 4.0"), tmp_path, "b"
        )
    )
    assert not {r.run_id for r in first} & {r.run_id for r in changed}


def test_overrides_reach_the_simulation(tmp_path):
    """A planned run simulates exactly like the same scenario edited by hand."""
    runs = plan_runs(campaign_from(SMALL_CAMPAIGN, tmp_path))
    run = runs[-1]
    campaign = campaign_from(SMALL_CAMPAIGN, tmp_path)
    _, coast = load_scenario("coast")
    by_hand = dataclasses.replace(
        coast,
        duration_s=run.grid_point["duration_s"],
        log_period_s=5.0,
        chaser=dataclasses.replace(
            coast.chaser,
            p_LC_L=[
                coast.chaser.p_LC_L[0],
                run.grid_point["chaser.p_LC_L[1]"],
                coast.chaser.p_LC_L[2],
            ],
            v_LC_L=coast.chaser.v_LC_L[:2] + [run.overrides["chaser.v_LC_L[2]"]],
        ),
        target=dataclasses.replace(coast.target, w_IT_T_deg_s=run.overrides["target.w_IT_T_deg_s"]),
    )
    planned = apply_overrides(campaign.base, run.overrides)
    # As YAML: Drake's SimulatorConfig (a bound C++ type) has no value equality.
    assert dump_scenario(planned) == dump_scenario(by_hand)
    assert simulate(planned).summary["final_p_LC_L"] == simulate(by_hand).summary["final_p_LC_L"]


def test_apply_overrides_does_not_touch_the_base(tmp_path):
    campaign = campaign_from(SMALL_CAMPAIGN, tmp_path)
    before = dump_scenario(campaign.base)
    apply_overrides(campaign.base, {"chaser.p_LC_L[1]": -1.0, "chaser.mass_kg": 1})
    assert dump_scenario(campaign.base) == before


def test_nested_override_mappings_are_flattened(tmp_path):
    campaign = campaign_from(
        "base: coast\ncases:\n  - name: x\n    overrides: {chaser: {mass_kg: 321}}\n", tmp_path
    )
    (run,) = plan_runs(campaign)
    assert run.overrides == {"chaser.mass_kg": 321}
    assert apply_overrides(campaign.base, run.overrides).chaser.mass_kg == 321.0


def test_a_tagged_override_keeps_its_tag_through_json(tmp_path):
    """A case choosing a union member (`navigation: !Ekf {}`) reaches a worker as JSON; the tag
    must survive it (a lost tag chose the union's first member: the run flew truth-fed) and
    must be part of the run id."""
    campaign = campaign_from(
        "base: hold_point\ncases:\n"
        "  - name: truth\n    overrides: {}\n"
        "  - name: ekf\n    overrides: {navigation: !Ekf {}}\n"
        "  - name: ekf_noisier\n    overrides: {navigation: !Ekf {noise_scale: 3.0}}\n",
        tmp_path,
    )
    truth, ekf, noisier = plan_runs(campaign)
    assert type(apply_overrides(campaign.base, truth.overrides).navigation).__name__ == "Truth"
    for run, scale in ((ekf, 1.0), (noisier, 3.0)):
        sent = json.loads(json.dumps(run.overrides))  # what the worker reads
        navigation = apply_overrides(campaign.base, sent).navigation
        assert type(navigation).__name__ == "Ekf" and navigation.noise_scale == scale
    assert len({truth.run_id, ekf.run_id, noisier.run_id}) == 3


def test_bundled_demo_sweep_has_at_least_8_runs():
    assert "demo_sweep" in bundled_campaigns()
    campaign = load_campaign("demo_sweep")
    runs = plan_runs(campaign)
    assert len(runs) >= 8 and campaign.description
    assert len(campaign.grid) == 2  # so that `rpod report` draws 2-D maps


# ------------------------------------------------------------------------------ samplers

N = 20000


def draws(spec: dict, count: int = N, key: str = "x"):
    distribution = sampling.parse_distribution(spec, key)
    rng = np.random.default_rng(5)
    return np.array([distribution.draw(rng) for _ in range(count)], dtype=object)


def test_uniform_normal_log_uniform_statistics():
    u = draws({"dist": "uniform", "low": 2.0, "high": 5.0}).astype(float)
    assert u.min() >= 2.0 and u.max() < 5.0
    assert abs(u.mean() - 3.5) < 5 * (3.0 / math.sqrt(12)) / math.sqrt(N)
    g = draws({"dist": "normal", "mean": -1.0, "std": 0.5}).astype(float)
    assert abs(g.mean() + 1.0) < 5 * 0.5 / math.sqrt(N)
    assert abs(g.std() - 0.5) < 5 * 0.5 / math.sqrt(2 * N)
    lu = draws({"dist": "log_uniform", "low": 0.01, "high": 100.0}).astype(float)
    assert lu.min() >= 0.01 and lu.max() < 100.0
    logs = np.log10(lu)  # uniform on [-2, 2]: mean 0, std 4/sqrt(12)
    assert abs(logs.mean()) < 5 * (4 / math.sqrt(12)) / math.sqrt(N)


def test_vector_parameters_draw_vectors():
    v = np.array(list(draws({"dist": "uniform", "low": [0, 10, 20], "high": [1, 11, 21]}, 500)))
    assert v.shape == (500, 3)
    assert np.all(v >= [0, 10, 20]) and np.all(v < [1, 11, 21])


def test_choice_follows_its_weights():
    picks = draws({"dist": "choice", "values": ["a", "b", [1, 2]], "weights": [1, 3, 0]})
    share_b = np.mean([p == "b" for p in picks])
    assert abs(share_b - 0.75) < 5 * math.sqrt(0.75 * 0.25 / N)
    assert not any(p == [1, 2] for p in picks)  # weight 0 is never drawn


def test_direction_is_uniform_on_the_sphere():
    v = np.array(list(draws({"dist": "direction", "scale": 2.0}))).astype(float)
    np.testing.assert_allclose(np.linalg.norm(v, axis=1), 2.0, rtol=1e-12)
    # Uniform on the sphere: each component has mean 0 and E[u_i^2] = 1/3 (std of u_i^2: 0.298).
    u = v / 2.0
    assert np.all(np.abs(u.mean(axis=0)) < 5 * math.sqrt(1 / 3) / math.sqrt(N))
    assert np.all(np.abs((u**2).mean(axis=0) - 1 / 3) < 5 * 0.298 / math.sqrt(N))


def test_direction_with_a_random_scale():
    v = np.array(
        list(draws({"dist": "direction", "scale": {"dist": "uniform", "low": 1, "high": 3}}, 2000))
    ).astype(float)
    norms = np.linalg.norm(v, axis=1)
    assert norms.min() >= 1.0 and norms.max() < 3.0


def test_attitude_is_uniform_on_so3():
    q = np.array(list(draws({"dist": "attitude"}, 5000))).astype(float)
    np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1.0, rtol=1e-12)
    assert np.all(q[:, 0] >= 0.0)
    # Haar measure: E[R] = 0 (each entry of R has mean 0 and variance 1/3).
    mean_R = np.mean([rotation_from_wxyz(qi) for qi in q], axis=0)
    assert np.all(np.abs(mean_R) < 5 * math.sqrt(1 / 3) / math.sqrt(len(q)))
    # The rotation angle theta in [0, pi] has density (1 - cos theta) / pi, so
    # E[theta] = pi/2 + 2/pi and its standard deviation is sqrt(pi^2/3 + 2 - E[theta]^2) = 0.646.
    theta = 2 * np.arccos(np.clip(q[:, 0], -1, 1))
    assert abs(theta.mean() - (math.pi / 2 + 2 / math.pi)) < 5 * 0.65 / math.sqrt(len(q))


def test_passively_safe_states_satisfy_paper_000_eqs_6_7(tmp_path):
    campaign = campaign_from(
        "base: coast\nsample:\n  count: 50\n  seed: 3\n  passively_safe:\n"
        "    radial_m: {dist: uniform, low: 15.0, high: 50.0}\n"
        "    cross_track_m: {dist: log_uniform, low: 1.0, high: 20.0}\n"
        "grid: {orbit.altitude_m: [400000.0, 900000.0]}\n",
        tmp_path,
    )
    runs = plan_runs(campaign)
    for run in runs:
        n = mean_motion(R_EARTH_M + run.grid_point["orbit.altitude_m"])  # the run's own orbit
        state = np.array(run.overrides["chaser.p_LC_L"] + run.overrides["chaser.v_LC_L"])
        x, y, _, vx, vy, _ = state
        assert vy == pytest.approx(-2.0 * n * x, rel=1e-12, abs=1e-15)  # eq. 6: no drift
        assert y == pytest.approx(2.0 * vx / n, rel=1e-12, abs=1e-12)  # eq. 6: centred
        draw = draw_sample(campaign.sample, run.sample_index)[1]
        A0, along, B0 = safe_ellipse_semi_axes(state, n)  # eq. 7
        assert A0 == pytest.approx(draw["radial_m"], rel=1e-12)
        assert B0 == pytest.approx(draw["cross_track_m"], rel=1e-12)
        assert 15.0 <= A0 < 50.0 and along == 2 * A0
        # Independent check: the exact CW flow brings it back after 10 periods (no secular
        # drift; 1e-6 m is ~1e5 times the rounding of 10 periods of a 50 m orbit).
        period = 2 * math.pi / n
        np.testing.assert_allclose(cw_state_transition(n, 10 * period) @ state, state, atol=1e-6)


# ------------------------------------------------------------------------------ bad input


def sampled(spec: str, field: str = "chaser.mass_kg", count: int = 2) -> str:
    """A campaign sampling one field of coast with the distribution `spec` (YAML flow text)."""
    return f"base: coast\nsample: {{count: {count}, fields: {{{field}: {spec}}}}}\n"


BAD_CAMPAIGNS = [
    ("unknown_field", "base: coast\ngrid: {chaser.mas_kg: [1.0, 2.0]}\n", "grid.chaser.mas_kg"),
    ("unknown_group", "base: coast\ngrid: {chasr.mass_kg: [1.0]}\n", "grid.chasr.mass_kg"),
    (
        "index_on_scalar",
        "base: coast\ngrid: {'chaser.mass_kg[0]': [1.0]}\n",
        "grid.chaser.mass_kg[0]",
    ),
    ("empty_grid_values", "base: coast\ngrid: {chaser.mass_kg: []}\n", "grid.chaser.mass_kg"),
    ("empty_grid", "base: coast\ngrid: {}\n", "grid"),
    ("wrong_type", "base: coast\ngrid: {chaser.mass_kg: [1.0, heavy]}\n", "grid.chaser.mass_kg[1]"),
    ("invalid_value", "base: coast\ngrid: {chaser.mass_kg: [1.0, -5.0]}\n", "grid.chaser.mass_kg"),
    (
        "duplicate_value",
        "base: coast\ngrid: {chaser.mass_kg: [1.0, 1.0]}\n",
        "grid.chaser.mass_kg[1]",
    ),
    (
        "uniform_high_below_low",
        sampled("{dist: uniform, low: 5, high: 1}"),
        "sample.fields.chaser.mass_kg.high",
    ),
    (
        "normal_negative_std",
        sampled("{dist: normal, mean: 5, std: -1}"),
        "sample.fields.chaser.mass_kg.std",
    ),
    (
        "log_uniform_zero",
        sampled("{dist: log_uniform, low: 0, high: 1}"),
        "sample.fields.chaser.mass_kg.low",
    ),
    (
        "choice_empty",
        sampled("{dist: choice, values: []}"),
        "sample.fields.chaser.mass_kg.values",
    ),
    (
        "unknown_distribution",
        sampled("{dist: gamma}"),
        "sample.fields.chaser.mass_kg.dist",
    ),
    (
        "unknown_parameter",
        sampled("{dist: uniform, lo: 1, high: 2}"),
        "sample.fields.chaser.mass_kg.lo",
    ),
    (
        "sampled_value_invalid",
        sampled("{dist: normal, mean: 1, std: 5}", count=50),
        "sample.fields.chaser.mass_kg",
    ),
    (
        "sample_wrong_shape",
        sampled("{dist: uniform, low: 1, high: 2}", field="chaser.p_LC_L"),
        "sample.fields.chaser.p_LC_L",
    ),
    (
        "zero_count",
        sampled("{dist: attitude}", count=0),
        "sample.count",
    ),
    (
        "passively_safe_conflict",
        (
            "base: coast\nsample:\n  count: 2\n  passively_safe: {radial_m: 10.0}\n"
            "  fields: {'chaser.p_LC_L[0]': {dist: uniform, low: 1, high: 2}}\n"
        ),
        "sample.fields.chaser.p_LC_L[0]",
    ),
    (
        "passively_safe_negative",
        "base: coast\nsample: {count: 2, passively_safe: {radial_m: -1.0}}\n",
        "sample.passively_safe.radial_m",
    ),
    (
        "grid_and_case_conflict",
        (
            "base: coast\ngrid: {chaser.mass_kg: [1.0]}\n"
            "cases: [{name: a, overrides: {chaser.mass_kg: 2.0}}]\n"
        ),
        "cases[0].overrides.chaser.mass_kg",
    ),
    (
        "duplicate_cases",
        (
            "base: coast\ncases: [{name: a, overrides: {chaser.mass_kg: 2.0}}, {name: b, overrides: "
            "{chaser.mass_kg: 2.0}}]\n"
        ),
        "cases[1]",
    ),
    ("nothing_to_vary", "base: coast\noverrides: {duration_s: 5.0}\n", "nothing to vary"),
    ("unknown_top_level", "base: coast\ngird: {chaser.mass_kg: [1.0]}\n", "gird"),
    ("missing_base", "grid: {chaser.mass_kg: [1.0]}\n", "base"),
    ("unknown_base", "base: no_such_scenario\ngrid: {chaser.mass_kg: [1.0]}\n", "base"),
    (
        "bad_base_override",
        "base: coast\noverrides: {duration_s: -1.0}\ngrid: {chaser.mass_kg: [1.0]}\n",
        "overrides.duration_s",
    ),
    ("yaml_syntax", "base: coast\ngrid: {chaser.mass_kg: [1.0\n", "YAML syntax error"),
]


@pytest.mark.parametrize("case, text, where", BAD_CAMPAIGNS, ids=[c[0] for c in BAD_CAMPAIGNS])
def test_bad_campaign_names_file_and_location(tmp_path, case, text, where):
    path = tmp_path / f"{case}.yaml"
    path.write_text(text)
    with pytest.raises(ScenarioFileError) as error:
        plan_runs(load_campaign(str(path)))
    message = str(error.value)
    assert message.startswith(f"{path}: ") and where in message, message
    assert "\n" not in message


_LONG_KEY = "k" * 1000  # a YAML implicit key has at most 1024 characters
_LONG_NUMBER = "9" * 300  # beyond 309 digits yaml_reader refuses an integer itself
# (case id, campaign text): keys and values far longer than an error line may quote
LONG_ECHOES = [
    ("top_level_key", f"base: coast\n{_LONG_KEY}: 1\n"),
    ("grid_key", f"base: coast\ngrid: {{{_LONG_KEY}: [1.0]}}\n"),
    ("grid_subkey", f"base: coast\ngrid: {{chaser.{_LONG_KEY}: [1.0]}}\n"),
    ("case_key", f"base: coast\ncases: [{{name: a, {_LONG_KEY}: 1}}]\n"),
    ("sample_key", f"base: coast\nsample: {{count: 2, {_LONG_KEY}: 1}}\n"),
    ("override_key", f"base: coast\noverrides: {{{_LONG_KEY}: 1}}\ngrid: {{duration_s: [9.0]}}\n"),
    (
        "sample_count",
        (
            f"base: coast\nsample: {{count: {_LONG_NUMBER}, seed: 1, fields: "
            "{duration_s: {dist: uniform, low: 10.0, high: 20.0}}}\n"
        ),
    ),
    ("grid_value", f"base: coast\ngrid: {{orbit.gravity: [{'g' * 4000}]}}\n"),
    ("base_name", f"base: {'b' * 4000}\ngrid: {{duration_s: [9.0]}}\n"),
    ("key_with_newlines", 'base: coast\n"a\\nb\\nc": 1\n'),
]


@pytest.mark.parametrize("case, text", LONG_ECHOES, ids=[c[0] for c in LONG_ECHOES])
def test_errors_quote_keys_and_values_cut_short(tmp_path, case, text):
    path = tmp_path / f"{case}.yaml"
    path.write_text(text)
    with pytest.raises(ScenarioFileError) as error:
        plan_runs(load_campaign(str(path)))
    message = str(error.value)
    assert message.startswith(f"{path}: ") and "\n" not in message, message
    assert len(message) < 500, message
    for letter in "kg9b":
        assert letter * 150 not in message, message


def test_a_campaign_name_too_long_for_the_file_system_is_one_short_line():
    with pytest.raises(ScenarioFileError, match="cannot be read") as error:
        load_campaign("c" * 5000)
    assert len(str(error.value)) < 300


# (case id, file name, content) of `base:` files that are not scenario YAML files
NOT_SCENARIO_YAML = [
    ("python_script", "script.py", b"import os\nprint('" + b"hello " * 500 + b"')\n"),
    ("python_def", "helper.py", b"def f(): pass\n" * 200),
    ("binary", "model.bin", b"\x7fELF\x02\x01\x01\x00" + bytes(range(256)) * 40),
    ("binary_named_yaml", "data.yaml", b"\x00\x01\x02binary" * 100),
    ("not_utf8_named_yaml", "latin.yaml", b"description: caf\xe9 " * 100),
]


@pytest.mark.parametrize(
    "case, name, content", NOT_SCENARIO_YAML, ids=[c[0] for c in NOT_SCENARIO_YAML]
)
def test_a_base_that_is_not_a_scenario_yaml_file_is_said_to_be_one(tmp_path, case, name, content):
    (tmp_path / name).write_bytes(content)
    campaign = tmp_path / "c.yaml"
    campaign.write_text(f"base: {name}\ngrid: {{duration_s: [9.0]}}\n")
    with pytest.raises(ScenarioFileError) as error:
        load_campaign(str(campaign))
    message = str(error.value)
    assert message.startswith(f"{campaign}: base: {tmp_path / name} is not a scenario YAML file")
    assert "\n" not in message and len(message) < 300, message
    assert "hello hello" not in message and "pass def" not in message, message


def test_a_base_that_is_a_folder_is_said_to_be_one(tmp_path):
    (tmp_path / "scenarios").mkdir()
    campaign = tmp_path / "c.yaml"
    campaign.write_text("base: scenarios\ngrid: {duration_s: [9.0]}\n")
    with pytest.raises(ScenarioFileError, match=r"base: .*scenarios is a folder, not a scenario"):
        load_campaign(str(campaign))


def test_a_base_yaml_file_that_is_a_scenario_still_loads_and_its_errors_name_it(tmp_path):
    (tmp_path / "ok.txt").write_text("duration_s: 9.0\n")  # any name, if it reads as one
    campaign = tmp_path / "c.yaml"
    campaign.write_text("base: ok.txt\ngrid: {chaser.mass_kg: [400.0]}\n")
    assert load_campaign(str(campaign)).base.duration_s == 9.0
    (tmp_path / "bad.yaml").write_text("chaser: {mass_kg: heavy}\n")
    campaign.write_text("base: bad.yaml\ngrid: {duration_s: [9.0]}\n")
    with pytest.raises(ScenarioFileError, match=r"bad\.yaml: chaser\.mass_kg: expected a number"):
        load_campaign(str(campaign))


def test_cli_base_naming_a_python_file_is_one_line_exit_2(tmp_path):
    (tmp_path / "tool.py").write_text("import sys\n" + "print('x' * 80)\n" * 50)
    campaign = tmp_path / "c.yaml"
    campaign.write_text("base: tool.py\ngrid: {duration_s: [9.0]}\n")
    process = run_rpod("sweep", str(campaign), "--out", str(tmp_path / "out"), cwd=tmp_path)
    assert process.returncode == 2, process.stderr
    lines = process.stderr.strip().splitlines()
    assert len(lines) == 1 and "tool.py is not a scenario YAML file (a .py file" in lines[0], lines
    assert not (tmp_path / "out").exists()


def test_seed_without_sample_block_is_an_error(tmp_path):
    campaign = campaign_from("base: coast\ngrid: {chaser.mass_kg: [1.0]}\n", tmp_path)
    with pytest.raises(ScenarioFileError, match="sample.seed"):
        campaign.with_seed(3)


def test_distribution_errors_are_scenario_errors():
    with pytest.raises(ScenarioError) as error:
        sampling.parse_distribution({"dist": "choice", "values": [1], "weights": [0]}, "f")
    assert error.value.field == "f.weights"


@pytest.mark.parametrize(
    "text, where",
    [
        ("base: coast\ngrid: {chaser.mas_kg: [1.0]}\n", "grid.chaser.mas_kg"),
        (
            sampled("{dist: uniform, low: 5, high: 1}"),
            "sample.fields.chaser.mass_kg.high",
        ),
        ("base: coast\ngrid: {chaser.mass_kg: []}\n", "grid.chaser.mass_kg"),
    ],
    ids=["unknown_field", "bad_distribution", "empty_grid"],
)
def test_cli_bad_campaign_exits_2_with_one_line_and_starts_nothing(tmp_path, text, where):
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    process = run_rpod(
        "sweep", str(path), "--out", str(tmp_path / "out"), cwd=tmp_path, timeout=120
    )
    assert process.returncode == 2, process.stderr
    lines = process.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"rpod: error: {path}: {where}: "), lines
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.yaml"]  # nothing started


def test_cli_list_shows_the_demo_campaign(tmp_path):
    process = run_rpod("list", cwd=tmp_path, timeout=120)
    assert process.returncode == 0, process.stderr
    campaigns = process.stdout.split("Campaigns (rpod sweep NAME):")[1].splitlines()
    demo = [line for line in campaigns if line.split()[:1] == ["demo_sweep"]]
    assert len(demo) == 1 and len(demo[0].split()) > 2  # with its description
