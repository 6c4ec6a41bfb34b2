"""Tilt correction (mapper.pose_correction) on scenes with known truth."""

import dataclasses
import math

import numpy as np
import pytest
from synthetic_depth import Box, look_down_camera, render_boxes

from mapper.intrinsics import PinholeIntrinsics
from mapper.pose_correction import estimate_tilt
from mapper.segmentation import SegmentationParams, segment_depth

INTR = PinholeIntrinsics.from_fov(88, 72, 47.0, 39.0)
CAMERA_TRUE = look_down_camera((0.0, 0.0, 0.9), pitch_down_deg=35.0)


def believed_with_pitch_error(error_deg):
    """The true camera pose with the neck's pitch reading off by ``error_deg``."""
    return look_down_camera((0.0, 0.0, 0.9), pitch_down_deg=35.0 + error_deg)


@pytest.mark.parametrize("error_deg", [15.0, -15.0])
def test_a_15_degree_tilt_error_is_corrected_with_a_20_degree_limit(error_deg):
    depth = render_boxes(INTR, CAMERA_TRUE, [Box((1.6, 0.0), (0.3, 0.6, 0.06))])
    believed = believed_with_pitch_error(error_deg)
    params = dataclasses.replace(SegmentationParams(), max_tilt_correction_deg=20.0)
    result = segment_depth(depth, INTR, believed, params)
    assert result.correction.rotation_deg == pytest.approx(15.0, abs=0.05)
    corrected = result.transform_camera_to_robot
    np.testing.assert_allclose(corrected[:3, :3], CAMERA_TRUE[:3, :3], atol=1e-3)
    floor = result.planes.heights_m[result.planes.is_floor]
    np.testing.assert_allclose(np.sort(floor), [0.0, 0.06], atol=0.001)
    # The former 12° limit leaves the frame uncorrected: no plane steers it.
    old = dataclasses.replace(SegmentationParams(), max_tilt_correction_deg=12.0)
    assert segment_depth(depth, INTR, believed, old).correction.tilt_planes == 0


def _tilted(deg, azimuth_deg=0.0):
    t, a = math.radians(deg), math.radians(azimuth_deg)
    return [math.sin(t) * math.cos(a), math.sin(t) * math.sin(a), math.cos(t)]


def test_agreeing_horizontal_planes_outvote_one_larger_ramp():
    # A neck error tilts the ground and a tread by 5°; a larger ramp rises at 14° (19° seen).
    normals = np.array([_tilted(19.0), _tilted(5.0), _tilted(5.0)])
    areas = np.array([1.0, 0.6, 0.6])
    eigen = np.full((3, 3), 0.01)  # 0.35 m wide footprints
    counts = np.full(3, 500)
    params = dataclasses.replace(SegmentationParams(), max_tilt_correction_deg=20.0)
    correction = estimate_tilt(normals, areas, eigen, counts, np.zeros(3), params)
    assert correction.tilt_planes == 2
    assert correction.rotation_deg == pytest.approx(5.0, abs=1e-9)
