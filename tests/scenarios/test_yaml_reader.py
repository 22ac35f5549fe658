"""rpod.scenarios.yaml_reader: numbers as people write them (YAML 1.2), and YAML that must be
refused (duplicate keys, runaway nesting, alias bombs, Python tags), in scenario and campaign
files alike."""

import pytest

from rpod.scenarios.campaign import parse_campaign
from rpod.scenarios.loader import ScenarioFileError, parse_scenario
from rpod.scenarios.yaml_reader import MAX_DEPTH, MAX_VALUES, YamlError, parse_yaml

# Every YAML 1.2 float form a person writes, and what it means. PyYAML's YAML 1.1 resolver
# read the exponent forms without a dot, or with an unsigned exponent, as strings.
FLOAT_FORMS = [
    ("5e2", 500.0),
    ("5E2", 500.0),
    ("+5e2", 500.0),
    ("5e+2", 500.0),
    ("1.0e308", 1.0e308),
    ("1e-3", 1e-3),
    ("-2.5E-3", -2.5e-3),
    ("1.5e3", 1500.0),
    ("1.", 1.0),
    (".5", 0.5),
    ("+.5", 0.5),
    ("500.0", 500.0),
    ("1.0e+2", 100.0),
]
INT_FORMS = [("500", 500), ("+7", 7), ("-7", -7), ("010", 10), ("0o17", 15), ("0x1F", 31)]


@pytest.mark.parametrize("text, value", FLOAT_FORMS, ids=[f[0] for f in FLOAT_FORMS])
def test_every_yaml_1_2_float_form_is_a_float(text, value):
    data = parse_yaml(f"x: {text}\n")
    assert isinstance(data["x"], float) and data["x"] == value


@pytest.mark.parametrize("text, value", INT_FORMS, ids=[f[0] for f in INT_FORMS])
def test_integers_are_decimal_octal_0o_or_hex_as_in_yaml_1_2(text, value):
    data = parse_yaml(f"x: {text}\n")
    assert isinstance(data["x"], int) and data["x"] == value


def test_special_floats_and_non_numbers_keep_their_yaml_meaning():
    data = parse_yaml("a: .inf\nb: -.inf\nc: .nan\nd: 1e\ne: e5\nf: 1:30\ng: '5e2'\nh: true\n")
    assert data["a"] == float("inf") and data["b"] == float("-inf") and data["c"] != data["c"]
    assert data["d"] == "1e" and data["e"] == "e5" and data["f"] == "1:30" and data["g"] == "5e2"
    assert data["h"] is True


MASS_FORMS = ["5e2", "5E2", "+5e2", "5e+2", "5.e2", "0.5e3", "50e1", "5000e-1"]


@pytest.mark.parametrize("text", MASS_FORMS)
def test_scenario_file_takes_exponent_numbers(text):
    scenario = parse_scenario(f"chaser:\n  mass_kg: {text}\n")
    assert scenario.chaser.mass_kg == 500.0


def test_scenario_file_takes_the_issue_examples():
    scenario = parse_scenario("chaser: {mass_kg: 5e2}\nduration_s: 1e3\nlog_period_s: 1e-3\n")
    assert (scenario.chaser.mass_kg, scenario.duration_s, scenario.log_period_s) == (
        500.0,
        1000.0,
        0.001,
    )


def test_campaign_file_takes_exponent_numbers(tmp_path):
    text = (
        "base: coast\n"
        "overrides: {duration_s: 6e2, log_period_s: 1E1}\n"
        "grid:\n  chaser.mass_kg: [2.5e2, 5e2, +1e+3]\n"
    )
    campaign = parse_campaign(text, "c.yaml", "c", tmp_path)
    assert campaign.base.duration_s == 600.0 and campaign.base.log_period_s == 10.0
    assert campaign.grid["chaser.mass_kg"] == [250.0, 500.0, 1000.0]


def test_duplicate_key_is_refused_with_both_lines():
    with pytest.raises(YamlError, match=r"duplicate key 'mass_kg' at line 3.*first at line 2"):
        parse_yaml("chaser:\n  mass_kg: 1.0\n  mass_kg: 2.0\n")
    with pytest.raises(ScenarioFileError, match=r"^s\.yaml: duplicate key 'duration_s'"):
        parse_scenario("duration_s: 10.0\nduration_s: 20.0\n", "s.yaml")


def test_duplicate_key_in_a_campaign_is_refused(tmp_path):
    text = "base: coast\ngrid:\n  chaser.mass_kg: [1.0]\n  chaser.mass_kg: [2.0]\n"
    with pytest.raises(ScenarioFileError, match=r"c\.yaml: duplicate key 'chaser\.mass_kg'"):
        parse_campaign(text, "c.yaml", "c", tmp_path)


def test_nesting_deeper_than_the_limit_is_refused():
    assert parse_yaml("a: " + "[" * (MAX_DEPTH - 1) + "]" * (MAX_DEPTH - 1))
    with pytest.raises(YamlError, match="nested deeper"):
        parse_yaml("a: " + "[" * MAX_DEPTH + "]" * MAX_DEPTH)
    # Far past Python's recursion limit: PyYAML's own recursion fails, the error is the same.
    with pytest.raises(YamlError, match="nested deeper"):
        parse_yaml("a: " + "[" * 50000 + "]" * 50000)


def _alias_bomb(levels: int) -> str:
    """A ~1 KB document that expands to 9^levels values."""
    lines = ["l0: &l0 [x, x, x, x, x, x, x, x, x]"]
    for level in range(1, levels):
        lines.append(f"l{level}: &l{level} [" + ", ".join([f"*l{level - 1}"] * 9) + "]")
    return "\n".join(lines) + "\n"


def test_alias_bomb_is_refused_without_expanding_it():
    text = _alias_bomb(10)  # 9^10 ~ 3.5e9 values: expanding it would take hours
    assert len(text) < 1200
    with pytest.raises(YamlError, match=f"more than {MAX_VALUES:,} values"):
        parse_yaml(text)


def test_small_aliases_still_work():
    data = parse_yaml("a: &v [1.0, 2.0, 3.0]\nb: *v\n")
    assert data["b"] == [1.0, 2.0, 3.0]


def test_recursive_alias_is_refused():
    with pytest.raises(YamlError, match="nested deeper"):
        parse_yaml("a: &a [*a]\n")


def test_python_tags_are_never_constructed(tmp_path):
    marker = tmp_path / "executed"
    text = f"a: !!python/object/apply:os.system ['touch {marker}']\n"
    with pytest.raises(YamlError, match="could not determine a constructor"):
        parse_yaml(text)
    assert not marker.exists()


def test_empty_and_comment_only_documents_are_none():
    assert parse_yaml("") is None
    assert parse_yaml("# only a comment\n\n") is None
