"""ROS bags in: bags written with rosbags' own writers from synthetic frames of a known scene.

The robot walks at constant velocity and turn rate while its head pitches at a constant rate;
tf is published at 50 Hz, off the camera's stamps, so every camera pose is interpolated — and
interpolation (linear for translation, slerp for a rotation about a fixed axis) is exact for
such motion. Importing the bag must give the frames back, and mapping them the same maps.npz as
mapping the frames directly.
"""

import math
import sqlite3
from dataclasses import dataclass

import numpy as np
import pytest
from rosbags.rosbag1 import Writer as Writer1
from rosbags.rosbag2 import StoragePlugin
from rosbags.rosbag2 import Writer as Writer2
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from synthetic_depth import Box, render_boxes, staircase

from fogsim.bags.images import depth_m_from_image
from fogsim.bags.read import bag_topics, import_bag, read_bag_frames
from fogsim.bags.tf import TfTree, TransformSample
from fogsim.bags.topics import BagError, BagOptions
from fogsim.cli import main
from fogsim.data.frame import Frame
from fogsim.data.recording import Recording, load_recording
from fogsim.errors import RecordingError
from fogsim.eval.maps import load_maps
from fogsim.run.runner import run_scenario
from mapper.intrinsics import PinholeIntrinsics
from mapper.transforms import planar_pose_to_matrix

INTR = PinholeIntrinsics.from_fov(88, 72, 47.0, 39.0)
T0_NS = 1_700_000_000_000_000_000
"""A realistic epoch stamp: real bags carry wall-clock time."""
FRAME_NS = 80_000_000  # 12.5 Hz
TF_NS = 20_000_000  # 50 Hz
FRAMES = 16
VELOCITY_XY = (0.25, 0.04)  # m/s
YAW0, YAW_RATE = 0.05, 0.08  # rad, rad/s
PITCH0_DEG, PITCH_RATE_DEG = 30.0, 4.0  # head pitch down, deg/s
FOOTPRINT_TO_LINK_Z = 0.55
HEAD_TO_CAMERA = (0.06, 0.0, 0.3)
DEPTH_TOPIC = "/camera/depth/image_rect_raw"
INFO_TOPIC = "/camera/depth/camera_info"
BOXES = [*staircase(x_start_m=1.1), Box((1.5, 0.6), (0.3, 0.3, 0.3))]
TF_MSG = "geometry_msgs/TransformStamped[] transforms\n"
OPTICAL = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
"""Columns: the optical frame's x, y, z axes in the head's body frame (x forward, z up)."""


def seconds(stamp_ns):
    return (stamp_ns - T0_NS) / 1e9


def robot_pose(stamp_ns):
    t = seconds(stamp_ns)
    return np.array(
        [0.1 + VELOCITY_XY[0] * t, -0.05 + VELOCITY_XY[1] * t, 0.0, YAW0 + YAW_RATE * t]
    )


def head_pitch_rad(stamp_ns):
    return math.radians(PITCH0_DEG + PITCH_RATE_DEG * seconds(stamp_ns))


def rot_y(angle):
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def transform(rotation, translation):
    out = np.eye(4)
    out[:3, :3] = rotation
    out[:3, 3] = translation
    return out


def camera_in_footprint(stamp_ns):
    link = transform(np.eye(3), (0.0, 0.0, FOOTPRINT_TO_LINK_Z))
    head = transform(rot_y(head_pitch_rad(stamp_ns)), (0.0, 0.0, 0.0))
    return link @ head @ transform(OPTICAL, HEAD_TO_CAMERA)


def image_stamps():
    return [T0_NS + 5_000_000 + i * FRAME_NS for i in range(FRAMES)]


def direct_frames():
    """The frames a bag of this walk must give back (poses analytic, depth ray-cast)."""
    frames = []
    for i, stamp in enumerate(image_stamps()):
        pose = robot_pose(stamp)
        camera = camera_in_footprint(stamp)
        depth = render_boxes(INTR, planar_pose_to_matrix(pose) @ camera, BOXES)
        frames.append(real_frame(i, stamp / 1e9, depth, camera, pose))
    return frames


def real_frame(index, time_s, depth_m, camera_in_robot, robot_pose):
    """A frame as real data has it: believed poses only, the true ones unknown (NaN)."""
    return Frame(
        index=index,
        time_s=time_s,
        depth_m=np.asarray(depth_m, dtype=np.float32),
        intrinsics=INTR,
        transform_camera_to_robot_believed=camera_in_robot,
        robot_pose_believed=robot_pose,
        transform_camera_to_world_true=np.full((4, 4), np.nan),
        robot_pose_true=np.full(4, np.nan),
    )


def quaternion_xyzw(rotation):
    """Quaternion of a rotation matrix (w > 0 branch: the test's rotations are < 180°)."""
    w = math.sqrt(max(0.0, 1.0 + np.trace(rotation))) / 2.0
    return (
        (rotation[2, 1] - rotation[1, 2]) / (4 * w),
        (rotation[0, 2] - rotation[2, 0]) / (4 * w),
        (rotation[1, 0] - rotation[0, 1]) / (4 * w),
        w,
    )


@dataclass
class BagSpec:
    """What to put into a test bag (defaults: a good bag of the walk)."""

    encoding: str = "32FC1"
    camera_info: bool = True
    tf_gap_ns: tuple[int, int] | None = None  # odom tf left out in [start, stop)
    frame_id_prefix: str = ""  # ROS 1 bags often name frames "/odom"
    second_parent: bool = False  # base_footprint also published under "map"
    camera_on_tf: bool = True  # False: only odom -> base_footprint on tf, the neck on /joint_states
    images_reversed: bool = False  # images received (bag time) in reverse order of their stamps


class BagBuilder:
    """Writes the walk into a ROS 2 (sqlite3 or MCAP) or ROS 1 bag with rosbags' writers."""

    def __init__(self, kind):
        self.kind = kind
        self.ros1 = kind == "ros1"
        self.store = get_typestore(Stores.ROS1_NOETIC if self.ros1 else Stores.ROS2_HUMBLE)
        if self.ros1:  # Noetic's store lacks tf2_msgs
            self.store.register(get_types_from_msg(TF_MSG, "tf2_msgs/msg/TFMessage"))
        self.types = self.store.types

    def header(self, stamp_ns, frame_id):
        sec, nanosec = divmod(stamp_ns, 1_000_000_000)
        stamp = self.types["builtin_interfaces/msg/Time"](sec=sec, nanosec=nanosec)
        fields = {"seq": 0} if self.ros1 else {}
        return self.types["std_msgs/msg/Header"](stamp=stamp, frame_id=frame_id, **fields)

    def transform_stamped(self, stamp_ns, parent, child, matrix):
        t = self.types
        return t["geometry_msgs/msg/TransformStamped"](
            header=self.header(stamp_ns, parent),
            child_frame_id=child,
            transform=t["geometry_msgs/msg/Transform"](
                translation=t["geometry_msgs/msg/Vector3"](*matrix[:3, 3]),
                rotation=t["geometry_msgs/msg/Quaternion"](*quaternion_xyzw(matrix[:3, :3])),
            ),
        )

    def image(self, stamp_ns, depth_m, encoding, frame_id):
        if encoding == "16UC1":
            data = np.nan_to_num(np.round(depth_m * 1000.0)).astype("<u2")
        else:
            data = depth_m.astype("<f4")
        return self.types["sensor_msgs/msg/Image"](
            header=self.header(stamp_ns, frame_id),
            height=INTR.height,
            width=INTR.width,
            encoding=encoding,
            is_bigendian=0,
            step=INTR.width * data.itemsize,
            data=np.frombuffer(data.tobytes(), dtype=np.uint8),
        )

    def joint_state(self, stamp_ns):
        """The neck's pitch and an arm joint off the camera's chain."""
        return self.types["sensor_msgs/msg/JointState"](
            header=self.header(stamp_ns, ""),
            name=["arm", "neck"],
            position=np.array([0.3, head_pitch_rad(stamp_ns)]),
            velocity=np.zeros(0),
            effort=np.zeros(0),
        )

    def camera_info(self, stamp_ns, frame_id):
        k = [INTR.fx, 0.0, INTR.cx, 0.0, INTR.fy, INTR.cy, 0.0, 0.0, 1.0]
        p = [INTR.fx, 0.0, INTR.cx, 0.0, 0.0, INTR.fy, INTR.cy, 0.0, 0.0, 0.0, 1.0, 0.0]
        arrays = {"d": np.zeros(5), "k": np.array(k), "r": np.eye(3).ravel(), "p": np.array(p)}
        if self.ros1:
            arrays = {name.upper(): value for name, value in arrays.items()}
        return self.types["sensor_msgs/msg/CameraInfo"](
            header=self.header(stamp_ns, frame_id),
            height=INTR.height,
            width=INTR.width,
            distortion_model="plumb_bob",
            binning_x=0,
            binning_y=0,
            roi=self.types["sensor_msgs/msg/RegionOfInterest"](0, 0, 0, 0, False),
            **arrays,
        )

    def messages(self, spec):
        """(topic, msgtype, stamp_ns, message) in time order."""
        name = lambda frame: spec.frame_id_prefix + frame  # noqa: E731
        out = []
        static = [
            ("base_footprint", "base_link", transform(np.eye(3), (0, 0, FOOTPRINT_TO_LINK_Z))),
            ("head", "camera_depth_optical_frame", transform(OPTICAL, HEAD_TO_CAMERA)),
        ]
        if not spec.camera_on_tf:
            static = [("odom", "world_origin", np.eye(4))]  # /tf_static still has something
        out.append(
            (
                "/tf_static",
                T0_NS,
                [self.transform_stamped(T0_NS, name(p), name(c), m) for p, c, m in static],
            )
        )
        last = image_stamps()[-1] + 3 * TF_NS
        for stamp in range(T0_NS - 2 * TF_NS + 3_000_000, last, TF_NS):
            neck_stamp = stamp + 4_000_000
            transforms = []
            if spec.camera_on_tf:
                neck = transform(rot_y(head_pitch_rad(neck_stamp)), (0, 0, 0))
                transforms.append(
                    self.transform_stamped(neck_stamp, name("base_link"), name("head"), neck)
                )
            else:
                out.append(("/joint_states", neck_stamp, self.joint_state(neck_stamp)))
            gap = spec.tf_gap_ns
            if gap is None or not gap[0] <= stamp < gap[1]:
                odom = planar_pose_to_matrix(robot_pose(stamp))
                transforms.append(
                    self.transform_stamped(stamp, name("odom"), name("base_footprint"), odom)
                )
            if spec.second_parent:
                transforms.append(
                    self.transform_stamped(stamp, name("map"), name("base_footprint"), np.eye(4))
                )
            out.append(("/tf", stamp, transforms))
        stamps = image_stamps()
        received = stamps[::-1] if spec.images_reversed else stamps
        for frame, stamp, at in zip(direct_frames(), stamps, received, strict=True):
            optical = name("camera_depth_optical_frame")
            out.append((DEPTH_TOPIC, at, self.image(stamp, frame.depth_m, spec.encoding, optical)))
            if spec.camera_info:
                out.append((INFO_TOPIC, stamp, self.camera_info(stamp, optical)))
        out.sort(key=lambda item: item[1])
        return out

    def write(self, path, spec=None):
        spec = spec or BagSpec()
        msgtypes = {
            "/tf": "tf2_msgs/msg/TFMessage",
            "/tf_static": "tf2_msgs/msg/TFMessage",
            DEPTH_TOPIC: "sensor_msgs/msg/Image",
            INFO_TOPIC: "sensor_msgs/msg/CameraInfo",
            "/joint_states": "sensor_msgs/msg/JointState",
        }
        if self.ros1:
            writer = Writer1(path)
        else:
            plugin = StoragePlugin.MCAP if self.kind == "mcap" else StoragePlugin.SQLITE3
            writer = Writer2(path, version=9, storage_plugin=plugin)
        with writer:
            connections = {}
            for topic, stamp, message in self.messages(spec):
                msgtype = msgtypes[topic]
                if topic not in connections:
                    connections[topic] = writer.add_connection(topic, msgtype, typestore=self.store)
                if topic in ("/tf", "/tf_static"):
                    message = self.types[msgtype](transforms=message)
                data = (
                    self.store.serialize_ros1(message, msgtype)
                    if self.ros1
                    else self.store.serialize_cdr(message, msgtype)
                )
                writer.write(connections[topic], stamp, data)
        return path


def bag_path(tmp_path, kind, name="walk"):
    return tmp_path / (f"{name}.bag" if kind == "ros1" else name)


KINDS = ["sqlite3", "mcap", "ros1"]


@pytest.mark.parametrize("kind", KINDS)
def test_a_bag_gives_back_its_frames(tmp_path, kind):
    spec = BagSpec(frame_id_prefix="/" if kind == "ros1" else "")
    path = BagBuilder(kind).write(bag_path(tmp_path, kind), spec)
    frames = read_bag_frames(path)
    expected = direct_frames()
    assert len(frames) == FRAMES
    for got, want in zip(frames, expected, strict=True):
        assert got.time_s == want.time_s
        assert got.intrinsics == INTR
        np.testing.assert_array_equal(got.depth_m, want.depth_m)  # 32FC1 is exact
        np.testing.assert_allclose(got.robot_pose_believed, want.robot_pose_believed, atol=1e-9)
        np.testing.assert_allclose(
            got.transform_camera_to_robot_believed,
            want.transform_camera_to_robot_believed,
            atol=1e-9,
        )
        assert np.isnan(got.robot_pose_true).all()
        assert np.isnan(got.transform_camera_to_world_true).all()


def test_images_received_out_of_stamp_order_come_out_in_time_order(tmp_path):
    path = BagBuilder("mcap").write(tmp_path / "late", BagSpec(images_reversed=True))
    frames = read_bag_frames(path, spool_folder=tmp_path)
    assert [f.time_s for f in frames] == sorted(f.time_s for f in frames)
    for got, want in zip(frames, direct_frames(), strict=True):
        np.testing.assert_array_equal(got.depth_m, want.depth_m)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["late"]  # the spool left nothing


@pytest.mark.parametrize("kind", KINDS)
def test_importing_then_replaying_gives_the_maps_of_the_direct_run(tmp_path, kind):
    bag = BagBuilder(kind).write(bag_path(tmp_path, kind))
    imported = import_bag(bag, tmp_path / "walk.npz")
    assert imported.frames == FRAMES
    recording = load_recording(imported.path)
    assert recording.scenario is None and not recording.has_truth

    direct = direct_frames()
    direct_recording = Recording(direct, None, [None] * len(direct), INTR)
    run_scenario(None, tmp_path / "direct", replay=direct_recording, pictures=False)
    report = run_scenario(None, tmp_path / "replayed", replay=recording, pictures=False)
    assert report.table1 is None  # no ground truth: not scored
    a = load_maps(tmp_path / "direct" / "maps.npz")
    b = load_maps(tmp_path / "replayed" / "maps.npz")
    assert a.truth is None and b.truth is None
    np.testing.assert_array_equal(a.cell_centers_xy, b.cell_centers_xy)
    np.testing.assert_array_equal(a.fog_types, b.fog_types)
    # The maps hold the scene: the ground, and the flat-topped 0.3 m box, whose top the FOG maps
    # as a floor at its height (a flat top is walkable to it) with its sides' cells as obstacle.
    floor = a.fog_types == 1
    assert floor.sum() > 500
    on_box = floor & (np.abs(a.fog_heights_m - 0.3) < 0.01)
    assert on_box.sum() > 5 and (a.fog_types == 2).sum() >= 1
    for name in ("fog_heights_m", "floor_m", "obstacle_m", "ceiling_m", "averaging_heights_m"):
        np.testing.assert_allclose(getattr(a, name), getattr(b, name), atol=1e-9, err_msg=name)


def test_the_command_line_imports_lists_and_replays(tmp_path, capsys):
    bag = BagBuilder("mcap").write(tmp_path / "walk")
    assert main(["import-bag", str(bag), "--list"]) == 0
    listing = capsys.readouterr().out
    assert DEPTH_TOPIC in listing and "sensor_msgs/msg/CameraInfo" in listing
    assert f"{FRAMES:>8}" in listing.splitlines()[0] or f" {FRAMES}" in listing
    out = tmp_path / "walk.npz"
    assert main(["import-bag", str(bag), "--out", str(out)]) == 0
    assert f"imported {FRAMES} frames" in capsys.readouterr().out
    assert (
        main(
            ["run", "--replay", str(out), "--quiet", "--no-pictures", "--out", str(tmp_path / "o")]
        )
        == 0
    )
    assert "no ground truth" in capsys.readouterr().out


def test_a_ros2_bag_without_message_definitions_is_read_with_humbles(tmp_path):
    bag = BagBuilder("sqlite3").write(tmp_path / "old")
    (db,) = bag.glob("*.db3")
    with sqlite3.connect(db) as connection:  # as rosbag2 before Iron wrote them
        connection.execute("DELETE FROM message_definitions")
    frames = read_bag_frames(bag)
    np.testing.assert_array_equal(frames[7].depth_m, direct_frames()[7].depth_m)


URDF = """<robot name="walker">
  <link name="base_footprint"/> <link name="base_link"/> <link name="head"/> <link name="arm"/>
  <link name="camera_depth_optical_frame"/>
  <joint name="lift" type="fixed"><parent link="base_footprint"/><child link="base_link"/>
    <origin xyz="0 0 0.55"/></joint>
  <joint name="neck" type="NECK"><parent link="base_link"/><child link="head"/>
    <axis xyz="0 1 0"/><limit lower="-1.5" upper="1.5" effort="10" velocity="2"/></joint>
  <joint name="arm" type="revolute"><parent link="base_link"/><child link="arm"/>
    <axis xyz="1 0 0"/><limit lower="-1.5" upper="1.5" effort="10" velocity="2"/></joint>
  <joint name="optical" type="fixed"><parent link="head"/><child link="camera_depth_optical_frame"/>
    <origin xyz="0.06 0 0.3" rpy="-1.5707963267948966 0 -1.5707963267948966"/></joint>
</robot>
"""
"""The walk's robot: the optical frame's rpy is OPTICAL (x right, y down, z forward)."""


@pytest.mark.parametrize("neck", ["revolute", "continuous"])
def test_the_camera_from_joint_states_through_the_urdf(tmp_path, neck):
    bag = BagBuilder("mcap").write(tmp_path / "joints", BagSpec(camera_on_tf=False))
    urdf = tmp_path / "walker.urdf"
    urdf.write_text(URDF.replace("NECK", neck))
    with pytest.raises(BagError, match="tf frame 'camera_depth_optical_frame' is not in /tf"):
        read_bag_frames(bag)
    frames = read_bag_frames(bag, BagOptions(urdf_path=urdf))
    for got, want in zip(frames, direct_frames(), strict=True):
        np.testing.assert_allclose(got.robot_pose_believed, want.robot_pose_believed, atol=1e-9)
        np.testing.assert_allclose(
            got.transform_camera_to_robot_believed,
            want.transform_camera_to_robot_believed,
            atol=1e-9,
        )
    urdf.write_text(URDF.replace("NECK", neck).replace('name="neck"', 'name="nod"'))
    with pytest.raises(BagError, match=r"joint 'nod' has no joint states; .*\['arm', 'neck'\]"):
        read_bag_frames(bag, BagOptions(urdf_path=urdf))
    urdf.write_text("<robot>")
    with pytest.raises(BagError, match="not a URDF model pinocchio can read"):
        read_bag_frames(bag, BagOptions(urdf_path=urdf))


def test_16bit_millimetre_depth_is_read_in_metres(tmp_path):
    bag = BagBuilder("sqlite3").write(tmp_path / "mm", BagSpec(encoding="16UC1"))
    frames = read_bag_frames(bag)
    want = direct_frames()[3].depth_m.astype(np.float64)
    got = frames[3].depth_m.astype(np.float64)
    np.testing.assert_array_equal(np.isnan(got), np.isnan(want))
    assert np.nanmax(np.abs(got - want)) <= 0.0005 + 1e-7  # rounded to whole millimetres


class _Image:
    """A hand-made sensor_msgs/Image (padded rows, either byte order)."""

    def __init__(self, encoding, values, dtype, bigendian=False, pad=2):
        array = np.asarray(values, dtype=np.dtype(dtype).newbyteorder(">" if bigendian else "<"))
        rows = [row.tobytes() + b"\xee" * pad for row in array]
        self.encoding, self.is_bigendian = encoding, int(bigendian)
        self.height, self.width = array.shape
        self.step = array.shape[1] * array.itemsize + pad
        self.data = np.frombuffer(b"".join(rows), dtype=np.uint8)


@pytest.mark.parametrize("bigendian", [False, True])
def test_depth_decoding_handles_padding_byte_order_and_invalid_pixels(bigendian):
    mm = _Image("16UC1", [[0, 1000, 2500], [65535, 1, 42]], "u2", bigendian)
    np.testing.assert_allclose(
        depth_m_from_image(mm, "t"), [[np.nan, 1.0, 2.5], [65.535, 0.001, 0.042]], rtol=1e-7
    )
    metres = _Image("32FC1", [[0.0, 1.25, np.inf], [-1.0, np.nan, 3.5]], "f4", bigendian)
    np.testing.assert_array_equal(
        depth_m_from_image(metres, "t"), [[np.nan, 1.25, np.nan], [np.nan, np.nan, 3.5]]
    )


def test_tf_interpolates_between_samples_and_chains_frames():
    half = math.sqrt(0.5)
    moving = [
        TransformSample(0, "odom", "base", (0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0)),
        TransformSample(100, "odom", "base", (2.0, 0.0, 0.0), (0.0, 0.0, half, half)),  # 90°
    ]
    static = [TransformSample(0, "base", "cam", (1.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))]
    tree = TfTree(moving, static)
    got = tree.lookup("odom", "cam", np.array([50]), max_dt_ns=60)[0]
    c = math.cos(math.radians(45.0))  # halfway: 45° turned, 1 m along x
    np.testing.assert_allclose(got[:3, :3], [[c, -c, 0], [c, c, 0], [0, 0, 1]], atol=1e-12)
    np.testing.assert_allclose(got[:3, 3], [1.0 + c, c, 0.0], atol=1e-12)
    inverse = tree.lookup("cam", "odom", np.array([50]), max_dt_ns=60)[0]
    np.testing.assert_allclose(inverse @ got, np.eye(4), atol=1e-12)
    with pytest.raises(BagError, match=r"no sample within 4e-05 ms of stamp 50 ns"):
        tree.lookup("odom", "cam", np.array([50]), max_dt_ns=40)
    with pytest.raises(BagError, match="several parents"):
        TfTree([*moving, TransformSample(0, "map", "base", (0, 0, 0), (0, 0, 0, 1))], [])


@pytest.mark.parametrize(
    ("spec", "options", "message"),
    [
        (
            BagSpec(),
            BagOptions(depth_topic="/nope/image"),
            r"no sensor_msgs/msg/Image messages on /nope/image.*\['/camera/depth/image_rect_raw'\]",
        ),
        (
            BagSpec(camera_info=False),
            BagOptions(),
            r"no sensor_msgs/msg/CameraInfo messages on /camera/depth/camera_info",
        ),
        (BagSpec(encoding="rgb8"), BagOptions(), r"encoding 'rgb8' is not a depth encoding"),
        (
            BagSpec(tf_gap_ns=(T0_NS + 300_000_000, T0_NS + 600_000_000)),
            BagOptions(),
            r"tf odom -> base_footprint: no sample within 50 ms of stamp 1700000000405000000 ns",
        ),
        (
            BagSpec(),
            BagOptions(base_frame="base_foot"),
            r"tf frame 'base_foot' is not in /tf or /tf_static",
        ),
        (
            BagSpec(second_parent=True),
            BagOptions(),
            r"tf frame 'base_footprint' has several parents \['map', 'odom'\]",
        ),
    ],
    ids=[
        "missing topic",
        "no CameraInfo",
        "bad encoding",
        "tf gap",
        "unknown frame",
        "two parents",
    ],
)
def test_broken_bags_get_named_errors(tmp_path, spec, options, message):
    bag = BagBuilder("mcap").write(tmp_path / "broken", spec)
    with pytest.raises(BagError, match=message) as caught:
        read_bag_frames(bag, options)
    assert isinstance(caught.value, RecordingError)
    assert str(bag) in str(caught.value)


def test_a_wider_tolerance_bridges_a_tf_gap(tmp_path):
    gap = BagSpec(tf_gap_ns=(T0_NS + 300_000_000, T0_NS + 450_000_000))  # image 5: 58 ms
    bag = BagBuilder("mcap").write(tmp_path / "gap", gap)
    with pytest.raises(BagError, match="no sample within 50 ms"):
        read_bag_frames(bag)
    frames = read_bag_frames(bag, BagOptions(max_dt_ms=120.0))
    np.testing.assert_allclose(  # interpolated across the gap: exact for constant velocity
        frames[5].robot_pose_believed, direct_frames()[5].robot_pose_believed, atol=1e-9
    )


def test_bad_bags_exit_2_on_the_command_line_without_a_traceback(tmp_path, capsys):
    broken = BagBuilder("ros1").write(tmp_path / "broken.bag", BagSpec(encoding="bgr8"))
    assert main(["import-bag", str(broken), "--out", str(tmp_path / "x.npz")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("fogsim: error:") and "bgr8" in err and "Traceback" not in err
    assert not (tmp_path / "x.npz").exists()
    assert main(["import-bag", str(tmp_path / "none"), "--out", str(tmp_path / "x.npz")]) == 2
    assert "bag not found" in capsys.readouterr().err
    (tmp_path / "junk").mkdir()
    assert main(["import-bag", str(tmp_path / "junk"), "--list"]) == 2
    assert "not a readable ROS 1 or ROS 2 bag" in capsys.readouterr().err
    assert main(["import-bag", str(broken)]) == 2
    assert "needs --out FILE" in capsys.readouterr().err
    assert main(["import-bag", str(broken), "--out", "x.npz", "--max-dt-ms", "0"]) == 2
    assert "max_dt_ms = 0.0 must be in (0, 1000] ms" in capsys.readouterr().err


def test_bag_topics_lists_types_and_counts(tmp_path):
    bag = BagBuilder("ros1").write(tmp_path / "walk.bag")
    topics = {t.name: (t.msgtype, t.count) for t in bag_topics(bag)}
    assert topics[DEPTH_TOPIC] == ("sensor_msgs/msg/Image", FRAMES)
    assert topics[INFO_TOPIC] == ("sensor_msgs/msg/CameraInfo", FRAMES)
    assert topics["/tf_static"] == ("tf2_msgs/msg/TFMessage", 1)


def test_the_default_camera_info_topic_sits_beside_the_depth_topic():
    assert BagOptions(depth_topic="/a/b/depth").info_topic == "/a/b/camera_info"
    assert BagOptions(camera_info_topic="/x/info").info_topic == "/x/info"
    with pytest.raises(BagError, match="depth_topic = 'camera' must be an absolute topic"):
        BagOptions(depth_topic="camera")
