"""What ``fogsim import-bag`` reads from a bag: topics, tf frames, the time tolerance.

Defaults follow the ROS conventions: a depth camera driver publishes its rectified depth image
and, in the same namespace, ``camera_info`` (image_transport's rule); REP 105 names the
odometry frame ``odom`` and the robot's ground projection ``base_footprint``, which is the
paper's robot frame R (on the ground below the robot, x forward, z up).
"""

from __future__ import annotations

import posixpath
from dataclasses import dataclass
from pathlib import Path

from fogsim.errors import RecordingError

DEFAULT_DEPTH_TOPIC = "/camera/depth/image_rect_raw"
"""The rectified depth image of the RealSense ROS driver (ROS 1 and ROS 2 up to 4.51), the most
common depth camera on legged and humanoid robots; any other is named with ``--depth-topic``."""

DEFAULT_ODOM_FRAME = "odom"
"""REP 105's odometry frame: the world the believed poses (and so the maps) live in."""

DEFAULT_BASE_FRAME = "base_footprint"
"""REP 105's projection of the robot's base onto the ground: the paper's robot frame R, which
the mapper assumes on the ground (its z is the robot's elevation). A robot without one names a
frame on the ground between its feet with ``--base-frame``."""

DEFAULT_MAX_DT_MS = 50.0
"""Largest distance [ms] from a depth image's stamp to the nearest sample of every moving
transform it needs. Transforms are interpolated between the samples around the stamp, so 50 ms
accepts tf publishers down to 10 Hz; a humanoid walking 0.5 m/s moves 25 mm in 50 ms, which the
interpolation (not the nearest sample) covers. A larger gap means the pose is unknown there."""

DEFAULT_JOINT_STATES_TOPIC = "/joint_states"
"""Where ``robot_state_publisher`` and ROS drivers publish ``sensor_msgs/JointState``."""

MAX_DT_LIMIT_MS = 1000.0
"""Largest ``max_dt_ms`` accepted: beyond a second an interpolated pose is a guess."""


class BagError(RecordingError):
    """A bag cannot be imported: unreadable, a topic or frame missing, a bad encoding, a gap.

    The message names the bag, the topic or frame, the message's stamp and what is allowed.
    A :class:`RecordingError` (the command line exits with code 2).
    """


@dataclass(frozen=True)
class BagOptions:
    """Where in a bag the mapper's inputs are.

    Attributes:
        depth_topic: ``sensor_msgs/Image`` topic of depth images, ``32FC1`` [m] or ``16UC1``
            [mm]; default :data:`DEFAULT_DEPTH_TOPIC`.
        camera_info_topic: ``sensor_msgs/CameraInfo`` topic; None (default) = ``camera_info``
            beside the depth topic (image_transport's rule: ``/a/b/image`` → ``/a/b/camera_info``).
        odom_frame: The world frame of the believed poses; default :data:`DEFAULT_ODOM_FRAME`.
        base_frame: The robot frame R (on the ground); default :data:`DEFAULT_BASE_FRAME`.
        max_dt_ms: Time tolerance [ms], in (0, :data:`MAX_DT_LIMIT_MS`]; default
            :data:`DEFAULT_MAX_DT_MS`.
        urdf_path: The robot's URDF: the camera in the base frame comes from the joint states
            through it (:mod:`fogsim.bags.urdf`) instead of from tf; None (default) = tf.
        joint_states_topic: ``sensor_msgs/JointState`` topic read with ``urdf_path``; default
            :data:`DEFAULT_JOINT_STATES_TOPIC`.

    Raises:
        BagError: A topic that is not an absolute ROS name, an empty frame, a tolerance out of
            range (naming the field and the value).
    """

    depth_topic: str = DEFAULT_DEPTH_TOPIC
    camera_info_topic: str | None = None
    odom_frame: str = DEFAULT_ODOM_FRAME
    base_frame: str = DEFAULT_BASE_FRAME
    max_dt_ms: float = DEFAULT_MAX_DT_MS
    urdf_path: Path | None = None
    joint_states_topic: str = DEFAULT_JOINT_STATES_TOPIC

    def __post_init__(self) -> None:
        for name in ("depth_topic", "camera_info_topic", "joint_states_topic"):
            topic = getattr(self, name)
            if topic is not None and not (topic.startswith("/") and len(topic) > 1):
                raise BagError(
                    f"BagOptions.{name} = {topic!r} must be an absolute topic name such as "
                    "'/camera/depth/image_rect_raw'"
                )
        for name in ("odom_frame", "base_frame"):
            if not getattr(self, name).strip("/"):
                raise BagError(
                    f"BagOptions.{name} must name a tf frame, got {getattr(self, name)!r}"
                )
        if not 0.0 < self.max_dt_ms <= MAX_DT_LIMIT_MS:
            raise BagError(
                f"BagOptions.max_dt_ms = {self.max_dt_ms!r} must be in (0, {MAX_DT_LIMIT_MS:g}] ms"
            )

    @property
    def info_topic(self) -> str:
        """The CameraInfo topic: as given, or ``camera_info`` beside the depth topic."""
        if self.camera_info_topic is not None:
            return self.camera_info_topic
        return posixpath.join(posixpath.dirname(self.depth_topic), "camera_info")

    @property
    def max_dt_ns(self) -> int:
        """The time tolerance [ns]."""
        return round(self.max_dt_ms * 1e6)
