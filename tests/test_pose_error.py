"""Pose-error statistics over frames: known offsets give known medians and maxima."""

import math

import numpy as np
import pytest
from msgspec import UNSET

from fogsim.data.frame import Frame
from fogsim.eval.pose_error import PoseErrorAccumulator, heading_error_deg
from fogsim.eval.report.schema import MedianMax, PoseErrorStats
from mapper.intrinsics import PinholeIntrinsics
from mapper.transforms import planar_pose_to_matrix

INTR = PinholeIntrinsics.from_fov(8, 6, 47.0, 39.0)
ROBOT_POSE = np.array([1.0, 2.0, 0.0, 0.5])


def camera_in_robot(yaw_deg=0.0, z_m=0.9):
    a = math.radians(yaw_deg)
    t = np.eye(4)
    t[:3, :3] = [[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]]
    t[2, 3] = z_m
    return t


def frame(index, believed_camera, robot_offset_m=0.0, true_pose=True, robot_yaw_deg=0.0):
    true_world = planar_pose_to_matrix(ROBOT_POSE) @ camera_in_robot()
    believed_robot = ROBOT_POSE + np.array([robot_offset_m, 0.0, 0.0, math.radians(robot_yaw_deg)])
    return Frame(
        index=index,
        time_s=index / 12.5,
        depth_m=np.ones((6, 8), np.float32),
        intrinsics=INTR,
        transform_camera_to_robot_believed=believed_camera,
        robot_pose_believed=believed_robot,
        transform_camera_to_world_true=true_world if true_pose else np.full((4, 4), np.nan),
        robot_pose_true=ROBOT_POSE,
    )


def test_no_true_pose_gives_only_a_zero_frame_count():
    errors = PoseErrorAccumulator()
    errors.add(frame(0, camera_in_robot(), true_pose=False))
    assert errors.stats() == PoseErrorStats(frames=0)


def test_encoder_and_odometry_offsets_give_known_statistics():
    errors = PoseErrorAccumulator()
    # Frame 0: the camera believed 2° yawed and 10 mm higher, the robot 30 mm ahead in world x.
    errors.add(frame(0, camera_in_robot(yaw_deg=2.0, z_m=0.91), robot_offset_m=0.03))
    errors.add(frame(1, camera_in_robot()))  # exact
    errors.add(frame(2, camera_in_robot(yaw_deg=9.0), true_pose=False))  # skipped
    stats = errors.stats()
    assert stats.frames == 2
    assert stats.camera_in_robot.rotation_deg == MedianMax(1.0, 2.0)
    assert stats.camera_in_robot.translation_mm == MedianMax(5.0, 10.0)
    assert stats.camera_in_world.rotation_deg == MedianMax(1.0, 2.0)
    world_mm = 1000.0 * math.hypot(0.03, 0.01)  # 31.6228 mm
    assert stats.camera_in_world.translation_mm.max == pytest.approx(world_mm, abs=1e-4)
    assert stats.camera_in_world.translation_mm.median == pytest.approx(world_mm / 2, abs=1e-4)


def test_residual_heading_is_the_yaw_left_after_the_corrections():
    errors = PoseErrorAccumulator()
    # Believed 4° off; the pipeline's corrected pose is 0.5° off on frame 0, −1.5° on frame 1.
    errors.add(frame(0, camera_in_robot(yaw_deg=4.0)), camera_in_robot(yaw_deg=0.5))
    errors.add(frame(1, camera_in_robot(yaw_deg=4.0)), camera_in_robot(yaw_deg=-1.5))
    errors.add(frame(2, camera_in_robot(), true_pose=False), camera_in_robot(yaw_deg=9.0))
    stats = errors.stats()
    assert stats.frames == 2
    assert stats.camera_in_robot.rotation_deg == MedianMax(4.0, 4.0)
    assert stats.residual_heading_deg == MedianMax(1.0, 1.5)  # of |yaw|: 0.5 and 1.5


def test_map_heading_takes_each_frames_last_mapping():
    # Three frames, believed 4° off, each corrected by 1.5° when processed (2.5° left); frames 0
    # and 1 are mapped again with the heading's estimate (0.5° and then -0.25° left on frame 0:
    # the last mapping wins, 0.75° on frame 1); frame 2 keeps its first mapping.
    errors = PoseErrorAccumulator()
    for index in range(3):
        errors.add(frame(index, camera_in_robot(yaw_deg=4.0)), camera_in_robot(yaw_deg=2.5))
    errors.remapped(0, camera_in_robot(yaw_deg=0.5))
    errors.remapped(1, camera_in_robot(yaw_deg=0.75))
    errors.remapped(0, camera_in_robot(yaw_deg=-0.25))
    stats = errors.stats()
    assert stats.residual_heading_deg == MedianMax(2.5, 2.5)  # as processed
    assert stats.map_heading_deg == MedianMax(0.75, 2.5)  # of 0.25, 0.75 and 2.5
    with pytest.raises(IndexError, match=r"position 3 is not among the 3 frames added"):
        errors.remapped(3, camera_in_robot())


def test_map_heading_skips_frames_without_a_true_pose_in_step_with_the_residual():
    # Frame 1 has no true pose: the remapping of frame 2 must land on frame 2's residual.
    errors = PoseErrorAccumulator()
    errors.add(frame(0, camera_in_robot(yaw_deg=4.0)), camera_in_robot(yaw_deg=1.0))
    errors.add(frame(1, camera_in_robot(), true_pose=False), camera_in_robot(yaw_deg=9.0))
    errors.add(frame(2, camera_in_robot(yaw_deg=4.0)), camera_in_robot(yaw_deg=3.0))
    errors.remapped(2, camera_in_robot(yaw_deg=-2.0))
    errors.remapped(1, camera_in_robot(yaw_deg=7.0))  # no true pose: not counted
    stats = errors.stats()
    assert stats.residual_heading_deg == MedianMax(2.0, 3.0)  # of 1 and 3
    assert stats.map_heading_deg == MedianMax(1.5, 2.0)  # of 1 and |-2|


def test_world_heading_adds_odometrys_yaw_error_to_the_last_mapping():
    # Odometry's yaw error +1°, −2°, +0.5° on three frames (a drift); the corrected camera is
    # 0.5° off in the robot frame on each, frame 2 mapped again 0.5° the other way. In the
    # world: 1.5°, −1.5° and 0.5° − 0.5° = 0°; in the robot frame 0.5°, 0.5° and 0.5°.
    errors = PoseErrorAccumulator()
    for index, odometry_deg in enumerate((1.0, -2.0, 0.5)):
        believed = frame(index, camera_in_robot(yaw_deg=4.0), robot_yaw_deg=odometry_deg)
        errors.add(believed, camera_in_robot(yaw_deg=0.5))
    errors.remapped(2, camera_in_robot(yaw_deg=-0.5))
    stats = errors.stats()
    assert stats.map_heading_deg == MedianMax(0.5, 0.5)
    assert stats.world_heading_deg.median == pytest.approx(1.5, abs=1e-4)
    assert stats.world_heading_deg.max == pytest.approx(1.5, abs=1e-4)
    # A frame whose odometry's yaw error the correction cancels is exact in the world only.
    errors = PoseErrorAccumulator()
    errors.add(frame(0, camera_in_robot(yaw_deg=4.0), robot_yaw_deg=1.0), camera_in_robot(-1.0))
    assert errors.stats().map_heading_deg == MedianMax(1.0, 1.0)
    assert errors.stats().world_heading_deg == MedianMax(0.0, 0.0)


def test_no_corrected_pose_leaves_the_residual_heading_out():
    errors = PoseErrorAccumulator()
    errors.add(frame(0, camera_in_robot(yaw_deg=2.0)))
    assert errors.stats().residual_heading_deg is UNSET
    assert errors.stats().map_heading_deg is UNSET
    assert errors.stats().world_heading_deg is UNSET


def test_heading_error_ignores_a_small_tilt_and_keeps_the_sign():
    tilt = math.radians(3.0)
    tilted = np.array(
        [
            [1.0, 0.0, 0.0],
            [0.0, math.cos(tilt), -math.sin(tilt)],
            [0.0, math.sin(tilt), math.cos(tilt)],
        ]
    )
    yawed = camera_in_robot(yaw_deg=-2.0)[:3, :3]
    assert heading_error_deg(yawed, np.eye(3)) == pytest.approx(-2.0, abs=1e-9)
    assert heading_error_deg(tilted, np.eye(3)) == pytest.approx(0.0, abs=1e-9)
