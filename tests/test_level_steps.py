"""A level region that is two levels joined over a hidden step is split (`mapper.scanline.steps`).

Stereo replays of `down_landing_turn` (seed 1, frames 604–692): the ground's level region took
in step_1 (20 mm high, 0.9–1.2 m away) beside its side edge, whose rows ran on over it; the
frames' largest plane held 450–600 of its pixels.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from synthetic_depth import GROUND, Box, add_stereo_noise, look_down_camera, render_scene
from test_floor_sides import SMALL
from test_floor_sides import STEREO as SIDE_STEREO

from mapper.errors import InvalidParameterError
from mapper.scanline.steps import (
    MIN_STEP_M,
    SPLIT_BINS,
    SPLIT_DIRECTIONS,
    best_step,
    cut_segments,
    split_stepped_levels,
)
from mapper.segmentation import SegmentationParams, segment_depth

SPLIT_T = 8.0  # where `SegmentationParams.floor_step_split_t` was measured (no default)
SIGMA_M = 0.005


def _grid(rows=30, cols=60, cell_m=0.02):
    """Pixel points on a horizontal grid: x along the rows, y along the columns [m]."""
    x, y = np.meshgrid(np.arange(rows) * cell_m, np.arange(cols) * cell_m, indexing="ij")
    return x, y


def _points(z):
    x, y = _grid(*z.shape)
    return np.ascontiguousarray(np.stack([x, y, z], axis=-1))


def _side_edge(step_m, tilt_deg=0.0, seed=0):
    """A 30 × 60 pixel level region whose columns 45 on lie ``step_m`` higher (a side edge
    along the rows: a quarter of the pixels, between two of `SPLIT_BINS`), tilted by ``tilt_deg``
    about x, with white noise of `SIGMA_M`."""
    _, y = _grid()
    z = y * math.tan(math.radians(tilt_deg))
    z[:, 45:] += step_m
    z += np.random.default_rng(seed).normal(0.0, SIGMA_M, z.shape)
    return _points(z)


def _best(points):
    return best_step(
        points[..., 0].ravel(),
        points[..., 1].ravel(),
        points[..., 2].ravel(),
        SPLIT_BINS,
        SPLIT_DIRECTIONS,
        1.0,
        MIN_STEP_M,
        20,
    )


def test_a_step_scores_and_a_tilt_does_not():
    """20 mm across the columns under 5 mm of white noise, its edge between two bins: t far
    above 8, the step's height to 1 mm; the same region without the step but
    tilted by 1.5° (26 mm over its width, more than the step) scores nothing: a tilt is the
    plane's, not a step."""
    t, (delta, _, _, slope_y) = _best(_side_edge(0.02))
    assert t > 5 * SPLIT_T
    assert delta == pytest.approx(0.02, abs=0.001)
    assert abs(slope_y) < 0.002
    t_tilt, _ = _best(_side_edge(0.0, tilt_deg=1.5))
    assert t_tilt < SPLIT_T
    t_low, _ = _best(_side_edge(0.006))  # below MIN_STEP_M: never a split, whatever t
    assert t_low == 0.0


def _split(points, min_t=SPLIT_T):
    rows, cols = points.shape[:2]
    labels = np.zeros((rows, cols), dtype=np.int64)
    grown = labels.copy()
    total = split_stepped_levels(
        labels,
        grown,
        points,
        np.full((rows, cols), SIGMA_M),
        1,
        SPLIT_BINS,
        SPLIT_DIRECTIONS,
        min_t,
        MIN_STEP_M,
        20,
        1.0,
        1.0,
    )
    return total, labels, grown


def test_the_smaller_level_of_a_stepped_region_takes_a_new_id():
    """The 15 columns of the higher level (a quarter of the region) become region 1, each pixel
    by its 5 × 5 window's mean: every pixel two columns or more from the edge on its side, the
    grown labels alike; the tilted region without a step stays one region."""
    total, labels, grown = _split(_side_edge(0.02))
    assert total == 2
    assert (labels[:, 47:] == 1).all()
    assert (labels[:, :43] == 0).all()
    np.testing.assert_array_equal(grown, labels)
    total, labels, _ = _split(_side_edge(0.0, tilt_deg=1.5))
    assert total == 1
    assert (labels == 0).all()


def test_the_larger_level_stays_when_the_step_side_is_lower():
    """The step down instead of up: the smaller level (columns 45 on, 20 mm lower) moves."""
    total, labels, _ = _split(_side_edge(-0.02))
    assert total == 2
    assert (labels[:, 47:] == 1).all()
    assert (labels[:, :43] == 0).all()


def test_cut_segments_cuts_where_the_region_changes():
    """Hand-made: a segment over pixels 0 0 0 1 1 is cut into (0, 3) of 0 and (3, 5) of 1; one
    whose pixels all moved takes the new id; one of no region and one untouched stay."""
    grown = np.array([[0, 0, 0, 1, 1, -1, 0, 0], [1, 1, 1, 1, -1, -1, 0, 0]], dtype=np.int64)
    rows = np.array([0, 0, 1, 1, 1], dtype=np.int64)
    starts = np.array([0, 6, 0, 4, 6], dtype=np.int64)
    stops = np.array([5, 8, 4, 6, 8], dtype=np.int64)
    floors = np.array([0, 0, 0, -1, 0], dtype=np.int64)
    out = cut_segments(grown, rows, starts, stops, floors)
    expected = (
        [0, 0, 0, 1, 1, 1],
        [0, 3, 6, 0, 4, 6],
        [3, 5, 8, 4, 6, 8],
        [0, 1, 0, 1, -1, 0],
    )
    for got, want in zip(out, expected, strict=True):
        np.testing.assert_array_equal(got, want)


CAMERA = look_down_camera((0.0, 0.0, 0.93), pitch_down_deg=40.0)
STEREO = replace(SIDE_STEREO, floor_side_strip_px=32, tilt_max_step_t=12.0)
"""The stereo head's segmentation noise model and its stereo rules (`fogsim.sim.camera`)."""


def _tread_counts(split_t: float) -> tuple[int, int]:
    """Over 10 seeded stereo frames of a 20 mm tread, 0.8 m deep and 1 m wide, 0.6-1.4 m ahead
    of a camera 0.93 m up pitched 40° down, its side edge along the view at y = −0.1 m: the
    tread's top pixels labelled with a floor within 6 mm of its height, the ground's within 6 mm
    of 0."""
    scene = render_scene(SMALL, CAMERA, [Box((1.0, -0.6), (0.8, 1.0, 0.02))])
    top = (scene.box_index == 0) & scene.on_top
    ground = scene.box_index == GROUND
    params = replace(STEREO, floor_step_split_t=split_t)
    on_top = on_ground = 0
    for seed in range(10):
        rng = np.random.default_rng(seed)
        depth = add_stereo_noise(scene.depth_m, SMALL.fx * 0.07, 0.074, 0.6, rng)
        floor = segment_depth(depth, SMALL, CAMERA, params).labels_image("floor")
        on_top += int(np.sum(top & (np.abs(floor - 0.02) < 0.006)))
        on_ground += int(np.sum(ground & (np.abs(floor) < 0.006)))
    return on_top, on_ground


def test_segmentation_gives_a_low_tread_beside_the_ground_its_own_level():
    """Without the split the tread's rows run on into the ground's region and none of its
    15 160 top pixels is at its height; with it 3058 are (the nearer ones: farther, the pixels'
    noise exceeds the step, `NOISE_PER_STEP`), and the ground keeps its right pixels (47 768 →
    47 758)."""
    top_off, ground_off = _tread_counts(0.0)
    top_on, ground_on = _tread_counts(SPLIT_T)
    assert top_off == 0
    assert top_on > 2500, top_on
    assert ground_on >= 0.99 * ground_off, (ground_on, ground_off)


def test_a_negative_split_threshold_is_refused_by_name():
    with pytest.raises(InvalidParameterError, match="floor_step_split_t"):
        SegmentationParams(floor_step_split_t=-1.0)
