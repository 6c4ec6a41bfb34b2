"""Scenario files: every shipped file validates, every kind of mistake names file, key, rule."""

from __future__ import annotations

import tomllib
from pathlib import Path

import pytest

from fogsim.config.scenario import (
    Scenario,
    list_scenarios,
    load_scenario,
    scenario_from_dict,
)
from fogsim.errors import ScenarioError

MINIMAL = """
name = "t"
seed = 1
[[objects]]
name = "box"
center = [1.0, 0.5]
size = [0.2, 0.2, 0.1]
[[route]]
walk_to = [1.0, 0.5]
[[events]]
at = 1.0
remove = "box"
"""


def test_registry_every_shipped_scenario_validates_and_round_trips():
    paths = list_scenarios()
    names = {p.stem for p in paths}
    assert {"stage", "box_removal", "moving_box", "simulated_world"} <= names
    for path in paths:
        scenario = load_scenario(path)
        assert scenario.name == path.stem
        assert scenario.source_path == path
        again = scenario_from_dict(tomllib.loads(scenario.to_toml()))
        assert again == scenario


def test_stage_matches_the_paper_course():
    stage = load_scenario("stage")
    heights = {o.name: o.size[2] for o in stage.objects if o.walkable}
    assert heights == pytest.approx(
        {"sill": 0.038, "step_1": 0.031, "step_2": 0.061, "step_3": 0.092, "platform": 0.122},
        abs=1e-12,
    )
    assert sum(not o.walkable for o in stage.objects) >= 3
    assert stage.robot.start == (0.3, 0.5, 0.0)
    assert stage.camera.width == 88 and stage.camera.height == 72
    assert stage.camera.fov_deg == (47.0, 39.0)


def test_simulated_world_has_rough_obstacles_and_ideal_camera():
    world = load_scenario("simulated_world")
    assert world.camera.mode == "ideal"
    assert sum(o.surface == "rough" for o in world.objects) == 2
    # Ground + two walkable levels = three floor levels.
    assert len({o.size[2] for o in world.objects if o.walkable}) == 2


def _write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "bad.toml"
    path.write_text(text)
    return path


@pytest.mark.parametrize(
    ("edit", "key", "rule"),
    [
        (("seed = 1", "seed = 1\ncolour = 3"), "colour", "unknown key"),
        (("seed = 1", 'seed = "one"'), "seed", "integer"),
        (("seed = 1", "seed = -4"), "seed", "in [0"),
        (("seed = 1", "seed = 1\n[camera]\nmode = 'lidar'"), "camera.mode", "ideal, depth, stereo"),
        (("seed = 1", "seed = 1\n[camera]\nfov_deg = [47.0]"), "camera.fov_deg", "2 numbers"),
        (("seed = 1", "seed = 1\n[camera]\nwidth = 2.5"), "camera.width", "integer"),
        (("seed = 1", "seed = 1\n[robot]\nmodel = 'asimo'"), "robot.model", "icub, talos"),
        (("seed = 1", "seed = 1\n[encoders]\nbias_deg = -1"), "encoders.bias_deg", "in [0.0"),
        (("seed = 1", "seed = 1\n[encoders]\nnoise = 1"), "encoders.noise", "unknown key"),
        (("size = [0.2, 0.2, 0.1]", "size = [0.2, 0.2, -0.1]"), "objects[0].size[2]", "in ["),
        (
            ("size = [0.2, 0.2, 0.1]", "size = [0.2, 0.2, 0.1]\nsurface = 'wavy'"),
            "objects[0].surface",
            "flat, rough",
        ),
        (
            ("size = [0.2, 0.2, 0.1]", "size = [0.2, 0.2, 0.1]\nwalkable = 1"),
            "objects[0].walkable",
            "true or false",
        ),
        (
            (
                "size = [0.2, 0.2, 0.1]",
                "size = [0.2, 0.2, 0.1]\nsurface = 'rough'\nwalkable = true",
            ),
            "objects[0].walkable",
            "rough",
        ),
        (("center = [1.0, 0.5]\n", ""), "objects[0].center", "required"),
        (("walk_to = [1.0, 0.5]", "walk_to = [1.0, 0.5]\nwait = 2.0"), "route[0]", "exactly one"),
        (("walk_to = [1.0, 0.5]", "jump = 1.0"), "route[0].jump", "unknown key"),
        (("walk_to = [1.0, 0.5]", "look = [0.0, -120.0]"), "route[0].look[1]", "in [-90.0"),
        (('remove = "box"', 'remove = "ball"'), "events[0].remove", "no object named 'ball'"),
        (('remove = "box"', 'move = "box"\nto = [1.0, 1.0]'), "events[0].speed", "required"),
        (('remove = "box"', 'remove = "box"\nspeed = 0.1'), "events[0].speed", "only allowed"),
        (("seed = 1", "seed = 1\n[mapper]\np_occ = 'high'"), "mapper.p_occ", "number"),
    ],
)
def test_each_mistake_names_file_key_and_rule(tmp_path, edit, key, rule):
    old, new = edit
    assert old in MINIMAL
    path = _write(tmp_path, MINIMAL.replace(old, new, 1))
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    message = str(info.value)
    assert str(path) in message
    assert f"{key}:" in message
    assert rule in message


def test_duplicate_object_names_and_bad_toml(tmp_path):
    dup = MINIMAL + '[[objects]]\nname = "box"\ncenter = [0, 0]\nsize = [0.1, 0.1, 0.1]\n'
    with pytest.raises(ScenarioError, match=r"objects\[1\]\.name: duplicate"):
        load_scenario(_write(tmp_path, dup))
    with pytest.raises(ScenarioError, match="not valid TOML"):
        load_scenario(_write(tmp_path, "name = "))
    with pytest.raises(ScenarioError, match=r"known scenarios: .*stage"):
        load_scenario("no_such_scenario")


def test_overrides_apply_and_validate():
    stage = load_scenario("stage")
    changed = stage.with_overrides(
        ["camera.mode=ideal", "seed=3", "encoders.bias_deg=0", "objects.sill.size=[0.1, 1, 0.04]"]
    )
    assert changed.camera.mode == "ideal" and changed.seed == 3
    assert changed.encoders.bias_deg == 0.0
    assert changed.object("sill").size == (0.1, 1.0, 0.04)
    assert stage.camera.mode == "depth"  # the original is untouched (frozen)
    with pytest.raises(ScenarioError, match=r"camera.mode: must be one of ideal, depth, stereo"):
        stage.with_overrides(["camera.mode=lidar"])
    with pytest.raises(ScenarioError, match="key=value"):
        stage.with_overrides(["seed"])
    with pytest.raises(ScenarioError, match=r"camera.colour: unknown key"):
        stage.with_overrides(["camera.colour=red"])
    with pytest.raises(ScenarioError, match="no entry named 'ghost'"):
        stage.with_overrides(["objects.ghost.base=1"])


def test_defaults_fill_missing_sections():
    scenario = scenario_from_dict({"name": "bare"})
    assert isinstance(scenario, Scenario)
    assert scenario.camera.mode == "depth" and scenario.frame_rate_hz == 12.5
    assert scenario.robot.model == "icub" and scenario.objects == ()


def test_parameter_tables_are_checked_against_the_parameter_classes():
    mapper = pytest.importorskip("mapper")
    segmentation = pytest.importorskip("mapper.segmentation")
    stage = load_scenario("stage")
    changed = stage.with_overrides(["mapper.p_occ=0.7", "mapper.nx=120"])
    assert changed.mapper == {"p_occ": 0.7, "nx": 120}
    assert isinstance(changed.mapper["nx"], int)
    with pytest.raises(ScenarioError, match=r"mapper\.p_ocx: unknown parameter; allowed: .*p_occ"):
        stage.with_overrides(["mapper.p_ocx=0.7"])
    seg_field = next(iter(segmentation.SegmentationParams.__dataclass_fields__))
    assert stage.with_overrides([f"segmentation.{seg_field}=0.1"]).segmentation
    with pytest.raises(ScenarioError, match=r"segmentation\.nonsense: unknown parameter"):
        stage.with_overrides(["segmentation.nonsense=1"])
    assert mapper.MapperParams
