"""Campaign files: a base scenario and how to vary it (grid, cases, samples) -> planned runs.

Owns: the campaign file format, its checks (each error names the file and the dotted location,
e.g. `grid.chaser.mas_kg`), dotted-path overrides of `Scenario` fields, the plan (the list of
runs, each with a stable id), and finding bundled campaigns.
Does not own: the distributions (sampling.py), running (sweep.py, harness.py), storing
(store.py) or reporting (report.py).

A campaign file (every block but `base` is optional; at least one of grid, cases, sample):

    description: "one line for rpod list"
    base: coast                  # a bundled scenario, or a path relative to this file
    overrides: {duration_s: 60.0}  # applied to the base for every run
    timeout_s: 120.0             # default of `rpod sweep --timeout-s`
    grid:                        # cartesian product of the listed values
      orbit.gravity: [cw, two_body_j2]
      chaser.p_LC_L[1]: [-50.0, -100.0]    # [i] indexes into a list field
    cases:                       # explicit variants, each a mapping of overrides
      - name: heavy
        overrides: {chaser.mass_kg: 800.0}
    sample:                      # count draws, seeded
      count: 16
      seed: 1
      fields: {target.q_LT: {dist: attitude}}
      passively_safe:            # + start_range_m: {low, high}, point_at_target: true
        radial_m: {dist: uniform, low: 15.0, high: 50.0}

Runs are every combination case x grid point x sample (an absent block counts as one empty
entry). The same `count` draws are used in every case and grid point (common random numbers:
groups differ only by what the grid or case changed). Overrides are applied in the order base
overrides, case, grid, sample; grid, sample and a case may not set the same field.

Run ids. `run_id` is a SHA-256 (first 16 hex digits) of the canonical JSON of the base scenario
after the campaign's `overrides` (every field, so editing the base file changes the ids), the
run's own overrides, and `[seed, sample index]` for sampled runs. It depends on nothing else:
not on the order of runs, on the other runs, on the machine or on the worker that runs it. A
sample's draws come from a numpy Generator seeded by (seed, sample index, field path), so sample
k is the same whatever `count` is and whatever other fields are sampled.
"""

import copy
import dataclasses
import hashlib
import itertools
import json
import math
import pathlib
import zlib

import numpy as np

from rpod.diagrams.scenario import Scenario, ScenarioError, validate_scenario
from rpod.models.gravity import R_EARTH_M, mean_motion
from rpod.scenarios import sampling, schema
from rpod.scenarios.loader import (
    BUNDLED_DIR,
    ScenarioFileError,
    dump_scenario,
    load_scenario,
    read_yaml,
)
from rpod.scenarios.schema import is_record, quote, quote_path
from rpod.scenarios.yaml_reader import tags_from_json, tags_to_json

CAMPAIGNS_DIR = BUNDLED_DIR / "campaigns"
TOP_LEVEL_KEYS = ("description", "base", "overrides", "timeout_s", "grid", "cases", "sample")
SAMPLE_KEYS = ("count", "seed", "fields", "passively_safe")
YAML_SUFFIXES = (".yaml", ".yml")
SNIFF_BYTES = 65536  # how much of a `base:` file is read to tell text from a binary file
PATH_CHARS = 200  # a file path is quoted whole up to this length
MESSAGE_CHARS = 300  # the part of an error line after the file and location, at most
# Most runs one campaign may plan (cases x grid points x samples), refused at load before
# anything is built: the plan holds every run in memory, and a million runs take minutes to plan.
MAX_RUNS = 1_000_000


# ---------------------------------------------------------------------------------------------
# Dotted-path overrides of Scenario fields.


def field_annotation(path: str):
    """The schema type of a dotted Scenario path; ScenarioError(path, ...) if there is none."""
    return schema.path_type(Scenario, path)


def check_value(path: str, value, location: str) -> None:
    """ScenarioError(location, ...) unless value fits the leaf field `path`."""
    annotation = field_annotation(path)
    if is_record(annotation):
        raise ScenarioError(location, f"{path} is a group of fields; name one of its fields")
    schema.check(value, annotation, location)


def _coerce(value, annotation):
    """Plain YAML data that passed the check -> the field's Python type (ints become floats)."""
    return schema.build(value, annotation)


def flatten_overrides(mapping, location: str, prefix: str = "") -> dict:
    """{'chaser': {'mass_kg': 1}} or {'chaser.mass_kg': 1} -> {'chaser.mass_kg': 1}, checked."""
    if not isinstance(mapping, dict):
        raise ScenarioError(
            location, f"expected a mapping of field paths to values, got {quote(mapping)}"
        )
    flat = {}
    for key, value in mapping.items():
        path = f"{prefix}.{key}" if prefix else str(key)
        where = f"{location}.{key}"
        try:
            annotation = field_annotation(path)
        except ScenarioError as error:
            raise ScenarioError(where, error.message) from None
        if is_record(annotation) and isinstance(value, dict):
            flat.update(flatten_overrides(value, where, path))
        else:
            check_value(path, value, where)
            flat[path] = value
    return flat


def _require_field(node, name: str, path: str, walked: str) -> None:
    """ScenarioError unless the dataclass instance has the field: a typed union (the
    controller) whose actual choice lacks a field that another choice has."""
    fields = schema.record_fields(type(node)) if node is not None else None
    if fields is None or name not in fields:
        what = "null" if node is None else f"!{type(node).__name__}"
        raise ScenarioError(path, f"{walked} is {what}, which has no field {quote(name)}")


def apply_overrides(scenario: Scenario, overrides: dict) -> Scenario:
    """A copy of scenario with each dotted path set; ScenarioError(path, ...) on a bad one.

    Values are plain data checked against the schema (as in a scenario file), a union's choice
    as a TaggedMapping or in tags_to_json's form (as the overrides reach a worker); the result
    is not validated as a whole (validate_scenario does that).
    """
    scenario = copy.deepcopy(scenario)
    for path, value in tags_from_json(overrides).items():
        annotation = field_annotation(path)
        schema.check(value, annotation, path)
        tokens = schema.path_tokens(path)
        parent, walked = scenario, ""
        for name, indices in tokens[:-1]:
            _require_field(parent, name, path, walked)
            parent = getattr(parent, name)
            walked = f"{walked}.{name}" if walked else name
            for index in indices:
                parent = parent[index]
        name, indices = tokens[-1]
        _require_field(parent, name, path, walked)
        if not indices:
            setattr(parent, name, schema.build(value, annotation, getattr(parent, name)))
            continue
        container = getattr(parent, name)
        for index in indices[:-1]:
            container = container[index]
        if indices[-1] >= len(container):
            raise ScenarioError(path, f"index {indices[-1]} out of range ({len(container)} items)")
        container[indices[-1]] = _coerce(value, annotation)
    return scenario


def _overlap(a: str, b: str) -> bool:
    """True when setting path a and path b touches the same value."""
    return a == b or b.startswith((a + ".", a + "[")) or a.startswith((b + ".", b + "["))


# ---------------------------------------------------------------------------------------------
# The campaign file.


@dataclasses.dataclass(frozen=True)
class SampleBlock:
    """A campaign's `sample:` block, checked."""

    count: int
    seed: int
    fields: dict  # dotted path -> sampling.Distribution
    passively_safe: sampling.PassivelySafeSampler | None


@dataclasses.dataclass(frozen=True)
class Campaign:
    """A loaded, checked campaign file.

    Attributes:
        name: the file's stem (the default output folder is runs/<name>).
        source: the file, as named in error messages.
        text: the file's text (kept in the results store).
        description: one line shown by `rpod list`.
        base_name: the base scenario's name (its file stem).
        base: the base scenario with the campaign's `overrides` applied.
        grid: dotted path -> list of values, in file order.
        cases: (name, overrides) pairs, in file order.
        sample: the sample block, or None.
        timeout_s: default per-run timeout, or None for no limit.
    """

    name: str
    source: str
    text: str
    description: str
    base_name: str
    base: Scenario
    grid: dict
    cases: list
    sample: SampleBlock | None
    timeout_s: float | None

    @property
    def base_yaml(self) -> str:
        """The base scenario (after `overrides`) as YAML, every field written."""
        return dump_scenario(self.base)

    def with_seed(self, seed: int) -> "Campaign":
        """The same campaign with another sampling seed."""
        if self.sample is None:
            raise ScenarioFileError(
                f"{self.source}: sample.seed: a seed was given but the "
                "campaign samples nothing (it has no sample block)"
            )
        return dataclasses.replace(self, sample=dataclasses.replace(self.sample, seed=seed))


@dataclasses.dataclass(frozen=True)
class PlannedRun:
    """One run of a campaign: plain data, the same on every machine.

    Attributes:
        run_id: stable id (see the module docstring).
        index: position in the plan (case-major, then grid, then sample).
        group: label of its case and grid point ('all' when there are neither).
        case: the case name, or ''.
        grid_point: dotted path -> value of its grid point.
        sample_index: its sample number, or None.
        overrides: every override of this run on top of the campaign's base.
    """

    run_id: str
    index: int
    group: str
    case: str
    grid_point: dict
    sample_index: int | None
    overrides: dict


def _cut(text, limit: int) -> str:
    """text on one line, cut to `limit` characters ("..." marks the cut)."""
    text = " ".join(str(text).split())
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _say(source, location: str | None, *message: str) -> ScenarioFileError:
    """'source: location: message', each part cut: the file's path to PATH_CHARS, the location
    (built from the file's keys) to quote_path's length, the message to MESSAGE_CHARS. Every
    error of a campaign file goes through here, so no key or value of it is echoed whole."""
    head = _cut(source, PATH_CHARS) + (f": {quote_path(_cut(location, 1000))}" if location else "")
    return ScenarioFileError(f"{head}: {_cut(': '.join(message), MESSAGE_CHARS)}")


def _error(source: str, error: ScenarioError) -> ScenarioFileError:
    return _say(source, error.field, error.message)


def _count(number: int) -> str:
    """A count for an error line: 1,234,567, or its order of magnitude when it is huge."""
    return f"{number:,}" if number < 10**15 else f"about 10^{len(str(number)) - 1}"


def _require_int(value, location: str, minimum: int) -> int:
    if not isinstance(value, int) or isinstance(value, bool) or value < minimum:
        raise ScenarioError(location, f"expected an integer >= {minimum}, got {quote(value)}")
    return value


def _parse_grid(data) -> dict:
    if not isinstance(data, dict) or not data:
        raise ScenarioError(
            "grid", "empty grid: give at least one field path with a list of values"
        )
    grid = {}
    for path, values in data.items():
        location = f"grid.{path}"
        try:
            annotation = field_annotation(path)
        except ScenarioError as error:
            raise ScenarioError(location, error.message) from None
        if not isinstance(values, list) or not values:
            raise ScenarioError(
                location, f"empty grid: expected a non-empty list of values, got {quote(values)}"
            )
        if is_record(annotation):
            raise ScenarioError(location, f"{path} is a group of fields; name one of its fields")
        seen = {}  # canonical JSON of each value as the field holds it (1 and 1.0 are one value)
        for index, value in enumerate(values):
            schema.check(value, annotation, f"{location}[{index}]")
            key = json.dumps(_coerce(value, annotation), sort_keys=True)
            if key in seen:
                raise ScenarioError(
                    f"{location}[{index}]", f"{quote(value)} is listed twice (also [{seen[key]}])"
                )
            seen[key] = index
        grid[str(path)] = values
    return grid


def _parse_cases(data) -> list:
    if not isinstance(data, list) or not data:
        raise ScenarioError("cases", "expected a non-empty list of {name, overrides}")
    cases, names = [], set()
    for index, case in enumerate(data):
        location = f"cases[{index}]"
        if not isinstance(case, dict):
            raise ScenarioError(location, "expected a mapping with name and overrides")
        for key in case:
            if key not in ("name", "overrides"):
                raise ScenarioError(f"{location}.{key}", "unknown key (known: name, overrides)")
        name = case.get("name", f"case{index}")
        if not isinstance(name, str) or not name or name in names:
            raise ScenarioError(
                f"{location}.name", f"expected a unique non-empty name, got {quote(name)}"
            )
        names.add(name)
        overrides = flatten_overrides(case.get("overrides", {}), f"{location}.overrides")
        cases.append((name, overrides))
    return cases


def _parse_sample(data) -> SampleBlock:
    if not isinstance(data, dict):
        raise ScenarioError("sample", "expected a mapping with count, seed, fields, passively_safe")
    for key in data:
        if key not in SAMPLE_KEYS:
            raise ScenarioError(f"sample.{key}", f"unknown key (known: {', '.join(SAMPLE_KEYS)})")
    count = _require_int(data.get("count"), "sample.count", 1)
    seed = _require_int(data.get("seed", 0), "sample.seed", 0)
    fields = {}
    raw_fields = data.get("fields", {})
    if not isinstance(raw_fields, dict):
        raise ScenarioError("sample.fields", "expected a mapping of field paths to distributions")
    for path, spec in raw_fields.items():
        location = f"sample.fields.{path}"
        try:
            annotation = field_annotation(path)
        except ScenarioError as error:
            raise ScenarioError(location, error.message) from None
        distribution = sampling.parse_distribution(spec, location)
        if is_record(annotation):
            raise ScenarioError(location, f"{path} is a group of fields; name one of its fields")
        fields[str(path)] = distribution
    passively_safe = None
    if "passively_safe" in data:
        passively_safe = sampling.parse_passively_safe(
            data["passively_safe"], "sample.passively_safe"
        )
        for path in fields:
            for target in passively_safe.fields:
                if _overlap(path, target):
                    raise ScenarioError(
                        f"sample.fields.{path}", f"passively_safe already sets {target}"
                    )
    if not fields and passively_safe is None:
        raise ScenarioError("sample", "samples nothing: give fields or passively_safe")
    return SampleBlock(count, seed, fields, passively_safe)


def _check_run_count(grid: dict, cases: list, sample: SampleBlock | None) -> None:
    """ScenarioError above MAX_RUNS runs, counted from the sizes before anything is built."""
    factors = {
        "cases": len(cases) or 1,
        "grid": math.prod(len(values) for values in grid.values()),
        "sample.count": sample.count if sample else 1,
    }
    total = math.prod(factors.values())
    if total > MAX_RUNS:
        sizes = " x ".join(_count(n) for n in factors.values())
        raise ScenarioError(
            max(factors, key=factors.get),
            f"{_count(total)} runs planned (cases x grid points x samples = {sizes}), above "
            f"the limit of {MAX_RUNS:,}",
        )


def _check_no_conflicts(grid: dict, cases: list, sample: SampleBlock | None) -> None:
    """Grid, sample and cases must not set the same field (which one would win is unclear)."""
    setters = [(f"grid.{p}", p) for p in grid]
    if sample is not None:
        setters += [(f"sample.fields.{p}", p) for p in sample.fields]
        if sample.passively_safe is not None:
            setters += [("sample.passively_safe", p) for p in sample.passively_safe.fields]
    for (where_a, a), (where_b, b) in itertools.combinations(setters, 2):
        if where_a != where_b and _overlap(a, b):
            raise ScenarioError(where_b, f"sets {b}, which {where_a} also sets")
    for index, (_, overrides) in enumerate(cases):
        for path in overrides:
            for where, other in setters:
                if _overlap(path, other):
                    raise ScenarioError(
                        f"cases[{index}].overrides.{path}", f"{where} also sets this field"
                    )


def parse_campaign(text: str, source: str, name: str, base_dir: pathlib.Path) -> Campaign:
    """A Campaign from YAML text; ScenarioFileError('source: location: message') on a problem."""
    data = read_yaml(text, source)
    try:
        if not isinstance(data, dict):
            raise ScenarioError("(top level)", "expected a mapping with base and grid/cases/sample")
        for key in data:
            if key not in TOP_LEVEL_KEYS:
                raise ScenarioError(str(key), f"unknown key (known: {', '.join(TOP_LEVEL_KEYS)})")
        if "base" not in data or not isinstance(data["base"], str):
            raise ScenarioError("base", "missing: name a bundled scenario or a scenario file")
        description = data.get("description", "")
        if not isinstance(description, str):
            raise ScenarioError("description", "expected a string")
        timeout_s = data.get("timeout_s")
        if timeout_s is not None and (
            isinstance(timeout_s, bool)
            or not isinstance(timeout_s, (int, float))
            or not 0 < timeout_s < math.inf
        ):
            raise ScenarioError(
                "timeout_s",
                f"expected a positive, finite number of seconds, got {quote(timeout_s)}",
            )
        overrides = flatten_overrides(data.get("overrides", {}), "overrides")
        grid = _parse_grid(data["grid"]) if "grid" in data else {}
        cases = _parse_cases(data["cases"]) if "cases" in data else []
        sample = _parse_sample(data["sample"]) if "sample" in data else None
        if not grid and not cases and sample is None:
            raise ScenarioError("(top level)", "nothing to vary: give grid, cases or sample")
        _check_run_count(grid, cases, sample)
        _check_no_conflicts(grid, cases, sample)
    except ScenarioError as error:
        raise _error(source, error) from None

    base_name, base = _load_base(data["base"], base_dir, source)
    try:
        base = apply_overrides(base, overrides)
        validate_scenario(base)
    except ScenarioError as error:
        raise _say(source, f"overrides.{error.field}", error.message) from None
    return Campaign(
        name,
        source,
        text,
        description,
        base_name,
        base,
        grid,
        cases,
        sample,
        None if timeout_s is None else float(timeout_s),
    )


def _binary(path: pathlib.Path) -> str | None:
    """Why the file is a binary file and not text (from its first SNIFF_BYTES), or None."""
    with open(path, "rb") as handle:
        head = handle.read(SNIFF_BYTES)
    if b"\0" in head:
        return "it holds NUL bytes: a binary file"
    try:
        head.decode("utf-8")
    except UnicodeDecodeError as error:
        if len(head) < SNIFF_BYTES or error.start < len(head) - 3:  # not a character cut short
            return "it is not UTF-8 text: a binary file"
    return None


def _load_base(base: str, base_dir: pathlib.Path, source: str):
    """(name, Scenario) of a campaign's `base:`: a scenario file relative to the campaign, or a
    bundled scenario. ScenarioFileError naming the campaign's `base`. A file that is not a
    scenario YAML file (a binary file, or one not named .yaml/.yml that does not read as a
    scenario: a Python file) is said to be one, with at most a short cut of what it holds; a
    problem inside a YAML file names that file and its field."""
    path = base_dir / base
    try:
        is_file = path.is_file()
        why = _binary(path) if is_file else None
    except OSError as error:  # a name too long, a file that cannot be opened
        raise _say(source, "base", f"{quote(base)}: cannot be read ({error.strerror})") from None
    shown = _cut(path, PATH_CHARS)
    if why:
        raise _say(source, "base", f"{shown} is not a scenario YAML file ({why})")
    if not is_file:
        if path.is_dir():
            raise _say(source, "base", f"{shown} is a folder, not a scenario YAML file")
        try:
            return load_scenario(base)  # a bundled name
        except ScenarioFileError as error:
            if "no such file" not in str(error):
                raise
            reason = str(error)[len(base) :] if str(error).startswith(base) else f": {error}"
            raise _say(source, "base", _cut(base, PATH_CHARS) + reason) from None
    try:
        return load_scenario(str(path))
    except ScenarioFileError as error:
        if path.suffix.lower() in YAML_SUFFIXES:
            raise  # a problem inside the base file names that file and field
        reason = str(error).removeprefix(f"{path}: ")
        kind = f"a {path.suffix} file" if path.suffix else "a file without .yaml"
        raise _say(
            source,
            "base",
            f"{shown} is not a scenario YAML file ({kind}; read as one: {_cut(reason, 60)})",
        ) from None


def bundled_campaigns() -> dict[str, pathlib.Path]:
    """Bundled campaign names -> their files."""
    return {path.stem: path for path in sorted(CAMPAIGNS_DIR.glob("*.yaml"))}


def load_campaign(name_or_path: str) -> Campaign:
    """A campaign from a path or a bundled name; ScenarioFileError on any problem."""
    path = pathlib.Path(name_or_path)
    try:
        is_file = path.is_file()
    except OSError as error:  # e.g. a name too long
        raise _say(name_or_path, None, f"cannot be read ({error.strerror})") from None
    if not is_file:
        bundled = bundled_campaigns()
        if name_or_path in bundled:
            path = bundled[name_or_path]
        elif path.suffix or "/" in name_or_path:
            raise _say(name_or_path, None, "no such file")
        else:
            raise _say(
                name_or_path,
                None,
                f"no such file or bundled campaign (bundled: {', '.join(bundled)})",
            )
    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError) as error:
        why = error.strerror if isinstance(error, OSError) else error
        raise _say(path, None, f"cannot read: {why}") from None
    return parse_campaign(text, str(path), path.stem, path.resolve().parent)


# ---------------------------------------------------------------------------------------------
# The plan.


def _rng(seed: int, index: int, key: str) -> np.random.Generator:
    """The Generator of one sampled field of one sample: independent of every other field."""
    return np.random.default_rng(
        np.random.SeedSequence(seed, spawn_key=(index, zlib.crc32(key.encode())))
    )


def draw_sample(sample: SampleBlock, index: int) -> tuple[dict, dict | None]:
    """(field overrides, passively safe draw or None) of sample number `index`."""
    fields = {path: d.draw(_rng(sample.seed, index, path)) for path, d in sample.fields.items()}
    safe = None
    if sample.passively_safe is not None:
        safe = sample.passively_safe.draw(
            lambda name: _rng(sample.seed, index, f"passively_safe.{name}")
        )
    return fields, safe


def plain_data(value):
    """A scenario (or any part of it) as plain JSON data: dataclasses and Drake's bound configs
    (SimulatorConfig) as dicts of their fields; the controller, a typed union, with its tag
    under '_tag' (two controllers with the same fields are different runs)."""
    fields = schema.record_fields(type(value)) if value is not None else None
    if fields is not None:
        data = {name: plain_data(getattr(value, name)) for name in fields}
        if "controller" in data and data["controller"] is not None:
            data["controller"]["_tag"] = type(value.controller).__name__
        return data
    if isinstance(value, list):
        return [plain_data(item) for item in value]
    return value


def base_fingerprint(campaign: "Campaign") -> str:
    """The hash of the campaign's base scenario as this code resolves it (every default
    included): two stores with the same fingerprint planned their runs on the same base, so a
    run of one and a run of the other with the same overrides are the same scenario."""
    canonical = json.dumps(plain_data(campaign.base), sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(canonical.encode()).hexdigest()[:16]


def run_id(base_data: dict, overrides: dict, sample_key) -> str:
    """The stable id of a run (see the module docstring)."""
    canonical = json.dumps(
        {"base": base_data, "overrides": overrides, "sample": sample_key},
        sort_keys=True,
        separators=(",", ":"),
        allow_nan=False,
    )
    return hashlib.sha256(canonical.encode()).hexdigest()[:16]


def _label(value) -> str:
    return value if isinstance(value, str) else json.dumps(value)


def plan_runs(campaign: Campaign) -> list[PlannedRun]:
    """Every run of the campaign, each applied to the base and validated (nothing is run).

    Raises ScenarioFileError naming the campaign location whose value makes a run invalid.
    """
    base_data = plain_data(campaign.base)
    grid_paths = list(campaign.grid)
    grid_points = [
        dict(zip(grid_paths, values)) for values in itertools.product(*campaign.grid.values())
    ] or [{}]
    cases = campaign.cases or [("", {})]
    sample = campaign.sample
    samples = [({}, None)]
    if sample:
        samples = []
        for k in range(sample.count):
            try:
                samples.append(draw_sample(sample, k))
            except ScenarioError as error:  # e.g. start_range_m never met
                raise _say(campaign.source, error.field, f"sample {k}", error.message) from None

    runs, seen = [], {}
    for case_index, (case_name, case_overrides) in enumerate(cases):
        for grid_point in grid_points:
            group = (
                " | ".join(
                    ([case_name] if case_name else [])
                    + [f"{path}={_label(value)}" for path, value in grid_point.items()]
                )
                or "all"
            )
            for sample_index, (fields, safe) in enumerate(samples):
                locations = {p: f"cases[{case_index}].overrides.{p}" for p in case_overrides}
                locations.update({p: f"grid.{p}" for p in grid_point})
                locations.update({p: f"sample.fields.{p}" for p in fields})
                overrides = tags_to_json({**case_overrides, **grid_point, **fields})
                try:
                    scenario = apply_overrides(campaign.base, overrides)
                    if safe is not None:
                        if scenario.orbit.gravity == "free_space":
                            raise ScenarioError(
                                "sample.passively_safe",
                                "needs an orbit, and orbit.gravity is free_space",
                            )
                        n = mean_motion(R_EARTH_M + scenario.orbit.altitude_m)
                        safe_overrides = sampling.passively_safe_overrides(
                            safe,
                            n,
                            scenario.chaser.capture_point_C
                            if sample.passively_safe.point_at_target
                            else None,
                        )
                        locations.update({p: "sample.passively_safe" for p in safe_overrides})
                        overrides.update(safe_overrides)
                        scenario = apply_overrides(scenario, safe_overrides)
                    validate_scenario(scenario)
                except ScenarioError as error:
                    where = next(
                        (loc for p, loc in locations.items() if _overlap(p, error.field)),
                        error.field,
                    )
                    which = f"run {len(runs)} ({_cut(group, 120)}" + (
                        f", sample {sample_index})" if sample else ")"
                    )
                    raise _say(
                        campaign.source, where, which, quote_path(error.field), error.message
                    ) from None
                sample_key = [sample.seed, sample_index] if sample else None
                identifier = run_id(base_data, overrides, sample_key)
                if identifier in seen:
                    raise _say(  # only cases can repeat: grid values are unique
                        campaign.source,
                        f"cases[{case_index}]",
                        f"run {len(runs)} ({_cut(group, 120)}) is the same run as run "
                        f"{seen[identifier]} (same overrides)",
                    )
                seen[identifier] = len(runs)
                runs.append(
                    PlannedRun(
                        identifier,
                        len(runs),
                        group,
                        case_name,
                        grid_point,
                        sample_index if sample else None,
                        overrides,
                    )
                )
    return runs
