"""ConfigError and declared bounds (rpod.models.config)."""

import dataclasses
import math

import pytest

from rpod.models.config import (
    ConfigError,
    bounded,
    check_bounds,
    count,
    positive,
    unbounded_numeric_fields,
)


@dataclasses.dataclass
class _Inner:
    iterations: int = count(10, 1, 100)
    weights: list[float] = bounded([1.0, 2.0], 0.0, 1e6)  # noqa: RUF009 (a field())


@dataclasses.dataclass
class _Outer:
    period_s: float = positive(0.5, 60.0)
    gain: float | None = bounded(None, 0.0, 10.0)
    inner: _Inner = dataclasses.field(default_factory=_Inner)
    loose: float = 1.0


def test_config_error_carries_the_field_and_nests_under_a_prefix():
    error = ConfigError("mpc.horizon", "must be at most 500, got 100000")
    assert (error.field, error.message) == ("mpc.horizon", "must be at most 500, got 100000")
    assert str(error) == "mpc.horizon: must be at most 500, got 100000"
    assert isinstance(error, ValueError)
    nested = error.under("controller")
    assert (nested.field, nested.message) == ("controller.mpc.horizon", error.message)


def test_defaults_pass_and_every_bound_is_enforced_with_the_dotted_field():
    check_bounds(_Outer())
    for path, value, words in (
        ("period_s", 0.0, "in (0, 60]"),
        ("period_s", 61.0, "in (0, 60]"),
        ("period_s", math.nan, "finite"),
        ("gain", 11.0, "in [0, 10]"),
        ("inner.iterations", 0, "in [1, 100]"),
        ("inner.iterations", 10**401, "finite"),
        ("inner.weights", [1.0, -1.0], "in [0, 1e+06]"),
        ("loose", math.inf, "finite"),
        ("loose", 1e308 * 10, "finite"),
    ):
        config = _Outer()
        target, name = (config.inner, path.split(".")[1]) if "." in path else (config, path)
        setattr(target, name, value)
        with pytest.raises(ConfigError) as raised:
            check_bounds(config)
        assert raised.value.field == path
        assert words in raised.value.message


def test_an_unset_optional_is_not_checked_and_bools_are_not_numbers():
    check_bounds(_Outer(gain=None))
    assert unbounded_numeric_fields(_Outer) == ["loose"]
