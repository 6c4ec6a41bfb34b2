"""The scan-line kernels' fast paths against plain definitions (session 26 speed work).

`region_interior` without branches, the noise box means counted once and summed by rows,
`plane_moments` taking rays and depths, `foreign_rim` in one pass: each equals the obvious
numpy computation of what its docstring says.
"""

from __future__ import annotations

import numpy as np
import pytest

from mapper import scanline
from mapper.scanline.noise import _box_counts, _box_mean, _running_row_sums
from mapper.scanline.planes import _solve_plane


def _blocky_labels(rng: np.random.Generator) -> np.ndarray:
    labels = rng.integers(-2, 3, size=(rng.integers(1, 12), rng.integers(1, 12)))
    return np.ascontiguousarray(np.repeat(np.repeat(labels, 3, axis=0), 3, axis=1))


def _interior_reference(labels: np.ndarray, margin: int) -> np.ndarray:
    height, width = labels.shape
    out = labels >= 0
    for k in range(1, margin + 1):
        padded = np.pad(labels, k, constant_values=-3)  # beyond the border: another region
        for dr, dc in ((-k, 0), (k, 0), (0, -k), (0, k)):
            out &= padded[k + dr : k + dr + height, k + dc : k + dc + width] == labels
    return out


@pytest.mark.parametrize("margin", [0, 1, 2, 3])
def test_region_interior_is_the_plain_definition(margin):
    rng = np.random.default_rng(margin)
    for _ in range(40):
        labels = _blocky_labels(rng)
        np.testing.assert_array_equal(
            scanline.region_interior(labels, margin), _interior_reference(labels, margin)
        )


def test_box_mean_is_the_clipped_mean_of_a_3_row_box():
    rng = np.random.default_rng(7)
    values = rng.uniform(0.0, 1.0, size=(9, 13))
    values[rng.random(values.shape) < 0.3] = np.nan
    clip = rng.uniform(0.1, 0.5, size=values.shape)
    half_cols = 2
    counts, work, row_sum, out = (np.empty(values.shape) for _ in range(4))
    _box_counts(values, half_cols, counts, row_sum)
    _box_mean(values, 2.5, clip, half_cols, counts, work, row_sum, out)
    clipped = np.minimum(values, 2.5 * clip)
    for r in range(values.shape[0]):
        for c in range(values.shape[1]):
            box = clipped[max(r - 1, 0) : r + 2, max(c - half_cols, 0) : c + half_cols + 1]
            present = box[np.isfinite(box)]
            assert counts[r, c] == present.size
            if present.size >= 3:
                assert out[r, c] == pytest.approx(present.mean(), rel=1e-12)
            else:
                assert np.isnan(out[r, c])


@pytest.mark.parametrize("height", [1, 3, 4, 5, 9])
@pytest.mark.parametrize("half_cols", [0, 2, 20])
def test_running_row_sums_are_each_rows_own_running_sum_bit_for_bit(height, half_cols):
    # Four rows are summed side by side (and the rest one by one): each row's sum is still
    # the one running sum of that row alone, the entering value added before the leaving one
    # is subtracted, so the float sums are the same to the last bit.
    rng = np.random.default_rng(height * 100 + half_cols)
    values = rng.uniform(0.0, 1.0, size=(height, 13)) * 10.0 ** rng.integers(-3, 3, (height, 13))
    out = np.empty_like(values)
    _running_row_sums(values, half_cols, out)
    width = values.shape[1]
    for r in range(height):
        s = 0.0
        for add in range(min(half_cols, width)):
            s += values[r, add]
        for c in range(width):
            if c + half_cols < width:
                s += values[r, c + half_cols]
            if c - half_cols - 1 >= 0:
                s -= values[r, c - half_cols - 1]
            assert out[r, c] == s, (r, c)


def test_plane_moments_of_rays_and_depths_are_those_of_the_points():
    rng = np.random.default_rng(3)
    height, width = 6, 8
    u, v = np.meshgrid(np.linspace(-0.4, 0.4, width), np.linspace(-0.3, 0.3, height))
    rays = np.stack([u, v, np.ones_like(u)], axis=-1).reshape(-1, 3)
    depth = rng.uniform(1.0, 2.0, size=(height, width))
    pixel_index = np.flatnonzero(rng.random(height * width) < 0.8)
    ids = rng.integers(-1, 2, size=pixel_index.size)
    normals = np.array([[0.0, 0.0, 1.0], [0.0, -0.6, 0.8]])
    centroids, eigen, areas = scanline.plane_moments(
        rays, depth, pixel_index, ids, normals, 2, 100.0, 100.0
    )
    points = rays[pixel_index] * depth.ravel()[pixel_index][:, None]
    for p in range(2):
        mine = points[ids == p]
        np.testing.assert_allclose(centroids[p], mine.mean(axis=0), rtol=1e-12)
        covariance = np.cov(mine.T, bias=True)
        np.testing.assert_allclose(eigen[p], np.linalg.eigvalsh(covariance), atol=1e-12)
        assert areas[p] > 0.0


def test_foreign_rim_is_the_ring_off_its_level():
    labels = np.array([[0, 0, 0], [0, 0, -1], [-2, 1, 1]])
    height_interior = np.array([[False, False, False], [False, True, False], [False, False, True]])
    z = np.array([[0.0, 0.05, 0.01], [0.2, 0.2, 0.0], [0.0, 0.5, 0.9]])
    sigma_z = np.full((3, 3), 0.01)
    rim = scanline.foreign_rim(labels, height_interior, z, sigma_z, np.array([0.0, 0.5]), 3.0)
    expected = np.array([[False, True, False], [True, False, False], [False, False, False]])
    np.testing.assert_array_equal(rim, expected)


def _noisy_staircase_segments(seed: int, noise: float):
    """A noisy 88×72 view of the staircase and its row segments (`scanline_inputs`)."""
    from scanline_inputs import row_segments
    from synthetic_depth import add_depth_noise, look_down_camera, render_scene, staircase

    from mapper.intrinsics import PinholeIntrinsics
    from mapper.segmentation import SegmentationParams

    intrinsics = PinholeIntrinsics.from_fov(88, 72, 47.0, 39.0)
    camera = look_down_camera((0.0, 0.0, 0.9), pitch_down_deg=30.0)
    scene = render_scene(intrinsics, camera, staircase())
    depth = add_depth_noise(scene.depth_m, noise, np.random.default_rng(seed))
    params = SegmentationParams()
    return row_segments(depth, intrinsics, params), params


def _break_rounds(seg, params, incremental: bool):
    rows, starts, stops, table = seg.rows, seg.starts, seg.stops, seg.table
    height = seg.inv_depth.shape[0]
    check = np.ones(height, np.bool_)
    splits = []
    for _ in range(params.break_passes):
        rows, starts, stops, table, split_in = scanline.propagate_breaks(
            seg.inv_depth,
            seg.x,
            seg.sigma,
            rows,
            starts,
            stops,
            table,
            check,
            params.edge_window_px,
            params.break_sigma_factor,
            params.tolerance_floor_m,
            params.min_segment_pixels,
            params.break_reach_px,
            params.noise_correlation_factor,
        )
        splits.append(int(split_in.sum()))
        if incremental:
            check = split_in.copy()
            check[1:] |= split_in[:-1]
            check[:-1] |= split_in[1:]
    return (rows, starts, stops, table), splits


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("noise", [0.01, 0.02])
def test_break_rounds_testing_only_rows_next_to_a_split_change_nothing(seed, noise):
    """`plane_labels` tests again only the rows in or next to a row that split: a segment's
    test depends on itself and its neighbour rows' breaks, so the rounds give what testing
    every row in every round gives, bit for bit."""
    seg, params = _noisy_staircase_segments(seed, noise)
    every, splits = _break_rounds(seg, params, incremental=False)
    fewer, _ = _break_rounds(seg, params, incremental=True)
    assert splits[0] > 0  # the case is not trivial: the first round splits rows
    for a, b in zip(every, fewer, strict=True):
        np.testing.assert_array_equal(a, b)


def test_propagate_breaks_leaves_unchecked_rows_alone():
    seg, params = _noisy_staircase_segments(0, 0.02)
    height = seg.inv_depth.shape[0]
    args = (params.edge_window_px, params.break_sigma_factor, params.tolerance_floor_m)
    rest = (params.min_segment_pixels, params.break_reach_px, params.noise_correlation_factor)
    out = scanline.propagate_breaks(
        seg.inv_depth, seg.x, seg.sigma, seg.rows, seg.starts, seg.stops, seg.table,
        np.zeros(height, np.bool_), *args, *rest,
    )  # fmt: skip
    for a, b in zip(out[:4], (seg.rows, seg.starts, seg.stops, seg.table), strict=True):
        np.testing.assert_array_equal(a, b)
    assert not out[4].any()


def _pixel_order_moments(inv_depth, x, y, labels, n_planes):
    """`plane_fits`' sums added pixel by pixel in row-major order (Python floats: IEEE doubles)."""
    sums = [[0.0] * 10 for _ in range(n_planes)]
    for r in range(labels.shape[0]):
        for c in range(labels.shape[1]):
            p = labels[r, c]
            if p < 0:
                continue
            xv, yv, z = float(x[c]), float(y[r]), float(inv_depth[r, c])
            terms = (1.0, xv, yv, xv * xv, xv * yv, yv * yv, z, xv * z, yv * z, z * z)
            for k in range(10):
                sums[p][k] += terms[k]
    return np.array(sums).reshape(n_planes, 10)


def test_plane_fits_run_sums_are_the_pixel_order_sums():
    """Runs of one label summed in registers: the same sums as pixel by pixel, bit for bit."""
    rng = np.random.default_rng(3)
    labels = _blocky_labels(rng)
    height, width = labels.shape
    inv_depth = rng.uniform(0.2, 2.0, size=(height, width))
    x = rng.normal(size=width)
    y = rng.normal(size=height)
    n_planes = np.int64(3)
    planes, counts = scanline.plane_fits(inv_depth, x, y, labels, n_planes)
    sums = _pixel_order_moments(inv_depth, x, y, labels, 3)
    np.testing.assert_array_equal(counts, sums[:, 0].astype(np.int64))
    for p in range(3):
        expected = np.full(13, np.nan)
        if _solve_plane(sums[p], expected):
            np.testing.assert_array_equal(planes[p], expected)


def test_segment_and_horizontal_sums_are_the_pixel_order_sums():
    seg, _ = _noisy_staircase_segments(1, 0.01)
    out = scanline.segment_sums(seg.inv_depth, seg.x, seg.y, seg.rows, seg.starts, seg.stops)
    rng = np.random.default_rng(0)
    height, width = seg.inv_depth.shape
    points = rng.normal(size=(height, width, 3))
    sigma_z = rng.uniform(0.001, 0.01, size=(height, width))
    hsums = scanline.horizontal_sums(points, sigma_z, seg.rows, seg.starts, seg.stops, 1.5)
    for i in range(0, seg.rows.shape[0], 7):
        r = int(seg.rows[i])
        yv = float(seg.y[r])
        expected = [0.0] * 20
        expected_h = [0.0] * 6
        for c in range(seg.starts[i], seg.stops[i]):
            z, xv = float(seg.inv_depth[r, c]), float(seg.x[c])
            w = 1.0 / (z * z * z * z)
            terms = (1.0, xv, yv, xv * xv, xv * yv, yv * yv, z, xv * z, yv * z, z * z)
            for k in range(10):
                expected[k] += terms[k]
            weighted = (w, w * xv, w * yv, w * xv * xv, w * xv * yv, w * yv * yv, w * z)
            weighted += (w * xv * z, w * yv * z, w * z * z)
            for k in range(10):
                expected[10 + k] += weighted[k]
            wh = 1.0 / (1.5 * float(sigma_z[r, c]) * float(sigma_z[r, c]))
            zh = float(points[r, c, 2])
            h_terms = (wh, wh * zh, wh * zh * zh, 1.0, wh * points[r, c, 0], wh * points[r, c, 1])
            for k in range(6):
                expected_h[k] += float(h_terms[k])
        np.testing.assert_array_equal(out[i], expected)
        np.testing.assert_array_equal(hsums[i], expected_h)
