"""Reading YAML as people write it: YAML 1.2 numbers, no duplicate keys, bounded size and depth.

Owns: `parse_yaml`, the one place where scenario and campaign text becomes plain data (dicts,
lists, strings, numbers, booleans), and the rules that make that safe and unsurprising:
- Numbers are read as YAML 1.2 reads them. PyYAML implements YAML 1.1, whose resolver reads
  `5e2`, `1e-3` and `1.0e308` as *strings* (1.1 wants a dot and a signed exponent), `010` as
  octal 8 and `1:30` as 90. Here every 1.2 float form (`5e2`, `5E2`, `+1e+3`, `-2.5e-3`, `.5`,
  `5.`, `.inf`, `.nan`) is a float, and an integer is decimal, `0o17` or `0x1F`. A date
  (`2024-03-01T00:00:00`) is text, as in 1.2, not a 1.1 timestamp.
- A key given twice in one mapping is an error naming both lines (PyYAML lets the last win).
- Nesting deeper than MAX_DEPTH and documents that expand (through aliases) to more than
  MAX_VALUES values are errors: a 1 KB alias bomb expands to billions of values, and every
  consumer (the schema check, an error message, a JSON dump) would walk them all. The depth is
  that of the data the aliases resolve to (`c: &c [*b]` is one deeper than `b`), so a chain of
  aliases cannot build data nested deeper than MAX_DEPTH either.
- An integer of more than MAX_INT_DIGITS digits is an error here: Python refuses to convert
  more (and the conversion's cost grows with the square of the length). A shorter one beyond
  the float range is the schema check's to refuse, naming the field (`must be finite`).
- Text that is not YAML text (a NUL or another control character: a binary file) is an error
  naming the line and column of the first such character.
- Error messages quote at most QUOTE_CHARS characters of what the file holds.
- Only the safe constructors: no Python tags (`!!python/object` is an error, never executed).
  A local tag on a mapping (`controller: !HoldPoint {...}`, the typed unions of Drake's
  yaml_load_typed) becomes a `TaggedMapping`: a dict that remembers its tag. `dump_yaml`
  writes it back with the tag, so that Drake reads the same union choice.
Does not own: what the data means (loader.py, campaign.py).
"""

import re

import yaml

MAX_DEPTH = 32  # the scenario schema nests 5 deep; campaigns add 3
MAX_VALUES = 2_000_000  # scalars + containers after alias expansion (a 1,000,000-value grid fits)
MAX_INT_DIGITS = 4300  # Python's own limit of int(str) (sys.get_int_max_str_digits())
QUOTE_CHARS = 60  # longest quotation of the file's text in an error message

_FLOAT_TAG = "tag:yaml.org,2002:float"
_INT_TAG = "tag:yaml.org,2002:int"
# YAML 1.2 core schema (https://yaml.org/spec/1.2.2/#1032-tag-resolution).
_FLOAT_12 = re.compile(
    r"^(?:[-+]?(?:\.[0-9]+|[0-9]+(?:\.[0-9]*)?)(?:[eE][-+]?[0-9]+)?"
    r"|[-+]?\.(?:inf|Inf|INF)|\.(?:nan|NaN|NAN))$"
)
_INT_12 = re.compile(r"^(?:[-+]?[0-9]+|0o[0-7]+|0x[0-9a-fA-F]+)$")


class YamlError(ValueError):
    """The text is not usable YAML; the message says where (line and column) and why."""


class TaggedMapping(dict):
    """A mapping written with a local tag, `!Name {...}`; `tag` is 'Name' (no '!')."""

    def __init__(self, tag: str, items=()):
        super().__init__(items)
        self.tag = tag

    def __repr__(self) -> str:
        return f"!{self.tag} {dict.__repr__(self)}"


JSON_TAG_KEY = "!tag"  # no field name starts with '!'


def tags_to_json(value):
    """Plain data with every TaggedMapping as a dict holding its tag under JSON_TAG_KEY: what
    JSON can carry (a campaign's overrides go to workers and into the run id as JSON, and a
    lost tag would silently choose a union's first member)."""
    if isinstance(value, TaggedMapping):
        return {JSON_TAG_KEY: value.tag, **{k: tags_to_json(v) for k, v in value.items()}}
    if isinstance(value, dict):
        return {k: tags_to_json(v) for k, v in value.items()}
    if isinstance(value, list):
        return [tags_to_json(item) for item in value]
    return value


def tags_from_json(value):
    """The inverse of tags_to_json: a dict holding JSON_TAG_KEY becomes a TaggedMapping again."""
    if isinstance(value, dict):
        items = {k: tags_from_json(v) for k, v in value.items() if k != JSON_TAG_KEY}
        tag = value.get(JSON_TAG_KEY)
        if isinstance(value, TaggedMapping):
            return TaggedMapping(value.tag, items)
        return TaggedMapping(tag, items) if isinstance(tag, str) else items
    if isinstance(value, list):
        return [tags_from_json(item) for item in value]
    return value


# LibYAML's parser (PyYAML's wheels carry it): a 100,000-value campaign grid loads in 2 s, not 15.
_SAFE_LOADER = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


class _Loader(_SAFE_LOADER):
    """The safe loader with YAML 1.2 number resolution (see the module docstring)."""


# The 1.1 int and float resolvers out, the 1.2 ones in. Int first: an implicit scalar takes
# the first resolver that matches, and every int would also match the float pattern. The 1.1
# timestamp resolver out too (1.2 has none): `epoch_utc: 2024-03-01T00:00:00` is text, which
# the field's own check reads, and an impossible date is that check's one-line error, not a
# traceback from PyYAML's datetime constructor.
_TIMESTAMP_TAG = "tag:yaml.org,2002:timestamp"
_Loader.yaml_implicit_resolvers = {
    first: [(tag, rx) for tag, rx in resolvers if tag not in (_FLOAT_TAG, _INT_TAG, _TIMESTAMP_TAG)]
    for first, resolvers in _SAFE_LOADER.yaml_implicit_resolvers.items()
}
_Loader.add_implicit_resolver(_INT_TAG, _INT_12, list("-+0123456789"))
_Loader.add_implicit_resolver(_FLOAT_TAG, _FLOAT_12, list("-+0123456789."))


def _cut(text: str, limit: int = QUOTE_CHARS) -> str:
    """text on one line, cut to `limit` characters ("..." marks the cut)."""
    text = " ".join(str(text).split())
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _construct_int(loader, node) -> int:
    text = loader.construct_scalar(node)
    sign, digits = (-1, text[1:]) if text[:1] == "-" else (1, text.lstrip("+"))
    try:
        if digits.startswith(("0o", "0x")):
            value = int(digits[2:], 8 if digits[1] == "o" else 16)
        elif not (digits.isascii() and digits.isdigit()):  # an explicit !!int tag on a non-int
            raise ValueError(text)
        elif len(digits) > MAX_INT_DIGITS:  # too long: not even converted
            value = None
        else:
            value = int(digits, 10)  # base 10: "010" is ten, as in YAML 1.2
    except ValueError:  # not an integer (an explicit !!int tag on something else)
        raise yaml.constructor.ConstructorError(
            None, None, f"not an integer: {_cut(repr(text))}", node.start_mark
        ) from None
    if value is None or value >= _TOO_LONG:
        raise yaml.constructor.ConstructorError(
            None,
            None,
            f"integer too long ({len(text):,} characters: {_cut(text, 24)}); rpod reads "
            f"integers of up to {MAX_INT_DIGITS:,} digits",
            node.start_mark,
        )
    return sign * value


_TOO_LONG = 10**MAX_INT_DIGITS  # the least integer of more than MAX_INT_DIGITS digits
_Loader.add_constructor(_INT_TAG, _construct_int)


def _construct_tagged(loader, tag_suffix: str, node):
    if not isinstance(node, yaml.MappingNode) or not tag_suffix or "!" in tag_suffix:
        raise yaml.constructor.ConstructorError(
            None,
            None,
            f"the tag {_cut('!' + tag_suffix)} is allowed on a mapping only",
            node.start_mark,
        )
    return TaggedMapping(tag_suffix, loader.construct_mapping(node, deep=True))


_Loader.add_multi_constructor("!", _construct_tagged)


class _Dumper(yaml.SafeDumper):
    """SafeDumper that writes a TaggedMapping with its tag."""


_Dumper.add_representer(
    TaggedMapping, lambda dumper, data: dumper.represent_mapping(f"!{data.tag}", dict(data))
)


def dump_yaml(data) -> str:
    """YAML text of plain data from parse_yaml (tags kept), for pydrake's yaml_load_typed."""
    return yaml.dump(data, Dumper=_Dumper)


def _where(mark) -> str:
    return f"line {mark.line + 1}, column {mark.column + 1}"


def quote_key(key: str, limit: int = 60) -> str:
    """A mapping key for an error message, cut to `limit` characters."""
    text = repr(key)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _check_node_graph(root) -> None:
    """YamlError on duplicate keys, nesting deeper than MAX_DEPTH, or more than MAX_VALUES.

    Iterative, and each node is visited once (aliases share nodes), so an alias bomb costs
    its size in the file, not its expanded size. The depth checked is that of the resolved
    data: a node's height (the levels of data at and below it, through aliases) is computed
    once, and a node first met shallow and later through an alias deeper down counts at the
    deeper place (`c: &c [[[*b]]]` is as deep as b's data plus three).
    """
    expanded = {}  # id(node) -> values below and including it, once computed
    height = {}  # id(node) -> levels of data at and below it, once computed
    stack = [(root, 1, False)]
    while stack:
        node, depth, children_done = stack.pop()
        if id(node) in expanded:
            continue
        if depth > MAX_DEPTH:
            raise YamlError(
                f"YAML nested deeper than {MAX_DEPTH} levels at {_where(node.start_mark)}"
            )
        if isinstance(node, yaml.MappingNode):
            children = [item for pair in node.value for item in pair]
            if not children_done:
                seen = {}
                for key, _ in node.value:
                    if isinstance(key, yaml.ScalarNode):
                        if key.value in seen:
                            raise YamlError(
                                f"duplicate key {quote_key(key.value)} at {_where(key.start_mark)} "
                                f"(first at {_where(seen[key.value])}): give each key once"
                            )
                        seen[key.value] = key.start_mark
        elif isinstance(node, yaml.SequenceNode):
            children = list(node.value)
        else:
            expanded[id(node)] = 1
            height[id(node)] = 1
            continue
        if children_done:
            expanded[id(node)] = 1 + sum(expanded[id(child)] for child in children)
            height[id(node)] = 1 + max((height[id(child)] for child in children), default=0)
            if depth - 1 + height[id(node)] > MAX_DEPTH:
                raise YamlError(
                    f"YAML nested deeper than {MAX_DEPTH} levels at {_where(node.start_mark)} "
                    f"(its data, through aliases, is {height[id(node)]} levels deep here)"
                )
            if expanded[id(node)] > MAX_VALUES:
                raise YamlError(
                    f"YAML expands to more than {MAX_VALUES:,} values at {_where(node.start_mark)}"
                    " (aliases repeated inside aliases?)"
                )
            continue
        stack.append((node, depth, True))
        stack.extend((child, depth + 1, False) for child in children if id(child) not in expanded)


def _position(text: str, index: int) -> str:
    """'line L, column C' of a character index into text."""
    line = text.count("\n", 0, index) + 1
    column = index - (text.rfind("\n", 0, index) + 1) + 1
    return f"line {line}, column {column}"


def parse_yaml(text: str):
    """Plain data from YAML text (None for an empty document); YamlError saying where and why."""
    loader = None
    try:
        loader = _Loader(text)  # the reader refuses NUL and other control characters here
        node = loader.get_single_node()
        if node is None:
            return None
        _check_node_graph(node)
        return loader.construct_document(node)
    except yaml.reader.ReaderError as error:  # before any parsing: not text
        where = _position(text, error.position) if isinstance(text, str) else "its start"
        raise YamlError(
            f"not YAML text: character #x{error.character:02x} at {where} is not allowed in "
            "YAML (a binary file?)"
        ) from None
    except yaml.YAMLError as error:
        if "exceeded maximum nesting depth" in str(error):  # libyaml's own limit (1000)
            raise YamlError(f"YAML nested deeper than {MAX_DEPTH} levels") from None
        mark = getattr(error, "problem_mark", None)
        where = f" at {_where(mark)}" if mark else ""
        problem = getattr(error, "problem", None) or str(error).splitlines()[0]
        kind = "value" if isinstance(error, yaml.constructor.ConstructorError) else "syntax"
        raise YamlError(f"YAML {kind} error{where}: {_cut(problem, 2 * QUOTE_CHARS)}") from None
    except RecursionError:  # the pure-Python composer recurses: nesting far beyond MAX_DEPTH
        raise YamlError(f"YAML nested deeper than {MAX_DEPTH} levels") from None
    finally:
        if loader is not None:
            loader.dispose()
