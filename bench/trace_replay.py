"""What the bench trace scripts share: ``--set`` overrides and a replay with a traced mapping.

``--set KEY=VALUE``: the keys are those of `fogsim.config.params.resolve_params` (``p_occ``,
``seg.<field>``, ``head.<field>``, ...); the values JSON (``0.25``, ``true``, ``"name"``).
"""

from __future__ import annotations

import json
from collections.abc import Callable, Iterable, Mapping
from typing import Any


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


def replay_traced(
    recording: Any,
    overrides: Mapping[str, object],
    trace_map: Callable[[Any, Any, Callable[[Any, Any], Any]], Any],
) -> None:
    """Replay ``recording`` through a `Pipeline` whose every frame mapping is traced.

    Args:
        recording: A `fogsim.data.recording.Recording`.
        overrides: Parameter overrides (`parse_overrides`).
        trace_map: Called as ``trace_map(pipeline, job, plain_map)`` instead of
            ``Pipeline._map(pipeline, job)``; it returns ``plain_map(pipeline, job)``'s outcome.
    """
    from fogsim.mapping.pipeline import Pipeline
    from fogsim.run.runner import resolve_params, sensor_fields

    params = resolve_params(recording.scenario, overrides, sensor_fields(recording.scenario))
    pipe = Pipeline(params)
    plain_map = Pipeline._map
    Pipeline._map = lambda self, job: trace_map(self, job, plain_map)
    try:
        for frame in recording.frames:
            pipe.process(frame)
        pipe.finish()
    finally:
        Pipeline._map = plain_map
