"""What every config says about itself: `ConfigError`, and the bounds of its numeric fields.

Owns: `ConfigError(field, message)`, the one error a config's `validate()` raises (the field is
dotted, relative to the config; a caller that nests the config prefixes it with `under`), and
`bounded`, the dataclass field that states a number's legal range beside its default, which
`check_bounds` enforces for a whole config, nested settings blocks included.
Does not own: reading configs from files (rpod.scenarios) or the checks that need more than one
field (each config's own `validate()`).

Why bounds live on the field: every size that sets the work of a run (a horizon, a number of
intervals, samples or faces, a duration) must have an upper bound, and every number a range, or a
typo (`horizon: 100000`, `a_max_m_s2: 1e308`) hangs a run or overflows in its plots instead of
being refused at load. Stated beside the default, the bound is read where the field is, and a test
(tests/diagrams/test_config_bounds.py) walks every registered plug-in's config and feeds each
numeric field 0, -1, NaN, inf and 1e308.
"""

from __future__ import annotations

import dataclasses
import math
import types
import typing

BOUNDS_KEY = "rpod_bounds"
"""Field metadata: the field's `Bounds`."""
CHOICES_KEY = "rpod_choices"
"""Field metadata of a typed union whose members come from a registry (the scenario's
controller): a callable returning the member types; None is always allowed."""


class ConfigError(ValueError):
    """A config field is invalid; `field` is its dotted path (e.g. 'mpc.horizon').

    A ValueError, so code that guards a config with `except ValueError` still catches it.
    """

    def __init__(self, field: str, message: str):
        super().__init__(f"{field}: {message}" if field else message)
        self.field = field
        self.message = message

    def under(self, prefix: str) -> ConfigError:
        """The same error with its field seen from the enclosing block (`prefix.field`)."""
        field = f"{prefix}.{self.field}" if prefix and self.field else prefix or self.field
        return type(self)(field, self.message)


@dataclasses.dataclass(frozen=True)
class Bounds:
    """The legal range of a number: [low, high], either end open when `*_open`.

    `None` leaves an end unbounded; every number must be finite whatever its bounds.
    """

    low: float | None = None
    high: float | None = None
    low_open: bool = False
    high_open: bool = False

    def describe(self) -> str:
        """'in (0, 10]', 'at least 1', 'at most 5', or 'finite'."""
        if self.low is not None and self.high is not None:
            left, right = "(" if self.low_open else "[", ")" if self.high_open else "]"
            return f"in {left}{self.low:g}, {self.high:g}{right}"
        if self.low is not None:
            return f"{'greater than' if self.low_open else 'at least'} {self.low:g}"
        if self.high is not None:
            return f"{'less than' if self.high_open else 'at most'} {self.high:g}"
        return "finite"

    def admits(self, value: float) -> bool:
        """True when value is finite and within the bounds."""
        if not math.isfinite(value):
            return False
        if self.low is not None and (value <= self.low if self.low_open else value < self.low):
            return False
        return self.high is None or (value < self.high if self.high_open else value <= self.high)


def bounded(
    default,
    low: float | None = None,
    high: float | None = None,
    *,
    low_open: bool = False,
    high_open: bool = False,
):
    """A dataclass field with a default and the legal range of its number(s).

    For a list of numbers (or a list of lists), the bounds apply to every entry. A value of
    None (an Optional field left unset) is not checked.
    """
    metadata = {BOUNDS_KEY: Bounds(low, high, low_open, high_open)}
    if isinstance(default, list):
        return dataclasses.field(default_factory=lambda: list(default), metadata=metadata)
    return dataclasses.field(default=default, metadata=metadata)


def positive(default, high: float):
    """A number in (0, high]: a period, a length, a gain, a limit."""
    return bounded(default, 0.0, high, low_open=True)


def count(default: int, low: int, high: int):
    """An integer in [low, high]: a horizon, a number of iterations, samples or faces."""
    return bounded(default, low, high)


def field_bounds(field: dataclasses.Field) -> Bounds | None:
    """The bounds a field declares (None: none)."""
    return field.metadata.get(BOUNDS_KEY)


def _numbers(value):
    """The numbers in a value: itself, or every entry of a (nested) list; bools excluded."""
    if isinstance(value, bool):
        return
    if isinstance(value, (int, float)):
        yield value
    elif isinstance(value, (list, tuple)):
        for item in value:
            yield from _numbers(item)


def as_float(value) -> float:
    """float(value), an integer too large for a float becoming +-inf (never OverflowError)."""
    try:
        return float(value)
    except OverflowError:  # an integer of hundreds of digits
        return math.inf if value > 0 else -math.inf


def check_bounds(config, prefix: str = "") -> None:
    """Raises ConfigError naming the first field of config (nested dataclasses included) whose
    number is non-finite or outside its declared bounds."""
    for field in dataclasses.fields(config):
        value = getattr(config, field.name)
        path = f"{prefix}.{field.name}" if prefix else field.name
        if dataclasses.is_dataclass(value) and not isinstance(value, type):
            check_bounds(value, path)
            continue
        bounds = field_bounds(field)
        for number in _numbers(value):
            x = as_float(number)
            if not math.isfinite(x):
                raise ConfigError(path, f"must be finite, got {_short(number)}")
            if bounds is not None and not bounds.admits(x):
                raise ConfigError(path, f"must be {bounds.describe()}, got {_short(number)}")


def _short(number) -> str:
    text = f"{number:g}" if isinstance(number, float) else str(number)
    return text if len(text) <= 24 else text[:21] + "..."


def is_numeric(annotation) -> bool:
    """True for int, float, Optional of them and (nested) lists of them."""
    if annotation in (int, float):
        return True
    origin = typing.get_origin(annotation)
    args = [a for a in typing.get_args(annotation) if a is not type(None)]
    if origin in (typing.Union, types.UnionType):
        return len(args) == 1 and is_numeric(args[0])
    if origin in (list, tuple):
        return bool(args) and all(is_numeric(a) for a in args if a is not Ellipsis)
    return False


def unbounded_numeric_fields(config_type: type, prefix: str = "") -> list[str]:
    """Dotted names of the numeric fields of a config dataclass (nested ones included) that
    declare no bounds: each is a size or a value a typo could make absurd."""
    missing = []
    hints = typing.get_type_hints(config_type)
    for field in dataclasses.fields(config_type):
        path = f"{prefix}.{field.name}" if prefix else field.name
        annotation = hints[field.name]
        if dataclasses.is_dataclass(annotation):
            missing += unbounded_numeric_fields(annotation, path)
        elif is_numeric(annotation) and field_bounds(field) is None:
            missing.append(path)
    return missing
