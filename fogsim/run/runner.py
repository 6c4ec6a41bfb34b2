"""Run frames through the pipeline and score them: what ``fogsim run`` and ``--replay`` do."""

from __future__ import annotations

import dataclasses
import os
import time
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from fogsim.config.params import RunParams, resolve_params
from fogsim.data.frame import Frame
from fogsim.errors import FogsimError
from fogsim.eval.report import build_report, write_report
from fogsim.eval.result import RunResult, Snapshot
from fogsim.eval.scoring import EventTracker, TruthProvider, WorldArchive, score_archive
from fogsim.mapping.pipeline import FrameCallback, Pipeline
from fogsim.sim.simulation import Simulation
from fogsim.viz.pictures import RunVideoWriter, write_pictures
from mapper import MapperParams
from mapper.segmentation import SegmentationParams
from mapper.transforms import planar_pose_to_matrix, rotation_angle_deg


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
        recording: A :class:`fogsim.data.recording.Recording`.
        overrides: ``{"p_occ": 0.7, "eps_m": 0.01, "seg.<name>": ..., "elev.<name>": ...,
            "pipe.<name>": ...}`` on top of the recording's scenario tables.

    Returns:
        The report (DESIGN.md "Results"), as :func:`fogsim.eval.report.build_report` makes it.
    """
    result = run_frames(
        recording.frames,
        recording.truth_at if recording.has_truth else None,
        recording.scenario,
        params=resolve_params(recording.scenario, overrides),
    )
    return build_report(result, recording.scenario, source="replay")


def run_scenario(
    scenario: Any,
    out_dir: str | os.PathLike[str] | None,
    *,
    replay: Any | None = None,
    pictures: bool = True,
    video: bool = False,
    progress: bool = False,
    max_frames: int | None = None,
    depth_backend: str = "renderer",
) -> dict:
    """Run one scenario end to end and write its results.

    Args:
        scenario: A loaded Scenario (overrides already applied).
        out_dir: Folder for ``report.json``, the PNGs (and ``run.mp4``); None = write nothing.
        replay: A Recording to feed instead of simulating (no MuJoCo).
        pictures: Write the PNGs.
        video: Write ``run.mp4`` (camera image beside the growing map).
        progress: Show a tqdm progress bar.
        max_frames: Stop after this many frames (the suite's quick mode).
        depth_backend: Simulation depth backend (``renderer`` or ``raycast``).

    Returns:
        The report dict.
    """
    start = time.perf_counter()
    params = resolve_params(scenario)  # bad parameters fail here, before any simulation
    if replay is not None:
        frames: Iterable[Any] = replay.frames
        truth_at = replay.truth_at if replay.has_truth else None
        times_s = [f.time_s for f in replay.frames]
        source = "replay"
    else:
        simulation = Simulation(scenario, depth_backend=depth_backend)
        frames = simulation.frames()
        truth_at = simulation.truth_at
        times_s = list(simulation.trajectory.times_s)
        source = "simulation"
    total = len(times_s)
    if max_frames is not None and total > max_frames:
        frames, total = _take(frames, max_frames), max_frames
    end_time_s = float(times_s[total - 1])

    callbacks: list[Callable[[Any, Any], None]] = []
    bar = None
    if progress:
        bar = tqdm(total=total, unit="frame", desc=getattr(scenario, "name", "run"))
        callbacks.append(lambda frame, pipeline: bar.update(1))
    writer = None
    if video and out_dir is not None:
        writer = RunVideoWriter(Path(out_dir) / "run.mp4", fps=scenario.frame_rate_hz)
        callbacks.append(writer.add)
    try:
        result = run_frames(
            frames,
            truth_at,
            scenario,
            params=params,
            end_time_s=end_time_s,
            on_frame=(lambda f, p: [cb(f, p) for cb in callbacks]) if callbacks else None,
        )
    finally:
        if bar is not None:
            bar.close()
        if writer is not None:
            writer.close()
    wall_s = time.perf_counter() - start
    report = build_report(
        result,
        scenario,
        source=source,
        wall_s=wall_s,
        duration_s=result.frames / scenario.frame_rate_hz if scenario is not None else None,
    )
    if out_dir is not None:
        out = Path(out_dir)
        if pictures:
            picture_start = time.perf_counter()
            report["pictures"] = [p.name for p in write_pictures(result, scenario, out)]
            report["timing"]["pictures_s"] = round(time.perf_counter() - picture_start, 3)
        if writer is not None:
            report["video"] = writer.path.name
        write_report(out / "report.json", report)
    return report


def _take(frames: Iterable[Any], count: int) -> Iterable[Any]:
    for i, frame in enumerate(frames):
        if i >= count:
            return
        yield frame
