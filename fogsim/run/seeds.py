"""Run a scenario over several seeds in parallel; each figure's mean and worst over the seeds.

``fogsim run SCENARIO --seeds 1-8`` calls :func:`run_seeds` (the spec read by
:func:`fogsim.run.seed_spec.parse_seeds`): every seed runs in its own process
exactly as ``fogsim run SCENARIO --seed n`` does (the scenario with ``seed=n``, through
:func:`fogsim.run.runner.run_scenario`) into ``OUT/seed_<n>/`` (its ``report.json`` and
pictures), and ``OUT/summary.json`` (:class:`SeedsSummary`, through the one JSON writer of
:mod:`fogsim.eval.report.io`) and ``OUT/summary.md`` give, per figure
(:func:`fogsim.run.baseline.report_metrics`), its mean and its worst over the seeds. "Worst"
follows the figure's direction (:func:`fogsim.run.baseline.rule_for`): the largest error, the
smallest recall. A run is deterministic for its seed, so the same seeds give the same reports
bit for bit whatever the number of workers (timing and version fields aside). ``OUT`` is
written whole (:class:`~fogsim.run.run_folder.RunFolder`: a temporary folder renamed into place
with its ``manifest.json``), so it never mixes seeds of two runs; each seed's folder inside is
a run folder of its own.

The suite (:mod:`fogsim.run.suite`) runs its scenarios and seeds through the same
:func:`run_jobs`. With ``--ray ADDRESS`` the jobs run as tasks on a Ray cluster
(:mod:`fogsim.run.ray_cluster`): each writes its run into a scratch folder of its node and
returns the files, which the driver writes where the local run would have written them.
"""

from __future__ import annotations

import concurrent.futures
import dataclasses
import math
import multiprocessing
import os
import tempfile
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

from fogsim.atomic import OutputError, write_bytes_atomic, write_text_atomic
from fogsim.config import Scenario, resolve_params
from fogsim.errors import FogsimError
from fogsim.eval.report.io import write_json
from fogsim.run.baseline import NEVER_FRAMES, poor_reasons, report_metrics, rule_for
from fogsim.run.orphans import watch_driver
from fogsim.run.ray_cluster import RayCluster, check_ray_address
from fogsim.run.run_folder import RunFolder
from fogsim.run.runner import run_scenario, sensor_fields
from fogsim.run.seed_spec import format_seeds

MAX_WORKERS = 64
"""Most worker processes of ``--workers``. Each holds a MuJoCo model, an EGL context and the
mapper (about 0.6 GB measured on ``flat_floor`` with pictures): 64 of them need some 40 GB, the
most a machine with that many cores is likely to have; more processes than cores only slow
each other down."""

GROUP_ORDER = ("table1", "cells", "safety", "step_edges", "events", "timing")
"""Figure groups (the first part of a flat name) in the order the text shows them."""


@dataclass(frozen=True)
class SeedJob:
    """One run of a scenario at one seed, for a worker process.

    Attributes:
        scenario: The scenario with its seed (and every override) applied.
        out_dir: Folder of its ``report.json`` and pictures.
        report: Path of its ``report.json`` relative to the summary's folder.
        max_frames: Stop after this many frames (the suite's quick subset); None = all.
        pictures: Write the PNGs.
        video: Write ``run.mp4``.
        depth_backend: Simulation depth backend (``renderer`` or ``raycast``).
    """

    scenario: Scenario
    out_dir: Path
    report: str
    max_frames: int | None = None
    pictures: bool = True
    video: bool = False
    depth_backend: str = "renderer"


@dataclass(frozen=True)
class SeedRun:
    """One seed's run as a summary lists it.

    Attributes:
        seed: The scenario's seed.
        metrics: Its flat figures (:func:`fogsim.run.baseline.report_metrics`); empty if the
            run failed.
        frames: Frames run.
        wall_s: Wall time of the run [s].
        report: Path of its ``report.json`` relative to the summary's folder (None if failed).
        poor: Why its map is poor (the report's ``quality.reasons``); empty when it is not.
        error: Why the run failed (None if it worked).
    """

    seed: int
    metrics: dict[str, float]
    frames: int
    wall_s: float
    report: str | None
    poor: tuple[str, ...]
    error: str | None

    def status(self) -> str:
        """``ok``, ``poor: <reasons>`` or ``failed: <error>``."""
        if self.error is not None:
            return f"failed: {self.error}"
        if self.poor:
            return "poor: " + "; ".join(self.poor)
        return "ok"


def run_seed(job: SeedJob) -> SeedRun:
    """Run one job (in a worker process) and return its summary entry.

    Any exception becomes the entry's ``error``: one failing seed or scenario must not stop
    the others. An :class:`~fogsim.atomic.OutputError` (a full or read-only disk) is raised:
    the other runs would fail the same way.
    """
    start = time.perf_counter()
    try:
        report = run_scenario(
            job.scenario,
            job.out_dir,
            pictures=job.pictures,
            video=job.video,
            max_frames=job.max_frames,
            depth_backend=job.depth_backend,
        )
        return SeedRun(
            seed=job.scenario.seed,
            metrics=report_metrics(report),
            frames=report.timing.frames,
            wall_s=round(time.perf_counter() - start, 2),
            report=job.report,
            poor=poor_reasons(report),
            error=None,
        )
    except OutputError:
        raise
    except Exception as exc:  # reported in the summary; the other jobs go on
        return SeedRun(
            seed=job.scenario.seed,
            metrics={},
            frames=0,
            wall_s=round(time.perf_counter() - start, 2),
            report=None,
            poor=(),
            error=f"{type(exc).__name__}: {exc}",
        )


def check_workers(workers: int) -> None:
    """Raise :class:`FogsimError` unless ``1 <= workers <=`` :data:`MAX_WORKERS`."""
    if workers < 1:
        raise FogsimError(f"--workers must be >= 1, got {workers}")
    if workers > MAX_WORKERS:
        raise FogsimError(f"--workers must be <= {MAX_WORKERS}, got {workers}")


def run_jobs(
    jobs: Sequence[SeedJob], workers: int, ray_address: str | None = None
) -> list[SeedRun]:
    """Run jobs in ``workers`` processes (inline for one) or on Ray; results in the jobs' order.

    Args:
        jobs: The runs.
        workers: Parallel processes (not used with ``ray_address``: the cluster's CPUs are).
        ray_address: A Ray cluster (checked by :func:`fogsim.run.ray_cluster.check_ray_address`
            before); None = local processes.

    Raises:
        FogsimError: ``workers`` is out of range (:func:`check_workers`), Ray cannot join, or
            a worker process ended abruptly (killed from outside, out of memory).
        OutputError: A run cannot write its results; the jobs not yet started are cancelled.
    """
    check_workers(workers)
    if ray_address is not None:
        with RayCluster(ray_address) as cluster:
            outcomes = cluster.map(run_seed_elsewhere, [(job,) for job in jobs])
        for job, (_, files) in zip(jobs, outcomes, strict=True):
            for relative, data in files.items():
                write_bytes_atomic(job.out_dir / relative, data)
        return [run for run, _ in outcomes]
    if workers == 1:
        return [run_seed(job) for job in jobs]
    context = multiprocessing.get_context("spawn")  # MuJoCo/EGL state must not be forked
    # A killed driver's workers end themselves (`fogsim.run.orphans`): else they finish their
    # runs into a folder the next run removes as stale.
    with concurrent.futures.ProcessPoolExecutor(
        workers, mp_context=context, initializer=watch_driver, initargs=(os.getpid(),)
    ) as pool:
        futures = [pool.submit(run_seed, job) for job in jobs]
        try:
            return [future.result() for future in futures]
        except concurrent.futures.process.BrokenProcessPool as exc:
            pool.shutdown(cancel_futures=True)
            raise FogsimError(
                "a run's worker process ended abruptly (killed, or out of memory); "
                "the runs not finished are lost: run the command again"
            ) from exc
        except BaseException:
            pool.shutdown(cancel_futures=True)
            raise


def run_seed_elsewhere(job: SeedJob) -> tuple[SeedRun, dict[str, bytes]]:
    """:func:`run_seed` on another machine (a Ray task): into a scratch folder, returned as files.

    The driver's output folder may not exist on the node, so the run is written into a
    temporary folder of the node and every file of it (``report.json``, pictures,
    ``manifest.json``) comes back by its path relative to the run's folder.
    """
    with tempfile.TemporaryDirectory(prefix="fogsim-ray-") as scratch:
        folder = Path(scratch) / "run"
        run = run_seed(dataclasses.replace(job, out_dir=folder))
        files = {
            path.relative_to(folder).as_posix(): path.read_bytes()
            for path in sorted(folder.rglob("*"))
            if path.is_file()
        }
    return run, files


@dataclass(frozen=True)
class SeedValue:
    """A figure's value on one seed."""

    seed: int
    value: float


@dataclass(frozen=True)
class FigureStats:
    """One figure over the seeds that have it.

    Attributes:
        direction: ``lower`` or ``higher`` is better (:func:`fogsim.run.baseline.rule_for`).
        mean: Mean over the seeds (rounded to 6 decimals; an event that never clears counts
            as :data:`fogsim.run.baseline.NEVER_FRAMES`).
        worst: The worst value: the largest if lower is better, the smallest if higher is.
        worst_seed: The seed with the worst value (the lowest such seed on a tie).
        values: Every seed's value, worst first (ties by seed).
        missing: Seeds whose run worked but has no value for the figure (e.g. a Table I row
            without cells, an object never seen before its event).
    """

    direction: Literal["lower", "higher"]
    mean: float
    worst: float
    worst_seed: int
    values: tuple[SeedValue, ...]
    missing: tuple[int, ...]


def figure_stats(runs: Sequence[SeedRun]) -> dict[str, FigureStats]:
    """Each figure's mean and worst over the runs that worked (failed runs are left out).

    Returns:
        Flat figure name → its statistics, names sorted.
    """
    worked = [run for run in runs if run.error is None]
    names = sorted({name for run in worked for name in run.metrics})
    stats = {}
    for name in names:
        rule = rule_for(name)
        values = [SeedValue(run.seed, run.metrics[name]) for run in worked if name in run.metrics]
        sign = -1.0 if rule.direction == "lower" else 1.0
        ranked = tuple(sorted(values, key=lambda v: (sign * v.value, v.seed)))
        stats[name] = FigureStats(
            direction=rule.direction,
            mean=round(math.fsum(v.value for v in values) / len(values), 6),
            worst=ranked[0].value,
            worst_seed=ranked[0].seed,
            values=ranked,
            missing=tuple(run.seed for run in worked if name not in run.metrics),
        )
    return stats


@dataclass(frozen=True)
class SeedsSummary:
    """``summary.json`` of ``fogsim run SCENARIO --seeds``.

    Attributes:
        format: Always ``fogsim-seeds``.
        version: Schema version, 1.
        scenario: The scenario's name.
        seeds: The seeds run, canonical spec (``"1-8"``).
        workers: Parallel processes (not used when ``ray_address`` is set).
        wall_s: Wall time of all runs [s].
        runs: Each seed's run, in seed order.
        figures: Each figure's mean and worst over the seeds, names sorted.
        ray_address: The Ray cluster the seeds ran on (its CPUs, not ``workers``); None =
            local processes (and in summaries written before the field existed).
    """

    format: Literal["fogsim-seeds"]
    version: Literal[1]
    scenario: str
    seeds: str
    workers: int
    wall_s: float
    runs: tuple[SeedRun, ...]
    figures: dict[str, FigureStats]
    ray_address: str | None = None


def seed_jobs(
    scenario: Scenario,
    seeds: Sequence[int],
    out_dir: str | os.PathLike[str],
    *,
    prefix: str = "",
    max_frames: int | None = None,
    pictures: bool = True,
    video: bool = False,
    depth_backend: str = "renderer",
) -> list[SeedJob]:
    """One job per seed: the scenario with ``seed=<n>``, into ``out_dir/seed_<n>/``.

    Args:
        scenario: The scenario, every other override applied.
        seeds: The seeds.
        out_dir: The folder that holds the ``seed_<n>`` folders.
        prefix: Path of ``out_dir`` relative to the summary's folder (``""`` or ``"stage/"``).
        max_frames: Stop each run after this many frames (None = all).
        pictures: Write the PNGs.
        video: Write ``run.mp4``.
        depth_backend: Simulation depth backend.
    """
    return [
        SeedJob(
            scenario=scenario.with_overrides([f"seed={seed}"]),
            out_dir=Path(out_dir) / f"seed_{seed}",
            report=f"{prefix}seed_{seed}/report.json",
            max_frames=max_frames,
            pictures=pictures,
            video=video,
            depth_backend=depth_backend,
        )
        for seed in seeds
    ]


def run_seeds(
    scenario: Scenario,
    seeds: Sequence[int],
    out_dir: str | os.PathLike[str],
    *,
    workers: int = 2,
    pictures: bool = True,
    video: bool = False,
    depth_backend: str = "renderer",
    ray_address: str | None = None,
) -> SeedsSummary:
    """Run a scenario once per seed in parallel; write ``summary.json`` and ``summary.md``.

    Args:
        scenario: The scenario, overrides other than the seed applied.
        seeds: The seeds (from :func:`~fogsim.run.seed_spec.parse_seeds`).
        out_dir: Output folder: ``seed_<n>/`` per seed, and the summaries.
        workers: Parallel processes (1 = run inline).
        pictures: Write each seed's PNGs.
        video: Write each seed's ``run.mp4``.
        depth_backend: Simulation depth backend.
        ray_address: Run the seeds as tasks on this Ray cluster (:func:`run_jobs`); None =
            local processes.

    Raises:
        FogsimError: ``workers`` out of range, an invalid seed or invalid parameters, an
            invalid or unreachable ``ray_address`` (all before any run).
        OutputError: ``out_dir`` cannot be written (found before the runs) or writing failed.
    """
    resolve_params(scenario, sensor=sensor_fields(scenario))  # bad parameters fail here, once
    check_workers(workers)
    if ray_address is not None:
        check_ray_address(ray_address)
    with RunFolder(out_dir) as folder:
        jobs = seed_jobs(
            scenario,
            seeds,
            folder.path,
            pictures=pictures,
            video=video,
            depth_backend=depth_backend,
        )
        start = time.perf_counter()
        runs = run_jobs(jobs, workers, ray_address)
        summary = SeedsSummary(
            format="fogsim-seeds",
            version=1,
            scenario=scenario.name,
            seeds=format_seeds(seeds),
            workers=workers,
            wall_s=round(time.perf_counter() - start, 2),
            runs=tuple(runs),
            figures=figure_stats(runs),
            ray_address=ray_address,
        )
        write_json(folder.path / "summary.json", summary)
        write_text_atomic(folder.path / "summary.md", seeds_markdown(summary))
        folder.commit("seeds", scenario=scenario.name, seeds=summary.seeds)
    return summary


def format_value(value: float) -> str:
    """A figure's value for text: ``never`` for an event that never happened, 4 digits."""
    if value >= NEVER_FRAMES:
        return "never"
    return f"{value:.4g}" if math.isfinite(value) else "–"


def where_run(workers: int, ray_address: str | None) -> str:
    """Where the runs went, for the summaries: ``"2 workers"`` or ``"on Ray at ADDRESS"``."""
    return f"on Ray at {ray_address}" if ray_address is not None else f"{workers} workers"


def _group(name: str) -> str:
    return name.split(".", 1)[0]


def _label(name: str) -> str:
    """A figure's name within its group: ``table1.sill.abs_error_mm`` → ``sill``."""
    return name.split(".", 1)[1].removesuffix(".abs_error_mm")


def grouped(figures: Mapping[str, FigureStats]) -> dict[str, dict[str, FigureStats]]:
    """Figures by group (:data:`GROUP_ORDER` first, others after), names sorted in a group."""
    groups: dict[str, dict[str, FigureStats]] = {}
    order = {group: i for i, group in enumerate(GROUP_ORDER)}
    for name in sorted(figures, key=lambda n: (order.get(_group(n), len(order)), n)):
        groups.setdefault(_group(name), {})[name] = figures[name]
    return groups


def _mean_text(stats: FigureStats) -> str:
    """The mean, or how many seeds never got there when the mean counts a never."""
    nevers = sum(v.value >= NEVER_FRAMES for v in stats.values)
    if nevers:
        return f"never on {nevers} of {len(stats.values)}"
    return format_value(stats.mean)


def worst_lines(figures: Mapping[str, FigureStats]) -> list[str]:
    """One console line per figure group: each figure's worst value and seed, and its mean."""
    lines = []
    for group, members in grouped(figures).items():
        parts = [
            f"{_label(name)} {format_value(s.worst)} (seed {s.worst_seed}, mean {_mean_text(s)})"
            for name, s in members.items()
        ]
        lines.append(f"{group:<10} worst: " + ", ".join(parts))
    return lines


def figures_markdown(figures: Mapping[str, FigureStats]) -> list[str]:
    """Markdown tables of the figures, one per group: worst and its seed first, then the mean.

    With one seed per figure the table has one value column.
    """
    lines: list[str] = []
    single = all(len(s.values) == 1 and not s.missing for s in figures.values())
    for group, members in grouped(figures).items():
        lines += ["", f"### {group}", ""]
        if single:
            lines += ["| figure | better | value |", "|---|---|---:|"]
            lines += [
                f"| {_label(n)} | {s.direction} | {format_value(s.worst)} |"
                for n, s in members.items()
            ]
            continue
        lines += [
            "| figure | better | worst | seed | mean | seeds, worst first |",
            "|---|---|---:|---:|---:|---|",
        ]
        for name, s in members.items():
            values = ", ".join(f"{format_value(v.value)} ({v.seed})" for v in s.values)
            if s.missing:
                values += f"; none on {format_seeds(s.missing)}"
            lines.append(
                f"| {_label(name)} | {s.direction} | {format_value(s.worst)} | {s.worst_seed} "
                f"| {_mean_text(s)} | {values} |"
            )
    return lines


def runs_markdown(runs: Sequence[SeedRun]) -> list[str]:
    """The table of runs: seed, frames, wall time, status."""
    lines = ["| seed | frames | wall s | status |", "|---:|---:|---:|---|"]
    lines += [f"| {r.seed} | {r.frames} | {r.wall_s} | {r.status()} |" for r in runs]
    return lines


def seeds_markdown(summary: SeedsSummary) -> str:
    """``summary.md`` of a seeds run: the runs, then every figure's worst and mean."""
    lines = [
        f"# fogsim run {summary.scenario}, seeds {summary.seeds}",
        "",
        f"{len(summary.runs)} seeds, {where_run(summary.workers, summary.ray_address)}, "
        f"{summary.wall_s} s wall. "
        "Worst = the largest error, the smallest recall or precision; each seed's report is "
        "in `seed_<n>/report.json`.",
        "",
        *runs_markdown(summary.runs),
        *figures_markdown(summary.figures),
    ]
    return "\n".join(lines) + "\n"
