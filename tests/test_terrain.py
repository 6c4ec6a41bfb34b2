"""Terrain objects: an 8-bit elevation image as heights, their truth and their MuJoCo geometry.

The synthetic terrain is a 3 × 3 image with 0.2 m cells and ``max_height_m = 2.55`` (a value v is
v / 100 m), centred at (0.2, 0.2) so that it covers x, y 0..0.4, ten 4 cm grid cells a side:

    row 0 (+y, y = 0.4):  10  10  40      left half: flat at 0.10 m above y = 0.2, below it a
    row 1 (y = 0.2):      10  10  40      gentle slope up to 0.25 m at y = 0 (0.03 m per cell);
    row 2 (-y, y = 0):    25  25  55      right half: 0.3 m above the left edge's height, rising
                                           towards +x by 0.06 m per cell.

Every cell of it is a plane (MuJoCo's two triangles and the truth's bilinear surface agree), so
on the terrain at world (x, y), yaw 0: h = 0.10 + max(0, 0.15 (0.2 - y) / 0.2) + max(0,
0.3 (x - 0.2) / 0.2).
"""

from __future__ import annotations

import cv2
import mujoco
import numpy as np
import pytest

from fogsim.config import load_scenario, scenario_from_dict
from fogsim.config import schema as config_schema
from fogsim.errors import ScenarioError
from fogsim.sim.scene import compile_scene
from fogsim.world import SceneTruth, TruthLabel
from fogsim.world.truth import TERRAIN_STEP_M

FLOOR, OBSTACLE = TruthLabel.FLOOR, TruthLabel.OBSTACLE
CELL_M = 0.04
IMAGE = np.array([[10, 10, 40], [10, 10, 40], [25, 25, 55]], dtype=np.uint8)


def height_by_hand(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """The synthetic terrain's height at world points (yaw 0) [m] (module docstring)."""
    return 0.10 + np.maximum(0.0, 0.75 * (0.2 - y)) + np.maximum(0.0, 1.5 * (x - 0.2))


@pytest.fixture
def assets(tmp_path, monkeypatch):
    """A private assets folder holding ``terrain/ramp.png`` (the synthetic image)."""
    (tmp_path / "terrain").mkdir()
    cv2.imwrite(str(tmp_path / "terrain" / "ramp.png"), IMAGE)
    monkeypatch.setattr(config_schema, "ASSETS_DIR", tmp_path)
    return tmp_path


def terrain(**more) -> dict:
    return {
        "name": "ramp",
        "center": [0.2, 0.2],
        "heightfield": "terrain/ramp.png",
        "cell_m": 0.2,
        "max_height_m": 2.55,
        **more,
    }


def scenario_of(*objects: dict):
    return scenario_from_dict({"name": "t", "objects": list(objects)})


def cell_centers(n: int) -> np.ndarray:
    xs = (np.arange(n) + 0.5) * CELL_M
    return np.stack(np.meshgrid(xs, xs, indexing="ij"), axis=-1)


def test_the_real_staircase_image_gives_value_over_255_times_the_max_height():
    (stairs,) = load_scenario("eth_stairs").objects
    heights = stairs.heightfield_m()
    assert heights.shape == (71, 64)
    # Pixel (row 18, column 12) of ETH's real_stairs_125cm.png reads 192 (R = G = B; printed
    # with OpenCV from /work/shared/data/eth_terrain): the top tread, 192 / 255 × 1.25 m up.
    assert heights[18, 12] == pytest.approx(192 / 255 * 1.25)
    assert heights[0, 0] == 0.0  # no data in the map: the ground
    # The footprint spans the samples: 63 × 0.04 m by 70 × 0.04 m, up to the highest (194).
    assert stairs.size == pytest.approx((2.52, 2.8, 194 / 255 * 1.25))
    # The truth reads the same sample where it lies in the world: yaw 180° puts local
    # (x, y) = (-1.26 + 12 × 0.04, 1.4 - 18 × 0.04) at centre - local.
    truth = SceneTruth.from_scenario(load_scenario("eth_stairs"), 0.0)
    world = np.array([[2.26 + 1.26 - 0.48, 0.5 - 1.4 + 0.72]])
    assert truth.support_height_m(world)[0] == pytest.approx(192 / 255 * 1.25)


def test_size_comes_from_the_image_and_round_trips(assets):
    scenario = scenario_of(terrain())
    (ramp,) = scenario.objects
    assert ramp.size == pytest.approx((0.4, 0.4, 0.55))
    assert scenario_from_dict(scenario.to_dict()) == scenario
    assert scenario_of(terrain(size=list(ramp.size))) == scenario


def test_the_truth_of_the_synthetic_terrain_by_hand(assets):
    grid = SceneTruth.from_scenario(scenario_of(terrain()), 0.0).rasterize(cell_centers(10), CELL_M)
    labels = grid.labels
    # Left half (x cells 0-4) is floor: flat at 0.10 m above y = 0.2, on the gentle slope
    # below it at its centre's height 0.25 - 0.75 y (cell (2, 0): y = 0.02 → 0.235 m).
    assert np.all(labels[:5] == FLOOR)
    assert grid.floor_m[2, 7] == pytest.approx(0.10)
    assert grid.floor_m[2, 0] == pytest.approx(0.235)
    assert grid.floor_m[4, 3] == pytest.approx(0.25 - 0.75 * 0.14)
    # Right half rises 0.06 m within each cell, more than δ: obstacle, its top the highest
    # sample (the cell's +x edge, inset by 1e-4 cell; on the slope its -y edge too).
    assert TERRAIN_STEP_M < 0.06
    assert np.all(labels[5:] == OBSTACLE)
    assert grid.obstacle_top_m[9, 5] == pytest.approx(0.4, abs=1e-4)
    assert grid.obstacle_top_m[5, 5] == pytest.approx(0.1 + 1.5 * 0.04, abs=1e-4)
    assert grid.obstacle_top_m[7, 0] == pytest.approx(0.25 + 1.5 * 0.12, abs=1e-4)
    # A terrain is no Table I row, and its cells name it.
    assert grid.surface_names == ("ground",)
    assert np.all(grid.surface_id[:5] == -1)
    assert np.all(grid.object_id == 0)


def test_a_cell_rising_more_than_delta_on_a_floor_is_an_obstacle(assets):
    # Columns 10 10 16 16 16 with 0.04 m cells: flat at 0.10 m, 0.06 m up within grid cell 1,
    # flat again at 0.16 m (a 0.16 m square: room for iCub's foot).
    image = np.tile(np.array([10, 10, 16, 16, 16], dtype=np.uint8), (5, 1))
    cv2.imwrite(str(assets / "terrain" / "step.png"), image)
    step = terrain(heightfield="terrain/step.png", cell_m=0.04, center=[0.08, 0.08])
    grid = SceneTruth.from_scenario(scenario_of(step), 0.0).rasterize(cell_centers(4), CELL_M)
    assert grid.labels.tolist() == [[FLOOR] * 4, [OBSTACLE] * 4, [FLOOR] * 4, [FLOOR] * 4]
    assert grid.floor_m[0, 0] == pytest.approx(0.10)
    assert grid.floor_m[3, 2] == pytest.approx(0.16)


def test_mujoco_s_height_field_has_the_truth_s_heights(assets):
    # Turned by 90°: local (x, y) → world (-y, x) about the centre.
    scenario = scenario_of(terrain(yaw_deg=90.0))
    model = compile_scene(scenario, None)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    local = np.random.default_rng(3).uniform(-0.199, 0.199, size=(40, 2))
    world = np.array([0.2, 0.2]) + local[:, ::-1] * [-1.0, 1.0]
    expected = height_by_hand(local[:, 0] + 0.2, local[:, 1] + 0.2)
    geom = np.zeros(1, dtype=np.int32)
    down = np.array([0.0, 0.0, -1.0])
    hits = [
        1.0 - mujoco.mj_ray(model, data, np.array([x, y, 1.0]), down, None, 1, -1, geom)
        for x, y in world
    ]
    assert hits == pytest.approx(expected, abs=1e-6)
    truth = SceneTruth.from_scenario(scenario, 0.0)
    assert truth.support_height_m(world) == pytest.approx(expected, abs=1e-9)


@pytest.mark.parametrize(
    ("more", "key", "rule"),
    [
        ({"heightfield": "../outside.png"}, "heightfield", "must be an image file inside"),
        ({"heightfield": "terrain/missing.png"}, "heightfield", "'terrain/missing.png'"),
        ({"heightfield": "terrain/deep.png"}, "heightfield", "8-bit image, got 'terrain/deep"),
        ({"heightfield": "terrain/colour.png"}, "heightfield", "must be grey"),
        ({"heightfield": "terrain/tiny.png"}, "heightfield", "3 to 512 pixels a side, got 5 × 2"),
        ({"heightfield": "terrain/junk.png"}, "heightfield", "(unreadable)"),
        ({"size": [0.4, 0.4, 0.3]}, "size", "omit it or give [0.4, 0.4, 0.5"),
        ({"base": 0.1}, "base", "must be 0.0 for a heightfield"),
        ({"walkable": True}, "walkable", "must be False for a heightfield"),
        ({"surface": "rough"}, "surface", "must be 'flat' for a heightfield"),
        ({"cell_m": 0.001}, "cell_m", "in [0.005"),
        ({"max_height_m": -1.0}, "max_height_m", "in [0.01"),
        ({"heightfield": 3}, "heightfield", "str"),
    ],
)
def test_bad_heightfields_are_refused_by_key(assets, more, key, rule):
    (assets / "outside.png").write_bytes(b"")
    cv2.imwrite(str(assets / "terrain" / "deep.png"), IMAGE.astype(np.uint16) * 256)
    cv2.imwrite(str(assets / "terrain" / "colour.png"), np.dstack([IMAGE, IMAGE, IMAGE + 1]))
    cv2.imwrite(str(assets / "terrain" / "tiny.png"), np.zeros((2, 5), dtype=np.uint8))
    (assets / "terrain" / "junk.png").write_bytes(b"not a png")
    with pytest.raises(ScenarioError) as info:
        scenario_of(terrain(**more))
    message = str(info.value)
    assert f"objects[0].{key}:" in message
    assert rule in message


@pytest.mark.parametrize(
    ("obj", "key", "rule"),
    [
        (
            {"name": "b", "center": [1, 0], "size": [0.2, 0.2, 0.2], "cell_m": 0.04},
            "cell_m",
            "only allowed with heightfield",
        ),
        (
            {"name": "b", "center": [1, 0], "max_height_m": 1.0, "size": [0.2, 0.2, 0.2]},
            "max_height_m",
            "only allowed with heightfield",
        ),
        ({"name": "b", "center": [1, 0]}, "size", "is required"),
    ],
)
def test_boxes_need_a_size_and_take_no_heightfield_keys(obj, key, rule):
    with pytest.raises(ScenarioError, match=rf"objects\[0\]\.{key}: .*{rule}"):
        scenario_of(obj)


def test_boxes_are_written_without_the_heightfield_keys():
    box = {"name": "b", "center": [1.0, 0.0], "size": [0.2, 0.2, 0.2]}
    (written,) = scenario_of(box).to_dict()["objects"]
    assert not {"heightfield", "cell_m", "max_height_m"} & set(written)
