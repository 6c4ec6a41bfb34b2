"""The tuning objective: one number (lower is better) from the report of a replayed run.

``fogsim tune`` scores a parameter set by replaying every recording of a suite with those
parameters (:func:`fogsim.run.runner.replay_report`) and reducing each report to these terms:

* ``table1_mm`` -- mean absolute Table I error of the FOG over the walkable surfaces and the
  ground [mm]; a row the FOG never estimated is charged ``missing_row_mm``;
* ``cell_error_pct`` -- share of the seen cells labelled wrong (floor vs obstacle) [%];
* ``unknown_pct`` -- share of the cells *in view* (a depth measurement fell into them, placed
  with the true camera pose) that the FOG left unknown [%], so that labelling fewer cells does
  not pass for accuracy. Cells the camera never saw do not count: over the whole scored area
  (every cell ever in the robot-centred grid) about 88 % stay unknown whatever the parameters,
  which made this term 95 % of the quick subset's objective;
* ``obstacle_missed_pct`` -- ``100 − obstacle recall`` [%]: the share of the seen true obstacle
  cells the FOG does not label obstacle; 100 when it leaves every true obstacle cell unknown
  (no recall), no term when the scored area holds no true obstacle;
* ``unsafe_cells`` -- FOG floor cells where the truth is obstacle or the floor is more than
  20 mm off (``safety.unsafe_cells``);
* ``clearing_s`` -- mean time until a removed or moved object's footprint is cleared (the
  report's ``cleared_frames``: no cell shows the object) [s]; a footprint that never clears is
  charged ``never_cleared_s``, and so is an object the FOG never saw before its event (no
  figure: not seeing it is no better). Recordings without events contribute no clearing term.

The objective of one recording is the sum of each term times its weight (a term a recording
does not have adds nothing); a trial's objective is the mean over the suite's recordings. The
default weights are in :class:`ObjectiveWeights`.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, fields

from fogsim.data.recording import Recording
from fogsim.errors import TuneError
from fogsim.eval.report import Report

ReportFunction = Callable[[Recording, Mapping[str, float]], Report]
"""``(recording, overrides) -> report``; :func:`fogsim.run.runner.replay_report`."""

TermValue = float | int | None
"""One objective term as the trial stores it (JSON-able for Optuna's user attributes)."""

TERM_NAMES = (
    "table1_mm",
    "cell_error_pct",
    "unknown_pct",
    "obstacle_missed_pct",
    "unsafe_cells",
    "clearing_s",
)
"""The weighted terms, in the order ``trials.md`` shows them (each has a weight of that name)."""


@dataclass(frozen=True)
class ObjectiveWeights:
    """Weights and penalties of the tuning objective (see the module docstring).

    With the defaults one millimetre of Table I error, one percent of wrong cells, ten percent
    of the cells in view left unknown, twenty percent of the seen obstacle cells missed, a
    hundred unsafe cells (0.16 m² of floor) and one second of clearing time cost the same. An
    unknown cell is safe (a planner avoids it), a wrong one is not, hence the tenth. Measured
    with the default parameters (the truth by the paper's definitions):

    * the quick subset, replayed (flat_floor, box_removal; 80 frames): over the whole scored
      area 87 % / 89 % of the cells stay unknown, 8.7 of 8.7 and 8.9 of 9.8 (95 % of the
      objective) with the former formula; over the cells in view 1.1 % / 1.0 %, 0.11 of 0.13
      and 0.10 of 1.02 now, where box_removal's 0.88 s of clearing is the term that moves;
    * the stage (depth, seed 1, the route that sees every box): Table I 1.0 mm, wrong cells
      2.5 %, unknown in view 9.2 %, obstacles missed 49 % (riser cells included), 349 unsafe
      cells: terms of 1.0, 2.5, 0.9, 2.5 and 3.5 of 10.3, none above a third.

    Attributes:
        table1_mm: Weight per millimetre of mean absolute Table I error.
        cell_error_pct: Weight per percent of seen cells labelled wrong.
        unknown_pct: Weight per percent of the cells in view left unknown (keeps the search
            from buying accuracy by labelling less).
        obstacle_missed_pct: Weight per percent of the seen obstacle cells not labelled
            obstacle.
        unsafe_cells: Weight per unsafe cell (floor on an obstacle, or floor > 20 mm off).
        clearing_s: Weight per second of event clearing time.
        missing_row_mm: Error charged for a Table I row without an estimate [mm].
        never_cleared_s: Clearing time charged when a footprint never clears [s].
    """

    table1_mm: float = 1.0
    cell_error_pct: float = 1.0
    unknown_pct: float = 0.1
    obstacle_missed_pct: float = 0.05
    unsafe_cells: float = 0.01
    clearing_s: float = 1.0
    missing_row_mm: float = 50.0
    never_cleared_s: float = 10.0

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise TuneError(f"objective weight {f.name} must be a number, got {value!r}")
            if not math.isfinite(value) or value < 0:
                raise TuneError(f"objective weight {f.name} must be finite and >= 0, got {value!r}")
        if all(getattr(self, name) == 0 for name in TERM_NAMES):
            raise TuneError(
                f"objective weights {', '.join(TERM_NAMES)} are all 0; at least one must be > 0"
            )

    @classmethod
    def from_assignments(cls, assignments: Sequence[str]) -> ObjectiveWeights:
        """Weights from ``name=value`` strings (``--weight table1_mm=2``), defaults otherwise.

        Raises:
            TuneError: a malformed assignment, an unknown name (the message lists the
                allowed ones) or an invalid value.
        """
        allowed = [f.name for f in fields(cls)]
        values: dict[str, float] = {}
        for assignment in assignments:
            name, sep, text = assignment.partition("=")
            name = name.strip()
            if not sep:
                raise TuneError(f"weight {assignment!r} must look like name=value")
            if name not in allowed:
                raise TuneError(f"unknown objective weight {name!r}; allowed: {allowed}")
            try:
                values[name] = float(text)
            except ValueError:
                raise TuneError(f"objective weight {name} must be a number, got {text!r}") from None
        return cls(**values)

    def to_dict(self) -> dict[str, float]:
        """The weights as a plain dict."""
        return asdict(self)


@dataclass(frozen=True)
class ObjectiveTerms:
    """The objective's terms for one recording.

    Attributes:
        table1_mm: Mean absolute Table I error of the FOG [mm] (missing rows charged).
        cell_error_pct: Seen cells labelled wrong [%] (100 if none was seen).
        unknown_pct: Cells in view the FOG left unknown [%] (100 if no cell was in view).
        obstacle_missed_pct: Seen true obstacle cells not labelled obstacle [%] (100 when
            none is labelled so), None when the scored area holds no true obstacle.
        unsafe_cells: Unsafe FOG floor cells.
        clearing_s: Mean event clearing time [s] (never-cleared charged), None without events.
        table1_rows: Number of Table I rows.
        seen_cells: Number of seen cells the cell accuracy is over.
    """

    table1_mm: float
    cell_error_pct: float
    unknown_pct: float
    obstacle_missed_pct: float | None
    unsafe_cells: int
    clearing_s: float | None
    table1_rows: int
    seen_cells: int

    def value(self, weights: ObjectiveWeights) -> float:
        """The weighted objective of this recording (lower is better)."""
        total = weights.table1_mm * self.table1_mm + weights.cell_error_pct * self.cell_error_pct
        total += weights.unknown_pct * self.unknown_pct
        if self.obstacle_missed_pct is not None:
            total += weights.obstacle_missed_pct * self.obstacle_missed_pct
        total += weights.unsafe_cells * self.unsafe_cells
        if self.clearing_s is not None:
            total += weights.clearing_s * self.clearing_s
        return float(total)

    def to_dict(self) -> dict[str, TermValue]:
        """The terms as a plain (JSON-able) dict."""
        return asdict(self)


def objective_terms(
    report: Report, weights: ObjectiveWeights, frame_rate_hz: float
) -> ObjectiveTerms:
    """Reduce one report (DESIGN.md "Results", :func:`fogsim.eval.report.build_report`) to terms.

    Reads the FOG's Table I rows (``error_mm``; rows whose surface has no interior cell in the
    scored area, ``surface_cells == 0``, are left out), its cell scores (``in_view``,
    ``in_view_seen``, ``seen``, ``correct``, the obstacle class's ``recall`` and the obstacle
    row of ``confusion``), ``safety.unsafe_cells`` and the events (``cleared_frames.fog``:
    frames until the footprint is cleared, None = never or not seen).

    Args:
        report: A report as :func:`fogsim.run.runner.replay_report` returns it.
        weights: Supplies the penalties for missing rows and never-cleared footprints.
        frame_rate_hz: Frame rate of the recording, to turn clearing frames into seconds.

    Raises:
        TuneError: the report has no ground-truth figures (a run without ground truth), or the
            frame rate is not positive.
    """
    if not frame_rate_hz > 0:
        raise TuneError(f"frame_rate_hz must be > 0, got {frame_rate_hz!r}")
    if report.table1 is None or report.cells is None or report.safety is None:
        raise TuneError(
            f"the report of {report.scenario or 'real data'} has no Table I, cell and safety "
            "scores; the objective needs a run with ground truth"
        )
    rows = [row for row in report.table1.fog if row.surface_cells != 0]
    errors = [weights.missing_row_mm if row.error_mm is None else abs(row.error_mm) for row in rows]
    table1_mm = sum(errors) / len(errors) if errors else 0.0

    cells = report.cells.fog
    seen, correct = cells.seen, cells.correct
    cell_error_pct = 100.0 * (1.0 - correct / seen) if seen else 100.0
    unknown_pct = 100.0 * (1.0 - cells.in_view_seen / cells.in_view) if cells.in_view else 100.0
    obstacle_row = cells.confusion.obstacle
    recall = cells.classes.obstacle.recall
    if obstacle_row.unknown + obstacle_row.floor + obstacle_row.obstacle == 0:
        obstacle_missed_pct = None  # nothing in the scored area is an obstacle
    else:
        obstacle_missed_pct = 100.0 if recall is None else 100.0 * (1.0 - recall)

    cleared = [event.cleared_frames.fog for event in report.events]
    clearing = [
        weights.never_cleared_s if frames is None else frames / frame_rate_hz for frames in cleared
    ]
    clearing_s = sum(clearing) / len(clearing) if clearing else None
    return ObjectiveTerms(
        table1_mm=float(table1_mm),
        cell_error_pct=float(cell_error_pct),
        unknown_pct=float(unknown_pct),
        obstacle_missed_pct=obstacle_missed_pct,
        unsafe_cells=report.safety.unsafe_cells,
        clearing_s=None if clearing_s is None else float(clearing_s),
        table1_rows=len(rows),
        seen_cells=seen,
    )


@dataclass(frozen=True)
class SuiteEntry:
    """One recording of a tuning suite.

    Attributes:
        name: Display name (the scenario's name or the file stem).
        recording: The recording the report function replays.
        frame_rate_hz: Frame rate of the recording [Hz].
    """

    name: str
    recording: Recording
    frame_rate_hz: float


@dataclass(frozen=True)
class TrialScore:
    """A parameter set's score over a suite.

    Attributes:
        objective: Mean of the recordings' objectives (lower is better).
        terms: Per recording name, its :class:`ObjectiveTerms` as a dict plus ``objective``.
        report_s: Wall time in the report function: replay (segmentation, mapper, baseline)
            and scoring against the ground truth [s]; ``bench/bench_tune.py`` splits the two.
        objective_s: Wall time reducing the reports to the objective [s].
    """

    objective: float
    terms: dict[str, dict[str, TermValue]]
    report_s: float
    objective_s: float


def score_parameters(
    suite: Sequence[SuiteEntry],
    overrides: Mapping[str, float],
    weights: ObjectiveWeights,
    report_function: ReportFunction,
) -> TrialScore:
    """Replay every recording with ``overrides`` and combine the reports into one objective.

    Args:
        suite: The recordings.
        overrides: Parameter values by name (``p_occ``, ``seg.<name>``).
        weights: Objective weights.
        report_function: ``(recording, overrides) -> report``.

    Returns:
        The trial's score with per-recording terms and the time split.
    """
    if not suite:
        raise TuneError("cannot score parameters over an empty suite")
    report_s = objective_s = 0.0
    terms: dict[str, dict[str, TermValue]] = {}
    values = []
    for entry in suite:
        start = time.perf_counter()
        report = report_function(entry.recording, dict(overrides))
        middle = time.perf_counter()
        entry_terms = objective_terms(report, weights, entry.frame_rate_hz)
        value = entry_terms.value(weights)
        objective_s += time.perf_counter() - middle
        report_s += middle - start
        terms[entry.name] = {**entry_terms.to_dict(), "objective": value}
        values.append(value)
    return TrialScore(
        objective=float(sum(values) / len(values)),
        terms=terms,
        report_s=report_s,
        objective_s=objective_s,
    )
