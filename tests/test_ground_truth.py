"""Ground truth: Table I heights of the stage, labels, interior cells, events, serialisation."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from fogsim.config import load_scenario, scenario_from_dict
from fogsim.world import (
    ObjectState,
    SceneTruth,
    TruthLabel,
    moving_objects,
    object_center_at,
)

CELL_M = 0.04


def cell_centers(x0: float, y0: float, nx: int, ny: int, cell_m: float = CELL_M) -> np.ndarray:
    """Centres of cells whose lower-left corner is (x0, y0)."""
    xs = x0 + (np.arange(nx) + 0.5) * cell_m
    ys = y0 + (np.arange(ny) + 0.5) * cell_m
    return np.stack(np.meshgrid(xs, ys, indexing="ij"), axis=-1)


@pytest.fixture(scope="module")
def stage_grid():
    truth = SceneTruth.from_scenario(load_scenario("stage"), 0.0)
    # The 4 x 1 m stage plus a 0.2 m margin, 4 cm cells aligned with the stage edges.
    return truth, truth.rasterize(cell_centers(-0.2, -0.2, 110, 35), CELL_M)


def test_table1_ground_truth_of_the_stage(stage_grid):
    _, grid = stage_grid
    table1_mm = {"sill": 38, "step_1": 31, "step_2": 61, "step_3": 92, "platform": 122}
    for name, height_mm in table1_mm.items():
        assert grid.surface_heights_m[name] == pytest.approx(height_mm / 1000, abs=1e-12)
        cells = grid.surface_mask(name)
        assert cells.sum() > 0, name
        assert np.all(grid.floor_m[cells] == pytest.approx(height_mm / 1000, abs=1e-12))
    # The sill spans x 1.15..1.25: with cell edges on multiples of 4 cm (from -0.2) the cells
    # 1.16..1.20 and 1.20..1.24 lie wholly on it; 25 interior cells across y 0..1 (0.0..1.0).
    sill = grid.surface_mask("sill")
    assert sill.any(axis=1).sum() == 2
    assert sill.sum() == 2 * 25
    # A 0.2 m tread holds 5 cells but only the ones not touching an edge are interior.
    assert grid.surface_mask("step_2").any(axis=1).sum() == 5
    assert grid.surface_mask("ground").sum() > 0
    assert np.all(grid.floor_m[grid.surface_mask("ground")] == 0.0)


def test_labels_obstacles_and_floor(stage_grid):
    truth, grid = stage_grid
    obstacles = grid.labels == TruthLabel.OBSTACLE
    assert set(np.unique(grid.labels)) == {TruthLabel.FLOOR, TruthLabel.OBSTACLE}
    assert np.all(np.isnan(grid.floor_m[obstacles]))
    assert np.all(grid.surface_id[obstacles] == -1)
    assert np.all(~np.isnan(grid.floor_m[~obstacles]))
    assert np.all(np.isnan(grid.obstacle_top_m[~obstacles]))
    assert np.all(np.isnan(grid.ceiling_m))  # nothing hangs on the stage
    assert grid.object_names == tuple(o.name for o in load_scenario("stage").objects)
    # Each (rough) box's centre cell is an obstacle with the box's top.
    for obj in truth.objects:
        if obj.walkable:
            continue
        i, j = (np.floor((np.array(obj.center_xy) + 0.2) / CELL_M)).astype(int)
        assert grid.labels[i, j] == TruthLabel.OBSTACLE
        assert grid.obstacle_top_m[i, j] == pytest.approx(obj.top_m, abs=1e-12)
        assert grid.object_names[grid.object_id[i, j]] == obj.name

    def obstacle_cells_of(name):
        return obstacles & (grid.object_id == grid.object_names.index(name))

    # Every cell a box touches is an obstacle (the paper's definition: a cell partly on a box
    # holds the box; before issue 10 the centre alone decided and this test only bounded the
    # total area). box_right_1 (x 0.70..1.00, y 0.045..0.295, not yawed): cells with edges on
    # -0.2 + 0.04 k run x 0.68..1.00 (8) and y 0.04..0.32 (7); box_left_2 (x 1.70..2.00,
    # y 0.74..0.96): x 1.68..2.00 (8), y 0.72..0.96 (6).
    assert obstacle_cells_of("box_right_1").sum() == 8 * 7
    assert obstacle_cells_of("box_left_2").sum() == 8 * 6
    # The sill (x 1.15..1.25) has its riser faces inside cells 1.12..1.16 and 1.24..1.28: two
    # columns of 25 obstacle cells with the sill's top (issue 10: cells over a step edge are
    # obstacles). The steps' and the platform's edges lie on cell boundaries: no riser cells.
    sill = obstacle_cells_of("sill")
    assert np.nonzero(sill.any(axis=1))[0].tolist() == [33, 36]
    assert sill.sum() == 2 * 25
    assert np.all(grid.obstacle_top_m[sill] == pytest.approx(0.038, abs=1e-12))
    for name in ("step_1", "step_2", "step_3", "platform"):
        assert not obstacle_cells_of(name).any(), name
    # The yawed boxes: every cell wholly inside is an obstacle, none beyond a cell's reach.
    reach = 0.5 * math.sqrt(2) * CELL_M
    centers = cell_centers(-0.2, -0.2, 110, 35)
    for name in ("box_left_1", "box_right_2"):
        obj = truth.object_state(name)
        cells = obstacle_cells_of(name)
        assert np.all(cells[obj.contains(centers, -reach)])
        assert not np.any(cells & ~obj.contains(centers, reach))
    assert obstacles.sum() == sum(obstacle_cells_of(o.name).sum() for o in truth.objects)


def test_support_height_on_route(stage_grid):
    truth, _ = stage_grid
    xy = np.array([[0.3, 0.5], [1.2, 0.5], [2.7, 0.5], [2.9, 0.1], [3.1, 0.9], [3.5, 0.5]])
    assert truth.support_height_m(xy) == pytest.approx([0, 0.038, 0.031, 0.061, 0.092, 0.122])
    # Edges belong to the object; just outside is the ground.
    assert truth.support_height_m([[1.15, 0.5], [1.1499, 0.5]]) == pytest.approx([0.038, 0.0])


def test_hanging_objects_curtain_obstacle_table_top_floor_with_ceiling_below():
    hanging = {
        "name": "hanging",
        "objects": [
            {"name": "curtain", "center": [1.0, 0.35], "size": [0.1, 0.5, 1.0], "base": 0.2},
            {"name": "table_top", "center": [1.5, 0.6], "size": [0.4, 0.6, 0.08], "base": 0.35},
        ],
    }
    truth = SceneTruth.from_scenario(scenario_from_dict(hanging), 0.0)
    grid = truth.rasterize(cell_centers(1.18, 0.18, 16, 21), CELL_M)
    # A flat table top (0.4 x 0.6 m, room for a foot, below the grid top 0.58 m) is floor at
    # its height with the ceiling (its base) below it — DESIGN.md "Ground truth"; before
    # issue 10 it was an obstacle. 0.4 x 0.6 m = 10 x 15 cells, edges on cell boundaries.
    assert np.all(grid.labels == TruthLabel.FLOOR)
    table = grid.object_id == 1
    assert table.sum() == 10 * 15
    assert np.all(grid.floor_m[table] == pytest.approx(0.35 + 0.08, abs=1e-12))
    assert np.all(grid.ceiling_m[table] == pytest.approx(0.35, abs=1e-12))
    assert np.all(grid.surface_id[table] == -1)  # not walkable: no Table I row
    assert np.all(grid.floor_m[~table] == 0.0) and np.all(np.isnan(grid.ceiling_m[~table]))
    # The table is no support: the robot stands on the ground under it.
    assert truth.support_height_m([[1.5, 0.6]]) == pytest.approx([0.0])
    # The curtain (x 0.95..1.05, y 0.1..0.6, 0.2..1.2 m) reaches above the grid top: obstacle
    # over every cell it touches: x cells 0.94..0.98, 0.98..1.02, 1.02..1.06 and y cells
    # 0.08..0.60 (13; the edge y = 0.6 is a cell boundary).
    grid = truth.rasterize(cell_centers(0.9, 0.0, 5, 20), CELL_M)
    curtain = grid.labels == TruthLabel.OBSTACLE
    assert curtain.any(axis=1).tolist() == [False, True, True, True, False]
    assert curtain.sum(axis=1).tolist() == [0, 13, 13, 13, 0]
    assert np.all(grid.obstacle_top_m[curtain] == pytest.approx(1.2))
    assert np.all(grid.ceiling_m[curtain] == pytest.approx(0.2))
    assert np.all(grid.object_id[curtain] == 0)
    assert np.all(np.isnan(grid.ceiling_m[~curtain]))
    # Only the middle column (x 0.98..1.02) lies wholly under the curtain, y 0.12..0.56 (12).
    assert grid.interior[curtain].sum() == 12
    assert np.all(np.nonzero(grid.interior & curtain)[0] == 2)


def test_stacked_and_rotated_objects():
    data = {
        "name": "t",
        "objects": [
            {"name": "slab", "center": [1.0, 1.0], "size": [1.0, 1.0, 0.1], "walkable": True},
            {
                "name": "box",
                "center": [1.0, 1.0],
                "size": [0.2, 0.2, 0.3],
                "base": 0.1,
                "yaw_deg": 45.0,
            },
        ],
    }
    truth = SceneTruth.from_scenario(scenario_from_dict(data), 0.0)
    # The box rests on the slab (base == slab top): support 0.4 on it, slab 0.1 around it.
    d = 0.1 * math.sqrt(2)  # corner of the 45°-rotated box along x
    xy = [[1.0, 1.0], [1.0 + d - 1e-6, 1.0], [1.0 + d + 1e-6, 1.0], [1.4, 1.4]]
    assert truth.support_height_m(xy) == pytest.approx([0.4, 0.4, 0.1, 0.1])
    grid = truth.rasterize(cell_centers(0.5, 0.5, 25, 25), CELL_M)
    # The box's flat 0.2 x 0.2 m top holds iCub's 0.156 x 0.06 m foot: floor at 0.4 (before
    # issue 10 every non-walkable top was an obstacle); it is no Table I row (not walkable).
    assert grid.labels[12, 12] == TruthLabel.FLOOR
    assert grid.floor_m[12, 12] == pytest.approx(0.4)
    assert grid.surface_id[12, 12] == -1 and grid.object_id[12, 12] == 1
    assert grid.floor_m[2, 2] == pytest.approx(0.1)
    assert grid.surface_id[2, 2] == 1 and grid.object_id[2, 2] == 0
    # Its yawed edges cross cells: risers 0.3 m high over the slab, obstacles with its top.
    # Rim cells: not wholly inside (centre less than half a diagonal in), and centre within
    # 0.2 cell of the footprint in the box's axes (< 0.29 cell away), so the box reaches well
    # into the cell, past its samples a quarter cell apart.
    box = truth.object_state("box")
    centers = cell_centers(0.5, 0.5, 25, 25)
    rim = box.contains(centers, 0.2 * CELL_M) & ~box.contains(centers, -math.sqrt(0.5) * CELL_M)
    assert rim.sum() > 0
    assert np.all(grid.labels[rim] == TruthLabel.OBSTACLE)
    assert np.all(grid.obstacle_top_m[rim] == pytest.approx(0.4))


def test_events_move_and_remove():
    moving = load_scenario("moving_box")
    box = moving.object("flat_box")
    event = moving.events[0]
    assert moving_objects(moving) == ("flat_box",)
    assert object_center_at(moving, "flat_box", 0.0) == box.center
    assert object_center_at(moving, "flat_box", event.at) == pytest.approx(box.center)
    # 5 s after the start at 0.08 m/s: 0.4 m along +y.
    at5 = object_center_at(moving, "flat_box", event.at + 5.0)
    assert at5 == pytest.approx((1.35, 0.4), abs=1e-12)
    # Arrives after 1.0 / 0.08 = 12.5 s and stays.
    assert object_center_at(moving, "flat_box", event.at + 100.0) == pytest.approx((1.35, 1.0))
    removal = load_scenario("box_removal")
    at = removal.events[0].at
    assert SceneTruth.from_scenario(removal, at - 0.01).object_state("flat_box") is not None
    after = SceneTruth.from_scenario(removal, at)
    assert after.object_state("flat_box") is None
    assert after.surface_names == ("ground", "flat_box")  # stable ids
    assert after.object_names == ("flat_box",)
    assert after.support_height_m([[1.35, 0.5]]) == pytest.approx([0.0])


def test_to_dict_round_trips_through_json(stage_grid):
    truth, _ = stage_grid
    again = SceneTruth.from_dict(json.loads(json.dumps(truth.to_dict())))
    assert again == truth


def test_object_state_contains_rotated_footprint():
    obj = ObjectState("b", (0.0, 0.0), (0.4, 0.2, 0.1), math.radians(90.0), 0.0, False)
    assert obj.contains([[0.0, 0.19], [0.09, 0.0], [0.0, 0.21], [0.11, 0.0]]).tolist() == [
        True,
        True,
        False,
        False,
    ]
    corners = obj.footprint_corners_xy()
    assert np.abs(corners).max(axis=0) == pytest.approx([0.1, 0.2])


def test_grid_far_from_every_object_and_empty_scene():
    truth = SceneTruth.from_scenario(load_scenario("stage"), 0.0)
    grid = truth.rasterize(cell_centers(10.0, 10.0, 4, 3), CELL_M)  # no edge nearby
    assert np.all(grid.labels == TruthLabel.FLOOR) and np.all(grid.interior)
    assert np.all(grid.floor_m == 0.0) and np.all(grid.surface_id == 0)
    empty = SceneTruth.from_scenario(load_scenario("flat_floor"), 0.0)
    assert empty.rasterize(cell_centers(0.0, 0.0, 2, 2), CELL_M).interior.all()
