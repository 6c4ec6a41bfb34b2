"""The occupancy grid against OctoMap's ``insertPointCloud`` under the same sensor model.

OctoMap (octomap-python, a dev dependency) is the reference implementation of the update rule
the mapper follows (DESIGN item 1): every cell a ray crosses gets one miss per cloud, every end
cell one hit, a cell both hit and crossed counts as hit, log-odds clamped to ``[p_min,
p_max]``, occupied above ``p_occ``. Same resolution, grids aligned (OctoMap's voxels start at
multiples of the resolution, so its points are given relative to the mapper's grid corner),
rays cleared to their ends (``free_margin_m = 0``, ``clear_outside``: OctoMap's tree has no
border). The mapper stores 8-bit levels, OctoMap floats, so a cell whose history sits right at
a threshold may be classified differently; occupied cells must still be the same. The same
holds with ``discretize`` on both sides (one ray per end cell, to its centre).
"""

import numpy as np
import octomap
import pytest

from mapper import FloorObstacleMapper, MapperParams, PinholeIntrinsics
from mapper.occupancy import cell_set, insert_frame_columns
from mapper.synthetic import Box, camera_rays_world, cast_frame

PARAMS = MapperParams(free_margin_m=0.0, clear_outside=True)


def _octree(params: MapperParams) -> octomap.OcTree:
    tree = octomap.OcTree(params.cell_m)
    tree.setProbHit(params.p_sense)
    tree.setProbMiss(1.0 - params.p_sense)
    tree.setClampingThresMin(params.p_min)
    tree.setClampingThresMax(params.p_max)
    tree.setOccupancyThres(params.p_occ)
    return tree


def _octree_cells(tree: octomap.OcTree, params: MapperParams) -> dict[tuple[int, int, int], bool]:
    """OctoMap's known voxels inside the grid box: cell index -> occupied (pruned leaves split)."""
    shape = (params.nx, params.ny, params.nz)
    cells = {}
    for leaf in tree.begin_leafs():
        size = leaf.getSize()
        low = np.rint((np.asarray(leaf.getCoordinate()) - size / 2) / params.cell_m).astype(int)
        n = round(size / params.cell_m)
        occupied = bool(tree.isNodeOccupied(leaf))
        for offset in np.ndindex(n, n, n):
            index = tuple(int(v) for v in low + np.array(offset))
            if all(0 <= index[a] < shape[a] for a in range(3)):
                cells[index] = occupied
    return cells


def _frames(count: int, removed_at: int, seed: int):
    """Frames of a floor with two boxes seen from 0.7 m; the tall box is gone from frame
    ``removed_at`` on (its saturated cells are then cleared)."""
    rng = np.random.default_rng(seed)
    rays = camera_rays_world(PinholeIntrinsics.from_fov(88, 72, 47.0, 39.0), 0.0, 25.0)
    step = Box((0.9, 0.3), (0.4, 0.4, 0.07))
    tall = Box((1.2, -0.5), (0.3, 0.3, 0.25), walkable=False)
    for i in range(count):
        boxes = [step, tall] if i < removed_at else [step]
        camera = np.array([0.01 * i, 0.005 * (i % 3), 0.70]) + rng.uniform(-0.003, 0.003, 3)
        points, heights = cast_frame(camera, rays, boxes, max_range_m=3.5, noise_z_m=0.005, rng=rng)
        seen = np.all(np.isfinite(points), axis=1)  # OctoMap takes no NaN points
        yield points[seen], heights[seen], camera


@pytest.mark.parametrize(("count", "removed_at"), [(10, 10), (30, 12)], ids=["static", "removal"])
def test_same_occupied_cells_as_octomap(count, removed_at):
    """The occupied cells are identical and at least 99.5 % of the cells either map touched
    are classified alike (static scene; a box removed after twelve frames)."""
    mapper = FloorObstacleMapper(PARAMS)
    tree = _octree(PARAMS)
    g = mapper.geometry
    corner = np.array([*g.origin_xy_m, g.z_min_m])
    for points, heights, camera in _frames(count, removed_at, seed=5):
        mapper.update(points, heights, camera)
        tree.insertPointCloud(points - corner, camera - corner)
    levels = mapper.occupancy_levels()
    ours = {
        index: bool(levels[index] > PARAMS.occ_threshold_level)
        for index in map(tuple, np.argwhere(levels != 128))
    }
    theirs = _octree_cells(tree, PARAMS)
    assert sum(ours.values()) > 500  # the boxes and the floor are in the map
    assert {c for c, occ in ours.items() if occ} == {c for c, occ in theirs.items() if occ}
    touched = ours.keys() | theirs.keys()
    agree = sum(ours.get(c, False) == theirs.get(c, False) for c in touched)
    assert len(touched) > 10000
    assert agree / len(touched) >= 0.995


def _discretized_levels(params: MapperParams, frames) -> np.ndarray:
    """The column kernel with ``discretize`` over ``frames`` on a grid centred at the origin.

    (Driven directly: the mapper passes `MapperParams.discretize_rays` to it once wired.)
    """
    mapper = FloorObstacleMapper(params)  # its geometry and scratch
    g = mapper.geometry
    og = mapper.occupancy_levels()
    for points, _, camera in frames:
        point_cell = np.empty(len(points), dtype=np.int64)
        insert_frame_columns(
            np.ascontiguousarray(points),
            camera,
            *g.origin_xy_m,
            g.z_min_m,
            g.cell_m,
            g.layer_m,
            og,
            mapper._hit_cols,
            mapper._miss_cols,
            mapper._range_masks,
            mapper._update_table,
            point_cell,
            params.free_margin_m,
            params.max_range_m,
            params.clear_outside,
            cell_set(len(points)),
        )
    return og


def test_discretized_same_occupied_cells_as_octomap_discretize():
    """With one ray per end cell to its centre on both sides (OctoMap's ``discretize``), the
    occupied cells are identical and at least 99.5 % of the touched cells agree (the box
    removed after twelve frames)."""
    mapper = FloorObstacleMapper(PARAMS)
    g = mapper.geometry
    corner = np.array([*g.origin_xy_m, g.z_min_m])
    tree = _octree(PARAMS)
    frames = list(_frames(30, 12, seed=5))
    for points, _, camera in frames:
        tree.insertPointCloud(points - corner, camera - corner, discretize=True)
    levels = _discretized_levels(PARAMS, frames)
    ours = {
        index: bool(levels[index] > PARAMS.occ_threshold_level)
        for index in map(tuple, np.argwhere(levels != 128))
    }
    theirs = _octree_cells(tree, PARAMS)
    assert sum(ours.values()) > 500
    assert {c for c, occ in ours.items() if occ} == {c for c, occ in theirs.items() if occ}
    touched = ours.keys() | theirs.keys()
    agree = sum(ours.get(c, False) == theirs.get(c, False) for c in touched)
    assert len(touched) > 10000
    assert agree / len(touched) >= 0.995


@pytest.mark.parametrize("k", [6, 8])
def test_repeat_rays_same_occupied_cells_as_octomap(k):
    """`MapperParams.repeat_ray_columns` against OctoMap's exact insertion (every ray whole):
    from 6 columns on the occupied cells are still identical and at least 99.5 % of the
    touched cells agree (the box removed after twelve frames). With 1 to 4 columns one or two
    of the removed box's cells are still occupied after the 30 frames (99.99 % agree): the
    cells far from the rays' ends are cleared only by the first ray to each end cell."""
    params = MapperParams(free_margin_m=0.0, clear_outside=True, repeat_ray_columns=k)
    mapper = FloorObstacleMapper(params)
    tree = _octree(params)
    g = mapper.geometry
    corner = np.array([*g.origin_xy_m, g.z_min_m])
    for points, heights, camera in _frames(30, 12, seed=5):
        mapper.update(points, heights, camera)
        tree.insertPointCloud(points - corner, camera - corner)
    levels = mapper.occupancy_levels()
    ours = {
        index: bool(levels[index] > params.occ_threshold_level)
        for index in map(tuple, np.argwhere(levels != 128))
    }
    theirs = _octree_cells(tree, params)
    assert sum(ours.values()) > 500
    assert {c for c, occ in ours.items() if occ} == {c for c, occ in theirs.items() if occ}
    touched = ours.keys() | theirs.keys()
    agree = sum(ours.get(c, False) == theirs.get(c, False) for c in touched)
    assert len(touched) > 10000
    assert agree / len(touched) >= 0.995
