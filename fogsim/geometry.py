"""Frame conventions shared by the robot, the scene and the camera (no MuJoCo import).

Cameras follow OpenCV's optical frame (x right, y down, z forward); MuJoCo cameras look along
their −z with y up. The two differ by a rotation of π about x: ``R_cv = R_mj @ MJ_FROM_CV`` and
``R_mj = R_cv @ MJ_FROM_CV`` (the matrix is its own inverse).
"""

import numpy as np

MJ_FROM_CV = np.diag([1.0, -1.0, -1.0])
"""Rotation between a MuJoCo camera frame and the OpenCV optical frame (its own inverse)."""
