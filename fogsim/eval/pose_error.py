"""Believed-vs-true camera pose error over a run's frames (the report's ``pose_error``).

Per frame with a true pose, the camera pose the robot believes is compared with the true one by
:func:`fogsim.geometry.pose_error` twice: in the robot frame (what the encoders cause, the
paper's "7° and 10 mm") and in the world (encoders plus odometry drift). When the caller also gives
the camera pose after the pipeline's corrections (tilt, heading), the yaw left between it and the
true one is recorded too (the residual heading, :func:`heading_error_deg`).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from numpy.typing import NDArray

from fogsim.data.frame import Frame
from fogsim.eval.report.schema import MedianMax, PoseErrorPair, PoseErrorStats
from fogsim.eval.rounding import rounded
from fogsim.geometry import pose_error
from mapper.transforms import planar_pose_to_matrix

_DIGITS = 4
"""Decimals kept in the report (0.0001° and 0.0001 mm, far below any error that matters)."""


def _median_max(values: NDArray[np.float64]) -> MedianMax:
    return MedianMax(
        median=rounded(float(np.median(values)), _DIGITS),
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


class PoseErrorAccumulator:
    """Collects each frame's pose errors; :meth:`stats` gives their median and maximum."""

    def __init__(self) -> None:
        # Per frame: robot-frame rotation [deg], translation [mm], world rotation, translation.
        self._rows: list[tuple[float, float, float, float]] = []
        self._residual_heading_deg: list[float] = []

    def add(
        self,
        frame: Frame,
        transform_camera_to_robot_corrected: NDArray[np.float64] | None = None,
    ) -> None:
        """Compare the frame's believed camera pose with the true one (skipped without one).

        Args:
            frame: The frame, with its believed and true poses.
            transform_camera_to_robot_corrected: 4×4 camera pose in the robot frame after the
                pipeline's corrections, or None (no residual heading recorded for the frame).
        """
        transform_camera_to_world_true = np.asarray(
            frame.transform_camera_to_world_true, dtype=np.float64
        )
        robot_pose_true = np.asarray(frame.robot_pose_true, dtype=np.float64)
        if not (
            np.all(np.isfinite(transform_camera_to_world_true))
            and np.all(np.isfinite(robot_pose_true))
        ):
            return
        transform_camera_to_robot_true = (
            np.linalg.inv(planar_pose_to_matrix(robot_pose_true)) @ transform_camera_to_world_true
        )
        in_robot = pose_error(
            frame.transform_camera_to_robot_believed, transform_camera_to_robot_true
        )
        in_world = pose_error(
            frame.transform_camera_to_world_believed, transform_camera_to_world_true
        )
        if transform_camera_to_robot_corrected is not None:
            self._residual_heading_deg.append(
                abs(
                    heading_error_deg(
                        np.asarray(transform_camera_to_robot_corrected)[:3, :3],
                        transform_camera_to_robot_true[:3, :3],
                    )
                )
            )
        self._rows.append(
            (
                in_robot.rotation_deg,
                in_robot.translation_mm,
                in_world.rotation_deg,
                in_world.translation_mm,
            )
        )

    def stats(self) -> PoseErrorStats:
        """Median and max of the errors; only ``frames=0`` when no frame had a true pose.

        ``residual_heading_deg`` (of |yaw|) is set when some frame was added with its corrected
        camera pose.
        """
        if not self._rows:
            return PoseErrorStats(frames=0)
        a = np.array(self._rows)
        stats = PoseErrorStats(
            frames=int(a.shape[0]),
            camera_in_robot=PoseErrorPair(_median_max(a[:, 0]), _median_max(a[:, 1])),
            camera_in_world=PoseErrorPair(_median_max(a[:, 2]), _median_max(a[:, 3])),
        )
        if not self._residual_heading_deg:
            return stats
        return dataclasses.replace(
            stats, residual_heading_deg=_median_max(np.array(self._residual_heading_deg))
        )
