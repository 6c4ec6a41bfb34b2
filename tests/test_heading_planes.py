"""Point-to-plane refinement of the heading (`mapper.heading_planes`): normals, known yaw errors."""

import math

import numpy as np
import pytest

from mapper.heading_planes import keyframe_normals, refine_heading

DEG = math.pi / 180.0


def _wall(start, end, heights, spacing=0.01):
    """Points of a vertical wall from ``start`` to ``end`` (x, y) [m] at the given heights."""
    length = math.dist(start, end)
    t = np.arange(0.0, length + 1e-9, spacing) / length
    xy = np.asarray(start) + np.outer(t, np.subtract(end, start))
    return np.array([[x, y, z] for x, y in xy for z in heights])


def test_normals_of_a_wall_are_across_it_and_a_blob_or_a_lone_point_has_none():
    wall = _wall((0.0, 1.0), (1.0, 1.0), (0.1, 0.12, 0.14))  # along x: normal ±y
    rng = np.random.default_rng(3)
    blob = rng.uniform(-0.03, 0.03, size=(40, 3)) + np.array([2.0, 2.0, 0.1])  # round in x, y
    lone = np.array([[5.0, 5.0, 0.1]])
    points = np.vstack([wall, blob, lone])
    normals, weights = keyframe_normals(points[:, :2], points[:, 2], 0.06)
    n_wall = len(wall)
    np.testing.assert_allclose(np.abs(normals[:n_wall, 1]), 1.0, atol=1e-9)
    np.testing.assert_allclose(normals[:n_wall, 0], 0.0, atol=1e-9)
    np.testing.assert_allclose(weights[:n_wall], 1.0, atol=1e-9)  # a line: planarity 1
    assert np.all(weights[n_wall : n_wall + len(blob)] < 0.8 + 1e-9)  # refused as no surface
    assert weights[-1] == 0.0 and np.all(normals[-1] == 0.0)


def _keyframes(world, cameras, yaw_error_rad):
    """Each camera's view of ``world`` believed turned by ``-yaw_error`` (robot yaw 0)."""
    c, s = math.cos(-yaw_error_rad), math.sin(-yaw_error_rad)
    turn = np.array([[c, -s], [s, c]])
    offsets, z, keyframe_of, normals, weights = [], [], [], [], []
    for k, camera in enumerate(cameras):
        seen = np.linalg.norm(world[:, :2] - camera, axis=1) < 3.0
        local = (world[seen, :2] - camera) @ turn.T
        n, w = keyframe_normals(local, world[seen, 2], 0.06)
        offsets.append(local)
        z.append(world[seen, 2])
        keyframe_of.append(np.full(int(seen.sum()), k))
        normals.append(n)
        weights.append(w)
    return (
        np.vstack(offsets),
        np.concatenate(z),
        np.vstack(normals),
        np.concatenate(weights),
        np.concatenate(keyframe_of).astype(np.int64),
        np.asarray(cameras, dtype=np.float64),
        np.zeros(len(cameras)),
    )


def _refine(data, start_rad):
    correction, information, _ = refine_heading(
        *data, start_rad, 0.08, 0.02, 0.15, 8, math.radians(0.005), math.radians(2.0)
    )
    return correction, information


def test_a_yaw_error_is_recovered_from_walls_across_the_path():
    # Cameras walk along x; a wall along x (beside the path, normal y) shows a yaw error as a
    # sideways shift between views (the error times the baseline); one across the path
    # (normal x) slides along itself and only adds its density. 1.5° is recovered from 0.5°.
    world = np.vstack(
        [
            _wall((1.0, 1.0), (2.6, 1.0), (0.1, 0.14, 0.18)),
            _wall((2.8, -0.6), (2.8, 0.9), (0.1, 0.14, 0.18)),
        ]
    )
    data = _keyframes(world, [(0.0, 0.0), (0.4, 0.0), (0.8, 0.0)], 1.5 * DEG)
    correction, information = _refine(data, 0.5 * DEG)
    assert abs(correction / DEG - 1.5) < 0.02
    assert information > 0.0


def test_a_wall_faced_head_on_shows_no_yaw_and_leaves_the_start():
    # Only the wall across the path, longer than the view: a yaw error slides it along itself,
    # every residual's slope is 0, and the start comes back unchanged.
    world = _wall((2.8, -5.0), (2.8, 5.0), (0.1, 0.14, 0.18))
    data = _keyframes(world, [(0.0, 0.0), (0.4, 0.0), (0.8, 0.0)], 1.5 * DEG)
    correction, information = _refine(data, 0.5 * DEG)
    assert correction == 0.5 * DEG and information == 0.0


def test_a_refinement_that_would_move_beyond_the_bound_is_refused():
    # The same scene as the recovered 1.5°, from 0.5° with at most 0.5° of shift allowed: the
    # fit would move 1°, so the start comes back.
    world = np.vstack(
        [
            _wall((1.0, 1.0), (2.6, 1.0), (0.1, 0.14, 0.18)),
            _wall((2.8, -0.6), (2.8, 0.9), (0.1, 0.14, 0.18)),
        ]
    )
    data = _keyframes(world, [(0.0, 0.0), (0.4, 0.0), (0.8, 0.0)], 1.5 * DEG)
    correction, information, rms_m = refine_heading(
        *data, 0.5 * DEG, 0.08, 0.02, 0.15, 8, math.radians(0.005), math.radians(0.5)
    )
    assert correction == 0.5 * DEG and information == 0.0 and rms_m == 0.0


def test_the_tiered_search_finds_the_same_nearest_points_as_the_whole_radius():
    # Dense clusters (a surface seen by many keyframes), sparse points and exact ties: for every
    # point the NEAREST nearest within MATCH_M (ties by index, nearest first) from the widening
    # search swept in key order are those of a brute-force search over the whole radius,
    # whichever tier stopped it.
    from mapper.heading_planes import MATCH_M, MATCH_TIERS, NEAREST, _nearest_matches, _voxel_order

    rng = np.random.default_rng(11)
    dense = rng.normal(0.0, 0.02, size=(600, 3)) + np.array([1.0, 1.0, 0.2])
    sparse = rng.uniform(0.0, 0.5, size=(200, 3))
    grid = np.round(rng.uniform(0.0, 0.3, size=(100, 3)) / 0.02) * 0.02  # exact ties
    far = rng.uniform(-3.0, -2.0, size=(20, 3))  # alone: no neighbour but itself
    points = np.vstack([dense, sparse, grid, far])
    x, y, z = (np.ascontiguousarray(points[:, k]) for k in range(3))
    order, keys, sorted_xyz = _voxel_order(x, y, z, MATCH_M / MATCH_TIERS[-1])
    matches = np.full((len(points), NEAREST), -1, dtype=np.int64)
    n_matches = np.full(len(points), -1, dtype=np.int64)
    r2 = MATCH_M * MATCH_M
    _nearest_matches(order, keys, sorted_xyz, r2, matches, n_matches)
    fewer = 0
    for i in range(len(points)):
        d2 = ((points - points[i]) ** 2).sum(axis=1)
        inside = np.flatnonzero(d2 <= r2)
        want = [j for _, j in sorted(zip(d2[inside], inside, strict=True))[:NEAREST]]
        assert n_matches[i] == len(want), i
        assert list(matches[i, : n_matches[i]]) == want, i
        fewer += len(want) < NEAREST
    assert fewer >= 20  # the far points (and some sparse ones) have fewer than NEAREST


@pytest.mark.parametrize("reach", [1, 2, 4])
def test_a_neighbour_search_lists_every_point_within_its_radius_in_voxel_order(reach):
    # A wall (points stacked over many layers, so the rows of columns it scans hold voxels
    # outside the z window), a cluster, scattered and negative coordinates: the search, every
    # point taken in key order (its rows' forward pointers), lists exactly the points within the
    # radius, in the order of the sorted voxel keys — the list a binary search per column gave
    # (session 49 scans a row of columns after one search, session 58 from forward pointers).
    from mapper.heading_planes import _KEY_RANGE, _swept_neighbours, _voxel_order

    rng = np.random.default_rng(5)
    wall = np.column_stack(
        [np.full(300, 0.40), rng.uniform(-0.2, 0.2, 300), rng.uniform(0.0, 0.6, 300)]
    )
    cluster = rng.normal(0.0, 0.015, size=(200, 3)) + np.array([0.38, 0.0, 0.3])
    scattered = rng.uniform(-0.5, 0.5, size=(300, 3))
    points = np.vstack([wall, cluster, scattered])
    x, y, z = (np.ascontiguousarray(points[:, k]) for k in range(3))
    radius = 0.06
    order, keys, sorted_xyz = _voxel_order(x, y, z, radius / reach)
    # The points in key order, and each key the point's voxel (the search reads it there).
    cells = np.floor(points / (radius / reach)).astype(np.int64) + _KEY_RANGE // 2
    field = _KEY_RANGE - 1
    decoded = np.column_stack([keys >> 40, (keys >> 20) & field, keys & field])
    assert np.array_equal(sorted_xyz, points[order]) and np.array_equal(decoded, cells[order])
    found_j = np.empty(len(points), dtype=np.int64)
    found_d2 = np.empty(len(points))
    pointers = np.zeros(2 * reach + 1, dtype=np.int64)
    reach = np.int64(reach)
    for q in range(len(points)):
        count = _swept_neighbours(
            q, sorted_xyz, keys, radius**2, found_j, found_d2, reach, pointers, np.int64(0),
        )  # fmt: skip
        i = order[q]
        d2 = ((points - points[i]) ** 2).sum(axis=1)
        want = [int(j) for j in order if d2[j] <= radius**2]
        assert order[found_j[:count]].tolist() == want, i
        assert np.array_equal(found_d2[:count], d2[want])
        assert np.array_equal(found_d2[:count], d2[want])
