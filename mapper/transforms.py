"""Rigid transforms as 4×4 homogeneous matrices and planar poses (x, y, z, yaw)."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mapper.validation import real_array


def planar_pose_to_matrix(pose: ArrayLike) -> NDArray[np.float64]:
    """4×4 transform of a pose (x [m], y [m], z [m], yaw [rad]) with zero roll and pitch."""
    x, y, z, yaw = (float(v) for v in real_array(pose, "pose").reshape(4))
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, 0.0, x], [s, c, 0.0, y], [0.0, 0.0, 1.0, z], [0.0, 0.0, 0.0, 1.0]])


def apply_transform(transform: ArrayLike, points: ArrayLike) -> NDArray[np.float64]:
    """Apply a 4×4 transform to points of shape (..., 3)."""
    t = real_array(transform, "transform")
    p = real_array(points, "points")
    return p @ t[:3, :3].T + t[:3, 3]


def rotation_angle_deg(rotation: ArrayLike) -> float:
    """Angle [deg] of a 3×3 rotation matrix (geodesic distance to the identity)."""
    r = real_array(rotation, "rotation")
    c = (np.trace(r) - 1.0) / 2.0
    return math.degrees(math.acos(min(1.0, max(-1.0, c))))
