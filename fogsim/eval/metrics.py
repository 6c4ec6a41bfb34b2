"""Metrics of maps against the ground truth: Table I rows, cell scores, error statistics.

All maps here are 2-D arrays over cells in x, y (index ``[ix, iy]``), heights in metres in the
world frame (z up, ground at 0), NaN = no value. Labels use ``mapper.CellType`` values
(UNKNOWN=0, FLOOR=1, OBSTACLE=2). Truth comes as a :class:`GroundTruthGrid` rasterised on the
same cells. Results are the report's typed rows (:mod:`fogsim.eval.report.schema`), lengths in
millimetres rounded to 0.01 mm, fractions to 5 digits, NaN as None.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from fogsim.eval.archive import WorldArchive
from fogsim.eval.report.schema import (
    ArchiveScores,
    AveragingCellScores,
    CellScores,
    Confusion,
    ConfusionRow,
    ErrorStats,
    FogCellScores,
    ObstacleHeightStats,
    ObstacleObjectScore,
    Table1,
    Table1Row,
)
from fogsim.eval.rounding import fraction, mm
from fogsim.world.truth import GroundTruthGrid, SceneTruth
from mapper import CellType


def _surface_true_height_m(truth: GroundTruthGrid, index: int, name: str) -> float:
    """True top height [m] of a walkable surface: ``surface_heights_m`` or the cells' median."""
    if name in truth.surface_heights_m:
        return float(truth.surface_heights_m[name])
    values = truth.floor_m[(truth.surface_id == index) & np.isfinite(truth.floor_m)]
    return float(np.median(values)) if values.size else float("nan")


def table1_rows(
    truth: GroundTruthGrid, heights_m: NDArray[np.floating], use: NDArray[np.bool_]
) -> tuple[Table1Row, ...]:
    """Table I of the paper: estimated vs true height of every walkable surface and the ground.

    Args:
        truth: Ground truth on the cells of ``heights_m``.
        heights_m: (nx, ny) estimated floor height per cell [m], NaN = none.
        use: (nx, ny) cells whose estimate counts (e.g. FOG cells labelled FLOOR).

    Returns:
        One row per surface in ``truth.surface_names``; the estimate is the median over the
        surface's interior cells (border cells left out) that have one, null when no cell was
        used.
    """
    heights = np.asarray(heights_m, dtype=np.float64)
    usable = np.asarray(use, dtype=bool) & np.isfinite(heights)
    rows = []
    for index, name in enumerate(truth.surface_names):
        surface = np.asarray(truth.interior, dtype=bool) & (truth.surface_id == index)
        cells = surface & usable
        true_m = _surface_true_height_m(truth, index, name)
        estimate_m = float(np.median(heights[cells])) if cells.any() else float("nan")
        rows.append(
            Table1Row(
                name=str(name),
                ground_truth_mm=mm(true_m),
                estimated_mm=mm(estimate_m),
                error_mm=mm(estimate_m - true_m),
                cells=int(cells.sum()),
                surface_cells=int(surface.sum()),
            )
        )
    return tuple(rows)


def error_stats_mm(abs_errors_m: NDArray[np.floating]) -> ErrorStats:
    """Statistics [mm] of absolute errors [m]; the finite ones count, None without any."""
    e = np.asarray(abs_errors_m, dtype=np.float64)
    e = e[np.isfinite(e)]
    if not e.size:
        return ErrorStats(0, None, None, None)
    return ErrorStats(
        cells=int(e.size),
        median_abs_error_mm=mm(np.median(e)),
        p95_abs_error_mm=mm(np.percentile(e, 95)),
        max_abs_error_mm=mm(e.max()),
    )


def floor_height_errors(
    truth: GroundTruthGrid, heights_m: NDArray[np.floating], use: NDArray[np.bool_]
) -> ErrorStats:
    """Absolute floor-height error stats over ``use`` cells that are true floor."""
    cells = np.asarray(use, dtype=bool) & (np.asarray(truth.labels) == CellType.FLOOR)
    return error_stats_mm(np.abs(np.asarray(heights_m)[cells] - truth.floor_m[cells]))


def _confusion_row(
    region: NDArray[np.bool_], truth_is: NDArray[np.bool_], types: NDArray[np.integer]
) -> ConfusionRow:
    def count(label: CellType) -> int:
        return int((region & truth_is & (types == label)).sum())

    return ConfusionRow(
        unknown=count(CellType.UNKNOWN),
        floor=count(CellType.FLOOR),
        obstacle=count(CellType.OBSTACLE),
    )


def cell_scores(
    truth: GroundTruthGrid,
    fog_types: NDArray[np.integer],
    fog_heights_m: NDArray[np.floating],
    region: NDArray[np.bool_],
    cell_z_m: float,
) -> FogCellScores:
    """Cell labelling and height errors of a FOG against the truth.

    Args:
        truth: Ground truth on the same cells.
        fog_types: (nx, ny) CellType values.
        fog_heights_m: (nx, ny) FOG height [m] (floor height or coarse obstacle top), NaN = none.
        region: (nx, ny) cells to score (the cells that were ever inside the map).
        cell_z_m: Vertical cell size [m] of the 3-D grid ("within one cell" of an obstacle top).

    Returns:
        The scores; the confusion counts cover the whole region, unknown cells included.
    """
    types = np.asarray(fog_types)
    heights = np.asarray(fog_heights_m, dtype=np.float64)
    region = np.asarray(region, dtype=bool)
    labels = np.asarray(truth.labels)
    interior = np.asarray(truth.interior, dtype=bool)
    known = region & (types != CellType.UNKNOWN)
    right = known & (types == labels)
    inner = known & interior

    both_obstacle = known & (labels == CellType.OBSTACLE) & (types == CellType.OBSTACLE)
    obstacle_error = np.abs(heights[both_obstacle] - truth.obstacle_top_m[both_obstacle])
    obstacle_error = obstacle_error[np.isfinite(obstacle_error)]
    obstacle = error_stats_mm(obstacle_error)
    return FogCellScores(
        region=int(region.sum()),
        seen=int(known.sum()),
        correct=int(right.sum()),
        accuracy=fraction(int(right.sum()), int(known.sum())),
        interior_seen=int(inner.sum()),
        interior_accuracy=fraction(int((inner & right).sum()), int(inner.sum())),
        confusion=Confusion(
            floor=_confusion_row(region, labels == CellType.FLOOR, types),
            obstacle=_confusion_row(region, labels == CellType.OBSTACLE, types),
        ),
        obstacle_height=ObstacleHeightStats(
            cells=obstacle.cells,
            median_abs_error_mm=obstacle.median_abs_error_mm,
            p95_abs_error_mm=obstacle.p95_abs_error_mm,
            max_abs_error_mm=obstacle.max_abs_error_mm,
            within_one_cell_fraction=fraction(
                int((obstacle_error <= cell_z_m + 1e-9).sum()), int(obstacle_error.size)
            ),
        ),
        floor_height=floor_height_errors(truth, heights, known & (types == CellType.FLOOR)),
    )


def obstacle_objects(
    truth: SceneTruth,
    centers_xy: NDArray[np.float64],
    fog_types: NDArray[np.integer],
    fog_heights_m: NDArray[np.floating],
    region: NDArray[np.bool_],
    cell_m: float,
) -> tuple[ObstacleObjectScore, ...]:
    """Per obstacle object (not walkable, or hanging): how much of it the FOG marks obstacle.

    Args:
        truth: The world state whose objects are scored.
        centers_xy: (nx, ny, 2) world cell centres [m].
        fog_types: (nx, ny) CellType values.
        fog_heights_m: (nx, ny) FOG heights [m].
        region: (nx, ny) cells to look at.
        cell_m: Cell side [m].
    """
    rows = []
    for obj in truth.objects:
        if obj.walkable and obj.base_m <= 1e-3:
            continue
        inside = obj.contains(centers_xy, -0.5 * cell_m)
        cells = inside & region
        types = np.asarray(fog_types)[cells]
        seen = types != CellType.UNKNOWN
        obstacle = types == CellType.OBSTACLE
        errors = np.asarray(fog_heights_m)[cells][obstacle] - obj.top_m
        rows.append(
            ObstacleObjectScore(
                name=obj.name,
                cells=int(cells.sum()),
                seen=int(seen.sum()),
                obstacle_fraction=fraction(int(obstacle.sum()), int(seen.sum())),
                top_mm=mm(obj.top_m),
                median_top_error_mm=mm(np.median(errors)) if errors.size else None,
            )
        )
    return tuple(rows)


def score_archive(archive: WorldArchive, truth: SceneTruth, cell_z_m: float) -> ArchiveScores:
    """Table I (FOG and averaging baseline) and cell scores of an archive against a truth.

    Args:
        archive: The run's archive.
        truth: The world state to score against (rasterised on the archive's cells).
        cell_z_m: Vertical cell size of the 3-D grid [m].
    """
    centers = archive.cell_centers_xy()
    grid = truth.rasterize(centers, archive.cell_m)
    visited = archive.visited
    fog_rows = table1_rows(
        grid, archive.fog_heights_m, visited & (archive.fog_types == CellType.FLOOR)
    )
    avg_rows = table1_rows(grid, archive.baseline_heights_m, visited)
    return ArchiveScores(
        table1=Table1(fog=fog_rows, averaging=avg_rows),
        cells=CellScores(
            fog=cell_scores(grid, archive.fog_types, archive.fog_heights_m, visited, cell_z_m),
            obstacles=obstacle_objects(
                truth, centers, archive.fog_types, archive.fog_heights_m, visited, archive.cell_m
            ),
            averaging=AveragingCellScores(
                seen=int((visited & np.isfinite(archive.baseline_heights_m)).sum()),
                floor_height=floor_height_errors(grid, archive.baseline_heights_m, visited),
            ),
        ),
    )
