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
    # Each box's centre cell is an obstacle with the box's top.
    for obj in truth.objects:
        if obj.walkable:
            continue
        i, j = (np.floor((np.array(obj.center_xy) + 0.2) / CELL_M)).astype(int)
        assert grid.labels[i, j] == TruthLabel.OBSTACLE
        assert grid.obstacle_top_m[i, j] == pytest.approx(obj.top_m, abs=1e-12)
    # Obstacle cells total about the boxes' footprints (within the border cells).
    area = sum(o.size[0] * o.size[1] for o in truth.objects if not o.walkable)
    assert obstacles.sum() * CELL_M**2 == pytest.approx(area, rel=0.2)


def test_support_height_on_route(stage_grid):
    truth, _ = stage_grid
    xy = np.array([[0.3, 0.5], [1.2, 0.5], [2.7, 0.5], [2.9, 0.1], [3.1, 0.9], [3.5, 0.5]])
    assert truth.support_height_m(xy) == pytest.approx([0, 0.038, 0.031, 0.061, 0.092, 0.122])
    # Edges belong to the object; just outside is the ground.
    assert truth.support_height_m([[1.15, 0.5], [1.1499, 0.5]]) == pytest.approx([0.038, 0.0])


def test_hanging_objects_are_obstacles_above_floor():
    hanging = {
        "name": "hanging",
        "objects": [
            {"name": "curtain", "center": [1.0, 0.35], "size": [0.1, 0.5, 1.0], "base": 0.2},
            {"name": "table_top", "center": [1.5, 0.6], "size": [0.4, 0.6, 0.08], "base": 0.35},
        ],
    }
    truth = SceneTruth.from_scenario(scenario_from_dict(hanging), 0.0)
    grid = truth.rasterize(cell_centers(1.18, 0.18, 16, 21), CELL_M)
    under = grid.labels == TruthLabel.OBSTACLE
    assert under.sum() == 10 * 15  # 0.4 x 0.6 m table = 10 x 15 cells, aligned
    assert np.all(grid.obstacle_top_m[under] == pytest.approx(0.35 + 0.08, abs=1e-12))
    assert np.all(np.isnan(grid.floor_m[under]))
    # The table is no support: the robot stands on the ground under it.
    assert truth.support_height_m([[1.5, 0.6]]) == pytest.approx([0.0])
    # The curtain (x 0.95..1.05, y 0.1..0.6, 0.2..1.2 m): cells with centres 0.96, 1.0, 1.04.
    grid = truth.rasterize(cell_centers(0.9, 0.0, 5, 20), CELL_M)
    curtain = grid.labels == TruthLabel.OBSTACLE
    assert curtain.any(axis=1).tolist() == [False, True, True, True, False]
    assert curtain[2].sum() == 13  # cell centres 0.1..0.58 lie on y 0.1..0.6 (edges included)
    assert np.all(grid.obstacle_top_m[curtain] == pytest.approx(1.2))
    # Only the middle column (x 0.98..1.02) lies wholly under the curtain.
    assert (
        grid.interior[curtain].sum() == 12
    )  # y 0.1..0.6 wholly holds cells 0.12..0.16 to 0.56..0.60
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
    assert grid.labels[12, 12] == TruthLabel.OBSTACLE
    assert grid.obstacle_top_m[12, 12] == pytest.approx(0.4)
    assert grid.floor_m[2, 2] == pytest.approx(0.1)


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
