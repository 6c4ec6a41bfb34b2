"""The camera height and tilt the segmentation estimates from noisy ground are unbiased.

A stereo camera's noise is additive in inverse depth (disparity), so depth itself is biased
(``E[d] = d·(1 + (σ_q/q)²)``) and the measured depth is correlated with its own noise estimate
(σ_z ∝ d²). The ground's height must come from an estimator unbiased under that model: seen from
0.84 m, 35° down (moving_box's iCub head) through 0.1 px of disparity noise, the weighted mean
of the points' z read the ground 1.2 mm too high, so the ground shift put the camera 1.2 mm low
(15 standard errors of this test's mean); the inverse-depth fit reads it within its standard
error (−0.18 ± 0.08 mm here).

A sensor also cuts at its range on the *measured* depth: near the limit only the pixels measured
too near are left, so the ground's far side reads near and the tilt leans; the tilt's normals
come from each plane's pixels predicted well inside `SegmentationParams.max_depth_m`.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from synthetic_depth import Box, add_stereo_noise, look_down_camera, render_scene, staircase

from mapper.intrinsics import PinholeIntrinsics
from mapper.segmentation import SegmentationParams, segment_depth

SMALL = PinholeIntrinsics.from_fov(88, 72, 47.0, 39.0)
CAMERA_HEIGHT_M = 0.84
CAMERA = look_down_camera((0.0, 0.0, CAMERA_HEIGHT_M), pitch_down_deg=35.0)
BOX = Box((0.9, 0.0), (0.3, 0.3, 0.06))  # moving_box's flat box, 0.9 m ahead
BASELINE_M = 0.07
DISPARITY_NOISE_PX = 0.1  # twice the depth mode's: the bias grows with its square
PARAMS = SegmentationParams(disparity_noise_px=DISPARITY_NOISE_PX, stereo_baseline_m=BASELINE_M)
FRAMES = 60


def _believed_camera(rng: np.random.Generator) -> np.ndarray:
    """The true pose rotated about the camera centre by a random 1° tilt (encoder error)."""
    axis = np.array([*rng.standard_normal(2), 0.0])
    axis /= np.linalg.norm(axis)
    angle = math.radians(1.0)
    k = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    rotation = np.eye(3) + math.sin(angle) * k + (1.0 - math.cos(angle)) * k @ k
    believed = CAMERA.copy()
    believed[:3, :3] = rotation @ CAMERA[:3, :3]
    return believed


def test_camera_height_and_tilt_from_noisy_ground_are_unbiased():
    """Over 60 seeded frames the corrected camera height and the corrected frame's vertical
    agree with the truth within 3 standard errors of their means (each about 0.08 mm and
    0.005°), and the ground shift really corrected (the believed tilt was 1°)."""
    depth_exact = render_scene(SMALL, CAMERA, [BOX]).depth_m
    height_errors_m, tilt_errors = [], []
    for seed in range(FRAMES):
        rng = np.random.default_rng(seed)
        depth = add_stereo_noise(depth_exact, SMALL.fx * BASELINE_M, DISPARITY_NOISE_PX, 0.0, rng)
        result = segment_depth(depth, SMALL, _believed_camera(rng), PARAMS)
        assert result.correction.ground_plane_found
        corrected = result.transform_camera_to_robot
        height_errors_m.append(corrected[2, 3] - CAMERA_HEIGHT_M)
        # The true vertical in the corrected frame: its x, y components are the tilt error.
        tilt_errors.append((corrected[:3, :3] @ CAMERA[:3, :3].T)[2, :2])
    for errors in (np.array(height_errors_m), np.array(tilt_errors)):
        mean = errors.mean(axis=0)
        standard_error = errors.std(axis=0, ddof=1) / math.sqrt(FRAMES)
        assert np.all(np.abs(mean) <= 3.0 * standard_error), (mean, standard_error)
    assert np.std(height_errors_m) < 1e-3  # the test resolves 0.25 mm
    assert np.degrees(np.abs(np.array(tilt_errors)).max()) < 0.2  # the 1° error was removed


def box_top_frames(box: Box, params: SegmentationParams, frames: int):
    """Per seeded frame of ``box`` seen by `CAMERA` through the stereo noise ``params`` model
    (its ``disparity_noise_px``): the segmentation's result and the floor region holding most of
    the box top's pixels."""
    scene = render_scene(SMALL, CAMERA, [box])
    top = (scene.box_index == 0) & scene.on_top
    for seed in range(frames):
        rng = np.random.default_rng(seed)
        noise_px = params.disparity_noise_px
        depth = add_stereo_noise(scene.depth_m, SMALL.fx * BASELINE_M, noise_px, 0.0, rng)
        result = segment_depth(depth, SMALL, CAMERA, params)
        regions = result.labels_image("floor_region")
        yield result, int(np.bincount(regions[top & (regions >= 0)]).argmax())


def _box_top_minus_ground_m(params: SegmentationParams, frames: int) -> np.ndarray:
    """Height of the box top's level region above the ground's, minus the true 60 mm [m], per
    frame: the box 0.45 m to the side, so its side face is in view beside the top."""
    box = Box((0.9, 0.45), (0.3, 0.3, 0.06))
    differences = []
    for result, box_region in box_top_frames(box, params, frames):
        ground = int(np.argmin(np.abs(result.floors.heights_m)))
        heights = result.floors.heights_m
        differences.append(heights[box_region] - heights[ground] - box.top_z_m)
    return np.array(differences)


def test_box_top_height_is_unbiased_with_its_side_face_in_view():
    """The side-face pixels just below the rim that join the top's region are left out of its
    height (`floor_height_margin_px` 1): over 60 frames the top lies 60 mm above the ground
    within 3 standard errors (−0.18 ± 0.12 mm); with every pixel counted it read 1.2 mm low."""
    differences = _box_top_minus_ground_m(PARAMS, FRAMES)
    standard_error = differences.std(ddof=1) / math.sqrt(FRAMES)
    assert abs(differences.mean()) <= 3.0 * standard_error, (differences.mean(), standard_error)
    assert standard_error < 0.15e-3
    every_pixel = _box_top_minus_ground_m(replace(PARAMS, floor_height_margin_px=0), 20)
    assert every_pixel.mean() < -0.5e-3  # the bias the margin removes, at this noise


RANGE_CAMERA = look_down_camera((0.0, 0.0, 0.85), pitch_down_deg=30.0)  # the stage's head
RANGE_LIMIT_M = 4.0  # fogsim's camera range: the top rows see the ground at up to 4.6 m


def _forward_tilt_errors_rad(camera, boxes, params: SegmentationParams) -> np.ndarray:
    """The corrected camera's forward tilt error [rad] in each of 60 frames (the true
    vertical's x component in the corrected frame), through 0.1 px of disparity noise and cut
    at 4 m like fogsim's camera."""
    depth_exact = render_scene(SMALL, camera, boxes).depth_m
    errors = []
    for seed in range(FRAMES):
        rng = np.random.default_rng(seed)
        depth = add_stereo_noise(depth_exact, SMALL.fx * BASELINE_M, DISPARITY_NOISE_PX, 0.0, rng)
        depth[depth > RANGE_LIMIT_M] = np.nan
        corrected = segment_depth(depth, SMALL, camera, params).transform_camera_to_robot
        errors.append((corrected[:3, :3] @ camera[:3, :3].T)[2, 0])
    return np.array(errors)


def test_tilt_is_unbiased_with_the_ground_cut_at_the_sensor_range():
    """Told the sensor's 4 m range (`max_depth_m`), the tilt over 60 frames is within 3
    standard errors of the truth (+0.01 ± 0.07 mrad); with the default 10 m the same frames
    lean by −0.58 mrad (0.6 mm of height over 1 m): the far pixels the cut left read near.
    Ground only, the normals from every pixel (`plane_normal_margin_px` 0: the interior
    leaves out the top row, half of the cut)."""
    every_pixel = replace(PARAMS, plane_normal_margin_px=0)
    told = _forward_tilt_errors_rad(
        RANGE_CAMERA, [], replace(every_pixel, max_depth_m=RANGE_LIMIT_M)
    )
    standard_error = told.std(ddof=1) / math.sqrt(FRAMES)
    assert abs(told.mean()) <= 3.0 * standard_error, (told.mean(), standard_error)
    assert standard_error < 0.08e-3
    untold = _forward_tilt_errors_rad(RANGE_CAMERA, [], every_pixel)
    assert (untold - told).mean() < -0.4e-3  # the lean the range margin removes


def _stair_tilt_errors_rad(margin_px: int) -> np.ndarray:
    """`_forward_tilt_errors_rad` with the paper's staircase filling the view (from 0.7 m
    before its first riser, 0.85 m up, 40° down)."""
    camera = look_down_camera((0.5, 0.0, 0.85), pitch_down_deg=40.0)
    params = replace(PARAMS, max_depth_m=RANGE_LIMIT_M, plane_normal_margin_px=margin_px)
    return _forward_tilt_errors_rad(camera, staircase(x_start_m=1.2), params)


def test_tilt_from_a_staircase_is_unbiased_with_the_treads_interiors():
    """The treads' normals from their interiors (`plane_normal_margin_px` 1): over 60 frames
    the tilt is within 3 standard errors of the truth (+0.06 ± 0.19 mrad); with every pixel the
    risers' pixels that joined the treads at their edges lean it by −1.2 mrad (the same frames:
    −1.25 ± 0.23)."""
    interior = _stair_tilt_errors_rad(1)
    standard_error = interior.std(ddof=1) / math.sqrt(FRAMES)
    assert abs(interior.mean()) <= 3.0 * standard_error, (interior.mean(), standard_error)
    assert standard_error < 0.25e-3
    every_pixel = _stair_tilt_errors_rad(0)
    assert (every_pixel - interior).mean() < -0.8e-3  # the lean the margin removes
