"""``--set KEY=VALUE`` overrides: parse them and assign them in a scenario's plain tables.

Keys are dotted: ``seed=3``, ``camera.mode=ideal``, ``mapper.p_occ=0.7``,
``heading.interior_peak=false``, ``encoders.bias_deg=0``, ``objects.<name>.<field>=...``.
A parameter table may also be named by its short prefix, as the tuner, the bench tools and the
README name parameters (``head.min_contrast`` = ``heading.min_contrast``; ``seg.``, ``pipe.``,
``ref.``, ``elev.``: `fogsim.config.params.OVERRIDE_PREFIXES`).
Values are TOML values (``[1, 2]``, ``true``, ``0.5``); a bare word that is no TOML value is
taken as a string (``camera.mode=ideal``).
The scenario decodes the edited tables again, so a bad key or value fails as in a file.
"""

from __future__ import annotations

import copy
import tomllib
from collections.abc import Sequence

from fogsim.config.params import OVERRIDE_PREFIXES
from fogsim.errors import ScenarioError

TABLES = ", ".join(("robot", "camera", "encoders", *OVERRIDE_PREFIXES, "objects.<name>"))
"""The tables an override key may go into (in messages)."""

_TABLE_OF_PREFIX = {prefix[:-1]: table for table, prefix in OVERRIDE_PREFIXES.items() if prefix}
"""A parameter table's short prefix (``head``) → the table (``heading``)."""


def canonical_key(key: str) -> str:
    """An override key with a short prefix spelt as its table: ``"head.x"`` → ``"heading.x"``."""
    table, dot, rest = key.strip().partition(".")
    return _TABLE_OF_PREFIX.get(table, table) + dot + rest if dot else table


def parse_override(assignment: str, origin: str) -> tuple[list[str], object]:
    """``"camera.mode=ideal"`` → ``(["camera", "mode"], "ideal")``.

    A short prefix names its table: ``"head.min_contrast=0.2"`` → ``(["heading",
    "min_contrast"], 0.2)``.

    Raises:
        ScenarioError: The text is no ``key=value``.
    """
    key, sep, text = assignment.partition("=")
    key = key.strip()
    if not sep or not key:
        raise ScenarioError(f"{origin}: override {assignment!r} must look like key=value")
    try:
        value = tomllib.loads(f"v = {text.strip()}")["v"]
    except (ValueError, RecursionError):  # no TOML value (TOMLDecodeError is a ValueError)
        value = text.strip()  # a bare word: the documented string shorthand
    return canonical_key(key).split("."), value


def assign_overrides(
    tables: dict[str, object], assignments: Sequence[str], origin: str
) -> dict[str, object]:
    """A copy of a scenario's plain tables with every ``key=value`` assignment made.

    Args:
        tables: The scenario as plain tables (``Scenario.to_dict()``).
        assignments: ``key=value`` texts, applied in order.
        origin: How errors name the scenario (``<file> (override)``).

    Raises:
        ScenarioError: A malformed assignment, a key through something that is no table or an
            object name that does not exist.
    """
    edited = copy.deepcopy(tables)
    for assignment in assignments:
        parts, value = parse_override(assignment, origin)
        key = assignment.partition("=")[0].strip()  # as given, short prefix and all
        target: object = edited
        for i, part in enumerate(parts[:-1]):
            if isinstance(target, list):  # objects.<name>
                match = [o for o in target if isinstance(o, dict) and o.get("name") == part]
                if not match:
                    raise ScenarioError(
                        f"{origin}: key {key!r}: no entry named {part!r} in {'.'.join(parts[:i])}"
                    )
                target = match[0]
            elif isinstance(target, dict) and isinstance(target.get(part), dict | list):
                target = target[part]
            else:
                raise ScenarioError(
                    f"{origin}: key {key!r}: {part!r} is not a table; tables: {TABLES}"
                )
        if not isinstance(target, dict):
            raise ScenarioError(f"{origin}: key {key!r} does not name a single value")
        target[parts[-1]] = value
    return edited
