"""Run frames through the pipeline and score them: what ``fogsim run`` and ``--replay`` do.

:func:`run_scenario` does one run end to end: frames from a simulation or a recording →
:func:`run_frames` (pipeline and scoring) → the typed report → ``maps.npz``, ``frames.csv`` →
pictures → ``report.json`` → ``manifest.json``, all into a temporary folder that is renamed
into place at the end (:class:`~fogsim.run.run_folder.RunFolder`).
"""

from __future__ import annotations

import dataclasses
import os
import sys
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from contextlib import ExitStack, closing
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from fogsim.config import RunParams, Scenario, resolve_params
from fogsim.data.frame import Frame
from fogsim.data.recording import Recording
from fogsim.errors import FogsimError
from fogsim.eval.archive import InView, WorldArchive, cells_in_view, view_points_world
from fogsim.eval.events import EventTracker, TruthProvider
from fogsim.eval.frame_log import FrameLog, write_frame_log
from fogsim.eval.maps import write_maps
from fogsim.eval.metrics import score_archive
from fogsim.eval.pose_error import PoseErrorAccumulator, pose_error_stats
from fogsim.eval.report import Report, build_report, write_report
from fogsim.eval.report.schema import Source
from fogsim.eval.result import RunResult, Snapshot
from fogsim.mapping.pipeline import FrameCallback, FrameTiming, Pipeline
from fogsim.mapping.prefetch import SegmentAhead
from fogsim.mapping.segment_process import SegmentInProcess, can_segment_in_process
from fogsim.mapping.segmenter import FrameSegmenter, SegmentFunction
from fogsim.robot.description import load_description
from fogsim.run.run_folder import RunFolder
from fogsim.run.warmup import KernelWarmUp, install_shipped_kernels
from fogsim.sim.background import AHEAD_FRAMES, BackgroundSimulation, frames_ahead
from fogsim.sim.camera.noise_model import heading_noise_fields, segmentation_noise_fields
from fogsim.viz.forked import ForkedCall
from fogsim.world.truth import TruthParams
from mapper import MapperParams
from mapper.grid import GridGeometry
from mapper.reference import NECK_FIELDS
from mapper.segmentation import SegmentationParams, segment_depth

if TYPE_CHECKING:
    from fogsim.sim.simulation import Simulation
    from fogsim.sim.third_person import FilmedSimulation
    from fogsim.viz.video import RunVideoWriter


class _Fig5Snapshots:
    """Keeps both maps of the last frame before the first event and of the last frame (Fig. 5)."""

    def __init__(self, first_event_s: float) -> None:
        self.first_event_s = first_event_s
        self._before: Snapshot | None = None
        self._previous: Snapshot | None = None

    def add(
        self,
        frame: Frame,
        centers_xy: NDArray[np.float64],
        fog_types: NDArray[np.int8],
        fog_heights_m: NDArray[np.float64],
        baseline_heights_m: NDArray[np.float64],
    ) -> None:
        """Copy this frame's maps; the previous frame's become "before" at the first event."""
        current = Snapshot(
            "before",
            frame.index,
            frame.time_s,
            centers_xy.copy(),
            fog_types.copy(),
            fog_heights_m.copy(),
            baseline_heights_m.copy(),
            np.array(frame.depth_m, copy=True),
        )
        if frame.time_s >= self.first_event_s and self._before is None:
            self._before = self._previous
        self._previous = current

    def snapshots(self) -> tuple[Snapshot, ...]:
        """("before", "after"), or nothing if the run has no frame before the first event."""
        if self._before is None or self._previous is None:
            return ()
        return (self._before, dataclasses.replace(self._previous, label="after"))


def truth_params(scenario: Scenario | None, mapper_params: MapperParams) -> TruthParams:
    """The ground truth's rules for this run: the robot's foot and the mapper's grid top.

    Args:
        scenario: The scenario (its robot's ``[feet]`` give the foot); None: the truth's default
            foot (recordings without a scenario).
        mapper_params: The mapper's parameters (things above its ``z_max_m`` are out of its
            grid).
    """
    grid_top_m = mapper_params.z_max_m
    if scenario is None:
        return TruthParams(grid_top_m=grid_top_m)
    feet = load_description(scenario.robot.model).feet
    back_m, front_m = feet.length_m
    return TruthParams(
        foot_length_m=front_m - back_m,
        foot_width_m=2.0 * feet.half_width_m,
        grid_top_m=grid_top_m,
    )


def run_frames(
    frames: Iterable[Frame],
    truth_provider: TruthProvider | None,
    scenario: Scenario | None,
    mapper_params: MapperParams | None = None,
    segmentation_params: SegmentationParams | None = None,
    *,
    params: RunParams | None = None,
    on_frame: FrameCallback | None = None,
    segment: SegmentFunction = segment_depth,
    segment_ahead: bool = True,
    in_view: InView = cells_in_view,
    segment_process: bool = False,
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
        on_frame: Called after every frame with the frame and the pipeline (progress bars,
            video).
        segment: The pipeline's segmentation (:class:`~fogsim.mapping.pipeline.Pipeline`).
        segment_ahead: Segment the frames and filter their tilt on a second thread ahead of
            the mapping (:class:`~fogsim.mapping.prefetch.SegmentAhead`: the same results, the
            two overlapped); False: in line.
        in_view: The cells of a grid a frame saw (:func:`~fogsim.eval.archive.cells_in_view`,
            or a cache in front of it: ``fogsim tune``).
        segment_process: With ``segment_ahead``, segment in a forked process instead of a
            thread (:class:`~fogsim.mapping.segment_process.SegmentInProcess`: the same
            results, no GIL shared with the mapping) when ``frames`` is a sequence and a fork
            is safe (:func:`~fogsim.mapping.segment_process.can_segment_in_process`); else
            on a thread. ``fogsim run --replay`` does.

    Raises:
        FogsimError: No frames.
    """
    start = time.perf_counter()
    run_params = params or resolve_params(scenario, sensor=sensor_fields(scenario))
    if mapper_params is not None:
        run_params = dataclasses.replace(run_params, mapper=mapper_params)
    if segmentation_params is not None:
        run_params = dataclasses.replace(run_params, segmentation=segmentation_params)
    if not segment_ahead:
        pipeline = Pipeline(run_params, segment)
        return _run_pipeline(
            frames, None, pipeline, truth_provider, scenario, run_params, on_frame, start, in_view
        )
    segmenter = FrameSegmenter(run_params, segment)
    if segment_process and isinstance(frames, Sequence) and can_segment_in_process():
        with SegmentInProcess(
            frames, segmenter, ahead=_frames_ahead(frames, scenario), also=view_points_world
        ) as forked:
            forked.start()
            pipeline = Pipeline(run_params, segmented=forked.segmented)
            return _run_pipeline(
                forked,
                forked,
                pipeline,
                truth_provider,
                scenario,
                run_params,
                on_frame,
                start,
                in_view,
            )
    # The frames' world points for the cells in view are made on the thread too.
    ahead_frames = _frames_ahead(frames, scenario)
    with SegmentAhead(frames, segmenter, ahead=ahead_frames, also=view_points_world) as ahead:
        pipeline = Pipeline(run_params, segmented=ahead.segmented)
        ahead.start()
        return _run_pipeline(
            ahead, ahead, pipeline, truth_provider, scenario, run_params, on_frame, start, in_view
        )


def _frames_ahead(frames: Iterable[Frame], scenario: Scenario | None) -> int:
    """Frames a run's stages may work ahead (`fogsim.sim.background.frames_ahead`).

    Sized by the first frame's depth image when the frames are a sequence (a recording), else
    by the scenario's camera (a simulation), else the fewest (real data streamed in).
    """
    if isinstance(frames, Sequence) and len(frames):
        return frames_ahead(int(np.asarray(frames[0].depth_m).size))
    if scenario is not None:
        return frames_ahead(scenario.camera.width * scenario.camera.height)
    return AHEAD_FRAMES


def _run_pipeline(
    frames: Iterable[Frame],
    ahead: SegmentAhead | SegmentInProcess | None,
    pipeline: Pipeline,
    truth_provider: TruthProvider | None,
    scenario: Scenario | None,
    run_params: RunParams,
    on_frame: FrameCallback | None,
    start: float,
    in_view: InView = cells_in_view,
) -> RunResult:
    """The frame loop and scoring of :func:`run_frames` (``ahead``: ``frames`` segmented ahead)."""
    cell_m = pipeline.mapper_params.cell_m
    events = scenario.events if scenario is not None else ()
    tracker = None
    if truth_provider is not None and events:
        tracker = EventTracker(
            events, truth_provider, tolerance_m=pipeline.params.event_tolerance_m
        )
    fig5 = _Fig5Snapshots(min(float(e.at) for e in events)) if events else None

    archive = WorldArchive(cell_m)
    archiver = _GridArchiver(archive)
    pose_errors = PoseErrorAccumulator()
    timings: list[FrameTiming] = []
    indices: list[int] = []
    times_s: list[float] = []
    last: Frame | None = None
    for frame in frames:
        if not pipeline.keeps_grid(frame):
            archiver.keep(pipeline)
        timing = pipeline.process(frame)
        if ahead is not None:  # the segmentation's own time, not the wait for it
            timing = dataclasses.replace(timing, segmentation_ms=ahead.segmentation_ms)
        timings.append(timing)
        indices.append(frame.index)
        times_s.append(frame.time_s)
        pose_errors.add(frame, pipeline.heading.transform_camera_to_robot)
        geometry = pipeline.mapper.geometry
        made = ahead.also(frame) if ahead is not None else None  # on the segmentation thread
        points_world = made if isinstance(made, np.ndarray) else None
        seen = in_view(frame, geometry, points_world)
        for late_frame in pipeline.mapped_now:  # frames mapped (again) with this one
            seen = seen | in_view(late_frame, geometry)
        archiver.add(geometry, seen)
        if tracker is not None or fig5 is not None:  # the maps, every cell's centre: for these
            types, fog_heights, base_heights = pipeline.maps()
            centers = pipeline.cell_centers_xy()
        if tracker is not None:
            tracker.update(
                frame.index, frame.time_s, centers, cell_m, types, fog_heights, base_heights
            )
        if fig5 is not None:
            fig5.add(frame, centers, types, fog_heights, base_heights)
        if on_frame is not None:
            on_frame(frame, pipeline)
        last = frame
    if last is None:
        raise FogsimError("run_frames got no frames")
    archiver.keep(pipeline)
    flushed = pipeline.finish()  # frames still waiting for the height reference
    if flushed:
        geometry = pipeline.mapper.geometry
        seen = np.logical_or.reduce([in_view(f, geometry) for f in flushed])
        archiver.add(geometry, seen)
    archiver.flush(pipeline)

    for late in pipeline.mapped_late:  # deferred frames: withdrawn when seen, mapped later
        pose_errors.remapped(late.position, late.transform_camera_to_robot)
        timings[late.position] = dataclasses.replace(
            timings[late.position],
            withdrawn=late.withdrawn,
            z_matched=late.z_matched,
            update_ms=late.update_ms,
        )
    scores = final_truth = None
    if truth_provider is not None:
        truth = truth_provider(last.time_s)
        rules = truth_params(scenario, pipeline.mapper_params)
        final_truth = truth.rasterize(archive.cell_centers_xy(), cell_m, params=rules)
        scores = score_archive(archive, truth, final_truth, pipeline.mapper_params.layer_m)
    frame_errors = pose_errors.per_frame()
    return RunResult(
        frames=len(timings),
        withdrawn=sum(t.withdrawn for t in timings),
        z_matched=sum(t.z_matched for t in timings),
        frames_without_ground_plane=sum(not t.ground_plane_found for t in timings),
        update_ms=np.array([t.update_ms for t in timings]),
        segmentation_ms=np.array([t.segmentation_ms for t in timings]),
        frame_ms=np.array([t.frame_ms for t in timings]),
        wall_s=time.perf_counter() - start,
        mapper=pipeline.mapper,
        baseline=pipeline.baseline,
        archive=archive,
        scores=scores,
        events=tracker.results() if tracker is not None else (),
        pose_error=pose_error_stats(frame_errors),
        params=run_params,
        snapshots=fig5.snapshots() if fig5 is not None else (),
        final_truth=final_truth,
        last_depth_m=last.depth_m,
        frame_log=FrameLog(
            frame=np.array(indices, dtype=np.int64),
            time_s=np.array(times_s, dtype=np.float64),
            withdrawn=np.array([t.withdrawn for t in timings], dtype=bool),
            z_matched=np.array([t.z_matched for t in timings], dtype=bool),
            ground_plane_found=np.array([t.ground_plane_found for t in timings], dtype=bool),
            pose=frame_errors,
        ),
    )


class _GridArchiver:
    """Stores a run's maps in its scoring archive once per place of the grid.

    The archive keeps each cell's last value (:class:`~fogsim.eval.archive.WorldArchive`), and
    the grid moves only when the robot has walked a whole cell (the stage: 116 moves in 832
    frames). The run calls :meth:`keep` before a frame that may move the grid
    (``Pipeline.keeps_grid``) and :meth:`add` after every frame; when the grid has moved, the
    maps kept before that frame, the last ones at the old place, are stored with the cells seen
    there; :meth:`flush` stores the last place's. The archive is the one storing every frame
    would leave, bit for bit: a cell's last value is that of the last frame whose grid held it,
    which is the last frame at that place of the grid; the cells seen are added up over the
    frames at one place (a union, in any order), and the bounding box grows through the same
    places in the same order. The maps are read only when they may be the last at a place (the
    stage: before about 120 of 832 frames), as the pipeline's own copies (``Pipeline.maps()``,
    ``floor()``, ``obstacle()``, ``ceiling()``: fresh arrays).
    """

    def __init__(self, archive: WorldArchive) -> None:
        self._archive = archive
        self._geometry: GridGeometry | None = None
        self._in_view: NDArray[np.bool_] | None = None
        self._kept: dict[str, NDArray[np.generic]] | None = None

    def keep(self, pipeline: Pipeline) -> None:
        """Keep the pipeline's maps now (before a frame that may move the grid)."""
        if self._geometry is None:  # nothing mapped yet
            return
        types, fog_heights, base_heights = pipeline.maps()
        self._kept = {
            "fog_types": types,
            "fog_heights_m": fog_heights,
            "baseline_heights_m": base_heights,
            "floor_m": pipeline.mapper.floor(),
            "obstacle_m": pipeline.mapper.obstacle(),
            "ceiling_m": pipeline.mapper.ceiling(),
        }

    def add(self, geometry: GridGeometry, in_view: NDArray[np.bool_]) -> None:
        """After a frame: the grid's geometry now and the cells the frame saw there."""
        if geometry != self._geometry:
            self._store()
            self._in_view = in_view
        else:
            assert self._in_view is not None
            self._in_view = self._in_view | in_view
            self._kept = None  # this frame changed the maps at this place: no longer the last
        self._geometry = geometry

    def flush(self, pipeline: Pipeline) -> None:
        """Store the last place's maps, as they are now (after the run's last frame)."""
        self.keep(pipeline)
        self._store()
        self._geometry = None

    def _store(self) -> None:
        """Store the maps kept at the current place with the cells seen there (if any)."""
        if self._geometry is None:
            return
        # The run keeps the maps before every frame that may move the grid (class doc).
        assert self._kept is not None and self._in_view is not None
        self._archive.store_grid(
            self._geometry.cell_center(0, 0), **self._kept, in_view=self._in_view
        )
        self._kept = None


def sensor_fields(scenario: Scenario | None) -> dict[str, float | int]:
    """The parameters the scenario's head sets (none without a scenario).

    The segmentation's noise model of its camera, the heading's (``head.``,
    `heading_noise_fields`), and for the height reference (``ref.``) where the robot's neck
    turns the head (`fogsim.robot.description.NeckDescription.pivot_in_camera_m`). Passed to
    :func:`~fogsim.config.resolve_params` as ``sensor``: the scenario's tables and overrides
    still take precedence.
    """
    if scenario is None:
        return {}
    description = load_description(scenario.robot.model)
    noise = segmentation_noise_fields(scenario.camera, description.camera.stereo_baseline_m)
    noise |= heading_noise_fields(scenario.camera)
    neck = description.neck.pivot_in_camera_m
    return noise | {f"ref.{name}": value for name, value in zip(NECK_FIELDS, neck, strict=True)}


def replay_report(
    recording: Recording,
    overrides: Mapping[str, float] | None = None,
    segment: SegmentFunction = segment_depth,
    *,
    segment_ahead: bool = True,
    in_view: InView = cells_in_view,
) -> Report:
    """Replay a recording with parameter overrides and return its report (no pictures).

    Args:
        recording: The recording.
        overrides: ``{"p_occ": 0.7, "eps_m": 0.01, "seg.<name>": ..., "elev.<name>": ...,
            "pipe.<name>": ...}`` on top of the recording's scenario tables.
        segment: The pipeline's segmentation (``fogsim tune`` passes a cache in front of it).
        segment_ahead: Segment on a second thread ahead of the mapping (:func:`run_frames`);
            ``fogsim tune`` turns it off: its worker processes already keep every core busy.
        in_view: The cells of a grid a frame saw (:func:`run_frames`).
    """
    install_shipped_kernels()
    result = run_frames(
        recording.frames,
        recording.truth_at if recording.has_truth else None,
        recording.scenario,
        params=resolve_params(recording.scenario, overrides, sensor_fields(recording.scenario)),
        segment=segment,
        segment_ahead=segment_ahead,
        in_view=in_view,
    )
    return build_report(result, recording.scenario, source="replay")


@dataclass(frozen=True)
class _FrameSource:
    """Where a run's frames come from.

    Attributes:
        frames: The frames (a :class:`BackgroundSimulation` for a simulation).
        truth_at: Ground truth at a time [s]; None for real data.
        frame_count: Frames the run will take (a simulation's waits for its set-up).
        kind: ``simulation`` or ``replay``.
        take_picture: Hands over frame i's third-person picture (only when a video is asked
            for); None for a replay.
    """

    frames: Iterable[Frame]
    truth_at: TruthProvider | None
    frame_count: Callable[[], int]
    kind: Source
    take_picture: Callable[[int], NDArray[np.uint8]] | None = None


def _frame_source(
    scenario: Scenario | None,
    replay: Recording | None,
    depth_backend: str,
    max_frames: int | None,
    cleanup: ExitStack,
    video: bool = False,
) -> _FrameSource:
    """The recording's frames, or a simulation of the scenario; cut after ``max_frames``.

    A simulation starts on its own thread at once (set-up included) and is stopped by
    ``cleanup``; its frames are mapped while the next ones are simulated. With ``video`` it
    also renders the third-person view of every frame (on its thread, where its OpenGL
    context lives).
    """
    if replay is not None:
        count = len(replay.frames) if max_frames is None else min(max_frames, len(replay.frames))
        return _FrameSource(
            replay.frames[:count],
            replay.truth_at if replay.has_truth else None,
            lambda: count,
            "replay",
        )
    if scenario is None:
        raise FogsimError("a run needs a scenario to simulate or a recording to replay")

    def make_simulation() -> Simulation | FilmedSimulation:
        # MuJoCo and the robot's kinematics: imported by a simulated run only, never by a
        # replay, and on the simulation's thread, while this one warms the kernels up.
        from fogsim.sim.simulation import Simulation
        from fogsim.sim.third_person import FilmedSimulation

        simulation = Simulation(scenario, depth_backend=depth_backend)
        return FilmedSimulation(simulation) if video else simulation

    background = cleanup.enter_context(
        BackgroundSimulation(
            make_simulation, max_frames=max_frames, ahead=_frames_ahead((), scenario)
        )
    )
    take_picture = None
    if video:

        def take_picture(index: int) -> NDArray[np.uint8]:
            from fogsim.sim.third_person import FilmedSimulation  # make_simulation's

            filmed = background.simulation
            assert isinstance(filmed, FilmedSimulation)
            return filmed.camera.take(index)

    return _FrameSource(
        background,
        background.truth_at,
        lambda: background.frame_count,
        "simulation",
        take_picture,
    )


def run_scenario(
    scenario: Scenario | None,
    out_dir: str | os.PathLike[str] | None,
    *,
    replay: Recording | None = None,
    pictures: bool = True,
    video: bool = False,
    progress: bool = False,
    max_frames: int | None = None,
    depth_backend: str = "renderer",
    mcap: Path | None = None,
    rerun: Path | None = None,
    rerun_spawn: bool = False,
) -> Report:
    """Run one scenario end to end and write its results.

    Args:
        scenario: A loaded Scenario (overrides already applied); None only with a
            recording of real data.
        out_dir: Folder for ``report.json``, ``maps.npz``, the PNGs (and ``run.mp4``), written
            whole (:class:`~fogsim.run.run_folder.RunFolder`: checked before the run, written
            into a temporary folder with ``manifest.json`` last, renamed into place); None =
            write nothing.
        replay: A Recording to feed instead of simulating (no MuJoCo).
        pictures: Write the PNGs.
        video: Write ``run.mp4`` (camera image beside the growing map).
        progress: Show a tqdm progress bar. Either way the kernels are compiled before the
            first frame (:class:`~fogsim.run.warmup.KernelWarmUp`; with ``progress`` a
            message on standard error when numba's cache is cold).
        max_frames: Stop after this many frames (the suite's quick mode).
        depth_backend: Simulation depth backend (``renderer`` or ``raycast``).
        mcap: Also write every frame's FOG and robot pose as a rosbag2 bag in MCAP storage
            there (:class:`~fogsim.bags.write.McapMapWriter`, renamed into place at the end).
        rerun: Also write this Rerun ``.rrd`` file (:class:`~fogsim.viz.rerun_log.RerunLogger`;
            needs the ``viewer`` extra), whether or not ``out_dir`` is given.
        rerun_spawn: Instead of a file, log live into a Rerun viewer spawned now (needs a
            display).

    Returns:
        The report, with the pictures and the video it wrote.

    Raises:
        OutputError: ``out_dir`` cannot be written (found before the run) or writing failed
            (nothing of the run is left, an earlier result there is unchanged).
    """
    start = time.perf_counter()
    # Bad parameters fail here, before any simulation.
    params = resolve_params(scenario, sensor=sensor_fields(scenario))
    options = _RunOptions(
        replay, pictures, video, progress, max_frames, depth_backend, mcap, rerun, rerun_spawn
    )
    if out_dir is None:
        return _run_and_write(scenario, params, None, options, start)
    with RunFolder(out_dir) as folder:
        report = _run_and_write(scenario, params, folder.path, options, start)
        folder.commit(
            "run",
            scenario=scenario.name if scenario is not None else None,
            seed=scenario.seed if scenario is not None else None,
        )
    return report


@dataclass(frozen=True)
class _RunOptions:
    """The options of :func:`run_scenario` (see there)."""

    replay: Recording | None
    pictures: bool
    video: bool
    progress: bool
    max_frames: int | None
    depth_backend: str
    mcap: Path | None
    rerun: Path | None
    rerun_spawn: bool


def _run_and_write(
    scenario: Scenario | None,
    params: RunParams,
    out: Path | None,
    options: _RunOptions,
    start: float,
) -> Report:
    """Run the frames and write the results into ``out`` (None: write nothing).

    The pictures are drawn by a process forked before the run
    (:class:`~fogsim.viz.forked.ForkedCall`, :func:`_draw_pictures`): it imports matplotlib
    while the frames are mapped and draws while this process builds the report and writes
    ``maps.npz``; ``pictures_s`` is the time from handing it the result to its last picture.
    """
    with ExitStack() as drawing:
        painter = None
        if options.pictures and out is not None:  # forked now: before the run's threads
            painter = drawing.enter_context(
                ForkedCall(_draw_pictures, prepare=_import_pictures, what="the picture process")
            )
        result, kind, writer = _run_frames_into(scenario, params, out, options)
        picture_start = time.perf_counter()
        if painter is not None:
            painter.submit(result, scenario, out)
        report = build_report(
            result,
            scenario,
            source=kind,
            wall_s=time.perf_counter() - start,
            duration_s=result.frames / scenario.frame_rate_hz if scenario is not None else None,
        )
        if out is None:
            return report
        write_maps(out / "maps.npz", result, result.final_truth)
        if result.frame_log is not None:
            write_frame_log(out / "frames.csv", result.frame_log)
        if painter is not None:
            names = tuple(path.name for path in painter.result())
            timing = dataclasses.replace(
                report.timing, pictures_s=round(time.perf_counter() - picture_start, 3)
            )
            report = dataclasses.replace(report, pictures=names, timing=timing)
    if writer is not None:
        report = dataclasses.replace(
            report, video=writer.path.name, video_codec=writer.codec.describe()
        )
    write_report(out / "report.json", report)
    return report


def _run_frames_into(
    scenario: Scenario | None, params: RunParams, out: Path | None, options: _RunOptions
) -> tuple[RunResult, Source, RunVideoWriter | None]:
    """The run's frames through :func:`run_frames`: the result, the frames' source, the video.

    The video, bag and Rerun recording asked for are written on the way.
    """
    video = options.video and out is not None
    callbacks: list[FrameCallback] = []
    writer = None
    with ExitStack() as cleanup:
        # Compiled (or loaded) now, while the simulation sets up, not in frame 1 (in two
        # processes when numba's cache is cold, saying so with the bar): the bar's rate then
        # measures frames only. Begun before the simulation's thread starts: a cold cache's
        # helper process is forked then.
        warm_up = cleanup.enter_context(
            KernelWarmUp(
                params, sys.stderr if options.progress else None, simulated=options.replay is None
            )
        )
        source = _frame_source(
            scenario, options.replay, options.depth_backend, options.max_frames, cleanup, video
        )
        warm_up.finish()
        if options.progress:
            from fogsim.run.progress import FrameProgress  # tqdm: only for the progress bar

            name = scenario.name if scenario is not None else "run"
            bar = cleanup.enter_context(closing(FrameProgress(source.frame_count(), name)))
            callbacks.append(lambda frame, pipeline: bar.update())
        if video:
            from fogsim.viz.video import RunVideoWriter  # cv2, matplotlib: only for a video

            if scenario is None:
                raise FogsimError(
                    "--video needs the scenario's frame rate; this recording has none"
                )
            assert out is not None
            writer = RunVideoWriter(
                out / "run.mp4", fps=scenario.frame_rate_hz, third_person=source.take_picture
            )
            cleanup.callback(writer.close)
            callbacks.append(writer.add)
        if options.mcap is not None:
            from fogsim.bags.write import McapMapWriter  # rosbags: only for a bag

            callbacks.append(cleanup.enter_context(McapMapWriter(options.mcap)).add)
        if options.rerun is not None or options.rerun_spawn:
            from fogsim.viz.rerun_log import RerunLogger  # matplotlib: only for Rerun

            run_id = f"{scenario.name}-seed{scenario.seed}" if scenario is not None else "run"
            logger = RerunLogger(options.rerun, run_id, source.truth_at, spawn=options.rerun_spawn)
            callbacks.append(cleanup.enter_context(logger).add)
        result = run_frames(
            source.frames,
            source.truth_at,
            scenario,
            params=params,
            on_frame=_all_of(callbacks) if callbacks else None,
            segment_process=source.kind == "replay",
        )
    return result, source.kind, writer


def _import_pictures() -> None:
    """Import the picture modules (matplotlib): the picture process's preparation."""
    import fogsim.viz.pictures  # noqa: F401


def _draw_pictures(result: RunResult, scenario: Scenario | None, out_dir: Path) -> list[Path]:
    """:func:`write_pictures` as the picture process calls it (looked up when it is called)."""
    return write_pictures(result, scenario, out_dir)


def write_pictures(
    result: RunResult, scenario: Scenario | None, out_dir: str | os.PathLike[str]
) -> list[Path]:
    """The run's PNGs: :func:`fogsim.viz.pictures.write_pictures`, imported on the first call.

    matplotlib is imported only by runs that draw pictures.
    """
    from fogsim.viz import pictures

    return pictures.write_pictures(result, scenario, out_dir)


def _all_of(callbacks: list[FrameCallback]) -> FrameCallback:
    """One frame callback that calls each of ``callbacks`` in order."""

    def call(frame: Frame, pipeline: Pipeline) -> None:
        for callback in callbacks:
            callback(frame, pipeline)

    return call
