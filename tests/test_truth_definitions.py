"""Ground truth by the paper's definitions, cell by cell on small hand-computed grids.

Grids: 4 cm cells with edges on multiples of 4 cm from (0, 0), so cell i spans
[0.04 i, 0.04 (i + 1)]. Default TruthParams: iCub's foot 0.156 x 0.06 m, grid top 0.58 m.
"""

from __future__ import annotations

import numpy as np
import pytest

from fogsim.config import scenario_from_dict
from fogsim.errors import FogsimError, ParameterError
from fogsim.robot.description import load_description
from fogsim.world import SceneTruth, TruthLabel, TruthParams
from mapper.params import MapperParams

CELL_M = 0.04
FLOOR, OBSTACLE = TruthLabel.FLOOR, TruthLabel.OBSTACLE


def cell_centers(nx: int, ny: int) -> np.ndarray:
    xs = (np.arange(nx) + 0.5) * CELL_M
    ys = (np.arange(ny) + 0.5) * CELL_M
    return np.stack(np.meshgrid(xs, ys, indexing="ij"), axis=-1)


def truth_of(*objects: dict) -> SceneTruth:
    return SceneTruth.from_scenario(scenario_from_dict({"name": "t", "objects": list(objects)}), 0)


def box(name: str, center, size, **more) -> dict:
    return {"name": name, "center": list(center), "size": list(size), **more}


def block(nx: int, ny: int, x: range, y: range) -> np.ndarray:
    """(nx, ny) mask of the cells x × y."""
    mask = np.zeros((nx, ny), dtype=bool)
    mask[x.start : x.stop, y.start : y.stop] = True
    return mask


# A 0.24 m square footprint x, y 0.08..0.32: cells 2..7 in x and y (edges on cell boundaries).
CENTER, SIDE = (0.2, 0.2), 0.24
ON_SQUARE = block(10, 10, range(2, 8), range(2, 8))


def test_defaults_are_icubs_foot_and_the_default_grid_top():
    params = TruthParams()
    feet = load_description("icub").feet
    assert params.foot_length_m == pytest.approx(feet.length_m[1] - feet.length_m[0], abs=1e-12)
    assert params.foot_width_m == pytest.approx(2 * feet.half_width_m, abs=1e-12)
    assert params.grid_top_m == pytest.approx(MapperParams().z_max_m) == pytest.approx(0.58)


@pytest.mark.parametrize(
    "changes",
    [
        {"foot_length_m": 0.0},
        {"foot_width_m": -0.1},
        {"foot_length_m": 0.1, "foot_width_m": 0.2},
        {"grid_top_m": float("nan")},
    ],
)
def test_bad_params_are_refused(changes):
    with pytest.raises(ParameterError, match="TruthParams"):
        TruthParams(**changes)


@pytest.mark.parametrize(
    ("size_x_m", "size_y_m", "room"),
    [
        (0.156, 0.06, True),  # exactly the foot
        (0.06, 0.156, True),  # the other way round
        (0.1, 1.0, True),  # the stage's sill: the foot along it
        (0.155, 0.155, False),  # shorter than the foot (a turned foot needs 0.153: ignored)
        (0.059, 1.0, False),  # narrower than the foot's width
    ],
)
def test_room_for_a_foot(size_x_m, size_y_m, room):
    assert TruthParams().has_room_for_foot(size_x_m, size_y_m) is room


@pytest.mark.parametrize("walkable", [False, True])
def test_flat_box_top_is_floor_at_its_height_walkable_or_not(walkable):
    truth = truth_of(box("crate", CENTER, (SIDE, SIDE, 0.1), walkable=walkable))
    grid = truth.rasterize(cell_centers(10, 10), CELL_M)
    assert np.all(grid.labels == FLOOR)
    np.testing.assert_array_equal(grid.floor_m, np.where(ON_SQUARE, 0.1, 0.0))
    np.testing.assert_array_equal(grid.object_id, np.where(ON_SQUARE, 0, -1))
    # walkable only chooses the Table I row (surface 1); a non-walkable top has none (-1).
    np.testing.assert_array_equal(grid.surface_id, np.where(ON_SQUARE, 1 if walkable else -1, 0))
    assert grid.interior.all()
    assert np.all(np.isnan(grid.obstacle_top_m)) and np.all(np.isnan(grid.ceiling_m))


def test_step_edge_inside_a_cell_is_an_obstacle_riser():
    # The square shifted by half a cell: x, y 0.10..0.34. Cells 2 and 8 hold its edges (risers),
    # cells 3..7 lie wholly on its top.
    truth = truth_of(box("crate", (0.22, 0.22), (0.24, 0.24, 0.1)))
    grid = truth.rasterize(cell_centers(10, 10), CELL_M)
    top = block(10, 10, range(3, 8), range(3, 8))
    rim = block(10, 10, range(2, 9), range(2, 9)) & ~top
    assert rim.sum() == 24
    np.testing.assert_array_equal(grid.labels, np.where(rim, OBSTACLE, FLOOR))
    np.testing.assert_array_equal(grid.obstacle_top_m[rim], 0.1)
    np.testing.assert_array_equal(grid.floor_m[top], 0.1)
    np.testing.assert_array_equal(grid.object_id, np.where(top | rim, 0, -1))
    np.testing.assert_array_equal(grid.surface_id, np.where(rim | top, -1, 0))
    np.testing.assert_array_equal(grid.interior, ~rim)


def test_steps_meeting_inside_a_cell():
    # Step a (x 0..0.21, 30 mm), b (x 0.21..0.42, 60 mm), c (0.21..0.42 at 30 mm), y 0..0.4.
    a = box("a", (0.105, 0.2), (0.21, 0.4, 0.03), walkable=True)
    b = box("b", (0.315, 0.2), (0.21, 0.4, 0.06), walkable=True)
    grid = truth_of(a, b).rasterize(cell_centers(12, 10), CELL_M)
    # Cell 5 (0.20..0.24) holds the riser a→b, cell 10 (0.40..0.44) b's edge to the ground.
    assert grid.labels[:, 0].tolist() == [FLOOR] * 5 + [OBSTACLE] + [FLOOR] * 4 + [OBSTACLE, FLOOR]
    assert grid.obstacle_top_m[5, 0] == pytest.approx(0.06)
    assert grid.obstacle_top_m[10, 0] == pytest.approx(0.06)
    assert grid.object_id[:, 0].tolist() == [0] * 5 + [1] * 6 + [-1]
    assert grid.surface_id[:, 0].tolist() == [1] * 5 + [-1] + [2] * 4 + [-1, 0]
    assert np.all(grid.labels == grid.labels[:, :1])  # the same along y
    # Two tops at one height meeting inside a cell: no step, floor, but not interior.
    c = box("c", (0.315, 0.2), (0.21, 0.4, 0.03), walkable=True)
    grid = truth_of(a, c).rasterize(cell_centers(12, 10), CELL_M)
    assert grid.labels[5, 0] == FLOOR and grid.floor_m[5, 0] == pytest.approx(0.03)
    assert grid.object_id[5, 0] == 1  # the centre (0.22) lies on c
    assert grid.surface_id[5, 0] == 2 and not grid.interior[5, 0]
    assert grid.interior[4, 0] and grid.interior[6, 0]


def test_rough_top_is_an_obstacle():
    crate = box("crate", CENTER, (SIDE, SIDE, 0.1), surface="rough", roughness_m=0.02)
    grid = truth_of(crate).rasterize(cell_centers(10, 10), CELL_M)
    np.testing.assert_array_equal(grid.labels, np.where(ON_SQUARE, OBSTACLE, FLOOR))
    np.testing.assert_array_equal(grid.obstacle_top_m[ON_SQUARE], 0.1)  # the highest bump
    assert np.all(np.isnan(grid.floor_m[ON_SQUARE]))
    np.testing.assert_array_equal(grid.object_id, np.where(ON_SQUARE, 0, -1))
    assert np.all(grid.surface_id[ON_SQUARE] == -1) and grid.interior.all()


@pytest.mark.parametrize(
    ("size_xy", "cells", "label"),
    [
        ((0.08, 0.08), (range(4, 6), range(4, 6)), OBSTACLE),  # a post shorter than the foot
        ((0.16, 0.04), (range(3, 7), range(4, 5)), OBSTACLE),  # a bar narrower than the foot
        ((0.16, 0.08), (range(3, 7), range(4, 6)), FLOOR),  # room for the foot
    ],
)
def test_tops_narrower_than_a_foot_are_obstacles(size_xy, cells, label):
    # Centred at (0.2, 0.2) + half a cell in y for the odd-width bar: edges on cell boundaries.
    center_y = 0.18 if size_xy[1] == 0.04 else 0.2
    post = box("post", (0.2, center_y), (*size_xy, 0.3))
    grid = truth_of(post).rasterize(cell_centers(10, 10), CELL_M)
    on = block(10, 10, *cells)
    np.testing.assert_array_equal(grid.labels, np.where(on, label, FLOOR))
    np.testing.assert_array_equal(grid.object_id, np.where(on, 0, -1))
    heights = grid.floor_m if label == FLOOR else grid.obstacle_top_m
    np.testing.assert_array_equal(heights[on], 0.3)


def test_the_robots_foot_decides():
    # A 0.16 m square top holds iCub's 0.156 x 0.06 m foot but not Talos's 0.2 x 0.13 m one.
    top = truth_of(box("top", (0.2, 0.2), (0.16, 0.16, 0.1)))
    on = block(10, 10, range(3, 7), range(3, 7))
    icub = top.rasterize(cell_centers(10, 10), CELL_M)
    talos = top.rasterize(cell_centers(10, 10), CELL_M, params=TruthParams(0.2, 0.13))
    np.testing.assert_array_equal(icub.labels, FLOOR)
    np.testing.assert_array_equal(talos.labels, np.where(on, OBSTACLE, FLOOR))


def test_thin_curtain_is_an_obstacle_over_the_floor_with_its_ceiling():
    # 2 cm thick (x 0.17..0.19, inside cell 4), y 0..0.4 (cells 0..9), hanging 0.2..0.5 m.
    curtain = box("curtain", (0.18, 0.2), (0.02, 0.4, 0.3), base=0.2)
    truth = truth_of(curtain)
    grid = truth.rasterize(cell_centers(10, 12), CELL_M)
    under = block(10, 12, range(4, 5), range(0, 10))
    np.testing.assert_array_equal(grid.labels, np.where(under, OBSTACLE, FLOOR))
    np.testing.assert_array_equal(grid.obstacle_top_m[under], 0.5)
    np.testing.assert_array_equal(grid.ceiling_m[under], 0.2)
    assert np.all(np.isnan(grid.ceiling_m[~under])) and np.all(grid.floor_m[~under] == 0)
    np.testing.assert_array_equal(grid.object_id, np.where(under, 0, -1))
    assert not grid.interior[under].any()  # the curtain covers half of each cell
    assert truth.support_height_m([[0.18, 0.2]]) == pytest.approx([0.0])


def test_table_top_is_floor_at_its_top_with_the_ceiling_below():
    table = box("table", CENTER, (SIDE, SIDE, 0.04), base=0.4)
    grid = truth_of(table).rasterize(cell_centers(10, 10), CELL_M)
    assert np.all(grid.labels == FLOOR)
    np.testing.assert_array_equal(grid.floor_m, np.where(ON_SQUARE, 0.44, 0.0))
    np.testing.assert_array_equal(grid.ceiling_m, np.where(ON_SQUARE, 0.4, np.nan))
    np.testing.assert_array_equal(grid.object_id, np.where(ON_SQUARE, 0, -1))
    # A cluttered (rough) table top is an obstacle; the ceiling is its base all the same.
    rough = truth_of({**table, "surface": "rough", "roughness_m": 0.02})
    grid = rough.rasterize(cell_centers(10, 10), CELL_M)
    np.testing.assert_array_equal(grid.labels, np.where(ON_SQUARE, OBSTACLE, FLOOR))
    np.testing.assert_array_equal(grid.obstacle_top_m[ON_SQUARE], 0.44)
    np.testing.assert_array_equal(grid.ceiling_m, np.where(ON_SQUARE, 0.4, np.nan))


def test_table_over_a_box_ceiling_over_the_box_top():
    # A flat box (top 0.1) under a table (0.4..0.44): the table is the highest thing (floor at
    # 0.44); the ceiling is the table's base over the box's top as over the ground.
    crate = box("crate", (0.2, 0.2), (0.16, 0.16, 0.1))
    table = box("table", CENTER, (SIDE, SIDE, 0.04), base=0.4)
    grid = truth_of(crate, table).rasterize(cell_centers(10, 10), CELL_M)
    np.testing.assert_array_equal(grid.floor_m, np.where(ON_SQUARE, 0.44, 0.0))
    np.testing.assert_array_equal(grid.ceiling_m, np.where(ON_SQUARE, 0.4, np.nan))
    np.testing.assert_array_equal(grid.object_id, np.where(ON_SQUARE, 1, -1))


def test_the_grid_top():
    # A top above the grid top (0.58 m) is no floor; an object whose bottom is at or above it
    # is not there; a lower grid top turns a floor into an obstacle.
    high = box("high", CENTER, (SIDE, SIDE, 0.05), base=0.55)  # 0.55..0.60
    grid = truth_of(high).rasterize(cell_centers(10, 10), CELL_M)
    np.testing.assert_array_equal(grid.labels, np.where(ON_SQUARE, OBSTACLE, FLOOR))
    np.testing.assert_allclose(grid.obstacle_top_m[ON_SQUARE], 0.6, atol=1e-12)
    np.testing.assert_array_equal(grid.ceiling_m, np.where(ON_SQUARE, 0.55, np.nan))
    above = truth_of(box("above", CENTER, (SIDE, SIDE, 0.05), base=0.58))
    grid = above.rasterize(cell_centers(10, 10), CELL_M)
    assert np.all(grid.labels == FLOOR) and np.all(grid.floor_m == 0.0)
    assert np.all(grid.object_id == -1) and np.all(np.isnan(grid.ceiling_m))
    crate = truth_of(box("crate", CENTER, (SIDE, SIDE, 0.4)))
    low_grid = TruthParams(grid_top_m=0.3)
    grid = crate.rasterize(cell_centers(10, 10), CELL_M, params=low_grid)
    np.testing.assert_array_equal(grid.labels, np.where(ON_SQUARE, OBSTACLE, FLOOR))


def test_object_ids_stay_stable_when_an_object_is_removed():
    scenario = scenario_from_dict(
        {
            "name": "t",
            "objects": [
                box("gone", (0.1, 0.1), (0.08, 0.08, 0.1)),
                box("crate", CENTER, (SIDE, SIDE, 0.1), surface="rough"),
            ],
            "events": [{"at": 1.0, "remove": "gone"}],
        }
    )
    after = SceneTruth.from_scenario(scenario, 2.0)
    assert [o.name for o in after.objects] == ["crate"]
    grid = after.rasterize(cell_centers(10, 10), CELL_M)
    assert grid.object_names == ("gone", "crate")
    np.testing.assert_array_equal(grid.object_id, np.where(ON_SQUARE, 1, -1))
    again = SceneTruth.from_dict(after.to_dict())
    assert again == after and again.object_names == ("gone", "crate")


def test_truth_dict_without_object_names_is_refused():
    data = truth_of(box("crate", CENTER, (SIDE, SIDE, 0.1))).to_dict()
    del data["object_names"]
    with pytest.raises(FogsimError, match="object_names"):
        SceneTruth.from_dict(data)
