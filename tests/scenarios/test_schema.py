"""The one schema walker (rpod.scenarios.schema): check, build, dump and dotted paths."""

import dataclasses
import typing

import pytest

from rpod.models.config import CHOICES_KEY, ConfigError
from rpod.scenarios import schema
from rpod.scenarios.yaml_reader import dump_yaml, parse_yaml


@dataclasses.dataclass
class Gains:
    kp: float = 1.0
    kd: float | None = None


@dataclasses.dataclass
class Alpha:
    mode: typing.Literal["fast", "safe"] = "safe"
    gains: Gains = dataclasses.field(default_factory=Gains)
    weights: dict[str, float] = dataclasses.field(default_factory=lambda: {"a": 1.0})
    steps: list[int] = dataclasses.field(default_factory=lambda: [1, 2])


@dataclasses.dataclass
class Beta:
    limit: float = 2.0


_REGISTRY = [Alpha, Beta]


@dataclasses.dataclass
class Root:
    name: str = "x"
    fixed: Gains = dataclasses.field(default_factory=Gains)
    choice: typing.Any = dataclasses.field(
        default_factory=Alpha, metadata={CHOICES_KEY: lambda: tuple(_REGISTRY)}
    )


def _load(text: str) -> Root:
    data = parse_yaml(text) or {}
    schema.check(data, Root)
    return schema.build(data, Root, Root())


@pytest.mark.parametrize(
    "text, field, words",
    [
        ("choice: !Alpha {gains: {kd: abc}}", "choice.gains.kd", "a number or null"),
        ("choice: !Alpha {mode: turbo}", "choice.mode", "one of 'fast', 'safe'"),
        ("choice: !Alpha {weights: [1, 2]}", "choice.weights", "a mapping of names to a number"),
        ("choice: !Alpha {weights: {a: .nan}}", "choice.weights.a", "must be finite"),
        ("choice: !Alpha {steps: [1, 2.5]}", "choice.steps[1]", "an integer"),
        ("choice: !Gamma {}", "choice", "unknown tag !Gamma (known: !Alpha, !Beta)"),
        ("fixed: !Gains {kp: 2}", "fixed", "remove the tag"),
        ("choice: !Alpha {weights: !Foo {a: 1}}", "choice.weights", "remove the tag"),
        ("fixed: {kq: 2}", "fixed.kq", "unknown field"),
        ("name: 1", "name", "a string"),
    ],
)
def test_each_bad_value_is_one_error_naming_the_dotted_field(text, field, words):
    with pytest.raises(ConfigError) as raised:
        _load(text)
    assert raised.value.field == field
    assert words in raised.value.message
    assert len(str(raised.value)) < 200 and "\n" not in str(raised.value)


def test_a_nul_character_in_a_string_and_an_integer_past_any_float_are_refused():
    with pytest.raises(ConfigError, match="NUL"):
        schema.check({"name": "a\x00b"}, Root)
    with pytest.raises(ConfigError, match="must be finite") as raised:
        schema.check({"fixed": {"kp": 10**401}}, Root)
    assert raised.value.field == "fixed.kp" and len(str(raised.value)) < 120


def test_build_keeps_defaults_merges_blocks_and_replaces_lists_and_mappings():
    root = _load("choice: !Alpha {gains: {kd: 3}, weights: {b: 2}, steps: [7]}")
    assert root.choice == Alpha(gains=Gains(kp=1.0, kd=3.0), weights={"b": 2.0}, steps=[7])
    assert isinstance(root.choice.gains.kd, float)
    assert _load("choice: {mode: fast}").choice == Alpha(mode="fast")  # untagged: the first
    assert _load("choice: !Beta {}").choice == Beta()
    assert _load("choice: null").choice is None


def test_the_union_follows_the_registry_without_rewriting_any_annotation():
    before = dict(Root.__annotations__)
    _REGISTRY.append(Gains)
    try:
        assert _load("choice: !Gains {kp: 5}").choice == Gains(kp=5.0)
    finally:
        _REGISTRY.pop()
    with pytest.raises(ConfigError, match="unknown tag !Gains"):
        _load("choice: !Gains {kp: 5}")
    assert Root.__annotations__ == before


def test_to_data_round_trips_through_yaml_with_tags():
    root = _load("name: y\nchoice: !Beta {limit: 4}")
    text = dump_yaml(schema.to_data(root))
    assert "!Beta" in text
    assert _load(text) == root


def test_dotted_paths_lead_into_the_union_member_that_has_them():
    assert schema.path_type(Root, "choice.limit") is float
    assert schema.path_type(Root, "choice.gains.kd") == float | None
    assert schema.path_type(Root, "choice.steps[0]") is int
    with pytest.raises(ConfigError, match="no member of choice"):
        schema.path_type(Root, "choice.nothing")
    with pytest.raises(ConfigError, match="malformed"):
        schema.path_type(Root, "choice..limit")


def test_quote_cuts_long_values_and_huge_integers():
    assert schema.quote("x" * 1000).endswith("...")
    assert len(schema.quote(10**4000)) <= schema.QUOTE_CHARS
