"""Tilt correction (mapper.pose_correction) on scenes with known truth."""

import dataclasses
import math

import numpy as np
import pytest
from synthetic_depth import Box, look_down_camera, render_boxes

from mapper import tilt_kernels
from mapper.intrinsics import PinholeIntrinsics
from mapper.pose_correction import estimate_tilt, stepped_planes
from mapper.reference import neck_prior_m
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


NECK_IN_CAMERA = np.array([0.0, 0.10, -0.09])
"""iCub's neck in its camera's optical frame [m]: 10 cm below the eyes, 9 cm behind them."""


def _turned_about(transform, pivot, pitch_deg):
    """``transform`` with the head turned by ``pitch_deg`` about world y through ``pivot``."""
    a = math.radians(pitch_deg)
    turn = np.eye(4)
    turn[:3, :3] = [
        [math.cos(a), 0.0, math.sin(a)],
        [0.0, 1.0, 0.0],
        [-math.sin(a), 0.0, math.cos(a)],
    ]
    turn[:3, 3] = pivot - turn[:3, :3] @ pivot
    return turn @ transform


@pytest.mark.parametrize("error_deg", [7.0, -7.0])
def test_a_neck_error_s_height_error_is_what_the_neck_prior_predicts(error_deg):
    # A neck encoder's error turns the head, camera and all, about the neck. The tilt
    # correction turns the data back about the camera centre (the paper's rotation): they keep
    # the camera's height error, which `neck_prior_m` predicts from the correction alone.
    depth = render_boxes(INTR, CAMERA_TRUE, [Box((1.6, 0.0), (0.3, 0.6, 0.06))])
    neck = CAMERA_TRUE[:3, :3] @ NECK_IN_CAMERA + CAMERA_TRUE[:3, 3]
    believed = _turned_about(CAMERA_TRUE, neck, error_deg)
    height_error = believed[2, 3] - CAMERA_TRUE[2, 3]
    # by hand: looking 35° down, the camera lies 0.09·cos 35° + 0.10·sin 35° = 13.1 cm ahead of
    # the neck, so 7° (0.122 rad) about the neck lift or lower it by 16.0 mm
    assert abs(height_error) == pytest.approx(0.0160, abs=0.0003)
    params = dataclasses.replace(SegmentationParams(), correct_ground_shift=False)
    result = segment_depth(depth, INTR, believed, params)
    assert result.correction.rotation_deg == pytest.approx(abs(error_deg), abs=0.05)
    floor = np.sort(result.planes.heights_m[result.planes.is_floor])
    np.testing.assert_allclose(floor, np.array([0.0, 0.06]) + height_error, atol=0.001)
    correction, transform = result.correction.rotation, result.transform_camera_to_robot
    # the shift a frame measures is minus the ground's height
    assert neck_prior_m(correction, transform, NECK_IN_CAMERA) == pytest.approx(
        -height_error, abs=0.0005
    )
    assert neck_prior_m(correction, transform, np.zeros(3)) == 0.0  # neck at the camera
    assert neck_prior_m(np.eye(3), transform, NECK_IN_CAMERA) == 0.0  # no tilt error


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


def _patch(rng, n, height_of, noise_m):
    """``n`` points on a 0.6 × 1.0 m patch, z = height_of(x, y) + Gaussian noise [m]."""
    x = rng.uniform(1.0, 1.6, n)
    y = rng.uniform(-0.5, 0.5, n)
    return np.column_stack([x, y, height_of(x, y) + rng.normal(0.0, noise_m, n)])


def _stepped(patches, max_step_t=12.0):
    points = np.concatenate(patches)
    ids = np.concatenate([np.full(len(p), i) for i, p in enumerate(patches)])
    normals = []
    for p in patches:
        design = np.column_stack([np.ones(len(p)), p[:, 0], p[:, 1]])
        a = np.linalg.lstsq(design, p[:, 2], rcond=None)[0]
        normal = np.array([-a[1], -a[2], 1.0])
        normals.append(normal / np.linalg.norm(normal))
    counts = np.array([len(p) for p in patches])
    return stepped_planes(
        points,
        ids,
        np.array(normals),
        counts,
        20,
        math.cos(math.radians(20.0)),
        max_step_t,
        3.0,
        math.radians(1.5),
    )


def test_a_plane_over_a_hidden_step_is_stepped_a_tilted_or_level_one_is_not():
    # Stereo-like noise at 1.3 m (20 mm): a tread 60 mm above the ground beside its side edge
    # (y = 0), one plane over both; the ground seen 3.5° tilted (an encoder error); level ground.
    rng = np.random.default_rng(11)
    noise = 0.02
    step = _patch(rng, 1300, lambda x, y: np.where(y < 0.0, 0.06, 0.0), noise)
    tilted = _patch(rng, 1300, lambda x, y: y * math.tan(math.radians(3.5)), noise)
    level = _patch(rng, 1300, lambda x, y: np.zeros_like(x), noise)
    np.testing.assert_array_equal(_stepped([step, tilted, level]), [True, False, False])
    # Off: nothing is stepped.
    assert not _stepped([step, tilted, level], max_step_t=0.0).any()


def test_level_and_tilted_planes_are_never_stepped_over_many_draws():
    # The test's false alarms: 50 draws each of a level and a 3.5°-tilted patch, 600 points.
    rng = np.random.default_rng(5)
    for _ in range(50):
        level = _patch(rng, 600, lambda x, y: np.zeros_like(x), 0.02)
        tilted = _patch(rng, 600, lambda x, y: x * math.tan(math.radians(3.5)), 0.02)
        assert not _stepped([level, tilted]).any()


def test_the_step_test_keeps_a_true_15_degree_tilt_error_corrected():
    # Real tilted planes (the neck's error) have no step: the correction is the same with it on.
    depth = render_boxes(INTR, CAMERA_TRUE, [Box((1.6, 0.0), (0.3, 0.6, 0.06))])
    believed = believed_with_pitch_error(15.0)
    params = dataclasses.replace(SegmentationParams(), tilt_max_step_t=12.0)
    result = segment_depth(depth, INTR, believed, params)
    assert result.correction.rotation_deg == pytest.approx(15.0, abs=0.05)


def _stepped_by_lstsq(points, max_step_t, correlation, min_turn_rad):
    """One plane's step test written out: every split's 4-column least squares, numpy."""
    centred = points - points.mean(axis=0)
    n = len(points)
    design = np.column_stack([np.ones(n), centred[:, 0], centred[:, 1]])
    z = centred[:, 2]
    coef = np.linalg.lstsq(design, z, rcond=None)[0]
    slope = math.hypot(coef[1], coef[2])
    s = (centred[:, 0] * coef[1] + centred[:, 1] * coef[2]) / slope
    splits = np.quantile(s, np.linspace(0.1, 0.9, 17))
    rise = slope * (splits[-1] - splits[0])
    for split in splits:
        upper = (s > split).astype(np.float64)
        if not 0 < upper.sum() < n:
            continue
        full = np.column_stack([design, upper])
        fit, *_ = np.linalg.lstsq(full, z, rcond=None)
        residual = float(np.sum((z - full @ fit) ** 2))
        inverse = np.linalg.inv(full.T @ full)
        t = abs(fit[3]) / math.sqrt(residual / (n - 4) * correlation * inverse[3, 3])
        turn = math.hypot(fit[1] - coef[1], fit[2] - coef[2])
        if t > max_step_t and turn > min_turn_rad and abs(fit[3]) >= 0.5 * rise:
            return True
    return False


def test_the_step_kernel_agrees_with_each_splits_least_squares():
    # Steps of 0-60 mm under 5-20 mm noise, on level and tilted patches: the Schur-complement
    # kernel decides as the plain 4-column least squares of every split, at thresholds that
    # put some draws on each side.
    rng = np.random.default_rng(23)
    decided = []
    for draw in range(60):
        step_m = rng.uniform(0.0, 0.06)
        tilt = math.tan(math.radians(rng.uniform(-4.0, 4.0)))
        patch = _patch(
            rng,
            int(rng.integers(40, 900)),
            lambda x, y, s=step_m, a=tilt: np.where(y < 0.0, s, 0.0) + a * x,
            rng.uniform(0.005, 0.02),
        )
        for threshold in (4.0, 12.0):
            expected = _stepped_by_lstsq(patch, threshold, 3.0, math.radians(1.5))
            assert _stepped([patch], max_step_t=threshold)[0] == expected, (draw, threshold)
            decided.append(expected)
    assert 0 < sum(decided) < len(decided)  # both answers occur


def _bucketed_quantiles(values, quantiles):
    """`tilt_kernels`' quantiles of ``values`` through its value buckets (as the kernel)."""
    buckets = max(len(values) // 4, 16)
    out = np.empty(len(values))
    offsets = np.empty(buckets + 1, dtype=np.int64)
    done = np.empty(buckets, dtype=np.bool_)
    tilt_kernels._bucket_values(values, out, offsets, done)
    return [tilt_kernels._bucketed_quantile(out, offsets, done, q) for q in quantiles]


@pytest.mark.parametrize(
    "values",
    [
        np.random.default_rng(1).normal(size=997),  # about 4 values a bucket
        np.round(np.random.default_rng(2).normal(size=600), 1),  # many equal values
        np.random.default_rng(3).exponential(size=800) ** 4,  # most in one bucket: np.sort
        np.full(50, 0.3),  # all equal: one bucket
        np.array([2.0, -1.0, 0.5, 0.5, 7.0]),  # fewer values than buckets
        np.array([-0.0, 0.0, 1e-300, -1e-300, 5.0]),
        np.array([3e-310, 0.0, 1e-310, 2e-310, 5e-310, 1e-310]),  # 16 / 5e-310 overflows
    ],
)
def test_the_bucketed_quantiles_are_numpys_to_the_last_bit(values):
    # The step test's splits are order statistics: taken from value buckets, only the buckets
    # holding the ranks asked for are sorted, and each quantile is numpy's "linear" exactly.
    quantiles = np.linspace(0.1, 0.9, 17)
    got = _bucketed_quantiles(values, quantiles)
    np.testing.assert_array_equal(got, np.quantile(values, quantiles))


def test_points_are_grouped_by_plane_as_a_stable_argsort_groups_them():
    # Ids -1 (no plane) and 3 (beyond the 3 planes) belong to none.
    ids = np.array([2, -1, 0, 2, 1, 3, 0, 2, -1, 1], dtype=np.int64)
    order, starts = tilt_kernels._points_by_plane(ids, 3)
    np.testing.assert_array_equal(starts, [0, 2, 4, 7])
    np.testing.assert_array_equal(order, [2, 6, 4, 9, 0, 3, 7])
    stable = np.argsort(ids, kind="stable")
    np.testing.assert_array_equal(order, stable[(ids[stable] >= 0) & (ids[stable] < 3)])
