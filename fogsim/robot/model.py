"""The humanoid: one `example-robot-data` model loaded into pinocchio and into MuJoCo.

Pinocchio holds the robot's own kinematics (what it believes); MuJoCo renders the true world.
The MuJoCo model is generated *from the pinocchio model* (joint placements, axes, inertias,
geometry placements), so both agree on joint zeros and axes by construction; a test checks every
frame to 1e-9. Meshes are taken from the geometry pinocchio loaded (coal meshes), written inline
into one MJCF file in a cache directory (``~/.cache/fogsim/robots/<name>/``, root overridable by
the environment variable ``FOGSIM_CACHE``).

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

Known quirk handled here: the iCub COLLADA meshes of example-robot-data are stored ``Y_UP`` and
coal loads them without the up-axis rotation, which leaves limbs "exploded"
(Gepetto/example-robot-data#105). We rotate them by +90° about x (Y_UP → Z_UP) before use.
"""

from __future__ import annotations

import enum
import functools
import hashlib
import math
import os
import warnings
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import mujoco
import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike, NDArray

from fogsim.atomic import write_text_atomic
from fogsim.errors import RobotModelError
from fogsim.geometry import MJ_FROM_CV

#: Bump when the generated MJCF changes, so stale cache files are rebuilt.
_CACHE_FORMAT_VERSION = 3
MIN_BODY_MASS_KG = 1e-3
MIN_PRINCIPAL_INERTIA_KGM2 = 1e-6
CAMERA_FOVY_DEG = 39.0
_Y_UP_TO_Z_UP = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])


class Stance(enum.IntEnum):
    """Which foot carries the robot (the odometry's and robot frame's reference)."""

    LEFT = 0
    RIGHT = 1
    DOUBLE = 2


@dataclass(frozen=True)
class RobotConfig:
    """What the testbed needs to know about one humanoid beyond its URDF.

    Attributes:
        name: Our name for the robot.
        erd_name: Name for ``example_robot_data.load``.
        left_sole: Pinocchio frame of the left sole (x forward, z up).
        right_sole: Pinocchio frame of the right sole.
        sole_center_offset_m: Footprint centre along the sole's x axis [m].
        foot_length_m: Footprint extent (back, front) along sole x from the sole origin [m].
        foot_half_width_m: Half the footprint width [m].
        left_leg_joints: The six left-leg joints, hip to ankle.
        right_leg_joints: The six right-leg joints.
        neck_joints: Every joint between the torso and the head (the encoders' NECK group).
        neck_yaw_joint: Joint that turns the head left (+) / right.
        neck_pitch_joint: Joint that tilts the head.
        neck_pitch_sign: +1 if a positive neck_pitch angle looks up, -1 if it looks down.
        camera_parent_joint: Joint whose body carries the cameras.
        camera_frame: Existing pinocchio frame for the depth camera (OpenCV convention), or
            empty to use ``camera_position_in_parent`` looking forward along ``camera_forward``.
        camera_position_in_parent: Camera position in the parent joint frame [m].
        camera_forward_in_parent: Unit forward (optical z) axis in the parent joint frame.
        camera_up_in_parent: Unit up axis in the parent joint frame (optical -y).
        stereo_baseline_m: Distance between left and right cameras [m].
        fix_y_up_meshes: Rotate mesh vertices Y_UP → Z_UP (see module docstring).
        use_collision_meshes_for_visuals: Use the (lighter) collision model for MuJoCo geoms.
        nominal_pelvis_height_m: Root height above the stance surface when walking [m].
        arm_pose_rad: Joint name → angle for a relaxed arm pose.
        camera_ahead_m: Move the cameras this far along their view axis from
            ``camera_frame`` (or ``camera_position_in_parent``) [m], to put them in front of
            the head geometry MuJoCo renders (a convex collision hull can enclose the real
            lens position).
    """

    name: str
    erd_name: str
    left_sole: str
    right_sole: str
    sole_center_offset_m: float
    foot_length_m: tuple[float, float]
    foot_half_width_m: float
    left_leg_joints: tuple[str, ...]
    right_leg_joints: tuple[str, ...]
    neck_joints: tuple[str, ...]
    neck_yaw_joint: str
    neck_pitch_joint: str
    neck_pitch_sign: float
    camera_parent_joint: str
    camera_frame: str
    camera_position_in_parent: tuple[float, float, float]
    camera_forward_in_parent: tuple[float, float, float]
    camera_up_in_parent: tuple[float, float, float]
    stereo_baseline_m: float
    fix_y_up_meshes: bool
    use_collision_meshes_for_visuals: bool
    nominal_pelvis_height_m: float
    arm_pose_rad: dict[str, float] = field(default_factory=dict)
    camera_ahead_m: float = 0.0


# iCub: root_link has x backward, y to the robot's right, z up; the head (neck_yaw) frame has
# x backward, y down, z right. The eyes sit ~10 cm above the neck-yaw axis, just in front of the
# face (face surface measured at 7.5 cm in front of the axis at that height), 68 mm apart.
_ICUB = RobotConfig(
    name="icub",
    erd_name="icub",
    left_sole="l_sole",
    right_sole="r_sole",
    sole_center_offset_m=0.05,
    foot_length_m=(-0.028, 0.128),
    foot_half_width_m=0.03,
    left_leg_joints=(
        "l_hip_pitch",
        "l_hip_roll",
        "l_hip_yaw",
        "l_knee",
        "l_ankle_pitch",
        "l_ankle_roll",
    ),
    right_leg_joints=(
        "r_hip_pitch",
        "r_hip_roll",
        "r_hip_yaw",
        "r_knee",
        "r_ankle_pitch",
        "r_ankle_roll",
    ),
    neck_joints=("neck_pitch", "neck_roll", "neck_yaw"),
    neck_yaw_joint="neck_yaw",
    neck_pitch_joint="neck_pitch",
    neck_pitch_sign=1.0,
    camera_parent_joint="neck_yaw",
    camera_frame="",
    camera_position_in_parent=(-0.09, -0.10, 0.0),
    camera_forward_in_parent=(-1.0, 0.0, 0.0),
    camera_up_in_parent=(0.0, -1.0, 0.0),
    stereo_baseline_m=0.068,
    fix_y_up_meshes=True,
    use_collision_meshes_for_visuals=False,
    nominal_pelvis_height_m=0.575,
    arm_pose_rad={
        "l_shoulder_roll": 0.35,
        "r_shoulder_roll": 0.35,
        "l_elbow": 0.6,
        "r_elbow": 0.6,
        "l_shoulder_pitch": -0.2,
        "r_shoulder_pitch": -0.2,
    },
)

_TALOS = RobotConfig(
    name="talos",
    erd_name="talos",
    left_sole="left_sole_link",
    right_sole="right_sole_link",
    sole_center_offset_m=0.0,
    foot_length_m=(-0.1, 0.1),
    foot_half_width_m=0.065,
    left_leg_joints=tuple(f"leg_left_{i}_joint" for i in range(1, 7)),
    right_leg_joints=tuple(f"leg_right_{i}_joint" for i in range(1, 7)),
    neck_joints=("head_1_joint", "head_2_joint"),
    neck_yaw_joint="head_2_joint",  # about z of head_1_link: + turns left
    neck_pitch_joint="head_1_joint",  # about y of torso_2_link: + looks down
    neck_pitch_sign=-1.0,
    camera_parent_joint="head_2_joint",
    camera_frame="rgbd_optical_frame",
    camera_position_in_parent=(0.0, 0.0, 0.0),
    camera_forward_in_parent=(1.0, 0.0, 0.0),
    camera_up_in_parent=(0.0, 0.0, 1.0),
    stereo_baseline_m=0.07,
    fix_y_up_meshes=False,
    use_collision_meshes_for_visuals=True,
    nominal_pelvis_height_m=0.98,
    arm_pose_rad={
        "arm_left_2_joint": 0.25,
        "arm_right_2_joint": -0.25,
        "arm_left_4_joint": -0.5,
        "arm_right_4_joint": -0.5,
    },
    # rgbd_optical_frame sits 66 mm in front of the head axis, but the head's collision hull
    # (what MuJoCo renders) reaches 105 mm: the camera moves 50 mm ahead, out of the hull.
    camera_ahead_m=0.05,
)

ROBOT_CONFIGS: dict[str, RobotConfig] = {"icub": _ICUB, "talos": _TALOS}
ROBOT_NAMES: tuple[str, ...] = tuple(ROBOT_CONFIGS)
CAMERA_NAMES: tuple[str, str, str] = ("head_camera", "head_camera_left", "head_camera_right")


def cache_root() -> Path:
    """Directory holding generated robot models (``$FOGSIM_CACHE/robots`` or ~/.cache)."""
    base = os.environ.get("FOGSIM_CACHE")
    root = Path(base) if base else Path.home() / ".cache" / "fogsim"
    return root / "robots"


def _yaw_of(rotation: NDArray[np.float64]) -> float:
    """Yaw [rad] of a rotation's x axis projected on the horizontal plane."""
    return math.atan2(rotation[1, 0], rotation[0, 0])


def _se3_to_matrix(placement: pin.SE3) -> NDArray[np.float64]:
    return np.asarray(placement.homogeneous, dtype=np.float64).copy()


def _mean_angle(a: float, b: float) -> float:
    return a + 0.5 * math.atan2(math.sin(b - a), math.cos(b - a))


@dataclass(frozen=True)
class BodyBox:
    """A box bounding one geometry of the robot, fixed to a pinocchio joint frame.

    Attributes:
        joint_id: Pinocchio joint the geometry moves with.
        name: Geometry name.
        transform_box_to_joint: 4×4 box centre and axes in the joint frame.
        half_extents_m: (3,) half sizes along the box axes [m].
    """

    joint_id: int
    name: str
    transform_box_to_joint: NDArray[np.float64]
    half_extents_m: NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class Robot:
    """A humanoid loaded into pinocchio and MuJoCo (see the module docstring for frames).

    Attributes:
        name: Robot name ("icub", "talos").
        config: The robot's `RobotConfig`.
        mjcf_path: Standalone MuJoCo XML (free joint "root", cameras in `CAMERA_NAMES`).
        pin_model: Pinocchio model with a free-flyer root and frames "head_camera",
            "head_camera_left", "head_camera_right" (OpenCV convention).
        pin_data: Pinocchio data for `pin_model` (scratch space; not thread safe).
        joint_names: Actuated joints in pinocchio order (q[7:] order).
        mujoco_joint_names: Joints of the MuJoCo model in qpos order, "root" first.
        stereo_baseline_m: Distance between the left and right cameras [m].
        body_boxes: Boxes bounding every geometry (in joint frames), for the self-filter.
    """

    name: str
    config: RobotConfig
    mjcf_path: Path
    pin_model: pin.Model
    pin_data: pin.Data
    joint_names: tuple[str, ...]
    mujoco_joint_names: tuple[str, ...]
    stereo_baseline_m: float
    body_boxes: tuple[BodyBox, ...]
    _qpos_index: NDArray[np.intp]
    _frame_ids: dict[str, int]
    _neutral: NDArray[np.float64]

    # ------------------------------------------------------------------ sizes and indices
    @property
    def nq(self) -> int:
        """Size of a pinocchio configuration (7 free-flyer + joints)."""
        return int(self.pin_model.nq)

    @property
    def n_joints(self) -> int:
        """Number of actuated joints."""
        return len(self.joint_names)

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
        return self.config.right_sole if foot == Stance.RIGHT else self.config.left_sole

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
        return [_se3_to_matrix(p) for p in self._placements(q_pin_or_joints, frames)]

    def _placements(self, q_pin_or_joints: ArrayLike, frames: tuple[str, ...]) -> list[pin.SE3]:
        q = self.full_configuration(q_pin_or_joints)
        model, data = self.pin_model, self.pin_data
        pin.forwardKinematics(model, data, q)
        return [pin.SE3(pin.updateFramePlacement(model, data, self.frame_id(n))) for n in frames]

    def _foot_centre(self, sole: NDArray[np.float64]) -> NDArray[np.float64]:
        return sole[:3, 3] + self.config.sole_center_offset_m * sole[:3, 0]

    def _robot_frame_from_soles(
        self, reference: NDArray[np.float64], other: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        """Planar pose (x, y, z, yaw) of R in the frame the soles are given in."""
        centre = 0.5 * (self._foot_centre(reference) + self._foot_centre(other))
        yaw = _mean_angle(_yaw_of(reference[:3, :3]), _yaw_of(other[:3, :3]))
        return np.array([centre[0], centre[1], reference[2, 3], yaw])

    def _reference_and_other(self, stance_foot: Stance | int) -> tuple[str, str]:
        stance = Stance(int(stance_foot))
        if stance == Stance.RIGHT:
            return self.config.right_sole, self.config.left_sole
        return self.config.left_sole, self.config.right_sole

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
            self._joints_only(q_pin_or_readings), (reference, other, camera)
        )
        t_robot_in_sole = self._robot_in_sole(t_ref.actInv(t_other))
        return t_robot_in_sole.actInv(t_ref.actInv(t_cam)).homogeneous

    def _joints_only(self, q_pin_or_readings: ArrayLike) -> NDArray[np.float64]:
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
        offset = self.config.sole_center_offset_m
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
        t_ref, t_other = self._placements(self._joints_only(q_pin_or_readings), (reference, other))
        return self._robot_in_sole(t_ref.actInv(t_other)).homogeneous

    def transform_sole_to_sole(
        self, q_pin_or_readings: ArrayLike, from_foot: Stance, to_foot: Stance
    ) -> NDArray[np.float64]:
        """4×4 pose of ``to_foot``'s sole in ``from_foot``'s sole frame (joint angles alone)."""
        t_from, t_to = self._placements(
            self._joints_only(q_pin_or_readings),
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


# ====================================================================== model generation


def _load_pinocchio(config: RobotConfig):
    import example_robot_data

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        wrapper = example_robot_data.load(config.erd_name)
    return wrapper


def _camera_rotation(forward: ArrayLike, up: ArrayLike) -> NDArray[np.float64]:
    """Rotation whose columns are the OpenCV camera axes (x right, y down, z forward)."""
    z = np.asarray(forward, dtype=np.float64)
    z /= np.linalg.norm(z)
    down = -np.asarray(up, dtype=np.float64)
    y = down - z * float(down @ z)
    y /= np.linalg.norm(y)
    return np.column_stack([np.cross(y, z), y, z])


def _add_camera_frames(model: pin.Model, config: RobotConfig) -> dict[str, pin.SE3]:
    """Add head_camera(_left/_right) frames (OpenCV convention); returns placements in joint."""
    parent_joint = model.getJointId(config.camera_parent_joint)
    if config.camera_frame:
        if not model.existFrame(config.camera_frame):
            raise RobotModelError(f"{config.name} has no camera frame {config.camera_frame!r}")
        frame = model.frames[model.getFrameId(config.camera_frame)]
        if frame.parentJoint != parent_joint:
            raise RobotModelError(
                f"{config.camera_frame} hangs on joint {model.names[frame.parentJoint]}, "
                f"expected {config.camera_parent_joint}"
            )
        centre = frame.placement
    else:
        rotation = _camera_rotation(config.camera_forward_in_parent, config.camera_up_in_parent)
        centre = pin.SE3(rotation, np.asarray(config.camera_position_in_parent, dtype=float))
    centre = centre * pin.SE3(np.eye(3), np.array([0.0, 0.0, config.camera_ahead_m]))
    half = 0.5 * config.stereo_baseline_m
    placements = {
        "head_camera": centre,
        "head_camera_left": centre * pin.SE3(np.eye(3), np.array([-half, 0.0, 0.0])),
        "head_camera_right": centre * pin.SE3(np.eye(3), np.array([half, 0.0, 0.0])),
    }
    parent_frame = model.getFrameId(config.camera_parent_joint, pin.FrameType.JOINT)
    for name, placement in placements.items():
        model.addFrame(
            pin.Frame(name, parent_joint, parent_frame, placement, pin.FrameType.OP_FRAME)
        )
    return placements


def _joint_axis(joint_model) -> NDArray[np.float64]:
    short = joint_model.shortname()
    axes = {"JointModelRX": (1, 0, 0), "JointModelRY": (0, 1, 0), "JointModelRZ": (0, 0, 1)}
    if short in axes:
        return np.array(axes[short], dtype=np.float64)
    if short == "JointModelRevoluteUnaligned":
        return np.asarray(joint_model.extract().axis, dtype=np.float64)
    raise RobotModelError(f"unsupported joint type {short} (revolute joints only)")


def _mesh_arrays(geometry, fix_y_up: bool) -> tuple[NDArray[np.float64], NDArray[np.int32]]:
    vertices = np.asarray(geometry.vertices(), dtype=np.float64)
    if fix_y_up:
        vertices = vertices @ _Y_UP_TO_Z_UP.T
    faces = np.empty((geometry.num_tris, 3), dtype=np.int32)
    for i in range(geometry.num_tris):
        tri = geometry.tri_indices(i)
        faces[i] = (tri[0], tri[1], tri[2])
    return vertices, faces


def _quat_wxyz(rotation: NDArray[np.float64]) -> NDArray[np.float64]:
    quat = np.empty(4)
    mujoco.mju_mat2Quat(quat, np.ascontiguousarray(rotation, dtype=np.float64).reshape(9))
    return quat


def _bounded_inertia(inertia: pin.Inertia) -> tuple[float, NDArray, NDArray]:
    mass = max(float(inertia.mass), MIN_BODY_MASS_KG)
    matrix = 0.5 * (inertia.inertia + inertia.inertia.T)
    if np.linalg.eigvalsh(matrix).min() < MIN_PRINCIPAL_INERTIA_KGM2:
        matrix = matrix + MIN_PRINCIPAL_INERTIA_KGM2 * np.eye(3)
    full = np.array(
        [matrix[0, 0], matrix[1, 1], matrix[2, 2], matrix[0, 1], matrix[0, 2], matrix[1, 2]]
    )
    return mass, np.asarray(inertia.lever, dtype=np.float64), full


def _fmt(values: ArrayLike) -> str:
    """Space-separated floats that read back bit for bit (MuJoCo's own writer keeps 6 digits)."""
    return " ".join(repr(float(v)) for v in np.asarray(values, dtype=np.float64).reshape(-1))


def _fmt_mesh(values: ArrayLike) -> str:
    return " ".join(f"{v:.9g}" for v in np.asarray(values, dtype=np.float64).reshape(-1))


def _add_geometry(
    asset: ET.Element, body: ET.Element, geometry_object, config: RobotConfig
) -> None:
    import coal

    geometry = geometry_object.geometry
    name = geometry_object.name
    placement = geometry_object.placement
    rgba = np.asarray(geometry_object.meshColor, dtype=np.float64)
    if not np.all(np.isfinite(rgba)) or rgba[3] <= 0.0 or rgba[:3].max() < 0.15:
        rgba = np.array([0.72, 0.72, 0.76, 1.0])  # URDF black/unset: a light grey to see it
    attributes = {
        "name": name,
        "pos": _fmt(placement.translation),
        "quat": _fmt(_quat_wxyz(placement.rotation)),
        "rgba": _fmt(rgba),
        "contype": "0",
        "conaffinity": "0",
        "group": "1",
    }
    if isinstance(geometry, coal.BVHModelBase):
        vertices, faces = _mesh_arrays(geometry, config.fix_y_up_meshes)
        vertices = vertices * np.asarray(geometry_object.meshScale, dtype=float)
        ET.SubElement(
            asset,
            "mesh",
            name=f"{name}_mesh",
            vertex=_fmt_mesh(vertices),
            face=" ".join(str(int(i)) for i in faces.reshape(-1)),
            inertia="shell",
        )
        ET.SubElement(body, "geom", type="mesh", mesh=f"{name}_mesh", **attributes)
    elif isinstance(geometry, coal.Box):
        ET.SubElement(body, "geom", type="box", size=_fmt(geometry.halfSide), **attributes)
    elif isinstance(geometry, coal.Cylinder | coal.Capsule):
        kind = "cylinder" if isinstance(geometry, coal.Cylinder) else "capsule"
        size = _fmt([geometry.radius, geometry.halfLength])
        ET.SubElement(body, "geom", type=kind, size=size, **attributes)
    elif isinstance(geometry, coal.Sphere):
        ET.SubElement(body, "geom", type="sphere", size=_fmt([geometry.radius]), **attributes)
    else:
        raise RobotModelError(f"unsupported geometry {type(geometry).__name__} in {name}")


def _geometry_box(geometry_object, config: RobotConfig) -> BodyBox:
    """Axis-aligned (in the joint frame) box around one geometry object."""
    import coal

    geometry = geometry_object.geometry
    if isinstance(geometry, coal.BVHModelBase):
        vertices = np.asarray(geometry.vertices(), dtype=np.float64)
        if config.fix_y_up_meshes:
            vertices = vertices @ _Y_UP_TO_Z_UP.T
        vertices = vertices * np.asarray(geometry_object.meshScale, dtype=float)
    else:
        if isinstance(geometry, coal.Box):
            half = np.asarray(geometry.halfSide, dtype=float)
        elif isinstance(geometry, coal.Cylinder | coal.Capsule):
            extra = geometry.radius if isinstance(geometry, coal.Capsule) else 0.0
            half = np.array([geometry.radius, geometry.radius, geometry.halfLength + extra])
        elif isinstance(geometry, coal.Sphere):
            half = np.full(3, geometry.radius)
        else:
            raise RobotModelError(f"unsupported geometry {type(geometry).__name__}")
        signs = np.array(np.meshgrid([-1, 1], [-1, 1], [-1, 1])).reshape(3, -1).T
        vertices = signs * half
    placement = geometry_object.placement
    in_joint = vertices @ placement.rotation.T + placement.translation
    low, high = in_joint.min(axis=0), in_joint.max(axis=0)
    transform = np.eye(4)
    transform[:3, 3] = 0.5 * (low + high)
    return BodyBox(
        int(geometry_object.parentJoint), geometry_object.name, transform, 0.5 * (high - low)
    )


def _body_names(model: pin.Model) -> list[str]:
    """MuJoCo body name of each pinocchio joint: its first BODY frame (the URDF child link)."""
    names = ["world"]
    for joint_id in range(1, model.njoints):
        candidates = [
            f.name
            for f in model.frames
            if f.parentJoint == joint_id and f.type == pin.FrameType.BODY
        ]
        names.append(candidates[0] if candidates else f"{model.names[joint_id]}_body")
    return names


def build_mjcf(config: RobotConfig, model: pin.Model, geometry_model) -> str:
    """Generate the standalone MJCF text of a robot from its pinocchio model.

    Numbers are written with full precision so that MuJoCo and pinocchio agree to 1e-12.
    """
    root = ET.Element("mujoco", model=config.name)
    ET.SubElement(root, "compiler", angle="radian", autolimits="true", fusestatic="false")
    visual = ET.SubElement(root, "visual")
    ET.SubElement(visual, "global", offwidth="640", offheight="480")
    asset = ET.SubElement(root, "asset")
    worldbody = ET.SubElement(root, "worldbody")
    body_names = _body_names(model)
    bodies = [worldbody]
    for joint_id in range(1, model.njoints):
        placement = model.jointPlacements[joint_id]
        body = ET.SubElement(
            bodies[model.parents[joint_id]],
            "body",
            name=body_names[joint_id],
            pos=_fmt(placement.translation),
            quat=_fmt(_quat_wxyz(placement.rotation)),
        )
        mass, lever, full = _bounded_inertia(model.inertias[joint_id])
        ET.SubElement(body, "inertial", pos=_fmt(lever), mass=repr(mass), fullinertia=_fmt(full))
        joint_model = model.joints[joint_id]
        if joint_model.shortname() == "JointModelFreeFlyer":
            ET.SubElement(body, "freejoint", name="root")
        else:
            idx = joint_model.idx_q
            limits = [model.lowerPositionLimit[idx], model.upperPositionLimit[idx]]
            ET.SubElement(
                body,
                "joint",
                name=model.names[joint_id],
                type="hinge",
                axis=_fmt(_joint_axis(joint_model)),
                range=_fmt(limits),
            )
        bodies.append(body)
    for geometry_object in geometry_model.geometryObjects:
        _add_geometry(asset, bodies[geometry_object.parentJoint], geometry_object, config)
    # Every other pinocchio frame becomes a site of the same name (l_sole, head_camera, ...).
    for frame in model.frames:
        if frame.type in (pin.FrameType.JOINT, pin.FrameType.FIXED_JOINT):
            continue
        if frame.parentJoint == 0 or (
            frame.type == pin.FrameType.BODY and frame.name in body_names
        ):
            continue
        ET.SubElement(
            bodies[frame.parentJoint],
            "site",
            name=frame.name,
            pos=_fmt(frame.placement.translation),
            quat=_fmt(_quat_wxyz(frame.placement.rotation)),
            size="0.005",
            group="4",
        )
    camera_joint = model.getJointId(config.camera_parent_joint)
    for name in CAMERA_NAMES:
        placement = model.frames[model.getFrameId(name)].placement
        ET.SubElement(
            bodies[camera_joint],
            "camera",
            name=name,
            pos=_fmt(placement.translation),
            quat=_fmt(_quat_wxyz(placement.rotation @ MJ_FROM_CV)),
            fovy=repr(CAMERA_FOVY_DEG),
        )
    ET.indent(root)
    return ET.tostring(root, encoding="unicode")


def _source_digest(config: RobotConfig, urdf_path: str) -> str:
    digest = hashlib.sha256()
    digest.update(Path(urdf_path).read_bytes())
    digest.update(repr((config, _CACHE_FORMAT_VERSION, mujoco.__version__)).encode())
    return digest.hexdigest()[:16]


@functools.cache
def load_robot(name: str = "icub") -> Robot:
    """Load a humanoid into pinocchio and MuJoCo (cached per process and on disk).

    Args:
        name: One of `ROBOT_NAMES` ("icub" default, "talos").

    Raises:
        RobotModelError: Unknown name, or the model lacks a frame the testbed needs.
    """
    if name not in ROBOT_CONFIGS:
        raise RobotModelError(f"unknown robot {name!r}; valid names: {', '.join(ROBOT_NAMES)}")
    config = ROBOT_CONFIGS[name]
    wrapper = _load_pinocchio(config)
    model: pin.Model = wrapper.model
    for frame in (config.left_sole, config.right_sole):
        if not model.existFrame(frame):
            raise RobotModelError(f"{name} has no sole frame {frame!r}")
    _add_camera_frames(model, config)
    geometry_model = (
        wrapper.collision_model if config.use_collision_meshes_for_visuals else wrapper.visual_model
    )
    mjcf_path = cache_root() / name / f"{name}_{_source_digest(config, wrapper.urdf)}.xml"
    if not mjcf_path.exists():
        write_text_atomic(mjcf_path, build_mjcf(config, model, geometry_model))
    mj_model = mujoco.MjModel.from_xml_path(str(mjcf_path))
    joint_names = tuple(model.names[j] for j in range(2, model.njoints))
    mujoco_joint_names = tuple(
        mujoco.mj_id2name(mj_model, mujoco.mjtObj.mjOBJ_JOINT, j) for j in range(mj_model.njnt)
    )
    if mujoco_joint_names[0] != "root" or sorted(mujoco_joint_names[1:]) != sorted(joint_names):
        raise RobotModelError(f"{mjcf_path} joints do not match the pinocchio model of {name}")
    qpos_index = np.array([joint_names.index(j) for j in mujoco_joint_names[1:]], dtype=np.intp)
    return Robot(
        name=name,
        config=config,
        mjcf_path=mjcf_path,
        pin_model=model,
        pin_data=model.createData(),
        joint_names=joint_names,
        mujoco_joint_names=mujoco_joint_names,
        stereo_baseline_m=config.stereo_baseline_m,
        body_boxes=tuple(_geometry_box(g, config) for g in geometry_model.geometryObjects),
        _qpos_index=qpos_index,
        _frame_ids={name: int(model.getFrameId(name)) for name in {f.name for f in model.frames}},
        _neutral=np.asarray(pin.neutral(model), dtype=np.float64),
    )
