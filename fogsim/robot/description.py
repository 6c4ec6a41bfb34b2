"""What the testbed knows about a humanoid beyond its URDF, read from ``assets/robots/<name>.toml``.

One data file per robot (soles, foot size, leg and neck joints, camera mount, mesh quirks, a
relaxed arm pose), decoded by msgspec into the frozen dataclasses below. Every key is required
except the camera mount's alternatives (see `CameraMount`). A malformed file raises
`RobotModelError` naming the file and the dotted key. The robot's name is its file name.
"""

from __future__ import annotations

import math
import re
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated

import msgspec
import numpy as np

from fogsim.config.decode import NOT_IN_FILE, dotted, unknown_key
from fogsim.errors import RobotModelError
from fogsim.paths import ROBOT_NAMES, ROBOTS_DIR

CAMERA_NAMES: tuple[str, str, str] = ("head_camera", "head_camera_left", "head_camera_right")
"""The camera rig every robot gets: the depth camera and the left and right stereo cameras."""

LengthM = Annotated[float, msgspec.Meta(ge=-2.0, le=2.0)]
"""A position or offset on a humanoid [m]: within ±2 m (which also rejects inf and NaN)."""
PositiveLengthM = Annotated[float, msgspec.Meta(gt=0.0, le=2.0)]
"""A size or height on a humanoid [m]: in (0, 2] m."""
AxisComponent = Annotated[float, msgspec.Meta(ge=-1.0, le=1.0)]
"""A component of a direction, in [-1, 1] (the direction need not be normalised)."""
SixJoints = tuple[str, str, str, str, str, str]


@dataclass(frozen=True)
class FeetDescription:
    """The soles and the footprint (table ``[feet]``).

    Attributes:
        left_sole: Pinocchio frame of the left sole (x forward along the foot, z up).
        right_sole: Pinocchio frame of the right sole.
        center_offset_m: Footprint centre along the sole's x axis [m].
        length_m: Footprint extent (back, front) along the sole's x from the sole origin [m].
        half_width_m: Half the footprint width [m].
    """

    left_sole: str
    right_sole: str
    center_offset_m: LengthM
    length_m: tuple[LengthM, LengthM]
    half_width_m: PositiveLengthM


@dataclass(frozen=True)
class LegsDescription:
    """The leg joints and the walking height (table ``[legs]``).

    Attributes:
        left_joints: The six left-leg joints, hip to ankle (the walking IK moves these).
        right_joints: The six right-leg joints.
        pelvis_height_m: Root height above the stance surface when walking [m].
    """

    left_joints: SixJoints
    right_joints: SixJoints
    pelvis_height_m: PositiveLengthM


@dataclass(frozen=True)
class NeckDescription:
    """The joints between the torso and the head (table ``[neck]``).

    Attributes:
        joints: Every joint between the torso and the head (the encoders' NECK group).
        yaw_joint: Joint that turns the head left (+) / right.
        pitch_joint: Joint that tilts the head.
        pitch_sign: +1 if a positive ``pitch_joint`` angle looks up, -1 if it looks down.
        pivot_in_camera_m: Where the neck turns the head, in the depth camera's optical frame
            (x right, y down, z forward) [m]: the origin of the camera's parent joint (the
            neck's joints meet within about a centimetre; ``tests/test_robot.py`` checks it
            against the URDF). A neck encoder's error turns the head about it, which moves
            the camera too: the height reference expects the ground where the tilt
            correction about this point puts it (`mapper.reference.neck_prior_m`,
            ``ref.neck_in_camera_*_m``).
    """

    joints: tuple[str, ...]
    yaw_joint: str
    pitch_joint: str
    pitch_sign: float
    pivot_in_camera_m: tuple[LengthM, LengthM, LengthM]


@dataclass(frozen=True)
class CameraMount:
    """Where the camera rig sits on the head (table ``[camera]``).

    The depth camera (OpenCV optical frame) is either an existing pinocchio ``frame`` or is
    placed by ``position_in_parent_m``, ``forward_in_parent`` and ``up_in_parent`` (all three);
    the file gives one or the other. The stereo cameras sit ``stereo_baseline_m / 2`` to its
    left and right along the optical x axis.

    Attributes:
        parent_joint: Joint whose body carries the cameras.
        stereo_baseline_m: Distance between the left and right cameras [m].
        frame: Pinocchio frame of the depth camera, or None to place it by the three vectors.
        position_in_parent_m: Camera position in the parent joint frame [m].
        forward_in_parent: Forward (optical z) axis in the parent joint frame.
        up_in_parent: Up axis (optical -y) in the parent joint frame.
        ahead_m: Move the cameras this far along their view axis [m], to put them in front of
            the head geometry MuJoCo renders (a convex collision hull can enclose the real lens
            position). Default 0: the cameras sit exactly at the mount.
    """

    parent_joint: str
    stereo_baseline_m: PositiveLengthM
    frame: str | None = None
    position_in_parent_m: tuple[LengthM, LengthM, LengthM] | None = None
    forward_in_parent: tuple[AxisComponent, AxisComponent, AxisComponent] | None = None
    up_in_parent: tuple[AxisComponent, AxisComponent, AxisComponent] | None = None
    ahead_m: LengthM = 0.0


@dataclass(frozen=True)
class MeshQuirks:
    """How the example-robot-data meshes must be treated (table ``[quirks]``).

    Attributes:
        fix_y_up_meshes: Rotate mesh vertices +90° about x (Y_UP → Z_UP): coal loads COLLADA
            meshes stored ``Y_UP`` without the up-axis rotation (Gepetto/example-robot-data#105).
        collision_meshes_for_visuals: Use the (lighter) collision model for MuJoCo's geoms.
    """

    fix_y_up_meshes: bool
    collision_meshes_for_visuals: bool


@dataclass(frozen=True)
class RobotDescription:
    """What the testbed needs to know about one humanoid beyond its URDF.

    Attributes:
        name: Our name for the robot (the data file's name).
        example_robot_data: Name for ``example_robot_data.load``.
        feet: Soles and footprint.
        legs: Leg joints and walking height.
        neck: Neck joints.
        camera: Camera mount.
        quirks: Mesh quirks.
        arm_pose_rad: Joint name → angle [rad] of a relaxed arm pose (table ``[arm_pose_rad]``).
    """

    name: str = field(metadata=NOT_IN_FILE)  # the data file's name, not a key in it
    example_robot_data: str
    feet: FeetDescription
    legs: LegsDescription
    neck: NeckDescription
    camera: CameraMount
    quirks: MeshQuirks
    arm_pose_rad: Mapping[str, float]


def load_description(name: str) -> RobotDescription:
    """The description of a shipped robot (``assets/robots/<name>.toml``).

    Raises:
        RobotModelError: Unknown name (the message lists `ROBOT_NAMES`) or a malformed file.
    """
    if name not in ROBOT_NAMES:
        raise RobotModelError(f"unknown robot {name!r}; valid names: {', '.join(ROBOT_NAMES)}")
    return read_description(ROBOTS_DIR / f"{name}.toml")


def read_description(path: Path) -> RobotDescription:
    """Read and check one robot description file; the robot is named after the file.

    Raises:
        RobotModelError: The file is missing, not TOML, has a missing, unknown or mistyped key,
            or a value out of range; the message names the file and the dotted key.
    """
    try:
        with path.open("rb") as file:
            table = tomllib.load(file)
    except OSError as error:
        raise RobotModelError(f"{path}: cannot read the robot description ({error})") from error
    except tomllib.TOMLDecodeError as error:
        raise RobotModelError(f"{path}: not valid TOML ({error})") from error
    unknown = unknown_key(table, RobotDescription)
    if unknown is not None:
        key, allowed = dotted(unknown[0]), unknown[1]
        raise RobotModelError(f"{path}: unknown key {key}; allowed there: {', '.join(allowed)}")
    try:
        description = msgspec.convert({**table, "name": path.stem}, RobotDescription)
    except msgspec.ValidationError as error:
        raise RobotModelError(f"{path}: {_dotted(str(error))}") from error
    _check_values(description, path)
    return description


def _dotted(message: str) -> str:
    """A msgspec message "what - at `$.a.b`" as "a.b: what" (a missing key: "a.b.key: missing")."""
    match = re.fullmatch(r"(.*?)(?: - at `\$\.?(.*)`)?", message)
    assert match is not None  # the pattern matches any text
    what, where = match[1], match[2] or ""
    missing = re.fullmatch(r"Object missing required field `(.*)`", what)
    if missing:
        return f"{where}.{missing[1]}: missing".lstrip(".")
    return f"{where}: {what}" if where else what


def _check_values(description: RobotDescription, path: Path) -> None:
    """The checks a type cannot say: relations between keys and allowed values."""
    feet, neck, camera = description.feet, description.neck, description.camera
    for joint, angle in description.arm_pose_rad.items():
        if not -math.pi <= angle <= math.pi:
            raise RobotModelError(f"{path}: arm_pose_rad.{joint} = {angle}: must be in [-π, π]")
    back, front = feet.length_m
    if not back < front:
        raise RobotModelError(
            f"{path}: feet.length_m = {list(feet.length_m)}: the back end must be behind the front"
        )
    if neck.pitch_sign not in (1.0, -1.0):
        raise RobotModelError(f"{path}: neck.pitch_sign = {neck.pitch_sign}: must be 1.0 or -1.0")
    for key, joint in (("yaw_joint", neck.yaw_joint), ("pitch_joint", neck.pitch_joint)):
        if joint not in neck.joints:
            raise RobotModelError(
                f"{path}: neck.{key} = {joint!r}: must be one of neck.joints {list(neck.joints)}"
            )
    vectors = {
        "position_in_parent_m": camera.position_in_parent_m,
        "forward_in_parent": camera.forward_in_parent,
        "up_in_parent": camera.up_in_parent,
    }
    given = [key for key, value in vectors.items() if value is not None]
    if camera.frame is not None and given:
        raise RobotModelError(
            f"{path}: camera.frame and camera.{', camera.'.join(given)} both place the camera; "
            "give either frame or the three vectors"
        )
    if camera.frame is None and len(given) != len(vectors):
        missing = [f"camera.{key}" for key in vectors if key not in given]
        raise RobotModelError(f"{path}: camera.frame or {', '.join(missing)} is missing")
    if camera.forward_in_parent is not None and camera.up_in_parent is not None:
        forward = np.asarray(camera.forward_in_parent)
        up = np.asarray(camera.up_in_parent)
        cross = float(np.linalg.norm(np.cross(forward, up)))
        if not cross > 1e-6 * float(np.linalg.norm(forward) * np.linalg.norm(up)):
            raise RobotModelError(
                f"{path}: camera.forward_in_parent = {list(camera.forward_in_parent)} and "
                f"camera.up_in_parent = {list(camera.up_in_parent)}: must be non-zero and not "
                "parallel"
            )
