"""Run every scenario of a folder (over seeds), summarise the runs, check them against a baseline.

:func:`run_suite` runs the scenarios — each at its own seed, or each over the same seeds —
in parallel processes or as Ray tasks (:func:`fogsim.run.seeds.run_jobs`, each run as
``fogsim run`` does it) and writes ``summary.json`` (:class:`SuiteSummary`) and ``summary.md``:
per scenario, every figure's mean and worst over the seeds. A scenario fails when it cannot be
loaded, a run of it raises, or a run's map is poor (the report's ``quality.poor``).
:func:`check_against_baseline` compares the figures with the baseline's set of the same kind of
run (quick or full, same seeds; :mod:`fogsim.run.baseline`) and lists every figure whose mean,
or worst over the seeds, got worse than its tolerance allows.

Output folders: ``OUT/<scenario>/`` for a run at the scenario's own seed,
``OUT/<scenario>/seed_<n>/`` for each of ``--seeds``; a scenario whose name would lead out of
``OUT`` fails (:func:`fogsim.run.output_paths.child_path`). ``OUT`` is written whole, with its
``manifest.json`` (:class:`~fogsim.run.run_folder.RunFolder`).
"""

from __future__ import annotations

import os
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

from fogsim.atomic import write_text_atomic
from fogsim.config import Scenario, find_scenario_files, load_scenario
from fogsim.errors import FogsimError
from fogsim.eval.report.io import load_json, write_json
from fogsim.paths import SCENARIOS_DIR
from fogsim.run.baseline import (
    Baseline,
    BaselineEntry,
    BaselineFigure,
    check_figures,
    set_name,
)
from fogsim.run.output_paths import child_path
from fogsim.run.ray_cluster import check_ray_address
from fogsim.run.run_folder import RunFolder
from fogsim.run.seed_spec import format_seeds
from fogsim.run.seeds import (
    FigureStats,
    SeedJob,
    SeedRun,
    check_workers,
    figure_stats,
    figures_markdown,
    run_jobs,
    runs_markdown,
    seed_jobs,
    where_run,
)
from fogsim.run.targets import (
    TargetResult,
    Targets,
    check_targets,
    run_failures,
    targets_markdown,
)

QUICK_SCENARIOS = ("flat_floor", "box_removal", "stairs")
"""The quick subset: an empty floor, an event (Fig. 5) and a staircase (Table I)."""

QUICK_MAX_FRAMES = 80
"""Frames of each quick run (6.4 s at 12.5 Hz): ``stairs`` has seen every tread by then."""


@dataclass(frozen=True)
class ScenarioRuns:
    """One scenario of a suite run.

    Attributes:
        runs: One run per seed (one run at the scenario's own seed without ``--seeds``).
        figures: Each figure's mean and worst over the runs that worked.
        error: Why the scenario could not be run at all (None if it was loaded).
    """

    runs: tuple[SeedRun, ...]
    figures: dict[str, FigureStats]
    error: str | None = None

    def failures(self) -> list[str]:
        """Why the scenario failed: not loaded, a run raised, a run's map is poor (empty: ok)."""
        if self.error is not None:
            return [self.error]
        return [f"seed {run.seed}: {run.status()}" for run in self.runs if run.status() != "ok"]


@dataclass(frozen=True)
class SuiteSummary:
    """``summary.json`` of a suite run.

    Attributes:
        format: Always ``fogsim-suite``.
        version: Schema version, 2 (version 1 had one metrics table per scenario).
        quick: Only the quick subset was run, each cut after ``QUICK_MAX_FRAMES`` frames.
        seeds: The seeds every scenario ran over (canonical spec, ``"1-8"``); None = each
            scenario at its own seed.
        workers: Parallel processes (not used when ``ray_address`` is set).
        wall_s: Wall time of the whole suite [s].
        scenarios: Each scenario's runs and figures, by name, in file order.
        ray_address: The Ray cluster the runs went to (its CPUs, not ``workers``); None =
            local processes (and in summaries written before the field existed).
        overrides: The ``--set`` assignments applied to every scenario, in the order given
            (empty in summaries written before the field existed); part of the baseline set's
            name (:func:`fogsim.run.baseline.set_name`).
    """

    format: Literal["fogsim-suite"]
    version: Literal[2]
    quick: bool
    seeds: str | None
    workers: int
    wall_s: float
    scenarios: dict[str, ScenarioRuns]
    ray_address: str | None = None
    overrides: tuple[str, ...] = ()

    def failures(self) -> dict[str, list[str]]:
        """Failed scenarios → why (see :meth:`ScenarioRuns.failures`)."""
        return {name: s.failures() for name, s in self.scenarios.items() if s.failures()}


def scenario_paths(directory: str | os.PathLike[str] | None, quick: bool) -> list[Path]:
    """Scenario files of a folder (default: the project's), the quick subset if asked."""
    folder = Path(directory) if directory is not None else SCENARIOS_DIR
    paths = find_scenario_files(folder)  # ScenarioError if the folder holds none
    if quick:
        paths = [p for p in paths if p.stem in QUICK_SCENARIOS]
        if not paths:
            raise FogsimError(f"--quick runs {list(QUICK_SCENARIOS)}, none of which is in {folder}")
    return paths


def _jobs(
    scenario: Scenario, folder: Path, seeds: Sequence[int] | None, max_frames: int | None
) -> list[SeedJob]:
    """A scenario's jobs: one at its own seed into ``folder``, or one per seed below it."""
    name = scenario.name
    if seeds is None:
        return [SeedJob(scenario, folder, f"{name}/report.json", max_frames=max_frames)]
    return seed_jobs(scenario, seeds, folder, prefix=f"{name}/", max_frames=max_frames)


def _load_with_overrides(
    paths: Sequence[Path], overrides: Sequence[str]
) -> list[Scenario | FogsimError]:
    """Each scenario file loaded with the overrides applied, or why it could not be.

    A broken file fails its own scenario, not the suite; but overrides that fail on every
    scenario that loads are a bad command line (an unknown key, a value out of range), which
    no run would survive: that is raised before any run, once, instead of failing each.

    Raises:
        FogsimError: The overrides fail on every scenario that loads without them.
    """
    loaded: list[Scenario | FogsimError] = []
    override_errors: list[FogsimError] = []
    for path in paths:
        try:
            scenario = load_scenario(path)
        except FogsimError as exc:
            loaded.append(exc)
            continue
        try:
            loaded.append(scenario.with_overrides(list(overrides)) if overrides else scenario)
        except FogsimError as exc:
            loaded.append(exc)
            override_errors.append(exc)
    if override_errors and not any(isinstance(entry, Scenario) for entry in loaded):
        raise FogsimError(
            f"--set {' '.join(overrides)}: fails on every scenario of the suite "
            f"({len(override_errors)}), e.g. {override_errors[0]}"
        )
    return loaded


def run_suite(
    directory: str | os.PathLike[str] | None,
    out_dir: str | os.PathLike[str],
    *,
    workers: int = 2,
    quick: bool = False,
    seeds: Sequence[int] | None = None,
    overrides: Sequence[str] = (),
    baseline: Baseline | None = None,
    ray_address: str | None = None,
    targets: Targets | None = None,
) -> SuiteSummary:
    """Run every scenario of a folder in parallel processes; write summary.json / summary.md.

    ``out_dir`` is written whole (:class:`~fogsim.run.run_folder.RunFolder`: checked before the
    runs, a temporary folder renamed into place with its ``manifest.json``), so it never mixes
    two suite runs; each run's folder inside is a run folder of its own.

    Args:
        directory: Folder of scenario files (None = the project's ``scenarios/``).
        out_dir: Output folder.
        workers: Parallel processes (1 = inline).
        quick: Only :data:`QUICK_SCENARIOS`, each cut after :data:`QUICK_MAX_FRAMES` frames.
        seeds: Run every scenario over these seeds (None = each at its own seed).
        overrides: ``key=value`` assignments applied to every scenario.
        baseline: The baseline whose comparison (:func:`check_against_baseline`) summary.md
            shows; None: "no baseline given".
        ray_address: Run the scenarios' jobs as tasks on this Ray cluster
            (:func:`fogsim.run.seeds.run_jobs`); None = local processes.
        targets: Accuracy targets whose check (:func:`check_suite_targets`) summary.md shows;
            None: no Targets section.

    Raises:
        FogsimError: No scenario file, ``workers`` out of range, two files with one scenario
            name, an invalid or unreachable ``ray_address``, ``overrides`` that apply to none
            of the scenarios that load (before any run).
        OutputError: ``out_dir`` cannot be written (found before the runs) or writing failed.
    """
    paths = scenario_paths(directory, quick)
    check_workers(workers)
    if ray_address is not None:
        check_ray_address(ray_address)
    loaded = _load_with_overrides(paths, overrides)
    max_frames = QUICK_MAX_FRAMES if quick else None
    with RunFolder(out_dir) as folder:
        start = time.perf_counter()
        planned: dict[str, list[SeedJob] | str] = {}  # name → its jobs, or why it was not loaded
        for path, scenario in zip(paths, loaded, strict=True):
            try:
                if isinstance(scenario, FogsimError):
                    raise scenario
                scenario_dir = child_path(folder.path, scenario.name, f"{path}: scenario name")
            except FogsimError as exc:  # a broken file fails its scenario, not the suite
                planned[path.stem] = f"{type(exc).__name__}: {exc}"
                continue
            if scenario.name in planned:
                raise FogsimError(
                    f"two scenario files in {path.parent} are named {scenario.name!r}"
                )
            planned[scenario.name] = _jobs(scenario, scenario_dir, seeds, max_frames)
        jobs = [job for entry in planned.values() if isinstance(entry, list) for job in entry]
        runs = iter(run_jobs(jobs, workers, ray_address))
        scenarios = {}
        for name, entry in planned.items():
            if isinstance(entry, str):
                scenarios[name] = ScenarioRuns(runs=(), figures={}, error=entry)
                continue
            own = tuple(next(runs) for _ in entry)
            scenarios[name] = ScenarioRuns(runs=own, figures=figure_stats(own))
        summary = SuiteSummary(
            format="fogsim-suite",
            version=2,
            quick=quick,
            seeds=format_seeds(seeds) if seeds is not None else None,
            workers=workers,
            wall_s=round(time.perf_counter() - start, 2),
            scenarios=scenarios,
            ray_address=ray_address,
            overrides=tuple(overrides),
        )
        comparison = check_against_baseline(summary, baseline) if baseline is not None else None
        checked = check_suite_targets(summary, targets) if targets is not None else None
        write_json(folder.path / "summary.json", summary)
        write_text_atomic(
            folder.path / "summary.md", summary_markdown(summary, comparison, checked)
        )
        folder.commit("suite", seeds=summary.seeds)
    return summary


def _entry(figures: dict[str, FigureStats]) -> BaselineEntry:
    """A scenario's figures as the baseline keeps them (mean and worst)."""
    return BaselineEntry({name: BaselineFigure(s.mean, s.worst) for name, s in figures.items()})


def check_against_baseline(summary: SuiteSummary, baseline: Baseline) -> list[str]:
    """Every figure of the summary worse than the baseline beyond its tolerance.

    The summary is compared with the baseline's set of the same kind of run
    (:func:`fogsim.run.baseline.set_name`): a quick run over seeds 1–8 only with
    ``"quick seeds=1-8"``, a run with ``--set camera.mode=stereo`` only with that set of its own.
    Means are compared, and over several seeds the worst values too.
    Scenarios of the baseline that the summary did not run are skipped; a figure the baseline
    has but the run lacks is reported, as is a scenario whose run raised (its figures would be
    over fewer seeds). A poor run's figures are compared: the suite fails it anyway.

    Returns:
        Human-readable lines, empty if nothing got worse.
    """
    key = set_name(summary.quick, summary.seeds, summary.overrides)
    entries = baseline.sets.get(key)
    if entries is None:
        known = ", ".join(f"'{name}'" for name in sorted(baseline.sets)) or "none"
        return [f"baseline has no set '{key}' to compare this run with (it has: {known})"]
    problems = []
    for name, base in entries.items():
        scenario = summary.scenarios.get(name)
        if scenario is None:
            continue
        if scenario.error is not None or any(run.error for run in scenario.runs):
            problems.append(f"{name}: not compared: a run failed")
            continue
        several = len(scenario.runs) > 1
        problems += check_figures(name, _entry(scenario.figures).figures, base, worst=several)
    return problems


def load_suite_summary(path: str | os.PathLike[str]) -> SuiteSummary:
    """Read a suite's ``summary.json``.

    Raises:
        ReportError: The file is missing or does not match the summary's schema (the message
            names the key).
    """
    return load_json(path, SuiteSummary, "suite summary")


def check_suite_targets(summary: SuiteSummary, targets: Targets) -> list[TargetResult]:
    """The summary's figures against accuracy targets (:func:`fogsim.run.targets.check_targets`).

    A scenario that could not be loaded or one of whose runs raised is not checked
    (:func:`fogsim.run.targets.run_failures`): each target that applies to it is missed.
    """
    failed = {}
    for name, scenario in summary.scenarios.items():
        reasons = run_failures(scenario.error, scenario.runs)
        if reasons:
            failed[name] = reasons
    figures = {name: scenario.figures for name, scenario in summary.scenarios.items()}
    return check_targets(figures, failed, targets)


def update_baseline(baseline: Baseline | None, summary: SuiteSummary) -> Baseline:
    """The baseline with the summary's figures as the set of its kind of run.

    The other sets of an existing baseline are kept, so one file serves ``--check`` of the
    full suite over seeds 1–8 and of the quick subset. Failed scenarios (not loaded, a run
    raised, or a poor map) are left out.
    """
    failed = summary.failures()
    entries = {
        name: _entry(scenario.figures)
        for name, scenario in summary.scenarios.items()
        if name not in failed
    }
    sets = dict(baseline.sets) if baseline is not None else {}
    sets[set_name(summary.quick, summary.seeds, summary.overrides)] = entries
    return Baseline(sets=sets)


def summary_markdown(
    summary: SuiteSummary,
    comparison: Sequence[str] | None = None,
    targets: Sequence[TargetResult] | None = None,
) -> str:
    """The suite's Markdown summary: the scenarios' status, each one's figures, the checks.

    Args:
        summary: The suite's summary.
        comparison: The baseline check's lines (empty: nothing got worse); None when no
            baseline was given.
        targets: The targets check's results (:func:`check_suite_targets`); None: no Targets
            section.
    """
    seeds = f"seeds {summary.seeds}" if summary.seeds is not None else "each at its own seed"
    settings = f"; every scenario with {', '.join(summary.overrides)}" if summary.overrides else ""
    lines = [
        "# fogsim suite",
        "",
        f"{len(summary.scenarios)} scenarios, {seeds}, "
        f"{where_run(summary.workers, summary.ray_address)}, "
        f"{summary.wall_s} s wall{' (quick subset)' if summary.quick else ''}{settings}. "
        "Worst = the largest error, the smallest recall or precision.",
        "",
        "| scenario | runs | frames | wall s | status |",
        "|---|---:|---:|---:|---|",
    ]
    for name, scenario in summary.scenarios.items():
        frames = sorted({run.frames for run in scenario.runs}) or [0]
        frames_text = str(frames[0]) if len(frames) == 1 else f"{frames[0]}–{frames[-1]}"
        wall = round(sum(run.wall_s for run in scenario.runs), 2)
        status = "; ".join(scenario.failures()) or "ok"
        lines.append(f"| {name} | {len(scenario.runs)} | {frames_text} | {wall} | {status} |")
    for name, scenario in summary.scenarios.items():
        if not scenario.runs:
            continue
        lines += ["", f"## {name}"]
        if summary.seeds is not None:
            lines += ["", *runs_markdown(scenario.runs)]
        lines += figures_markdown(scenario.figures)
    lines += ["", "## Baseline", ""]
    if comparison is None:
        lines.append("No baseline given: nothing compared.")
    elif not comparison:
        lines.append("Nothing got worse than the baseline.")
    else:
        lines += [f"- {line}" for line in comparison]
    if targets is not None:
        lines += ["", "## Targets", "", *targets_markdown(targets)]
    return "\n".join(lines) + "\n"
