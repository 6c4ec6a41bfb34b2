"""Write the scenario's dataclasses as TOML text (with ``tomli_w``) that the loader reads back.

:func:`to_plain` (:func:`to_table` at the top) turns a schema dataclass into the plain tables of
its file — tuples become arrays, unset optional keys (``None``) are left out, and so are fields no
file may set (``source_path``); :func:`toml_text` writes that as TOML.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping

import tomli_w

from fogsim.config.decode import in_file

TomlValue = str | int | float | bool | list["TomlValue"] | dict[str, "TomlValue"]
"""A value TOML can hold (dates aside)."""


def to_plain(value: object) -> TomlValue:
    """A dataclass (or mapping, tuple, scalar) as the plain values of its TOML file."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {
            f.name: to_plain(getattr(value, f.name))
            for f in dataclasses.fields(value)
            if in_file(f) and getattr(value, f.name) is not None
        }
    if isinstance(value, Mapping):
        return {str(k): to_plain(v) for k, v in value.items()}
    if isinstance(value, tuple | list):
        return [to_plain(v) for v in value]
    if isinstance(value, str | int | float | bool):
        return value
    raise TypeError(f"cannot write {type(value).__name__} {value!r} to TOML")


def to_table(value: object) -> dict[str, TomlValue]:
    """A dataclass or mapping as the plain top-level table of its TOML file."""
    plain = to_plain(value)
    if not isinstance(plain, dict):
        raise TypeError(f"a TOML document is a table, not {type(value).__name__} {value!r}")
    return plain


def toml_text(value: object) -> str:
    """``value`` (a dataclass or a mapping) as TOML text."""
    return tomli_w.dumps(to_table(value))
