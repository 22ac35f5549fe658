"""rpod.scenarios.yaml_reader: numbers as people write them (YAML 1.2), and YAML that must be
refused (duplicate keys, runaway nesting, alias bombs, Python tags), in scenario and campaign
files alike."""

import pytest

from rpod.scenarios.campaign import load_campaign, parse_campaign
from rpod.scenarios.loader import ScenarioFileError, load_scenario, parse_scenario
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


def test_dates_are_text_as_in_yaml_1_2_and_a_bad_one_is_the_fields_error():
    """YAML 1.1 reads an unquoted date as a timestamp: the epoch would be refused as not a
    string, and an impossible date was a traceback from PyYAML's datetime constructor."""
    data = parse_yaml("a: 2024-03-01T00:00:00\nb: 2000-13-01T00:00:00\nc: 2002-12-14")
    assert data == {"a": "2024-03-01T00:00:00", "b": "2000-13-01T00:00:00", "c": "2002-12-14"}
    scenario = parse_scenario("orbit: {epoch_utc: 2024-03-01T00:00:00}", "s.yaml")
    assert scenario.orbit.epoch_utc == "2024-03-01T00:00:00"
    with pytest.raises(ScenarioFileError, match=r"^s.yaml: orbit.epoch_utc: not a valid date"):
        parse_scenario("orbit: {epoch_utc: 2000-13-01T00:00:00}", "s.yaml")


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


@pytest.mark.parametrize("character", ["\x00", "\x07", "\x7f"])
def test_a_control_character_is_an_error_naming_line_and_column(character):
    with pytest.raises(YamlError, match=r"^not YAML text: .* at line 2, column 13 .*binary file"):
        parse_yaml(f"a: 1\nduration_s: {character}10.0\n")


def test_a_nul_byte_in_a_scenario_or_campaign_file_is_one_line_naming_the_file(tmp_path):
    scenario = tmp_path / "nul.yaml"
    scenario.write_bytes(b"duration_s: 10.0\x00\n")
    with pytest.raises(ScenarioFileError) as raised:
        load_scenario(str(scenario))
    assert str(raised.value).startswith(f"{scenario}: not YAML text: character #x00 at line 1")
    assert "\n" not in str(raised.value)
    campaign = tmp_path / "nul_campaign.yaml"
    campaign.write_bytes(b"base: coast\x00\ngrid: {duration_s: [10.0]}\n")
    with pytest.raises(ScenarioFileError) as raised:
        load_campaign(str(campaign))
    assert str(raised.value).startswith(f"{campaign}: not YAML text: character #x00 at line 1")
    assert "\n" not in str(raised.value)


def _alias_chain(levels: int, copies: int = 1) -> str:
    """l0 holds a number, each further level `copies` aliases of the one before: `levels` lists
    deep through aliases, while no list of the text holds another one."""
    lines = ["l0: &l0 [1]"]
    lines += [f"l{i}: &l{i} [" + ", ".join([f"*l{i - 1}"] * copies) + "]" for i in range(1, levels)]
    return "\n".join(lines) + "\n"


def _depth(value) -> int:
    """Levels of data: a list is one more than its deepest item, a number one."""
    return 1 + max(map(_depth, value), default=0) if isinstance(value, list) else 1


def test_a_chain_of_aliases_may_not_resolve_deeper_than_the_limit():
    # The mapping is the first level, l29 .. l0 thirty more, the number the last.
    data = parse_yaml(_alias_chain(MAX_DEPTH - 2))
    assert 1 + _depth(data[f"l{MAX_DEPTH - 3}"]) == MAX_DEPTH
    with pytest.raises(YamlError, match="nested deeper"):
        parse_yaml(_alias_chain(MAX_DEPTH - 1))
    # Each level twice the one before (a: &a [1]; b: &b [*a, *a]; ...): refused as well, by
    # its depth or by its size, without expanding it.
    with pytest.raises(YamlError, match="nested deeper|more than"):
        parse_yaml(_alias_chain(MAX_DEPTH + 8, copies=2))


def test_data_met_shallow_first_and_then_deeper_through_an_alias_is_refused():
    # `r: *p` puts p's data at depth 2 first (the last key is checked first); q reaches the same
    # data 20 levels further down: 1 + 20 + 15 levels in all.
    text = "p: &p " + "[" * 15 + "1" + "]" * 15 + "\nq: " + "[" * 20 + "*p" + "]" * 20 + "\nr: *p\n"
    with pytest.raises(YamlError, match=r"nested deeper than 32 levels at line 2"):
        parse_yaml(text)


@pytest.mark.parametrize("text", ["9" * 4301, "-" + "9" * 4301, "9" * 100_000, "0x" + "f" * 4000])
def test_an_integer_too_long_to_convert_is_refused_and_not_echoed(text):
    with pytest.raises(YamlError) as raised:
        parse_yaml(f"x: {text}\n")
    message = str(raised.value)
    assert message.startswith("YAML value error at line 1, column 4: integer too long")
    assert len(message) < 200, message


def test_long_integers_that_python_converts_are_read():
    assert parse_yaml(f"x: {'9' * 4300}\n")["x"] == 10**4300 - 1
    assert parse_yaml(f"x: -{'9' * 401}\n")["x"] == -(10**401 - 1)


@pytest.mark.parametrize("digits", [310, 401, 4000])
def test_an_integer_beyond_the_float_range_for_a_float_field_is_one_line_naming_the_file(
    tmp_path, digits
):
    scenario = tmp_path / "big.yaml"
    scenario.write_text(f"chaser:\n  mass_kg: {'9' * digits}\n")
    with pytest.raises(ScenarioFileError) as raised:
        load_scenario(str(scenario))
    message = str(raised.value)
    assert message.startswith(f"{scenario}: chaser.mass_kg: must be finite"), message
    assert len(message) < 250 and "9" * 60 not in message, message


@pytest.mark.parametrize(
    "text",
    [
        "x: !!int " + "y" * 4000 + "\n",
        "x: !" + "t" * 4000 + " [1]\n",
        "x: !!" + "t" * 4000 + " [1]\n",
    ],
    ids=["not_an_int", "local_tag_on_a_list", "unknown_tag"],
)
def test_what_the_file_holds_is_quoted_cut_in_errors(text):
    with pytest.raises(YamlError) as raised:
        parse_yaml(text)
    assert len(str(raised.value)) < 250, str(raised.value)
