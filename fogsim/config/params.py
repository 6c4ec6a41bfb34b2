"""Every parameter of a run, resolved once: library defaults ← scenario tables ← overrides.

:class:`RunParams` groups the mapper's, the segmentation's, the robot elevation filter's and the
pipeline's own parameters; :func:`resolve_params` builds it from a scenario and ``--set`` style
overrides, naming any unknown key or bad value with what is allowed.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from fogsim.errors import FogsimError
from mapper import ElevationFilterParams, MapperParams
from mapper.segmentation import SegmentationParams


@dataclass(frozen=True)
class PipelineParams:
    """Parameters of the pipeline around the mapper (override keys ``pipe.<name>``).

    Attributes:
        use_z_match: Apply the z-shift matching (paper: optional step 2 of Fig. 2).
        use_elevation_filter: Filter the robot's z with the floor map (Sec. IV).
        event_tolerance_m: Height tolerance of "floor again" in the event scores [m].
    """

    use_z_match: bool = True
    use_elevation_filter: bool = True
    event_tolerance_m: float = 0.01

    def __post_init__(self) -> None:
        if not self.event_tolerance_m > 0.0:
            raise FogsimError(
                f"PipelineParams.event_tolerance_m must be > 0 m, got {self.event_tolerance_m!r}"
            )


def _replace_validated(params: Any, changes: Mapping[str, Any], what: str) -> Any:
    """``dataclasses.replace`` that names unknown fields and what is allowed."""
    if not changes:
        return params
    allowed = [f.name for f in dataclasses.fields(params)]
    unknown = sorted(set(changes) - set(allowed))
    if unknown:
        raise FogsimError(f"unknown {what} parameter(s) {unknown}; allowed: {allowed}")
    typed = {}
    for name, value in changes.items():
        current = getattr(params, name)
        if isinstance(current, bool):
            value = bool(value)
        elif isinstance(current, int) and float(value).is_integer():
            value = int(value)
        typed[name] = value
    return dataclasses.replace(params, **typed)


@dataclass(frozen=True)
class RunParams:
    """Every parameter of a run (the report's ``params``).

    Attributes:
        mapper: Grid and thresholds (override keys: bare field names or ``mapper.<field>``).
        segmentation: Plane segmentation (``seg.<field>``).
        elevation: Robot elevation filter (``elev.<field>``).
        pipeline: The pipeline's own switches (``pipe.<field>``).
    """

    mapper: MapperParams = field(default_factory=MapperParams)
    segmentation: SegmentationParams = field(default_factory=SegmentationParams)
    elevation: ElevationFilterParams = field(default_factory=ElevationFilterParams)
    pipeline: PipelineParams = field(default_factory=PipelineParams)

    def to_dict(self) -> dict[str, dict[str, Any]]:
        """Plain ``{"mapper": {...}, "segmentation": {...}, ...}``."""
        return {
            f.name: {
                g.name: getattr(getattr(self, f.name), g.name)
                for g in dataclasses.fields(getattr(self, f.name))
            }
            for f in dataclasses.fields(self)
        }


_PREFIXES = {"seg.": "segmentation", "elev.": "elevation", "pipe.": "pipeline", "mapper.": "mapper"}


def resolve_params(scenario: Any | None, overrides: Mapping[str, float] | None = None) -> RunParams:
    """Parameters of a run: defaults ← scenario ``[mapper]`` / ``[segmentation]`` ← overrides.

    Args:
        scenario: A Scenario (its ``mapper`` and ``segmentation`` tables) or None.
        overrides: Keys ``"<mapper field>"`` (e.g. ``"p_occ"``, or ``"mapper.p_occ"``),
            ``"seg.<field>"``, ``"elev.<field>"`` and ``"pipe.<field>"``.

    Raises:
        FogsimError: An unknown key (the message lists the allowed ones) or a bad value.
    """
    changes: dict[str, dict[str, Any]] = {
        "mapper": dict(getattr(scenario, "mapper", {}) or {}),
        "segmentation": dict(getattr(scenario, "segmentation", {}) or {}),
        "elevation": {},
        "pipeline": {},
    }
    for key, value in (overrides or {}).items():
        group = next((g for prefix, g in _PREFIXES.items() if key.startswith(prefix)), None)
        name = key.split(".", 1)[1] if group else key
        changes[group or "mapper"][name] = value
    defaults = RunParams()
    try:
        return RunParams(
            **{
                group: _replace_validated(getattr(defaults, group), values, group)
                for group, values in changes.items()
            }
        )
    except (TypeError, ValueError) as exc:
        raise FogsimError(f"invalid parameter override: {exc}") from exc
