"""`scanline.grow_planes` reuses a seed's first score: the same planes as scoring every seed again.

`grow_planes` scores every segment's best seed triple once, then seeds planes best-first; a
seed whose picked segments a plane has taken since is scored again, the others keep their first
score (`_best_seed`'s ``tried``). The reference below is the loop as it was before (every seed
scored again when its turn comes), run in Python on the same compiled helpers: the planes must
be the same, segment for segment, on noisy staircase frames where planes take segments from
under many seeds.
"""

from __future__ import annotations

import numpy as np
import pytest
from scanline_inputs import row_segments
from synthetic_depth import add_depth_noise, look_down_camera, render_scene, staircase

from mapper import scanline
from mapper.intrinsics import PinholeIntrinsics
from mapper.scanline.planes import _add_segment, _best_seed, _segment_fits, _solve_plane
from mapper.scanline.regions import _overlap, _row_index
from mapper.segmentation import SegmentationParams

INTRINSICS = PinholeIntrinsics.from_fov(88, 72, 47.0, 39.0)
PARAMS = SegmentationParams()


def _segments(noise: float, seed: int, yaw_deg: float):
    """`grow_planes`' arguments for a staircase frame with depth noise (a fraction of range)."""
    camera = look_down_camera((0.1, 0.2, 0.9), 35.0, yaw_deg=yaw_deg, roll_deg=3.0)
    scene = render_scene(INTRINSICS, camera, staircase())
    depth_m = add_depth_noise(scene.depth_m, noise, np.random.default_rng(seed))
    return row_segments(depth_m, INTRINSICS, PARAMS).grow_planes_args(PARAMS)


def _rescoring_grow_planes(inv_depth, x, y, rows, starts, stops, table, sums, *factors):
    """`grow_planes` scoring every seed again when its turn comes (the loop before the reuse)."""
    grow_factor, rms_factor, tol0, seed_min_pixels = factors
    height = inv_depth.shape[0]
    n_seg = rows.shape[0]
    plane_of = np.full(n_seg, -1, np.int64)
    row_first = _row_index(rows, height)
    work = np.zeros(20), np.zeros(13), np.full(3, -1, np.int64), np.full(3, -1, np.int64)
    tried = np.full((n_seg, 9), -1, np.int64)

    def best_seed(s: int) -> float:
        segment_sums, plane, members, chosen = work
        return _best_seed(
            s,
            (sums, x, y, rows, starts, stops, table, row_first),
            plane_of,
            (grow_factor, rms_factor, tol0, seed_min_pixels),
            (members, segment_sums, plane, chosen, tried),
        )

    scores = np.array([best_seed(s) for s in range(n_seg)])
    n_planes = 0
    for s in np.argsort(scores, kind="mergesort"):
        if scores[s] > 1.0:
            break
        if plane_of[s] >= 0 or best_seed(int(s)) > 1.0:
            continue
        plane_sums, plane, members, _ = work
        plane_sums[:] = 0.0
        queue = []
        for t in members:
            plane_of[t] = n_planes
            queue.append(int(t))
            _add_segment(plane_sums, sums, t)
        _solve_plane(plane_sums, plane)
        for q in queue:  # grows while it is walked: breadth first
            for rr in (rows[q] - 1, rows[q], rows[q] + 1):
                if not 0 <= rr < height:
                    continue
                gap = 1 if rr == rows[q] else 0
                for t in range(row_first[rr], row_first[rr + 1]):
                    if plane_of[t] >= 0 or not _overlap(
                        starts[q], stops[q], starts[t], stops[t], gap
                    ):
                        continue
                    if _segment_fits(
                        plane, sums, table, t, x, y[rr], starts[t], stops[t],
                        grow_factor, rms_factor, tol0,
                    ):  # fmt: skip
                        plane_of[t] = n_planes
                        queue.append(t)
                        _add_segment(plane_sums, sums, t)
                        _solve_plane(plane_sums, plane)
        n_planes += 1
    return plane_of


@pytest.mark.parametrize(
    ("noise", "seed", "yaw_deg"),
    [(0.0, 0, 0.0), (0.005, 1, 10.0), (0.01, 2, -15.0), (0.02, 3, 25.0), (0.02, 4, 0.0)],
)
def test_reused_scores_give_the_planes_of_rescoring_every_seed(noise, seed, yaw_deg):
    args = _segments(noise, seed, yaw_deg)
    planes = scanline.grow_planes(*args)
    assert planes.max() >= 3  # the ground and the treads at least: the reuse was exercised
    np.testing.assert_array_equal(planes, _rescoring_grow_planes(*args))


def test_tried_lists_the_picked_segments_beside_the_seed():
    """Three rows of one long segment each: the only triples are the three row windows."""
    height, width = 5, 40
    inv_depth = np.full((height, width), 0.5)  # a fronto-parallel wall 2 m away
    x = (np.arange(width) - width / 2) / 50.0
    y = (np.arange(height) - height / 2) / 50.0
    rows = np.arange(height, dtype=np.int64)
    starts = np.zeros(height, np.int64)
    stops = np.full(height, width, np.int64)
    sums = scanline.segment_sums(inv_depth, x, y, rows, starts, stops)
    table = np.zeros((height, 3))  # each row's line 1/d = 0.5 + 0·x, its depth sigma [m]
    table[:, 0] = 0.5
    table[:, 2] = 1e-4
    row_first = _row_index(rows, height)
    plane_of = np.full(height, -1, np.int64)
    members = np.full(3, -1, np.int64)
    tried = np.full((height, 9), -7, np.int64)
    segments = (sums, x, y, rows, starts, stops, table, row_first)
    limits = (3.0, 3.0, 0.002, 4)
    work = (members, np.zeros(20), np.zeros(13), np.full(3, -1, np.int64), tried)
    score = _best_seed(2, segments, plane_of, limits, work)
    assert score <= 1.0
    # Triples (2, 3, 4), (1, 2, 3), (0, 1, 2): s itself is not listed (it is free by the caller).
    np.testing.assert_array_equal(tried[2], [-1, 3, 4, 1, -1, 3, 0, 1, -1])
    np.testing.assert_array_equal(tried[[0, 1, 3, 4]], -7)  # only s's row is written
    # Once a picked segment is taken, the triples through it are gone: a different answer.
    plane_of[4] = 0
    _best_seed(2, segments, plane_of, limits, work)
    np.testing.assert_array_equal(tried[2], [-1, 3, -1, 1, -1, 3, 0, 1, -1])
