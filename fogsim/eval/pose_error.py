"""Believed-vs-true camera pose error over a run's frames (the report's ``pose_error``).

Per frame with a true pose, the camera pose the robot believes is compared with the true one by
:func:`fogsim.geometry.pose_error` twice: in the robot frame (what the encoders cause, the
paper's "7° and 10 mm") and in the world (encoders plus odometry drift).
"""

from __future__ import annotations

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


class PoseErrorAccumulator:
    """Collects each frame's pose errors; :meth:`stats` gives their median and maximum."""

    def __init__(self) -> None:
        # Per frame: robot-frame rotation [deg], translation [mm], world rotation, translation.
        self._rows: list[tuple[float, float, float, float]] = []

    def add(self, frame: Frame) -> None:
        """Compare the frame's believed camera pose with the true one (skipped without one)."""
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
        self._rows.append(
            (
                in_robot.rotation_deg,
                in_robot.translation_mm,
                in_world.rotation_deg,
                in_world.translation_mm,
            )
        )

    def stats(self) -> PoseErrorStats:
        """Median and max of the errors; only ``frames=0`` when no frame had a true pose."""
        if not self._rows:
            return PoseErrorStats(frames=0)
        a = np.array(self._rows)
        return PoseErrorStats(
            frames=int(a.shape[0]),
            camera_in_robot=PoseErrorPair(_median_max(a[:, 0]), _median_max(a[:, 1])),
            camera_in_world=PoseErrorPair(_median_max(a[:, 2]), _median_max(a[:, 3])),
        )
