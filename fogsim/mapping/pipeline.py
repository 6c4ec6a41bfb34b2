"""The per-frame pipeline: depth image → segmentation → world points → z-shift → maps.

Per frame (paper Fig. 1, 2 and Sec. IV), with the pose the robot *believes*:

1. ``segment_depth`` labels the (already self-filtered) depth image: points in the robot frame
   R with the height ``h`` of the horizontal plane each belongs to (NaN = not floor), after the
   segmentation's own rotation correction (and, with ``pipe.use_height_reference`` off, its
   per-frame ground-plane shift); the tilt filtered over the frames replaces that rotation
   (``pipe.use_tilt_filter``). Both depend on the frames alone
   (:class:`~fogsim.mapping.segmenter.FrameSegmenter`: a run does them on a second thread).
2. Height reference (``mapper.reference``, issue 11): the camera height error is estimated over
   frames from the ground under the feet and its shift added to every frame's z (a frame whose
   own ground measurement agrees with the estimate takes its own: its ground then lies exactly
   at the feet's height, whatever the encoders' noise did to this frame's camera). Frames
   segmented before it is known are *deferred*, then mapped in order (steps 3-8) with the
   converged shift just before the frame that makes it known (the first time, known also
   means precise: ``ref.known_error_m``, at the start level ``ref.start_known_error_m``;
   every later frame is anchored to what the deferred frames made of the ground, so their
   shift is the map's offset): the start pose's exact odometry,
   not one frame's ground fragment, anchors the map, also when the start surface is out of view.
   The robot then stands on the ground it measured; how the height at which the first frames
   saw that surface changes over the way walked gives odometry's z drift since the start
   (``mapper.reference.arrival_drift_m``; still at the start level, odometry's change), taken out of
   the deferred frames (growing from 0 at the start) and, through the elevation filter's offset,
   of the frames after them (walking down, the drift otherwise went into the map: stage_down).
3. Heading correction (``mapper.HeadingEstimator``, beyond the paper): the camera's yaw error,
   estimated from how well the structure seen from different places agrees, is taken out by a
   rotation about the vertical through the camera centre. The estimator takes its keyframes
   when a frame is segmented; when its first estimate comes, both maps are rebuilt from the
   frames mapped before it (``pipe.heading_rebuild_frames``), with it, and (when
   ``pipe.heading_rebuild_change_deg`` is set; off by default) again when a later estimate
   moves more than that from the one they were rebuilt with while no more than that many
   frames have been mapped, or (``pipe.heading_rebuild_on_structure``) when the structure
   score's first estimate replaces the edge score's stand-in they were rebuilt with.
4. Points and heights go to the world with the believed robot pose (x, y, yaw from odometry,
   z from the *elevation filter* below): ``h_G = h_R + z_R``.
5. The grids follow the robot: both maps ``recenter`` on the believed (x, y).
6. z-shift matching against the floor map (``match_z``): an accepted shift is added to the
   points' z, their floor heights and the camera origin. If it is not accepted (few pairs or an
   implausible shift) and the segmentation found no ground plane either, the frame is
   *withdrawn* (Sec. IV); otherwise the unshifted data are used. The anchor rule: a frame
   shifted by its own measurement of the height reference (it agrees with the estimate,
   ``ref.frame_gate_m``: its data are right relative to the feet) is shifted only by up to
   ``pipe.anchor_shift_m`` (the odometry's drift: the map anchored at the start holds); a
   larger shift is the robot's elevation error and goes to the elevation filter (shifting every
   such frame onto the map let the map drift by about −3 mm over a stage run). A frame whose
   measurement disagrees was shifted by the estimate, not by its own ground, and is z-matched
   as any other (stereo: keeping it unshifted put its measurement's ±10 mm scatter into the map).
   When its own measurement shifted it and the first frames saw a surface at the robot's
   elevation (``ref.surface_gate_m``; the surface the feet stood on at the start is at the start
   pose's z), the robot stands on that surface: its elevation is set
   to the surface's height from the start and the frame is not z-matched (the filter's lag
   behind odometry went into the map ahead and came back: stairs s7, the ground 2 mm low).
7. ``FloorObstacleMapper.update`` and ``AveragingMap.update`` get exactly the same data.
8. Robot elevation filter (``mapper.RobotElevationFilter``): the offset on odometry's z is
   pulled towards ``Floor(x_R, y_R)`` when the floor map has a height under the robot.

Every frame is checked first: a believed robot pose or camera transform that is not finite or
lies beyond the world's limits, or a believed position that jumps more than
:data:`~fogsim.data.limits.MAX_POSE_STEP_M` from the previous frame's, raises
:class:`FrameError` naming the frame. Such a frame is an odometry failure or corrupt data, not
noise: skipping it would map the following frames in the same wrong place, and mapping it would
grow the maps and the scoring archive to the bounding box of the jump. Nothing is changed by a
refused frame.

Scoring is not done here: :func:`fogsim.run.runner.run_frames` hands every frame's maps to the
evaluation layer (:mod:`fogsim.eval`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from fogsim.config import RunParams
from fogsim.data.checks import pose_problem, step_problem, surely_plausible, transform_problem
from fogsim.data.frame import Frame
from fogsim.data.limits import MAX_CAMERA_OFFSET_M
from fogsim.errors import FrameError
from fogsim.mapping.segmenter import (
    FrameSegmenter,
    Segmented,
    SegmentFunction,
    pipeline_segmentation_params,
)
from mapper import (
    AveragingMap,
    FloorObstacleMapper,
    HeadingEstimator,
    RobotElevationFilter,
    ZDecision,
    frame_decision,
)
from mapper.limits import MAX_COORDINATE_M
from mapper.reference import HeightReference, arrival_drift_m, neck_prior_m, start_surface_m
from mapper.segmentation import SegmentationResult, segment_depth
from mapper.transforms import apply_transform, planar_pose_to_matrix

FrameCallback = Callable[[Frame, "Pipeline"], None]
"""Called after every frame with the frame and the pipeline (progress bars, video)."""

MAX_REBUILD_BYTES = 256 << 20
"""Most bytes of frame data kept for the heading's rebuilds (``pipe.heading_rebuild_frames``):
256 MiB. A kept frame holds its depth image, robot-frame points and floor heights, 226 KB at
88 × 72 (`Pipeline.rebuild_bytes`): the frame bound (1000) binds first there, while at 176 ×
144 (about 0.9 MB a frame) this one does, after about 290 frames. Beyond either bound nothing
more is kept and there is no more rebuild."""


@dataclass(frozen=True)
class FrameTiming:
    """What processing one frame took and decided.

    Attributes:
        segmentation_ms: Segmentation time [ms] (a lookup when the result was cached).
        update_ms: ``FloorObstacleMapper.update`` time [ms]; NaN when the frame was withdrawn.
        frame_ms: The whole frame [ms].
        withdrawn: The z-match rule withdrew the frame (no map update).
        z_matched: An accepted z shift was applied to the frame's data.
        ground_plane_found: The segmentation found the ground plane (Sec. IV).
    """

    segmentation_ms: float
    update_ms: float
    frame_ms: float
    withdrawn: bool
    z_matched: bool
    ground_plane_found: bool


@dataclass(frozen=True)
class LabelledPoints:
    """One frame's points as the maps received them (viewers, debugging).

    Attributes:
        points_world: (N, 3) world points [m], every correction and the z shift applied.
        floor_heights_m: (N,) world floor height of each point [m], NaN = not floor.
        withdrawn: The frame was withdrawn: the maps did not receive these points.
    """

    points_world: NDArray[np.float64]
    floor_heights_m: NDArray[np.float64]
    withdrawn: bool


@dataclass(frozen=True)
class _FrameData:
    """One segmented frame before the height reference's shift (mapped now or deferred).

    Attributes:
        frame: The frame (its believed poses).
        points_robot: (N, 3) tilt-corrected robot-frame points [m], no ground shift.
        floor_heights_m: (N,) their floor heights [m], NaN = not floor.
        transform_camera_to_robot: 4×4 tilt-corrected camera pose in the robot frame.
        ground_plane_found: The segmentation found a ground plane near the expected height.
        measured_shift_m: The frame's measurement of the height reference [m] (None: its
            ground was not in view).
        ground_sized_m: Heights of its floor regions large enough to be the ground around the
            robot, tilt-corrected robot frame, no shift [m] (empty without the reference).
        position: The frame's place in the run (0 = the first frame processed).
    """

    frame: Frame
    points_robot: NDArray[np.float64]
    floor_heights_m: NDArray[np.float64]
    transform_camera_to_robot: NDArray[np.float64]
    ground_plane_found: bool
    measured_shift_m: float | None
    ground_sized_m: NDArray[np.float64]
    position: int


@dataclass(frozen=True)
class LateMapping:
    """A deferred frame's outcome once it was mapped (its :class:`FrameTiming` said withdrawn).

    Attributes:
        position: The frame's place in the run (0 = the first frame processed).
        withdrawn: The z-match rule withdrew it after all.
        z_matched: An accepted z shift was applied to its data.
        update_ms: ``FloorObstacleMapper.update`` time [ms]; NaN when withdrawn.
        transform_camera_to_robot: 4×4 camera pose in the robot frame it was mapped with (the
            heading correction of that moment applied).
    """

    position: int
    withdrawn: bool
    z_matched: bool
    update_ms: float
    transform_camera_to_robot: NDArray[np.float64]


@dataclass(frozen=True)
class _MapJob:
    """A segmented frame waiting to be mapped, with what was decided when it was queued.

    The height reference's state moves on while frames wait for the heading: what it said of
    a frame is fixed when the frame is queued, so a frame is mapped as it would have been then.

    Attributes:
        data: The frame.
        shift_m: The height reference's shift of its data [m] (0 without the reference).
        agrees: Its own ground measurement agreed with the reference's estimate.
        use_z_match: z-match it (False: a frame deferred by the height reference).
        drift_m: Odometry's z drift at the frame, measured when the reference became known [m]
            (None: not measured; the elevation filter gives the robot's z).
        elevation_offset_m: Set the elevation filter's offset to this before mapping the frame
            [m] (the drift taken out of the frames after the deferred ones; None: leave it).
    """

    data: _FrameData
    shift_m: float
    agrees: bool
    use_z_match: bool
    drift_m: float | None
    elevation_offset_m: float | None


def _job_bytes(job: _MapJob) -> int:
    """Bytes of a queued frame's arrays: its depth image, points and floor heights."""
    data = job.data
    return data.frame.depth_m.nbytes + data.points_robot.nbytes + data.floor_heights_m.nbytes


class Pipeline:
    """Stateful per-frame processing: the two maps, the heading estimate, the elevation filter.

    Attributes:
        last_points: The last mapped frame's labelled points (None before the first, and while
            frames are deferred until the height reference is known).
        mapped_late: The outcomes of frames mapped after their :meth:`process` returned, in
            order: deferred frames, and frames mapped again when the maps were rebuilt with
            the heading's first estimate (a frame's last entry is its outcome).
        mapped_now: The frames mapped (again) by the last :meth:`process` before its own frame
            (the cells they saw count as seen at the grid's place now).
        on_restart: The ``on_restart`` argument (settable).

    Args:
        params: All parameters (defaults when None).
        segment: Segments a frame's depth image (:class:`~fogsim.mapping.segmenter.FrameSegmenter`
            calls it: the frame's depth, intrinsics, believed camera transform and the
            segmentation parameters, and nothing else).
        segmented: The frames' segmentations made elsewhere by a
            :class:`~fogsim.mapping.segmenter.FrameSegmenter` of the same ``params`` (a second
            thread's, :meth:`~fogsim.mapping.prefetch.SegmentAhead.segmented`), called with each
            frame processed, in order; None: a segmenter of this pipeline's with ``segment``.
        on_restart: Called with the new FOG mapper each time the maps start anew for a
            heading rebuild, before the frames mapped so far are mapped into it again (the
            comparison restarts its other maps there and listens to the new mapper).
    """

    def __init__(
        self,
        params: RunParams | None = None,
        segment: SegmentFunction = segment_depth,
        *,
        segmented: Segmented | None = None,
        on_restart: Callable[[FloorObstacleMapper], None] | None = None,
    ) -> None:
        self.run_params = params or RunParams()
        self._segmented = segmented or FrameSegmenter(self.run_params, segment)
        self.on_restart = on_restart
        self.mapper_params = self.run_params.mapper
        self.segmentation_params = pipeline_segmentation_params(self.run_params)
        self.params = self.run_params.pipeline
        self.mapper = FloorObstacleMapper(self.mapper_params)
        self.baseline = AveragingMap(self.mapper_params)
        self.elevation = RobotElevationFilter(self.run_params.elevation)
        self.heading = HeadingEstimator(self.run_params.heading)
        self.reference = HeightReference(self.run_params.reference)
        self._deferred: list[_FrameData] = []  # waiting for the height reference
        self._queue: list[_MapJob] = []  # to map at this frame
        # Every frame mapped so far, for the rebuilds with the heading's estimates (None: no
        # more rebuilds: off, or more than `heading_rebuild_frames` frames or
        # `MAX_REBUILD_BYTES` of them mapped).
        self._mapped: list[_MapJob] | None = (
            []
            if self.heading.params.correct_heading and self.params.heading_rebuild_frames > 0
            else None
        )
        self._mapped_bytes = 0  # the bytes of `_mapped`'s frame data (`rebuild_bytes`)
        self._rebuilt_rad: float | None = None  # the estimate the maps were rebuilt with
        self._rebuilt_from_edges = False  # ... and whether it was the edge score's
        self._processed = 0
        self.mapped_late: list[LateMapping] = []
        self.mapped_now: list[Frame] = []
        self._use_reference = self.params.use_height_reference
        self._last_pose_believed: NDArray[np.float64] | None = None
        self._start_z_m: float | None = None  # odometry's z of the first frame
        self._rise_m = 0.0  # odometry's z of this frame minus the start's
        # World heights of the ground-sized floors the first (deferred) frames saw, odometry's
        # drift taken out: where the robot stands when it measures the ground under its feet.
        self._start_surfaces_m: list[NDArray[np.float64]] = []
        self.last_points: LabelledPoints | None = None

    def check_frame(self, frame: Frame) -> None:
        """Refuse a frame whose believed pose is not finite, out of bounds or a jump.

        Raises:
            FrameError: Naming the frame, the value and what is allowed.
        """
        pose = np.asarray(frame.robot_pose_believed, dtype=np.float64)
        camera = np.asarray(frame.transform_camera_to_robot_believed, dtype=np.float64)
        if pose.shape != (4,) or camera.shape != (4, 4):
            raise FrameError(
                f"frame {frame.index}: robot_pose_believed must have shape (4,) and "
                f"transform_camera_to_robot_believed (4, 4), got {pose.shape} and {camera.shape}"
            )
        previous = self._last_pose_believed
        if surely_plausible(pose, camera, previous, max_translation_m=MAX_CAMERA_OFFSET_M):
            return
        poses = pose[None] if previous is None else np.stack([previous, pose])
        problems = (
            ("robot_pose_believed", pose_problem(pose[None])),
            (
                "transform_camera_to_robot_believed",
                transform_problem(camera[None], max_translation_m=MAX_CAMERA_OFFSET_M),
            ),
            ("robot_pose_believed", step_problem(poses)),
        )
        for key, problem in problems:
            if problem is not None:
                raise FrameError(f"frame {frame.index}: {key}: {problem.what}")

    def keeps_grid(self, frame: Frame) -> bool:
        """Whether :meth:`process` of ``frame`` will leave the grids where they are.

        True only when that is certain: the frame is mapped alone or not at all (the height
        reference is off or known and no frame waits for the heading, so none is mapped with
        it) and its believed (x, y), where the grids are centred, lies in their central cell
        already. False otherwise: the grids scroll, frames may be mapped with it, or its
        position is no coordinate (:meth:`process` refuses the frame).
        """
        if (self._use_reference and not self.reference.known) or self._queue:
            return False
        x_m, y_m = np.asarray(frame.robot_pose_believed, dtype=np.float64).reshape(-1)[:2]
        if not (abs(x_m) <= MAX_COORDINATE_M and abs(y_m) <= MAX_COORDINATE_M):  # NaN too
            return False
        return self.mapper.geometry.shift_to(float(x_m), float(y_m)) == (0, 0)

    def robot_pose(self, frame: Frame) -> NDArray[np.float64]:
        """Believed robot pose (x, y, z, yaw) with the elevation filter's z."""
        pose = np.asarray(frame.robot_pose_believed, dtype=np.float64).copy()
        if self.params.use_elevation_filter:
            pose[2] += self.elevation.offset_m
        return pose

    def process(self, frame: Frame) -> FrameTiming:
        """Run one frame through segmentation, z-match and both maps.

        With the height reference (``pipe.use_height_reference``) a frame segmented before the
        reference is known is *deferred*: its timing says withdrawn, and it is mapped, in
        order and with the converged reference, just before the frame that makes it known.
        The heading estimator learns from every frame when it is segmented (its keyframes
        depend on the pose and the points only). Frames are mapped at once with the heading
        correction of the moment; when its first estimate comes (after at most
        ``pipe.heading_rebuild_frames`` mapped frames), the maps are *rebuilt*: they start
        anew and every frame mapped so far is mapped again, in order and as it was decided
        then, with the estimate (until then frames carried the neck's yaw error). The outcomes
        of the frames mapped again are added to :attr:`mapped_late`.

        Raises:
            FrameError: The frame's believed pose is refused (:meth:`check_frame`).
        """
        t0 = time.perf_counter()
        self.check_frame(frame)
        self._last_pose_believed = np.asarray(frame.robot_pose_believed, dtype=np.float64)
        if self._start_z_m is None:
            self._start_z_m = float(self._last_pose_believed[2])
        self._rise_m = float(self._last_pose_believed[2]) - self._start_z_m
        seg = self._segmented(frame)
        t1 = time.perf_counter()
        data = _FrameData(
            frame,
            np.asarray(seg.points, dtype=np.float64),
            np.asarray(seg.floor_heights, dtype=np.float64),
            np.asarray(seg.transform_camera_to_robot, dtype=np.float64),
            bool(seg.correction.ground_plane_found),
            self._measure_reference(seg),
            self._ground_sized_m(seg),
            self._processed,
        )
        self._processed += 1
        self._observe_heading(data, seg.structure_border)
        if self._use_reference and not self.reference.known:
            self._deferred.append(data)
        else:
            offset_m = self._queue_deferred(arrival=data)
            self._queue.append(self._job(data, elevation_offset_m=offset_m))
        withdrawn, matched, update_ms = True, False, float("nan")
        if self._queue:
            *earlier, (mapped, outcome) = self._map_queue()
            assert mapped is data  # the queue ends with the frame just queued
            self._record_late(earlier)
            self.mapped_now = [late.frame for late, _ in earlier]
            withdrawn, matched, update_ms = outcome.withdrawn, outcome.z_matched, outcome.update_ms
        else:
            self.last_points = None
            self.mapped_now = []
        return FrameTiming(
            segmentation_ms=1000.0 * (t1 - t0),
            update_ms=update_ms,
            frame_ms=1000.0 * (time.perf_counter() - t0),
            withdrawn=withdrawn,
            z_matched=matched,
            ground_plane_found=data.ground_plane_found,
        )

    def finish(self) -> list[Frame]:
        """Map the deferred frames now, in order, without z-match.

        Called by the run at its end: a run that ends before the height reference converged
        maps its frames with the reference's estimate so far (the kinematics when nothing was
        measured) instead of dropping them.

        Returns:
            The frames mapped.
        """
        self._queue_deferred(arrival=None)
        mapped = self._map_queue()
        self._record_late(mapped)
        return [data.frame for data, _ in mapped]

    def _take_queue(self) -> list[_MapJob]:
        """The queued frames to map now; with a rebuild (`_rebuild_due`), all so far.

        When the heading's first estimate has come, or a later one has moved more than
        ``pipe.heading_rebuild_change_deg`` from the one the maps were rebuilt with, and frames
        were mapped before it, the maps start anew (`_restart_maps`) and those frames come
        first. Beyond ``pipe.heading_rebuild_frames`` frames mapped, or
        :data:`MAX_REBUILD_BYTES` of their data, there is no rebuild.
        """
        jobs, self._queue = self._queue, []
        if self._mapped is None:
            return jobs
        if self._rebuild_due():
            if self._mapped:
                jobs = self._mapped + jobs
                self._restart_maps()
            self._rebuilt_rad = self.heading.correction_rad
            self._rebuilt_from_edges = self.heading.from_edges
            self._mapped, self._mapped_bytes = [], 0
        # Kept for another rebuild only while a later estimate may ask for one.
        if self._rebuilt_rad is not None and not self._may_rebuild_again():
            self._mapped, self._mapped_bytes = None, 0
            return jobs
        self._mapped.extend(jobs)
        self._mapped_bytes += sum(_job_bytes(job) for job in jobs)
        if (
            len(self._mapped) > self.params.heading_rebuild_frames
            or self._mapped_bytes > MAX_REBUILD_BYTES
        ):
            self._mapped, self._mapped_bytes = None, 0
        return jobs

    @property
    def rebuild_bytes(self) -> int:
        """Bytes of frame data kept for a heading rebuild (0 when nothing is kept).

        The depth images, robot-frame points and floor heights of the frames mapped since the
        last rebuild (or the start), bounded by :data:`MAX_REBUILD_BYTES`.
        """
        return self._mapped_bytes

    def _may_rebuild_again(self) -> bool:
        """Whether, after a rebuild, a later estimate may still ask for another one.

        With ``pipe.heading_rebuild_change_deg`` while an estimate may still count (with
        ``pipe.heading_rebuild_refined_only``: may still be refined,
        `mapper.HeadingEstimator.refines_more`), or with ``pipe.heading_rebuild_on_structure``
        while the maps hold the edge score's estimate. Otherwise no frame is kept any more.
        """
        p = self.params
        by_change = p.heading_rebuild_change_deg > 0.0 and (
            not p.heading_rebuild_refined_only or self.heading.refines_more
        )
        return by_change or (p.heading_rebuild_on_structure and self._rebuilt_from_edges)

    def _rebuild_due(self) -> bool:
        """Whether the maps are to be rebuilt with the heading's current estimate.

        Yes when the first estimate has come, when a later one moved more than
        ``pipe.heading_rebuild_change_deg`` from the one they were rebuilt with, or when the
        structure score's first estimate replaced the edge score's they were rebuilt with
        (``pipe.heading_rebuild_on_structure``).
        """
        if not self.heading.estimates:
            return False
        if self._rebuilt_rad is None:
            return True
        if (
            self.params.heading_rebuild_on_structure
            and self._rebuilt_from_edges
            and not self.heading.from_edges
        ):
            return True
        if self.params.heading_rebuild_change_deg <= 0.0:  # 0: off
            return False
        if self.params.heading_rebuild_refined_only and not self.heading.refined:
            return False
        change_deg = math.degrees(abs(self.heading.correction_rad - self._rebuilt_rad))
        return change_deg > self.params.heading_rebuild_change_deg

    def _restart_maps(self) -> None:
        """Both maps and the elevation filter as at the start (nothing mapped); ``on_restart``."""
        self.mapper = FloorObstacleMapper(self.mapper_params)
        self.baseline = AveragingMap(self.mapper_params)
        self.elevation = RobotElevationFilter(self.run_params.elevation)
        if self.on_restart is not None:
            self.on_restart(self.mapper)

    def _observe_heading(
        self, data: _FrameData, structure_border: NDArray[np.bool_] | None
    ) -> None:
        """Give the segmented frame to the heading estimator (the reference's shift so far).

        Its floors' occluding borders (`SegmentationResult.structure_border`, None: none) go to
        the estimator as structure points, with no floor height; the maps keep them as floor.
        """
        floor_heights_m = data.floor_heights_m
        if structure_border is not None:
            floor_heights_m = np.where(structure_border, np.nan, floor_heights_m)
        self.heading.observe(
            data.points_robot,
            floor_heights_m,
            data.transform_camera_to_robot,
            self.robot_pose(data.frame),
            z_shift_m=self._shift_m(data),
        )

    def _shift_m(self, data: _FrameData) -> float:
        """The height reference's shift of the frame's data now [m] (0 without it)."""
        if not self._use_reference:
            return 0.0
        return self.reference.frame_shift_m(data.measured_shift_m)

    def _job(
        self,
        data: _FrameData,
        use_z_match: bool = True,
        drift_m: float | None = None,
        elevation_offset_m: float | None = None,
    ) -> _MapJob:
        """The frame's map job, with the height reference's verdict on it now."""
        return _MapJob(
            data,
            self._shift_m(data),
            self.reference.agrees(data.measured_shift_m),
            use_z_match,
            drift_m,
            elevation_offset_m,
        )

    def _map_queue(self) -> list[tuple[_FrameData, LateMapping]]:
        """Map the queued frames in order (`_take_queue`); each frame with its outcome."""
        return [(job.data, self._map(job)) for job in self._take_queue()]

    def _record_late(self, mapped: list[tuple[_FrameData, LateMapping]]) -> None:
        """Add the outcomes of frames mapped after their timing was given to `mapped_late`."""
        self.mapped_late.extend(outcome for _, outcome in mapped)

    def _queue_deferred(self, arrival: _FrameData | None) -> float | None:
        """Queue the deferred frames in order, without z-match; the arrival's elevation offset.

        Args:
            arrival: The frame that made the reference known (None: the run's end). When it
                measured the ground under its feet and the first frames saw that surface,
                odometry's z drift since the start is taken out of the deferred frames (in
                proportion to their place between the start and ``arrival``) and of the robot's
                elevation from ``arrival`` on (the elevation filter's offset, returned: to set
                before mapping ``arrival``; None: leave it).
        """
        if not self._deferred:
            return None
        deferred = self._deferred
        fractions = self._way_fractions(arrival)
        surfaces_m = self._deferred_surfaces_m()
        # The drift is the slope of the heights at which the frames saw the arrival surface:
        # shifted by one estimate, the camera's height error is the same in every frame and
        # drops out. With each frame's own shift, the frames on that surface (their own
        # measurement: its view lies exactly at their odometry) and the earlier ones (the
        # estimate, off by its error) differ by the estimate's error, which went into the
        # slope (stereo, stage_down: drift 0.8 mm off on seeds 7 and 8).
        drift_m = self._arrival_drift_m(arrival, fractions, self._deferred_surfaces_m(False))
        if arrival is not None and arrival.measured_shift_m is not None:
            drift = 0.0 if drift_m is None else drift_m
            self._start_surfaces_m = [
                heights - drift * float(f) for heights, f in zip(surfaces_m, fractions, strict=True)
            ]
        for data, fraction in zip(deferred, fractions, strict=True):
            frame_drift_m = None if drift_m is None else drift_m * float(fraction)
            self._queue.append(self._job(data, use_z_match=False, drift_m=frame_drift_m))
        self._deferred = []
        return None if drift_m is None else -drift_m

    def _way_fractions(self, arrival: _FrameData | None) -> NDArray[np.float64]:
        """Each deferred frame's place between the start (0) and ``arrival`` (1); 0 without."""
        positions = np.array([data.position for data in self._deferred], dtype=np.float64)
        if arrival is None or positions.size == 0:
            return np.zeros(positions.size)
        return (positions - positions[0]) / (arrival.position - positions[0])

    def _arrival_drift_m(
        self,
        arrival: _FrameData | None,
        fractions: NDArray[np.float64],
        surfaces_m: list[NDArray[np.float64]],
    ) -> float | None:
        """Odometry's z drift at ``arrival`` measured on the start frames' surfaces [m] or None.

        ``surfaces_m`` are the deferred frames' ground-sized floors (`_deferred_surfaces_m`).

        None without the elevation filter (nothing carries the correction forward), without
        deferred frames, or when ``arrival`` did not measure the ground under its feet.
        """
        if (
            arrival is None
            or arrival.measured_shift_m is None
            or not self._deferred
            or not self.params.use_elevation_filter
        ):
            return None
        arrival_z_m = float(arrival.frame.robot_pose_believed[2])
        assert self._start_z_m is not None  # set by the first frame
        return arrival_drift_m(
            surfaces_m, fractions, arrival_z_m, self._start_z_m, self.reference.params
        )

    def _deferred_surfaces_m(self, own_shift: bool = True) -> list[NDArray[np.float64]]:
        """World heights of each deferred frame's ground-sized floors (odometry, its shift).

        Args:
            own_shift: Each frame's shift (`HeightReference.frame_shift_m`: its own
                measurement when it agrees); False: the estimate's, the same in every frame.
        """
        reference = self.reference
        return [
            data.ground_sized_m
            + float(data.frame.robot_pose_believed[2])
            + (reference.frame_shift_m(data.measured_shift_m) if own_shift else reference.shift_m)
            for data in self._deferred
        ]

    def _measure_reference(self, seg: SegmentationResult) -> float | None:
        """Give the frame's floor regions to the height reference; its measurement [m] or None."""
        if not self._use_reference:
            return None
        floors = seg.floors
        prior_m = neck_prior_m(
            seg.correction.rotation,
            seg.transform_camera_to_robot,
            self.run_params.reference.neck_in_camera_m,
        )
        return self.reference.update(
            floors.heights_m, floors.areas_m2, floors.is_floor, self._rise_m, prior_m
        )

    def _ground_sized_m(self, seg: SegmentationResult) -> NDArray[np.float64]:
        """Heights of the frame's ground-sized floor regions [m] (empty without the reference)."""
        if not self._use_reference:
            return np.empty(0)
        floors = seg.floors
        return self.reference.ground_sized_m(floors.heights_m, floors.areas_m2, floors.is_floor)

    def _map(self, job: _MapJob) -> LateMapping:
        """Heading, world transform, z-match and map update of one segmented frame.

        Deferred frames are mapped without z-match (``job.use_z_match`` False): their odometry
        is the run's freshest (from the start pose) and matching them onto a map they are still
        building let it drift (stage_down seed 2: z shifts of −1 to −2 mm per frame while the
        robot stood on the platform with exact odometry; worst row 2.89 → 1.60 mm). The
        elevation filter still corrects their robot z from the map under the robot, unless
        ``job.drift_m`` (odometry's z drift at this frame, measured on arrival) is given: then
        the robot's z is odometry's minus it and the filter is left alone.

        Returns:
            The frame's outcome: whether it was withdrawn, whether it was z-matched, the mapper
            update time [ms] (NaN when withdrawn) and its corrected camera pose.
        """
        data, shift_m, drift_m = job.data, job.shift_m, job.drift_m
        if job.elevation_offset_m is not None:
            self.elevation.offset_m = job.elevation_offset_m
        frame = data.frame
        points_robot = _raised(data.points_robot, shift_m)
        floor_robot = data.floor_heights_m + shift_m
        transform_camera_to_robot = data.transform_camera_to_robot.copy()
        transform_camera_to_robot[2, 3] += shift_m
        pose = self.robot_pose(frame)
        if drift_m is not None:
            pose[2] = float(frame.robot_pose_believed[2]) - drift_m
        on_start_surface = self._stand_on_start_surface(job, pose)
        # Heading correction (mapper.heading): a yaw about the camera centre, before the pose.
        transform_robot_to_world = planar_pose_to_matrix(pose) @ self.heading.rotation(
            transform_camera_to_robot
        )
        points_world = apply_transform(transform_robot_to_world, points_robot)
        floor_world = floor_robot + pose[2]
        # Camera centre after the segmentation's own correction, so rays match the points.
        sensor_origin = apply_transform(transform_robot_to_world, transform_camera_to_robot[:3, 3])
        self.mapper.recenter(pose[0], pose[1])
        self.baseline.recenter(pose[0], pose[1])

        matched = withdrawn = False
        if self.params.use_z_match and job.use_z_match and not on_start_surface:
            match = self.mapper.match_z(points_world, floor_world)
            decision = frame_decision(
                match, data.ground_plane_found or data.measured_shift_m is not None
            )
            if job.agrees and decision == ZDecision.APPLY_SHIFT:
                # The frame saw the ground under the feet and was shifted by its own measurement
                # (it agrees with the reference): its data are right relative to the feet, so
                # the map's disagreement is the robot's elevation error. A small one
                # (`anchor_shift_m`) is the odometry's drift: the map holds. Shifting every
                # frame onto the map let the map drift (stage: -3 mm over a run). A frame whose
                # measurement disagrees was shifted by the reference's estimate, not by its own
                # ground: it is z-matched as any other (stereo: its measurement scatters by
                # ±10 mm, and keeping such frames unshifted put their scatter into the map).
                if abs(match.shift_m) > self.params.anchor_shift_m:
                    decision = ZDecision.KEEP_UNSHIFTED
                if self.params.use_elevation_filter:
                    self.elevation.update(
                        float(frame.robot_pose_believed[2]), pose[2] + float(match.shift_m)
                    )
            if decision == ZDecision.APPLY_SHIFT:
                shift = float(match.shift_m)
                points_world[:, 2] += shift
                floor_world = floor_world + shift
                sensor_origin = sensor_origin + np.array([0.0, 0.0, shift])
                matched = True
            withdrawn = decision == ZDecision.WITHDRAW
        self.last_points = LabelledPoints(points_world, floor_world, withdrawn)
        update_ms = float("nan")
        if not withdrawn:
            t2 = time.perf_counter()
            self.mapper.update(points_world, floor_world, sensor_origin)
            update_ms = 1000.0 * (time.perf_counter() - t2)
            self.baseline.update(points_world, floor_world, sensor_origin)
            if self.params.use_elevation_filter and drift_m is None and not on_start_surface:
                self.elevation.update(
                    float(frame.robot_pose_believed[2]), self.mapper.floor_at(pose[0], pose[1])
                )
        assert self.heading.transform_camera_to_robot is not None  # set by `rotation` above
        return LateMapping(
            data.position, withdrawn, matched, update_ms, self.heading.transform_camera_to_robot
        )

    def _stand_on_start_surface(self, job: _MapJob, pose: NDArray[np.float64]) -> bool:
        """Put the robot on the start surface under its feet; whether it was (sets ``pose``).

        A frame that measured the ground under its feet and was shifted by its own measurement
        (it agrees with the reference's estimate) has its data right relative to its feet,
        which stand on that ground; when the first frames saw a surface within
        ``ref.surface_gate_m`` of the robot's filtered elevation ``pose[2]``, the robot's
        elevation is that surface's height (``pose[2]`` and the elevation filter's offset are
        set to it). The frame's data are then right relative to the start and are neither
        z-matched nor used to pull the elevation to the map. A frame shifted by the estimate
        instead (stereo: its measurement scatters by ±10 mm) is z-matched as before.
        """
        if not job.agrees or not self.params.use_elevation_filter:
            return False
        assert self._start_z_m is not None  # set by the first frame
        height_m = start_surface_m(
            self._start_surfaces_m, pose[2], self._start_z_m, self.reference.params
        )
        if height_m is None:
            return False
        pose[2] = height_m
        self.elevation.offset_m = height_m - float(job.data.frame.robot_pose_believed[2])
        return True

    def maps(self) -> tuple[NDArray[np.int8], NDArray[np.float64], NDArray[np.float64]]:
        """Current FOG types, FOG heights [m] and baseline heights [m] (NaN = none)."""
        types, heights = self.mapper.fog()
        return (
            np.asarray(types),
            np.asarray(heights, dtype=np.float64),
            np.asarray(self.baseline.heights(), dtype=np.float64),
        )

    def cell_centers_xy(self) -> NDArray[np.float64]:
        """(nx, ny, 2) world centres of the current grid cells [m]."""
        return np.asarray(self.mapper.geometry.cell_centers_xy(), dtype=np.float64)


def _raised(points: NDArray[np.float64], shift_m: float) -> NDArray[np.float64]:
    """``points + [0, 0, shift_m]`` of (N, 3) points bit for bit, added per column.

    A broadcast over rows of 3 loops 3 elements at a time (about ten times slower on a
    frame's points); x and y get their + 0.0 too (it turns -0.0 into 0.0, as the broadcast).
    """
    raised = np.empty(points.shape)
    for axis, offset in enumerate((0.0, 0.0, shift_m)):
        np.add(points[:, axis], offset, out=raised[:, axis])
    return raised
