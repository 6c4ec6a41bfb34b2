"""Believed-vs-true camera pose error over a run's frames (the report's ``pose_error``).

Per frame with a true pose, the camera pose the robot believes is compared with the true one by
:func:`fogsim.geometry.pose_error` twice: in the robot frame (what the encoders cause, the
paper's "7° and 10 mm") and in the world (encoders plus odometry drift). When the caller also gives
the camera pose after the pipeline's corrections (tilt, heading), the yaw left between it and the
true one is recorded too (the residual heading, :func:`heading_error_deg`): as the frame was
corrected when it was processed (``residual_heading_deg``: what a robot using the map at that
moment saw), and as the frame was last mapped (``map_heading_deg``: what the final maps hold).
The two differ for the frames the pipeline mapped again later (:meth:`remapped`): the frames
mapped once more with the heading's first estimate (`pipe.heading_rebuild_frames`) and the
frames deferred by the height reference. Both are in the robot frame: the camera's own yaw
error, what a neck correction is judged by. The maps are built in the *believed* world
(odometry's) and scored against the true one, so what they hold is the yaw between the
corrected camera pose brought into the world by the believed robot pose and the true camera
pose in the world (``world_heading_deg``, as last mapped): the robot-frame yaw plus odometry's
yaw error at the frame, which drifts over a run (`bench/heading_drift.py`).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from fogsim.data.frame import Frame
from fogsim.eval.report.schema import MedianMax, MedianP95Max, PoseErrorPair, PoseErrorStats
from fogsim.eval.rounding import rounded

_DIGITS = 4
"""Decimals kept in the report (0.0001° and 0.0001 mm, far below any error that matters)."""


def _median_max(values: NDArray[np.float64]) -> MedianMax:
    return MedianMax(
        median=rounded(float(np.median(values)), _DIGITS),
        max=rounded(float(np.max(values)), _DIGITS),
    )


def _median_p95_max(values: NDArray[np.float64]) -> MedianP95Max:
    return MedianP95Max(
        median=rounded(float(np.median(values)), _DIGITS),
        p95=rounded(float(np.percentile(values, 95)), _DIGITS),
        max=rounded(float(np.max(values)), _DIGITS),
    )


def heading_error_deg(rotation: NDArray[np.float64], rotation_true: NDArray[np.float64]) -> float:
    """Yaw [deg] of ``rotation · rotation_trueᵀ``: the heading error of a camera orientation.

    Both are 3×3 camera-to-robot rotations; the yaw is that of the error rotation taken about
    the robot's vertical axis (``atan2`` of the antisymmetric part of its upper 2×2 block, exact
    for a pure yaw and insensitive to a small remaining tilt).
    """
    error = np.asarray(rotation, dtype=np.float64) @ np.asarray(rotation_true, dtype=np.float64).T
    return math.degrees(math.atan2(error[1, 0] - error[0, 1], error[0, 0] + error[1, 1]))


@dataclass(frozen=True)
class FramePoseErrors:
    """Each frame's camera pose errors, in the order the frames were added (NaN = not known).

    A frame without a finite true pose has NaN everywhere; one added without a corrected pose
    has NaN in the residual columns. Angles [deg], offsets [mm].

    Attributes:
        camera_rotation_deg: (N,) rotation between the believed and the true camera pose in the
            robot frame (what the encoders cause).
        camera_translation_mm: (N,) the same poses' offset.
        world_rotation_deg: (N,) rotation between the believed and the true camera pose in the
            world (encoders and odometry).
        world_translation_mm: (N,) the same poses' offset.
        residual_tilt_deg: (N,) angle between the vertical of the camera pose the frame was last
            mapped with (the pipeline's tilt and heading corrections applied) and the true
            vertical, robot frame: the tilt the corrections left.
        residual_heading_deg: (N,) signed yaw [deg] of the corrected camera pose against the
            true one as the frame was processed, robot frame (+ = turned left); the report's
            ``residual_heading_deg`` is the median and max of its magnitude. NaN for a frame
            deferred by the height reference (it had no corrected pose when processed).
        map_heading_deg: (N,) the same for the pose the frame was last mapped with; a deferred
            frame has it (the report's ``map_heading_deg`` leaves deferred frames out, as its
            ``residual_heading_deg`` does).
        world_heading_deg: (N,) signed yaw of that pose brought into the world by the believed
            robot pose against the true camera pose in the world.
    """

    camera_rotation_deg: NDArray[np.float64]
    camera_translation_mm: NDArray[np.float64]
    world_rotation_deg: NDArray[np.float64]
    world_translation_mm: NDArray[np.float64]
    residual_tilt_deg: NDArray[np.float64]
    residual_heading_deg: NDArray[np.float64]
    map_heading_deg: NDArray[np.float64]
    world_heading_deg: NDArray[np.float64]


class PoseErrorAccumulator:
    """Collects each frame's poses; :meth:`stats` gives the errors' median and maximum.

    A frame costs a few list appends; the errors are computed in :meth:`stats`, for all frames
    at once, with the arithmetic of :func:`fogsim.geometry.pose_error` and
    :func:`heading_error_deg` on each frame (the same BLAS products and LAPACK inverse on
    stacks of matrices, the same scalar ``math`` functions per frame): the same numbers bit
    for bit as comparing each frame when added (``tests/test_exact_fast_paths.py``), without
    some forty small numpy calls on the run's main thread per frame.
    """

    def __init__(self) -> None:
        # Per frame added: true camera pose in the world, true robot pose, believed camera
        # pose in the robot frame, believed robot pose, corrected camera pose in the robot
        # frame (or None). Copies: the frames' arrays may be reused by their producer.
        self._world_true: list[NDArray[np.float64]] = []
        self._robot_true: list[NDArray[np.float64]] = []
        self._camera_believed: list[NDArray[np.float64]] = []
        self._robot_believed: list[NDArray[np.float64]] = []
        self._corrected: list[NDArray[np.float64] | None] = []
        # Frame position -> corrected camera pose of its last mapping, where it was mapped again.
        self._remapped: dict[int, NDArray[np.float64]] = {}

    def add(
        self,
        frame: Frame,
        transform_camera_to_robot_corrected: NDArray[np.float64] | None = None,
    ) -> None:
        """Keep the frame's believed and true poses (a frame without a true pose counts none).

        Args:
            frame: The frame, with its believed and true poses.
            transform_camera_to_robot_corrected: 4×4 camera pose in the robot frame after the
                pipeline's corrections, or None (no residual heading recorded for the frame).
        """
        self._world_true.append(np.array(frame.transform_camera_to_world_true, dtype=np.float64))
        self._robot_true.append(np.array(frame.robot_pose_true, dtype=np.float64))
        self._camera_believed.append(
            np.array(frame.transform_camera_to_robot_believed, dtype=np.float64)
        )
        self._robot_believed.append(np.array(frame.robot_pose_believed, dtype=np.float64))
        self._corrected.append(
            None
            if transform_camera_to_robot_corrected is None
            else np.array(transform_camera_to_robot_corrected, dtype=np.float64)
        )

    def remapped(
        self, position: int, transform_camera_to_robot_corrected: NDArray[np.float64]
    ) -> None:
        """The frame added ``position``-th (0 = first) was mapped again with this camera pose.

        Args:
            position: The frame's place among the frames added.
            transform_camera_to_robot_corrected: 4×4 camera pose in the robot frame it was
                mapped with that time (`fogsim.mapping.pipeline.LateMapping`); the last call
                for a position wins.

        Raises:
            IndexError: No frame was added at ``position``.
        """
        if not 0 <= position < len(self._corrected):
            raise IndexError(
                f"remapped frame position {position} is not among the {len(self._corrected)} "
                "frames added (0 ... frames - 1)"
            )
        self._remapped[position] = np.array(transform_camera_to_robot_corrected, dtype=np.float64)

    def per_frame(self) -> FramePoseErrors:
        """Every frame's errors (:class:`FramePoseErrors`), aligned with the frames added.

        The matrix products for all frames at once, each yaw by :mod:`math` per frame, as
        :func:`heading_error_deg` takes it: the same numbers bit for bit as that function on
        each frame (``tests/test_exact_fast_paths.py``).
        """
        n = len(self._world_true)
        columns = np.full((8, n), np.nan)
        if not n:
            return FramePoseErrors(*columns)
        world_true = np.stack(self._world_true)
        robot_true = np.stack(self._robot_true)
        known = np.isfinite(world_true).all(axis=(1, 2)) & np.isfinite(robot_true).all(axis=1)
        positions = np.flatnonzero(known)
        if not positions.size:
            return FramePoseErrors(*columns)
        world_true = world_true[known]
        camera_true = np.linalg.inv(_planar_matrices(robot_true[known])) @ world_true
        camera_believed = np.stack(self._camera_believed)[known]
        robot_believed = _planar_matrices(np.stack(self._robot_believed)[known])
        errors = (
            *_errors(camera_believed, camera_true),
            *_errors(robot_believed @ camera_believed, world_true),
        )
        for row, values in enumerate(errors):
            columns[row, positions] = values
        firsts = [self._corrected[i] for i in positions.tolist()]
        processed = np.array([first is not None for first in firsts], dtype=bool)
        if processed.any():
            columns[5, positions[processed]] = _yaw_deg(
                [first for first in firsts if first is not None], camera_true[processed, :3, :3]
            )
        # The pose each frame was last mapped with (None: never mapped with one).
        lasts = [self._remapped.get(i, first) for i, first in zip(positions, firsts, strict=True)]
        mapped = np.array([last is not None for last in lasts], dtype=bool)
        if mapped.any():
            last = np.stack([m for m in lasts if m is not None])
            rotation = np.stack([m[:3, :3] for m in last])
            tilt_cos = (rotation @ camera_true[mapped, :3, :3].transpose(0, 2, 1))[:, 2, 2]
            columns[4, positions[mapped]] = np.degrees(np.arccos(np.clip(tilt_cos, -1.0, 1.0)))
            columns[6, positions[mapped]] = _yaw_deg(list(last), camera_true[mapped, :3, :3])
            columns[7, positions[mapped]] = _yaw_deg(
                list(robot_believed[mapped] @ last), world_true[mapped, :3, :3]
            )
        return FramePoseErrors(*columns)

    def stats(self) -> PoseErrorStats:
        """:func:`pose_error_stats` of :meth:`per_frame`."""
        return pose_error_stats(self.per_frame())


def pose_error_stats(errors: FramePoseErrors) -> PoseErrorStats:
    """Median and max of the errors; only ``frames=0`` when no frame had a true pose.

    Over the columns of ``errors`` (:meth:`PoseErrorAccumulator.per_frame`). Per frame with a
    finite true pose: the rotation [deg] and translation [mm] between the believed and the
    true camera pose in the robot frame (the true one is the true camera pose brought into
    the true robot frame) and in the world (the believed one through the believed robot
    pose). ``residual_heading_deg`` (of |yaw|, the yaw between the corrected and the true
    camera pose in the robot frame) is set when some such frame was added with its corrected
    camera pose, and ``map_heading_deg`` with it (the same with the pose of each frame's last
    mapping, :meth:`PoseErrorAccumulator.remapped`), and ``world_heading_deg`` with them (of
    |yaw| between that pose brought into the world by the believed robot pose and the true
    camera pose in the world), all three over those frames; ``residual_tilt_deg`` (median,
    95th percentile, max) over every frame mapped with a corrected pose (deferred frames too).
    """
    known = np.isfinite(errors.camera_rotation_deg)
    if not known.any():
        return PoseErrorStats(frames=0)
    stats = PoseErrorStats(
        frames=int(np.count_nonzero(known)),
        camera_in_robot=PoseErrorPair(
            _median_max(errors.camera_rotation_deg[known]),
            _median_max(errors.camera_translation_mm[known]),
        ),
        camera_in_world=PoseErrorPair(
            _median_max(errors.world_rotation_deg[known]),
            _median_max(errors.world_translation_mm[known]),
        ),
    )
    processed = np.isfinite(errors.residual_heading_deg)
    if not processed.any():
        return stats
    tilt = errors.residual_tilt_deg[np.isfinite(errors.residual_tilt_deg)]
    return dataclasses.replace(
        stats,
        residual_heading_deg=_median_max(np.abs(errors.residual_heading_deg[processed])),
        map_heading_deg=_median_max(np.abs(errors.map_heading_deg[processed])),
        world_heading_deg=_median_max(np.abs(errors.world_heading_deg[processed])),
        residual_tilt_deg=_median_p95_max(tilt),
    )


def _yaw_deg(
    corrected: list[NDArray[np.float64]], true_rotations: NDArray[np.float64]
) -> NDArray[np.float64]:
    """(M,) signed yaw [deg] between M 4×4 corrected camera poses and M 3×3 true rotations.

    :func:`heading_error_deg` of each pair, with its one matrix product done for the stack.
    """
    rotation = np.stack([c[:3, :3] for c in corrected])
    error = rotation @ true_rotations.transpose(0, 2, 1)
    return np.array(
        [
            math.degrees(math.atan2(e10 - e01, e00 + e11))
            for (e00, e01, _), (e10, e11, _), _ in error.tolist()
        ]
    )


def _planar_matrices(poses: NDArray[np.float64]) -> NDArray[np.float64]:
    """(N, 4, 4) :func:`~mapper.transforms.planar_pose_to_matrix` of (N, 4) poses, exactly.

    The cosines and sines by :mod:`math`, as that function takes them (numpy's vectorised
    ones may differ in the last bit).
    """
    matrices = np.zeros((poses.shape[0], 4, 4))
    yaw = poses[:, 3].tolist()
    c = np.array([math.cos(a) for a in yaw])
    s = np.array([math.sin(a) for a in yaw])
    matrices[:, 0, 0], matrices[:, 0, 1], matrices[:, 1, 0], matrices[:, 1, 1] = c, -s, s, c
    matrices[:, :3, 3] = poses[:, :3]
    matrices[:, 2, 2] = matrices[:, 3, 3] = 1.0
    return matrices


def _errors(
    believed: NDArray[np.float64], true: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Rotation [deg] and translation [mm] between (N, 4, 4) poses, as ``pose_error`` each."""
    relative = believed[:, :3, :3].transpose(0, 2, 1) @ true[:, :3, :3]
    cosines = ((np.trace(relative, axis1=1, axis2=2) - 1.0) / 2.0).tolist()
    rotation_deg = [math.degrees(math.acos(min(1.0, max(-1.0, c)))) for c in cosines]
    offsets = believed[:, :3, 3] - true[:, :3, 3]
    translation_mm = [1000.0 * math.sqrt(d.dot(d)) for d in offsets]  # as np.linalg.norm
    return np.array(rotation_deg), np.array(translation_mm)
