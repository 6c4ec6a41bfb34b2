"""Regression figures of a report, their tolerance rules, and the committed ``baseline.json``.

Figures (flat names, one value per run; ``direction`` says which way is better):

============================================  =========  ===========  =========================
figure                                        direction  tolerance    meaning
============================================  =========  ===========  =========================
``table1.<surface>.abs_error_mm``             lower      1.0 mm       FOG Table I row error
``table1.<surface>.coverage``                 higher     0.05         fraction of the row's
                                                                      interior cells the FOG
                                                                      has a floor height in
``cells.floor_recall``                        higher     0.01         true floor cells seen and
                                                                      labelled floor
``cells.floor_precision``                     higher     0.01         FOG floor cells that are
                                                                      true floor
``cells.obstacle_recall``                     higher     0.05         true obstacle cells seen
                                                                      and labelled obstacle
``cells.obstacle_precision``                  higher     0.05         FOG obstacle cells that
                                                                      are true obstacle
``safety.unsafe_cells``                       lower      3 cells      floor on a true obstacle
                                              + 10 %                  or > 20 mm off
``step_edges.<surface>.<edge>.abs_error_mm``  lower      20 mm        |median position error|
                                                                      of a walkable edge
``step_edges.<surface>.<edge>.nearest_abs_``  lower      20 mm        |median error| of the
``error_mm``                                                          edge nearest the truth
                                                                      that the map allows
``step_edges.<surface>.<edge>.gap_mm``        lower      20 mm        median width of the band
                                                                      left undecided at it
``events.<object>.cleared_frames``            lower      3 frames     until no footprint cell
                                                                      shows the object
``events.<object>.floor_again_frames``        lower      3 frames     until ≥ 90 % of it is
                                                                      floor within 10 mm
``pose_error.residual_heading_deg.median``    lower      0.25°        median |yaw| of the
                                                                      corrected camera
``pose_error.map_heading_deg.median``         lower      0.25°        the same as the frames
                                                                      were last mapped
``pose_error.world_heading_deg.median``       lower      0.25°        the same in the world
                                                                      (with odometry's yaw)
``pose_error.residual_tilt_deg.median``      lower      0.05°        median tilt left by the
                                                                      corrections (as mapped)
``pose_error.residual_tilt_deg.p95``         lower      0.1°         its 95th percentile
``timing.frame_ms_median``                    lower      not checked  pipeline time per frame
============================================  =========  ===========  =========================

Why these tolerances. A run is deterministic for its seed, so the tolerance is not noise
between runs: it is how far a harmless change (a refactoring, another platform's floating
point) may move a figure before the check calls it a regression.

* Table I rows are medians over about a hundred cells of smoothed heights: a millimetre is
  below the paper's own Table I resolution (its rows differ by 1–4 mm) and above rounding.
* A Table I row's coverage says how many cells its error stands on (a row measured on 1 of
  50 cells is one cell's height): 0.05 is a few cells of a step, flagging a surface the map
  lost.
* Floor classes hold thousands of seen cells on the stage, so 0.01 is tens of cells; obstacle
  classes hold 50–100 seen cells (the stage's boxes), so one cell is 1–2 % and 0.05 lets
  two or three cells flip, no more.
* Unsafe cells are counts from a handful to hundreds: 3 cells absorb a cell or two flipping at
  an object's border, 10 % of the baseline scales that for scenes with many.
* A mapped edge sits on a cell border, so its median position error moves in steps of half
  a cell (the median of an even count averages two cells): 20 mm, half the 40 mm cell, lets one
  such step through and flags an edge moved by a whole cell.
* Event frames are counted at 12.5 Hz: 3 frames (0.24 s) is one odd frame (a withdrawn frame,
  a late ray) at either end of the count; a footprint that never clears or never becomes
  floor again counts as :data:`NEVER_FRAMES`.
* The residual heading is a median over hundreds of frames: a harmless change moves it by
  hundredths of a degree; 0.25° (4 mm sideways at 1 m) flags a heading estimate that changed.
* The residual tilt moves every point's height by its range times the angle: 0.05° is 1.7 mm
  at 2 m, the Table I tolerance at the far end of the view, against the hundredths of a degree
  a harmless change moves a median over hundreds of frames by; its 95th percentile stands on
  a few tens of frames, so 0.1°: a run of wrongly tilted frames (what it is there to show)
  moves it by half a degree and more.
* Frame times are wall-clock: reported in the summary, never checked (a loaded machine would
  fail the check; speed is measured in ``bench/``).

An event whose object the map never saw before its event has no figure (the report says
``seen: false``): it is left out, and a baseline that has it reports it missing.

``baseline.json`` (version 2) holds figure **sets**: one per way the suite ran (quick or full,
over which seeds, with which ``--set`` overrides), named by :func:`set_name` (``"full seeds=1-8"``,
``"full seeds=1-8 set=camera.mode=stereo"``, ``"quick seeds=scenario"``
for each scenario's own seed). Each set maps a scenario to its figures, each figure to its
``mean`` and ``worst`` over the set's seeds::

    {"format": "fogsim-baseline", "version": 2,
     "sets": {"full seeds=1-8": {"stage": {"figures": {
         "table1.sill.abs_error_mm": {"mean": 1.9, "worst": 4.7}, ...}}}}}

Keys are sorted so that a rewrite shows as a small diff. Version 1 files (one value per figure,
``scenarios`` and ``quick_scenarios``) scored the truth before per-object figures existed and
use figure names that no longer exist: they are not converted. The loader names the version and
the command that writes a new one; ``--write-baseline`` replaces such a file with a new
baseline holding the set it wrote.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

from msgspec import UnsetType

from fogsim.config.overrides import canonical_key
from fogsim.errors import FogsimError, ReportError
from fogsim.eval.report import Report
from fogsim.eval.report.io import load_json, write_json

NEVER_FRAMES = 1_000_000.0
"""The event figure of a footprint that never clears (or never becomes floor again)."""

BASELINE_VERSION = 2

REGENERATE = "fogsim suite [--quick] [--seeds 1-8] --out DIR --write-baseline {path}"
"""The command that writes a set of a baseline (``{path}``: the file)."""


@dataclass(frozen=True)
class MetricRule:
    """How a figure may change.

    Attributes:
        direction: ``"lower"`` or ``"higher"`` is better.
        absolute: Allowed slack in the figure's unit.
        relative: Further slack as a fraction of ``|baseline|``.
        checked: Whether ``--check`` compares it (wall-clock figures are reported, not checked:
            speed is measured in ``bench/``, never asserted, since a loaded machine fails it).
    """

    direction: Literal["lower", "higher"]
    absolute: float
    relative: float = 0.0
    checked: bool = True

    def worse_by(self, current: float, baseline: float) -> float:
        """How much worse ``current`` is than ``baseline`` beyond the tolerance (> 0 = fail)."""
        change = current - baseline if self.direction == "lower" else baseline - current
        return change - (self.absolute + self.relative * abs(baseline))


def rule_for(metric: str) -> MetricRule:
    """The tolerance rule of a figure name (see the module table)."""
    if metric.startswith("table1.") and metric.endswith(".coverage"):
        return MetricRule("higher", 0.05)
    if metric.startswith("table1."):
        return MetricRule("lower", 1.0)
    if metric in ("cells.floor_recall", "cells.floor_precision"):
        return MetricRule("higher", 0.01)
    if metric in ("cells.obstacle_recall", "cells.obstacle_precision"):
        return MetricRule("higher", 0.05)
    if metric == "safety.unsafe_cells":
        return MetricRule("lower", 3.0, 0.1)
    if metric.startswith("step_edges."):
        return MetricRule("lower", 20.0)
    if metric.endswith((".cleared_frames", ".floor_again_frames")):
        return MetricRule("lower", 3.0)
    if metric in (
        "pose_error.residual_heading_deg.median",
        "pose_error.map_heading_deg.median",
        "pose_error.world_heading_deg.median",
    ):
        return MetricRule("lower", 0.25)
    if metric == "pose_error.residual_tilt_deg.median":
        return MetricRule("lower", 0.05)
    if metric == "pose_error.residual_tilt_deg.p95":
        return MetricRule("lower", 0.1)
    if metric.startswith("timing."):
        return MetricRule("lower", 5.0, 1.0, checked=False)
    raise FogsimError(f"no tolerance rule for figure {metric!r}")


def _frames(frames: int | None) -> float:
    """An event figure: the frame count, or :data:`NEVER_FRAMES` for never."""
    return NEVER_FRAMES if frames is None else float(frames)


def report_metrics(report: Report) -> dict[str, float]:
    """The flat figures of one report (see the module table).

    Figures the report has no value for (a Table I row without cells, a class no cell of which
    was seen, an edge not in view, an event whose object was never seen) are left out.
    """
    metrics: dict[str, float] = {}
    if report.table1 is not None:
        for row in report.table1.fog:
            if row.error_mm is not None:
                metrics[f"table1.{row.name}.abs_error_mm"] = abs(float(row.error_mm))
            if row.surface_cells:
                metrics[f"table1.{row.name}.coverage"] = row.cells / row.surface_cells
    if report.cells is not None:
        classes = report.cells.fog.classes
        for label, scores in (("floor", classes.floor), ("obstacle", classes.obstacle)):
            if scores.recall is not None:
                metrics[f"cells.{label}_recall"] = float(scores.recall)
            if scores.precision is not None:
                metrics[f"cells.{label}_precision"] = float(scores.precision)
    if report.safety is not None:
        metrics["safety.unsafe_cells"] = float(report.safety.unsafe_cells)
    for edge in report.step_edges:
        name = f"step_edges.{edge.surface}.{edge.edge}"
        if edge.median_error_mm is not None:
            metrics[f"{name}.abs_error_mm"] = abs(float(edge.median_error_mm))
        if isinstance(edge.median_nearest_error_mm, float):
            metrics[f"{name}.nearest_abs_error_mm"] = abs(edge.median_nearest_error_mm)
        if isinstance(edge.median_gap_mm, float):
            metrics[f"{name}.gap_mm"] = edge.median_gap_mm
    for event in report.events:
        if event.seen.fog:
            metrics[f"events.{event.object}.cleared_frames"] = _frames(event.cleared_frames.fog)
            metrics[f"events.{event.object}.floor_again_frames"] = _frames(
                event.floor_again_frames.fog
            )
    for key in ("residual_heading_deg", "map_heading_deg", "world_heading_deg"):
        residual = getattr(report.pose_error, key)
        if not isinstance(residual, UnsetType) and residual.median is not None:
            metrics[f"pose_error.{key}.median"] = float(residual.median)
    tilt = report.pose_error.residual_tilt_deg
    if not isinstance(tilt, UnsetType):
        if tilt.median is not None:
            metrics["pose_error.residual_tilt_deg.median"] = float(tilt.median)
        if tilt.p95 is not None:
            metrics["pose_error.residual_tilt_deg.p95"] = float(tilt.p95)
    median = report.timing.frame_ms.median
    if median is not None:
        metrics["timing.frame_ms_median"] = float(median)
    return metrics


def poor_reasons(report: Report) -> tuple[str, ...]:
    """Why the report's map is poor (``quality.reasons``), empty when it is not."""
    return report.quality.reasons if report.quality.poor else ()


@dataclass(frozen=True)
class BaselineFigure:
    """One figure of a scenario over a set of seeds.

    Attributes:
        mean: Mean over the seeds.
        worst: Worst over the seeds (the largest of a lower-is-better figure, the smallest of a
            higher-is-better one); equal to ``mean`` for one seed.
    """

    mean: float
    worst: float


@dataclass(frozen=True)
class BaselineEntry:
    """The committed figures of one scenario, by flat name."""

    figures: dict[str, BaselineFigure]


@dataclass(frozen=True)
class Baseline:
    """``baseline.json``: the figures a run is checked against.

    Attributes:
        format: Always ``fogsim-baseline``.
        version: Schema version, 2.
        sets: Set name (:func:`set_name`) → scenario name → its figures.
    """

    format: Literal["fogsim-baseline"] = "fogsim-baseline"
    version: Literal[2] = 2
    sets: dict[str, dict[str, BaselineEntry]] = field(default_factory=dict)


@dataclass(frozen=True)
class _EntryV1:
    """A scenario of a version-1 baseline (recognised only to say it is not converted)."""

    metrics: dict[str, float]


@dataclass(frozen=True)
class _BaselineV1:
    """A version-1 ``baseline.json``: one value per figure, a full and a quick section."""

    format: Literal["fogsim-baseline"]
    version: Literal[1]
    quick_scenarios: dict[str, _EntryV1] | None = None
    scenarios: dict[str, _EntryV1] | None = None


def set_name(quick: bool, seeds: str | None, overrides: Sequence[str] = ()) -> str:
    """The baseline set of a run: ``"<quick|full> seeds=<spec>[ set=<key=value,...>]"``.

    A suite run with ``--set`` overrides is another kind of run (``--set camera.mode=stereo``
    scores the stereo head): its figures are checked against, and written to, a set of their
    own, never the plain run's.

    Args:
        quick: The quick subset ran.
        seeds: The seeds in canonical form (:func:`fogsim.run.seed_spec.format_seeds`, e.g.
            ``"1-8"``), or None when each scenario ran at its own seed (``seeds=scenario``).
        overrides: The ``key=value`` assignments applied to every scenario; named sorted, with
            the blanks around ``=`` removed and a short prefix spelt as its table
            (`fogsim.config.overrides.canonical_key`: ``head.x`` is ``heading.x``), so neither
            their order nor their spelling on the command line matters.
    """
    name = f"{'quick' if quick else 'full'} seeds={seeds if seeds is not None else 'scenario'}"
    if overrides:
        canonical = sorted(
            canonical_key(key) + "=" + value.strip()
            for key, _, value in (o.partition("=") for o in overrides)
        )
        name += " set=" + ",".join(canonical)
    return name


def check_figures(
    name: str, current: Mapping[str, BaselineFigure], baseline: BaselineEntry, *, worst: bool
) -> list[str]:
    """Every figure of one scenario worse than its baseline beyond its tolerance, or missing.

    Args:
        name: The scenario (for the messages).
        current: Its figures now.
        baseline: Its committed figures.
        worst: Compare the worst over the seeds too (not for one seed: it equals the mean).

    Returns:
        Human-readable lines, empty if nothing got worse.
    """
    problems = []
    for metric, base in baseline.figures.items():
        now = current.get(metric)
        if now is None:
            problems.append(f"{name}: {metric} missing (baseline mean {base.mean:g})")
            continue
        rule = rule_for(metric)
        if not rule.checked:
            continue
        pairs = [("mean", now.mean, base.mean)]
        if worst:
            pairs.append(("worst", now.worst, base.worst))
        for which, value, reference in pairs:
            if rule.worse_by(value, reference) > 1e-9:
                problems.append(
                    f"{name}: {metric} {which} got worse: {value:g} vs baseline {reference:g} "
                    f"({rule.direction} is better, tolerance {rule.absolute:g}"
                    + (f" + {rule.relative:g}×baseline" if rule.relative else "")
                    + ")"
                )
    return problems


def _is_version_1(path: str | os.PathLike[str]) -> bool:
    """Whether the file is a readable version-1 baseline."""
    try:
        load_json(path, _BaselineV1, "baseline")
    except ReportError:
        return False
    return True


def load_baseline(path: str | os.PathLike[str]) -> Baseline:
    """Read ``baseline.json``.

    Raises:
        ReportError: The file is missing or does not match the schema (the message names the
            key), or it is a version-1 baseline (the message says how to write a new one).
    """
    try:
        return load_json(path, Baseline, "baseline")
    except ReportError:
        if not _is_version_1(path):
            raise
    raise ReportError(
        f"baseline {path} is version 1 (one value per figure, scored against the truth before "
        f"per-seed figures); it is not converted: write a version {BASELINE_VERSION} baseline "
        f"with `{REGENERATE.format(path=path)}`"
    )


def baseline_to_update(path: str | os.PathLike[str]) -> Baseline:
    """The baseline that ``--write-baseline`` adds its set to.

    The file's baseline; a new, empty one when the file does not exist or is a version-1
    baseline (every figure of which is stale, see the module docstring).

    Raises:
        ReportError: The file exists but is neither a version-1 nor a valid baseline.
    """
    if not Path(path).exists() or _is_version_1(path):
        return Baseline()
    return load_baseline(path)


def write_baseline(path: str | os.PathLike[str], baseline: Baseline) -> Path:
    """Write ``baseline.json`` with sorted keys, atomically."""
    return write_json(path, baseline, sort_keys=True)
