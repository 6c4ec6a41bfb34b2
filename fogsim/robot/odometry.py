"""Kinematic odometry: the pose of the robot frame R in the world that the robot believes.

Foot to foot: when the support switches, the new reference sole's pose = old reference sole's
pose ∘ FK(readings, old sole → new sole), projected to a level pose (x, y, z, yaw), using readings
taken while both feet were down. R's pose in the reference sole frame comes from the same
forward kinematics of the readings (`fogsim.robot.kinematics.Robot.transform_robot_to_sole`).
"""

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fogsim.robot.kinematics import Robot, Stance
from fogsim.robot.planar import planar_pose_of
from mapper.transforms import planar_pose_to_matrix


class Odometry:
    """Believed pose of the robot frame R from foot-to-foot kinematics of the readings.

    Args:
        robot: The humanoid.
        initial_robot_pose: (x, y, z [m], yaw [rad]) of R at the start (taken as known).
        readings: Joint readings at the start.
        stance: Stance at the start.
    """

    def __init__(
        self,
        robot: Robot,
        initial_robot_pose: ArrayLike,
        readings: ArrayLike,
        stance: Stance | int,
    ) -> None:
        self.robot = robot
        stance = Stance(int(stance))
        self.reference = Stance.RIGHT if stance == Stance.RIGHT else Stance.LEFT
        t_world_robot = planar_pose_to_matrix(initial_robot_pose)
        t_sole_robot = robot.transform_robot_to_sole(readings, self.reference)
        self.sole_world = _level(t_world_robot @ np.linalg.inv(t_sole_robot))
        self.readings_both_down = np.asarray(readings, dtype=np.float64).copy()
        self.pose = np.asarray(initial_robot_pose, dtype=np.float64).copy()

    def update(self, readings: ArrayLike, stance: Stance | int) -> NDArray[np.float64]:
        """Advance by one frame; returns the believed R pose (x, y, z [m], yaw [rad])."""
        stance = Stance(int(stance))
        readings = np.asarray(readings, dtype=np.float64)
        if stance == Stance.DOUBLE:
            self.readings_both_down = readings.copy()
        reference = Stance.RIGHT if stance == Stance.RIGHT else Stance.LEFT
        if reference != self.reference:
            step = self.robot.transform_sole_to_sole(
                self.readings_both_down, self.reference, reference
            )
            self.sole_world = _level(self.sole_world @ step)
            self.reference = reference
        t_world_robot = self.sole_world @ self.robot.transform_robot_to_sole(readings, reference)
        self.pose = planar_pose_of(t_world_robot)
        return self.pose.copy()


def _level(transform: NDArray[np.float64]) -> NDArray[np.float64]:
    """Drop roll and pitch: keep x, y, z and the yaw of the x axis."""
    return planar_pose_to_matrix(planar_pose_of(transform))
