"""A complete real-data run: a ROS 2 bag → a recording → a map → pictures.

The bag is made here, so the example runs anywhere: a robot walks 0.6 m toward a 0.15 m high
flat box on a flat floor while its head camera (0.9 m up, pitched 35° down, 88×72 px) sends depth
images. The images are ray-cast exactly from that known scene and written with rosbags' own
writer, as a real robot's driver would publish them (``sensor_msgs/Image`` ``32FC1`` in metres,
``sensor_msgs/CameraInfo``, ``/tf`` odom → base_footprint at 50 Hz and ``/tf_static``
base_footprint → the camera's optical frame). Then the two commands a user runs on their own bag::

    fogsim import-bag BAG --out REC.npz --depth-topic TOPIC
    fogsim run --replay REC.npz --out DIR

Run it with ``python examples/real_data.py --out runs/real_data`` and open
``runs/real_data/fog_map.png``: the floor at 0 m, the box's top as a floor at 0.15 m, its sides
as obstacle cells. ``examples/README.md`` says how to run the same on one's own bag.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np
from numpy.typing import NDArray
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore

from fogsim.cli import main as fogsim_main
from mapper import PinholeIntrinsics
from mapper.transforms import planar_pose_to_matrix

T0_NS = 1_700_000_000_000_000_000
"""A wall-clock epoch stamp, as real bags carry."""
FRAME_NS = 80_000_000
"""12.5 Hz depth images (the paper's camera rate)."""
TF_NS = 20_000_000
"""50 Hz odometry on ``/tf``."""
FRAMES = 30
SPEED_M_S = 0.25
"""Walking speed along the odometry frame's x: 0.6 m over the 30 frames."""
CAMERA_HEIGHT_M = 0.9
CAMERA_PITCH_DEG = 35.0
"""Camera pitched down: the floor from 0.6 m to 4 m ahead is in view."""
BOX_MIN_XYZ_M = (1.6, -0.3, 0.0)
BOX_MAX_XYZ_M = (2.0, 0.3, 0.15)
"""The box in the odometry frame: 0.4 × 0.6 m, its flat top 0.15 m up."""
DEPTH_TOPIC = "/camera/depth/image_rect_raw"
OPTICAL_FRAME = "camera_depth_optical_frame"
INTRINSICS = PinholeIntrinsics.from_fov(88, 72, 47.0, 39.0)


def camera_to_base() -> NDArray[np.float64]:
    """The optical frame (x right, y down, z forward) in base_footprint (x forward, z up)."""
    pitch = math.radians(CAMERA_PITCH_DEG)
    forward = np.array([math.cos(pitch), 0.0, -math.sin(pitch)])
    right = np.array([0.0, -1.0, 0.0])
    transform = np.eye(4)
    transform[:3, :3] = np.column_stack([right, np.cross(forward, right), forward])
    transform[:3, 3] = (0.0, 0.0, CAMERA_HEIGHT_M)
    return transform


def base_pose(stamp_ns: int) -> NDArray[np.float64]:
    """base_footprint in odom at a stamp: x, y, z [m], yaw [rad]."""
    return np.array([SPEED_M_S * (stamp_ns - T0_NS) / 1e9, 0.0, 0.0, 0.0])


def render_depth(camera_to_world: NDArray[np.float64]) -> NDArray[np.float32]:
    """Exact depth [m] along the optical axis of the floor z = 0 and the box (NaN = no hit)."""
    rays = INTRINSICS.ray_directions_camera() @ camera_to_world[:3, :3].T  # unit optical z
    origin = camera_to_world[:3, 3]
    with np.errstate(divide="ignore", invalid="ignore"):
        floor = np.where(rays[..., 2] < 0.0, -origin[2] / rays[..., 2], np.inf)
        low = (np.array(BOX_MIN_XYZ_M) - origin) / rays  # slab method, per axis
        high = (np.array(BOX_MAX_XYZ_M) - origin) / rays
    enter = np.minimum(low, high).max(axis=-1)
    leave = np.maximum(low, high).min(axis=-1)
    box = np.where((enter <= leave) & (enter > 0.0), enter, np.inf)
    depth = np.minimum(floor, box)
    return np.where(np.isfinite(depth), depth, np.nan).astype(np.float32)


def quaternion_xyzw(rotation: NDArray[np.float64]) -> tuple[float, float, float, float]:
    """Quaternion of a rotation matrix (w > 0 branch: every rotation here is below 180°)."""
    w = math.sqrt(max(0.0, 1.0 + float(np.trace(rotation)))) / 2.0
    return (
        (rotation[2, 1] - rotation[1, 2]) / (4 * w),
        (rotation[0, 2] - rotation[2, 0]) / (4 * w),
        (rotation[1, 0] - rotation[0, 1]) / (4 * w),
        w,
    )


def write_bag(path: Path, depth_topic: str = DEPTH_TOPIC) -> Path:
    """Write the walk as a ROS 2 bag folder (MCAP storage); CameraInfo beside the depth topic."""
    store = get_typestore(Stores.ROS2_HUMBLE)
    t = store.types
    info_topic = depth_topic.rsplit("/", 1)[0] + "/camera_info"

    def header(stamp_ns: int, frame_id: str):
        sec, nanosec = divmod(stamp_ns, 1_000_000_000)
        return t["std_msgs/msg/Header"](
            stamp=t["builtin_interfaces/msg/Time"](sec=sec, nanosec=nanosec), frame_id=frame_id
        )

    def tf_message(stamp_ns: int, parent: str, child: str, matrix: NDArray[np.float64]):
        transform = t["geometry_msgs/msg/Transform"](
            translation=t["geometry_msgs/msg/Vector3"](*matrix[:3, 3]),
            rotation=t["geometry_msgs/msg/Quaternion"](*quaternion_xyzw(matrix[:3, :3])),
        )
        stamped = t["geometry_msgs/msg/TransformStamped"](
            header=header(stamp_ns, parent), child_frame_id=child, transform=transform
        )
        return t["tf2_msgs/msg/TFMessage"](transforms=[stamped])

    i = INTRINSICS
    k = np.array([i.fx, 0.0, i.cx, 0.0, i.fy, i.cy, 0.0, 0.0, 1.0])
    p = np.array([i.fx, 0.0, i.cx, 0.0, 0.0, i.fy, i.cy, 0.0, 0.0, 0.0, 1.0, 0.0])
    messages = [
        ("/tf_static", T0_NS, tf_message(T0_NS, "base_footprint", OPTICAL_FRAME, camera_to_base()))
    ]
    last_ns = T0_NS + FRAMES * FRAME_NS
    for stamp in range(T0_NS, last_ns + TF_NS, TF_NS):
        odom = planar_pose_to_matrix(base_pose(stamp))
        messages.append(("/tf", stamp, tf_message(stamp, "odom", "base_footprint", odom)))
    for frame in range(FRAMES):
        stamp = T0_NS + 10_000_000 + frame * FRAME_NS  # images between odometry samples
        depth = render_depth(planar_pose_to_matrix(base_pose(stamp)) @ camera_to_base())
        image = t["sensor_msgs/msg/Image"](
            header=header(stamp, OPTICAL_FRAME),
            height=i.height,
            width=i.width,
            encoding="32FC1",
            is_bigendian=0,
            step=i.width * 4,
            data=np.frombuffer(depth.astype("<f4").tobytes(), dtype=np.uint8),
        )
        info = t["sensor_msgs/msg/CameraInfo"](
            header=header(stamp, OPTICAL_FRAME),
            height=i.height,
            width=i.width,
            distortion_model="plumb_bob",
            d=np.zeros(5),
            k=k,
            r=np.eye(3).ravel(),
            p=p,
            binning_x=0,
            binning_y=0,
            roi=t["sensor_msgs/msg/RegionOfInterest"](0, 0, 0, 0, False),
        )
        messages += [(depth_topic, stamp, image), (info_topic, stamp, info)]
    messages.sort(key=lambda item: item[1])
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        connections = {}
        for topic, stamp, message in messages:
            if topic not in connections:
                connections[topic] = writer.add_connection(
                    topic, message.__msgtype__, typestore=store
                )
            writer.write(
                connections[topic], stamp, store.serialize_cdr(message, message.__msgtype__)
            )
    return path


def run(out: Path) -> int:
    """Make the bag, import it, map it: ``OUT/bag``, ``OUT/walk.npz``, ``OUT/map/`` (pictures)."""
    out.mkdir(parents=True, exist_ok=True)
    bag = write_bag(out / "bag")
    recording = out / "walk.npz"
    for argv in (
        ["import-bag", str(bag), "--list"],
        ["import-bag", str(bag), "--out", str(recording), "--depth-topic", DEPTH_TOPIC],
        ["run", "--replay", str(recording), "--out", str(out / "map"), "--quiet"],
    ):
        print("$ fogsim", " ".join(argv))
        code = fogsim_main(argv)
        if code != 0:
            return code
    return 0


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("runs/real_data"), help="new folder")
    raise SystemExit(run(parser.parse_args().out))
