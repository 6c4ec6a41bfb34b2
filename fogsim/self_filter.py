"""Remove the robot's own body from depth images before they reach the mapper.

The body is approximated by one box per geometry (bounding its mesh in the joint frame, see
`fogsim.robot.BodyBox`), inflated by a margin. Each frame, pinocchio's forward kinematics of the
joint readings places the boxes relative to the camera (the same kinematics that gives the
believed camera pose, so no world pose is needed); every pixel whose back-projected point falls
in a box is flagged. Points at or below the believed ground plane of R (z_R below
``ground_clearance_m``) are never flagged, so the floor next to the feet survives.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike, NDArray

from fogsim.errors import FogsimError
from fogsim.robot import Robot
from mapper.intrinsics import PinholeIntrinsics


@dataclass(frozen=True)
class SelfFilterParams:
    """Parameters of the self-filter.

    Attributes:
        margin_m: Inflation of every body box [m] (absorbs the box fit and encoder errors).
        ground_clearance_m: Points lower than this in R are never robot [m].
    """

    margin_m: float = 0.03
    ground_clearance_m: float = 0.004

    def __post_init__(self) -> None:
        if not 0.0 <= self.margin_m <= 0.5:
            raise FogsimError(
                f"SelfFilterParams.margin_m must be in [0, 0.5] m, got {self.margin_m}"
            )
        if not -0.5 <= self.ground_clearance_m <= 0.5:
            raise FogsimError(
                "SelfFilterParams.ground_clearance_m must be in [-0.5, 0.5] m, got "
                f"{self.ground_clearance_m}"
            )


@numba.njit(cache=True)
def _points_in_boxes(
    points: np.ndarray,  # (N, 3) camera frame
    rotations: np.ndarray,  # (B, 3, 3) box axes in the camera frame
    centres: np.ndarray,  # (B, 3)
    half: np.ndarray,  # (B, 3) inflated half extents
    radius2: np.ndarray,  # (B,) squared bounding-sphere radius, for early rejection
) -> np.ndarray:
    n = points.shape[0]
    inside = np.zeros(n, dtype=np.bool_)
    for i in range(n):
        px, py, pz = points[i, 0], points[i, 1], points[i, 2]
        if not (px == px and py == py and pz == pz):
            continue
        for b in range(centres.shape[0]):
            dx, dy, dz = px - centres[b, 0], py - centres[b, 1], pz - centres[b, 2]
            if dx * dx + dy * dy + dz * dz > radius2[b]:
                continue
            ok = True
            for a in range(3):
                proj = dx * rotations[b, 0, a] + dy * rotations[b, 1, a] + dz * rotations[b, 2, a]
                if abs(proj) > half[b, a]:
                    ok = False
                    break
            if ok:
                inside[i] = True
                break
    return inside


class SelfFilter:
    """Flags depth pixels that lie on the robot at the configuration it believes it has.

    Args:
        robot: The humanoid.
        params: Margin and ground clearance.
        camera: Camera frame the depth images come from.
    """

    def __init__(
        self, robot: Robot, params: SelfFilterParams | None = None, camera: str = "head_camera"
    ) -> None:
        self.robot = robot
        self.params = params or SelfFilterParams()
        self.model = robot.pin_model
        self.data = robot.pin_model.createData()
        self.camera_frame_id = robot.frame_id(camera)
        boxes = robot.body_boxes
        self.joint_ids = np.array([b.joint_id for b in boxes], dtype=np.intp)
        self.box_in_joint = np.stack([b.transform_box_to_joint for b in boxes])
        self.half = np.stack([b.half_extents_m for b in boxes]) + self.params.margin_m
        self.radius2 = np.sum(self.half**2, axis=1)

    def boxes_in_camera(
        self, q_read: ArrayLike
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """Box axes (B, 3, 3), centres (B, 3) [m] in the camera frame and half extents (B, 3)."""
        q = self.robot.full_configuration(q_read).copy()
        q[:7] = self.robot.neutral()[:7]
        pin.forwardKinematics(self.model, self.data, q)
        camera = pin.updateFramePlacement(self.model, self.data, self.camera_frame_id)
        camera_inv = np.asarray(camera.inverse().homogeneous)
        joints = np.stack([self.data.oMi[int(j)].homogeneous for j in self.joint_ids])
        boxes = camera_inv @ joints @ self.box_in_joint
        return boxes[:, :3, :3].copy(), boxes[:, :3, 3].copy(), self.half

    def mask(
        self,
        depth_m: ArrayLike,
        intrinsics: PinholeIntrinsics,
        q_read: ArrayLike,
        transform_camera_to_robot: ArrayLike | None = None,
    ) -> NDArray[np.bool_]:
        """Pixels of a depth image that lie on the robot's body.

        Args:
            depth_m: (H, W) depth along the optical axis [m], NaN or 0 = none.
            intrinsics: Intrinsics of the depth image.
            q_read: Joint readings (or a full pinocchio configuration; the root is ignored).
            transform_camera_to_robot: Believed 4×4 camera pose in R; if given, points below
                ``ground_clearance_m`` in R are kept (never flagged).

        Returns:
            (H, W) bool, True where the pixel shows the robot.
        """
        points = intrinsics.depth_to_points_camera(depth_m).reshape(-1, 3)
        rotations, centres, half = self.boxes_in_camera(q_read)
        inside = _points_in_boxes(points, rotations, centres, half, self.radius2)
        if transform_camera_to_robot is not None:
            t = np.asarray(transform_camera_to_robot, dtype=np.float64)
            if t.shape != (4, 4):
                raise FogsimError(f"transform_camera_to_robot must be 4×4, got {t.shape}")
            z_robot = points @ t[2, :3] + t[2, 3]
            inside &= ~(z_robot < self.params.ground_clearance_m)
        return inside.reshape(intrinsics.shape)

    def apply(
        self,
        depth_m: ArrayLike,
        intrinsics: PinholeIntrinsics,
        q_read: ArrayLike,
        transform_camera_to_robot: ArrayLike | None = None,
    ) -> tuple[NDArray[np.float32], int]:
        """Depth image with robot pixels set to NaN, and how many pixels were removed."""
        depth = np.array(depth_m, dtype=np.float32, copy=True)
        flagged = self.mask(depth, intrinsics, q_read, transform_camera_to_robot)
        depth[flagged] = np.nan
        return depth, int(flagged.sum())
