"""Every field of every registered plug-in's config is checked at load (issue 20): each numeric
field declares its bounds (rpod.models.config), and 0, -1, NaN, inf and 1e308 either load (when
the bounds admit them) or give one ConfigError naming `controller.<field>`, never a traceback,
a hang or a silent acceptance of a value outside the bounds."""

import dataclasses
import math
import typing

import pytest

from rpod.diagrams import controller_seam
from rpod.diagrams.scenario import ScenarioError, validate_scenario
from rpod.models.config import field_bounds, is_numeric, unbounded_numeric_fields
from rpod.scenarios.campaign import apply_overrides
from rpod.scenarios.loader import bundled_scenarios, load_scenario

PROBES = (0, -1, math.nan, math.inf, 1e308)


def _bases() -> dict:
    """Tag -> a bundled scenario flown by that plug-in (the first one, by name)."""
    bases = {}
    for name in bundled_scenarios():
        scenario = load_scenario(name)[1]
        if scenario.controller is not None:
            bases.setdefault(type(scenario.controller).__name__, scenario)
    return bases


BASES = _bases()
PLUGINS = [p for p in controller_seam.controller_plugins() if p.tag in BASES]


def _numeric_fields(config_type, prefix=""):
    """(dotted path, field, annotation) of every numeric field, nested blocks included."""
    hints = typing.get_type_hints(config_type)
    for field in dataclasses.fields(config_type):
        path = f"{prefix}.{field.name}" if prefix else field.name
        annotation = hints[field.name]
        if dataclasses.is_dataclass(annotation):
            yield from _numeric_fields(annotation, path)
        elif is_numeric(annotation):
            yield path, field, annotation


def _value_at(config, path: str):
    for name in path.split("."):
        config = getattr(config, name)
    return config


def _filled(current, probe):
    """The probe in place of a number, or of every entry of a list (of lists); an empty list
    (a point left to be derived) gets a 3-vector of probes."""
    if isinstance(current, list):
        return [_filled(item, probe) for item in current] if current else [probe] * 3
    return probe


def test_every_builtin_plugin_has_a_bundled_scenario_to_probe():
    builtin = [
        p
        for p in controller_seam.controller_plugins()
        if type(p).__module__.startswith("rpod.diagrams.controllers.")
    ]  # other test files register their own test controllers in the same process
    assert len(builtin) == 5 and {p.tag for p in builtin} <= set(BASES)


@pytest.mark.parametrize("plugin", PLUGINS, ids=lambda p: p.tag)
def test_every_numeric_field_declares_its_bounds(plugin):
    assert unbounded_numeric_fields(plugin.config_type) == []


@pytest.mark.parametrize("plugin", PLUGINS, ids=lambda p: p.tag)
def test_each_numeric_field_takes_0_minus_1_nan_inf_and_1e308_safely(plugin):
    base = BASES[plugin.tag]
    for path, field, annotation in _numeric_fields(plugin.config_type):
        bounds = field_bounds(field)
        current = _value_at(base.controller, path)
        for probe in PROBES:
            value = _filled(current, probe)
            where = f"controller.{path} = {probe!r}"
            try:
                scenario = apply_overrides(base, {f"controller.{path}": value})
                validate_scenario(scenario)
            except ScenarioError as error:
                assert (
                    error.field.startswith(f"controller.{path}") or error.field == "controller"
                ), f"{where}: the error names {error.field}: {error.message}"
                assert "\n" not in str(error) and len(str(error)) < 300, where
                continue
            admitted = bounds is not None and bounds.admits(float(probe))
            assert admitted, f"{where}: accepted, outside its declared bounds"
