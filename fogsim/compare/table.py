"""The comparison's figures per run, their mean and worst over runs, as JSON and Markdown.

Per run and row (a map labelled one way), from its scores (:mod:`fogsim.eval`):

* ``table1_worst_abs_error_mm``: the largest ``|error|`` of Table I over the surfaces the row's
  floor cells cover (a surface it covers nowhere has no row value);
* ``floor_height_median_mm``: median ``|height − true floor|`` over every true floor cell the
  map has a height for, whatever its label (heights only);
* ``unsafe_cells``, ``floor_recall``, ``floor_precision``, ``obstacle_recall``,
  ``obstacle_precision``: labels against the truth (the row's labels);
* ``step_edge_abs_error_mm``: mean over the edges the row's floor shows of ``|median error|``;
* ``scan_median_abs_error_mm``, ``scan_p95_abs_error_mm``, ``scan_coverage``: the height scans
  (:mod:`fogsim.compare.scans`; per map, the same for both rows of a labelled map);
* ``events.<object>.cleared_frames`` / ``floor_again_frames``: frames until the object's
  footprint no longer shows it / is floor again (never = :data:`NEVER_FRAMES`; no value when the
  map never showed the object).

The worst over runs is the largest value of a "lower is better" figure, the smallest of a
"higher is better" one. These tables hold no timing, so the same recordings give the same bytes
every time; update times (``update_ms_median``, ``update_ms_p99`` per map, measured in the same
process) go to a table of their own.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np

from fogsim.compare.maps import RULE_SUFFIX
from fogsim.compare.replay import RunComparison
from fogsim.run.baseline import NEVER_FRAMES

Better = Literal["lower", "higher"]

FIGURES: tuple[tuple[str, Better, str], ...] = (
    ("table1_worst_abs_error_mm", "lower", "Table I worst [mm]"),
    ("floor_height_median_mm", "lower", "floor height median [mm]"),
    ("unsafe_cells", "lower", "unsafe cells"),
    ("floor_recall", "higher", "floor recall"),
    ("floor_precision", "higher", "floor precision"),
    ("obstacle_recall", "higher", "obstacle recall"),
    ("obstacle_precision", "higher", "obstacle precision"),
    ("step_edge_abs_error_mm", "lower", "step edge [mm]"),
    ("scan_median_abs_error_mm", "lower", "scan median [mm]"),
    ("scan_p95_abs_error_mm", "lower", "scan p95 [mm]"),
    ("scan_coverage", "higher", "scan coverage"),
)
"""Every fixed figure: key, which way is better, Markdown column title."""
EVENT_FIGURES = ("cleared_frames", "floor_again_frames")
"""Event figures (lower is better), per object: ``events.<object>.<figure>``."""
FORMAT = "fogsim-compare-1"
"""The ``format`` key of ``compare.json``."""

Figures = dict[str, float | None]


def _round(value: float | None, digits: int = 3) -> float | None:
    """A figure as written: rounded, None for NaN or None."""
    if value is None or not math.isfinite(float(value)):
        return None
    return round(float(value), digits)


def run_figures(run: RunComparison) -> dict[str, Figures]:
    """Per row of one run, every figure (module docstring)."""
    rows: dict[str, Figures] = {}
    for row, scores in run.scores.items():
        map_run = run.maps[row.removesuffix(RULE_SUFFIX)]
        errors = [abs(r.error_mm) for r in scores.table1.fog if r.error_mm is not None]
        classes = scores.cells.fog.classes
        edges = [abs(e.median_error_mm) for e in scores.step_edges if e.median_error_mm is not None]
        scan_mm = 1000.0 * map_run.scan_errors_m
        figures: Figures = {
            "table1_worst_abs_error_mm": max(errors) if errors else None,
            "floor_height_median_mm": scores.cells.averaging.floor_height.median_abs_error_mm,
            "unsafe_cells": float(scores.safety.unsafe_cells),
            "floor_recall": classes.floor.recall,
            "floor_precision": classes.floor.precision,
            "obstacle_recall": classes.obstacle.recall,
            "obstacle_precision": classes.obstacle.precision,
            "step_edge_abs_error_mm": float(np.mean(edges)) if edges else None,
            "scan_median_abs_error_mm": float(np.median(scan_mm)) if scan_mm.size else None,
            "scan_p95_abs_error_mm": float(np.percentile(scan_mm, 95)) if scan_mm.size else None,
            "scan_coverage": scan_mm.size / map_run.scan_points if map_run.scan_points else None,
        }
        for event in run.events[row]:
            for name in EVENT_FIGURES:
                frames = getattr(event, name).fog
                scored = event.seen.fog and event.start_frame is not None
                figures[f"events.{event.object}.{name}"] = (
                    None if not scored else NEVER_FRAMES if frames is None else float(frames)
                )
        rows[row] = {key: _round(value) for key, value in figures.items()}
    return rows


def timing_figures(run: RunComparison) -> dict[str, Figures]:
    """Per map of one run, the median and p99 update time per frame [ms] (withdrawn left out)."""
    out: dict[str, Figures] = {}
    for m, map_run in run.maps.items():
        times = map_run.update_ms[np.isfinite(map_run.update_ms)]
        out[m] = {
            "update_ms_median": _round(float(np.median(times)), 4) if times.size else None,
            "update_ms_p99": _round(float(np.percentile(times, 99)), 4) if times.size else None,
        }
    return out


def _better(key: str) -> Better:
    """Which way figure ``key`` is better."""
    for name, better, _ in FIGURES:
        if name == key:
            return better
    return "lower"  # event figures and timing


@dataclass(frozen=True)
class Stat:
    """A figure over runs: mean, worst, how many runs had a value and how many of them never.

    Attributes:
        mean: Mean over the runs with a value (a never counts as :data:`NEVER_FRAMES`).
        worst: The worst value.
        runs: Runs with a value.
        nevers: Runs whose value is never (:data:`NEVER_FRAMES`; event figures only).
    """

    mean: float | None
    worst: float | None
    runs: int
    nevers: int = 0


def aggregate(per_run: Sequence[dict[str, Figures]]) -> dict[str, dict[str, Stat]]:
    """Per row and figure, the mean and worst over the runs that have a value."""
    out: dict[str, dict[str, Stat]] = {}
    for row in per_run[0]:
        keys = sorted({k for run in per_run for k in run.get(row, {})})
        stats: dict[str, Stat] = {}
        for key in keys:
            values = [run[row][key] for run in per_run if run.get(row, {}).get(key) is not None]
            if not values:
                stats[key] = Stat(None, None, 0)
                continue
            worst = max(values) if _better(key) == "lower" else min(values)
            nevers = sum(value >= NEVER_FRAMES for value in values)
            mean = _round(float(np.mean(values)))
            stats[key] = Stat(mean, _round(worst), len(values), nevers)
        out[row] = stats
    return out


def comparison_json(groups: dict[str, Sequence[RunComparison]], maps: tuple[str, ...]) -> str:
    """``compare.json``: per group (scenario), its runs and every row's figures over them."""
    data = {
        "format": FORMAT,
        "maps": list(maps),
        "groups": {
            group: {
                "runs": [run.name for run in runs],
                "rows": {
                    row: {key: vars(stat) for key, stat in stats.items()}
                    for row, stats in aggregate([run_figures(r) for r in runs]).items()
                },
            }
            for group, runs in groups.items()
        },
    }
    return json.dumps(data, indent=1, sort_keys=True) + "\n"


def _cell(stat: Stat | None) -> str:
    """``worst (mean)`` of a figure, ``–`` without a value.

    ``never`` stands for the never value; a mean over runs of which some never got there is
    ``never on k of n`` (the number would be a count of :data:`NEVER_FRAMES`).
    """
    if stat is None or stat.worst is None or stat.mean is None:
        return "–"
    worst = "never" if stat.worst >= NEVER_FRAMES else f"{stat.worst:g}"
    mean = f"never on {stat.nevers} of {stat.runs}" if stat.nevers else f"{stat.mean:g}"
    return f"{worst} ({mean})"


def comparison_markdown(groups: dict[str, Sequence[RunComparison]]) -> str:
    """The tables of ``compare.md``: per group, one row per map, each figure ``worst (mean)``."""
    lines = ["# How the maps compare", "", "Each cell: worst over the runs (mean).", ""]
    for group, runs in groups.items():
        stats = aggregate([run_figures(r) for r in runs])
        event_keys = sorted({k for s in stats.values() for k in s if k.startswith("events.")})
        columns = [(key, title) for key, _, title in FIGURES] + [(k, k[7:]) for k in event_keys]
        lines += [f"## {group} ({len(runs)} runs: {', '.join(r.name for r in runs)})", ""]
        lines.append("| map | " + " | ".join(title for _, title in columns) + " |")
        lines.append("|---" * (len(columns) + 1) + "|")
        for row, row_stats in stats.items():
            cells = " | ".join(_cell(row_stats.get(key)) for key, _ in columns)
            lines.append(f"| {row} | {cells} |")
        lines.append("")
    return "\n".join(lines)


def timing_markdown(groups: dict[str, Sequence[RunComparison]]) -> str:
    """Update time per frame of each map [ms], worst (mean) over runs (not bit for bit)."""
    lines = [
        "# Update time per frame [ms]",
        "",
        "Measured in the same process, every map on the same frames; worst over runs (mean).",
        "",
        "| group | map | median | p99 |",
        "|---|---|---|---|",
    ]
    for group, runs in groups.items():
        for m, stats in aggregate([timing_figures(r) for r in runs]).items():
            median, p99 = stats.get("update_ms_median"), stats.get("update_ms_p99")
            lines.append(f"| {group} | {m} | {_cell(median)} | {_cell(p99)} |")
    return "\n".join(lines) + "\n"
