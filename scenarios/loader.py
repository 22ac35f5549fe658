"""Loading scenario files: bundled names or paths, YAML -> `Scenario`, one-line errors.

Owns: finding a scenario (a path, or the name of a file in scenarios/bundled/), parsing it, the
schema check that names the file and the dotted field of any unknown key or wrong type, and the
`ScenarioFileError` the command line turns into exit status 2.
Does not own: the schema itself or its semantic checks (rpod.diagrams.scenario).

The YAML is read once, by rpod.scenarios.yaml_reader (YAML 1.2 numbers, no duplicate keys,
bounded depth and size, tags kept), into plain data that rpod.scenarios.schema checks (naming
*which* field is wrong, inside a tagged controller block too) and builds the dataclasses from,
with the semantics of Drake's `yaml_load_typed`: one walk of the schema for files, `--set` and
campaigns, and one YAML dialect.
"""

import pathlib

from rpod.diagrams.scenario import Scenario, ScenarioError, validate_scenario
from rpod.scenarios import schema
from rpod.scenarios.schema import quote_path
from rpod.scenarios.yaml_reader import YamlError, dump_yaml, parse_yaml

BUNDLED_DIR = pathlib.Path(__file__).resolve().parent / "bundled"


class ScenarioFileError(Exception):
    """A scenario file cannot be used; the message is one line naming the file and field."""


def bundled_scenarios() -> dict[str, pathlib.Path]:
    """Bundled scenario names -> their files."""
    return {path.stem: path for path in sorted(BUNDLED_DIR.glob("*.yaml"))}


def resolve_scenario_path(name_or_path: str) -> pathlib.Path:
    """The file of a scenario given as a path or as a bundled name."""
    path = pathlib.Path(name_or_path)
    try:
        if path.is_file():
            return path
    except (OSError, ValueError) as error:  # a name too long for the file system, a NUL
        raise ScenarioFileError(
            f"{quote_path(name_or_path)}: cannot be a file ({error.strerror if isinstance(error, OSError) else error})"
        ) from None
    bundled = bundled_scenarios()
    if name_or_path in bundled:
        return bundled[name_or_path]
    if path.suffix or "/" in name_or_path:
        raise ScenarioFileError(f"{quote_path(name_or_path)}: no such file")
    raise ScenarioFileError(
        f"{quote_path(name_or_path)}: no such file or bundled scenario (bundled: {', '.join(bundled)})"
    )


def read_yaml(text: str, source: str):
    """Plain data from YAML text (rpod.scenarios.yaml_reader: YAML 1.2 numbers, no duplicate
    keys, bounded depth and size); ScenarioFileError naming the file, line and column."""
    try:
        return parse_yaml(text)
    except YamlError as error:
        raise ScenarioFileError(f"{source}: {error}") from None


def build_scenario(text: str, source: str = "<string>") -> Scenario:
    """Scenario from YAML text, checked against the schema but not validated as a whole
    (a campaign's base, validated with each run's overrides); ScenarioFileError on a problem."""
    data = read_yaml(text, source)
    if data is None:  # empty or only comments: every field has its default
        data = {}
    try:
        schema.check(data, Scenario, "")
    except ScenarioError as error:
        raise ScenarioFileError(f"{source}: {error.field}: {error.message}") from None
    return schema.build(data, Scenario, Scenario())


def parse_scenario(text: str, source: str = "<string>") -> Scenario:
    """Scenario from YAML text; errors are ScenarioFileError('source: field: message')."""
    scenario = build_scenario(text, source)
    try:
        validate_scenario(scenario)
    except ScenarioError as error:
        raise ScenarioFileError(f"{source}: {error.field}: {error.message}") from None
    return scenario


def dump_scenario(scenario: Scenario) -> str:
    """YAML text of a scenario, tags kept: what `parse_scenario` reads back to an equal one
    (summary folders' scenario.yaml, and the base a campaign sends its workers)."""
    return dump_yaml(schema.to_data(scenario))


def load_scenario(name_or_path: str) -> tuple[str, Scenario]:
    """(name, Scenario) of a path or bundled name; ScenarioFileError on any problem."""
    path = resolve_scenario_path(name_or_path)
    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError) as error:
        raise ScenarioFileError(f"{path}: cannot read: {error}") from None
    return path.stem, parse_scenario(text, str(path))
