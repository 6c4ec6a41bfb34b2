"""Decode a parsed TOML document into the scenario's frozen dataclasses, with msgspec.

Why msgspec (pydantic is no dependency of ours): it decodes strictly and typed straight into
frozen dataclasses (a string is never a number, ``true`` never 1, an int becomes the float a
field declares, an array the declared tuple); the allowed ranges and choices are declared on
the fields themselves (``Annotated[float, Meta(ge=0.0, le=10.0)]``, ``Literal[...]``); its
errors carry the path of the bad value (``$.objects[2].size[1]``); it is fast and small (one C
extension without dependencies). Rules across fields live in the dataclasses' ``__post_init__``,
which msgspec calls, and raise :class:`FieldRuleError`.

msgspec forbids unknown keys only for its own ``Struct`` type, not for dataclasses (msgspec
issue #791); the schema stays dataclasses (consumers use ``dataclasses.replace`` and a field
left out of equality, ``Scenario.source_path``), so :func:`decode` checks the keys against the
dataclass fields itself before msgspec runs.

Every error becomes a :class:`~fogsim.errors.ScenarioError` reading
``<origin>: <dotted key>: must be <what is allowed>, got <value>``; keys and values are shown
shortened (:func:`shown`), so a megabyte of junk makes a one-line message.
"""

from __future__ import annotations

import dataclasses
import re
import reprlib
from collections.abc import Mapping
from typing import TypeVar, get_args, get_type_hints

import msgspec
import msgspec.inspect as mi

from fogsim.errors import ScenarioError

T = TypeVar("T")

NOT_IN_FILE: Mapping[str, bool] = {"in_file": False}
"""``dataclasses.field`` metadata of a field that no file may set (e.g. ``source_path``)."""

_AT = re.compile(r" - at `\$(?P<path>[^`]*)`$")
_MISSING = re.compile(r"^Object missing required field `(?P<field>[^`]+)`")
_SEGMENT = re.compile(r"\.(?P<key>\w+)|\[(?P<index>\d+)\]")

Segment = str | int
"""One step of a key path: a table key or an array index."""

_SHOWN = reprlib.Repr()
_SHOWN.maxstring = _SHOWN.maxother = 80
_SHOWN.maxlevel = 3
_LONGEST_KEY = 80
"""Longest key (characters) a message shows whole; longer ones are cut in the middle."""


_LARGEST_SHOWN_INT_BITS = 256
"""Integers with more bits are shown by their size: Python refuses to print beyond 4300 digits."""


def shown(value: object) -> str:
    """``repr(value)`` for messages: strings and nesting cut short, a long array by its length."""
    if isinstance(value, list | tuple) and len(value) > _SHOWN.maxlist:
        return f"an array of {len(value)} values"
    if isinstance(value, int) and value.bit_length() > _LARGEST_SHOWN_INT_BITS:
        return f"an integer of {value.bit_length()} bits"
    return _SHOWN.repr(value)


def in_file(declared: dataclasses.Field[object]) -> bool:
    """Whether a file may set the dataclass field (fields marked :data:`NOT_IN_FILE` may not)."""
    return bool(declared.metadata.get("in_file", True))


class FieldRuleError(ScenarioError):
    """A rule across fields of one schema object is broken (raised in ``__post_init__``).

    Attributes:
        key: The offending key relative to the object (``"walkable"``; ``""`` for the object
            itself); :func:`decode` puts the object's own path in front.
        rule: What is wrong and what is allowed.
    """

    def __init__(self, key: str, rule: str) -> None:
        super().__init__(f"{key}: {rule}" if key else rule)
        self.key = key
        self.rule = rule


def decode(data: Mapping[str, object], cls: type[T], origin: str) -> T:
    """Decode a parsed TOML table into the dataclass ``cls``.

    Args:
        data: The parsed table (``tomllib`` output or an equivalent dict).
        cls: The frozen dataclass to build (its nested dataclasses come along).
        origin: How errors name the table's origin (the file path).

    Raises:
        ScenarioError: An unknown key, a missing one, a value of the wrong type or out of
            range, or a broken rule across fields; the message names ``origin``, the dotted key
            path, the value and what is allowed.
    """
    info = mi.type_info(cls)
    unknown = unknown_key(data, cls)
    if unknown is not None:
        path, allowed = unknown
        raise ScenarioError(f"{origin}: {dotted(path)}: unknown key; allowed: {', '.join(allowed)}")
    try:
        return msgspec.convert(data, cls, strict=True)
    except msgspec.ValidationError as exc:
        raise _scenario_error(exc, data, info, origin) from exc


def dotted(segments: tuple[Segment, ...]) -> str:
    """The key path as written in messages: ``objects[2].size``."""
    text = "".join(f"[{s}]" if isinstance(s, int) else f".{_clipped(s)}" for s in segments)
    return text.removeprefix(".")


def _clipped(key: str) -> str:
    """``key``, cut in the middle if longer than :data:`_LONGEST_KEY` characters."""
    if len(key) <= _LONGEST_KEY:
        return key
    half = _LONGEST_KEY // 2
    return f"{key[:half]}...{key[-half:]}"


def unknown_key(value: object, cls: type) -> tuple[tuple[Segment, ...], tuple[str, ...]] | None:
    """The first key in ``value`` that no dataclass field of ``cls`` accepts.

    msgspec decodes dataclasses without refusing unknown keys, so every loader of a typed file
    (scenarios, robot descriptions, reports) asks this first.

    Args:
        value: Parsed data (TOML or JSON: dicts, lists, scalars).
        cls: The dataclass the data is meant for (nested dataclasses, lists and tuples of them
            are followed; fields marked :data:`NOT_IN_FILE` are not accepted).

    Returns:
        The key's path and the keys allowed beside it, or None when every key is known.
    """
    return _first_unknown(value, mi.type_info(cls), ())


def _first_unknown(
    value: object, info: mi.Type, path: tuple[Segment, ...]
) -> tuple[tuple[Segment, ...], tuple[str, ...]] | None:
    info = _bare(info)
    if isinstance(info, mi.DataclassType) and isinstance(value, Mapping):
        types = {
            f.name: f.type
            for f, declared in zip(info.fields, dataclasses.fields(info.cls), strict=True)
            if in_file(declared)
        }
        for key, item in value.items():
            if key not in types:
                return (*path, key), tuple(types)
            found = _first_unknown(item, types[key], (*path, key))
            if found is not None:
                return found
    elif isinstance(info, mi.VarTupleType | mi.ListType) and isinstance(value, list):
        for index, item in enumerate(value):
            found = _first_unknown(item, info.item_type, (*path, index))
            if found is not None:
                return found
    return None


def _scenario_error(
    exc: msgspec.ValidationError, data: Mapping[str, object], info: mi.Type, origin: str
) -> ScenarioError:
    """The ScenarioError for msgspec's error, naming the key, the value and what is allowed."""
    message = str(exc)
    at = _AT.search(message)
    segments = _segments(at["path"]) if at else ()
    missing = _MISSING.match(message)
    if isinstance(exc.__cause__, FieldRuleError):
        key = ".".join(p for p in (dotted(segments), exc.__cause__.key) if p)
        rule = exc.__cause__.rule
    elif missing:
        key = dotted((*segments, missing["field"]))
        rule = "is required but missing"
    else:
        key = dotted(segments)
        rule = f"must be {_allowed_at(info, segments)}, got {shown(_value_at(data, segments))}"
    return ScenarioError(f"{origin}: {key or '(top level)'}: {rule}")


def _segments(path: str) -> tuple[Segment, ...]:
    """``.objects[2].size`` → ``("objects", 2, "size")``."""
    return tuple(
        int(m["index"]) if m["index"] is not None else m["key"] for m in _SEGMENT.finditer(path)
    )


def _bare(info: mi.Type) -> mi.Type:
    """The type without its metadata and without ``| None``."""
    if isinstance(info, mi.Metadata):
        return _bare(info.type)
    if isinstance(info, mi.UnionType):
        kept = [t for t in info.types if not isinstance(t, mi.NoneType)]
        return _bare(kept[0]) if len(kept) == 1 else info
    return info


def _type_at(info: mi.Type, segments: tuple[Segment, ...]) -> mi.Type:
    """The declared type of the value at ``segments``."""
    for segment in segments:
        info = _bare(info)
        if isinstance(info, mi.TupleType) and isinstance(segment, int):
            info = info.item_types[segment]
        elif isinstance(info, mi.VarTupleType | mi.ListType):
            info = info.item_type
        elif isinstance(info, mi.DataclassType):
            info = next(f.type for f in info.fields if f.name == segment)
    return info


def _value_at(data: Mapping[str, object], segments: tuple[Segment, ...]) -> object:
    """The value at ``segments`` in the parsed document (msgspec reports only its type)."""
    value: object = data
    for segment in segments:
        value = value[segment]  # type: ignore[index]  # the path msgspec reports exists
    return value


def _allowed_at(info: mi.Type, segments: tuple[Segment, ...]) -> str:
    """What the value at ``segments`` may be; choices in the order the schema declares them.

    (msgspec's type info sorts a ``Literal``'s choices; the dataclass's annotation keeps them.)
    """
    declared = _type_at(info, segments)
    parent = _bare(_type_at(info, segments[:-1]))
    if isinstance(declared, mi.LiteralType) and isinstance(parent, mi.DataclassType):
        choices = get_args(get_type_hints(parent.cls)[str(segments[-1])])
        return f"one of {', '.join(str(c) for c in choices)}"
    return _allowed(declared)


def _allowed(info: mi.Type) -> str:
    """What a value of the declared type may be, in words (``a number in [0.0, 10.0]``)."""
    if isinstance(info, mi.Metadata):
        description = (info.extra_json_schema or {}).get("description")
        return str(description) if description else _allowed(info.type)
    if isinstance(info, mi.UnionType):
        return " or ".join(_allowed(t) for t in info.types if not isinstance(t, mi.NoneType))
    if isinstance(info, mi.FloatType):
        return f"a number{_bounds(info)}"
    if isinstance(info, mi.IntType):
        return f"an integer{_bounds(info)}"
    if isinstance(info, mi.BoolType):
        return "true or false"
    if isinstance(info, mi.LiteralType):
        return f"one of {', '.join(str(v) for v in info.values)}"
    if isinstance(info, mi.StrType):
        return "a non-empty string" if info.min_length else "a string"
    if isinstance(info, mi.TupleType):
        return f"an array of {len(info.item_types)} {_plural(info.item_types[0])}"
    if isinstance(info, mi.VarTupleType | mi.ListType):
        return f"an array of {_plural(info.item_type)}"
    if isinstance(info, mi.DictType | mi.DataclassType):
        return "a table"
    return type(info).__name__


def _plural(info: mi.Type) -> str:
    """The items of an array or table in words (``numbers in [1.0, 170.0]``)."""
    info = _bare(info)
    if isinstance(info, mi.FloatType):
        return f"numbers{_bounds(info)}"
    if isinstance(info, mi.DataclassType):
        return "tables"
    return f"values that are each {_allowed(info)}"


def _bounds(info: mi.FloatType | mi.IntType) -> str:
    """`` in [low, high]`` of a number declared with both bounds, else nothing."""
    return f" in [{info.ge}, {info.le}]" if info.ge is not None and info.le is not None else ""
