"""``--set KEY=VALUE`` parameter overrides of the bench trace scripts (JSON values).

The keys are those of `fogsim.config.params.resolve_params` (``p_occ``, ``seg.<field>``,
``head.<field>``, ...); the values JSON (``0.25``, ``true``, ``"name"``).
"""

from __future__ import annotations

import json
from collections.abc import Iterable


def parse_overrides(items: Iterable[str]) -> dict[str, object]:
    """``{KEY: value}`` of ``KEY=VALUE`` strings, each value parsed as JSON.

    Raises:
        SystemExit: An item without ``=`` or whose value is no JSON (exit code 2, naming it).
    """
    overrides: dict[str, object] = {}
    for item in items:
        key, sep, value = item.partition("=")
        try:
            if not sep:
                raise ValueError("no '='")
            overrides[key] = json.loads(value)
        except ValueError as error:
            raise SystemExit(
                f"--set {item!r}: expected KEY=VALUE with a JSON value "
                f"(e.g. p_occ=0.7, head.correct_heading=false): {error}"
            ) from None
    return overrides
