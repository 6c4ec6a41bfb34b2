"""The pipeline applies the tilt filtered over frames (`mapper.tilt_filter`, issue 12)."""

import math

import numpy as np
from synthetic_depth import Box, look_down_camera, render_boxes

from fogsim.config import RunParams
from fogsim.config.params import PipelineParams
from fogsim.data.frame import Frame
from fogsim.mapping.pipeline import Pipeline
from mapper.intrinsics import PinholeIntrinsics
from mapper.segmentation import segment_depth

INTR = PinholeIntrinsics.from_fov(88, 72, 47.0, 39.0)
CAMERA_IN_ROBOT = look_down_camera((0.0, 0.0, 0.9), pitch_down_deg=35.0)
ROBOT_POSE = np.array([0.3, 0.5, 0.0, 0.0])
# A wall 0.55 m ahead of the camera fills the whole view (rays 15.5-54.5° down meet its face
# 0.13-0.75 m high): no horizontal plane, so no tilt measurement.
WALL = Box((0.95, 0.5), (0.2, 3.0, 1.5))
WALL_FACE_X_M = 0.85
PITCH_ERROR_DEG = 2.0


def _believed_camera():
    """The camera pose the robot believes: pitched 2° about the robot's y axis."""
    c, s = math.cos(math.radians(PITCH_ERROR_DEG)), math.sin(math.radians(PITCH_ERROR_DEG))
    out = CAMERA_IN_ROBOT.copy()
    out[:3, :3] = np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]]) @ out[:3, :3]
    return out


def _camera_in_world():
    t = np.eye(4)
    t[:3, 3] = ROBOT_POSE[:3]
    return t @ CAMERA_IN_ROBOT


def _frames(n_ground, n_wall):
    """Standing robot: ``n_ground`` frames of bare ground, then ``n_wall`` of the wall."""
    world = _camera_in_world()
    believed = _believed_camera()
    frames = []
    for i in range(n_ground + n_wall):
        depth = render_boxes(INTR, world, [] if i < n_ground else [WALL])
        frames.append(
            Frame(
                index=i,
                time_s=i / 12.5,
                depth_m=depth.astype(np.float32),
                intrinsics=INTR,
                transform_camera_to_robot_believed=believed,
                robot_pose_believed=ROBOT_POSE,
                transform_camera_to_world_true=world,
                robot_pose_true=ROBOT_POSE,
            )
        )
    return frames


def _pipeline(use_tilt_filter):
    params = PipelineParams(
        use_height_reference=False, use_z_match=False, use_tilt_filter=use_tilt_filter
    )
    return Pipeline(RunParams(pipeline=params))


def test_a_frame_without_horizontal_planes_takes_the_tilt_learnt_from_the_frames_before():
    # Six frames of exact ground teach the filter the 2° pitch error (their own measurement is
    # exact); then the wall frame measures no tilt: with the filter it is rotated by the learnt
    # tilt and its face lies where it is, without it the frame keeps the believed pitch and the
    # face's points move by up to 0.77 m · tan 2° = 27 mm (its lowest points, farthest below
    # the camera).
    frames = _frames(6, 1)
    assert (
        segment_depth(
            frames[-1].depth_m, INTR, frames[-1].transform_camera_to_robot_believed
        ).correction.tilt_planes
        == 0
    )
    faces = {}
    for use in (True, False):
        pipeline = _pipeline(use)
        for frame in frames:
            pipeline.process(frame)
        assert pipeline.last_points is not None
        faces[use] = pipeline.last_points.points_world[:, 0]
    assert np.abs(faces[True] - WALL_FACE_X_M).max() < 1e-3
    assert np.abs(faces[False] - WALL_FACE_X_M).max() > 0.02


def test_with_exact_data_the_filter_keeps_the_frames_own_tilt():
    # A depth camera's tilt is nearly exact (σ ≪ the encoders' 0.3°): the filter takes it
    # (gain (P⁻ + σ_w²)/(P⁻ + σ_w² + σ²) ≈ 1), the ground lies level at 0 either way.
    frames = _frames(8, 0)
    for use in (True, False):
        pipeline = _pipeline(use)
        for frame in frames:
            pipeline.process(frame)
        assert pipeline.last_points is not None
        z = pipeline.last_points.points_world[:, 2]
        assert np.abs(z).max() < 1e-4, use
