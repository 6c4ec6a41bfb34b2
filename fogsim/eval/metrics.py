"""Metrics of maps against the ground truth: Table I, cells, safety, step edges, ceiling.

All maps here are 2-D arrays over cells in x, y (index ``[ix, iy]``), heights in metres in the
world frame (z up, ground at 0), NaN = no value. Labels use ``mapper.CellType`` values
(UNKNOWN=0, FLOOR=1, OBSTACLE=2). Truth comes as a :class:`GroundTruthGrid` rasterised on the
same cells. Results are the report's typed rows (:mod:`fogsim.eval.report.schema`), lengths in
millimetres rounded to 0.01 mm, fractions to 5 digits, NaN as None. A cell is *seen* when the
FOG labels it floor or obstacle.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from fogsim.eval.archive import WorldArchive
from fogsim.eval.report.schema import (
    ArchiveScores,
    AveragingCellScores,
    CeilingScores,
    CellScores,
    ClassScores,
    Confusion,
    ConfusionRow,
    ErrorStats,
    FogCellScores,
    FogClasses,
    ObstacleHeightStats,
    ObstacleObjectScore,
    Percentiles,
    Safety,
    StepEdge,
    Table1,
    Table1Row,
)
from fogsim.eval.rounding import fraction, mm
from fogsim.world.timeline import ObjectState
from fogsim.world.truth import GroundTruthGrid, SceneTruth
from mapper import CellType

HEIGHT_TOLERANCE_M = 0.02
"""A FOG floor more than this off the true floor is unsafe [m] (DESIGN.md "Ground truth"): 20 mm
is about the height a swinging foot clears with margin and half the 38 mm sill, so a floor off
by more hides a step a foot can stumble on."""
MAX_UNSAFE_POSITIONS = 200
"""Unsafe cells whose positions the report lists, worst first (8 m of a 4 cm wide strip: enough
to find every bad place of a run, small enough to keep ``report.json`` readable)."""
STEP_EDGE_REACH_M = 0.2
"""How far a step-edge profile looks on each side of the true edge [m]: the stage's tread
depth, and more than twice the 8 cm by which today's maps misplace risers; a map edge further
off than this is not found."""
MIN_STEP_M = 0.01
"""Smallest height difference across an edge that makes it a step [m]: the mapper's ``eps_m``
(10 mm), below which it merges two surfaces into one floor."""
_SAME_HEIGHT_M = 1e-3
"""Two true heights this close belong to one surface (the truth's resting tolerance) [m]."""
_POSITION_DIGITS = 4
"""Decimals of the unsafe cells' positions [m] (0.1 mm)."""


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


def class_scores(
    truth_is: NDArray[np.bool_], fog_is: NDArray[np.bool_], seen: NDArray[np.bool_]
) -> ClassScores:
    """Recall and precision of one FOG label over the seen cells.

    Args:
        truth_is: (nx, ny) the truth is the class.
        fog_is: (nx, ny) the FOG labels the class.
        seen: (nx, ny) the cells that count.
    """
    truth_seen = int((seen & truth_is).sum())
    labelled = int((seen & fog_is).sum())
    true_positive = int((seen & truth_is & fog_is).sum())
    return ClassScores(
        truth_seen=truth_seen,
        labelled=labelled,
        true_positive=true_positive,
        recall=fraction(true_positive, truth_seen),
        precision=fraction(true_positive, labelled),
    )


def cell_scores(
    truth: GroundTruthGrid,
    fog_types: NDArray[np.integer],
    fog_heights_m: NDArray[np.floating],
    region: NDArray[np.bool_],
    in_view: NDArray[np.bool_],
    cell_z_m: float,
) -> FogCellScores:
    """Cell labelling and height errors of a FOG against the truth.

    Args:
        truth: Ground truth on the same cells.
        fog_types: (nx, ny) CellType values.
        fog_heights_m: (nx, ny) FOG height [m] (floor height or coarse obstacle top), NaN = none.
        region: (nx, ny) cells to score (the cells that were ever inside the map).
        in_view: (nx, ny) cells the camera saw (:func:`fogsim.eval.archive.cells_in_view`).
        cell_z_m: Vertical cell size [m] of the 3-D grid ("within one cell" of an obstacle top).

    Returns:
        The scores; the confusion counts cover the whole region, unknown cells included.
    """
    types = np.asarray(fog_types)
    heights = np.asarray(fog_heights_m, dtype=np.float64)
    region = np.asarray(region, dtype=bool)
    viewed = region & np.asarray(in_view, dtype=bool)
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
        in_view=int(viewed.sum()),
        seen=int(known.sum()),
        in_view_seen=int((viewed & known).sum()),
        correct=int(right.sum()),
        accuracy=fraction(int(right.sum()), int(known.sum())),
        interior_seen=int(inner.sum()),
        interior_accuracy=fraction(int((inner & right).sum()), int(inner.sum())),
        confusion=Confusion(
            floor=_confusion_row(region, labels == CellType.FLOOR, types),
            obstacle=_confusion_row(region, labels == CellType.OBSTACLE, types),
        ),
        classes=FogClasses(
            floor=class_scores(labels == CellType.FLOOR, types == CellType.FLOOR, known),
            obstacle=class_scores(labels == CellType.OBSTACLE, types == CellType.OBSTACLE, known),
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


def percentiles_mm(abs_errors_m: NDArray[np.floating]) -> Percentiles:
    """p50, p90, p95, p99 and max [mm] of the finite absolute errors [m]; None without any."""
    e = np.asarray(abs_errors_m, dtype=np.float64)
    e = e[np.isfinite(e)]
    if not e.size:
        return Percentiles(None, None, None, None, None)
    p50, p90, p95, p99 = np.percentile(e, [50, 90, 95, 99])
    return Percentiles(p50=mm(p50), p90=mm(p90), p95=mm(p95), p99=mm(p99), max=mm(e.max()))


def safety_scores(
    truth: GroundTruthGrid,
    centers_xy: NDArray[np.float64],
    fog_types: NDArray[np.integer],
    fog_heights_m: NDArray[np.floating],
    region: NDArray[np.bool_],
) -> Safety:
    """Unsafe FOG floor cells: floor on a true obstacle, or floor more than 20 mm off.

    Args:
        truth: Ground truth on the same cells.
        centers_xy: (nx, ny, 2) world cell centres [m].
        fog_types: (nx, ny) CellType values.
        fog_heights_m: (nx, ny) FOG heights [m].
        region: (nx, ny) cells to score.

    Returns:
        The counts, the positions worst first (largest ``|FOG floor − true top|``, the true top
        being the floor's height on floor and the obstacle's top on obstacles; a true obstacle
        without a top counts as worst; ties in cell order) and the floor-height error
        percentiles of FOG floor on true floor.
    """
    heights = np.asarray(fog_heights_m, dtype=np.float64)
    fog_floor = np.asarray(region, dtype=bool) & (np.asarray(fog_types) == CellType.FLOOR)
    labels = np.asarray(truth.labels)
    on_obstacle = fog_floor & (labels == CellType.OBSTACLE)
    on_floor = fog_floor & (labels == CellType.FLOOR)
    floor_error = np.abs(heights - truth.floor_m)
    height_off = on_floor & (floor_error > HEIGHT_TOLERANCE_M)
    unsafe = on_obstacle | height_off
    true_top = np.where(labels == CellType.OBSTACLE, truth.obstacle_top_m, truth.floor_m)
    gap = np.nan_to_num(np.abs(heights - true_top), nan=np.inf)[unsafe]
    worst = np.argsort(-gap, kind="stable")[:MAX_UNSAFE_POSITIONS]
    positions = np.asarray(centers_xy, dtype=np.float64)[unsafe][worst]
    return Safety(
        unsafe_cells=int(unsafe.sum()),
        floor_on_obstacle=int(on_obstacle.sum()),
        floor_height_off=int(height_off.sum()),
        height_tolerance_mm=round(HEIGHT_TOLERANCE_M * 1000.0, 2),
        positions_xy_m=tuple(
            (round(float(x), _POSITION_DIGITS), round(float(y), _POSITION_DIGITS))
            for x, y in positions
        ),
        floor_height_error_mm=percentiles_mm(floor_error[on_floor]),
    )


@dataclass(frozen=True)
class _Edge:
    """One side of an object's footprint.

    Attributes:
        name: ``x_min``, ``x_max``, ``y_min`` or ``y_max`` in the object's own frame.
        midpoint_xy: (2,) world midpoint [m].
        normal_xy: (2,) outward unit normal in the world.
        length_m: Its length [m].
    """

    name: str
    midpoint_xy: NDArray[np.float64]
    normal_xy: NDArray[np.float64]
    length_m: float


def _object_edges(obj: ObjectState) -> tuple[_Edge, ...]:
    """The four sides of an object's footprint."""
    c, s = np.cos(obj.yaw_rad), np.sin(obj.yaw_rad)
    axis_x, axis_y = np.array([c, s]), np.array([-s, c])
    half_x, half_y = 0.5 * obj.size[0], 0.5 * obj.size[1]
    center = np.asarray(obj.center_xy, dtype=np.float64)
    return (
        _Edge("x_min", center - half_x * axis_x, -axis_x, obj.size[1]),
        _Edge("x_max", center + half_x * axis_x, axis_x, obj.size[1]),
        _Edge("y_min", center - half_y * axis_y, -axis_y, obj.size[0]),
        _Edge("y_max", center + half_y * axis_y, axis_y, obj.size[0]),
    )


class _Boundary(NamedTuple):
    """Where a profile's map changes from the inner surface to the outer one.

    Attributes:
        middle_m: The middle of the boundaries that leave the fewest cells on the wrong side
            (the mean of equally good ones) [m], along the profile from the true edge.
        nearest_m: Of those boundaries, the position nearest the true edge [m]: a boundary may
            lie anywhere in the band between its two cells (from the nearer side of one to the
            nearer side of the other), so 0 when the true edge lies in a band the map leaves
            undecided (unknown or obstacle cells), the band's near side otherwise.
        gap_m: Width of that band: the cells between the two sides that the map puts on
            neither [m] (0 when the two sides' floors touch).
    """

    middle_m: float
    nearest_m: float
    gap_m: float


def _boundary_m(
    offsets_m: NDArray[np.float64], inner: NDArray[np.bool_], cell_m: float
) -> _Boundary | None:
    """Where along a profile the map changes from the inner surface to the outer one.

    Args:
        offsets_m: (n,) signed offsets of the profile's cells from the true edge [m].
        inner: (n,) the map puts the cell on the inner surface (else on the outer one).
        cell_m: Cell side [m]: a cell reaches half of it to either side of its centre.

    Returns:
        The `_Boundary` between two neighbouring cells (by offset) that leaves the fewest cells
        on the wrong side, or None unless both sides have a cell.
    """
    order = np.argsort(offsets_m, kind="stable")
    t, on_inner = offsets_m[order], inner[order]
    if on_inner.all() or not on_inner.any():
        return None
    inner_from = np.cumsum(on_inner[::-1])[::-1]  # inner cells at or after each index
    outer_upto = np.cumsum(~on_inner)  # outer cells at or before each index
    wrong = outer_upto[:-1] + inner_from[1:]
    best = np.flatnonzero(wrong == wrong.min())
    middles = 0.5 * (t[best] + t[best + 1])
    # Each tied boundary's band: from the far side of its lower cell to the near side of its
    # upper one (cells closer than a cell apart, off the lattice, leave no band: the middle).
    low = np.minimum(t[best] + 0.5 * cell_m, middles)
    high = np.maximum(t[best + 1] - 0.5 * cell_m, middles)
    nearest = np.clip(0.0, low, high)
    nearest[np.abs(nearest) < 1e-9] = 0.0  # an edge on a cell side, up to rounding
    k = int(np.argmin(np.abs(nearest)))
    return _Boundary(
        middle_m=float(np.mean(middles)),
        nearest_m=float(nearest[k]) + 0.0,  # + 0.0: no negative zero
        gap_m=float(high[k] - low[k]),
    )


@dataclass(frozen=True)
class _FlatCells:
    """The archive's cells, flattened, with what the step-edge profiles read.

    Attributes:
        centers_xy: (N, 2) world cell centres [m].
        support_m: (N,) true support height at the centres [m].
        true_floor: (N,) the truth labels the cell floor.
        seen: (N,) the FOG labels the cell floor or obstacle (in the scored region).
        fog_floor_m: (N,) the FOG's floor height [m], NaN where it has no floor.
    """

    centers_xy: NDArray[np.float64]
    support_m: NDArray[np.float64]
    true_floor: NDArray[np.bool_]
    seen: NDArray[np.bool_]
    fog_floor_m: NDArray[np.float64]


def _edge_errors(
    truth: SceneTruth,
    obj: ObjectState,
    edge: _Edge,
    cells: _FlatCells,
    cell_m: float,
) -> tuple[bool, list[_Boundary]]:
    """Signed edge errors [m] (+ toward the higher side) along one edge of a walkable surface.

    One profile per cell-wide slot along the edge (end slots left out): the cells on the
    surface inside the edge and the cells on the neighbour beyond it (same true height as just
    beyond the edge), within :data:`STEP_EDGE_REACH_M`. A slot counts where the neighbour is a
    floor (some of its profile cells are true floor; cells at the riser may be true obstacle)
    whose height differs from the surface's by at least :data:`MIN_STEP_M`. Each FOG floor cell
    of the profile goes to the side whose true height it is nearer (obstacle and unknown cells
    to neither), and :func:`_boundary_m` puts the map's edge between the two sides.

    Returns:
        Whether the FOG labelled any cell of the edge's step profiles, and one `_Boundary` per
        slot where the map shows the step, its positions signed + toward the higher side.
    """
    midpoint, normal, length = edge.midpoint_xy, edge.normal_xy, edge.length_m
    tangent = np.array([-normal[1], normal[0]])
    relative = cells.centers_xy - midpoint
    offset_all = relative @ normal
    # A cell centre on a slot boundary (an edge through cell centres) goes to the upper slot.
    slot_all = np.floor((relative @ tangent + 0.5 * length) / cell_m + 1e-6).astype(np.int64)
    slots = np.arange(1, int(np.floor(length / cell_m + 1e-6)) - 1)
    near = np.flatnonzero((np.abs(offset_all) <= STEP_EDGE_REACH_M) & np.isin(slot_all, slots))
    offset, slot, support = offset_all[near], slot_all[near], cells.support_m[near]
    heights, seen, true_floor = cells.fog_floor_m[near], cells.seen[near], cells.true_floor[near]
    inside = obj.contains(cells.centers_xy[near])
    top = obj.top_m
    inner = inside & (np.abs(support - top) <= _SAME_HEIGHT_M)
    edge_points = midpoint + tangent * ((slots + 0.5) * cell_m - 0.5 * length)[:, None]
    beyond = truth.support_height_m(edge_points + 0.5 * cell_m * normal)
    in_view = False
    errors = []
    for k, beyond_m in zip(slots, beyond, strict=True):
        if abs(beyond_m - top) < MIN_STEP_M:
            continue
        here = slot == k
        outer = here & ~inside & (offset > 0) & (np.abs(support - beyond_m) <= _SAME_HEIGHT_M)
        if not (outer & true_floor).any():
            continue  # no floor beyond the edge here (an obstacle stands there)
        profile = ((here & inner) | outer) & seen
        in_view |= bool(profile.any())
        to_top, to_beyond = np.abs(heights - top), np.abs(heights - beyond_m)
        decided = profile & np.isfinite(heights) & (to_top != to_beyond)
        boundary = _boundary_m(offset[decided], (to_top < to_beyond)[decided], cell_m)
        if boundary is not None:
            sign = 1.0 if beyond_m > top else -1.0
            errors.append(
                _Boundary(sign * boundary.middle_m, sign * boundary.nearest_m + 0.0, boundary.gap_m)
            )
    return in_view, errors


def step_edges(
    truth: SceneTruth,
    grid: GroundTruthGrid,
    centers_xy: NDArray[np.float64],
    fog_types: NDArray[np.integer],
    fog_heights_m: NDArray[np.floating],
    region: NDArray[np.bool_],
) -> tuple[StepEdge, ...]:
    """Edge position errors of every walkable surface's edges in view (see :class:`StepEdge`).

    Args:
        truth: The world (the walkable objects present give the edges).
        grid: Its truth on the cells.
        centers_xy: (nx, ny, 2) world cell centres [m].
        fog_types: (nx, ny) CellType values.
        fog_heights_m: (nx, ny) FOG heights [m].
        region: (nx, ny) cells to score.
    """
    centers = np.asarray(centers_xy, dtype=np.float64).reshape(-1, 2)
    types = np.asarray(fog_types).reshape(-1)
    cells = _FlatCells(
        centers_xy=centers,
        support_m=truth.support_height_m(centers),
        true_floor=np.asarray(grid.labels).reshape(-1) == CellType.FLOOR,
        seen=np.asarray(region, dtype=bool).reshape(-1) & (types != CellType.UNKNOWN),
        fog_floor_m=np.where(
            types == CellType.FLOOR, np.asarray(fog_heights_m, dtype=np.float64).reshape(-1), np.nan
        ),
    )
    rows = []
    for obj in truth.objects:
        if not obj.walkable:
            continue
        for edge in _object_edges(obj):
            in_view, errors = _edge_errors(truth, obj, edge, cells, grid.cell_m)
            if not in_view:
                continue
            e = np.asarray(errors, dtype=np.float64).reshape(-1, 3)  # middle, nearest, gap
            rows.append(
                StepEdge(
                    surface=obj.name,
                    edge=edge.name,
                    cells=len(e),
                    median_error_mm=mm(np.median(e[:, 0])) if len(e) else None,
                    max_abs_error_mm=mm(np.abs(e[:, 0]).max()) if len(e) else None,
                    median_nearest_error_mm=mm(np.median(e[:, 1])) if len(e) else None,
                    median_gap_mm=mm(np.median(e[:, 2])) if len(e) else None,
                )
            )
    return tuple(rows)


def unseen_objects(
    truth: SceneTruth, grid: GroundTruthGrid, seen: NDArray[np.bool_]
) -> tuple[str, ...]:
    """Objects present in ``truth`` none of whose cells (``grid.object_id``) was seen.

    Objects removed before the end are not listed (their events say whether they were seen).
    """
    seen_ids = set(np.unique(np.asarray(grid.object_id)[np.asarray(seen, dtype=bool)]).tolist())
    present = {obj.name for obj in truth.objects}
    return tuple(
        name
        for index, name in enumerate(grid.object_names)
        if name in present and index not in seen_ids
    )


def ceiling_scores(
    truth: GroundTruthGrid, ceiling_m: NDArray[np.floating], region: NDArray[np.bool_]
) -> CeilingScores | None:
    """The map's ceiling against the true one; None when the truth has no ceiling in the region.

    Args:
        truth: Ground truth on the same cells.
        ceiling_m: (nx, ny) the map's ceiling [m], NaN = none.
        region: (nx, ny) cells to score.
    """
    true_ceiling = np.asarray(truth.ceiling_m, dtype=np.float64)
    has_truth = np.asarray(region, dtype=bool) & np.isfinite(true_ceiling)
    if not has_truth.any():
        return None
    errors = error_stats_mm(
        np.abs(np.asarray(ceiling_m, dtype=np.float64) - true_ceiling)[has_truth]
    )
    return CeilingScores(
        cells=errors.cells,
        median_abs_error_mm=errors.median_abs_error_mm,
        max_abs_error_mm=errors.max_abs_error_mm,
    )


def score_archive(
    archive: WorldArchive, truth: SceneTruth, grid: GroundTruthGrid, cell_z_m: float
) -> ArchiveScores:
    """Every figure of an archive against a truth.

    Args:
        archive: The run's archive.
        truth: The world state to score against.
        grid: ``truth`` rasterised on ``archive.cell_centers_xy()`` (with the run's
            ``TruthParams``).
        cell_z_m: Vertical cell size of the 3-D grid [m].
    """
    centers = archive.cell_centers_xy()
    visited = archive.visited
    types, heights = archive.fog_types, archive.fog_heights_m
    fog_rows = table1_rows(grid, heights, visited & (types == CellType.FLOOR))
    avg_rows = table1_rows(grid, archive.baseline_heights_m, visited)
    return ArchiveScores(
        table1=Table1(fog=fog_rows, averaging=avg_rows),
        cells=CellScores(
            fog=cell_scores(grid, types, heights, visited, archive.in_view, cell_z_m),
            obstacles=obstacle_objects(truth, centers, types, heights, visited, archive.cell_m),
            averaging=AveragingCellScores(
                seen=int((visited & np.isfinite(archive.baseline_heights_m)).sum()),
                floor_height=floor_height_errors(grid, archive.baseline_heights_m, visited),
            ),
        ),
        safety=safety_scores(grid, centers, types, heights, visited),
        step_edges=step_edges(truth, grid, centers, types, heights, visited),
        unseen_objects=unseen_objects(truth, grid, visited & (types != CellType.UNKNOWN)),
        ceiling=ceiling_scores(grid, archive.ceiling_m, visited),
    )
