"""Result files on disk: the one JSON writer and the one typed JSON loader.

``report.json`` goes through :func:`write_report` / :func:`load_report`; the suite's summary
and baseline use the same two functions with their own schemas. Both go through msgspec, which
maps the schema's dataclasses to JSON objects field by field: files are indented by two spaces,
NaN and infinity are written as ``null``, and loading checks every key and value against the
schema, so a missing, renamed or mistyped key is an error that names it instead of a silent
``None``.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import TypeVar

import msgspec

from fogsim.atomic import write_bytes_atomic
from fogsim.config.decode import unknown_key
from fogsim.errors import ReportError
from fogsim.eval.report.schema import Report

T = TypeVar("T")

_INDENT = 2


def write_json(path: str | os.PathLike[str], value: object, *, sort_keys: bool = False) -> Path:
    """Write typed results as indented JSON, atomically (complete or absent).

    Args:
        path: The file.
        value: Dataclasses, dicts, lists and scalars (NaN and infinity become null).
        sort_keys: Sort every object's keys (files under version control, such as the
            baseline); default: the schema's field order.
    """
    encoded = msgspec.json.encode(value, order="sorted" if sort_keys else None)
    data = msgspec.json.format(encoded, indent=_INDENT) + b"\n"
    return write_bytes_atomic(path, data)


def load_json(path: str | os.PathLike[str], schema: type[T], what: str) -> T:
    """Read a JSON file into ``schema``, checking every key and value.

    Args:
        path: The file.
        schema: The type to decode (a dataclass of the file's top-level object).
        what: What the file is, for messages (``"report"``, ``"baseline"``).

    Raises:
        ReportError: The file is missing, is not JSON, lacks a key, has a key the schema does
            not know, or holds a value of the wrong type; the message names the file and the
            key path (``$.timing.frames``).
    """
    try:
        data = Path(path).read_bytes()
    except OSError as exc:
        raise ReportError(f"cannot read {what} {path}: {exc}") from exc
    try:
        value = msgspec.json.decode(data, type=schema)
    except msgspec.ValidationError as exc:
        raise ReportError(f"{what} {path} does not match the {what} schema: {exc}") from exc
    except msgspec.DecodeError as exc:
        raise ReportError(f"{what} {path} is not valid JSON: {exc}") from exc
    unknown = unknown_key(msgspec.json.decode(data), schema)
    if unknown is not None:
        where = "$" + "".join(f"[{s}]" if isinstance(s, int) else f".{s}" for s in unknown[0])
        raise ReportError(f"{what} {path} has a key the {what} schema does not know: `{where}`")
    return value


def write_report(path: str | os.PathLike[str], report: Report) -> Path:
    """Write ``report.json`` (keys in the schema's order)."""
    return write_json(path, report)


def load_report(path: str | os.PathLike[str]) -> Report:
    """Read a ``report.json``; raises :class:`ReportError` naming any bad key."""
    return load_json(path, Report, "report")
