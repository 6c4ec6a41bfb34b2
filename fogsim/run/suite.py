"""Run every scenario of a folder, summarise the runs, and check them against the baseline.

:func:`run_suite` runs the scenarios in parallel processes (each as ``fogsim run`` does,
:func:`fogsim.run.runner.run_scenario`) and writes ``summary.json`` and ``summary.md``;
:func:`check_against_baseline` compares the summary's metrics (:mod:`fogsim.run.baseline`)
with ``baseline.json`` and lists every metric that got worse by more than its tolerance.
"""

from __future__ import annotations

import concurrent.futures
import dataclasses
import math
import multiprocessing
import os
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

from fogsim.atomic import write_text_atomic
from fogsim.config import find_scenario_files, load_scenario
from fogsim.errors import FogsimError
from fogsim.eval.report.io import write_json
from fogsim.paths import SCENARIOS_DIR
from fogsim.run.baseline import (
    NEVER_FRAMES,
    Baseline,
    BaselineEntry,
    check_metrics,
    report_metrics,
    section_name,
)
from fogsim.run.runner import run_scenario

QUICK_SCENARIOS = ("flat_floor", "box_removal")
QUICK_MAX_FRAMES = 80
"""The quick subset: these scenarios, each cut after this many frames (6.4 s at 12.5 Hz)."""


@dataclass(frozen=True)
class ScenarioRun:
    """One scenario of a suite run.

    Attributes:
        metrics: Its regression metrics (:func:`fogsim.run.baseline.report_metrics`), empty if
            the run failed.
        frames: Frames run.
        wall_s: Wall time of the run [s].
        report: Path of its ``report.json`` relative to the suite's folder (None if failed).
        error: Why the run failed (None if it worked).
    """

    metrics: dict[str, float]
    frames: int
    wall_s: float
    report: str | None
    error: str | None


@dataclass(frozen=True)
class SuiteSummary:
    """``summary.json`` of a suite run.

    Attributes:
        format: Always ``fogsim-suite``.
        version: Schema version, 1.
        quick: Only the quick subset was run, each cut after ``QUICK_MAX_FRAMES`` frames.
        workers: Parallel processes.
        wall_s: Wall time of the whole suite [s].
        scenarios: Each scenario's run, by name, in file order.
    """

    format: Literal["fogsim-suite"]
    version: Literal[1]
    quick: bool
    workers: int
    wall_s: float
    scenarios: dict[str, ScenarioRun]


def _suite_worker(
    path: str, out_dir: str, quick: bool, overrides: Sequence[str]
) -> tuple[str, ScenarioRun]:
    """One scenario in a worker process: run it, return its name and summary entry."""
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
        return name, ScenarioRun(
            metrics=report_metrics(report),
            frames=report.timing.frames,
            wall_s=round(time.perf_counter() - start, 2),
            report=f"{name}/report.json",
            error=None,
        )
    except Exception as exc:  # a failing scenario must not stop the others
        return name, ScenarioRun(
            metrics={},
            frames=0,
            wall_s=round(time.perf_counter() - start, 2),
            report=None,
            error=f"{type(exc).__name__}: {exc}",
        )


def scenario_paths(directory: str | os.PathLike[str] | None, quick: bool) -> list[Path]:
    """Scenario files of a folder (default: the project's), the quick subset if asked."""
    folder = Path(directory) if directory is not None else SCENARIOS_DIR
    paths = find_scenario_files(folder)  # ScenarioError if the folder holds none
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
) -> SuiteSummary:
    """Run every scenario of a folder in parallel processes; write summary.json / summary.md."""
    if workers < 1:
        raise FogsimError(f"--workers must be >= 1, got {workers}")
    paths = scenario_paths(directory, quick)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    if workers == 1:
        runs = [_suite_worker(str(p), str(out), quick, tuple(overrides)) for p in paths]
    else:
        context = multiprocessing.get_context("spawn")  # MuJoCo/EGL state must not be forked
        with concurrent.futures.ProcessPoolExecutor(workers, mp_context=context) as pool:
            futures = [
                pool.submit(_suite_worker, str(p), str(out), quick, tuple(overrides)) for p in paths
            ]
            runs = [f.result() for f in futures]
    summary = SuiteSummary(
        format="fogsim-suite",
        version=1,
        quick=quick,
        workers=workers,
        wall_s=round(time.perf_counter() - start, 2),
        scenarios=dict(runs),
    )
    write_json(out / "summary.json", summary)
    write_text_atomic(out / "summary.md", summary_markdown(summary))
    return summary


def check_against_baseline(summary: SuiteSummary, baseline: Baseline) -> list[str]:
    """Every metric of the summary worse than the baseline beyond its tolerance.

    A quick summary is compared with the baseline's ``quick_scenarios``, a full one with its
    ``scenarios``. Scenarios of the baseline that the summary did not run are skipped; a metric
    the baseline has but the run lacks is reported, as is a scenario that failed.

    Returns:
        Human-readable lines, empty if nothing got worse.
    """
    section = section_name(summary.quick)
    entries = baseline.section(summary.quick)
    if not entries:
        return [f"baseline has no '{section}' to compare a {section.split('_')[0]} run with"]
    problems = []
    for name, base in entries.items():
        run = summary.scenarios.get(name)
        if run is None:
            continue
        if run.error:
            problems.append(f"{name}: run failed: {run.error}")
            continue
        problems += check_metrics(name, run.metrics, base.metrics)
    return problems


def update_baseline(baseline: Baseline | None, summary: SuiteSummary) -> Baseline:
    """The baseline with the summary's metrics as its ``quick_scenarios`` or ``scenarios``.

    The other section of an existing baseline is kept, so one file serves ``--check`` of both
    the full and the quick suite. Failed scenarios are left out.
    """
    entries = {
        name: BaselineEntry(metrics=run.metrics)
        for name, run in summary.scenarios.items()
        if not run.error
    }
    current = baseline or Baseline()
    if summary.quick:
        return dataclasses.replace(current, quick_scenarios=entries)
    return dataclasses.replace(current, scenarios=entries)


def _fmt(value: float | None) -> str:
    if value is None:
        return "–"
    if value >= NEVER_FRAMES:
        return "never"
    return f"{value:.4g}" if math.isfinite(value) else "–"


def summary_markdown(summary: SuiteSummary, problems: Sequence[str] = ()) -> str:
    """The suite's Markdown summary: one section per scenario with its metrics."""
    lines = [
        "# fogsim suite",
        "",
        f"{len(summary.scenarios)} scenarios, {summary.workers} workers, "
        f"{summary.wall_s} s wall{' (quick subset)' if summary.quick else ''}.",
        "",
        "| scenario | frames | wall s | status |",
        "|---|---:|---:|---|",
    ]
    for name, run in summary.scenarios.items():
        status = f"failed: {run.error}" if run.error else "ok"
        lines.append(f"| {name} | {run.frames} | {run.wall_s} | {status} |")
    for name, run in summary.scenarios.items():
        if not run.metrics:
            continue
        lines += ["", f"## {name}", "", "| metric | value |", "|---|---:|"]
        lines += [f"| {m} | {_fmt(v)} |" for m, v in sorted(run.metrics.items())]
    if problems:
        lines += ["", "## Worse than the baseline", ""] + [f"- {p}" for p in problems]
    return "\n".join(lines) + "\n"
