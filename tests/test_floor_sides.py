"""A floor region's side bands at another floor's level move to that floor (`mapper.floor_sides`).

Stereo replays of the stage (seeds 1 and 4, `bench/spill_trace.py`): the rows of step_1 ran on
over its side edge onto the ground beside it (the row split's step test cannot see 31 mm at
1.3 m through the matcher's noise), the step's region took those ground pixels and the snap put
them on the step's height, in the ground's cells.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from synthetic_depth import GROUND, Box, add_stereo_noise, look_down_camera, render_scene

from mapper.floor_sides import peel_side_strips
from mapper.intrinsics import PinholeIntrinsics
from mapper.segmentation import SegmentationParams, segment_depth

SIGMA_Z = 0.015  # the segmentation's noise along z of a stereo pixel at 1.3 m [m]
NOISE_Z = SIGMA_Z * 0.074 / 0.109  # the matcher's robust std under the model's 99 % tail
CORRELATION = 3.0
SIGMA_FACTOR = 3.0
TOL = 0.005
MAX_RMS_RATIO = 1.05
SMALL = PinholeIntrinsics.from_fov(88, 72, 47.0, 39.0)
CAMERA = look_down_camera((0.0, 0.0, 0.93), pitch_down_deg=30.0)
STEP = Box((1.35, 0.35), (0.2, 1.0, 0.031))
STEREO = SegmentationParams(
    disparity_noise_px=0.109,
    stereo_baseline_m=0.07,
    noise_correlation_factor=3.0,
    floor_edge_margin_px=1,
    max_depth_m=4.0,
)
"""The stereo head's segmentation noise model (`fogsim.sim.camera.noise_model`)."""


def _scene(rows=20, ground_cols=10, spill_cols=4, tread_cols=50, band_z=0.0):
    """A ground region (label 0, level 0) left of a tread (label 1, true top 31 mm) whose
    region took ``spill_cols`` pixels of each row beside its left edge at ``band_z``."""
    width = ground_cols + tread_cols
    labels = np.zeros((rows, width), dtype=np.int64)
    labels[:, ground_cols:] = 1
    z = np.zeros((rows, width))
    z[:, ground_cols:] = 0.031
    z[:, ground_cols : ground_cols + spill_cols] = band_z
    # The region's level is the mean of its pixels (the spill pulls it down).
    level = np.array([0.0, z[:, ground_cols:].mean()])
    return labels, z, np.full(z.shape, SIGMA_Z), level


def _peel(labels, z, sigma_z, level, max_px=16):
    return peel_side_strips(
        labels, z, sigma_z, level, max_px, SIGMA_FACTOR, CORRELATION, TOL, MAX_RMS_RATIO
    )


def test_spilled_ground_band_goes_to_the_ground():
    """Exact heights: the 4 spilled columns score highest (the score rises while a strip of
    ground is added and falls with the first strip of the tread), move to the ground region,
    and the tread's level is its own 31 mm again; its right side (all tread) stays."""
    labels, z, sigma_z, level = _scene()
    out, depth, new_level = _peel(labels, z, sigma_z, level)
    np.testing.assert_array_equal(depth[1], [4, 0])
    np.testing.assert_array_equal(depth[0], [0, 0])
    expected = labels.copy()
    expected[:, 10:14] = 0
    np.testing.assert_array_equal(out, expected)
    assert abs(new_level[1] - 0.031) < 1e-12
    assert new_level[0] == 0.0


def test_noisy_spill_is_found_within_a_column():
    """With seeded noise of the stereo head's size at 1.3 m (the model's σ_z 15 mm, the
    matcher's robust std 0.074 of its 0.109 px: 10 mm) over 20 rows the band found is 4 ± 1
    columns wide on every seed, and always goes to the ground."""
    for seed in range(8):
        labels, z, sigma_z, _ = _scene()
        z = z + np.random.default_rng(seed).normal(0.0, NOISE_Z, z.shape)
        level = np.array([z[:, :10].mean(), z[:, 10:].mean()])
        out, depth, _ = _peel(labels, z, sigma_z, level)
        assert 3 <= depth[1, 0] <= 5, (seed, depth)
        assert (out[:, 10 : 10 + depth[1, 0]] == 0).all()


def test_flat_region_keeps_its_sides():
    """One level throughout, seeded noise: no band scores above 3 standard errors plus the
    tolerance on any of 8 seeds."""
    for seed in range(8):
        labels = np.zeros((20, 60), dtype=np.int64)
        labels[:, 30:] = 1
        z = np.random.default_rng(seed).normal(0.0, NOISE_Z, labels.shape)
        level = np.array([z[:, :30].mean(), z[:, 30:].mean()])
        out, depth, new_level = _peel(labels, z, np.full(z.shape, SIGMA_Z), level)
        np.testing.assert_array_equal(out, labels)
        assert not depth.any()
        np.testing.assert_array_equal(new_level, level)


def test_band_between_levels_stays():
    """A band at 15 mm (a matcher's edge blended between the two surfaces) fits neither the
    ground it touches nor the tread: it stays in the tread's region."""
    labels, z, sigma_z, level = _scene(band_z=0.015)
    out, depth, new_level = _peel(labels, z, sigma_z, level)
    np.testing.assert_array_equal(out, labels)
    assert not depth.any()
    np.testing.assert_array_equal(new_level, level)


def test_side_face_band_stays():
    """A 100 mm top's region took a band whose rows lie at 0-80 mm (a side face, a row each
    height): its mean, 40 mm, is the level of the floor it touches (label 0 at 40 mm), but it
    is no level surface there: its RMS about that level is 25 mm against 15 mm of noise
    (ratio 1.6 > 1.05), so it stays. Without the smoothness test it would move."""
    labels, z, sigma_z, _ = _scene()
    z[:, 10:] = 0.1
    z[:, 10:14] = np.linspace(0.0, 0.08, 20)[:, None]
    z[:, :10] = 0.04
    level = np.array([0.04, z[:, 10:].mean()])
    out, depth, _ = _peel(labels, z, sigma_z, level)
    np.testing.assert_array_equal(out, labels)
    assert not depth.any()
    _, depth, _ = peel_side_strips(
        labels, z, sigma_z, level, 16, SIGMA_FACTOR, CORRELATION, TOL, 0.0
    )
    assert depth[1, 0] == 4


def test_band_goes_only_to_a_floor_it_touches():
    """The same spill, but the ground beside it is no floor (level NaN) while another floor at
    the band's level lies elsewhere in the image (label 2, not touching): the band stays."""
    labels, z, sigma_z, level = _scene()
    labels = np.concatenate([labels, np.full((20, 5), 2)], axis=1)
    labels[:, 60] = -1  # a column of no region between the tread and region 2
    z = np.concatenate([z, np.zeros((20, 5))], axis=1)
    sigma_z = np.full(z.shape, SIGMA_Z)
    level = np.array([np.nan, level[1], 0.0])
    out, depth, _ = _peel(labels, z, sigma_z, level)
    np.testing.assert_array_equal(out, labels)
    assert not depth.any()


def test_band_never_takes_a_runs_middle():
    """A run of 5 pixels, all at the ground's height beside a tread level of 31 mm: at most 2
    pixels a side move (a band leaves the run's middle pixel), and nothing with max_px 0."""
    labels = np.zeros((30, 8), dtype=np.int64)
    labels[:, 3:] = 1
    z = np.zeros(labels.shape)
    level = np.array([0.0, 0.031])
    out, depth, _ = _peel(labels, z, np.full(z.shape, SIGMA_Z), level)
    assert depth[1, 0] <= 2
    assert (out[:, 5] == 1).all()
    out0, depth0, level0 = _peel(labels, z, np.full(z.shape, SIGMA_Z), level, max_px=0)
    np.testing.assert_array_equal(out0, labels)
    assert not depth0.any()
    np.testing.assert_array_equal(level0, level)


def _side_edge_counts(strip_px: int) -> tuple[int, int]:
    """Over 20 seeded stereo frames of a 31 mm step (0.2 m deep, 1 m wide, its side edge at
    y = −0.15 m in view, 1.25-1.45 m ahead of a camera 0.93 m up, pitched 30° down): the ground
    pixels beside the side edge (y < −0.15, over the step's x) labelled with a floor above
    15 mm, and the step's top pixels labelled so."""
    scene = render_scene(SMALL, CAMERA, [STEP])
    points = scene.points_world
    beside = (
        (scene.box_index == GROUND)
        & (points[..., 1] < -0.15)
        & (np.abs(points[..., 0] - STEP.center_xy_m[0]) < 0.1)
    )
    top = (scene.box_index == 0) & scene.on_top
    params = replace(STEREO, floor_side_strip_px=strip_px)
    spilled = kept = 0
    for seed in range(20):
        rng = np.random.default_rng(seed)
        depth = add_stereo_noise(scene.depth_m, SMALL.fx * 0.07, 0.074, 0.6, rng)
        floor = segment_depth(depth, SMALL, CAMERA, params).labels_image("floor")
        spilled += int(np.sum(beside & (floor > 0.015)))
        kept += int(np.sum(top & (floor > 0.015)))
    return spilled, kept


def test_segmentation_moves_the_ground_beside_a_side_edge_off_the_step():
    """The stereo head's segmentation (its noise model) of synthetic stereo frames: with the
    side bands tested (32 px) the ground pixels beside the step's side edge that carry the
    step's height drop from 1411 to 113 over the 20 frames, and the step keeps 96 % of its
    own (3355 → 3231)."""
    spilled_off, kept_off = _side_edge_counts(0)
    spilled_on, kept_on = _side_edge_counts(32)
    assert spilled_off > 1000  # the spill is there without the test
    assert spilled_on <= 0.1 * spilled_off, (spilled_on, spilled_off)
    assert kept_on >= 0.95 * kept_off, (kept_on, kept_off)
