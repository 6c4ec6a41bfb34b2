"""``report.json`` on disk: the one writer and the one typed loader of a :class:`Report`.

Both go through msgspec, which maps the schema's dataclasses to JSON objects field by field:
the file is indented by two spaces, NaN and infinity are written as ``null``, and loading
checks every key and value against the schema, so a missing, renamed or mistyped key is an
error that names it instead of a silent ``None``.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import msgspec

from fogsim.atomic import write_atomic
from fogsim.errors import ReportError
from fogsim.eval.report.schema import Report

_INDENT = 2


def write_report(path: str | os.PathLike[str], report: Report) -> Path:
    """Write a report as indented JSON, atomically (complete or absent)."""
    data = msgspec.json.format(msgspec.json.encode(report), indent=_INDENT) + b"\n"
    return write_atomic(path, lambda handle: handle.write(data))


def _unknown_key(raw: Any, typed: Any, where: str) -> str | None:
    """Path of the first key of ``raw`` (decoded JSON) that ``typed`` (the schema's view) lacks."""
    if isinstance(raw, dict) and isinstance(typed, dict):
        for key, value in raw.items():
            if key not in typed:
                return f"{where}.{key}"
            found = _unknown_key(value, typed[key], f"{where}.{key}")
            if found is not None:
                return found
    if isinstance(raw, list) and isinstance(typed, list | tuple):
        for index, (value, known) in enumerate(zip(raw, typed, strict=True)):
            found = _unknown_key(value, known, f"{where}[{index}]")
            if found is not None:
                return found
    return None


def load_report(path: str | os.PathLike[str]) -> Report:
    """Read a ``report.json`` into a :class:`Report`.

    Raises:
        ReportError: The file is missing, is not JSON, lacks a key, has a key the schema does
            not know, or holds a value of the wrong type; the message names the file and the
            key path (``$.timing.frames``).
    """
    try:
        data = Path(path).read_bytes()
    except OSError as exc:
        raise ReportError(f"cannot read report {path}: {exc}") from exc
    try:
        report = msgspec.json.decode(data, type=Report)
    except msgspec.ValidationError as exc:
        raise ReportError(f"report {path} does not match the report schema: {exc}") from exc
    except msgspec.DecodeError as exc:
        raise ReportError(f"report {path} is not valid JSON: {exc}") from exc
    unknown = _unknown_key(msgspec.json.decode(data), msgspec.to_builtins(report), "$")
    if unknown is not None:
        raise ReportError(f"report {path} has a key the report schema does not know: `{unknown}`")
    return report
