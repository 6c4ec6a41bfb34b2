"""The tilt correction's and the segmentation's bookkeeping kernels against the numpy they replace.

Each reference below is the numpy code the kernel replaced (mapper/tilt_filter.py,
mapper/segmentation.py at c9e53c9); the kernels must give the same bits, and known answers on
hand-computed planes.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from mapper import scanline, tilt_kernels
from mapper.segmentation import _normal_sigma_deg, _unit_normals


def _numpy_turn(points, floor_ids, floor_heights, turn, origin, n_floors):
    turned = (points - origin) @ turn.T + origin
    dz = turned[:, 2] - points[:, 2]
    in_floor = np.flatnonzero(floor_ids >= 0)
    region = floor_ids[in_floor]
    counts = np.bincount(region, minlength=n_floors)
    region_dz = np.bincount(region, weights=dz[in_floor], minlength=n_floors) / np.maximum(
        counts, 1
    )
    heights = floor_heights.copy()
    heights[in_floor] += region_dz[region]
    return turned, heights, region_dz


def _rotation(rng):
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    return q if np.linalg.det(q) > 0 else -q


@pytest.mark.parametrize("n", [1, 2, 3, 7, 64, 1000, 6336])
def test_turn_points_is_numpys(n):
    rng = np.random.default_rng(n)
    points = rng.normal(size=(n, 3)) * 2.0
    floor_ids = rng.integers(-1, 4, n)
    floor_heights = np.where(floor_ids >= 0, rng.normal(size=n), np.nan)
    turn = _rotation(rng)
    origin = rng.normal(size=3)
    expected = _numpy_turn(points, floor_ids, floor_heights, turn, origin, 5)
    got = tilt_kernels.turn_points(points, floor_ids, floor_heights, turn, origin, 5)
    for a, b in zip(expected, got, strict=True):
        assert np.array_equal(a, b, equal_nan=True)
    assert got[2][4] == 0.0  # a region without points does not move


def test_turn_points_known_answer():
    # A quarter turn about z through (1, 0, 0): (2, 0, 0.5) → (1, 1, 0.5); a tilt about x
    # lifts a floor point ahead of the origin: region height moves by its points' mean dz.
    quarter = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    points = np.array([[2.0, 0.0, 0.5]])
    turned, _, _ = tilt_kernels.turn_points(
        points, np.array([-1]), np.array([np.nan]), quarter, np.array([1.0, 0.0, 0.0]), 0
    )
    assert np.allclose(turned, [[1.0, 1.0, 0.5]], atol=1e-15)
    angle = 0.01
    tilt = np.array(
        [
            [1.0, 0.0, 0.0],
            [0.0, math.cos(angle), -math.sin(angle)],
            [0.0, math.sin(angle), math.cos(angle)],
        ]
    )
    points = np.array([[0.0, 1.0, 0.0], [0.0, 3.0, 0.0]])
    _, heights, region_dz = tilt_kernels.turn_points(
        points, np.array([0, 0]), np.array([0.0, 0.0]), tilt, np.zeros(3), 1
    )
    assert region_dz[0] == pytest.approx(2.0 * math.sin(angle), rel=1e-12)
    assert np.allclose(heights, region_dz[0], rtol=1e-12)


@pytest.mark.parametrize("n", [1, 2, 3, 7, 1000, 6336])
def test_believed_points_are_numpys(n):
    # segment_depth's numpy expression before the kernel: gathers, broadcast, matrix product.
    rng = np.random.default_rng(100 + n)
    height, width = 72, 88
    pixels = height * width
    depth = rng.uniform(0.3, 5.0, pixels)
    rays = np.stack(
        [rng.uniform(-0.4, 0.4, pixels), rng.uniform(-0.3, 0.3, pixels), np.ones(pixels)], axis=1
    )
    pixel_index = np.sort(rng.choice(pixels, n, replace=False))
    rotation = _rotation(rng)
    pivot = rng.normal(size=3)
    expected = (depth[pixel_index][:, None] * rays[pixel_index]) @ rotation.T + pivot
    got = tilt_kernels.believed_points(depth, pixel_index, rays, rotation, pivot)
    assert got.tobytes() == expected.tobytes()


def test_believed_points_known_answer():
    # A camera 0.9 m up looking straight down (optical z = robot -z, optical x = robot -y):
    # the pixel with ray (0.5, 0, 1) at depth 2 m lies 2 m below and 1 m to the right.
    rotation = np.array([[0.0, -1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
    rays = np.array([[0.0, 0.0, 1.0], [0.5, 0.0, 1.0]])
    got = tilt_kernels.believed_points(
        np.array([1.0, 2.0]), np.array([1]), rays, rotation, np.array([0.0, 0.0, 0.9])
    )
    assert np.allclose(got, [[0.0, -1.0, -1.1]], atol=1e-15)


def _numpy_variances(points, plane_ids, counts, pivot, normals, rms, extents, min_noise, c):
    used = np.flatnonzero(plane_ids >= 0)
    ids = plane_ids[used]
    sums = np.stack(
        [np.bincount(ids, weights=points[used, j], minlength=len(counts)) for j in range(3)],
        axis=1,
    )
    rays = sums / np.maximum(counts, 1)[:, None] - pivot
    rays /= np.linalg.norm(rays, axis=1)[:, None]
    minor, major = extents[:, 0], extents[:, 1]
    perpendicular = np.maximum(rms, min_noise) * np.abs(np.einsum("pi,pi->p", rays, normals))
    with np.errstate(divide="ignore", invalid="ignore"):
        return c * perpendicular**2 * 12.0 / counts * (1.0 / minor**2 + 1.0 / major**2)


@pytest.mark.parametrize("n_planes", [1, 2, 5, 9, 30, 200])
def test_tilt_variances_are_numpys(n_planes):
    rng = np.random.default_rng(100 + n_planes)
    n = 3000
    points = rng.normal(size=(n, 3)) + np.array([0.0, 2.0, 0.0])
    plane_ids = rng.integers(-1, n_planes, n)
    counts = np.bincount(plane_ids[plane_ids >= 0], minlength=n_planes)
    normals = rng.normal(size=(n_planes, 3)) * [0.02, 0.02, 1.0]
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    rms = np.abs(rng.normal(size=n_planes)) * 1e-3
    rms[0] = np.nan if n_planes > 3 else rms[0]
    extents = np.sort(np.abs(rng.normal(size=(n_planes, 2))), axis=1)
    pivot = np.array([0.1, -0.2, 0.9])
    for correlation in (1.0, 3.0):
        expected = _numpy_variances(
            points, plane_ids, counts, pivot, normals, rms, extents, 5e-4, correlation
        )
        consensus_z = math.cos(math.radians(1.5))
        variance, consensus, information = tilt_kernels.tilt_variances(
            points, plane_ids, counts, pivot, normals, rms, extents, 5e-4, correlation, 20, 0.08,
            consensus_z,
        )  # fmt: skip
        assert np.array_equal(variance, expected, equal_nan=True)
        want = (
            (np.abs(normals[:, 2]) >= consensus_z)
            & (counts >= 20)
            & (extents[:, 0] >= 0.08)
            & np.isfinite(expected)
            & (expected > 0.0)
        )
        assert np.array_equal(consensus, want)
        assert information == (1.0 / expected[want]).sum()


def _numpy_unit_normals(plane_table, rotation):
    normals_camera = plane_table[:, :3] / np.linalg.norm(plane_table[:, :3], axis=1)[:, None]
    normals = normals_camera @ rotation.T
    normals *= np.where(normals[:, 2] < 0.0, -1.0, 1.0)[:, None]
    return normals_camera, normals


def _numpy_normal_sigma_deg(plane_table, correlation, min_inv_sigma):
    coefficients = plane_table[:, :3]
    norm = np.linalg.norm(coefficients, axis=1)
    unit = coefficients / norm[:, None]
    variance = np.maximum(plane_table[:, 3], min_inv_sigma**2)
    covariance = (correlation * variance)[:, None, None] * plane_table[:, 4:13].reshape(-1, 3, 3)
    along = np.einsum("pi,pij,pj->p", unit, covariance, unit)
    across = np.maximum(np.trace(covariance, axis1=1, axis2=2) - along, 0.0)
    sigma = np.degrees(np.sqrt(across) / norm)
    return np.where(np.isfinite(sigma), sigma, np.inf)


def _plane_table(rng, n_planes):
    table = rng.normal(size=(n_planes, 13)) * 10.0 ** rng.integers(-3, 3, (n_planes, 13))
    m = rng.normal(size=(n_planes, 3, 3))
    table[:, 4:13] = (m @ m.transpose(0, 2, 1)).reshape(n_planes, 9) * 1e-3
    table[:, 3] = np.abs(table[:, 3])
    if n_planes > 2:
        table[0, :3] = 0.0  # degenerate: NaN normal, inf sigma
        table[1, 3] = np.nan
    return table


@pytest.mark.parametrize("n_planes", [0, 1, 2, 3, 17, 40])
def test_normal_kernels_are_numpys(n_planes):
    rng = np.random.default_rng(200 + n_planes)
    for _ in range(20):
        table = _plane_table(rng, n_planes)
        rotation = _rotation(rng)
        min_inv_sigma = np.abs(rng.normal(size=n_planes)) * 1e-2
        with np.errstate(invalid="ignore", divide="ignore"):
            expected = _numpy_unit_normals(table, rotation)
            for correlation in (1.0, 3.0):
                assert np.array_equal(
                    _normal_sigma_deg(table, correlation, min_inv_sigma),
                    _numpy_normal_sigma_deg(table, correlation, min_inv_sigma),
                )
        got = _unit_normals(table, rotation)
        for a, b in zip(expected, got, strict=True):
            assert np.array_equal(a, b, equal_nan=True)


def test_normal_kernels_known_answer():
    # The ground 0.9 m below a camera looking straight down (x right, y down, z forward =
    # robot -z): 1/d = 0·x + 0·y + 1/0.9, normal (0, 0, 1) in the camera, (0, 0, 1) in the
    # robot frame after turning up. Its direction's std from a covariance diag(a, b, c) of
    # (A, B, C): sqrt(a + b)/|C| [rad] (the part across the normal), at least min_inv_sigma.
    down = np.array([[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]])
    table = np.zeros((1, 13))
    table[0, 2] = 1.0 / 0.9
    table[0, 3] = 4e-6
    table[0, 4:13] = np.diag([2.0, 3.0, 5.0]).ravel()
    camera, robot = _unit_normals(table, down)
    assert np.array_equal(camera, [[0.0, 0.0, 1.0]])
    assert np.array_equal(robot, [[0.0, 0.0, 1.0]])
    sigma = _normal_sigma_deg(table, 1.0, np.array([0.0]))
    assert sigma[0] == pytest.approx(math.degrees(math.sqrt(4e-6 * 5.0) * 0.9), rel=1e-12)
    floored = _normal_sigma_deg(table, 3.0, np.array([1e-2]))
    assert floored[0] == pytest.approx(math.degrees(math.sqrt(3.0 * 1e-4 * 5.0) * 0.9), rel=1e-12)


def test_renumber_planes_is_numpys():
    rng = np.random.default_rng(7)
    height, width, n_planes = 24, 32, 9
    grown = rng.integers(-2, n_planes, (height, width))
    labels = np.where(rng.random((height, width)) < 0.2, rng.integers(0, n_planes), grown)
    labels[grown == -2] = -2
    pixel_index = np.flatnonzero(labels != -2)
    keep = rng.random(n_planes) < 0.6
    new_id = np.full(n_planes + 2, -1, dtype=np.int64)
    new_id[:n_planes][keep] = np.arange(int(keep.sum()))
    new_id[-2] = -2
    expected_labels = np.take(new_id, labels)
    expected_ids = np.take(expected_labels, pixel_index)
    got = scanline.renumber_planes(labels, grown, pixel_index, keep)
    assert np.array_equal(got[0], expected_labels)
    assert np.array_equal(got[1], np.take(new_id, grown))
    assert np.array_equal(got[2], expected_ids)
    assert np.array_equal(got[3], np.take(new_id, np.take(grown, pixel_index)))
    counts = np.bincount(expected_ids + 1, minlength=int(keep.sum()) + 1)[1:]
    assert np.array_equal(got[4], counts)


def test_level_heights_and_floor_verdict_are_numpys():
    rng = np.random.default_rng(8)
    n_floors, n_segments = 6, 40
    floor_of_segment = rng.integers(-1, n_floors - 1, n_segments)  # the last region: none
    sums = np.abs(rng.normal(size=(n_segments, 6)))
    member = floor_of_segment >= 0
    with np.errstate(invalid="ignore"):
        expected = np.bincount(
            floor_of_segment[member], weights=sums[member, 1], minlength=n_floors
        ) / np.bincount(floor_of_segment[member], weights=sums[member, 0], minlength=n_floors)
    assert np.array_equal(
        scanline.level_heights(floor_of_segment, sums, n_floors), expected, equal_nan=True
    )
    n = 200
    counts = rng.integers(0, 60, n)
    segments = rng.integers(0, 12, n)
    extents = np.abs(rng.normal(size=(n, 2))) * 0.1
    slope = np.abs(rng.normal(size=n)) * 0.1
    rms = np.abs(rng.normal(size=n)) + 0.3
    chi2 = np.abs(rng.normal(size=n))
    max_slope = math.tan(math.radians(5.0))
    for max_rms, max_chi2 in ((1.05, 1.0), (0.0, 1.0), (1.05, 0.0)):
        dof = np.maximum(segments - 3, 1)
        want = (
            (counts >= 20)
            & (segments >= 3)
            & (extents[:, 0] >= 0.08)
            & (slope <= max_slope)
            & ((max_rms == 0.0) | (rms <= max_rms))
            & (
                (max_chi2 == 0.0)
                | (chi2 <= max_chi2 * np.minimum(1.0 + 3.0 * np.sqrt(2.0 / dof), 2.5))
            )
        )
        got = scanline.floor_verdict(
            counts, segments, extents, slope, rms, chi2, 20, 0.08, max_slope, max_rms, max_chi2
        )
        assert np.array_equal(got, want)
