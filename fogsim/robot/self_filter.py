"""Remove the robot's own body from depth images before they reach the mapper.

The body is approximated by one box per geometry (bounding its mesh in the joint frame, see
`fogsim.robot.body_boxes.BodyBox`), inflated by a margin. Each frame, forward kinematics of the
joint readings places the boxes relative to the camera (the same kinematics that gives the
believed camera pose, so no world pose is needed); every pixel whose back-projected point falls
in a box is flagged. Points at or below the believed ground plane of R (z_R below
``ground_clearance_m``) are never flagged, so the floor next to the feet survives.

MuJoCo is imported by :class:`SelfFilter` when one is made (a simulation), not with the module:
the run's kernel warm-up (:mod:`fogsim.run.warmup`) loads the mask kernel in replays too.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray

from fogsim.errors import CameraError, ParameterError, RobotModelError
from mapper import kernel_cache
from mapper.intrinsics import PinholeIntrinsics

# numba's cache of this folder's kernel stamped by its text, not the file's time (the mapper's
# rule, `mapper.kernel_cache`): the shipped kernel bundle then applies to a fresh checkout
# (`fogsim.run.kernel_bundle`). Installed before the kernel below is decorated.
kernel_cache.install(Path(__file__).resolve().parent)

if TYPE_CHECKING:
    from fogsim.robot.kinematics import Robot


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
            raise ParameterError(
                f"SelfFilterParams.margin_m must be in [0, 0.5] m, got {self.margin_m}"
            )
        if not -0.5 <= self.ground_clearance_m <= 0.5:
            raise ParameterError(
                "SelfFilterParams.ground_clearance_m must be in [-0.5, 0.5] m, got "
                f"{self.ground_clearance_m}"
            )


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _mask_kernel(
    depth: np.ndarray,  # (H, W) depth along the optical axis [m], NaN/<=0 = none
    fx: float,
    fy: float,
    cx: float,
    cy: float,
    rotations: np.ndarray,  # (B, 3, 3) box axes in the camera frame (columns)
    centres: np.ndarray,  # (B, 3) box centres in the camera frame [m]
    half: np.ndarray,  # (B, 3) inflated half extents [m]
    ground: np.ndarray,  # (4,) z_R = ground[:3]·p + ground[3]
    clearance: float,  # points with z_R below this are never flagged [m]
) -> np.ndarray:
    height, width = depth.shape
    inside = np.zeros((height, width), dtype=np.bool_)
    for b in range(centres.shape[0]):
        # pixel rectangle covered by the box (whole image if it reaches behind the camera)
        u0, u1, v0, v1 = width, -1, height, -1
        behind = 0
        z_low, z_high = np.inf, -np.inf
        for corner in range(8):
            p = centres[b].copy()
            for a in range(3):
                sign = 1.0 if (corner >> a) & 1 else -1.0
                for k in range(3):
                    p[k] += sign * half[b, a] * rotations[b, k, a]
            z_low, z_high = min(z_low, p[2]), max(z_high, p[2])
            if p[2] <= 1e-3:
                behind += 1
                continue
            u = fx * p[0] / p[2] + cx
            v = fy * p[1] / p[2] + cy
            u0, u1 = min(u0, int(np.floor(u))), max(u1, int(np.ceil(u)))
            v0, v1 = min(v0, int(np.floor(v))), max(v1, int(np.ceil(v)))
        if behind == 8:
            continue  # wholly behind the camera: invisible
        if behind > 0:  # straddles the camera plane: may cover any pixel
            u0, u1, v0, v1 = 0, width - 1, 0, height - 1
        u0, u1 = max(u0, 0), min(u1, width - 1)
        v0, v1 = max(v0, 0), min(v1, height - 1)
        for v in range(v0, v1 + 1):
            for u in range(u0, u1 + 1):
                d = depth[v, u]
                if inside[v, u] or not (d > 0.0 and z_low <= d <= z_high):  # rejects NaN
                    continue
                px, py, pz = (u - cx) / fx * d, (v - cy) / fy * d, d
                if ground[0] * px + ground[1] * py + ground[2] * pz + ground[3] < clearance:
                    continue
                dx, dy, dz = px - centres[b, 0], py - centres[b, 1], pz - centres[b, 2]
                ok = True
                for a in range(3):
                    proj = (
                        dx * rotations[b, 0, a] + dy * rotations[b, 1, a] + dz * rotations[b, 2, a]
                    )
                    if abs(proj) > half[b, a]:
                        ok = False
                        break
                if ok:
                    inside[v, u] = True
    return inside


def compile_mask_kernel() -> None:
    """Compile (or load from numba's cache) the mask kernel on a 2 × 2 image and one box.

    Called by the run's kernel warm-up (`fogsim.run.warmup`) so that the first frame of a
    simulated run does not compile it silently.
    """
    eye = np.eye(3)[None]
    _mask_kernel(
        np.ones((2, 2)),
        1.0,
        1.0,
        0.5,
        0.5,
        eye,
        np.array([[0.0, 0.0, 1.0]]),
        np.full((1, 3), 0.1),
        np.array([0.0, 0.0, 0.0, 1e9]),
        0.0,
    )


class SelfFilter:
    """Flags depth pixels that lie on the robot at the configuration it believes it has.

    The boxes are placed by forward kinematics of the readings on a private MuJoCo copy of the
    robot (the same kinematic model as pinocchio's, tested to agree to 1e-9; MuJoCo returns
    all body poses as arrays in a few microseconds).

    Args:
        robot: The humanoid.
        params: Margin and ground clearance.
        camera: Camera frame the depth images come from.
    """

    def __init__(
        self, robot: Robot, params: SelfFilterParams | None = None, camera: str = "head_camera"
    ) -> None:
        import mujoco  # only where a filter is made (module doc)

        from fogsim.robot.mj_xml import model_from_xml_path

        self.robot = robot
        self.params = params or SelfFilterParams()
        self.mj_model = model_from_xml_path(robot.mjcf_path)
        self.mj_data = mujoco.MjData(self.mj_model)
        self.camera_site = mujoco.mj_name2id(self.mj_model, mujoco.mjtObj.mjOBJ_SITE, camera)
        if self.camera_site < 0:
            raise RobotModelError(f"{robot.name} has no camera {camera!r}")
        boxes = robot.body_boxes
        body_ids = []
        for box in boxes:
            name = "root" if box.joint_id == 1 else robot.pin_model.names[box.joint_id]
            joint = mujoco.mj_name2id(self.mj_model, mujoco.mjtObj.mjOBJ_JOINT, name)
            body_ids.append(int(self.mj_model.jnt_bodyid[joint]))
        self.body_ids = np.array(body_ids, dtype=np.intp)
        self.box_centres_in_body = np.stack([b.transform_box_to_joint[:3, 3] for b in boxes])
        self.box_axes_in_body = np.stack([b.transform_box_to_joint[:3, :3] for b in boxes])
        self.half = np.stack([b.half_extents_m for b in boxes]) + self.params.margin_m
        self._kinematics = functools.partial(mujoco.mj_kinematics, self.mj_model, self.mj_data)

    def boxes_in_camera(
        self, q_read: ArrayLike
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """Box axes (B, 3, 3), centres (B, 3) [m] in the camera frame and half extents (B, 3)."""
        robot = self.robot
        self.mj_data.qpos[:] = robot.qpos_mujoco(robot.configuration_at_origin(q_read))
        self._kinematics()
        body_rot = self.mj_data.xmat[self.body_ids].reshape(-1, 3, 3)
        body_pos = self.mj_data.xpos[self.body_ids]
        cam_rot = self.mj_data.site_xmat[self.camera_site].reshape(3, 3)
        cam_pos = self.mj_data.site_xpos[self.camera_site]
        centres_world = np.einsum("bij,bj->bi", body_rot, self.box_centres_in_body) + body_pos
        centres = (centres_world - cam_pos) @ cam_rot
        rotations = cam_rot.T @ body_rot @ self.box_axes_in_body
        return rotations, centres, self.half

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
        depth = np.asarray(depth_m, dtype=np.float64)
        if depth.shape != intrinsics.shape:
            raise CameraError(f"depth_m must have shape {intrinsics.shape}, got {depth.shape}")
        ground = np.array([0.0, 0.0, 0.0, 1e9])  # no ground plane given: nothing is below it
        if transform_camera_to_robot is not None:
            t = np.asarray(transform_camera_to_robot, dtype=np.float64)
            if t.shape != (4, 4):
                raise CameraError(f"transform_camera_to_robot must be 4×4, got {t.shape}")
            ground = t[2].copy()
        rotations, centres, half = self.boxes_in_camera(q_read)
        return _mask_kernel(
            np.ascontiguousarray(depth),
            intrinsics.fx,
            intrinsics.fy,
            intrinsics.cx,
            intrinsics.cy,
            rotations,
            centres,
            half,
            ground,
            self.params.ground_clearance_m,
        )

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
