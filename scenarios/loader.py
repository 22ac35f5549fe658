"""Loading scenario files: bundled names or paths, YAML -> `Scenario`, one-line errors.

Owns: finding a scenario (a path, or the name of a file in scenarios/bundled/), parsing it, the
schema check that names the file and the dotted field of any unknown key or wrong type, and the
`ScenarioFileError` the command line turns into exit status 2.
Does not own: the schema itself or its semantic checks (rpod.diagrams.scenario).

The YAML is parsed twice on purpose: once with PyYAML into plain data, to say *which* field is
wrong (pydrake's loader reports unknown keys but not where a type is wrong), and once with
`pydrake.common.yaml.yaml_load_typed`, which builds the dataclasses the way Drake's own
`*Config` types are built.
"""

import dataclasses
import math
import pathlib
import typing

import yaml
from pydrake.common.yaml import yaml_load_typed

from rpod.diagrams.scenario import Scenario, ScenarioError, validate_scenario

BUNDLED_DIR = pathlib.Path(__file__).resolve().parent / "bundled"


class ScenarioFileError(Exception):
    """A scenario file cannot be used; the message is one line naming the file and field."""


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


def _type_name(annotation) -> str:
    origin = typing.get_origin(annotation)
    if origin is list:
        return f"a list of {_type_name(typing.get_args(annotation)[0])}"
    if dataclasses.is_dataclass(annotation):
        return "a mapping"
    return {float: "a number", int: "an integer", bool: "true or false", str: "a string"}.get(
        annotation, str(annotation)
    )


def _check(value, annotation, field: str) -> None:
    """Raises ScenarioError if plain YAML data does not fit the annotated dataclass field."""
    expected = _type_name(annotation)
    if dataclasses.is_dataclass(annotation):
        if not isinstance(value, dict):
            raise ScenarioError(field or "(top level)", f"expected {expected}, got {value!r}")
        known = typing.get_type_hints(annotation)
        for key, item in value.items():
            path = f"{field}.{key}" if field else str(key)
            if key not in known:
                raise ScenarioError(path, f"unknown field (known: {', '.join(known)})")
            _check(item, known[key], path)
        return
    origin = typing.get_origin(annotation)
    if origin is list:
        if not isinstance(value, list):
            raise ScenarioError(field, f"expected {expected}, got {value!r}")
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
        raise ScenarioError(field, f"expected {expected}, got {value!r}")


def read_yaml(text: str, source: str):
    """Plain data from YAML text; a syntax error is ScenarioFileError with its line and column."""
    try:
        return yaml.safe_load(text)
    except yaml.YAMLError as error:
        mark = getattr(error, "problem_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
        problem = getattr(error, "problem", None) or str(error).splitlines()[0]
        raise ScenarioFileError(f"{source}: YAML syntax error{where}: {problem}") from None


def parse_scenario(text: str, source: str = "<string>") -> Scenario:
    """Scenario from YAML text; errors are ScenarioFileError('source: field: message')."""
    data = read_yaml(text, source)
    if data is None:
        data = {}
    try:
        _check(data, Scenario, "")
        scenario = yaml_load_typed(schema=Scenario, data=text, defaults=Scenario())
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
