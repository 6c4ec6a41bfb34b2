"""mapper.floor_borders: a floor's pixels on the near side of an occluding edge leave it."""

from dataclasses import replace

import numpy as np
import pytest
from synthetic_depth import GROUND, Box, render_scene
from test_floor_sides import CAMERA, STEREO
from test_floor_sides import SMALL as INTRINSICS

from mapper.errors import InvalidParameterError
from mapper.floor_borders import BORDER_LABEL, occluding_border
from mapper.scanline.points import floor_points
from mapper.segmentation import OCCLUDING_JUMP_SIGMA, SegmentationParams, segment_depth

NAN = np.nan
LEVELS = np.array([0.12, 0.0, NAN])  # region 0 a raised floor, 1 the ground, 2 no floor


def test_only_floor_pixels_beside_a_farther_pixel_of_another_label_leave():
    # Inverse depth [1/m], jump 0.1, one pixel: a raised floor (region 0, inverse depth 1)
    # before farther ground (region 1 at 0.5) and beside nearer or barely farther ground (0.95,
    # 1.05), a pixel in no region (-1) far behind (0.2), a pixel with no measurement (NaN), and
    # a region that is no floor (2) before the ground.
    labels = np.array(
        [
            [0, 0, 0, 1, 1],
            [1, 0, 0, 0, 1],
            [0, 0, -1, 0, 0],
            [0, 0, 1, 1, 1],
            [2, 2, 1, 1, 1],
        ]
    )
    inv = np.array(
        [
            [1.0, 1.0, 1.0, 0.5, 0.5],
            [0.95, 1.0, 1.0, 1.0, 1.05],
            [1.0, 1.0, 0.2, 1.0, 1.0],
            [1.0, 1.0, NAN, 0.5, 0.5],
            [1.0, 1.0, 0.5, 0.5, 0.5],
        ]
    )
    b = BORDER_LABEL
    # By hand: region 0's pixels with a 4-neighbour of another label more than 0.1 farther
    # (the ground at 0.5, the unlabelled pixel at 0.2); the ground at 0.95 / 1.05 beside region
    # 0 is no edge (nearer / 0.05 farther), the NaN pixel none; region 2 is never a border.
    want = [
        [0, 0, b, 1, 1],
        [1, 0, b, b, 1],
        [0, b, -1, b, b],
        [0, 0, 1, 1, 1],
        [2, 2, 1, 1, 1],
    ]
    out = occluding_border(labels, inv, LEVELS, 1, 0.1)
    assert out.tolist() == want
    assert labels[0, 2] == 0  # the input is left as it was
    # Along the rows only (`SegmentationParams.floor_occluding_border_rows_only`): the pixels
    # whose farther pixel lies above or below them keep their region — (1, 2) over the
    # unlabelled pixel, (1, 3) below the ground at 0.5, (2, 4) above it.
    want_rows = [
        [0, 0, b, 1, 1],
        [1, 0, 0, 0, 1],
        [0, b, -1, b, 0],
        [0, 0, 1, 1, 1],
        [2, 2, 1, 1, 1],
    ]
    assert occluding_border(labels, inv, LEVELS, 1, 0.1, rows_only=True).tolist() == want_rows


def test_the_band_reaches_px_pixels_and_the_jump_is_strict():
    labels = np.array([[0, 0, 0, 0, 1, 1]])
    inv = np.array([[1.0, 1.0, 1.0, 1.0, 0.5, 0.5]])
    b = BORDER_LABEL
    assert occluding_border(labels, inv, LEVELS, 1, 0.1).tolist() == [[0, 0, 0, b, 1, 1]]
    assert occluding_border(labels, inv, LEVELS, 3, 0.1).tolist() == [[0, b, b, b, 1, 1]]
    assert occluding_border(labels, inv, LEVELS, 1, 0.5).tolist() == [[0, 0, 0, 0, 1, 1]]
    assert occluding_border(labels, inv, LEVELS, 1, 0.49).tolist() == [[0, 0, 0, b, 1, 1]]


def test_a_border_pixel_is_neither_floor_nor_made_a_ground_point():
    # One row of two pixels looking down at the ground (z = 0) from 1 m: the first in no
    # region (ground-relabelled), the second a border pixel (stays off the floor).
    rays = np.array([[[0.0, 0.6, -0.8], [0.0, 0.6, -0.8]]])
    depth = np.array([[1.25, 1.25]])  # both meet z = 0
    labels = np.array([[-1, BORDER_LABEL]])
    _, heights, regions = floor_points(
        np.array([0, 1]),
        labels,
        np.array([0.0]),
        0.0,
        rays,
        depth,
        np.full((1, 2), 0.01),
        np.array([0.0, 0.0, 1.0]),
        3.0,
        3.0,
    )
    assert heights[0] == 0.0 and np.isnan(heights[1])
    assert regions.tolist() == [-1, BORDER_LABEL]


BOX = Box((1.4, 0.0), (0.3, 0.3, 0.12))


def test_a_box_top_loses_the_pixels_before_the_ground_it_hides_and_nothing_else():
    # Exact depth of a 120 mm box 1.4 m ahead: its top's pixels whose row or column neighbour
    # is ground (farther: the box hides the ground behind its far and side edges) leave the
    # floor; every other pixel keeps its floor height, bit for bit.
    scene = render_scene(INTRINSICS, CAMERA, [BOX])
    off = segment_depth(scene.depth_m, INTRINSICS, CAMERA, STEREO).labels_image("floor")
    on = segment_depth(
        scene.depth_m, INTRINSICS, CAMERA, replace(STEREO, floor_occluding_border_px=1)
    ).labels_image("floor")
    top = (scene.box_index == 0) & scene.on_top
    ground = scene.box_index == GROUND
    beside_ground = np.zeros_like(top)
    beside_ground[:, :-1] |= ground[:, 1:]
    beside_ground[:, 1:] |= ground[:, :-1]
    beside_ground[:-1, :] |= ground[1:, :]
    beside_ground[1:, :] |= ground[:-1, :]
    inverse = 1.0 / scene.depth_m
    jump = (
        OCCLUDING_JUMP_SIGMA
        * STEREO.disparity_noise_px
        / (INTRINSICS.fx * STEREO.stereo_baseline_m)
    )
    farther = np.zeros_like(top)  # a ground neighbour farther than the pixel
    for shifted, mask in (
        ((slice(None), slice(1, None)), (slice(None), slice(None, -1))),
        ((slice(None), slice(None, -1)), (slice(None), slice(1, None))),
        ((slice(1, None), slice(None)), (slice(None, -1), slice(None))),
        ((slice(None, -1), slice(None)), (slice(1, None), slice(None))),
    ):
        farther[mask] |= ground[shifted] & (inverse[mask] - inverse[shifted] > jump)
    box_floor = (scene.box_index == 0) & (np.abs(off - 0.12) < 0.005)  # its top's region
    assert np.sum(box_floor & top) > 100  # the top is a floor without the rule
    lost = np.isfinite(off) & np.isnan(on)
    assert lost.sum() > 20
    assert np.array_equal(lost, box_floor & farther)  # exactly the occluding border
    assert np.array_equal(on[~lost], off[~lost], equal_nan=True)  # every other pixel the same
    assert not np.any(lost & ~beside_ground)


def test_without_the_stereo_model_the_rule_does_nothing_and_its_window_is_checked():
    scene = render_scene(INTRINSICS, CAMERA, [BOX])
    depth_camera = SegmentationParams(max_depth_m=4.0)
    plain = segment_depth(scene.depth_m, INTRINSICS, CAMERA, depth_camera)
    asked = segment_depth(
        scene.depth_m, INTRINSICS, CAMERA, replace(depth_camera, floor_occluding_border_px=1)
    )
    assert np.array_equal(plain.floor_heights, asked.floor_heights, equal_nan=True)
    assert np.array_equal(plain.floor_ids, asked.floor_ids)
    with pytest.raises(InvalidParameterError, match="floor_occluding_border_px"):
        replace(STEREO, floor_occluding_border_px=-1)


def test_the_structure_border_marks_the_same_pixels_and_changes_nothing_else():
    # `structure_border_px`: the pixels `floor_occluding_border_px` would take out of the floor
    # are marked for the heading estimator instead; points, floor heights and regions are
    # those of the segmentation without either rule, bit for bit.
    scene = render_scene(INTRINSICS, CAMERA, [BOX])
    plain = segment_depth(scene.depth_m, INTRINSICS, CAMERA, STEREO)
    marked = segment_depth(
        scene.depth_m, INTRINSICS, CAMERA, replace(STEREO, structure_border_px=1)
    )
    taken = segment_depth(
        scene.depth_m, INTRINSICS, CAMERA, replace(STEREO, floor_occluding_border_px=1)
    )
    assert plain.structure_border is None
    assert np.array_equal(marked.points, plain.points)
    assert np.array_equal(marked.floor_heights, plain.floor_heights, equal_nan=True)
    assert np.array_equal(marked.floor_ids, plain.floor_ids)
    border = marked.structure_border
    assert border is not None and border.shape == plain.floor_ids.shape
    assert border.sum() > 20
    assert np.array_equal(border, taken.floor_ids == BORDER_LABEL)
    assert np.all(np.isfinite(plain.floor_heights[border]))  # floor points, all of them


def test_the_structure_border_needs_the_stereo_model_and_its_window_is_checked():
    scene = render_scene(INTRINSICS, CAMERA, [BOX])
    depth_camera = SegmentationParams(max_depth_m=4.0, structure_border_px=1)
    assert segment_depth(scene.depth_m, INTRINSICS, CAMERA, depth_camera).structure_border is None
    with pytest.raises(InvalidParameterError, match="structure_border_px"):
        replace(STEREO, structure_border_px=-1)
