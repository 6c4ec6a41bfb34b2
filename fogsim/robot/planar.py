"""Planar poses (x, y, z [m], yaw [rad]) of level frames: the robot frame R, soles, footsteps."""

import math

import numpy as np
from numpy.typing import NDArray


def wrap_angle(angle_rad: float) -> float:
    """The same angle in (-π, π] [rad]."""
    return math.atan2(math.sin(angle_rad), math.cos(angle_rad))


def mean_angle(a_rad: float, b_rad: float) -> float:
    """The angle halfway from ``a_rad`` to ``b_rad`` along the shorter way round [rad]."""
    return a_rad + 0.5 * wrap_angle(b_rad - a_rad)


def yaw_of(rotation: NDArray[np.float64]) -> float:
    """Yaw [rad] of a 3×3 rotation's x axis projected on the horizontal plane."""
    return math.atan2(rotation[1, 0], rotation[0, 0])


def planar_pose_of(transform: NDArray[np.float64]) -> NDArray[np.float64]:
    """(x, y, z [m], yaw [rad]) of a 4×4 transform: its position and the yaw of its x axis."""
    return np.array([transform[0, 3], transform[1, 3], transform[2, 3], yaw_of(transform)])
