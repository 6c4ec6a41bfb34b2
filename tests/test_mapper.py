"""FloorObstacleMapper end to end: the paper's Fig. 5, scrolling, bad input, geometry."""

import tracemalloc

import numpy as np
import pytest

from mapper import (
    AveragingMap,
    CellType,
    FloorObstacleMapper,
    GridGeometry,
    MapperParams,
    PinholeIntrinsics,
)
from mapper.synthetic import Box, camera_rays_world, cast_frame

# The expected values below were worked out for these thresholds (the pre-tuning defaults).
P = MapperParams(p_occ=0.75, eps_m=0.02, nu=0.9, p_sense=0.7, p_min=0.12, p_max=0.97)
INTR = PinholeIntrinsics.from_fov(88, 72, 47.0, 39.0)
RAYS = camera_rays_world(INTR, yaw_deg=0.0, pitch_down_deg=30.0)
CAMERA = np.array([0.0, 0.0, 0.55])
BOX = Box((1.2, 0.0), (0.3, 0.3, 0.07))  # a flat box: walkable top at 0.07 m


def frame(rng, boxes, camera=CAMERA):
    pts, h = cast_frame(camera, RAYS, boxes, noise_z_m=0.005, rng=rng)
    return pts, h, camera


def footprint(geometry, box, shrink_cells=1):
    """Slices of the cells lying fully inside the box footprint, shrunk by some cells."""
    lo = box.lower[:2] + shrink_cells * geometry.cell_m
    hi = box.upper[:2] - shrink_cells * geometry.cell_m
    (ix0, iy0), (ix1, iy1) = geometry.cell_of(np.array([lo, hi]))[0]
    return slice(ix0 + 1, ix1), slice(iy0 + 1, iy1)


def test_fig5_box_removed_fog_forgets_averaging_keeps():
    rng = np.random.default_rng(5)
    fog, avg = FloorObstacleMapper(P), AveragingMap(P)
    for _ in range(10):
        pts, h, cam = frame(rng, [BOX])
        fog.update(pts, h, cam)
        avg.update(pts, h, cam)
    area = footprint(fog.geometry, BOX)
    types, heights = fog.fog()
    # (b) both maps show the box top as floor at 0.07 m
    assert np.all(types[area] == CellType.FLOOR)
    assert np.allclose(heights[area], 0.07, atol=0.003)
    assert np.allclose(avg.floor()[area], 0.07, atol=0.003)
    frames_to_ground = None
    for k in range(1, 11):
        pts, h, cam = frame(rng, [])  # box removed, camera still looking
        fog.update(pts, h, cam)
        avg.update(pts, h, cam)
        types, heights = fog.fog()
        ground = (types[area] == CellType.FLOOR) & (np.abs(heights[area]) < 0.006)
        if frames_to_ground is None and np.all(ground):
            frames_to_ground = k
    # (d) three misses take a saturated cell below p_occ; the ground cell needs two hits
    assert frames_to_ground is not None and frames_to_ground <= 4
    assert np.all(np.abs(fog.floor()[area]) < 0.006)
    # (c) after as many frames without the box as with it the averages sit halfway
    _, avg_heights = avg.fog()
    assert np.all(avg_heights[area] > 0.03)
    assert np.all(avg.floor()[area] > 0.03)


def test_box_slid_slowly_no_intermediate_floor_heights():
    rng = np.random.default_rng(6)
    fog, avg = FloorObstacleMapper(P), AveragingMap(P)
    low, high = P.eps_m, 0.07 - P.eps_m  # strictly between the ground and the box top
    intermediate_fog = 0
    for i in range(60):
        box = Box((1.2, -0.3 + 0.01 * i), (0.3, 0.3, 0.07))  # 1 cm per frame = 0.125 m/s
        pts, h, cam = frame(rng, [box])
        fog.update(pts, h, cam)
        avg.update(pts, h, cam)
        f = fog.floor()
        intermediate_fog += np.count_nonzero((f > low) & (f < high))
    assert intermediate_fog == 0
    a = avg.floor()
    assert np.count_nonzero((a > low) & (a < high)) > 20  # the baseline smears the box


def test_scroll_10m_content_stays_put_and_memory_flat():
    rng = np.random.default_rng(7)
    m = FloorObstacleMapper(P)
    landmark = Box((1.0, 0.2), (0.2, 0.2, 0.3), walkable=False)
    boxes = [landmark]
    for _ in range(3):
        m.update(*frame(rng, boxes))
    ix, iy = m.geometry.cell_of([[1.0, 0.2]])[0][0]
    assert m.fog()[0][ix, iy] == CellType.OBSTACLE
    arrays_before = [m._og, m._floor, m._fog_types]
    tracemalloc.start()
    robot_x = 0.0
    seen_landmark_at = []
    for step in range(1, 401):  # 10 m in 2.5 cm steps
        robot_x = 0.025 * step
        floor_before, types_before = m.floor(), m.fog()[0]
        origin_before = m.geometry.origin_ix
        sx, sy = m.recenter(robot_x, 0.0)
        assert sy == 0 and m.geometry.origin_ix == origin_before + sx
        # world-anchored: every cell that stays on the grid keeps its content
        if sx:
            assert np.array_equal(m.floor()[: P.nx - sx], floor_before[sx:], equal_nan=True)
            assert np.array_equal(m.fog()[0][: P.nx - sx], types_before[sx:])
            assert np.all(np.isnan(m.floor()[P.nx - sx :]))
            assert np.all(m.occupancy_levels()[P.nx - sx :] == 128)
        lx = m.geometry.cell_of([[1.0, 0.2]])
        if lx[1][0]:
            seen_landmark_at.append(m.fog()[0][lx[0][0, 0], lx[0][0, 1]])
        if step % 20 == 0:
            cam = np.array([robot_x, 0.0, 0.55])
            m.update(*frame(rng, [], cam))
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    assert m._og is arrays_before[0] and m._floor is arrays_before[1]
    assert peak < 2_000_000  # one grid copy at most (160 kB) plus per-frame buffers
    assert all(t == CellType.OBSTACLE for t in seen_landmark_at)  # until it left the grid
    assert 110 < len(seen_landmark_at) < 125  # it leaves the grid when the robot passes x≈3 m
    # the robot is in the central cell, the geometry moved by whole cells
    ix, iy = m.geometry.cell_of([[robot_x, 0.0]])[0][0]
    assert (ix, iy) == (P.nx // 2, P.ny // 2)
    assert m.geometry.origin_xy_m[0] == pytest.approx(m.geometry.origin_ix * P.cell_m)


def test_recenter_far_jump_resets():
    rng = np.random.default_rng(8)
    m = FloorObstacleMapper(P)
    m.update(*frame(rng, []))
    assert m.recenter(100.0, -50.0) != (0, 0)
    assert np.all(m.occupancy_levels() == 128) and np.all(np.isnan(m.floor()))
    assert np.all(m.fog()[0] == CellType.UNKNOWN)


def test_bad_points_dropped_and_counted():
    m = FloorObstacleMapper(P)
    pts = np.array(
        [
            [0.5, 0.0, 0.0],
            [np.nan, 0.0, 0.0],
            [0.5, np.inf, 0.0],
            [5.0, 0.0, 0.0],  # outside in x
            [0.5, 0.0, 0.7],  # above the grid
            [0.5, 0.0, -0.07],  # below the grid
        ]
    )
    r = m.update(pts, np.full(6, np.nan), CAMERA)
    assert (r.points_used, r.points_dropped_nonfinite, r.points_dropped_outside) == (1, 2, 3)


@pytest.mark.parametrize("points", [np.empty((0, 3)), np.full((5, 3), np.nan)])
def test_empty_or_all_nan_frame_changes_nothing(points):
    rng = np.random.default_rng(9)
    m = FloorObstacleMapper(P)
    m.update(*frame(rng, [BOX]))
    before = (m.occupancy_levels(), m.floor(), *m.fog())
    r = m.update(points, np.full(len(points), np.nan), CAMERA)
    assert r.affected_area is None and r.points_used == 0 and r.cells_updated == 0
    after = (m.occupancy_levels(), m.floor(), *m.fog())
    for a, b in zip(before, after, strict=True):
        assert np.array_equal(a, b, equal_nan=True)


@pytest.mark.parametrize(
    ("points", "heights", "origin", "message"),
    [
        (np.zeros((4, 2)), np.zeros(4), np.zeros(3), r"points must have shape \(N, 3\)"),
        (np.zeros(3), np.zeros(1), np.zeros(3), r"points must have shape \(N, 3\)"),
        (np.zeros((4, 3)), np.zeros(3), np.zeros(3), r"floor_heights must have shape \(N,\)"),
        (np.zeros((4, 3)), np.zeros(4), np.zeros(2), r"sensor_origin must have shape \(3,\)"),
        (np.zeros((4, 3)), np.zeros(4), [0, np.nan, 0], "sensor_origin must be finite"),
    ],
)
def test_wrong_shapes_raise_value_error(points, heights, origin, message):
    with pytest.raises(ValueError, match=message):
        FloorObstacleMapper(P).update(points, heights, origin)


def test_update_result_counts_floor_points():
    rng = np.random.default_rng(10)
    m = FloorObstacleMapper(P)
    r1 = m.update(*frame(rng, []))
    # first frame: ground cells only reach 0.70 <= p_occ: every floor point fails eq. 7
    assert r1.floor_points_used == 0 and r1.floor_points_rejected > 1000
    r2 = m.update(*frame(rng, []))
    assert r2.floor_points_used > 0.9 * (r2.floor_points_used + r2.floor_points_rejected)
    assert r2.affected_area is not None and r2.affected_area.cell_count > 100


def test_same_input_same_result_bit_for_bit():
    def run():
        rng = np.random.default_rng(11)
        m = FloorObstacleMapper(P)
        for i in range(5):
            m.update(*frame(rng, [Box((1.2, 0.05 * i), (0.3, 0.3, 0.07))]))
        return m.occupancy_levels(), m.floor(), *m.fog(), m.ceiling()

    for a, b in zip(run(), run(), strict=True):
        assert np.array_equal(a, b, equal_nan=True)


def test_geometry_cells_and_centres():
    g = GridGeometry.from_params(P, (0.0, 0.0))
    assert g.origin_xy_m == pytest.approx((-2.0, -2.0))
    idx, valid = g.cell_of(
        [
            [0.0, 0.0, 0.0],
            [-2.0, -2.0, -0.06],
            [1.999, 1.999, 0.579],
            [2.0, 0.0, 0.0],
            [0.0, 0.0, 0.581],
        ]
    )
    assert valid.tolist() == [True, True, True, False, False]
    assert idx[0].tolist() == [50, 50, 1] and idx[1].tolist() == [0, 0, 0]
    assert idx[2].tolist() == [99, 99, 15] and idx[3].tolist() == [-1, -1, -1]
    assert g.cell_center(50, 50, 1) == pytest.approx([0.02, 0.02, 0.0])
    centres = g.cell_centers_xy()
    assert centres.shape == (100, 100, 2)
    assert centres[0, 0] == pytest.approx([-1.98, -1.98])
    assert centres[99, 0] == pytest.approx([1.98, -1.98])
    back, ok = g.cell_of(centres.reshape(-1, 2))
    assert ok.all() and np.array_equal(
        back.reshape(100, 100, 2)[..., 0], np.arange(100)[:, None] * np.ones(100, dtype=int)
    )


def test_match_z_through_mapper():
    rng = np.random.default_rng(12)
    m = FloorObstacleMapper(P)
    for _ in range(3):
        m.update(*frame(rng, []))
    pts, h, _ = frame(rng, [])
    z = m.match_z(pts - [0, 0, 0.012], h - 0.012)
    assert z.accepted and z.shift_m == pytest.approx(0.012, abs=0.001)
