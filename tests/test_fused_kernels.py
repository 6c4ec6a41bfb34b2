"""The segmentation's fused kernels against the code they replace, and known answers.

`scanline.level_regions` (the floor stage's kernels in one call), `tilt_kernels.plane_geometry`
(the planes' bookkeeping), and the pose correction's kernels (`tilt_candidates`,
`tilt_consensus`, `corrected_planes`, `ground_level`, `shifted_floors`), and `segment_depth`'s
per-frame check of its transform (`clearly_rigid`) and floor ids (`floor_points`). Each
reference below is the code the kernel replaced (mapper/segmentation.py,
mapper/pose_correction.py at e15ff06); the kernels must give the same bits.
"""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest
from scanline_inputs import row_segments
from synthetic_depth import (
    Box,
    add_depth_noise,
    add_stereo_noise,
    look_down_camera,
    render_scene,
    staircase,
)

from mapper import scanline, tilt_kernels
from mapper.errors import InvalidInputError
from mapper.intrinsics import PinholeIntrinsics
from mapper.limits import RIGID_TOLERANCE
from mapper.pose_correction import (
    PoseCorrection,
    estimate_tilt,
    ground_shift,
    rotation_to_vertical,
    within_deg_of_vertical,
)
from mapper.scanline import steps
from mapper.segmentation import SegmentationParams, segment_depth
from mapper.validation import rigid_transform

INTRINSICS = PinholeIntrinsics.from_fov(88, 72, 47.0, 39.0)
PARAMS = SegmentationParams()


def _same(a, b):
    """Equal bits: arrays (NaN equal, dtype and shape too) or numbers."""
    if isinstance(a, np.ndarray):
        return a.dtype == b.dtype and a.shape == b.shape and np.array_equal(a, b, equal_nan=True)
    return a == b or (a != a and b != b)


# ---- the floor stage: level_regions against its kernels called one by one --------------------


def _numpy_floor_stage(z, sigma_z, points, rays, depth, segments, origin_z, params):
    """`segmentation.floor_regions` at e15ff06 (without the table), with session 56's split of
    stepped level regions (`mapper.scanline.steps`) after the pixel fill."""
    seg_rows, seg_starts, seg_stops = scanline.split_level(
        z,
        sigma_z,
        *segments,
        params.edge_sigma_factor,
        params.min_segment_pixels,
        params.noise_correlation_factor,
    )
    sums = scanline.horizontal_sums(
        points, sigma_z, seg_rows, seg_starts, seg_stops, params.noise_correlation_factor
    )
    floor_of_segment = scanline.grow_floors(
        seg_rows,
        seg_starts,
        seg_stops,
        sums,
        depth.shape[0],
        params.grow_sigma_factor,
        params.rms_sigma_factor,
        params.floor_height_tolerance_m,
        params.seed_min_pixels,
        params.noise_correlation_factor,
    )
    n_floors = int(floor_of_segment.max(initial=-1)) + 1
    grown = scanline.segment_labels(
        np.isfinite(depth), seg_rows, seg_starts, seg_stops, floor_of_segment
    )
    labels = grown
    grown_heights = scanline.level_heights(floor_of_segment, sums, n_floors)
    if n_floors > 0 and params.fill_passes > 0:
        labels = grown.copy()
        level_model = np.zeros((n_floors, 3))
        level_model[:, 2] = grown_heights
        scanline.fill_pixels(
            z,
            np.zeros(z.shape[1]),
            np.zeros(z.shape[0]),
            labels,
            sigma_z,
            level_model,
            params.fill_sigma_factor,
            params.tolerance_floor_m,
            params.fill_passes,
            False,
        )
    if n_floors > 0 and params.floor_step_split_t > 0.0:
        if params.fill_passes == 0:
            labels = grown.copy()
        split_floors = steps.split_stepped_levels(
            labels,
            grown,
            points,
            sigma_z,
            n_floors,
            steps.SPLIT_BINS,
            steps.SPLIT_DIRECTIONS,
            params.floor_step_split_t,
            steps.MIN_STEP_M,
            params.min_plane_pixels,
            params.noise_correlation_factor,
            steps.CONFIDENCE_SIGMAS,
        )
        if split_floors > n_floors:
            n_floors = split_floors
            seg_rows, seg_starts, seg_stops, floor_of_segment = steps.cut_segments(
                grown, seg_rows, seg_starts, seg_stops, floor_of_segment
            )
            sums = scanline.horizontal_sums(
                points, sigma_z, seg_rows, seg_starts, seg_stops, params.noise_correlation_factor
            )
            grown_heights = scanline.level_heights(floor_of_segment, sums, n_floors)
    interior = scanline.region_interior(labels, params.floor_edge_margin_px)
    height_depth = scanline.region_depth(labels, params.floor_height_margin_px)
    ring_inside = height_depth >= min(params.floor_height_margin_px, 1)
    if n_floors > 0 and params.floor_snap_sigma_factor > 0.0:
        interior = interior & ~scanline.foreign_rim(
            labels, ring_inside, z, sigma_z, grown_heights, params.floor_snap_sigma_factor
        )
    counts, heights, rms, extents, areas, slope = scanline.floor_statistics(
        labels,
        grown,
        interior,
        height_depth,
        params.floor_height_margin_px,
        points,
        sigma_z,
        depth,
        rays,
        origin_z,
        INTRINSICS.fx,
        INTRINSICS.fy,
        n_floors,
        params.tolerance_floor_m,
        params.floor_roughness_m,
        params.floor_roughness_min_extent_m,
    )
    chi2, n_segments = scanline.floor_segment_fit(
        sums, floor_of_segment, n_floors, params.floor_height_tolerance_m, params.min_plane_extent_m
    )
    is_floor = scanline.floor_verdict(
        counts,
        n_segments,
        extents,
        slope,
        rms,
        chi2,
        params.min_plane_pixels,
        params.min_plane_extent_m,
        math.tan(math.radians(params.floor_max_normal_angle_deg)),
        params.floor_max_rms_ratio,
        params.floor_max_segment_chi2,
    )
    return labels, counts, heights, rms, extents, areas, is_floor


def _level_regions(z, sigma_z, points, rays, depth, segments, origin_z, params):
    return scanline.level_regions(
        z,
        sigma_z,
        points,
        rays,
        depth,
        *segments,
        origin_z,
        INTRINSICS.fx,
        INTRINSICS.fy,
        params.edge_sigma_factor,
        params.min_segment_pixels,
        params.noise_correlation_factor,
        params.grow_sigma_factor,
        params.rms_sigma_factor,
        params.floor_height_tolerance_m,
        params.seed_min_pixels,
        params.fill_sigma_factor,
        params.tolerance_floor_m,
        params.fill_passes,
        params.floor_edge_margin_px,
        params.floor_height_margin_px,
        params.floor_snap_sigma_factor,
        params.min_plane_pixels,
        params.min_plane_extent_m,
        math.tan(math.radians(params.floor_max_normal_angle_deg)),
        params.floor_max_rms_ratio,
        params.floor_max_segment_chi2,
        params.floor_roughness_m,
        params.floor_roughness_min_extent_m,
        params.floor_step_split_t,
    )


def _floor_inputs(noise, seed, pitch_deg=30.0):
    """A staircase frame's floor-stage inputs (believed = true pose, every row one segment)."""
    camera = look_down_camera((0.0, 0.0, 0.9), pitch_deg)
    scene = render_scene(INTRINSICS, camera, staircase())
    depth = add_depth_noise(scene.depth_m, noise, np.random.default_rng(seed))
    depth = np.where((depth >= PARAMS.min_depth_m) & (depth <= PARAMS.max_depth_m), depth, np.nan)
    return _row_segment_inputs(depth, camera, np.full(depth.shape, 0.002))


def _row_segment_inputs(depth, camera, typical):
    """The floor-stage inputs of a depth image seen from ``camera`` (the believed pose is the
    true one), its typical depth noise ``typical`` [m], every row one segment."""
    height, width = depth.shape
    origin = camera[:3, 3].copy()
    rays, points, sigma_z = scanline.level_geometry(
        depth,
        INTRINSICS.ray_directions_camera().reshape(-1, 3),
        camera[:3, :3].copy(),
        origin,
        typical,
        PARAMS.min_noise_m,
    )
    segments = (
        np.arange(height, dtype=np.int64),
        np.zeros(height, dtype=np.int64),
        np.full(height, width, dtype=np.int64),
    )
    z = np.ascontiguousarray(points[..., 2])
    return z, sigma_z, points, rays, depth, segments, float(origin[2])


@pytest.mark.parametrize(
    "params",
    [
        PARAMS,
        SegmentationParams(fill_passes=0),
        SegmentationParams(floor_height_margin_px=2),
        SegmentationParams(floor_snap_sigma_factor=0.0),
        SegmentationParams(floor_max_rms_ratio=0.0, floor_max_segment_chi2=0.0),
        SegmentationParams(floor_step_split_t=1.0),  # tested, none split
    ],
)
@pytest.mark.parametrize("noise,seed", [(0.0, 0), (0.01, 1), (0.02, 2)])
def test_level_regions_is_the_floor_stage(params, noise, seed):
    inputs = _floor_inputs(noise, seed)
    expected = _numpy_floor_stage(*inputs, params)
    got = _level_regions(*inputs, params)
    assert len(got) == len(expected)
    for a, b in zip(expected, got, strict=True):
        assert _same(a, b)


def _tread_inputs(seed):
    """A stereo frame's floor-stage inputs: a 20 mm tread whose side edge runs along the view
    (0.6-1.4 m ahead), the ground beside it, every row one segment (the rows run on over the
    edge) — the joined levels `mapper.scanline.steps` splits."""
    camera = look_down_camera((0.0, 0.0, 0.93), 40.0)
    scene = render_scene(INTRINSICS, camera, [Box((1.0, -0.6), (0.8, 1.0, 0.02))])
    rng = np.random.default_rng(seed)
    depth = add_stereo_noise(scene.depth_m, INTRINSICS.fx * 0.07, 0.074, 0.6, rng)
    typical = depth**2 * 0.109 / (INTRINSICS.fx * 0.07)  # the stereo head's model
    return _row_segment_inputs(depth, camera, typical)


@pytest.mark.parametrize("fill_passes", [0, 2])
@pytest.mark.parametrize("seed", [0, 3, 4])
def test_level_regions_splits_as_its_kernels(seed, fill_passes):
    """With the split on, the fused stage is its kernels one by one, and it split a region."""
    inputs = _tread_inputs(seed)
    plain = SegmentationParams(noise_correlation_factor=3.0, fill_passes=fill_passes)
    split = SegmentationParams(
        noise_correlation_factor=3.0, fill_passes=fill_passes, floor_step_split_t=8.0
    )
    got = _level_regions(*inputs, split)
    expected = _numpy_floor_stage(*inputs, split)
    for a, b in zip(expected, got, strict=True):
        assert _same(a, b)
    assert len(got[1]) == len(_level_regions(*inputs, plain)[1]) + 1


def test_level_regions_known_answer():
    # Exact depth of the staircase: its ground, three steps and the platform are level
    # regions at 0, 31, 61, 94 and 122 mm, and the ground is a floor.
    got = _level_regions(*_floor_inputs(0.0, 0), PARAMS)
    labels, counts, heights, _, _, _, is_floor = got
    floors = np.sort(heights[is_floor])
    assert floors[0] == pytest.approx(0.0, abs=1e-9)
    for step_m in (0.031, 0.061, 0.094):
        assert np.min(np.abs(floors - step_m)) < 1e-9
    assert counts.sum() == np.count_nonzero(labels >= 0)


def test_level_regions_without_segments():
    inputs = list(_floor_inputs(0.0, 0))
    inputs[5] = tuple(np.zeros(0, dtype=np.int64) for _ in range(3))
    labels, counts, heights, rms, extents, areas, is_floor = _level_regions(*inputs, PARAMS)
    assert np.all(labels[np.isfinite(inputs[4])] == -1)
    assert counts.shape == heights.shape == rms.shape == areas.shape == is_floor.shape == (0,)
    assert extents.shape == (0, 2)


# ---- the planes' bookkeeping: plane_geometry against segment_depth's numpy at e15ff06 ----------


def _plane_inputs(noise, seed):
    """The planes stage's inputs of a staircase frame (segment_depth's calls up to the fill)."""
    camera = look_down_camera((0.1, 0.2, 0.9), 30.0, yaw_deg=20.0, roll_deg=5.0)
    scene = render_scene(INTRINSICS, camera, staircase())
    depth_m = add_depth_noise(scene.depth_m, noise, np.random.default_rng(seed))
    p = PARAMS
    seg = row_segments(depth_m, INTRINSICS, p)
    plane_of = scanline.grow_planes(*seg.grow_planes_args(p))
    labels = scanline.segment_labels(seg.valid, seg.rows, seg.starts, seg.stops, plane_of)
    n_planes = int(plane_of.max(initial=-1)) + 1
    inv_depth, x, y = seg.inv_depth, seg.x, seg.y
    plane_table, counts = scanline.plane_fits(inv_depth, x, y, labels, n_planes)
    grown = labels.copy()
    scanline.fill_pixels(
        inv_depth, x, y, labels, seg.sigma, plane_table, p.fill_sigma_factor, 0.0, 2, True
    )
    return labels, grown, seg.pixel_index, counts, plane_table, camera, seg.depth, inv_depth, x, y


def _numpy_plane_geometry(labels, grown, pixel_index, counts, plane_table, camera, depth, *rest):
    """segment_depth at e15ff06, from ``keep`` to the tilt's information."""
    inv_depth, x, y, margin, min_pixels = rest
    p = PARAMS
    keep = (counts >= min_pixels) & np.isfinite(plane_table[:, 0])
    _, refit_labels, plane_ids, grown_ids, counts = scanline.renumber_planes(
        labels, grown, pixel_index, keep
    )
    plane_table = plane_table[keep]
    rotation = camera[:3, :3].copy()
    pivot = camera[:3, 3].copy()
    rays_camera = INTRINSICS.ray_directions_camera().reshape(-1, 3)
    normals_camera, normals, _ = tilt_kernels.unit_normals(plane_table, rotation)
    centroids_camera, eigen, areas = scanline.plane_moments(
        rays_camera,
        depth,
        pixel_index,
        grown_ids,
        normals_camera,
        len(counts),
        INTRINSICS.fx,
        INTRINSICS.fy,
    )
    centroids = tilt_kernels.rotate_points(centroids_camera, rotation, np.zeros(3), pivot, True)
    rms = np.sqrt(plane_table[:, 3]) * centroids_camera[:, 2] ** 2
    min_inv_sigma = p.min_noise_m / centroids_camera[:, 2] ** 2
    if margin > 0:
        interior = scanline.region_interior(refit_labels, margin)
        refit_labels = np.where(interior, refit_labels, -1)
    tilt_table = scanline.plane_refits(
        inv_depth,
        x,
        y,
        refit_labels,
        plane_table,
        p.plane_refit_sigma,
        p.min_noise_m,
        1.0 / p.max_depth_m,
    )
    _, tilt_normals, _ = tilt_kernels.unit_normals(tilt_table, rotation)
    sigma = tilt_kernels.normal_sigma_deg(tilt_table, p.noise_correlation_factor, min_inv_sigma)
    return plane_ids, counts, normals, centroids, eigen, areas, rms, tilt_normals, 1.0 / sigma**2


def _plane_geometry(
    labels, grown, pixel_index, counts, table, camera, depth, inv_depth, x, y, margin, min_pixels
):
    """`tilt_kernels.plane_geometry` on `_plane_inputs`' arrays with PARAMS' other fields."""
    return tilt_kernels.plane_geometry(
        labels,
        grown,
        pixel_index,
        counts,
        table,
        camera[:3, :3].copy(),
        camera[:3, 3].copy(),
        INTRINSICS.ray_directions_camera().reshape(-1, 3),
        depth,
        inv_depth,
        x,
        y,
        INTRINSICS.fx,
        INTRINSICS.fy,
        min_pixels,
        PARAMS.min_noise_m,
        margin,
        PARAMS.plane_refit_sigma,
        1.0 / PARAMS.max_depth_m,
        PARAMS.noise_correlation_factor,
    )


@pytest.mark.parametrize("margin,min_pixels", [(1, 30), (0, 30), (2, 200), (1, 10**6)])
@pytest.mark.parametrize("noise,seed", [(0.0, 0), (0.01, 3)])
def test_plane_geometry_is_segment_depths_numpy(margin, min_pixels, noise, seed):
    inputs = _plane_inputs(noise, seed)
    labels, *rest = inputs
    expected = _numpy_plane_geometry(labels.copy(), *rest, margin, min_pixels)
    got = _plane_geometry(*inputs, margin, min_pixels)
    for a, b in zip(expected, got, strict=True):
        assert _same(a, b)
    if min_pixels == 10**6:
        assert got[1].shape == (0,) and np.all(got[0] < 0)  # every plane dissolved


def test_plane_geometry_known_answer():
    # Exact depth, camera 0.9 m up: the ground plane's normal is vertical in the robot frame
    # and its centroid lies on the ground (z = 0).
    labels, grown, pixel_index, counts, table, camera, depth, inv_depth, x, y = _plane_inputs(
        0.0, 0
    )
    plane_ids, kept, normals, centroids, *_ = _plane_geometry(
        labels,
        grown,
        pixel_index,
        counts,
        table,
        camera,
        depth,
        inv_depth,
        x,
        y,
        1,
        PARAMS.min_plane_pixels,
    )
    lowest = int(np.argmin(np.abs(centroids[:, 2])))
    # The fit's normal is vertical within 1e-5 (2.3e-6 across: the inverse-depth fit of exact
    # depths is not exact in floats).
    assert centroids[lowest, 2] == pytest.approx(0.0, abs=1e-5)
    assert normals[lowest] == pytest.approx([0.0, 0.0, 1.0], abs=1e-5)
    assert np.array_equal(np.bincount(plane_ids[plane_ids >= 0], minlength=len(kept)), kept)


# ---- the pose correction ----------------------------------------------------------------------


def _fma(a: float, b: float, c: float) -> float:
    """``a·b + c`` rounded once: exact in fractions, then rounded to the nearest float."""
    return float(Fraction(a) * Fraction(b) + Fraction(c))


def _fused_norm(v: np.ndarray) -> float:
    """``np.linalg.norm`` of a 3-vector as OpenBLAS's fused ddot takes it (the kernel's order).

    e15ff06's ``np.linalg.norm(mean)`` is BLAS's ddot, whose order depends on the CPU's kernel:
    fused multiply-adds ``fma(v2, v2, fma(v1, v1, v0·v0))`` on the AVX-512 machine the kernel was
    written on, a plain sum on a Zen 3 EPYC (session 58: 2 144 of 20 000 random vectors differ in
    the last bit, and this test failed there). The kernel keeps the fused order on every CPU, so
    the reference spells it out instead of asking the host's BLAS.
    """
    return math.sqrt(_fma(v[2], v[2], _fma(v[1], v[1], v[0] * v[0])))


def _numpy_estimate_tilt(normals, areas, eigen, counts, pivot, params):
    """`pose_correction.estimate_tilt` at e15ff06."""
    identity = PoseCorrection.identity(pivot)
    if not params.correct_tilt or normals.shape[0] == 0:
        return identity
    minor_extent = np.sqrt(12.0 * np.maximum(eigen[:, 1], 0.0))
    candidates = (
        within_deg_of_vertical(normals, params.max_tilt_correction_deg)
        & (counts >= params.min_plane_pixels)
        & (minor_extent >= params.min_plane_extent_m)
    )
    if not candidates.any():
        return identity
    agree = (normals @ normals.T >= math.cos(math.radians(params.tilt_consensus_deg))) & (
        candidates[:, None] & candidates[None, :]
    )
    support = agree.astype(np.float64) @ areas
    candidates &= agree[int(np.argmax(np.where(candidates, support, -1.0)))]
    mean = (normals[candidates] * areas[candidates, None]).sum(axis=0)
    mean /= _fused_norm(mean)
    if not within_deg_of_vertical(mean[None], params.max_tilt_correction_deg)[0]:
        return identity
    return PoseCorrection(
        rotation=rotation_to_vertical(mean),
        pivot_m=pivot,
        z_shift_m=0.0,
        ground_plane_found=False,
        tilt_planes=int(candidates.sum()),
    )


def _planes(rng, n, spread_deg=12.0):
    """n random planes around vertical: unit normals (z > 0), weights, eigenvalues, counts."""
    tilt = np.radians(rng.uniform(0.0, spread_deg, n))
    azimuth = rng.uniform(0.0, 2 * np.pi, n)
    normals = np.stack(
        [np.sin(tilt) * np.cos(azimuth), np.sin(tilt) * np.sin(azimuth), np.cos(tilt)], axis=1
    )
    weights = rng.uniform(0.01, 5.0, n)
    eigen = np.sort(rng.uniform(-1e-4, 0.3, (n, 3)), axis=1)
    counts = rng.integers(10, 400, n)
    return normals, weights, eigen, counts


def _assert_same_correction(a, b):
    assert np.array_equal(a.rotation, b.rotation)
    assert np.array_equal(a.pivot_m, b.pivot_m)
    assert (a.z_shift_m, a.ground_plane_found, a.tilt_planes) == (
        b.z_shift_m,
        b.ground_plane_found,
        b.tilt_planes,
    )


@pytest.mark.parametrize("n", [0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 25, 40])
def test_estimate_tilt_is_numpys(n):
    rng = np.random.default_rng(100 + n)
    pivot = np.array([0.1, -0.2, 0.9])
    for trial in range(40):
        normals, weights, eigen, counts = _planes(rng, n, spread_deg=25.0 if trial % 2 else 8.0)
        for params in (PARAMS, SegmentationParams(tilt_consensus_deg=2.0)):
            expected = _numpy_estimate_tilt(normals, weights, eigen, counts, pivot, params)
            got = estimate_tilt(normals, weights, eigen, counts, pivot, params)
            _assert_same_correction(expected, got)


def test_estimate_tilt_known_answer():
    # Two floors tilted 3° about x and a ramp tilted 15°: the floors agree and outweigh it;
    # the correction turns their normal to vertical and leaves the ramp out.
    tilt = math.radians(3.0)
    ramp = math.radians(15.0)
    normals = np.array(
        [
            [0.0, -math.sin(tilt), math.cos(tilt)],
            [0.0, -math.sin(ramp), math.cos(ramp)],
            [0.0, -math.sin(tilt), math.cos(tilt)],
        ]
    )
    eigen = np.array([[0.0, 0.2, 0.5]] * 3)
    counts = np.array([500, 900, 500])
    correction = estimate_tilt(
        normals, np.array([1.0, 1.5, 1.0]), eigen, counts, np.zeros(3), PARAMS
    )
    assert correction.tilt_planes == 2
    assert correction.rotation @ normals[0] == pytest.approx([0.0, 0.0, 1.0], abs=1e-12)
    assert correction.rotation_deg == pytest.approx(3.0, abs=1e-9)


def test_estimate_tilt_without_candidates_is_the_identity():
    normals = np.array([[1.0, 0.0, 0.0]])  # a wall
    got = estimate_tilt(
        normals, np.ones(1), np.array([[0.0, 1.0, 1.0]]), np.array([1000]), np.ones(3), PARAMS
    )
    _assert_same_correction(got, PoseCorrection.identity(np.ones(3)))


def test_tilt_consensus_takes_numpys_first_maximum_and_sum_order():
    # Equal supports: the first candidate is the reference (np.argmax); the mean's norm is
    # numpy's (np.linalg.norm) bit for bit.
    normals = np.array([[0.0, 0.0, 1.0], [0.3, 0.0, 0.9539392014169457], [0.0, 0.0, 1.0]])
    candidates = np.array([True, True, True])
    agree = np.array([[1.0, 0.0, 1.0], [0.0, 1.0, 0.0], [1.0, 0.0, 1.0]])
    weights = np.array([1.0, 2.0, 1.0])
    mean, used, within = tilt_kernels.tilt_consensus(
        normals, weights, candidates, agree, agree @ weights, 0.9
    )
    assert used == 2 and within
    assert np.array_equal(mean, np.array([0.0, 0.0, 1.0]))


def _numpy_ground_shift(correction, heights, areas, is_floor, params):
    """`pose_correction.ground_shift` at e15ff06."""
    offsets = heights - params.expected_ground_z_m
    near = is_floor & (np.abs(offsets) <= params.ground_search_window_m)
    if not near.any():
        return correction
    near &= areas >= 0.25 * areas[near].max()
    nearest = int(np.argmin(np.where(near, np.abs(offsets), np.inf)))
    shift = -float(offsets[nearest]) if params.correct_ground_shift else 0.0
    return PoseCorrection(
        correction.rotation, correction.pivot_m, shift, True, correction.tilt_planes
    )


@pytest.mark.parametrize("n", [0, 1, 2, 5, 17])
def test_ground_shift_is_numpys(n):
    rng = np.random.default_rng(n)
    start = PoseCorrection.identity(np.zeros(3))
    for _ in range(60):
        heights = rng.normal(0.0, 0.1, n)
        heights[rng.random(n) < 0.1] = np.nan
        areas = rng.uniform(0.0, 2.0, n)
        is_floor = rng.random(n) < 0.7
        for params in (PARAMS, SegmentationParams(correct_ground_shift=False)):
            expected = _numpy_ground_shift(start, heights, areas, is_floor, params)
            got = ground_shift(start, heights, areas, is_floor, params)
            _assert_same_correction(expected, got)


def test_ground_level_known_answer():
    # The region 5 mm below is nearest but small: a quarter of the largest near area rules it
    # out; the next nearest (12 mm up) wins; a floor beyond the window does not count.
    heights = np.array([-0.005, 0.012, -0.02, 0.4])
    areas = np.array([0.1, 1.0, 2.0, 9.0])
    is_floor = np.array([True, True, True, True])
    found, offset = tilt_kernels.ground_level(heights, areas, is_floor, 0.0, 0.1)
    assert found and offset == 0.012
    found, offset = tilt_kernels.ground_level(heights, areas, ~is_floor, 0.0, 0.1)
    assert not found and offset == 0.0


def test_ground_level_nan_area_is_as_numpys_max():
    # A NaN area makes np.max NaN: no region qualifies and np.argmin takes the first (inf).
    heights = np.array([0.03, 0.01])
    areas = np.array([1.0, np.nan])
    is_floor = np.array([True, True])
    found, offset = tilt_kernels.ground_level(heights, areas, is_floor, 0.0, 0.1)
    assert found and offset == 0.03


def test_corrected_planes_is_numpys():
    rng = np.random.default_rng(7)
    for n in (0, 1, 2, 9, 30):
        normals, _, eigen, counts = _planes(rng, n, spread_deg=40.0)
        centroids = rng.normal(size=(n, 3))
        rotation = rotation_to_vertical(np.array([0.05, -0.03, math.sqrt(1 - 0.05**2 - 0.03**2)]))
        pivot = rng.normal(size=3)
        centroids_c, normals_c, extents, is_floor = tilt_kernels.corrected_planes(
            centroids,
            normals,
            rotation,
            pivot,
            eigen,
            counts,
            math.cos(math.radians(10.0)),
            30,
            0.2,
        )
        assert _same(
            centroids_c, tilt_kernels.rotate_points(centroids, rotation, pivot, pivot, True)
        )
        assert _same(
            normals_c,
            tilt_kernels.rotate_points(normals, rotation, np.zeros(3), np.zeros(3), False),
        )
        assert _same(extents, np.sqrt(12.0 * np.maximum(eigen[:, 1:], 0.0)))
        expected = (
            within_deg_of_vertical(normals_c, 10.0)
            & (counts >= 30)
            & (np.sqrt(12.0 * np.maximum(eigen[:, 1], 0.0)) >= 0.2)
        )
        assert _same(is_floor, expected)


def test_corrected_planes_known_answer():
    # No rotation: centroids and normals unchanged; variance 0.03 m² → width sqrt(0.36) = 0.6 m.
    centroids = np.array([[1.0, 2.0, 0.5]])
    normals = np.array([[0.0, 0.0, 1.0]])
    got = tilt_kernels.corrected_planes(
        centroids,
        normals,
        np.eye(3),
        np.zeros(3),
        np.array([[0.0, 0.03, 0.12]]),
        np.array([100]),
        0.9,
        30,
        0.5,
    )
    assert np.array_equal(got[0], centroids) and np.array_equal(got[1], normals)
    assert got[2][0] == pytest.approx([0.6, 1.2])
    assert got[3].tolist() == [True]


def test_shifted_floors_known_answer():
    heights = np.array([0.01, -0.004, 0.2, np.nan])
    is_floor = np.array([True, True, False, False])
    shifted, floor_heights, ground = tilt_kernels.shifted_floors(
        heights, is_floor, 0.004, 0.0, True
    )
    assert np.array_equal(shifted, heights + 0.004, equal_nan=True)
    assert np.array_equal(floor_heights, np.array([0.014, 0.0, np.nan, np.nan]), equal_nan=True)
    assert ground == 0.0
    assert math.isnan(tilt_kernels.shifted_floors(heights, is_floor, 0.0, 0.0, False)[2])


def test_segment_depth_on_the_staircase_is_unchanged_by_the_fusion():
    # Known answer end to end: the staircase's floors at their true heights.
    camera = look_down_camera((0.0, 0.0, 0.9), 30.0)
    scene = render_scene(INTRINSICS, camera, staircase())
    result = segment_depth(scene.depth_m, INTRINSICS, camera)
    floors = np.sort(result.floors.heights_m[result.floors.is_floor])
    assert floors[0] == pytest.approx(0.0, abs=1e-6)
    assert result.correction.ground_plane_found
    assert result.correction.rotation_deg == pytest.approx(0.0, abs=1e-6)


# ---- segment_depth's per-frame glue: the rigidity check and the floor ids ----------------------


def _rotation(rng):
    """A random proper rotation (QR of a Gaussian matrix, det +1)."""
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    if np.linalg.det(q) < 0.0:
        q[:, 0] = -q[:, 0]
    return q


def _transform(rotation, translation=(0.1, -0.2, 0.9)):
    out = np.eye(4)
    out[:3, :3] = rotation
    out[:3, 3] = translation
    return out


def _rigid_verdict(transform):
    """`rigid_transform`'s verdict: True if it accepts ``transform``."""
    try:
        rigid_transform(transform, "t")
    except InvalidInputError:
        return False
    return True


@pytest.mark.parametrize("seed", range(5))
def test_clearly_rigid_accepts_only_what_rigid_transform_accepts(seed):
    rng = np.random.default_rng(seed)
    rotation = _rotation(rng)
    transform = _transform(rotation)
    assert tilt_kernels.clearly_rigid(transform, RIGID_TOLERANCE)
    # Float32 rounding (recordings) is clearly rigid too.
    rounded = transform.astype(np.float32).astype(np.float64)
    assert tilt_kernels.clearly_rigid(rounded, RIGID_TOLERANCE)
    # Perturbed around the tolerance: whatever the kernel accepts, rigid_transform accepts.
    for scale in (1e-8, 1e-7, 2e-7, 4e-7, 6e-7, 1e-6, 2e-6, 1e-4):
        for _ in range(20):
            perturbed = transform.copy()
            perturbed[:3, :3] += scale * rng.normal(size=(3, 3))
            if tilt_kernels.clearly_rigid(perturbed, RIGID_TOLERANCE):
                assert _rigid_verdict(perturbed)


def test_clearly_rigid_refuses_what_rigid_transform_refuses():
    rng = np.random.default_rng(7)
    transform = _transform(_rotation(rng))
    reflection = transform.copy()
    reflection[:3, 0] = -reflection[:3, 0]
    shear = transform.copy()
    shear[0, 1] += 1e-3
    last_row = transform.copy()
    last_row[3, 0] = 1e-9
    not_finite = transform.copy()
    not_finite[1, 3] = np.nan
    infinite = transform.copy()
    infinite[2, 2] = np.inf
    for bad in (reflection, shear, last_row, not_finite, infinite, 2.0 * transform):
        assert not tilt_kernels.clearly_rigid(bad, RIGID_TOLERANCE)
        assert not _rigid_verdict(bad)


def test_segment_depth_takes_every_transform_rigid_transform_takes():
    # The fast check and rigid_transform's own path give the same result and the same errors.
    camera = look_down_camera((0.0, 0.0, 0.9), 30.0)
    depth = render_scene(INTRINSICS, camera, staircase()).depth_m
    reference = segment_depth(depth, INTRINSICS, camera)
    for same in (camera.tolist(), np.asfortranarray(camera), camera.astype(np.longdouble)):
        result = segment_depth(depth, INTRINSICS, same)
        assert _same(result.floor_heights, reference.floor_heights)
        assert _same(result.transform_camera_to_robot, reference.transform_camera_to_robot)
    shear = camera.copy()
    shear[0, 1] += 1e-3
    with pytest.raises(InvalidInputError, match="transform_camera_to_robot must be a rigid"):
        segment_depth(depth, INTRINSICS, shear)
    with pytest.raises(InvalidInputError, match="transform_camera_to_robot must be a finite"):
        segment_depth(depth, INTRINSICS, np.eye(3))


@pytest.mark.parametrize("noise,seed", [(0.0, 0), (0.01, 1), (0.02, 2)])
def test_floor_points_regions_are_the_labels_taken_at_the_pixels(noise, seed):
    z, sigma_z, points, rays, depth, segments, origin_z = _floor_inputs(noise, seed)
    labels = _level_regions(z, sigma_z, points, rays, depth, segments, origin_z, PARAMS)[0]
    pixel_index = np.flatnonzero(np.isfinite(depth))
    n_regions = int(labels.max()) + 1
    origin = np.array([0.0, 0.0, origin_z])
    *_, regions = scanline.floor_points(
        pixel_index,
        labels,
        np.linspace(0.0, 0.1, n_regions),
        0.0,
        rays,
        depth,
        np.full(depth.shape, 0.002),
        origin,
        PARAMS.ground_relabel_sigma_factor,
        PARAMS.floor_snap_sigma_factor,
    )
    assert _same(regions, np.take(labels, pixel_index))
