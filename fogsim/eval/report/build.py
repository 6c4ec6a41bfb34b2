"""Build the typed :class:`Report` of a run, once, from its :class:`RunResult`."""

from __future__ import annotations

import dataclasses
import functools
import importlib.metadata
import math
import platform
from collections.abc import Mapping
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from fogsim.config import RunParams, Scenario
from fogsim.eval.report.quality import assess_quality
from fogsim.eval.report.schema import (
    REPORT_FORMAT,
    REPORT_VERSION,
    ParamTables,
    ParamValue,
    Report,
    Source,
    TimeStats,
    Timing,
)
from fogsim.eval.rounding import rounded

if TYPE_CHECKING:  # result.py imports the schema, whose package imports this module: a cycle
    from fogsim.eval.result import RunResult

_PACKAGES = ("fogsim", "numpy", "numba", "mujoco", "dm-control", "opencv-python-headless", "pin")
_TIME_DIGITS = 4
"""Decimals of per-frame times [ms] (0.1 µs)."""
_WALL_DIGITS = 3
"""Decimals of the wall time [s] and the realtime factor."""


def package_versions() -> dict[str, str | None]:
    """Python and key package versions (None for a package that is not installed).

    Read once a process (:func:`_installed_versions`): the modules a process runs are those
    it imported, whatever is installed later, and reading the packages' metadata took 78 ms
    a report (a tune trial builds one per recording: 0.16 s of a 4.4 s trial).
    """
    return dict(_installed_versions())


@functools.cache
def _installed_versions() -> tuple[tuple[str, str | None], ...]:
    """(name, version) of Python and of each of :data:`_PACKAGES`, read from the metadata."""
    versions: list[tuple[str, str | None]] = [("python", platform.python_version())]
    for name in _PACKAGES:
        try:
            versions.append((name, importlib.metadata.version(name)))
        except importlib.metadata.PackageNotFoundError:
            versions.append((name, None))
    return tuple(versions)


def time_stats_ms(values_ms: NDArray[np.floating]) -> TimeStats:
    """Median, 99th percentile and max of the finite per-frame times [ms]."""
    v = np.asarray(values_ms, dtype=np.float64)
    v = v[np.isfinite(v)]
    if not v.size:
        return TimeStats(None, None, None)
    return TimeStats(
        median=rounded(float(np.median(v)), _TIME_DIGITS),
        p99=rounded(float(np.percentile(v, 99)), _TIME_DIGITS),
        max=rounded(float(np.max(v)), _TIME_DIGITS),
    )


def _param_table(values: Mapping[str, ParamValue]) -> dict[str, ParamValue]:
    """A parameter group as JSON holds it: an infinite limit (``max_range_m``) is null."""
    return {
        name: None if isinstance(value, float) and not math.isfinite(value) else value
        for name, value in values.items()
    }


def param_tables(params: RunParams) -> ParamTables:
    """The report's ``params``: every field of every parameter group, in declaration order."""
    return ParamTables(
        mapper=_param_table(dataclasses.asdict(params.mapper)),
        segmentation=_param_table(dataclasses.asdict(params.segmentation)),
        elevation=_param_table(dataclasses.asdict(params.elevation)),
        pipeline=_param_table(dataclasses.asdict(params.pipeline)),
        heading=_param_table(dataclasses.asdict(params.heading)),
        reference=_param_table(dataclasses.asdict(params.reference)),
    )


def build_report(
    result: RunResult,
    scenario: Scenario | None,
    *,
    source: Source = "simulation",
    wall_s: float | None = None,
    duration_s: float | None = None,
) -> Report:
    """The report of a run.

    Args:
        result: The run's result.
        scenario: The scenario (name, seed), or None for real data.
        source: ``"simulation"`` or ``"replay"``.
        wall_s: Whole-run wall time incl. setup [s]; default the pipeline's own wall time.
        duration_s: Simulated duration [s] of the run, for ``realtime_factor``.
    """
    wall = float(result.wall_s if wall_s is None else wall_s)
    timing = Timing(
        frames=int(result.frames),
        withdrawn_frames=int(result.withdrawn),
        z_matched_frames=int(result.z_matched),
        update_ms=time_stats_ms(result.update_ms),
        segmentation_ms=time_stats_ms(result.segmentation_ms),
        frame_ms=time_stats_ms(result.frame_ms),
        wall_s=round(wall, _WALL_DIGITS),
        realtime_factor=(
            round(float(duration_s) / wall, _WALL_DIGITS) if duration_s and wall > 0 else None
        ),
    )
    scores = result.scores
    return Report(
        format=REPORT_FORMAT,
        version=REPORT_VERSION,
        scenario=scenario.name if scenario is not None else None,
        seed=scenario.seed if scenario is not None else None,
        source=source,
        quality=assess_quality(
            frames=result.frames,
            withdrawn=result.withdrawn,
            frames_without_ground_plane=result.frames_without_ground_plane,
            z_match=result.params.pipeline.use_z_match,
            map_empty=result.archive.is_empty(),
            scores=scores,
        ),
        table1=scores.table1 if scores is not None else None,
        cells=scores.cells if scores is not None else None,
        safety=scores.safety if scores is not None else None,
        step_edges=scores.step_edges if scores is not None else (),
        unseen_objects=scores.unseen_objects if scores is not None else (),
        ceiling=scores.ceiling if scores is not None else None,
        events=result.events,
        timing=timing,
        pose_error=result.pose_error,
        params=param_tables(result.params),
        versions=package_versions(),
    )
