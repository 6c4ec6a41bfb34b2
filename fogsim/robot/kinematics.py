"""The humanoid's kinematics as the robot computes them: pinocchio forward kinematics and frames.

Frames:
    world: z up, ground at z = 0.
    sole: each foot's sole frame (x forward along the foot, z up out of the sole).
    foot centre: the sole frame moved to the middle of the footprint.
    robot R: on the ground under the robot, halfway between the two foot centres (x, y), at the
        height of the reference (stance) sole, z up, yaw = mean yaw of the two soles
        (x forward). When both feet are down (``Stance.DOUBLE``) the left sole is the reference.
        Roll and pitch of R are zero by definition (the reference sole stands on a flat surface).
    camera: OpenCV optical frame (x right, y down, z forward). MuJoCo cameras look along -z with
        y up: ``R_cv = R_mj @ diag(1, -1, -1)``.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike, NDArray

from fogsim.errors import RobotModelError
from fogsim.robot.body_boxes import BodyBox
from fogsim.robot.description import RobotDescription
from fogsim.robot.planar import mean_angle, yaw_of


@dataclass(frozen=True)
class LookRange:
    """The head's reach as a route's ``look`` gives it: (yaw, pitch) relative to the body [deg].

    Attributes:
        yaw_deg: (lowest, highest) yaw; + turns the head left.
        pitch_deg: (lowest, highest) pitch; + looks up.
    """

    yaw_deg: tuple[float, float]
    pitch_deg: tuple[float, float]

    def refusal(self, yaw_deg: float, pitch_deg: float) -> str | None:
        """Why the head cannot look at (yaw, pitch) [deg], naming the reach; None if it can."""
        wrong = [
            f"{name} {value:g}°"
            for name, value, (lo, hi) in (
                ("yaw", yaw_deg, self.yaw_deg),
                ("pitch", pitch_deg, self.pitch_deg),
            )
            if not lo <= value <= hi
        ]
        if not wrong:
            return None
        return (
            f"{' and '.join(wrong)} beyond the neck's reach: yaw within [{self.yaw_deg[0]:g}, "
            f"{self.yaw_deg[1]:g}]° (+ turns left), pitch within [{self.pitch_deg[0]:g}, "
            f"{self.pitch_deg[1]:g}]° (+ looks up)"
        )


class Stance(enum.IntEnum):
    """Which foot carries the robot (the odometry's and robot frame's reference)."""

    LEFT = 0
    RIGHT = 1
    DOUBLE = 2


@dataclass(frozen=True, eq=False)
class Robot:
    """A humanoid loaded into pinocchio and MuJoCo (see the module docstring for frames).

    Attributes:
        description: What the testbed knows of the robot beyond its URDF.
        mjcf_path: Standalone MuJoCo XML (free joint "root", cameras in `CAMERA_NAMES`); its
            meshes are the files of `fogsim.robot.mjcf.mjcf_files`, in the folder beside it.
        pin_model: Pinocchio model with a free-flyer root and frames "head_camera",
            "head_camera_left", "head_camera_right" (OpenCV convention).
        pin_data: Pinocchio data for `pin_model` (scratch space; not thread safe).
        joint_names: Actuated joints in pinocchio order (q[7:] order).
        mujoco_joint_names: Joints of the MuJoCo model in qpos order, "root" first.
        body_boxes: Boxes bounding every geometry (in joint frames), for the self-filter.
    """

    description: RobotDescription
    mjcf_path: Path
    pin_model: pin.Model
    pin_data: pin.Data
    joint_names: tuple[str, ...]
    mujoco_joint_names: tuple[str, ...]
    body_boxes: tuple[BodyBox, ...]
    _qpos_index: NDArray[np.intp]
    _frame_ids: dict[str, int]
    _neutral: NDArray[np.float64]

    # ------------------------------------------------------------------ sizes and indices
    @property
    def name(self) -> str:
        """Robot name ("icub", "talos")."""
        return self.description.name

    @property
    def stereo_baseline_m(self) -> float:
        """Distance between the left and right cameras [m]."""
        return self.description.camera.stereo_baseline_m

    @property
    def nq(self) -> int:
        """Size of a pinocchio configuration (7 free-flyer + joints)."""
        return int(self.pin_model.nq)

    @property
    def n_joints(self) -> int:
        """Number of actuated joints."""
        return len(self.joint_names)

    def joint_limits_rad(self, name: str) -> tuple[float, float]:
        """(lower, upper) position limit of an actuated joint [rad], as the URDF gives it."""
        index = 7 + self.joint_index(name)
        return (
            float(self.pin_model.lowerPositionLimit[index]),
            float(self.pin_model.upperPositionLimit[index]),
        )

    @property
    def look_range(self) -> LookRange:
        """The head's reach in the route's ``look`` convention, from the neck joints' limits.

        Rounded to 0.01° (the URDFs store the limits as radians: iCub's -40° is
        -40.0000171°): a look of exactly the limit is within reach.
        """
        neck = self.description.neck
        yaw = tuple(round(math.degrees(v), 2) for v in self.joint_limits_rad(neck.yaw_joint))
        pitch = sorted(
            round(math.degrees(v) / neck.pitch_sign, 2)
            for v in self.joint_limits_rad(neck.pitch_joint)
        )
        return LookRange((yaw[0], yaw[1]), (pitch[0], pitch[1]))

    def joint_index(self, name: str) -> int:
        """Index of an actuated joint in ``q[7:]`` (and in encoder readings)."""
        try:
            return self.joint_names.index(name)
        except ValueError:
            raise RobotModelError(
                f"{self.name} has no joint {name!r}; joints: {', '.join(self.joint_names)}"
            ) from None

    def frame_id(self, name: str) -> int:
        """Pinocchio frame index of ``name``."""
        try:
            return self._frame_ids[name]
        except KeyError:
            raise RobotModelError(f"{self.name} has no frame {name!r}") from None

    def sole_frame(self, foot: Stance) -> str:
        """Name of the sole frame of a foot (LEFT or RIGHT)."""
        return (
            self.description.feet.right_sole
            if foot == Stance.RIGHT
            else self.description.feet.left_sole
        )

    # ------------------------------------------------------------------ configurations
    def neutral(self) -> NDArray[np.float64]:
        """Pinocchio neutral configuration (root at the origin, all joints zero)."""
        return self._neutral.copy()

    def full_configuration(self, q_pin_or_joints: ArrayLike) -> NDArray[np.float64]:
        """A full pinocchio configuration from either a full one or joint angles only.

        Joint angles alone (length ``n_joints``) get the root at the origin, unrotated.
        """
        q = np.asarray(q_pin_or_joints, dtype=np.float64).reshape(-1)
        if q.size == self.nq:
            return q
        if q.size == self.n_joints:
            full = self.neutral()
            full[7:] = q
            return full
        raise RobotModelError(
            f"configuration of {self.name} must have {self.nq} (with free flyer) or "
            f"{self.n_joints} (joints only) entries, got {q.size}"
        )

    def qpos_mujoco(self, q_pin: ArrayLike) -> NDArray[np.float64]:
        """MuJoCo qpos of the standalone robot model for a pinocchio configuration.

        Pinocchio's free-flyer quaternion (x, y, z, w) becomes MuJoCo's (w, x, y, z); joints are
        mapped by name (order in `mujoco_joint_names`).
        """
        q = np.asarray(q_pin, dtype=np.float64).reshape(-1)
        if q.size != self.nq:
            raise RobotModelError(f"q_pin must have {self.nq} entries, got {q.size}")
        qpos = np.empty(self.nq)
        qpos[:3] = q[:3]
        qpos[3] = q[6]
        qpos[4:7] = q[3:6]
        qpos[7:] = q[7:][self._qpos_index]
        return qpos

    # ------------------------------------------------------------------ kinematics
    def frame_transforms(
        self, q_pin_or_joints: ArrayLike, frames: tuple[str, ...]
    ) -> list[NDArray[np.float64]]:
        """4×4 poses of named frames in the root's world (pinocchio forward kinematics)."""
        return [
            np.asarray(p.homogeneous, dtype=np.float64).copy()
            for p in self._placements(q_pin_or_joints, frames)
        ]

    def _placements(self, q_pin_or_joints: ArrayLike, frames: tuple[str, ...]) -> list[pin.SE3]:
        q = self.full_configuration(q_pin_or_joints)
        model, data = self.pin_model, self.pin_data
        pin.forwardKinematics(model, data, q)
        return [pin.SE3(pin.updateFramePlacement(model, data, self.frame_id(n))) for n in frames]

    def _foot_centre(self, sole: NDArray[np.float64]) -> NDArray[np.float64]:
        return sole[:3, 3] + self.description.feet.center_offset_m * sole[:3, 0]

    def _robot_frame_from_soles(
        self, reference: NDArray[np.float64], other: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        """Planar pose (x, y, z, yaw) of R in the frame the soles are given in."""
        centre = 0.5 * (self._foot_centre(reference) + self._foot_centre(other))
        yaw = mean_angle(yaw_of(reference[:3, :3]), yaw_of(other[:3, :3]))
        return np.array([centre[0], centre[1], reference[2, 3], yaw])

    def _reference_and_other(self, stance_foot: Stance | int) -> tuple[str, str]:
        stance = Stance(int(stance_foot))
        if stance == Stance.RIGHT:
            return self.description.feet.right_sole, self.description.feet.left_sole
        return self.description.feet.left_sole, self.description.feet.right_sole

    def robot_frame_in_world(
        self, q_pin: ArrayLike, stance_foot: Stance | int = Stance.LEFT
    ) -> NDArray[np.float64]:
        """Pose (x [m], y [m], z [m], yaw [rad]) of the robot frame R in the world.

        R: halfway between the foot centres, at the reference sole's height, yaw = mean sole
        yaw. The reference is the stance foot (the left one for DOUBLE).
        """
        reference, other = self._reference_and_other(stance_foot)
        t_ref, t_other = self.frame_transforms(q_pin, (reference, other))
        return self._robot_frame_from_soles(t_ref, t_other)

    def transform_camera_to_robot(
        self,
        q_pin_or_readings: ArrayLike,
        stance_foot: Stance | int = Stance.LEFT,
        camera: str = "head_camera",
    ) -> NDArray[np.float64]:
        """4×4 camera (OpenCV) pose in R from joint angles alone (the free flyer is ignored).

        Assumes the reference sole stands flat (zero roll and pitch); this is how the robot
        computes its camera pose from its encoders.
        """
        reference, other = self._reference_and_other(stance_foot)
        t_ref, t_other, t_cam = self._placements(
            self.configuration_at_origin(q_pin_or_readings), (reference, other, camera)
        )
        t_robot_in_sole = self._robot_in_sole(t_ref.actInv(t_other))
        return t_robot_in_sole.actInv(t_ref.actInv(t_cam)).homogeneous

    def configuration_at_origin(self, q_pin_or_readings: ArrayLike) -> NDArray[np.float64]:
        """Full configuration with the root at the origin (joint angles only matter)."""
        q = np.asarray(q_pin_or_readings, dtype=np.float64).reshape(-1)
        if q.size == self.n_joints:
            full = self._neutral.copy()
            full[7:] = q
            return full
        q = self.full_configuration(q).copy()
        q[:7] = self._neutral[:7]
        return q

    def _robot_in_sole(self, other_in_reference: pin.SE3) -> pin.SE3:
        """R in the reference sole frame (level), given the other sole in that frame."""
        offset = self.description.feet.center_offset_m
        rotation = other_in_reference.rotation
        centre = 0.5 * (
            np.array([offset, 0.0, 0.0]) + other_in_reference.translation + offset * rotation[:, 0]
        )
        yaw = 0.5 * math.atan2(rotation[1, 0], rotation[0, 0])
        c, s = math.cos(yaw), math.sin(yaw)
        return pin.SE3(
            np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]),
            np.array([centre[0], centre[1], 0.0]),
        )

    def transform_robot_to_sole(
        self, q_pin_or_readings: ArrayLike, stance_foot: Stance | int = Stance.LEFT
    ) -> NDArray[np.float64]:
        """4×4 pose of R in the reference sole frame, from joint angles alone.

        The reference sole is taken as flat and level, so R's z axis is the sole's z axis.
        """
        reference, other = self._reference_and_other(stance_foot)
        t_ref, t_other = self._placements(
            self.configuration_at_origin(q_pin_or_readings), (reference, other)
        )
        return self._robot_in_sole(t_ref.actInv(t_other)).homogeneous

    def transform_sole_to_sole(
        self, q_pin_or_readings: ArrayLike, from_foot: Stance, to_foot: Stance
    ) -> NDArray[np.float64]:
        """4×4 pose of ``to_foot``'s sole in ``from_foot``'s sole frame (joint angles alone)."""
        t_from, t_to = self._placements(
            self.configuration_at_origin(q_pin_or_readings),
            (self.sole_frame(Stance(from_foot)), self.sole_frame(Stance(to_foot))),
        )
        return t_from.actInv(t_to).homogeneous

    def transform_camera_to_world(
        self, q_pin: ArrayLike, camera: str = "head_camera"
    ) -> NDArray[np.float64]:
        """4×4 true camera (OpenCV) pose in the world from a full configuration."""
        q = np.asarray(q_pin, dtype=np.float64).reshape(-1)
        if q.size != self.nq:
            raise RobotModelError(f"q_pin must have {self.nq} entries, got {q.size}")
        return self.frame_transforms(q, (camera,))[0]
