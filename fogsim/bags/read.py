"""A ROS 1 or ROS 2 bag → the frames of a recording (``fogsim import-bag``).

Read with ``rosbags``' :class:`~rosbags.highlevel.AnyReader` (ROS 1 ``.bag`` files, ROS 2 bag
folders in sqlite3 or MCAP storage; no ROS install). Per depth image (its ``header.stamp`` is
the frame's time, its ``header.frame_id`` the camera's optical frame):

* the depth [m] (:func:`fogsim.bags.images.depth_m_from_image`);
* the intrinsics from the CameraInfo topic (every message must agree);
* from ``/tf`` + ``/tf_static`` at the image's stamp (:class:`fogsim.bags.tf.TfTree`): the
  base frame in the odometry frame, ``T_odom_base``, and the camera in the base frame,
  ``T_base_camera``, each a chain of lookups interpolated in time within the tolerance.

The recording's robot frame R is the base frame levelled: ``robot_pose_believed`` = (x, y, z,
yaw) of ``T_odom_base``, and ``transform_camera_to_robot_believed`` =
``planar(pose)⁻¹ · T_odom_base · T_base_camera``, so the camera's pose in the world is exactly
the bag's even when the base rolls or pitches. A real bag has no ground truth: the true poses
are NaN and there is no scenario, so ``fogsim run --replay`` maps it with default parameters
and says "no ground truth". With a URDF (``BagOptions.urdf_path``) ``T_base_camera`` comes from
the joint states through it instead (:mod:`fogsim.bags.urdf`); ``T_odom_base`` is always tf's.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from rosbags.highlevel import AnyReader, AnyReaderError
from rosbags.rosbag1 import ReaderError as Ros1ReaderError
from rosbags.rosbag2 import ReaderError as Ros2ReaderError
from rosbags.typesys import Stores, get_typestore

from fogsim.atomic import reason
from fogsim.bags.images import depth_m_from_image, intrinsics_from_camera_info
from fogsim.bags.tf import TfTree, TransformSample, frame_name, rigid_inverse
from fogsim.bags.topics import BagError, BagOptions
from fogsim.bags.urdf import JointSample, UrdfChain
from fogsim.data.frame import Frame
from fogsim.data.recording import save_recording
from fogsim.data.spool import spooled_array
from fogsim.errors import OutputError
from mapper.intrinsics import PinholeIntrinsics
from mapper.transforms import planar_pose_to_matrix

IMAGE_TYPE = "sensor_msgs/msg/Image"
CAMERA_INFO_TYPE = "sensor_msgs/msg/CameraInfo"
JOINT_STATE_TYPE = "sensor_msgs/msg/JointState"
TF_TOPIC = "/tf"
TF_STATIC_TOPIC = "/tf_static"
DEFAULT_TYPE_STORE = Stores.ROS2_HUMBLE
"""Message definitions for ROS 2 bags that carry none (rosbag2 before Iron stored only type
names): Humble's. Image, CameraInfo and TFMessage are the same in every ROS 2 release; bags
that carry definitions (ROS 1, newer ROS 2) are read with their own."""
_MESSAGE_ERRORS = (AnyReaderError, Ros1ReaderError, Ros2ReaderError)
"""What rosbags raises for a message it cannot read or deserialise."""
_OPEN_ERRORS = (*_MESSAGE_ERRORS, OSError, KeyError, ValueError)
"""What rosbags raises for a bag it cannot open (its own errors, a file or a field missing)."""


@dataclass(frozen=True)
class TopicSummary:
    """One topic of a bag (``fogsim import-bag --list``).

    Attributes:
        name: Topic name.
        msgtype: Message type (``sensor_msgs/msg/Image``; ROS 1 types are named the same way).
        count: Messages on the topic.
    """

    name: str
    msgtype: str
    count: int


@dataclass(frozen=True)
class ImportedBag:
    """What :func:`import_bag` wrote.

    Attributes:
        path: The recording file.
        frames: Frames in it.
        first_s: Stamp of the first frame [s].
        last_s: Stamp of the last frame [s].
        intrinsics: The depth camera's intrinsics.
    """

    path: Path
    frames: int
    first_s: float
    last_s: float
    intrinsics: PinholeIntrinsics


@contextmanager
def _open_bag(path: str | os.PathLike[str]) -> Iterator[AnyReader]:
    """An open :class:`AnyReader` of the bag; any failure to read it is a :class:`BagError`."""
    source = Path(path)
    if not source.exists():
        raise BagError(f"bag not found: {source} (a ROS 1 .bag file or a ROS 2 bag folder)")
    try:
        reader = AnyReader([source], default_typestore=get_typestore(DEFAULT_TYPE_STORE))
        reader.open()
    except _OPEN_ERRORS as exc:
        raise BagError(f"{source} is not a readable ROS 1 or ROS 2 bag: {exc}") from exc
    try:
        yield reader
    except _MESSAGE_ERRORS as exc:
        raise BagError(f"{source}: a message cannot be read: {exc}") from exc
    finally:
        reader.close()


def bag_topics(path: str | os.PathLike[str]) -> list[TopicSummary]:
    """The topics of a bag with their types and message counts, by name.

    Raises:
        BagError: The bag is missing or unreadable.
    """
    with _open_bag(path) as reader:
        return [
            TopicSummary(name, info.msgtype or "(several types)", info.msgcount)
            for name, info in sorted(reader.topics.items())
        ]


def _connections(reader: AnyReader, topic: str, msgtype: str | None, source: Path) -> list[Any]:
    """The connections of ``topic`` (of ``msgtype`` if given); none if the topic is absent."""
    found = [c for c in reader.connections if c.topic == topic]
    wrong = sorted({c.msgtype for c in found if msgtype is not None and c.msgtype != msgtype})
    if wrong:
        raise BagError(f"{source}: topic {topic} holds {wrong}, expected {msgtype}")
    return found


def _required(reader: AnyReader, topic: str, msgtype: str, source: Path, option: str) -> list:
    """The connections of a topic the import needs; a missing or empty one is a BagError."""
    found = _connections(reader, topic, msgtype, source)
    if not found or sum(c.msgcount for c in found) == 0:
        candidates = sorted({c.topic for c in reader.connections if c.msgtype == msgtype})
        raise BagError(
            f"{source}: no {msgtype} messages on {topic}; the bag's {msgtype} topics: "
            f"{candidates or 'none'} (choose one with {option}; `fogsim import-bag BAG --list`)"
        )
    return found


def _stamp_ns(message: Any) -> int:
    """``header.stamp`` [ns]."""
    stamp = message.header.stamp
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def _tf_samples(reader: AnyReader, connections: list) -> list[TransformSample]:
    """Every transform of the tf messages on ``connections``, in bag order."""
    samples = []
    for connection, _, raw in reader.messages(connections=connections):
        for t in reader.deserialize(raw, connection.msgtype).transforms:
            v, q = t.transform.translation, t.transform.rotation
            samples.append(
                TransformSample(
                    _stamp_ns(t),
                    frame_name(t.header.frame_id),
                    frame_name(t.child_frame_id),
                    (float(v.x), float(v.y), float(v.z)),
                    (float(q.x), float(q.y), float(q.z), float(q.w)),
                )
            )
    return samples


def _joint_samples(reader: AnyReader, connections: list) -> list[JointSample]:
    """Every joint position of the JointState messages on ``connections``, in bag order."""
    samples = []
    for connection, _, raw in reader.messages(connections=connections):
        message = reader.deserialize(raw, connection.msgtype)
        stamp = _stamp_ns(message)
        samples.extend(
            JointSample(stamp, str(name), float(position))
            for name, position in zip(message.name, message.position, strict=False)
        )
    return samples


def _intrinsics(
    reader: AnyReader, connections: list, source: Path, topic: str
) -> PinholeIntrinsics:
    """The intrinsics of the CameraInfo messages; all of them must agree."""
    intrinsics = None
    for connection, _, raw in reader.messages(connections=connections):
        message = reader.deserialize(raw, connection.msgtype)
        where = f"{source}: {topic} at stamp {_stamp_ns(message)} ns"
        current = intrinsics_from_camera_info(message, where)
        if intrinsics is not None and current != intrinsics:
            raise BagError(
                f"{where}: intrinsics {current} differ from the first message's {intrinsics}; a "
                "recording has one camera (cut the bag where the camera changes)"
            )
        intrinsics = current
    assert intrinsics is not None  # _required saw messages
    return intrinsics


@dataclass(frozen=True)
class _DepthImages:
    """The depth topic's images by increasing stamp.

    Attributes:
        stamps_ns: (T,) stamps [ns], increasing.
        depth_m: (T, H, W) images [m] on disk (:func:`~fogsim.data.spool.spooled_array`).
        frame_id: The images' camera frame.
    """

    stamps_ns: NDArray[np.int64]
    depth_m: NDArray[np.float32]
    frame_id: str


def _depth_stamps(
    reader: AnyReader, connections: list, source: Path, topic: str
) -> tuple[NDArray[np.int64], str]:
    """The stamps of the topic's images in bag order and their one camera frame (first pass)."""
    stamps, frame_ids = [], set()
    for connection, _, raw in reader.messages(connections=connections):
        message = reader.deserialize(raw, connection.msgtype)
        stamps.append(_stamp_ns(message))
        frame_ids.add(frame_name(message.header.frame_id))
    if len(frame_ids) != 1:
        raise BagError(f"{source}: {topic} names several camera frames {sorted(frame_ids)}")
    return np.array(stamps, dtype=np.int64), frame_ids.pop()


def _depth_images(
    reader: AnyReader,
    connections: list,
    source: Path,
    topic: str,
    intrinsics: PinholeIntrinsics,
    spool_folder: Path | None,
) -> _DepthImages:
    """Every depth image of the topic, decoded, sorted by stamp (stamps must be distinct).

    Two passes over the topic: the stamps first, to know each image's place in time order,
    then the images, each decoded straight into its row of an array on disk — memory holds one
    image whatever the bag's length, and a bag whose images are out of stamp order is sorted
    without holding it.
    """
    stamps, frame_id = _depth_stamps(reader, connections, source, topic)
    order = np.argsort(stamps, kind="stable")
    sorted_stamps = stamps[order]
    repeated = np.flatnonzero(np.diff(sorted_stamps) == 0)
    if repeated.size:
        raise BagError(
            f"{source}: two images on {topic} have the stamp {int(sorted_stamps[repeated[0]])} "
            "ns; frames need distinct times"
        )
    rank = np.empty_like(order)
    rank[order] = np.arange(order.size)
    images = spooled_array((order.size, *intrinsics.shape), np.float32, spool_folder)
    messages = reader.messages(connections=connections)
    for k, (connection, _, raw) in enumerate(messages):
        message = reader.deserialize(raw, connection.msgtype)
        where = f"{source}: {topic} at stamp {_stamp_ns(message)} ns"
        depth = depth_m_from_image(message, where)
        if depth.shape != intrinsics.shape:
            raise BagError(
                f"{where}: a {depth.shape[1]}×{depth.shape[0]} image, but the CameraInfo says "
                f"{intrinsics.width}×{intrinsics.height}"
            )
        images[rank[k]] = depth
    return _DepthImages(sorted_stamps, images, frame_id)


def read_bag_frames(
    path: str | os.PathLike[str],
    options: BagOptions | None = None,
    *,
    spool_folder: str | os.PathLike[str] | None = None,
) -> list[Frame]:
    """The frames of a bag, one per depth image, in time order (see the module doc).

    The frames' depth images are rows of one array on an anonymous temporary file in
    ``spool_folder`` (None = the system's temp folder), freed with the last frame: reading a
    bag holds one image in memory whatever its length.

    Raises:
        BagError: The bag is missing or unreadable; the depth or CameraInfo topic is missing,
            empty or of another type; a bad encoding; tf lacks a frame or has no sample within
            the tolerance of an image's stamp (the message names the bag, topic or frame, and
            the stamp).
    """
    options = options or BagOptions()
    source = Path(path)
    chain = None
    if options.urdf_path is not None:
        try:
            text = Path(options.urdf_path).read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as exc:
            raise BagError(f"cannot read the URDF {options.urdf_path}: {exc}") from exc
        chain = UrdfChain(text, str(options.urdf_path))
    with _open_bag(source) as reader:
        depth_connections = _required(
            reader, options.depth_topic, IMAGE_TYPE, source, "--depth-topic"
        )
        info_connections = _required(
            reader, options.info_topic, CAMERA_INFO_TYPE, source, "--camera-info-topic"
        )
        intrinsics = _intrinsics(reader, info_connections, source, options.info_topic)
        images = _depth_images(
            reader,
            depth_connections,
            source,
            options.depth_topic,
            intrinsics,
            None if spool_folder is None else Path(spool_folder),
        )
        moving = _tf_samples(reader, _connections(reader, TF_TOPIC, None, source))
        static = _tf_samples(reader, _connections(reader, TF_STATIC_TOPIC, None, source))
        joints = []
        if chain is not None:
            topic = options.joint_states_topic
            joints = _joint_samples(
                reader, _required(reader, topic, JOINT_STATE_TYPE, source, "--joint-states-topic")
            )
    try:
        tree = TfTree(moving, static)
        odom_to_base = tree.lookup(
            options.odom_frame, options.base_frame, images.stamps_ns, options.max_dt_ns
        )
        if chain is None:
            base_to_camera = tree.lookup(
                options.base_frame, images.frame_id, images.stamps_ns, options.max_dt_ns
            )
        else:
            base_to_camera = chain.transforms(
                options.base_frame, images.frame_id, joints, images.stamps_ns, options.max_dt_ns
            )
    except BagError as exc:
        raise BagError(f"{source}: {exc}") from exc
    return _frames(images, intrinsics, odom_to_base, base_to_camera)


def _frames(
    images: _DepthImages,
    intrinsics: PinholeIntrinsics,
    odom_to_base: NDArray[np.float64],
    base_to_camera: NDArray[np.float64],
) -> list[Frame]:
    """One frame per image: R = the base levelled, the camera's pose in the world kept exact."""
    poses = np.column_stack(
        [odom_to_base[:, :3, 3], np.arctan2(odom_to_base[:, 1, 0], odom_to_base[:, 0, 0])]
    )
    unknown_pose, unknown_transform = np.full(4, np.nan), np.full((4, 4), np.nan)
    frames = []
    for i, stamp in enumerate(images.stamps_ns.tolist()):
        world_to_robot = rigid_inverse(planar_pose_to_matrix(poses[i])[None])[0]
        camera_to_world = odom_to_base[i] @ base_to_camera[i]
        frames.append(
            Frame(
                index=i,
                time_s=stamp / 1e9,
                depth_m=images.depth_m[i],
                intrinsics=intrinsics,
                transform_camera_to_robot_believed=world_to_robot @ camera_to_world,
                robot_pose_believed=poses[i],
                transform_camera_to_world_true=unknown_transform,
                robot_pose_true=unknown_pose,
            )
        )
    return frames


def import_bag(
    path: str | os.PathLike[str], out: str | os.PathLike[str], options: BagOptions | None = None
) -> ImportedBag:
    """Read a bag's frames and write them as a recording (no scenario, no ground truth).

    Raises:
        BagError: See :func:`read_bag_frames`.
        RecordingError: A frame the recording format refuses (e.g. a pose beyond its limits).
        OutputError: ``out`` cannot be written (nothing is left).
    """
    folder = Path(out).parent
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(f"cannot write {out}: {reason(exc)}") from exc
    frames = read_bag_frames(path, options, spool_folder=folder)
    written = save_recording(out, frames)
    return ImportedBag(
        written, len(frames), frames[0].time_s, frames[-1].time_s, frames[0].intrinsics
    )
