"""Obstacle height (eq. 10), FOG (eq. 11) required behaviours (DESIGN item 4), ceiling map."""

import numpy as np
import pytest

from mapper import CellType, FloorObstacleMapper, MapperParams, PinholeIntrinsics
from mapper.fog import ceiling_map, update_fog_area
from mapper.synthetic import Box, camera_rays_world, cast_frame

P = MapperParams()
Z0, L = P.z_min_m, P.layer_m
OCC, FREE = 230, 60


def fog_of_column(levels, hf):
    """FOG type and height of one column with the given 3D levels and floor height."""
    og = np.asarray(levels, dtype=np.uint8).reshape(1, 1, -1)
    floor = np.array([[hf]], dtype=float)
    obstacle = np.full((1, 1), np.nan)
    types = np.zeros((1, 1), dtype=np.int8)
    heights = np.zeros((1, 1))
    no_cover = (np.zeros((1, 1), dtype=np.int32), np.zeros((1, 1), dtype=np.int32), 1, 0.0)
    update_fog_area(
        og,
        floor,
        obstacle,
        types,
        heights,
        P.occ_threshold_level,
        Z0,
        L,
        P.delta_m,
        0,
        1,
        0,
        1,
        *no_cover,
    )
    return CellType(types[0, 0]), heights[0, 0], obstacle[0, 0]


def column(*occupied_layers, free=()):
    levels = np.full(P.nz, 128, dtype=np.uint8)
    levels[list(free)] = FREE
    levels[list(occupied_layers)] = OCC
    return levels


def layer_of(z):
    return int(np.floor((z - Z0) / L))


def test_eq10_obstacle_is_top_of_highest_occupied_cell():
    t, h, h_o = fog_of_column(column(1, 3, 7), np.nan)
    assert t == CellType.OBSTACLE  # no floor: anything occupied is an obstacle
    assert h_o == pytest.approx(Z0 + 8 * L) and h == h_o  # top of layer 7 = 0.26 m


def test_eq11_unknown_floor_obstacle():
    assert fog_of_column(column(), np.nan)[0] == CellType.UNKNOWN
    assert np.isnan(fog_of_column(column(), np.nan)[1])
    t, h, _ = fog_of_column(column(layer_of(0.031)), 0.031)
    assert (t, h) == (CellType.FLOOR, 0.031)
    t, h, h_o = fog_of_column(column(layer_of(0.031), 10), 0.031)
    assert (t, h) == (CellType.OBSTACLE, h_o)


HF_ACROSS_A_CELL = np.linspace(Z0 + 2 * L, Z0 + 3 * L, 11)[:-1] + np.array([0] * 9 + [0.0399])


@pytest.mark.parametrize("hf", HF_ACROSS_A_CELL)
def test_floor_noise_spill_into_next_layer_is_not_obstacle(hf):
    # the floor's own cell and the one above it (noise up to +10 mm spills there) are occupied
    levels = column(layer_of(hf - 0.01), layer_of(hf), layer_of(hf + 0.01))
    assert fog_of_column(levels, hf)[0] == CellType.FLOOR


@pytest.mark.parametrize("hf", HF_ACROSS_A_CELL)
def test_a_cell_one_layer_above_the_floor_is_obstacle(hf):
    k = int(np.ceil((hf + L - Z0) / L - 1e-9))  # lowest layer whose bottom is >= hf + L
    assert Z0 + k * L >= hf + L - 1e-12  # this occupied cell lies one layer or more above
    assert fog_of_column(column(layer_of(hf), k), hf)[0] == CellType.OBSTACLE
    # and anything reaching delta above the floor
    top = hf + P.delta_m + 1e-6
    assert fog_of_column(column(layer_of(hf), layer_of(top)), hf)[0] == CellType.OBSTACLE


def test_obstacle_below_floor_is_ignored_and_hanging_one_is_not():
    hf = 0.25
    assert fog_of_column(column(1, 2, layer_of(hf)), hf)[0] == CellType.FLOOR
    t, h, _ = fog_of_column(column(1, layer_of(hf), 13), hf)  # a curtain above the floor
    assert t == CellType.OBSTACLE and h == pytest.approx(Z0 + 14 * L)


# ------------------------------------------------------------------ end to end with rays
def patch_frame(rng, hf, noise, n=600, x=(0.6, 1.0), y=(-0.2, 0.2)):
    pts = np.column_stack(
        [rng.uniform(*x, n), rng.uniform(*y, n), hf + rng.uniform(-noise, noise, n)]
    )
    return pts, np.full(n, hf)


@pytest.mark.parametrize("noise", [0.005, 0.0095])
def test_flat_floor_anywhere_in_a_cell_never_obstacle(noise):
    rng = np.random.default_rng(1)
    sensor = np.array([0.0, 0.0, 0.55])
    for hf in [*HF_ACROSS_A_CELL, 0.0]:
        m = FloorObstacleMapper(P)
        for _ in range(15):
            m.update(*patch_frame(rng, hf, noise), sensor)
        types, heights = m.fog()
        inner = types[66:74, 46:54]  # x 0.64..0.96, y -0.16..0.16
        assert np.all(inner == CellType.FLOOR), (hf, np.unique(inner, return_counts=True))
        assert np.allclose(heights[66:74, 46:54], hf, atol=0.003)


def test_box_one_delta_above_floor_is_obstacle_wherever_the_floor_is():
    rng = np.random.default_rng(2)
    sensor = np.array([0.0, 0.0, 0.55])
    for hf in HF_ACROSS_A_CELL:
        m = FloorObstacleMapper(P)
        top = hf + P.delta_m + 0.005
        for _ in range(10):
            floor_pts, floor_h = patch_frame(rng, hf, 0.005)
            # an obstacle's front face and top over x 0.80..0.84, y 0..0.04 (cell 70, 50)
            zz = np.linspace(hf, top, 12)
            face = np.column_stack([np.full(12, 0.8001), np.full(12, 0.02), zz])
            lid = np.column_stack(
                [rng.uniform(0.8, 0.84, 12), rng.uniform(0, 0.04, 12), np.full(12, top)]
            )
            pts = np.vstack([floor_pts, face, lid])
            h = np.concatenate([floor_h, np.full(24, np.nan)])
            m.update(pts, h, sensor)
        types, _ = m.fog()
        assert types[70, 50] == CellType.OBSTACLE, hf
        assert types[66, 46] == CellType.FLOOR


def test_table_top_ceiling_and_obstacle():
    """A table top hanging at 0.24-0.28 m over seen ground: obstacle, ceiling ~0.24 m.

    The camera sways by ±2 cm as a walking robot's does, and the top is low enough to be seen
    at a moderate angle (see MapperParams.free_margin_m about grazing angles).
    """
    rng = np.random.default_rng(3)
    intr = PinholeIntrinsics.from_fov(88, 72, 47.0, 39.0)
    rays = camera_rays_world(intr, yaw_deg=0.0, pitch_down_deg=15.0)  # sees top and under
    table = Box((1.0, 0.0), (0.4, 0.6, 0.04), base_m=0.24, walkable=False)
    m = FloorObstacleMapper(P)
    for _ in range(10):
        camera = np.array([rng.uniform(-0.02, 0.02), rng.uniform(-0.02, 0.02), 0.55])
        pts, h = cast_frame(camera, rays, [table], noise_z_m=0.003, rng=rng)
        m.update(pts, h, camera)
    g = m.geometry
    (ix0, iy0), (ix1, iy1) = g.cell_of([[0.82, -0.28], [1.18, 0.28]])[0]
    sl = (slice(ix0, ix1 + 1), slice(iy0, iy1 + 1))
    types, _ = m.fog()
    # Every row but the far edge's is obstacle. The far edge's top cells are crossed by the rays
    # that graze over the edge to the ground 2.4 m away: in the frames where no ray ends in
    # them they get the "empty" update (exact ray casting with the paper's sharp model; the map
    # is the same inside any larger grid, MapperParams.clear_outside).
    near = (slice(ix0, ix1), slice(iy0, iy1 + 1))
    assert np.all(types[near] == CellType.OBSTACLE)
    floor = m.floor()[sl]
    ceiling = m.ceiling()[near]
    seen = np.isfinite(floor)
    assert seen.mean() > 0.9  # the ground under the table is seen between its legs-free gap
    assert np.allclose(floor[seen], 0.0, atol=0.004)
    # coarse: bottom of the layer holding the underside (0.22) or the top face (0.26)
    assert np.all((ceiling >= 0.22 - 1e-9) & (ceiling <= 0.26 + 1e-9))
    assert np.any(np.isclose(ceiling, 0.22))  # the front edge sees the underside layer
    # behind the table: ground, no ceiling
    ix_front = g.cell_of([[1.4, 0.0]])[0][0, 0]
    assert np.isnan(m.ceiling()[ix_front, 50])
    assert m.fog()[0][ix_front, 50] == CellType.FLOOR


def test_ceiling_without_floor_needs_free_space_below():
    og = np.stack([column(12, free=range(1, 12)), column(2, 3, 12), column()]).reshape(3, 1, -1)
    floor = np.full((3, 1), np.nan)
    c = ceiling_map(og, floor, P.occ_threshold_level, Z0, L, P.delta_m)
    assert c[0, 0] == pytest.approx(Z0 + 12 * L)  # overhang seen above free space
    assert np.isnan(c[1, 0])  # a solid column: nothing to crawl under
    assert np.isnan(c[2, 0])


def test_ceiling_with_floor_ignores_cells_near_the_floor():
    hf = 0.018  # near the top of layer 1: +5 mm noise spills into layer 2
    og = np.stack([column(1, 2, 9), column(1, 2)]).reshape(2, 1, -1)
    floor = np.full((2, 1), hf)
    c = ceiling_map(og, floor, P.occ_threshold_level, Z0, L, P.delta_m)
    assert c[0, 0] == pytest.approx(Z0 + 9 * L)
    assert np.isnan(c[1, 0])
