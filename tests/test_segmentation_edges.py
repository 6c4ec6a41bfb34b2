"""Floor regions' borders under a stereo matcher's window (edge and height margins).

A block matcher's window blends the disparities of the pixels next to an edge with the other
surface's: on the stage (stereo mode) the sill top's far row reads 10-25 mm low while its inner
rows are within 4 mm. The floor statistics therefore take a region's height from its interior.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from synthetic_depth import Box, add_stereo_noise, look_down_camera, render_scene

from mapper import scanline
from mapper.intrinsics import PinholeIntrinsics
from mapper.segmentation import SegmentationParams, segment_depth

SMALL = PinholeIntrinsics.from_fov(88, 72, 47.0, 39.0)
STEREO_BASELINE_M = 0.068  # fogsim's iCub head
STEREO = SegmentationParams(
    disparity_noise_px=0.125,
    stereo_baseline_m=STEREO_BASELINE_M,
    noise_correlation_factor=3.0,
    floor_edge_margin_px=1,
)
"""The stereo head's sensor fields (`fogsim.sim.camera.noise_model`)."""
SILL = Box((1.0, 0.0), (0.1, 1.5, 0.038))
"""The stage's 38 mm sill, 0.1 m deep: 4-6 rows of the 88 × 72 image at 1-1.3 m."""


def test_region_interior_leaves_out_the_border_and_the_image_edge():
    labels = np.full((6, 7), -1, dtype=np.int64)
    labels[1:5, 1:6] = 0  # a 4 × 5 region
    labels[0, :] = 1  # a region along the image's top edge
    interior = scanline.region_interior(labels, 1)
    expected = np.zeros((6, 7), dtype=bool)
    expected[2:4, 2:5] = True  # the 4 × 5 region less its border: 2 × 3
    np.testing.assert_array_equal(interior, expected)
    np.testing.assert_array_equal(scanline.region_interior(labels, 0), labels >= 0)
    assert not scanline.region_interior(labels, 2).any()  # 2 px in from every side: none


def test_region_depth_counts_the_pixels_to_the_border():
    labels = np.full((9, 9), -1, dtype=np.int64)
    labels[1:8, 1:8] = 0  # a 7 × 7 region: border ring 0, then 1, 2, the centre 3
    labels[0, :] = 1  # a region along the image's top edge: all border
    depth = scanline.region_depth(labels, 5)
    ring = np.minimum.reduce(np.indices((7, 7)).tolist() + (6 - np.indices((7, 7))).tolist())
    np.testing.assert_array_equal(depth[1:8, 1:8], ring)
    assert ring[3, 3] == 3
    np.testing.assert_array_equal(depth[0], 0)
    np.testing.assert_array_equal(depth[labels < 0], -1)
    for margin in (0, 1, 2, 4):  # capped at the margin; `region_interior` is its top level
        capped = scanline.region_depth(labels, margin)
        np.testing.assert_array_equal(capped, np.minimum(depth, margin))
        np.testing.assert_array_equal(capped >= margin, scanline.region_interior(labels, margin))


def _matcher_window(depth_m, focal_baseline_px_m):
    """Disparity averaged over 3 rows (weights 1/4, 1/2, 1/4): a matcher's window at an edge."""
    disparity = focal_baseline_px_m / depth_m
    blended = disparity.copy()
    blended[1:-1] = 0.25 * disparity[:-2] + 0.5 * disparity[1:-1] + 0.25 * disparity[2:]
    return focal_baseline_px_m / blended


def _sill_errors_mm(params, box=SILL, pitches_deg=(35.0, 45.0), xs_m=(0.0, 0.1, 0.2, 0.3)):
    """Median floor label minus the top's height [mm] per frame: the views from 0.9 m high
    (each pitch down at each x) × 3 noise draws of 0.1 px."""
    focal_baseline = SMALL.fx * STEREO_BASELINE_M
    errors = []
    for pitch_deg in pitches_deg:
        for x_m in xs_m:
            camera = look_down_camera((x_m, 0.0, 0.9), pitch_down_deg=pitch_deg)
            scene = render_scene(SMALL, camera, [box])
            on_sill = (scene.box_index == 0) & scene.on_top
            for seed in range(3):
                depth = add_stereo_noise(
                    _matcher_window(scene.depth_m, focal_baseline),
                    focal_baseline,
                    0.1,
                    0.6,
                    np.random.default_rng(seed),
                )
                labels = segment_depth(depth, SMALL, camera, params).labels_image("floor")
                labelled = labels[on_sill][np.isfinite(labels[on_sill])]
                if labelled.size:
                    errors.append(1000.0 * (np.median(labelled) - box.top_z_m))
    return np.asarray(errors)


def test_a_sill_blended_at_its_edges_is_labelled_at_its_height_from_its_inner_rows():
    """With the margins the sill's labels are right in the median over the frames (within
    1.5 mm; measured -0.7 mm); without them its border rows pull them 3 mm or more low
    (measured -3.9 mm; with the tilt's normals still from the planes' interiors -2.5 mm)."""
    with_margin = _sill_errors_mm(STEREO)
    without = _sill_errors_mm(
        dataclasses.replace(
            STEREO, floor_edge_margin_px=0, floor_height_margin_px=0, plane_normal_margin_px=0
        )
    )
    assert with_margin.size >= 18 and without.size >= 18  # the sill is labelled in most frames
    assert abs(np.median(with_margin)) <= 1.5, np.median(with_margin)
    assert np.median(without) <= -3.0, np.median(without)


def _tread_heights(margins):
    """A level region 5 rows × 22 columns seen straight down from 1 m above a 40 mm tread: its
    border ring reads 10 mm low, the next ring 4 mm low (a matcher's window at the edges), the
    middle row exact. The region's height [m] for each margin (`scanline.floor_statistics`)."""
    height_m, origin_z = 0.04, 1.0
    labels = np.full((7, 24), -1, dtype=np.int64)
    labels[1:6, 1:23] = 0
    ring = scanline.region_depth(labels, 5)
    z = np.where(ring == 0, height_m - 0.010, np.where(ring == 1, height_m - 0.004, height_m))
    rows, cols = np.indices(labels.shape)
    rays = np.stack([(cols - 11.5) / 100.0, (rows - 3.0) / 100.0, -np.ones(labels.shape)], -1)
    depth = np.where(labels >= 0, origin_z - z, np.nan)
    points = rays * depth[..., None]
    points[..., 2] += origin_z
    interior = scanline.region_interior(labels, 1)
    heights = []
    for margin in margins:
        _, h, *_ = scanline.floor_statistics(
            labels,
            labels,
            interior,
            scanline.region_depth(labels, margin),
            margin,
            points,
            np.full(labels.shape, 0.002),
            depth,
            rays,
            origin_z,
            100.0,
            100.0,
            1,
            0.0,
            0.0,
            0.0,
        )
        heights.append(h[0])
    return np.asarray(heights)


def test_a_narrow_region_takes_its_height_from_its_deepest_pixels():
    """Margin 2 takes the middle row alone (exact); margin 3 finds no pixel 3 deep and takes
    the deepest there are (exact; before session 35 it took every pixel, 6.1 mm low); margin 1
    the inner 3 rows (2.8 mm low), margin 0 every pixel (6.1 mm low)."""
    m0, m1, m2, m3 = _tread_heights((0, 1, 2, 3))
    assert abs(m2 - 0.04) < 1e-9 and abs(m3 - 0.04) < 1e-9, (m2, m3)
    assert -0.004 < m1 - 0.04 < -0.002, m1
    assert m0 - 0.04 < -0.005, m0


VIEWS_DEG_M = ((25.0, 30.0, 35.0), tuple(np.linspace(-0.3, 0.3, 7)))
"""Pitches down [deg] and camera x [m] of the views of a tread: 21 views from 0.9 m high."""


def test_a_height_margin_of_2_labels_narrow_treads_at_their_height_in_stereo():
    """A 31 mm tread 0.2 m deep 1.3-1.9 m ahead and one 0.1 m deep (a sill) 1.1-1.7 m ahead,
    blended at their edges by the matcher's window (3 noise draws a view): with a height
    margin of 2 (`SegmentationParams.floor_height_margin_px`) the median of the frames' median
    labels is within 0.5 mm (measured -0.14 and -0.30 mm); with the default margin 1 the second
    rows from the edges pull them 1.2 mm or more low (measured -1.73 and -1.33 mm)."""
    head = dataclasses.replace(STEREO, floor_height_margin_px=2)
    for box in (Box((1.4, 0.0), (0.2, 1.5, 0.031)), Box((1.2, 0.0), (0.1, 1.5, 0.031))):
        with_head_margin = _sill_errors_mm(head, box, *VIEWS_DEG_M)
        with_one = _sill_errors_mm(STEREO, box, *VIEWS_DEG_M)
        assert with_head_margin.size >= 30 and with_one.size >= 30, box
        assert abs(np.median(with_head_margin)) <= 0.5, (box, np.median(with_head_margin))
        assert np.median(with_one) <= -1.2, (box, np.median(with_one))
