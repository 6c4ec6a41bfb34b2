"""The pipeline applies the tilt filtered over frames (`mapper.tilt_filter`, issue 12)."""

import dataclasses
import math

import numpy as np
from synthetic_depth import Box, render_boxes
from test_pipeline import CAMERA_IN_ROBOT, INTR, camera_in_world, make_frames

from fogsim.config import RunParams
from fogsim.config.params import PipelineParams
from fogsim.mapping.pipeline import Pipeline
from mapper.segmentation import segment_depth

# The test_pipeline robot (x = 0.3 m, camera 0.9 m high looking 35° down).
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


def _frames(n_ground, n_wall):
    """Standing robot: ``n_ground`` frames of bare ground, then ``n_wall`` of the wall."""
    world = camera_in_world()
    ground, wall = render_boxes(INTR, world, []), render_boxes(INTR, world, [WALL])
    return [
        dataclasses.replace(
            frame,
            depth_m=(ground if i < n_ground else wall).astype(np.float32),
            transform_camera_to_robot_believed=_believed_camera(),
        )
        for i, frame in enumerate(make_frames(n_ground + n_wall))
    ]


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
