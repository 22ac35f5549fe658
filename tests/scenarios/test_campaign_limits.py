"""Bounded work at load time: the run count and --workers are refused above their limits (one
line, exit 2, nothing built or started), grid duplicates are found in one pass, and every
parameter of a distribution that has the wrong type or size is a field error, not a traceback.

Nothing here times anything: the checks are that the refusal happens, where, and what it says.
"""

import pytest
from campaign_helpers import SMALL_CAMPAIGN
from campaign_helpers import run_rpod_in_process as run_rpod

from rpod.scenarios import campaign as campaign_module
from rpod.scenarios.campaign import MAX_RUNS, load_campaign, plan_runs
from rpod.scenarios.loader import ScenarioFileError
from rpod.scenarios.sweep import MAX_WORKERS_PER_CORE, usable_cores


def write(tmp_path, text: str, name: str = "c"):
    path = tmp_path / f"{name}.yaml"
    path.write_text(text)
    return path


def load_error(path) -> str:
    with pytest.raises(ScenarioFileError) as error:
        plan_runs(load_campaign(str(path)))
    message = str(error.value)
    assert message.startswith(f"{path}: ") and "\n" not in message, message
    return message


def values(count: int, start: float) -> str:
    return "[" + ", ".join(f"{start + i:.1f}" for i in range(count)) + "]"


# ------------------------------------------------------------------------------ the run count


def test_a_billion_samples_are_refused_at_load(tmp_path):
    path = write(
        tmp_path,
        "base: coast\nsample: {count: 1000000000, fields: {target.q_LT: {dist: attitude}}}\n",
    )
    message = load_error(path)
    assert message == (
        f"{path}: sample.count: 1,000,000,000 runs planned (cases x grid points x samples = "
        f"1 x 1 x 1,000,000,000), above the limit of {MAX_RUNS:,}"
    )


def test_a_grid_of_a_billion_points_is_refused_before_it_is_built(tmp_path):
    path = write(
        tmp_path,
        "base: coast\ngrid:\n"
        f"  chaser.mass_kg: {values(1000, 100.0)}\n"
        f"  'chaser.p_LC_L[0]': {values(1000, -500.0)}\n"
        f"  duration_s: {values(1000, 10.0)}\n",
    )
    message = load_error(path)
    assert message.startswith(f"{path}: grid: 1,000,000,000 runs planned (cases x grid points x ")
    assert message.endswith(f"= 1 x 1,000,000,000 x 1), above the limit of {MAX_RUNS:,}")


def test_the_limit_is_on_cases_times_grid_points_times_samples(tmp_path, monkeypatch):
    path = write(tmp_path, SMALL_CAMPAIGN)  # 1 case x 4 grid points x 2 samples
    monkeypatch.setattr(campaign_module, "MAX_RUNS", 8)
    assert len(plan_runs(load_campaign(str(path)))) == 8  # at the limit: fine
    monkeypatch.setattr(campaign_module, "MAX_RUNS", 7)
    assert load_error(path) == (
        f"{path}: grid: 8 runs planned (cases x grid points x samples = 1 x 4 x 2), above the "
        "limit of 7"
    )


def test_cli_a_billion_samples_exits_2_and_creates_nothing(tmp_path):
    path = write(
        tmp_path,
        "base: coast\nsample: {count: 1000000000, fields: {target.q_LT: {dist: attitude}}}\n",
    )
    process = run_rpod("sweep", str(path), "--out", str(tmp_path / "out"), cwd=tmp_path)
    assert process.returncode == 2, process.stderr
    lines = process.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"rpod: error: {path}: sample.count: ")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.yaml"]


def test_cli_workers_above_the_limit_exits_2_before_loading_anything(tmp_path):
    limit = MAX_WORKERS_PER_CORE * usable_cores()
    process = run_rpod(
        "sweep", "no_such_campaign.yaml", "--workers", "1000000000", "--out", "out", cwd=tmp_path
    )
    assert process.returncode == 2, process.stderr
    lines = process.stderr.strip().splitlines()
    expected = (
        f"rpod: error: --workers 1000000000: above the limit of {limit} ({MAX_WORKERS_PER_CORE} x "
        f"the {usable_cores()} cores this process may use)"
    )
    assert lines == [expected]
    assert list(tmp_path.iterdir()) == []


# ------------------------------------------------------------------------------ grid duplicates


@pytest.mark.parametrize(
    "field, listed, where",
    [
        ("chaser.mass_kg", "[300, 310, 300.0]", "[2]: 300.0 is listed twice (also [0])"),
        ("chaser.p_LC_L", "[[1, 2, -30], [1.0, 2.0, -30.0]]", "[1]: [1.0, 2.0, -30.0] is listed"),
        ("orbit.gravity", "[cw, two_body, cw]", "[2]: 'cw' is listed twice (also [0])"),
    ],
    ids=["int_and_float", "vectors", "strings"],
)
def test_grid_duplicates_are_found_as_the_field_holds_them(tmp_path, field, listed, where):
    path = write(tmp_path, f"base: coast\ngrid: {{{field}: {listed}}}\n")
    assert f": grid.{field}{where}" in load_error(path)


def test_grid_values_that_differ_are_kept(tmp_path):
    path = write(tmp_path, "base: coast\ngrid: {chaser.mass_kg: [300, 300.5, 301]}\n")
    assert load_campaign(str(path)).grid == {"chaser.mass_kg": [300, 300.5, 301]}


def test_a_100000_value_grid_loads_and_finds_a_late_duplicate(tmp_path):
    """The duplicate check is one pass over the values (it was quadratic: 87 s for this)."""
    many = [f"{300.0 + 0.001 * i:.3f}" for i in range(100_000)]
    path = write(tmp_path, f"base: coast\ngrid: {{chaser.mass_kg: [{', '.join(many)}]}}\n", "ok")
    campaign = load_campaign(str(path))
    assert len(campaign.grid["chaser.mass_kg"]) == 100_000
    late = write(
        tmp_path,
        f"base: coast\ngrid: {{chaser.mass_kg: [{', '.join(many[:-1] + [many[5]])}]}}\n",
        "late",
    )
    assert ": grid.chaser.mass_kg[99999]: 300.005 is listed twice (also [5])" in load_error(late)


# ------------------------------------------------------------------------------ distributions


def sampled(spec: str, field: str = "chaser.mass_kg") -> str:
    return f"base: coast\nsample: {{count: 2, fields: {{{field}: {spec}}}}}\n"


BAD_PARAMETERS = [
    (
        "direction_scale_list",
        sampled("{dist: direction, scale: [1, 2]}", "target.w_IT_T_deg_s"),
        "sample.fields.target.w_IT_T_deg_s.scale: expected a number or a scalar distribution",
    ),
    (
        "direction_scale_text",
        sampled("{dist: direction, scale: fast}", "target.w_IT_T_deg_s"),
        "sample.fields.target.w_IT_T_deg_s.scale: expected a number",
    ),
    (
        "direction_scale_vector_distribution",
        sampled(
            "{dist: direction, scale: {dist: uniform, low: [1, 2], high: [3, 4]}}",
            "target.w_IT_T_deg_s",
        ),
        "sample.fields.target.w_IT_T_deg_s.scale: must be a scalar distribution",
    ),
    (
        "integer_beyond_floats",
        sampled("{dist: uniform, low: " + "9" * 400 + ", high: 2}"),
        # read (yaml_reader refuses only integers Python will not convert, over 4,300 digits),
        # then refused by the field's check, which names the field
        "sample.fields.chaser.mass_kg.low: must be finite",
    ),
    (
        "uniform_width_overflows",
        sampled("{dist: uniform, low: -1.0e308, high: 1.0e308}"),
        "sample.fields.chaser.mass_kg.high: high - low must be a finite number",
    ),
    (
        "weights_sum_overflows",
        sampled("{dist: choice, values: [1, 2], weights: [1.0e308, 1.0e308]}"),
        "sample.fields.chaser.mass_kg.weights: ",
    ),
    (
        "weights_not_numbers",
        sampled("{dist: choice, values: [1, 2], weights: heavy}"),
        "sample.fields.chaser.mass_kg.weights: expected a number or a list of numbers",
    ),
    (
        "values_not_a_list",
        sampled("{dist: choice, values: heavy}"),
        "sample.fields.chaser.mass_kg.values: expected a non-empty list",
    ),
    (
        "low_missing_value",
        sampled("{dist: uniform, low: null, high: 2}"),
        "sample.fields.chaser.mass_kg.low: expected a number",
    ),
    (
        "dist_not_a_name",
        sampled("{dist: [uniform]}"),
        "sample.fields.chaser.mass_kg.dist: unknown distribution ['uniform']",
    ),
    (
        "start_range_not_a_mapping",
        "base: coast\nsample: {count: 2, passively_safe: {radial_m: 10, start_range_m: [1, 2]}}\n",
        "sample.passively_safe.start_range_m: expected a mapping",
    ),
    (
        "amplitude_beyond_reach",
        (
            "base: coast\nsample: {count: 2, passively_safe: {radial_m: 1.0e308, "
            "start_range_m: {low: 1, high: 50}}}\n"
        ),
        "sample.passively_safe.start_range_m: [1, 50] m can never be met",
    ),
    (
        "timeout_infinite",
        "base: coast\ntimeout_s: .inf\ngrid: {chaser.mass_kg: [300.0]}\n",
        "timeout_s: expected a positive, finite number of seconds",
    ),
]


@pytest.mark.parametrize("case, text, expected", BAD_PARAMETERS, ids=[c[0] for c in BAD_PARAMETERS])
def test_a_parameter_of_the_wrong_type_is_a_field_error(tmp_path, case, text, expected):
    assert f": {expected}" in load_error(write(tmp_path, text))


def test_a_long_bad_value_is_quoted_short(tmp_path):
    scale = "[" + ", ".join(["1.5"] * 1000) + "]"
    path = write(tmp_path, sampled(f"{{dist: direction, scale: {scale}}}", "target.w_IT_T_deg_s"))
    message = load_error(path)
    quoted = message.split(", got ", 1)[1]
    assert quoted.startswith("[1.5, 1.5") and quoted.endswith("...") and len(quoted) <= 60


def test_cli_direction_scale_list_exits_2_with_one_line(tmp_path):
    path = write(tmp_path, sampled("{dist: direction, scale: [1, 2]}", "target.w_IT_T_deg_s"))
    process = run_rpod("sweep", str(path), "--out", str(tmp_path / "out"), cwd=tmp_path)
    assert process.returncode == 2, process.stderr
    lines = process.stderr.strip().splitlines()
    expected = (
        f"rpod: error: {path}: sample.fields.target.w_IT_T_deg_s.scale: expected a number or a "
        "scalar distribution, got [1, 2]"
    )
    assert lines == [expected]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.yaml"]
