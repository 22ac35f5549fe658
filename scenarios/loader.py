"""Loading scenario files: bundled names or paths, YAML -> `Scenario`, one-line errors.

Owns: finding a scenario (a path, or the name of a file in scenarios/bundled/), parsing it, the
schema check that names the file and the dotted field of any unknown key or wrong type, and the
`ScenarioFileError` the command line turns into exit status 2.
Does not own: the schema itself or its semantic checks (rpod.diagrams.scenario).

The YAML is read once, by rpod.scenarios.yaml_reader (YAML 1.2 numbers, no duplicate keys,
bounded depth and size, tags kept), into plain data that is checked against the schema here, to
say *which* field is wrong (pydrake's loader reports unknown keys but not where a type is
wrong), including inside a tagged controller block. The checked data, dumped back with its
tags, is what `pydrake.common.yaml.yaml_load_typed` then builds the dataclasses from, the way
Drake's own `*Config` types are built: one YAML dialect decides, not two.
"""

import dataclasses
import math
import pathlib
import typing

from pydrake.common.yaml import yaml_load_typed

from rpod.diagrams.scenario import Scenario, ScenarioError, validate_scenario
from rpod.scenarios.yaml_reader import YamlError, dump_yaml, parse_yaml

BUNDLED_DIR = pathlib.Path(__file__).resolve().parent / "bundled"


QUOTE_CHARS = 60  # longest quotation of a bad value in an error message


class ScenarioFileError(Exception):
    """A scenario file cannot be used; the message is one line naming the file and field."""


def quote(value, limit: int = QUOTE_CHARS) -> str:
    """repr(value) on one line, cut to `limit` characters: error messages stay one short line.

    A YAML alias bomb expands to a value whose repr has billions of characters; the repr of a
    container is built item by item and abandoned once past the limit.
    """
    parts, length, cut = [], 0, False
    for piece in _repr_pieces(value):
        parts.append(piece)
        length += len(piece)
        if length > limit:
            cut = True
            break
    text = " ".join("".join(parts).split())
    return text if not cut and len(text) <= limit else text[: limit - 3] + "..."


def quote_path(path: str, limit: int = 2 * QUOTE_CHARS) -> str:
    """A dotted field path as written by the user, cut to `limit` characters."""
    return path if len(path) <= limit else path[: limit - 3] + "..."


def _repr_pieces(value):
    """repr(value) as a stream of pieces (lists and dicts item by item)."""
    if isinstance(value, list):
        yield "["
        for index, item in enumerate(value):
            yield ", " if index else ""
            yield from _repr_pieces(item)
        yield "]"
    elif isinstance(value, dict):
        yield "{"
        for index, (key, item) in enumerate(value.items()):
            yield (", " if index else "") + repr(key) + ": "
            yield from _repr_pieces(item)
        yield "}"
    else:
        yield repr(value)


def bundled_scenarios() -> dict[str, pathlib.Path]:
    """Bundled scenario names -> their files."""
    return {path.stem: path for path in sorted(BUNDLED_DIR.glob("*.yaml"))}


def resolve_scenario_path(name_or_path: str) -> pathlib.Path:
    """The file of a scenario given as a path or as a bundled name."""
    path = pathlib.Path(name_or_path)
    if path.is_file():
        return path
    bundled = bundled_scenarios()
    if name_or_path in bundled:
        return bundled[name_or_path]
    if path.suffix or "/" in name_or_path:
        raise ScenarioFileError(f"{name_or_path}: no such file")
    raise ScenarioFileError(
        f"{name_or_path}: no such file or bundled scenario (bundled: {', '.join(bundled)})"
    )


def schema_fields(annotation) -> dict | None:
    """{field: type} of a schema record: a dataclass, or a Drake config bound from C++ with
    DefAttributesUsingSerialize (e.g. SimulatorConfig, whose `__fields__` list them); None for
    anything else."""
    if dataclasses.is_dataclass(annotation):
        return typing.get_type_hints(annotation)
    fields = getattr(annotation, "__fields__", None)
    if isinstance(annotation, type) and fields is not None:
        return {field.name: field.type for field in fields}
    return None


def is_record(annotation) -> bool:
    """True for a schema type with named fields (schema_fields)."""
    return schema_fields(annotation) is not None


def _union_choices(annotation) -> tuple[list[type], bool]:
    """(the dataclass choices of a Union annotation, whether None is allowed)."""
    args = typing.get_args(annotation)
    return [a for a in args if a is not type(None)], type(None) in args


def _type_name(annotation) -> str:
    origin = typing.get_origin(annotation)
    if origin is typing.Union:
        choices, nullable = _union_choices(annotation)
        names = [f"!{choice.__name__} {{...}}" for choice in choices] + ["null"] * nullable
        return "one of " + ", ".join(names)
    if origin is list:
        return f"a list of {_type_name(typing.get_args(annotation)[0])}"
    if is_record(annotation):
        return "a mapping"
    return {float: "a number", int: "an integer", bool: "true or false", str: "a string"}.get(
        annotation, str(annotation)
    )


def _check(value, annotation, field: str) -> None:
    """Raises ScenarioError if plain YAML data does not fit the annotated dataclass field."""
    expected = _type_name(annotation)
    if typing.get_origin(annotation) is typing.Union:  # a typed union chosen by YAML tag
        choices, nullable = _union_choices(annotation)
        if value is None and nullable:
            return
        if not isinstance(value, dict):
            raise ScenarioError(field, f"expected {expected}, got {quote(value)}")
        tag = getattr(value, "tag", None)
        if tag is None:  # untagged: the first choice, as Drake's yaml_load_typed reads it
            chosen = choices[0]
        else:
            chosen = next((c for c in choices if c.__name__ == tag), None)
            if chosen is None:
                known = ", ".join(f"!{c.__name__}" for c in choices)
                raise ScenarioError(field, f"unknown tag !{tag} (known: {known})")
        _check(value, chosen, field)
        return
    if is_record(annotation):
        if not isinstance(value, dict):
            raise ScenarioError(field or "(top level)", f"expected {expected}, got {quote(value)}")
        known = schema_fields(annotation)
        for key, item in value.items():
            path = f"{field}.{key}" if field else str(key)
            if key not in known:
                raise ScenarioError(quote_path(path), f"unknown field (known: {', '.join(known)})")
            _check(item, known[key], path)
        return
    origin = typing.get_origin(annotation)
    if origin is list:
        if not isinstance(value, list):
            raise ScenarioError(field, f"expected {expected}, got {quote(value)}")
        (item_type,) = typing.get_args(annotation)
        for index, item in enumerate(value):
            _check(item, item_type, f"{field}[{index}]")
        return
    if annotation is bool:
        ok = isinstance(value, bool)
    elif annotation is int:
        ok = isinstance(value, int) and not isinstance(value, bool)
    elif annotation is float:
        ok = isinstance(value, (int, float)) and not isinstance(value, bool)
        if ok and not math.isfinite(value):
            raise ScenarioError(field, f"must be finite, got {value}")
    elif annotation is str:
        ok = isinstance(value, str)
    else:  # pragma: no cover - a schema type this checker does not know is a programming error
        raise TypeError(f"unsupported schema type {annotation} at {field}")
    if not ok:
        raise ScenarioError(field, f"expected {expected}, got {quote(value)}")


def read_yaml(text: str, source: str):
    """Plain data from YAML text (rpod.scenarios.yaml_reader: YAML 1.2 numbers, no duplicate
    keys, bounded depth and size); ScenarioFileError naming the file, line and column."""
    try:
        return parse_yaml(text)
    except YamlError as error:
        raise ScenarioFileError(f"{source}: {error}") from None


def parse_scenario(text: str, source: str = "<string>") -> Scenario:
    """Scenario from YAML text; errors are ScenarioFileError('source: field: message')."""
    data = read_yaml(text, source)
    if data is None:  # empty or only comments: every field has its default
        data = {}
    try:
        _check(data, Scenario, "")
        # Drake reads the checked data, not the text: one YAML dialect (yaml_reader's) decides.
        scenario = yaml_load_typed(schema=Scenario, data=dump_yaml(data), defaults=Scenario())
        validate_scenario(scenario)
    except ScenarioError as error:
        raise ScenarioFileError(f"{source}: {error.field}: {error.message}") from None
    return scenario


def load_scenario(name_or_path: str) -> tuple[str, Scenario]:
    """(name, Scenario) of a path or bundled name; ScenarioFileError on any problem."""
    path = resolve_scenario_path(name_or_path)
    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError) as error:
        raise ScenarioFileError(f"{path}: cannot read: {error}") from None
    return path.stem, parse_scenario(text, str(path))
