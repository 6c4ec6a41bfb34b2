"""Hand-made typed reports for tests of what reads them (suite metrics, tuning objective)."""

from __future__ import annotations

from collections.abc import Sequence

from msgspec import UNSET, UnsetType

from fogsim.config import RunParams
from fogsim.eval.report.build import param_tables
from fogsim.eval.report.schema import (
    AveragingCellScores,
    CeilingScores,
    CellScores,
    ClassScores,
    Confusion,
    ConfusionRow,
    ErrorStats,
    EventFrames,
    EventResult,
    EventSeen,
    FogCellScores,
    FogClasses,
    IntermediateFloorCells,
    MaxFinal,
    ObstacleHeightStats,
    Percentiles,
    PoseErrorStats,
    Quality,
    Report,
    Safety,
    StepEdge,
    Table1,
    Table1Row,
    TimeStats,
    Timing,
)

NO_ERRORS = ErrorStats(0, None, None, None)
NO_CLASS = ClassScores(0, 0, 0, None, None)
GOOD = Quality(
    withdrawn_fraction=0.0,
    frames_without_ground_plane=0,
    map_empty=False,
    floor_right_fraction=None,
    poor=False,
    reasons=(),
)
NO_SAFETY = Safety(0, 0, 0, 20.0, (), Percentiles(None, None, None, None, None))


def class_scores(truth_seen: int, labelled: int, true_positive: int) -> ClassScores:
    """Scores of one class with recall and precision computed (5 digits, None for 0 / 0)."""
    return ClassScores(
        truth_seen,
        labelled,
        true_positive,
        round(true_positive / truth_seen, 5) if truth_seen else None,
        round(true_positive / labelled, 5) if labelled else None,
    )


def safety_with(unsafe: int, on_obstacle: int = 0) -> Safety:
    """Safety with ``unsafe`` cells, ``on_obstacle`` of them floor on an obstacle."""
    return Safety(
        unsafe_cells=unsafe,
        floor_on_obstacle=on_obstacle,
        floor_height_off=unsafe - on_obstacle,
        height_tolerance_mm=20.0,
        positions_xy_m=((1.0, 0.5),) * min(unsafe, 1),
        floor_height_error_mm=Percentiles(1.0, 2.0, 3.0, 25.0, 40.0),
    )


def step_edge(
    surface: str,
    edge: str,
    median_mm: float | None,
    max_mm: float | None,
    nearest_mm: float | UnsetType | None = UNSET,
    gap_mm: float | UnsetType | None = UNSET,
):
    """A step-edge row over 10 cells (0 when the map never shows the step); without the
    nearest edge and the gap, as a report from before those figures."""
    cells = 0 if median_mm is None else 10
    return StepEdge(surface, edge, cells, median_mm, max_mm, nearest_mm, gap_mm)


def row(name: str, error_mm: float | None, surface_cells: int = 100) -> Table1Row:
    """A FOG Table I row with a true height of 0 (so the estimate equals the error)."""
    return Table1Row(name, 0.0, error_mm, error_mm, 0 if error_mm is None else 10, surface_cells)


def event(name: str, fog_frames: int | None, intermediate_final: int | None = None) -> EventResult:
    """A remove event (a move when ``intermediate_final``, FOG cells at the end, is given):
    the FOG clears it and is floor again after ``fog_frames`` (None = never), the averaging
    baseline never."""
    moved = intermediate_final is not None
    frames = EventFrames(fog=fog_frames, averaging=None)
    return EventResult(
        object=name,
        kind="move" if moved else "remove",
        at_s=1.0,
        start_frame=12,
        footprint_cells=20,
        excluded_cells=0,
        old_top_mm=50.0,
        seen=EventSeen(fog=True, averaging=True),
        cleared_frames=frames,
        floor_again_frames=frames,
        intermediate_floor_cells=(
            IntermediateFloorCells(
                fog=MaxFinal(max=intermediate_final + 2, final=intermediate_final),
                averaging=MaxFinal(max=0, final=0),
            )
            if moved
            else UNSET
        ),
    )


def make_report(
    rows: Sequence[Table1Row] = (),
    *,
    region: int = 0,
    seen: int = 0,
    correct: int = 0,
    accuracy: float | None = None,
    within_one_cell: float | None = None,
    events: Sequence[EventResult] = (),
    frame_ms_median: float | None = None,
    in_view: int | None = None,
    in_view_seen: int | None = None,
    floor: ClassScores = NO_CLASS,
    obstacle: ClassScores = NO_CLASS,
    obstacle_truth_cells: int = 0,
    safety: Safety = NO_SAFETY,
    step_edges: Sequence[StepEdge] = (),
    unseen_objects: Sequence[str] = (),
    ceiling: CeilingScores | None = None,
    quality: Quality = GOOD,
    pose_error: PoseErrorStats | None = None,
) -> Report:
    """A complete report with the given scores; everything else empty or None.

    ``in_view`` / ``in_view_seen`` default to ``region`` / ``seen``; ``obstacle_truth_cells``
    is how many region cells are true obstacle (the confusion row's unknown count).
    """
    no_time = TimeStats(None, None, None)
    empty = ConfusionRow(0, 0, 0)
    return Report(
        format="fogsim-report",
        version=2,
        scenario="stage",
        seed=0,
        source="replay",
        quality=quality,
        table1=Table1(fog=tuple(rows), averaging=()),
        cells=CellScores(
            fog=FogCellScores(
                region=region,
                in_view=region if in_view is None else in_view,
                seen=seen,
                in_view_seen=seen if in_view_seen is None else in_view_seen,
                correct=correct,
                accuracy=accuracy,
                interior_seen=seen,
                interior_accuracy=accuracy,
                confusion=Confusion(floor=empty, obstacle=ConfusionRow(obstacle_truth_cells, 0, 0)),
                classes=FogClasses(floor=floor, obstacle=obstacle),
                obstacle_height=ObstacleHeightStats(0, None, None, None, within_one_cell),
                floor_height=NO_ERRORS,
            ),
            obstacles=(),
            averaging=AveragingCellScores(seen=0, floor_height=NO_ERRORS),
        ),
        safety=safety,
        step_edges=tuple(step_edges),
        unseen_objects=tuple(unseen_objects),
        ceiling=ceiling,
        events=tuple(events),
        timing=Timing(
            frames=5,
            withdrawn_frames=0,
            z_matched_frames=0,
            update_ms=no_time,
            segmentation_ms=no_time,
            frame_ms=TimeStats(frame_ms_median, frame_ms_median, frame_ms_median),
            wall_s=1.0,
            realtime_factor=None,
        ),
        pose_error=PoseErrorStats(frames=0) if pose_error is None else pose_error,
        params=param_tables(RunParams()),
        versions={"python": "3.11.7"},
    )
