"""One run of the comparison: the same frames into every map, every map scored the same way.

The frames go through the testbed's :class:`~fogsim.mapping.pipeline.Pipeline` once: one
segmentation, one heading and z-shift correction. The comparison listens to the FOG's
``update`` (:class:`_UpdateTap`) and hands the very arrays the FOG received — world points,
floor heights, camera centre — to every other map right after, each recentred on the FOG's grid
first, so all maps get the same input on the same cells (a withdrawn frame reaches no map).
Each map's update is timed in the same process.

After every frame each map's labels and heights go into its own
:class:`~fogsim.eval.archive.WorldArchive` (and :class:`~fogsim.eval.events.EventTracker` when
the scenario has events), once per row of :func:`fogsim.compare.maps.row_names`; at the end every
archive is scored with the same final truth by :func:`fogsim.eval.metrics.score_archive`.
Height scans (:mod:`fogsim.compare.scans`) are taken every ``every_frames`` frames.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fogsim.compare.maps import LABELLED, RULE_SUFFIX, MapSettings, build_map, row_names
from fogsim.compare.scans import (
    HeightScanParams,
    sample_heights,
    scan_pattern_robot,
    scan_points_world,
)
from fogsim.config import RunParams, Scenario
from fogsim.data.frame import Frame
from fogsim.errors import FogsimError
from fogsim.eval.archive import WorldArchive, cells_in_view
from fogsim.eval.events import EventTracker
from fogsim.eval.metrics import score_archive
from fogsim.eval.report.schema import ArchiveScores, EventResult
from fogsim.mapping.pipeline import Pipeline
from fogsim.run.runner import truth_params
from fogsim.world.truth import SceneTruth
from mapper.backends import HeightMapBackend, label_by_step
from mapper.grid import CellType, UpdateResult

TruthAt = Callable[[float], SceneTruth | None]
"""Ground truth at a time [s] (``Recording.truth_at``, ``Simulation.truth_at``)."""


class _UpdateTap:
    """Stands in for the FOG's ``update``: calls it, times it and keeps its arguments."""

    def __init__(self, update: Callable[[ArrayLike, ArrayLike, ArrayLike], UpdateResult]) -> None:
        self._update = update
        self.arguments: tuple[ArrayLike, ArrayLike, ArrayLike] | None = None
        self.update_ms = float("nan")

    def __call__(
        self, points: ArrayLike, floor_heights: ArrayLike, sensor_origin: ArrayLike
    ) -> UpdateResult:
        start = time.perf_counter()
        result = self._update(points, floor_heights, sensor_origin)
        self.update_ms = 1000.0 * (time.perf_counter() - start)
        self.arguments = (points, floor_heights, sensor_origin)
        return result


@dataclass
class _Row:
    """One map labelled one way: its archive and event tracker."""

    archive: WorldArchive
    tracker: EventTracker | None


@dataclass
class _MapRecord:
    """What one map did over the run: update times and height-scan errors."""

    update_ms: list[float] = field(default_factory=list)
    scan_errors_m: list[NDArray[np.float64]] = field(default_factory=list)
    scan_points: int = 0


@dataclass(frozen=True)
class MapRun:
    """One map's results of one run.

    Attributes:
        update_ms: (frames,) update time per frame [ms], NaN for withdrawn frames.
        scan_errors_m: Absolute height-scan errors [m] of every covered scan point.
        scan_points: Scan points asked for (covered or not).
    """

    update_ms: NDArray[np.float64]
    scan_errors_m: NDArray[np.float64]
    scan_points: int


@dataclass(frozen=True)
class RunComparison:
    """Every map's results of one run.

    Attributes:
        name: The run's name (``stage_s1``).
        frames: Frames processed.
        withdrawn: Frames no map received.
        maps: Per map name, its :class:`MapRun`.
        scores: Per row name, its archive's scores against the final truth.
        events: Per row name, its event results (empty without events).
        archives: Per row name, its archive (pictures).
        final_truth_top_m: (nx, ny) true highest top per archive cell [m] (pictures).
    """

    name: str
    frames: int
    withdrawn: int
    maps: dict[str, MapRun]
    scores: dict[str, ArchiveScores]
    events: dict[str, tuple[EventResult, ...]]
    archives: dict[str, WorldArchive]
    final_truth_top_m: NDArray[np.float64]


def compare_frames(
    name: str,
    frames: Iterable[Frame],
    truth_at: TruthAt,
    scenario: Scenario | None,
    params: RunParams,
    maps: tuple[str, ...],
    settings: MapSettings | None = None,
    scan: HeightScanParams | None = None,
) -> RunComparison:
    """Feed the frames to every map of ``maps`` and score them all (see the module).

    Args:
        name: The run's name in the tables.
        frames: The frames in order.
        truth_at: Ground truth at a time [s]; it must know every frame's time.
        scenario: The scenario (events, the robot's foot for the truth); None for a recording
            without one.
        params: The pipeline's parameters (the maps share the FOG's grid).
        maps: Map names (:data:`fogsim.compare.maps.MAP_NAMES`), ``fog`` among them.
        settings: Parameters of the other maps.
        scan: The height-scan pattern.

    Raises:
        FogsimError: No frames, no truth, or ``fog`` not among ``maps``.
    """
    if "fog" not in maps:
        raise FogsimError(f"the comparison needs the FOG among its maps, got {maps}")
    settings = settings if settings is not None else MapSettings()
    scan = scan if scan is not None else HeightScanParams()
    pipeline = Pipeline(params)
    tap = _UpdateTap(pipeline.mapper.update)
    pipeline.mapper.update = tap  # type: ignore[method-assign]  # the FOG's input for all maps
    grid = pipeline.mapper_params
    backends: dict[str, HeightMapBackend] = {"fog": pipeline.mapper}
    backends.update({m: build_map(m, grid, settings) for m in maps if m != "fog"})
    records = {m: _MapRecord() for m in maps}
    events = scenario.events if scenario is not None else ()
    rows = {
        row: _Row(
            WorldArchive(grid.cell_m),
            EventTracker(events, truth_at, tolerance_m=params.pipeline.event_tolerance_m)
            if events
            else None,
        )
        for row in row_names(maps)
    }
    pattern = scan_pattern_robot(scan)
    count = withdrawn = 0
    last: Frame | None = None
    for frame in frames:
        tap.arguments = None
        pipeline.process(frame)
        geometry = pipeline.mapper.geometry
        center = geometry.cell_center(geometry.nx // 2, geometry.ny // 2)
        _feed(backends, records, tap, center)
        withdrawn += tap.arguments is None
        centers = pipeline.cell_centers_xy()
        in_view = cells_in_view(frame, geometry)
        truth = truth_at(frame.time_s) if count % scan.every_frames == 0 else None
        points_xy = scan_points_world(pattern, frame.robot_pose_true)
        true_scan = truth.support_height_m(points_xy) if truth is not None else None
        for m, backend in backends.items():
            types, heights = backend.fog()
            if true_scan is not None:
                errors = np.abs(sample_heights(heights, geometry, points_xy) - true_scan)
                records[m].scan_errors_m.append(errors[np.isfinite(errors)])
                records[m].scan_points += errors.size
            labellings = {m: types}
            if m in LABELLED:
                labellings[m + RULE_SUFFIX] = label_by_step(heights, settings.rule)
            for row, labels in labellings.items():
                _store(rows[row], frame, centers, grid.cell_m, labels, heights, in_view)
        count += 1
        last = frame
    if last is None:
        raise FogsimError(f"{name}: no frames to compare")
    final = truth_at(last.time_s)
    if final is None:
        raise FogsimError(f"{name}: the comparison needs ground truth (a recording without it)")
    first = next(iter(rows.values())).archive
    truth_grid = final.rasterize(
        first.cell_centers_xy(), grid.cell_m, params=truth_params(scenario, grid)
    )
    obstacle = np.asarray(truth_grid.labels) == CellType.OBSTACLE
    top = np.where(obstacle, truth_grid.obstacle_top_m, truth_grid.floor_m)
    return RunComparison(
        name=name,
        frames=count,
        withdrawn=withdrawn,
        maps={
            m: MapRun(
                np.array(r.update_ms),
                np.concatenate(r.scan_errors_m) if r.scan_errors_m else np.zeros(0),
                r.scan_points,
            )
            for m, r in records.items()
        },
        scores={
            row: score_archive(r.archive, final, truth_grid, grid.layer_m)
            for row, r in rows.items()
        },
        events={row: r.tracker.results() if r.tracker else () for row, r in rows.items()},
        archives={row: r.archive for row, r in rows.items()},
        final_truth_top_m=np.asarray(top, dtype=np.float64),
    )


def _feed(
    backends: dict[str, HeightMapBackend],
    records: dict[str, _MapRecord],
    tap: _UpdateTap,
    center_xy: NDArray[np.float64],
) -> None:
    """Recentre every other map on the FOG's grid and give it the FOG's input, timed."""
    for m, backend in backends.items():
        if m == "fog":
            records[m].update_ms.append(tap.update_ms if tap.arguments is not None else np.nan)
            continue
        backend.recenter(float(center_xy[0]), float(center_xy[1]))
        if tap.arguments is None:
            records[m].update_ms.append(np.nan)
            continue
        start = time.perf_counter()
        backend.update(*tap.arguments)
        records[m].update_ms.append(1000.0 * (time.perf_counter() - start))


def _store(
    row: _Row,
    frame: Frame,
    centers: NDArray[np.float64],
    cell_m: float,
    labels: NDArray[np.int8],
    heights: NDArray[np.float64],
    in_view: NDArray[np.bool_],
) -> None:
    """One frame's labels and heights into a row's archive and event tracker."""
    row.archive.store(
        centers,
        labels,
        heights,
        heights,
        floor_m=heights,
        obstacle_m=heights,
        ceiling_m=np.full(heights.shape, np.nan),
        in_view=in_view,
    )
    if row.tracker is not None:
        row.tracker.update(frame.index, frame.time_s, centers, cell_m, labels, heights, heights)
