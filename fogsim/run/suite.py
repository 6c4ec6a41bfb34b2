"""Run scenarios (one or all), summarise them, and check them against a committed baseline.

:func:`run_scenario` is what ``fogsim run`` does: simulate (or replay) a scenario, feed the
pipeline, write ``report.json`` and the pictures. :func:`run_suite` runs every scenario of a
folder in parallel processes and writes ``summary.json`` and ``summary.md``;
:func:`check_against_baseline` compares the summary's metrics with ``baseline.json`` and lists
every metric that got worse by more than its tolerance.

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
"""

from __future__ import annotations

import concurrent.futures
import json
import math
import multiprocessing
import os
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from msgspec import UNSET

from fogsim.atomic import write_text_atomic
from fogsim.config.scenario import load_scenario
from fogsim.errors import FogsimError
from fogsim.eval.report import Report
from fogsim.paths import SCENARIOS_DIR
from fogsim.run.runner import run_scenario

NEVER_FRAMES = 1_000_000.0
QUICK_SCENARIOS = ("flat_floor", "box_removal")
QUICK_MAX_FRAMES = 80
"""The quick subset: these scenarios, each cut after this many frames (6.4 s at 12.5 Hz)."""


@dataclass(frozen=True)
class MetricRule:
    """How a metric may change.

    Attributes:
        direction: ``"lower"`` or ``"higher"`` is better.
        absolute: Allowed slack in the metric's unit.
        relative: Further slack as a fraction of ``|baseline|``.
    """

    direction: str
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


def check_against_baseline(summary: Mapping[str, Any], baseline: Mapping[str, Any]) -> list[str]:
    """Every metric of the summary worse than the baseline beyond its tolerance.

    A quick summary is compared with the baseline's ``quick_scenarios``, a full one with its
    ``scenarios``. Scenarios of the baseline that the summary did not run are skipped; a metric
    the baseline has but the run lacks is reported, as is a scenario that failed.

    Returns:
        Human-readable lines, empty if nothing got worse.
    """
    problems = []
    ran = summary.get("scenarios") or {}
    section = "quick_scenarios" if summary.get("quick") else "scenarios"
    if not baseline.get(section):
        return [f"baseline has no '{section}' to compare a {section.split('_')[0]} run with"]
    for name, base in baseline[section].items():
        if name not in ran:
            continue
        entry = ran[name]
        if entry.get("error"):
            problems.append(f"{name}: run failed: {entry['error']}")
            continue
        current = entry.get("metrics") or {}
        for metric, base_value in (base.get("metrics") or {}).items():
            if metric not in current:
                problems.append(f"{name}: {metric} missing (baseline {base_value:g})")
                continue
            rule = rule_for(metric)
            excess = rule.worse_by(float(current[metric]), float(base_value))
            if excess > 1e-9:
                problems.append(
                    f"{name}: {metric} got worse: {current[metric]:g} vs baseline "
                    f"{base_value:g} ({'lower' if rule.direction == 'lower' else 'higher'} is "
                    f"better, tolerance {rule.absolute:g}"
                    + (f" + {rule.relative:g}×baseline" if rule.relative else "")
                    + ")"
                )
    return problems


def _suite_worker(path: str, out_dir: str, quick: bool, overrides: Sequence[str]) -> dict:
    """One scenario in a worker process: run it, return its summary entry."""
    start = time.perf_counter()
    name = Path(path).stem
    try:
        scenario = load_scenario(path)
        name = scenario.name
        if overrides:
            scenario = scenario.with_overrides(list(overrides))
        report = run_scenario(
            scenario,
            Path(out_dir) / name,
            max_frames=QUICK_MAX_FRAMES if quick else None,
        )
        return {
            "name": name,
            "metrics": report_metrics(report),
            "frames": report.timing.frames,
            "wall_s": round(time.perf_counter() - start, 2),
            "report": f"{name}/report.json",
            "error": None,
        }
    except Exception as exc:  # a failing scenario must not stop the others
        return {
            "name": name,
            "metrics": {},
            "frames": 0,
            "wall_s": round(time.perf_counter() - start, 2),
            "report": None,
            "error": f"{type(exc).__name__}: {exc}",
        }


def scenario_paths(directory: str | os.PathLike[str] | None, quick: bool) -> list[Path]:
    """Scenario files of a folder (default: the project's), the quick subset if asked."""
    folder = Path(directory) if directory is not None else SCENARIOS_DIR
    paths = sorted(folder.glob("*.toml"))
    if not paths:
        raise FogsimError(f"no scenario files (*.toml) in {folder}")
    if quick:
        paths = [p for p in paths if p.stem in QUICK_SCENARIOS]
        if not paths:
            raise FogsimError(f"--quick runs {list(QUICK_SCENARIOS)}, none of which is in {folder}")
    return paths


def run_suite(
    directory: str | os.PathLike[str] | None,
    out_dir: str | os.PathLike[str],
    *,
    workers: int = 2,
    quick: bool = False,
    overrides: Sequence[str] = (),
) -> dict:
    """Run every scenario of a folder in parallel processes; write summary.json / summary.md.

    Returns:
        The summary: ``{"quick", "workers", "wall_s", "scenarios": {name: entry}}`` with each
        entry's ``metrics`` (:func:`report_metrics`), ``frames``, ``wall_s``, ``report`` path and
        ``error`` (null if the run worked).
    """
    if workers < 1:
        raise FogsimError(f"--workers must be >= 1, got {workers}")
    paths = scenario_paths(directory, quick)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    entries: list[dict] = []
    if workers == 1:
        entries = [_suite_worker(str(p), str(out), quick, tuple(overrides)) for p in paths]
    else:
        context = multiprocessing.get_context("spawn")  # MuJoCo/EGL state must not be forked
        with concurrent.futures.ProcessPoolExecutor(workers, mp_context=context) as pool:
            futures = [
                pool.submit(_suite_worker, str(p), str(out), quick, tuple(overrides)) for p in paths
            ]
            entries = [f.result() for f in futures]
    summary = {
        "format": "fogsim-suite",
        "version": 1,
        "quick": quick,
        "workers": workers,
        "wall_s": round(time.perf_counter() - start, 2),
        "scenarios": {e["name"]: {k: v for k, v in e.items() if k != "name"} for e in entries},
    }
    write_text_atomic(out / "summary.json", json.dumps(summary, indent=2) + "\n")
    write_text_atomic(out / "summary.md", summary_markdown(summary))
    return summary


def _fmt(value: float | None) -> str:
    if value is None:
        return "–"
    if value >= NEVER_FRAMES:
        return "never"
    return f"{value:.4g}" if math.isfinite(value) else "–"


def summary_markdown(summary: Mapping[str, Any], problems: Sequence[str] = ()) -> str:
    """The suite's Markdown summary: one section per scenario with its metrics."""
    lines = [
        "# fogsim suite",
        "",
        f"{len(summary['scenarios'])} scenarios, {summary['workers']} workers, "
        f"{summary['wall_s']} s wall{' (quick subset)' if summary.get('quick') else ''}.",
        "",
        "| scenario | frames | wall s | status |",
        "|---|---:|---:|---|",
    ]
    for name, entry in summary["scenarios"].items():
        status = f"failed: {entry['error']}" if entry.get("error") else "ok"
        lines.append(f"| {name} | {entry['frames']} | {entry['wall_s']} | {status} |")
    for name, entry in summary["scenarios"].items():
        if not entry.get("metrics"):
            continue
        lines += ["", f"## {name}", "", "| metric | value |", "|---|---:|"]
        lines += [f"| {m} | {_fmt(v)} |" for m, v in sorted(entry["metrics"].items())]
    if problems:
        lines += ["", "## Worse than the baseline", ""] + [f"- {p}" for p in problems]
    return "\n".join(lines) + "\n"


def update_baseline(baseline: Mapping[str, Any] | None, summary: Mapping[str, Any]) -> dict:
    """baseline.json with the summary's metrics as its ``quick_scenarios`` or ``scenarios``.

    The other section of an existing baseline is kept, so one file serves ``--check`` of both
    the full and the quick suite. Failed scenarios are left out.
    """
    updated = dict(baseline or {})
    updated.update({"format": "fogsim-baseline", "version": 1})
    section = "quick_scenarios" if summary.get("quick") else "scenarios"
    updated[section] = {
        name: {"metrics": entry["metrics"]}
        for name, entry in summary["scenarios"].items()
        if not entry.get("error")
    }
    return updated


def load_json(path: str | os.PathLike[str], what: str) -> dict:
    """Read a JSON file, with an error naming the file and what it should be."""
    try:
        return json.loads(Path(path).read_text(encoding="utf-8"))
    except FileNotFoundError as exc:
        raise FogsimError(f"{what} not found: {path}") from exc
    except json.JSONDecodeError as exc:
        raise FogsimError(f"{what} {path} is not valid JSON: {exc}") from exc
