"""What the testbed hands the mapper each frame (the simulation's and the recording's contract).

Frames:
    world: z up, gravity aligned, fixed to the stage floor (z = 0 is the ground).
    robot: the paper's robot frame R: on the ground below the robot (between its feet),
        z up, x forward; its pose in the world is (x, y, z, yaw) with zero roll and pitch.
    camera: OpenCV's optical frame of the depth camera (x right, y down, z forward).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from mapper.intrinsics import PinholeIntrinsics
from mapper.transforms import planar_pose_to_matrix


@dataclass(frozen=True)
class Frame:
    """One camera frame with the poses the robot believes and the true ones.

    Attributes:
        index: Frame number from 0.
        time_s: Simulation time [s].
        depth_m: (height, width) float32 depth along the optical axis [m], NaN = none;
            already self-filtered (pixels on the robot's own body are NaN).
        intrinsics: Pinhole intrinsics of the depth image.
        transform_camera_to_robot_believed: 4×4, forward kinematics of the encoder readings.
        robot_pose_believed: (4,) x [m], y [m], z [m], yaw [rad] in the world, from odometry.
        transform_camera_to_world_true: 4×4 true camera pose.
        robot_pose_true: (4,) true robot pose, same convention as the believed one.
        self_filtered_pixels: how many pixels the self-filter removed.
    """

    index: int
    time_s: float
    depth_m: NDArray[np.float32]
    intrinsics: PinholeIntrinsics
    transform_camera_to_robot_believed: NDArray[np.float64]
    robot_pose_believed: NDArray[np.float64]
    transform_camera_to_world_true: NDArray[np.float64]
    robot_pose_true: NDArray[np.float64]
    self_filtered_pixels: int = 0

    @property
    def transform_robot_to_world_believed(self) -> NDArray[np.float64]:
        """4×4 believed robot pose in the world."""
        return planar_pose_to_matrix(self.robot_pose_believed)

    @property
    def transform_camera_to_world_believed(self) -> NDArray[np.float64]:
        """4×4 believed camera pose in the world."""
        return self.transform_robot_to_world_believed @ self.transform_camera_to_robot_believed
