"""Hand-made typed reports for tests of what reads them (suite metrics, tuning objective)."""

from __future__ import annotations

from collections.abc import Sequence

from msgspec import UNSET

from fogsim.config import RunParams
from fogsim.eval.report.build import param_tables
from fogsim.eval.report.schema import (
    AveragingCellScores,
    CellScores,
    Confusion,
    ConfusionRow,
    ErrorStats,
    EventResult,
    FogCellScores,
    IntermediateFloorCells,
    MaxFinal,
    ObstacleHeightStats,
    PoseErrorStats,
    Report,
    Table1,
    Table1Row,
    TimeStats,
    Timing,
)

NO_ERRORS = ErrorStats(0, None, None, None)


def row(name: str, error_mm: float | None, surface_cells: int = 100) -> Table1Row:
    """A FOG Table I row with a true height of 0 (so the estimate equals the error)."""
    return Table1Row(name, 0.0, error_mm, error_mm, 0 if error_mm is None else 10, surface_cells)


def event(name: str, fog_frames: int | None, intermediate_final: int | None = None) -> EventResult:
    """A remove event, or a move when ``intermediate_final`` (FOG cells at the end) is given."""
    moved = intermediate_final is not None
    return EventResult(
        object=name,
        kind="move" if moved else "remove",
        at_s=1.0,
        start_frame=12,
        footprint_cells=20,
        old_top_mm=50.0,
        fog_frames=fog_frames,
        averaging_frames=None,
        fog_frames_to_floor=fog_frames,
        averaging_frames_to_floor=None,
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
) -> Report:
    """A complete report with the given scores; everything else empty or None."""
    no_time = TimeStats(None, None, None)
    empty = ConfusionRow(0, 0, 0)
    return Report(
        format="fogsim-report",
        version=1,
        scenario="stage",
        seed=0,
        source="replay",
        table1=Table1(fog=tuple(rows), averaging=()),
        cells=CellScores(
            fog=FogCellScores(
                region=region,
                seen=seen,
                correct=correct,
                accuracy=accuracy,
                interior_seen=seen,
                interior_accuracy=accuracy,
                confusion=Confusion(floor=empty, obstacle=empty),
                obstacle_height=ObstacleHeightStats(0, None, None, None, within_one_cell),
                floor_height=NO_ERRORS,
            ),
            obstacles=(),
            averaging=AveragingCellScores(seen=0, floor_height=NO_ERRORS),
        ),
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
        pose_error=PoseErrorStats(frames=0),
        params=param_tables(RunParams()),
        versions={"python": "3.11.7"},
    )
