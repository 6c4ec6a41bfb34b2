"""Regression metrics of a report and their check against the committed ``baseline.json``.

Metrics (flat names, one value per scenario; ``direction`` says which way is better):

=====================================  =========  ==========  ================================
metric                                 direction  tolerance   meaning
=====================================  =========  ==========  ================================
``table1.<surface>.abs_error_mm``      lower      1.0 mm      FOG Table I row error
``cells.accuracy``                     higher     0.01        seen cells labelled right
``cells.obstacle_within_one_cell``     higher     0.02        obstacle tops within one cell
``events.<object>.fog_frames``         lower      3 frames    frames to clear the footprint
                                                              (never = 10⁶)
``events.<object>.intermediate``       lower      2 cells     moved box: intermediate floor
                                                              cells at the end (FOG)
``timing.frame_ms_median``             lower      ×2 + 5 ms   pipeline time per frame (noisy,
                                                              so only gross regressions count)
=====================================  =========  ==========  ================================

``baseline.json`` keeps the metrics of a full run (``scenarios``) and of a quick run
(``quick_scenarios``), keys sorted so that a rewrite shows as a small diff.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

from msgspec import UNSET, UnsetType

from fogsim.errors import FogsimError
from fogsim.eval.report import Report
from fogsim.eval.report.io import load_json, write_json

NEVER_FRAMES = 1_000_000.0
"""The ``fog_frames`` metric of a footprint that never clears."""


@dataclass(frozen=True)
class MetricRule:
    """How a metric may change.

    Attributes:
        direction: ``"lower"`` or ``"higher"`` is better.
        absolute: Allowed slack in the metric's unit.
        relative: Further slack as a fraction of ``|baseline|``.
    """

    direction: Literal["lower", "higher"]
    absolute: float
    relative: float = 0.0

    def worse_by(self, current: float, baseline: float) -> float:
        """How much worse ``current`` is than ``baseline`` beyond the tolerance (> 0 = fail)."""
        change = current - baseline if self.direction == "lower" else baseline - current
        return change - (self.absolute + self.relative * abs(baseline))


def rule_for(metric: str) -> MetricRule:
    """The tolerance rule of a metric name (see the module table)."""
    if metric.startswith("table1."):
        return MetricRule("lower", 1.0)
    if metric == "cells.accuracy":
        return MetricRule("higher", 0.01)
    if metric == "cells.obstacle_within_one_cell":
        return MetricRule("higher", 0.02)
    if metric.endswith(".fog_frames"):
        return MetricRule("lower", 3.0)
    if metric.endswith(".intermediate"):
        return MetricRule("lower", 2.0)
    if metric.startswith("timing."):
        return MetricRule("lower", 5.0, 1.0)
    raise FogsimError(f"no tolerance rule for metric {metric!r}")


def report_metrics(report: Report) -> dict[str, float]:
    """Flat regression metrics of one report (None values are left out, except events)."""
    metrics: dict[str, float] = {}
    if report.table1 is not None:
        for row in report.table1.fog:
            if row.error_mm is not None:
                metrics[f"table1.{row.name}.abs_error_mm"] = abs(float(row.error_mm))
    if report.cells is not None:
        cells = report.cells.fog
        if cells.accuracy is not None:
            metrics["cells.accuracy"] = float(cells.accuracy)
        within = cells.obstacle_height.within_one_cell_fraction
        if within is not None:
            metrics["cells.obstacle_within_one_cell"] = float(within)
    for event in report.events:
        frames = event.fog_frames
        metrics[f"events.{event.object}.fog_frames"] = (
            NEVER_FRAMES if frames is None else float(frames)
        )
        if event.intermediate_floor_cells is not UNSET:
            metrics[f"events.{event.object}.intermediate"] = float(
                event.intermediate_floor_cells.fog.final
            )
    median = report.timing.frame_ms.median
    if median is not None:
        metrics["timing.frame_ms_median"] = float(median)
    return metrics


@dataclass(frozen=True)
class BaselineEntry:
    """The committed metrics of one scenario."""

    metrics: dict[str, float]


@dataclass(frozen=True)
class Baseline:
    """``baseline.json``: the metrics a run is checked against, per scenario.

    Attributes:
        format: Always ``fogsim-baseline``.
        version: Schema version, 1.
        quick_scenarios: Metrics of the quick subset (cut after the quick frame count); absent
            until a quick run was written.
        scenarios: Metrics of the full runs; absent until a full run was written.
    """

    format: Literal["fogsim-baseline"] = "fogsim-baseline"
    version: Literal[1] = 1
    quick_scenarios: dict[str, BaselineEntry] | UnsetType = UNSET
    scenarios: dict[str, BaselineEntry] | UnsetType = UNSET

    def section(self, quick: bool) -> dict[str, BaselineEntry]:
        """The metrics a quick or a full run is compared with (empty when absent)."""
        entries = self.quick_scenarios if quick else self.scenarios
        return {} if entries is UNSET else entries


def section_name(quick: bool) -> str:
    """The baseline key of a quick or a full run."""
    return "quick_scenarios" if quick else "scenarios"


def check_metrics(
    name: str, current: Mapping[str, float], baseline: Mapping[str, float]
) -> list[str]:
    """Every metric of one scenario worse than its baseline beyond its tolerance, or missing.

    Returns:
        Human-readable lines, empty if nothing got worse.
    """
    problems = []
    for metric, base_value in baseline.items():
        if metric not in current:
            problems.append(f"{name}: {metric} missing (baseline {base_value:g})")
            continue
        rule = rule_for(metric)
        excess = rule.worse_by(float(current[metric]), float(base_value))
        if excess > 1e-9:
            problems.append(
                f"{name}: {metric} got worse: {current[metric]:g} vs baseline "
                f"{base_value:g} ({rule.direction} is better, tolerance {rule.absolute:g}"
                + (f" + {rule.relative:g}×baseline" if rule.relative else "")
                + ")"
            )
    return problems


def load_baseline(path: str | os.PathLike[str]) -> Baseline:
    """Read ``baseline.json``; raises :class:`fogsim.errors.ReportError` naming any bad key."""
    return load_json(path, Baseline, "baseline")


def write_baseline(path: str | os.PathLike[str], baseline: Baseline) -> Path:
    """Write ``baseline.json`` with sorted keys, atomically."""
    return write_json(path, baseline, sort_keys=True)
