"""The per-frame pipeline: depth image → segmentation → world points → z-shift → maps → scores.

Per frame (paper Fig. 1, 2 and Sec. IV), with the pose the robot *believes*:

1. ``segment_depth`` labels the (already self-filtered) depth image: points in the robot frame
   R with the height ``h`` of the horizontal plane each belongs to (NaN = not floor), after the
   segmentation's own rotation / ground-plane correction.
2. Points and heights go to the world with the believed robot pose (x, y, yaw from odometry,
   z from the *elevation filter* below): ``h_G = h_R + z_R``.
3. The grids follow the robot: both maps ``recenter`` on the believed (x, y).
4. z-shift matching against the floor map (``match_z``): an accepted shift is added to the
   points' z, their floor heights and the camera origin. If it is not accepted (few pairs or an
   implausible shift) and the segmentation found no ground plane either, the frame is
   *withdrawn* (Sec. IV); otherwise the unshifted data are used.
5. ``FloorObstacleMapper.update`` and ``AveragingMap.update`` get exactly the same data.
6. Robot elevation filter (``mapper.RobotElevationFilter``): the offset on odometry's z is
   pulled towards ``Floor(x_R, y_R)`` when the floor map has a height under the robot.

Scoring runs alongside (:mod:`fogsim.scoring`): every frame's FOG and baseline go into a
world-fixed archive, event footprints are checked, and the archive is scored against the truth
at the end of the run.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from fogsim.errors import FogsimError
from fogsim.frames import Frame
from fogsim.scoring import EventTracker, TruthProvider, WorldArchive, score_archive
from mapper import (
    AveragingMap,
    ElevationFilterParams,
    FloorObstacleMapper,
    MapperParams,
    RobotElevationFilter,
    ZDecision,
    frame_decision,
)
from mapper.segmentation import SegmentationParams, segment_depth
from mapper.transforms import apply_transform, planar_pose_to_matrix, rotation_angle_deg


@dataclass(frozen=True)
class PipelineParams:
    """Parameters of the pipeline around the mapper (override keys ``pipe.<name>``).

    Attributes:
        use_z_match: Apply the z-shift matching (paper: optional step 2 of Fig. 2).
        use_elevation_filter: Filter the robot's z with the floor map (Sec. IV).
        event_tolerance_m: Height tolerance of "floor again" in the event scores [m].
    """

    use_z_match: bool = True
    use_elevation_filter: bool = True
    event_tolerance_m: float = 0.01

    def __post_init__(self) -> None:
        if not self.event_tolerance_m > 0.0:
            raise FogsimError(
                f"PipelineParams.event_tolerance_m must be > 0 m, got {self.event_tolerance_m!r}"
            )


@dataclass
class Snapshot:
    """Both maps at one frame (for Fig. 5).

    Attributes:
        label: What the snapshot shows (``"before"`` / ``"after"``).
        frame_index: Frame number.
        time_s: Frame time [s].
        cell_centers_xy: (nx, ny, 2) world cell centres [m].
        fog_types: (nx, ny) CellType values.
        fog_heights_m: (nx, ny) FOG heights [m], NaN = none.
        baseline_heights_m: (nx, ny) averaging-baseline heights [m], NaN = none.
        depth_m: The frame's depth image [m].
    """

    label: str
    frame_index: int
    time_s: float
    cell_centers_xy: NDArray[np.float64]
    fog_types: NDArray[np.int8]
    fog_heights_m: NDArray[np.float64]
    baseline_heights_m: NDArray[np.float64]
    depth_m: NDArray[np.float32]


@dataclass
class RunResult:
    """Everything a run produced (the report is assembled from it by :mod:`fogsim.report`).

    Attributes:
        frames: Frames processed.
        withdrawn: Frames withdrawn by the z-match rule.
        z_matched: Frames whose data were shifted by an accepted z match.
        update_ms: (frames,) time of ``FloorObstacleMapper.update`` per applied frame [ms].
        segmentation_ms: (frames,) time of ``segment_depth`` per frame [ms].
        frame_ms: (frames,) whole pipeline time per frame, scoring excluded [ms].
        wall_s: Wall time of the whole run incl. scoring [s].
        mapper: The final FloorObstacleMapper.
        baseline: The final AveragingMap.
        archive: World-fixed archive of both maps.
        scores: ``{"table1", "cells"}`` from :func:`fogsim.scoring.score_archive`, None without
            ground truth.
        events: Per-event results of :class:`fogsim.scoring.EventTracker`.
        pose_error: Believed-vs-true camera pose error statistics.
        params: ``{"mapper", "segmentation", "elevation", "pipeline"}`` parameters used.
        snapshots: Snapshots for Fig. 5 (event scenarios only).
        final_truth: ``GroundTruthGrid`` of the final world on the final grid, or None.
        last_depth_m: Depth image of the last frame.
    """

    frames: int
    withdrawn: int
    z_matched: int
    update_ms: NDArray[np.float64]
    segmentation_ms: NDArray[np.float64]
    frame_ms: NDArray[np.float64]
    wall_s: float
    mapper: Any
    baseline: Any
    archive: WorldArchive
    scores: dict | None
    events: list[dict]
    pose_error: dict
    params: dict
    snapshots: list[Snapshot] = field(default_factory=list)
    final_truth: Any | None = None
    last_depth_m: NDArray[np.float32] | None = None


FrameCallback = Callable[[Frame, "Pipeline"], None]


def _replace_validated(params: Any, changes: Mapping[str, Any], what: str) -> Any:
    """``dataclasses.replace`` that names unknown fields and what is allowed."""
    if not changes:
        return params
    allowed = [f.name for f in dataclasses.fields(params)]
    unknown = sorted(set(changes) - set(allowed))
    if unknown:
        raise FogsimError(f"unknown {what} parameter(s) {unknown}; allowed: {allowed}")
    typed = {}
    for name, value in changes.items():
        current = getattr(params, name)
        if isinstance(current, bool):
            value = bool(value)
        elif isinstance(current, int) and float(value).is_integer():
            value = int(value)
        typed[name] = value
    return dataclasses.replace(params, **typed)


@dataclass(frozen=True)
class RunParams:
    """Every parameter of a run (the report's ``params``).

    Attributes:
        mapper: Grid and thresholds (override keys: bare field names or ``mapper.<field>``).
        segmentation: Plane segmentation (``seg.<field>``).
        elevation: Robot elevation filter (``elev.<field>``).
        pipeline: The pipeline's own switches (``pipe.<field>``).
    """

    mapper: MapperParams = field(default_factory=MapperParams)
    segmentation: SegmentationParams = field(default_factory=SegmentationParams)
    elevation: ElevationFilterParams = field(default_factory=ElevationFilterParams)
    pipeline: PipelineParams = field(default_factory=PipelineParams)

    def to_dict(self) -> dict[str, dict[str, Any]]:
        """Plain ``{"mapper": {...}, "segmentation": {...}, ...}``."""
        return {
            f.name: {
                g.name: getattr(getattr(self, f.name), g.name)
                for g in dataclasses.fields(getattr(self, f.name))
            }
            for f in dataclasses.fields(self)
        }


_PREFIXES = {"seg.": "segmentation", "elev.": "elevation", "pipe.": "pipeline", "mapper.": "mapper"}


def resolve_params(scenario: Any | None, overrides: Mapping[str, float] | None = None) -> RunParams:
    """Parameters of a run: defaults ← scenario ``[mapper]`` / ``[segmentation]`` ← overrides.

    Args:
        scenario: A Scenario (its ``mapper`` and ``segmentation`` tables) or None.
        overrides: Keys ``"<mapper field>"`` (e.g. ``"p_occ"``, or ``"mapper.p_occ"``),
            ``"seg.<field>"``, ``"elev.<field>"`` and ``"pipe.<field>"``.

    Raises:
        FogsimError: An unknown key (the message lists the allowed ones) or a bad value.
    """
    changes: dict[str, dict[str, Any]] = {
        "mapper": dict(getattr(scenario, "mapper", {}) or {}),
        "segmentation": dict(getattr(scenario, "segmentation", {}) or {}),
        "elevation": {},
        "pipeline": {},
    }
    for key, value in (overrides or {}).items():
        group = next((g for prefix, g in _PREFIXES.items() if key.startswith(prefix)), None)
        name = key.split(".", 1)[1] if group else key
        changes[group or "mapper"][name] = value
    defaults = RunParams()
    try:
        return RunParams(
            **{
                group: _replace_validated(getattr(defaults, group), values, group)
                for group, values in changes.items()
            }
        )
    except (TypeError, ValueError) as exc:
        raise FogsimError(f"invalid parameter override: {exc}") from exc


class Pipeline:
    """Stateful per-frame processing: the two maps and the robot elevation filter."""

    def __init__(self, params: RunParams | None = None) -> None:
        self.run_params = params or RunParams()
        self.mapper_params = self.run_params.mapper
        self.segmentation_params = self.run_params.segmentation
        self.params = self.run_params.pipeline
        self.mapper = FloorObstacleMapper(self.mapper_params)
        self.baseline = AveragingMap(self.mapper_params)
        self.elevation = RobotElevationFilter(self.run_params.elevation)
        self.last_segmentation: Any = None
        self.last_match: Any = None
        self.last_withdrawn = False

    def robot_pose(self, frame: Frame) -> NDArray[np.float64]:
        """Believed robot pose (x, y, z, yaw) with the elevation filter's z."""
        pose = np.asarray(frame.robot_pose_believed, dtype=np.float64).copy()
        if self.params.use_elevation_filter:
            pose[2] += self.elevation.offset_m
        return pose

    def process(self, frame: Frame) -> dict[str, float]:
        """Run one frame through segmentation, z-match and both maps.

        Returns:
            Timings ``segmentation_ms``, ``update_ms`` (NaN if withdrawn), ``frame_ms`` and
            flags ``withdrawn``, ``z_matched`` (as floats 0/1).
        """
        t0 = time.perf_counter()
        seg = segment_depth(
            frame.depth_m,
            frame.intrinsics,
            frame.transform_camera_to_robot_believed,
            self.segmentation_params,
        )
        t1 = time.perf_counter()
        pose = self.robot_pose(frame)
        transform_robot_to_world = planar_pose_to_matrix(pose)
        points_world = apply_transform(transform_robot_to_world, seg.points)
        floor_world = np.asarray(seg.floor_heights, dtype=np.float64) + pose[2]
        # Camera centre after the segmentation's own correction, so rays match the points.
        sensor_origin = apply_transform(
            transform_robot_to_world, np.asarray(seg.transform_camera_to_robot)[:3, 3]
        )
        self.mapper.recenter(pose[0], pose[1])
        self.baseline.recenter(pose[0], pose[1])

        matched = withdrawn = False
        match = None
        if self.params.use_z_match:
            match = self.mapper.match_z(points_world, floor_world)
            decision = frame_decision(match, bool(seg.correction.ground_plane_found))
            if decision == ZDecision.APPLY_SHIFT:
                shift = float(match.shift_m)
                points_world[:, 2] += shift
                floor_world = floor_world + shift
                sensor_origin = sensor_origin + np.array([0.0, 0.0, shift])
                matched = True
            withdrawn = decision == ZDecision.WITHDRAW
        update_ms = float("nan")
        if not withdrawn:
            t2 = time.perf_counter()
            self.mapper.update(points_world, floor_world, sensor_origin)
            update_ms = 1000.0 * (time.perf_counter() - t2)
            self.baseline.update(points_world, floor_world, sensor_origin)
            if self.params.use_elevation_filter:
                self.elevation.update(
                    float(frame.robot_pose_believed[2]), self.mapper.floor_at(pose[0], pose[1])
                )
        self.last_segmentation, self.last_match, self.last_withdrawn = seg, match, withdrawn
        return {
            "segmentation_ms": 1000.0 * (t1 - t0),
            "update_ms": update_ms,
            "frame_ms": 1000.0 * (time.perf_counter() - t0),
            "withdrawn": float(withdrawn),
            "z_matched": float(matched),
        }

    def maps(self) -> tuple[NDArray[np.int8], NDArray[np.float64], NDArray[np.float64]]:
        """Current FOG types, FOG heights [m] and baseline heights [m] (NaN = none)."""
        types, heights = self.mapper.fog()
        return (
            np.asarray(types),
            np.asarray(heights, dtype=np.float64),
            baseline_heights(self.baseline),
        )

    def cell_centers_xy(self) -> NDArray[np.float64]:
        """(nx, ny, 2) world centres of the current grid cells [m]."""
        return np.asarray(self.mapper.geometry.cell_centers_xy(), dtype=np.float64)


def baseline_heights(baseline: AveragingMap) -> NDArray[np.float64]:
    """Averaging-baseline height map (nx, ny) [m]: mean z of all points, NaN where none."""
    return np.asarray(baseline.heights(), dtype=np.float64)


class _PoseErrors:
    """Believed-vs-true camera pose errors, in the robot frame (encoders) and world (+odometry)."""

    def __init__(self) -> None:
        self.rows: list[tuple[float, float, float, float]] = []

    def add(self, frame: Frame) -> None:
        true_world = np.asarray(frame.transform_camera_to_world_true, dtype=np.float64)
        robot_true = np.asarray(frame.robot_pose_true, dtype=np.float64)
        if not (np.all(np.isfinite(true_world)) and np.all(np.isfinite(robot_true))):
            return
        believed_world = frame.transform_camera_to_world_believed
        true_in_robot = np.linalg.inv(planar_pose_to_matrix(robot_true)) @ true_world
        believed_in_robot = np.asarray(frame.transform_camera_to_robot_believed)
        self.rows.append(
            (
                rotation_angle_deg(believed_in_robot[:3, :3].T @ true_in_robot[:3, :3]),
                1000.0 * float(np.linalg.norm(believed_in_robot[:3, 3] - true_in_robot[:3, 3])),
                rotation_angle_deg(believed_world[:3, :3].T @ true_world[:3, :3]),
                1000.0 * float(np.linalg.norm(believed_world[:3, 3] - true_world[:3, 3])),
            )
        )

    def stats(self) -> dict:
        """Median and max of the errors.

        Returns:
            ``{"frames", "camera_in_robot", "camera_in_world"}``, each with ``rotation_deg`` and
            ``translation_mm`` ``{median, max}``; the robot-frame error is what the encoders
            cause (the paper's 7° / 10 mm), the world one adds odometry drift. Only
            ``{"frames": 0}`` without true poses.
        """
        if not self.rows:
            return {"frames": 0}
        a = np.array(self.rows)

        def pair(col: int) -> dict:
            return {
                "median": round(float(np.median(a[:, col])), 4),
                "max": round(float(np.max(a[:, col])), 4),
            }

        return {
            "frames": int(a.shape[0]),
            "camera_in_robot": {"rotation_deg": pair(0), "translation_mm": pair(1)},
            "camera_in_world": {"rotation_deg": pair(2), "translation_mm": pair(3)},
        }


def run_frames(
    frames: Iterable[Frame],
    truth_provider: TruthProvider | None,
    scenario: Any | None,
    mapper_params: MapperParams | None = None,
    segmentation_params: SegmentationParams | None = None,
    *,
    params: RunParams | None = None,
    end_time_s: float | None = None,
    on_frame: FrameCallback | None = None,
) -> RunResult:
    """Feed frames through the pipeline and score the run.

    Args:
        frames: Frames in order (a list, or a simulation's generator).
        truth_provider: ``time_s -> SceneTruth`` (e.g. ``Simulation.truth_at`` or
            ``Recording.truth_at``); None = no scoring (real data).
        scenario: The scenario (its events and parameter tables); None for real data.
        mapper_params: Mapper parameters; default from the scenario's ``[mapper]`` table.
        segmentation_params: Segmentation parameters; default from ``[segmentation]``.
        params: All parameters at once (from :func:`resolve_params`); replaces the scenario's
            tables; ``mapper_params`` / ``segmentation_params`` still override its parts.
        end_time_s: Time of the last frame [s], needed to score events when ``frames`` is a
            generator; default: the last frame of a sequence, or the scenario's events only
            after the run.
        on_frame: Called after every frame with the frame and the pipeline (progress bars,
            video).

    Returns:
        The :class:`RunResult`.
    """
    start = time.perf_counter()
    run_params = params or resolve_params(scenario)
    if mapper_params is not None:
        run_params = dataclasses.replace(run_params, mapper=mapper_params)
    if segmentation_params is not None:
        run_params = dataclasses.replace(run_params, segmentation=segmentation_params)
    pipeline = Pipeline(run_params)
    if end_time_s is None and isinstance(frames, list | tuple) and frames:
        end_time_s = frames[-1].time_s
    events = list(getattr(scenario, "events", ()) or ())
    tracker = None
    if truth_provider is not None and events:
        if end_time_s is None:
            raise FogsimError("run_frames needs end_time_s to score events of a frame generator")
        tracker = EventTracker(
            events, truth_provider, end_time_s, tolerance_m=pipeline.params.event_tolerance_m
        )
    first_event_s = min((float(e.at) for e in events), default=None)

    archive = WorldArchive(pipeline.mapper_params.cell_m)
    pose_errors = _PoseErrors()
    timings: list[dict[str, float]] = []
    snapshots: list[Snapshot] = []
    previous: Snapshot | None = None
    last: Frame | None = None
    for frame in frames:
        timings.append(pipeline.process(frame))
        pose_errors.add(frame)
        centers = pipeline.cell_centers_xy()
        types, fog_heights, base_heights = pipeline.maps()
        archive.store(centers, types, fog_heights, base_heights)
        if tracker is not None:
            tracker.update(
                frame.index,
                frame.time_s,
                centers,
                pipeline.mapper_params.cell_m,
                {"fog": (types, fog_heights), "averaging": (None, base_heights)},
            )
        if first_event_s is not None:
            current = Snapshot(
                "before",
                frame.index,
                frame.time_s,
                centers.copy(),
                types.copy(),
                fog_heights.copy(),
                base_heights.copy(),
                np.array(frame.depth_m, copy=True),
            )
            if frame.time_s >= first_event_s and not snapshots and previous is not None:
                snapshots.append(previous)
            previous = current
        if on_frame is not None:
            on_frame(frame, pipeline)
        last = frame
    if last is None:
        raise FogsimError("run_frames got no frames")
    if previous is not None and snapshots:
        snapshots.append(dataclasses.replace(previous, label="after"))

    scores = final_truth = None
    if truth_provider is not None:
        truth = truth_provider(last.time_s)
        scores = score_archive(archive, truth, pipeline.mapper_params.layer_m)
        final_truth = truth.rasterize(pipeline.cell_centers_xy(), pipeline.mapper_params.cell_m)
    column = {key: np.array([t[key] for t in timings]) for key in timings[0]}
    return RunResult(
        frames=len(timings),
        withdrawn=int(column["withdrawn"].sum()),
        z_matched=int(column["z_matched"].sum()),
        update_ms=column["update_ms"],
        segmentation_ms=column["segmentation_ms"],
        frame_ms=column["frame_ms"],
        wall_s=time.perf_counter() - start,
        mapper=pipeline.mapper,
        baseline=pipeline.baseline,
        archive=archive,
        scores=scores,
        events=tracker.results() if tracker is not None else [],
        pose_error=pose_errors.stats(),
        params=run_params.to_dict(),
        snapshots=snapshots,
        final_truth=final_truth,
        last_depth_m=last.depth_m,
    )


def replay_report(recording: Any, overrides: Mapping[str, float] | None = None) -> dict:
    """Replay a recording with parameter overrides and return its report dict (no pictures).

    Args:
        recording: A :class:`fogsim.recording.Recording`.
        overrides: ``{"p_occ": 0.7, "eps_m": 0.01, "seg.<name>": ..., "elev.<name>": ...,
            "pipe.<name>": ...}`` on top of the recording's scenario tables.

    Returns:
        The report (DESIGN.md "Results"), as :func:`fogsim.report.build_report` makes it.
    """
    from fogsim.report import build_report

    result = run_frames(
        recording.frames,
        recording.truth_at if recording.has_truth else None,
        recording.scenario,
        params=resolve_params(recording.scenario, overrides),
    )
    return build_report(result, recording.scenario, source="replay")
