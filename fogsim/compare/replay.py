"""One run of the comparison: the same frames into every map, every map scored the same way.

The frames go through the testbed's :class:`~fogsim.mapping.pipeline.Pipeline` once: one
segmentation, one heading and z-shift correction. The comparison listens to the FOG's
``update`` (:class:`_UpdateTap`) and hands the very arrays the FOG received — world points,
floor heights, camera centre — to every other map right after, each recentred on the FOG's grid
first, so all maps get the same input on the same cells (a withdrawn frame reaches no map).
Every call is handed on, also the several of the frame that makes the height reference known
(the deferred frames are mapped then), and the frames still deferred when the run ends are
mapped by ``Pipeline.finish`` and archived as :func:`fogsim.run.runner.run_frames` does. When
the heading's estimate makes the pipeline rebuild its maps (``pipe.heading_rebuild_frames``),
every map starts anew and gets the frames mapped so far again (:class:`_ComparedMaps`), and the
cells those frames saw count as seen, as in a run: the comparison's FOG is the FOG of
``fogsim run`` on the same frames (``tests/test_compare.py``). Each map's update is timed in the
same process (a rebuild's updates too).

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
from fogsim.run.warmup import install_shipped_kernels
from fogsim.world.truth import SceneTruth
from mapper.backends import HeightMapBackend, label_by_step
from mapper.grid import CellType, UpdateResult
from mapper.mapper import FloorObstacleMapper
from mapper.params import MapperParams

TruthAt = Callable[[float], SceneTruth | None]
"""Ground truth at a time [s] (``Recording.truth_at``, ``Simulation.truth_at``)."""


@dataclass(frozen=True)
class _Update:
    """One call of the FOG's ``update``: its arguments, its grid's centre and its time."""

    arguments: tuple[ArrayLike, ArrayLike, ArrayLike]
    center_xy: NDArray[np.float64]
    update_ms: float


class _UpdateTap:
    """Stands in for the FOG's ``update``: calls it, times it and keeps every call.

    One ``Pipeline.process`` can update the FOG several times (the frames deferred until the
    height reference is known are mapped just before the frame that makes it known), and
    ``Pipeline.finish`` maps the frames still deferred at the end: every call is kept with the
    grid centre the FOG had then, so the other maps get each of them on the same cells.
    """

    def __init__(self, mapper: FloorObstacleMapper) -> None:
        self._mapper = mapper
        self._update = mapper.update
        self.calls: list[_Update] = []

    def __call__(
        self, points: ArrayLike, floor_heights: ArrayLike, sensor_origin: ArrayLike
    ) -> UpdateResult:
        start = time.perf_counter()
        result = self._update(points, floor_heights, sensor_origin)
        update_ms = 1000.0 * (time.perf_counter() - start)
        self.calls.append(
            _Update((points, floor_heights, sensor_origin), _grid_center(self._mapper), update_ms)
        )
        return result


def _grid_center(mapper: FloorObstacleMapper) -> NDArray[np.float64]:
    """The world (x, y) [m] of the FOG grid's middle cell, where the other maps are centred."""
    geometry = mapper.geometry
    return np.asarray(geometry.cell_center(geometry.nx // 2, geometry.ny // 2), dtype=np.float64)


class _ComparedMaps:
    """Every map of the comparison, following the FOG through the pipeline's heading rebuilds.

    When the heading's estimate makes the pipeline start its maps anew and map the frames so
    far into them again (``pipe.heading_rebuild_frames``), every other map starts anew too and
    gets those frames again, as the FOG does: the FOG of the comparison is the FOG of
    ``fogsim run``. (Before session 36 the comparison ran without the rebuild: on the stage,
    seeds 1-8, its FOG had 6.75 (22) unsafe cells where the runs have 0.)

    Attributes:
        backends: Every map by name, the FOG's mapper (``fog``) first.
        tap: The FOG mapper's tapped ``update`` (its calls not yet handed on).
    """

    def __init__(
        self,
        mapper: FloorObstacleMapper,
        maps: tuple[str, ...],
        grid: MapperParams,
        settings: MapSettings,
    ) -> None:
        self._maps = maps
        self._grid = grid
        self._settings = settings
        self.backends: dict[str, HeightMapBackend] = {}
        self.tap = self.restart(mapper)

    def restart(self, mapper: FloorObstacleMapper) -> _UpdateTap:
        """Listen to this FOG mapper (a new one: nothing mapped) and start the others anew.

        Returns:
            The new tap (also :attr:`tap`).
        """
        self.tap = _UpdateTap(mapper)
        mapper.update = self.tap  # type: ignore[method-assign]  # the FOG's input for all maps
        self.backends = {"fog": mapper}
        self.backends.update(
            {m: build_map(m, self._grid, self._settings) for m in self._maps if m != "fog"}
        )
        return self.tap


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
        update_ms: (updates,) time of each update [ms]: one per frame the maps received.
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
        withdrawn: Frames no map received (withdrawn by the z-match rule).
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
    install_shipped_kernels()  # on a fresh machine, instead of compiling them here
    pipeline = Pipeline(params)
    grid = pipeline.mapper_params
    compared = _ComparedMaps(pipeline.mapper, maps, grid, settings)
    pipeline.on_restart = compared.restart
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
    count = updates = 0
    last: Frame | None = None
    for frame in frames:
        pipeline.process(frame)
        updates += _feed(compared, records, _grid_center(pipeline.mapper))
        geometry = pipeline.mapper.geometry
        centers = pipeline.cell_centers_xy()
        in_view = cells_in_view(frame, geometry)
        for late_frame in pipeline.mapped_now:  # frames mapped (again) with this one
            in_view = in_view | cells_in_view(late_frame, geometry)
        truth = truth_at(frame.time_s) if count % scan.every_frames == 0 else None
        points_xy = scan_points_world(pattern, frame.robot_pose_true)
        true_scan = truth.support_height_m(points_xy) if truth is not None else None
        for m, backend in compared.backends.items():
            types, heights = backend.fog()
            if true_scan is not None:
                errors = np.abs(sample_heights(heights, geometry, points_xy) - true_scan)
                records[m].scan_errors_m.append(errors[np.isfinite(errors)])
                records[m].scan_points += errors.size
            for row, labels in _labellings(m, types, heights, settings).items():
                _store(rows[row], frame, centers, grid.cell_m, labels, heights, in_view)
        count += 1
        last = frame
    if last is None:
        raise FogsimError(f"{name}: no frames to compare")
    final = truth_at(last.time_s)
    if final is None:
        raise FogsimError(f"{name}: the comparison needs ground truth (a recording without it)")
    flushed = pipeline.finish()  # frames still waiting for the height reference
    if flushed:
        updates += _feed(compared, records, _grid_center(pipeline.mapper))
        geometry = pipeline.mapper.geometry
        centers = pipeline.cell_centers_xy()
        in_view = np.logical_or.reduce([cells_in_view(f, geometry) for f in flushed])
        for m, backend in compared.backends.items():
            types, heights = backend.fog()
            for row, labels in _labellings(m, types, heights, settings).items():
                _archive(rows[row].archive, centers, labels, heights, in_view)
    first = next(iter(rows.values())).archive
    truth_grid = final.rasterize(
        first.cell_centers_xy(), grid.cell_m, params=truth_params(scenario, grid)
    )
    obstacle = np.asarray(truth_grid.labels) == CellType.OBSTACLE
    top = np.where(obstacle, truth_grid.obstacle_top_m, truth_grid.floor_m)
    return RunComparison(
        name=name,
        frames=count,
        withdrawn=count - updates,
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
    compared: _ComparedMaps,
    records: dict[str, _MapRecord],
    now_xy: NDArray[np.float64],
) -> int:
    """Give every other map each FOG update since the last call, timed; returns their number.

    Each map is recentred on the FOG's grid of that update first, and at the end on the FOG's
    grid now (a withdrawn frame recentres the FOG without updating it), so every map's read-out
    lies on the FOG's cells.

    Args:
        compared: Every map, the FOG (``fog``) among them, and the FOG's tapped ``update``,
            whose calls are handed on and cleared.
        records: Every map's record, by name.
        now_xy: The world (x, y) [m] of the FOG grid's middle cell now.
    """
    tap = compared.tap
    for call in tap.calls:
        records["fog"].update_ms.append(call.update_ms)
    for m, backend in compared.backends.items():
        if m == "fog":
            continue
        for call in tap.calls:
            backend.recenter(float(call.center_xy[0]), float(call.center_xy[1]))
            start = time.perf_counter()
            backend.update(*call.arguments)
            records[m].update_ms.append(1000.0 * (time.perf_counter() - start))
        backend.recenter(float(now_xy[0]), float(now_xy[1]))
    fed = len(tap.calls)
    tap.calls.clear()
    return fed


def _labellings(
    m: str, types: NDArray[np.int8], heights: NDArray[np.float64], settings: MapSettings
) -> dict[str, NDArray[np.int8]]:
    """A map's labels per row: its own, and for a labelled map also the step rule's."""
    labellings = {m: types}
    if m in LABELLED:
        labellings[m + RULE_SUFFIX] = label_by_step(heights, settings.rule)
    return labellings


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
    _archive(row.archive, centers, labels, heights, in_view)
    if row.tracker is not None:
        row.tracker.update(frame.index, frame.time_s, centers, cell_m, labels, heights, heights)


def _archive(
    archive: WorldArchive,
    centers: NDArray[np.float64],
    labels: NDArray[np.int8],
    heights: NDArray[np.float64],
    in_view: NDArray[np.bool_],
) -> None:
    """A map's labels and heights into an archive (its heights stand for every layer)."""
    archive.store(
        centers,
        labels,
        heights,
        heights,
        floor_m=heights,
        obstacle_m=heights,
        ceiling_m=np.full(heights.shape, np.nan),
        in_view=in_view,
    )
