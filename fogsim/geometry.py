"""Frame conventions and pose comparison shared by robot, scene, camera and scoring (no MuJoCo).

Cameras follow OpenCV's optical frame (x right, y down, z forward); MuJoCo cameras look along
their −z with y up. The two differ by a rotation of π about x: ``R_cv = R_mj @ MJ_FROM_CV`` and
``R_mj = R_cv @ MJ_FROM_CV`` (the matrix is its own inverse).
"""

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from mapper.transforms import rotation_angle_deg

MJ_FROM_CV = np.diag([1.0, -1.0, -1.0])
"""Rotation between a MuJoCo camera frame and the OpenCV optical frame (its own inverse)."""


@dataclass(frozen=True)
class PoseError:
    """Difference between a believed and a true pose.

    Attributes:
        rotation_deg: Angle of the relative rotation ``R_believed^T R_true`` [deg].
        translation_mm: Distance between the two positions [mm].
    """

    rotation_deg: float
    translation_mm: float


def pose_error(believed: ArrayLike, true: ArrayLike) -> PoseError:
    """Rotation [deg] and translation [mm] between two 4×4 poses given in the same frame."""
    a = np.asarray(believed, dtype=np.float64)
    b = np.asarray(true, dtype=np.float64)
    return PoseError(
        rotation_angle_deg(a[:3, :3].T @ b[:3, :3]),
        1000.0 * float(np.linalg.norm(a[:3, 3] - b[:3, 3])),
    )
