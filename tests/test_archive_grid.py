"""The archive stored from a grid's first cell centre and the cells in view from cached rays:
the same archive, the same cells, and the checks of the functions they stand for; a run's
maps stored once per place of the grid: the archive of every frame, bit for bit."""

from __future__ import annotations

import dataclasses
from types import SimpleNamespace

import numpy as np
import pytest
from archive_factory import CELL, centers

from fogsim.data.frame import Frame
from fogsim.errors import FogsimError
from fogsim.eval.archive import WorldArchive, cells_in_view
from fogsim.run.runner import _GridArchiver
from mapper import MapperParams
from mapper.errors import InvalidInputError
from mapper.grid import GridGeometry
from mapper.intrinsics import PinholeIntrinsics
from mapper.transforms import apply_transform

LAYERS = (
    "fog_types",
    "fog_heights_m",
    "floor_m",
    "obstacle_m",
    "ceiling_m",
    "baseline_heights_m",
    "visited",
    "in_view",
)


def test_store_grid_from_the_first_centre_equals_store_with_every_centre():
    rng = np.random.default_rng(5)
    by_centres, by_corner = WorldArchive(CELL), WorldArchive(CELL)
    for x0, y0 in ((0.0, 0.0), (3 * CELL, -2 * CELL), (-7 * CELL, 5 * CELL)):
        grid = centers(12, 9, x0, y0)
        types = rng.integers(0, 3, (12, 9)).astype(np.int8)
        heights = [rng.uniform(-0.1, 0.5, (12, 9)) for _ in range(5)]
        in_view = rng.random((12, 9)) < 0.5
        maps = dict(floor_m=heights[2], obstacle_m=heights[3], ceiling_m=heights[4])
        by_centres.store(grid, types, heights[0], heights[1], **maps, in_view=in_view)
        by_corner.store_grid(grid[0, 0], types, heights[0], heights[1], **maps, in_view=in_view)
    for name in LAYERS:
        np.testing.assert_array_equal(by_centres.layer(name), by_corner.layer(name), name)
    np.testing.assert_array_equal(by_centres.cell_centers_xy(), by_corner.cell_centers_xy())


def test_store_refuses_centres_that_are_not_the_maps_grid():
    maps = np.zeros((4, 3))
    with pytest.raises(FogsimError, match=r"cell centres of shape \(4, 4, 2\) for maps of shape"):
        WorldArchive(CELL).store(
            centers(4, 4),
            maps.astype(np.int8),
            maps,
            maps,
            floor_m=maps,
            obstacle_m=maps,
            ceiling_m=maps,
            in_view=maps > 0,
        )


def _frame(depth_m, intrinsics):
    # Camera 1 m above the floor looking straight down (camera x = world x, y = -world y).
    down = np.array([[1.0, 0, 0, 0], [0, -1.0, 0, 0], [0, 0, -1.0, 1.0], [0, 0, 0, 1.0]])
    return Frame(
        index=0,
        time_s=0.0,
        depth_m=depth_m,
        intrinsics=intrinsics,
        transform_camera_to_robot_believed=down,
        robot_pose_believed=np.zeros(4),
        transform_camera_to_world_true=down,
        robot_pose_true=np.zeros(4),
    )


def _seen_by_definition(frame, geometry):
    """The cells of the frame's depth points: back-projection, true pose, cell_of."""
    points = apply_transform(
        frame.transform_camera_to_world_true,
        frame.intrinsics.depth_to_points_camera(frame.depth_m).reshape(-1, 3),
    )
    index, inside = geometry.cell_of(points)
    seen = np.zeros((geometry.nx, geometry.ny), dtype=bool)
    seen[index[inside, 0], index[inside, 1]] = True
    return seen, inside


def test_cells_in_view_are_the_cells_of_the_depth_points_by_cell_of():
    """A camera 1 m above the floor looking down: the floor points' cells, by the definition;
    dropouts (NaN, 0) see nothing, nor points outside the grid or its height range."""
    intrinsics = PinholeIntrinsics.from_fov(40, 30, 60.0, 47.0)
    rng = np.random.default_rng(3)
    depth_m = rng.uniform(0.9, 1.0, intrinsics.shape).astype(np.float32)  # dips below z 0
    depth_m[::4, ::3] = np.nan
    depth_m[1::5, ::7] = 0.0
    geometry = GridGeometry(
        nx=30, ny=30, nz=40, cell_m=CELL, layer_m=0.01, z_min_m=0.02, origin_ix=-15, origin_iy=-12
    )
    frame = _frame(depth_m, intrinsics)
    expected, inside = _seen_by_definition(frame, geometry)
    assert 0 < expected.sum() < expected.size and not inside.all()
    np.testing.assert_array_equal(cells_in_view(frame, geometry), expected)
    # The same camera again (its rays cached) and another one: still by the definition.
    np.testing.assert_array_equal(cells_in_view(frame, geometry), expected)
    narrow = dataclasses.replace(intrinsics, fx=2 * intrinsics.fx, fy=2 * intrinsics.fy)
    narrow_frame = _frame(depth_m, narrow)
    expected_narrow, _ = _seen_by_definition(narrow_frame, geometry)
    assert not np.array_equal(expected_narrow, expected)
    np.testing.assert_array_equal(cells_in_view(narrow_frame, geometry), expected_narrow)


def test_cells_in_view_refuses_a_depth_image_of_another_size():
    intrinsics = PinholeIntrinsics.from_fov(40, 30, 60.0, 47.0)
    frame = _frame(np.ones((30, 40), np.float32), intrinsics)
    frame = dataclasses.replace(frame, depth_m=np.ones((29, 40), np.float32))
    geometry = GridGeometry(nx=4, ny=4, nz=4, cell_m=CELL, layer_m=0.01, z_min_m=0.0)
    with pytest.raises(InvalidInputError, match=r"\(30, 40\), got \(29, 40\)"):
        cells_in_view(frame, geometry)


def _walk_frames(rng, geometry, count):
    """``count`` frames of random maps; the grid stays 1-5 frames, then moves by whole cells."""
    shape = (geometry.nx, geometry.ny)
    stay = 0
    for _ in range(count):
        if stay == 0:
            geometry = geometry.shifted(*(int(v) for v in rng.integers(-3, 4, 2)))
            stay = int(rng.integers(1, 6))
        stay -= 1
        heights = [
            np.where(rng.random(shape) < 0.3, np.nan, rng.normal(size=shape)) for _ in "abcde"
        ]
        yield (
            geometry,
            rng.integers(0, 3, shape).astype(np.int8),
            heights,
            rng.random(shape) < 0.2,
        )


def _fake_pipeline(geometry, types, heights):
    """What the archiver reads of a pipeline: its grid and its maps (fresh copies)."""
    fog, base, floor, obstacle, ceiling = heights
    mapper = SimpleNamespace(
        geometry=geometry, floor=floor.copy, obstacle=obstacle.copy, ceiling=ceiling.copy
    )
    return SimpleNamespace(mapper=mapper, maps=lambda: (types.copy(), fog.copy(), base.copy()))


@pytest.mark.parametrize("spurious_keeps", [0.0, 0.5])
def test_storing_once_per_place_leaves_the_archive_of_every_frame(spurious_keeps):
    """Maps kept before each frame that moves the grid (and, with ``spurious_keeps``, before
    random others that do not: a pipeline that cannot tell) give the archive of every frame."""
    rng = np.random.default_rng(3)
    start = GridGeometry.from_params(MapperParams(nx=12, ny=9))
    every, once = WorldArchive(start.cell_m), WorldArchive(start.cell_m)
    archiver = _GridArchiver(once)
    stores, places = [], 0
    once_store = once.store_grid
    once.store_grid = lambda *args, **kwargs: stores.append(1) or once_store(*args, **kwargs)
    pipeline = None  # the pipeline's state after the previous frame
    for geometry, types, heights, in_view in _walk_frames(rng, start, 80):
        fog, base, floor, obstacle, ceiling = heights
        layers = {"floor_m": floor, "obstacle_m": obstacle, "ceiling_m": ceiling}
        every.store_grid(geometry.cell_center(0, 0), types, fog, base, **layers, in_view=in_view)
        moves = pipeline is None or pipeline.mapper.geometry != geometry
        places += moves
        if pipeline is not None and (moves or rng.random() < spurious_keeps):
            archiver.keep(pipeline)
        pipeline = _fake_pipeline(geometry, types, heights)  # the frame mapped
        archiver.add(geometry, in_view)
    archiver.flush(pipeline)
    assert len(stores) == places < 80
    for name in LAYERS:
        np.testing.assert_array_equal(getattr(once, name), getattr(every, name), err_msg=name)
    np.testing.assert_array_equal(once.cell_centers_xy(), every.cell_centers_xy())
    assert once.storage_cells == every.storage_cells


def test_a_move_without_the_maps_kept_before_it_is_refused():
    """The run must keep the maps before a frame that moves the grid: else nothing to store."""
    rng = np.random.default_rng(4)
    start = GridGeometry.from_params(MapperParams(nx=12, ny=9))
    archiver = _GridArchiver(WorldArchive(start.cell_m))
    (first, *_, in_view), (moved, *_) = list(_walk_frames(rng, start, 7))[::6]
    assert moved != first
    archiver.add(first, in_view)
    with pytest.raises(AssertionError):
        archiver.add(moved, in_view)
