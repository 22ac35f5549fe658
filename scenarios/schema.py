"""The one walk of the scenario schema: check plain YAML data, build the typed scenario, dump it.

Owns: what a schema type means to a YAML writer, in one place for scenario files, `--set` and
campaign overrides: checking plain data (from rpod.scenarios.yaml_reader) against an annotation
with a one-line `ConfigError` naming the dotted field; building the dataclasses from the checked
data over their defaults; dumping a typed value back to plain data with its tags; and the type
of a dotted path (`controller.mpc.horizon`, `chaser.p_LC_L[1]`).
Does not own: the schema itself (rpod.diagrams.scenario and the configs beside their systems and
plug-ins), the bounds and cross-field checks of a config (rpod.models.config, each `validate()`),
or files (loader.py, campaign.py).

Types it understands: dataclasses and Drake's bound configs (SimulatorConfig: their
`__fields__`), bool, int, float (finite), str, `list[T]`, `dict[str, T]`, `Literal[...]`,
`Optional[T]` / `T | None`, and typed unions chosen by YAML tag (`!HoldPoint {...}`), whether
written as a `Union` of dataclasses or as a field whose metadata names a registry of choices
(`CHOICES_KEY`: the scenario's `controller`, whose choices are the plug-ins registered when the
scenario is read, so no annotation is ever rewritten as plug-ins register).

Building, as Drake's `yaml_load_typed` does for the same data: a field the YAML leaves out keeps
its default, a nested block given in part keeps the defaults of the rest, a list or a mapping is
replaced whole, and a tagged union keeps its default's fields when the tag names the default's own
type and starts from that type's defaults otherwise. An untagged union block is the first choice.
"""

from __future__ import annotations

import copy
import dataclasses
import functools
import math
import re
import types
import typing

from rpod.models.config import CHOICES_KEY, ConfigError, as_float
from rpod.scenarios.yaml_reader import TaggedMapping

QUOTE_CHARS = 60  # longest quotation of a bad value in an error message
_TOKEN = re.compile(r"^([A-Za-z_][A-Za-z0-9_]*)((?:\[\d+\])*)$")


# ---------------------------------------------------------------------------------------------
# What a type is.


def record_fields(annotation) -> dict | None:
    """{field: type} of a record (a dataclass, or a Drake config bound from C++ with
    DefAttributesUsingSerialize, e.g. SimulatorConfig); None for any other type. A field with
    registry choices (CHOICES_KEY) has the union of the choices registered now, and None."""
    if dataclasses.is_dataclass(annotation) and isinstance(annotation, type):
        hints, registries = _dataclass_hints(annotation)
        if not registries:
            return types.MappingProxyType(hints)  # the cached mapping, read-only
        hints = dict(hints)
        for name, choices in registries.items():  # read now: plug-ins register at any time
            hints[name] = typing.Union[(*choices(), type(None))]
        return hints
    fields = getattr(annotation, "__fields__", None)
    if isinstance(annotation, type) and fields is not None:
        return {field.name: field.type for field in fields}
    return None


@functools.cache
def _dataclass_hints(record: type) -> tuple[dict, dict]:
    """({field: type}, {field: its registry of choices}) of a dataclass, resolved once: a
    campaign of thousands of runs walks the same few types hundreds of thousands of times."""
    registries = {
        field.name: field.metadata[CHOICES_KEY]
        for field in dataclasses.fields(record)
        if CHOICES_KEY in field.metadata
    }
    return typing.get_type_hints(record), registries


def is_record(annotation) -> bool:
    """True for a type with named fields (record_fields)."""
    return record_fields(annotation) is not None


def _is_union(annotation) -> bool:
    return typing.get_origin(annotation) in (typing.Union, types.UnionType)


def union_parts(annotation) -> tuple[list, bool]:
    """(the non-None members of a Union, whether None is allowed)."""
    args = typing.get_args(annotation)
    return [a for a in args if a is not type(None)], type(None) in args


def is_tagged_union(annotation) -> bool:
    """True for a Union whose members are records (chosen by YAML tag)."""
    if not _is_union(annotation):
        return False
    members, _ = union_parts(annotation)
    return bool(members) and all(is_record(m) for m in members)


def type_name(annotation) -> str:
    """What a YAML writer must give for a type, e.g. 'a number', 'one of 'L', 'C''."""
    if is_tagged_union(annotation):
        members, nullable = union_parts(annotation)
        names = [f"!{m.__name__} {{...}}" for m in members] + ["null"] * nullable
        return "one of " + ", ".join(names)
    if _is_union(annotation):
        members, nullable = union_parts(annotation)
        names = [type_name(m) for m in members] + ["null"] * nullable
        return " or ".join(names)
    origin = typing.get_origin(annotation)
    if origin is typing.Literal:
        return "one of " + ", ".join(repr(a) for a in typing.get_args(annotation))
    if origin is list:
        return f"a list of {type_name(typing.get_args(annotation)[0])}"
    if origin is dict:
        return f"a mapping of names to {type_name(typing.get_args(annotation)[1])}"
    if is_record(annotation):
        return "a mapping"
    return {float: "a number", int: "an integer", bool: "true or false", str: "a string"}.get(
        annotation, getattr(annotation, "__name__", str(annotation))
    )


# ---------------------------------------------------------------------------------------------
# Quoting values in errors.


def quote(value, limit: int = QUOTE_CHARS) -> str:
    """repr(value) on one line, cut to `limit` characters: error messages stay one short line.

    A YAML alias bomb expands to a value whose repr has billions of characters, and a number
    can have thousands of digits: containers are quoted item by item and abandoned once past
    the limit, and an integer's digits are not all rendered.
    """
    parts, length, cut = [], 0, False
    for piece in _repr_pieces(value, limit):
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


def _repr_pieces(value, limit: int):
    """repr(value) as a stream of pieces (lists and dicts item by item)."""
    if isinstance(value, list):
        yield "["
        for index, item in enumerate(value):
            yield ", " if index else ""
            yield from _repr_pieces(item, limit)
        yield "]"
    elif isinstance(value, dict):
        yield f"!{value.tag} {{" if isinstance(value, TaggedMapping) else "{"
        for index, (key, item) in enumerate(value.items()):
            yield (", " if index else "") + _short_repr(key, limit) + ": "
            yield from _repr_pieces(item, limit)
        yield "}"
    else:
        yield _short_repr(value, limit)


def _short_repr(value, limit: int) -> str:
    if isinstance(value, int) and not isinstance(value, bool) and abs(value) > 10**limit:
        return f"an integer of more than {limit} digits"
    if isinstance(value, str) and len(value) > limit:
        value = value[:limit]
    return repr(value)


# ---------------------------------------------------------------------------------------------
# Checking plain data.


def _tag(value) -> str | None:
    return value.tag if isinstance(value, TaggedMapping) else None


def chosen_member(value, annotation, field: str):
    """The member of a tagged union that a (mapping) value selects; ConfigError otherwise."""
    members, _ = union_parts(annotation)
    tag = _tag(value)
    if tag is None:  # untagged: the first choice, as Drake's yaml_load_typed reads it
        return members[0]
    for member in members:
        if member.__name__ == tag:
            return member
    known = ", ".join(f"!{m.__name__}" for m in members)
    raise ConfigError(field, f"unknown tag !{quote(tag)[1:-1]} (known: {known})")


def _no_tag(value, field: str) -> None:
    tag = _tag(value)
    if tag is not None:
        raise ConfigError(
            field or "(top level)",
            f"a tag (!{quote(tag)[1:-1]}) chooses a member of a typed union; this block is not "
            "one: remove the tag",
        )


def check(value, annotation, field: str = "") -> None:
    """ConfigError(field, ...) unless plain YAML data fits the annotation, nested fields named
    by their dotted path."""
    expected = type_name(annotation)
    if is_tagged_union(annotation):
        members, nullable = union_parts(annotation)
        if value is None and nullable:
            return
        if not isinstance(value, dict):
            raise ConfigError(field, f"expected {expected}, got {quote(value)}")
        member = chosen_member(value, annotation, field)
        _check_record(value, member, field)
        return
    if _is_union(annotation):  # Optional[T] of a plain type
        members, nullable = union_parts(annotation)
        if value is None and nullable:
            return
        deeper = None
        for member in members:
            try:
                check(value, member, field)
                return
            except ConfigError as error:
                deeper = deeper or (error if error.field != field else None)
        if deeper is not None and len(members) == 1:  # a nested field of the one member
            raise deeper
        raise ConfigError(field, f"expected {expected}, got {quote(value)}")
    if is_record(annotation):
        if not isinstance(value, dict):
            raise ConfigError(field or "(top level)", f"expected {expected}, got {quote(value)}")
        _no_tag(value, field)
        _check_record(value, annotation, field)
        return
    origin = typing.get_origin(annotation)
    if origin is typing.Literal:
        allowed = typing.get_args(annotation)
        if isinstance(value, bool) or value not in allowed or isinstance(value, (list, dict)):
            raise ConfigError(field, f"must be {expected}, got {quote(value)}")
        return
    if origin is list:
        if not isinstance(value, list):
            raise ConfigError(field, f"expected {expected}, got {quote(value)}")
        (item_type,) = typing.get_args(annotation)
        for index, item in enumerate(value):
            check(item, item_type, f"{field}[{index}]")
        return
    if origin is dict:
        if not isinstance(value, dict):
            raise ConfigError(field, f"expected {expected}, got {quote(value)}")
        _no_tag(value, field)
        item_type = typing.get_args(annotation)[1]
        for key, item in value.items():
            if not isinstance(key, str):
                raise ConfigError(field, f"keys must be strings, got {quote(key)}")
            check(item, item_type, f"{field}.{key}")
        return
    _check_scalar(value, annotation, field, expected)


def _check_record(value: dict, record, field: str) -> None:
    known = record_fields(record)
    for key, item in value.items():
        path = f"{field}.{key}" if field else str(key)
        if key not in known:
            raise ConfigError(quote_path(path), f"unknown field (known: {', '.join(known)})")
        check(item, known[key], path)


def _check_scalar(value, annotation, field: str, expected: str) -> None:
    if annotation is bool:
        ok = isinstance(value, bool)
    elif annotation is int:
        ok = isinstance(value, int) and not isinstance(value, bool)
    elif annotation is float:
        ok = isinstance(value, (int, float)) and not isinstance(value, bool)
        if ok and not _finite(value):
            raise ConfigError(field, f"must be finite, got {quote(value)}")
    elif annotation is str:
        ok = isinstance(value, str)
        if ok and "\x00" in value:
            raise ConfigError(field, "must not contain a NUL character")
    elif annotation is typing.Any:
        ok = True
    else:  # a schema type this walker does not know is a programming error in the schema
        raise TypeError(f"unsupported schema type {annotation} at {field}")
    if not ok:
        raise ConfigError(field, f"expected {expected}, got {quote(value)}")


def _finite(number) -> bool:
    return math.isfinite(as_float(number))


# ---------------------------------------------------------------------------------------------
# Building typed values from checked data, and dumping them back.


def build(value, annotation, default=None):
    """The typed value of checked plain data (check first), over `default` (module docstring)."""
    if is_tagged_union(annotation):
        if value is None:
            return None
        member = chosen_member(value, annotation, "")
        start = default if type(default) is member else None
        return _build_record(value, member, start)
    if _is_union(annotation):
        if value is None:
            return None
        members, _ = union_parts(annotation)
        for member in members:
            try:
                check(value, member)
            except ConfigError:
                continue
            return build(value, member, default)
        return value
    if is_record(annotation):
        return _build_record(value, annotation, default)
    origin = typing.get_origin(annotation)
    if origin is list:
        (item_type,) = typing.get_args(annotation)
        return [build(item, item_type) for item in value]
    if origin is dict:
        item_type = typing.get_args(annotation)[1]
        return {key: build(item, item_type) for key, item in value.items()}
    if annotation is float:
        return float(value)
    return value


def _build_record(value: dict, record, default):
    result = copy.deepcopy(default) if default is not None else record()
    known = record_fields(record)
    for key, item in value.items():
        setattr(result, key, build(item, known[key], getattr(result, key)))
    return result


def to_data(value, annotation=None):
    """Plain data (tags kept, as TaggedMapping) of a typed value: what `build` reads back."""
    if value is None:
        return None
    if annotation is not None and is_tagged_union(annotation):
        return TaggedMapping(type(value).__name__, to_data(value).items())
    fields = record_fields(type(value))
    if fields is not None:
        return {name: to_data(getattr(value, name), fields[name]) for name in fields}
    if isinstance(value, (list, tuple)):
        item = typing.get_args(annotation)[0] if typing.get_origin(annotation) is list else None
        return [to_data(v, item) for v in value]
    if isinstance(value, dict):
        args = typing.get_args(annotation) if typing.get_origin(annotation) is dict else ()
        return {k: to_data(v, args[1] if args else None) for k, v in value.items()}
    return value


# ---------------------------------------------------------------------------------------------
# Dotted paths.


def path_tokens(path: str) -> list[tuple[str, list[int]]]:
    """'chaser.p_LC_L[1]' -> [('chaser', []), ('p_LC_L', [1])]; ConfigError when malformed."""
    if not isinstance(path, str) or not path:
        raise ConfigError(str(path), "a field path must be a non-empty string")
    if "\x00" in path:
        raise ConfigError(quote(path), "a field path must not contain a NUL character")
    tokens = []
    for part in path.split("."):
        match = _TOKEN.match(part)
        if not match:
            raise ConfigError(quote_path(path), f"malformed field path (at {quote(part)})")
        tokens.append((match.group(1), [int(i) for i in re.findall(r"\d+", match.group(2))]))
    return tokens


def path_type(root, path: str):
    """The schema type a dotted path leads to from `root`; ConfigError(path, ...) if none.

    Through a tagged union, the path continues into the first member in which all of it
    exists (e.g. `controller.planner.dt_s`), else the first that has the next field, so that
    the error names the deepest field; whether the value's actual member has it is checked
    where the value is set.
    """
    return _walk(root, path_tokens(path), path, "")


def _walk(annotation, tokens: list, path: str, walked: str):
    for position, (name, indices) in enumerate(tokens):
        if is_tagged_union(annotation):
            annotation = _member_for(annotation, tokens[position:], path, walked)
        elif _is_union(annotation):  # Optional[record]
            members, _ = union_parts(annotation)
            annotation = members[0] if len(members) == 1 else annotation
        fields = record_fields(annotation)
        if fields is None:
            raise ConfigError(path, f"{walked} is a value, it has no field {quote(name)}")
        if name not in fields:
            where = f" of {walked}" if walked else ""
            raise ConfigError(
                quote_path(path), f"unknown field {quote(name)}{where} (known: {', '.join(fields)})"
            )
        annotation = fields[name]
        walked = f"{walked}.{name}" if walked else name
        for index in indices:
            if typing.get_origin(annotation) is not list:
                raise ConfigError(path, f"{walked} is not a list, it cannot take [{index}]")
            annotation = typing.get_args(annotation)[0]
            walked += f"[{index}]"
    return annotation


def _member_for(annotation, rest: list, path: str, walked: str):
    members = [m for m in union_parts(annotation)[0]]
    having = [m for m in members if rest[0][0] in record_fields(m)]
    for member in having:
        try:
            _walk(member, rest, path, walked)
        except ConfigError:
            continue
        return member
    if having:
        return having[0]
    known = ", ".join(f"!{m.__name__}" for m in members)
    raise ConfigError(path, f"no member of {walked} ({known}) has a field {quote(rest[0][0])}")
