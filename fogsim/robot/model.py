"""Load a humanoid: an `example-robot-data` model into pinocchio and, through the MJCF, MuJoCo.

Pinocchio holds the robot's own kinematics (what it believes, `fogsim.robot.kinematics.Robot`);
MuJoCo renders the true world from the MJCF generated from the same pinocchio model
(`fogsim.robot.mjcf`), so both agree on every frame (a test checks them to 1e-9). What the URDF
does not say (soles, legs, neck, camera mount, quirks) comes from the robot's description file
(`fogsim.robot.description`).
"""

import functools
import warnings
from pathlib import Path
from typing import Any

import example_robot_data
import mujoco
import numpy as np
import pinocchio as pin
from numpy.typing import NDArray

from fogsim.errors import RobotModelError
from fogsim.robot.body_boxes import body_boxes
from fogsim.robot.description import CAMERA_NAMES, CameraMount, RobotDescription, load_description
from fogsim.robot.disk_cache import content_key, library_versions, load_or_build, source_digest
from fogsim.robot.kinematics import Robot
from fogsim.robot.mj_xml import model_from_xml_path
from fogsim.robot.mjcf import cache_root, cached_mjcf, mjcf_files

MAX_CACHED_ROBOTS = 8
"""Most loaded robot models kept on disk, the least recently used removed first: both robots
with room for edited descriptions and code (a loaded iCub is ~110 kB)."""
_LIBRARIES = ("example-robot-data", "pin", "coal", "mujoco", "numpy")
"""The packages a loaded robot comes from: the URDF, SRDF and meshes ship with
example-robot-data, pinocchio and coal parse them, MuJoCo compiles the MJCF."""


@functools.cache
def load_robot(name: str = "icub") -> Robot:
    """Load a humanoid into pinocchio and MuJoCo (cached per process and on disk).

    On disk: what :func:`_load` builds (the URDF parsed, the meshes loaded, the MJCF
    generated: about 0.3 s) is kept in ``robot_models`` beside :func:`~fogsim.robot.mjcf.cache_root`
    under a key of the description, the versions of :data:`_LIBRARIES` and the source of
    ``fogsim.robot`` (:mod:`fogsim.robot.disk_cache`); a later process loads it in milliseconds,
    the same model to the bit (pinocchio's own serialisation).

    Args:
        name: One of `fogsim.robot.description.ROBOT_NAMES` ("icub" default, "talos").

    Raises:
        RobotModelError: Unknown name, a malformed description, or the model lacks a frame or
            joint the description names.
    """
    description = load_description(name)
    key = content_key(
        (
            repr(description).encode(),
            library_versions(*_LIBRARIES),
            source_digest(Path(__file__).parent),
        )
    )
    fields = load_or_build(
        cache_root().parent / "robot_models" / f"{name}_{key}.pickle",
        lambda: _load(description),
        MAX_CACHED_ROBOTS,
        # The MJCF or its meshes may be deleted.
        usable=lambda loaded: all(path.exists() for path in mjcf_files(Path(loaded["mjcf_path"]))),
    )
    return Robot(description=description, pin_data=fields["pin_model"].createData(), **fields)


def _load(description: RobotDescription) -> dict[str, Any]:
    """The fields of the :class:`Robot` of ``description`` but its description and data."""
    name = description.name
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        wrapper = example_robot_data.load(description.example_robot_data)
    model: pin.Model = wrapper.model
    _check_names(model, description)
    _add_camera_frames(model, description.name, description.camera)
    geometry_model = (
        wrapper.collision_model
        if description.quirks.collision_meshes_for_visuals
        else wrapper.visual_model
    )
    mjcf_path = cached_mjcf(description, model, geometry_model, wrapper.urdf)
    mj_model = model_from_xml_path(mjcf_path)
    joint_names = tuple(model.names[j] for j in range(2, model.njoints))
    mujoco_joint_names = tuple(
        mujoco.mj_id2name(mj_model, mujoco.mjtObj.mjOBJ_JOINT, j) for j in range(mj_model.njnt)
    )
    if mujoco_joint_names[0] != "root" or sorted(mujoco_joint_names[1:]) != sorted(joint_names):
        raise RobotModelError(f"{mjcf_path} joints do not match the pinocchio model of {name}")
    qpos_index = np.array([joint_names.index(j) for j in mujoco_joint_names[1:]], dtype=np.intp)
    return dict(
        mjcf_path=mjcf_path,
        pin_model=model,
        joint_names=joint_names,
        mujoco_joint_names=mujoco_joint_names,
        body_boxes=body_boxes(geometry_model, description.quirks.fix_y_up_meshes),
        _qpos_index=qpos_index,
        _frame_ids={name: int(model.getFrameId(name)) for name in {f.name for f in model.frames}},
        _neutral=np.asarray(pin.neutral(model), dtype=np.float64),
    )


def _check_names(model: pin.Model, description: RobotDescription) -> None:
    """Every frame and joint the description names exists in the pinocchio model."""
    name = description.name
    for frame in (description.feet.left_sole, description.feet.right_sole):
        if not model.existFrame(frame):
            raise RobotModelError(f"{name} has no sole frame {frame!r}")
    joints = {
        "legs.left_joints": description.legs.left_joints,
        "legs.right_joints": description.legs.right_joints,
        "neck.joints": description.neck.joints,
        "camera.parent_joint": (description.camera.parent_joint,),
        "arm_pose_rad": tuple(description.arm_pose_rad),
    }
    for key, names in joints.items():
        missing = [joint for joint in names if not model.existJointName(joint)]
        if missing:
            raise RobotModelError(f"{name}: {key} names joints the model lacks: {missing}")


def _camera_rotation(forward: NDArray[np.float64], up: NDArray[np.float64]) -> NDArray[np.float64]:
    """Rotation whose columns are the OpenCV camera axes (x right, y down, z forward)."""
    z = forward / np.linalg.norm(forward)
    down = -up
    y = down - z * float(down @ z)
    y /= np.linalg.norm(y)
    return np.column_stack([np.cross(y, z), y, z])


def _add_camera_frames(model: pin.Model, name: str, mount: CameraMount) -> None:
    """Add the frames of `CAMERA_NAMES` (OpenCV convention) to the camera's parent joint."""
    parent_joint = model.getJointId(mount.parent_joint)
    if mount.frame is not None:
        if not model.existFrame(mount.frame):
            raise RobotModelError(f"{name} has no camera frame {mount.frame!r}")
        frame = model.frames[model.getFrameId(mount.frame)]
        if frame.parentJoint != parent_joint:
            raise RobotModelError(
                f"{mount.frame} hangs on joint {model.names[frame.parentJoint]}, "
                f"expected {mount.parent_joint}"
            )
        centre = frame.placement
    else:
        # read_description checked that a mount without a frame gives all three vectors
        assert mount.forward_in_parent is not None and mount.up_in_parent is not None
        assert mount.position_in_parent_m is not None
        rotation = _camera_rotation(
            np.asarray(mount.forward_in_parent, dtype=np.float64),
            np.asarray(mount.up_in_parent, dtype=np.float64),
        )
        centre = pin.SE3(rotation, np.asarray(mount.position_in_parent_m, dtype=float))
    centre = centre * pin.SE3(np.eye(3), np.array([0.0, 0.0, mount.ahead_m]))
    half = 0.5 * mount.stereo_baseline_m
    middle, left, right = CAMERA_NAMES
    placements = {middle: centre, left: centre * _shift_x(-half), right: centre * _shift_x(half)}
    parent_frame = model.getFrameId(mount.parent_joint, pin.FrameType.JOINT)
    for camera, placement in placements.items():
        model.addFrame(
            pin.Frame(camera, parent_joint, parent_frame, placement, pin.FrameType.OP_FRAME)
        )


def _shift_x(offset_m: float) -> pin.SE3:
    """A translation by ``offset_m`` along x."""
    return pin.SE3(np.eye(3), np.array([offset_m, 0.0, 0.0]))
