"""Accuracy targets: absolute bounds on a suite's figures, checked after its runs.

A baseline (:mod:`fogsim.run.baseline`) asks whether a figure got *worse* than it was; a
targets file asks whether it is *good enough*: every Table I row within 1.5 mm on every seed,
floor precision at least 99.5 %, no unsafe cell on the stage. ``scenarios/targets.toml`` holds
issue 11's acceptance targets for the depth-mode suite over seeds 1–8;
``fogsim suite ... --targets FILE`` checks them after the runs (``summary.md`` gets a Targets
section, every missed target is printed, the exit code is 1), ``fogsim targets DIR --targets
FILE`` checks a finished suite's ``summary.json`` again (another file, no runs).

The file (TOML)::

    format = "fogsim-targets"
    version = 1

    [[target]]
    figure = "table1.*.abs_error_mm"   # a pattern over the summary's flat figure names
    worst = 1.5                        # the worst seed's value: at most this (lower is better)
    mean = 0.7                         # and the mean over the seeds
    scenarios = ["*"]                  # patterns over scenario names (default: all)
    why = "every Table I row within 1.5 mm on every seed, 0.7 mm on average"

Patterns are shell-style (:func:`fnmatch.fnmatchcase`; ``*`` also matches dots). Whether a
bound is an upper or a lower one is the figure's own direction (:func:`fogsim.run.baseline.
rule_for`): an error or a count must not exceed it, a recall or precision must not fall below.
``timing.*`` figures cannot be targets: speed is measured in ``bench/``, never asserted (a
loaded machine would miss it).

What counts as missed: a bound the figure's statistic does not meet; a scenario a target
applies to that failed (no figures to check); a target that matches no figure of any scenario
it applies to that ran (a misspelt pattern passes nothing). A target that applies to no
scenario of the suite (the stage's, in the held-out suite) is not checked. A figure some seeds
lack (a Table I row without cells on a seed) is checked over the seeds that have it, and the
result says which seeds lack it.
"""

from __future__ import annotations

import fnmatch
import math
import os
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

from fogsim.config.decode import decode
from fogsim.errors import ScenarioError, TargetsError
from fogsim.run.seeds import GROUP_ORDER, FigureStats, SeedRun, SeedsSummary, format_value

_CHECKABLE_GROUPS = tuple(group for group in (*GROUP_ORDER, "pose_error") if group != "timing")
"""First segments of the figure names a target may name (every group but ``timing``)."""


@dataclass(frozen=True)
class Target:
    """One bound on the figures whose names match ``figure``.

    Attributes:
        figure: Shell-style pattern over flat figure names (``table1.*.abs_error_mm``).
        worst: Bound on the worst seed's value (None: not bounded).
        mean: Bound on the mean over the seeds (None: not bounded).
        scenarios: Patterns over the scenario names it applies to.
        why: What the target stands for, shown beside every result.
    """

    figure: str
    worst: float | None = None
    mean: float | None = None
    scenarios: tuple[str, ...] = ("*",)
    why: str = ""

    def bounds(self) -> list[tuple[Literal["worst", "mean"], float]]:
        """The bounded statistics and their bounds, worst first."""
        pairs: list[tuple[Literal["worst", "mean"], float | None]] = [
            ("worst", self.worst),
            ("mean", self.mean),
        ]
        return [(name, bound) for name, bound in pairs if bound is not None]

    def applies_to(self, scenario: str) -> bool:
        """Whether one of its scenario patterns matches ``scenario``."""
        return any(fnmatch.fnmatchcase(scenario, pattern) for pattern in self.scenarios)


@dataclass(frozen=True)
class Targets:
    """A targets file (module doc).

    Attributes:
        format: Always ``fogsim-targets``.
        version: Schema version, 1.
        target: The targets, in the file's order.
    """

    format: Literal["fogsim-targets"]
    version: Literal[1]
    target: tuple[Target, ...]


@dataclass(frozen=True)
class TargetResult:
    """One statistic of one figure of one scenario against its bound.

    Attributes:
        scenario: The scenario's name.
        figure: The figure's flat name (None: the target matched no figure, or the scenario
            failed before it had any).
        statistic: ``worst`` or ``mean``.
        value: The statistic (NaN when there is no figure).
        bound: The target's bound.
        direction: ``lower``: the value must be at most the bound; ``higher``: at least.
        met: Whether it holds.
        worst_seed: The seed of the worst value (None without a figure).
        missing_seeds: Seeds whose run has no value for the figure.
        why: The target's ``why``, or why nothing could be checked.
    """

    scenario: str
    figure: str | None
    statistic: Literal["worst", "mean"]
    value: float
    bound: float
    direction: Literal["lower", "higher"] | None
    met: bool
    worst_seed: int | None
    missing_seeds: tuple[int, ...]
    why: str

    def line(self) -> str:
        """One line for standard error: ``stage: table1.sill.abs_error_mm worst 1.6 > 1.5``."""
        if self.figure is None:
            return f"{self.scenario}: {self.why}"
        relations = {"lower": ("<=", ">"), "higher": (">=", "<")}
        relation = relations[self.direction or "lower"][0 if self.met else 1]
        why = f" — {self.why}" if self.why else ""
        return (
            f"{self.scenario}: {self.figure} {self.statistic} {format_value(self.value)}"
            f"{self.seed_note()} {relation} {format_value(self.bound)}{self.missing_note()}{why}"
        )

    def seed_note(self) -> str:
        """`` (seed 3)`` after a worst value; empty for a mean."""
        return f" (seed {self.worst_seed})" if self.statistic == "worst" and self.worst_seed else ""

    def missing_note(self) -> str:
        """``, no value on seeds 2, 5`` when some seeds lack the figure; else empty."""
        if not self.missing_seeds:
            return ""
        return ", no value on seeds " + ", ".join(str(seed) for seed in self.missing_seeds)


def load_targets(path: str | os.PathLike[str]) -> Targets:
    """Read and check a targets file.

    Raises:
        TargetsError: The file is missing or not TOML, a key is unknown or mistyped (the
            message names it and what is allowed), a target bounds nothing, names a
            ``timing`` figure or a figure group that does not exist, or a bound is not finite.
    """
    try:
        data = tomllib.loads(Path(path).read_text(encoding="utf-8"))
    except OSError as exc:
        raise TargetsError(f"cannot read targets {path}: {exc}") from exc
    except tomllib.TOMLDecodeError as exc:
        raise TargetsError(f"targets {path} is not valid TOML: {exc}") from exc
    try:
        targets = decode(data, Targets, str(path))
    except ScenarioError as exc:  # the decoder's message names the key and what is allowed
        raise TargetsError(f"targets {exc}") from exc
    for index, target in enumerate(targets.target):
        where = f"{path}: target[{index}] ({target.figure!r})"
        if not target.bounds():
            raise TargetsError(f"{where}: bounds nothing; give worst = ..., mean = ... or both")
        group = target.figure.split(".", 1)[0]
        if group == "timing":
            raise TargetsError(
                f"{where}: timing figures cannot be targets (speed is measured in bench/, "
                "never asserted: a loaded machine would miss it)"
            )
        if not any(fnmatch.fnmatchcase(name, group) for name in _CHECKABLE_GROUPS):
            raise TargetsError(
                f"{where}: no figure group {group!r}; groups: {', '.join(_CHECKABLE_GROUPS)}"
            )
        for statistic, bound in target.bounds():
            if not math.isfinite(bound):
                raise TargetsError(f"{where}: {statistic} must be a finite number, got {bound}")
        if not target.scenarios:
            raise TargetsError(f"{where}: scenarios is empty; give at least one pattern ('*')")
    return targets


def check_targets(
    figures_by_scenario: Mapping[str, Mapping[str, FigureStats]],
    failed: Mapping[str, Sequence[str]],
    targets: Targets,
) -> list[TargetResult]:
    """Every target against every scenario it applies to; missed results first.

    Args:
        figures_by_scenario: Scenario name → its figures (a suite's, in its order).
        failed: Scenario name → why it failed (those are not checked: each target that applies
            to one is missed, with the reason).
        targets: The targets.

    Returns:
        One result per (scenario, matching figure, bounded statistic), plus one missed result
        per target that applies to a scenario but matched no figure; none for a target that
        applies to no scenario; missed first, then in the suite's and the file's order.
    """
    results: list[TargetResult] = []
    for target in targets.target:
        matched = applied = False
        for scenario, figures in figures_by_scenario.items():
            if not target.applies_to(scenario):
                continue
            applied = True
            if scenario in failed:  # no figures: missed, but it matches nothing either
                reason = "; ".join(failed[scenario])
                for statistic, bound in target.bounds():
                    results.append(
                        _unchecked(scenario, statistic, bound, f"{target.figure}: failed: {reason}")
                    )
                continue
            for name in sorted(n for n in figures if fnmatch.fnmatchcase(n, target.figure)):
                matched = True
                results += _figure_results(target, scenario, name, figures[name])
        if applied and not matched:
            for statistic, bound in target.bounds():
                results.append(
                    _unchecked(
                        "(every scenario)",
                        statistic,
                        bound,
                        f"target {target.figure!r} (scenarios {', '.join(target.scenarios)}) "
                        "matched no figure",
                    )
                )
    return sorted(results, key=lambda result: result.met)  # stable: the order within kept


def _figure_results(
    target: Target, scenario: str, name: str, stats: FigureStats
) -> list[TargetResult]:
    """One figure's bounded statistics against the target's bounds."""
    results = []
    for statistic, bound in target.bounds():
        value = stats.worst if statistic == "worst" else stats.mean
        met = value <= bound if stats.direction == "lower" else value >= bound
        results.append(
            TargetResult(
                scenario=scenario,
                figure=name,
                statistic=statistic,
                value=value,
                bound=bound,
                direction=stats.direction,
                met=bool(met),
                worst_seed=stats.worst_seed,
                missing_seeds=stats.missing,
                why=target.why,
            )
        )
    return results


def run_failures(error: str | None, runs: Sequence[SeedRun]) -> list[str]:
    """Why a scenario's figures are not checked: it was not loaded or a run raised (else empty).

    A scenario one of whose runs raised has figures over fewer seeds: not checked, each target
    that applies to it missed. A poor run's figures are checked (the suite fails it anyway).
    """
    if error is not None:
        return [error]
    return [f"seed {run.seed}: failed: {run.error}" for run in runs if run.error is not None]


def check_seeds_targets(summary: SeedsSummary, targets: Targets) -> list[TargetResult]:
    """The figures of ``fogsim run SCENARIO --seeds`` against the targets (:func:`check_targets`).

    The run is checked as a suite of one scenario; a seed that raised leaves it unchecked.
    """
    failed = run_failures(None, summary.runs)
    return check_targets(
        {summary.scenario: summary.figures},
        {summary.scenario: failed} if failed else {},
        targets,
    )


def scenario_counts(results: Sequence[TargetResult]) -> list[tuple[str, int, int]]:
    """Per scenario ``(name, checks met, checks)``, the most missed first (ties: first seen)."""
    counts: dict[str, list[int]] = {}
    for result in results:
        met_total = counts.setdefault(result.scenario, [0, 0])
        met_total[0] += result.met
        met_total[1] += 1
    order = sorted(counts.items(), key=lambda item: item[1][0] - item[1][1])  # stable
    return [(name, met, total) for name, (met, total) in order]


def missed_summary(results: Sequence[TargetResult]) -> str:
    """One line: the scenarios with missed checks, most first (``stairs 2 of 25 missed; ...``)."""
    missing = [
        f"{name} {total - met} of {total} missed"
        for name, met, total in scenario_counts(results)
        if met < total
    ]
    return "; ".join(missing) if missing else "every check met"


def targets_markdown(results: Sequence[TargetResult]) -> list[str]:
    """The Targets section's lines: a count, each scenario's count, every check (missed first)."""
    missed = sum(not result.met for result in results)
    lines = [f"{len(results) - missed} of {len(results)} checks met, {missed} missed.", ""]
    if not results:
        return lines
    lines += ["| scenario | checks met | missed |", "|---|---:|---:|"]
    lines += [
        f"| {name} | {met} of {total} | {total - met} |"
        for name, met, total in scenario_counts(results)
    ]
    lines += [
        "",
        "| scenario | figure | statistic | value | target | met | why |",
        "|---|---|---|---:|---:|---|---|",
    ]
    for r in results:
        bound = format_value(r.bound)
        if r.figure is None:
            lines.append(f"| {r.scenario} | — | {r.statistic} | — | {bound} | **no** | {r.why} |")
            continue
        relation = "≤" if r.direction == "lower" else "≥"
        lines.append(
            f"| {r.scenario} | {r.figure} | {r.statistic} | {format_value(r.value)}"
            f"{r.seed_note()} | {relation} {bound} | {'yes' if r.met else '**no**'} | "
            f"{r.why}{r.missing_note()} |"
        )
    return lines


def _unchecked(
    scenario: str, statistic: Literal["worst", "mean"], bound: float, why: str
) -> TargetResult:
    """A missed result with no figure behind it (a failed scenario, an unmatched target)."""
    return TargetResult(
        scenario=scenario,
        figure=None,
        statistic=statistic,
        value=math.nan,
        bound=bound,
        direction=None,
        met=False,
        worst_seed=None,
        missing_seeds=(),
        why=why,
    )
