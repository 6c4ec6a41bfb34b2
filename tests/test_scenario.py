"""Scenario files: every shipped file validates, every kind of mistake names file, key, rule."""

from __future__ import annotations

import dataclasses
import tomllib
from pathlib import Path

import numpy as np
import pytest

from fogsim.config import (
    CAMERA_MODES,
    Event,
    RobotSpec,
    RouteStep,
    Scenario,
    SceneObject,
    find_scenario_files,
    load_scenario,
    scenario_from_dict,
    scenario_from_toml,
)
from fogsim.config.limits import (
    MAX_CAMERA_SIDE_PX,
    MAX_EVENTS,
    MAX_OBJECTS,
    MAX_SCENARIO_FILE_BYTES,
    MIN_STEREO_WIDTH_PX,
    SCENARIO_NAME_PATTERN,
)
from fogsim.errors import ScenarioError
from fogsim.paths import HOLDOUT_DIR, SCENARIOS_DIR
from fogsim.robot import load_robot
from fogsim.sim.camera import HeadCamera
from fogsim.sim.camera.stereo import stereo_render_px
from fogsim.sim.scene import Scene

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
    paths = find_scenario_files()
    names = {p.stem for p in paths}
    assert {"stage", "box_removal", "moving_box", "simulated_world"} <= names
    for path in paths:
        scenario = load_scenario(path)
        assert scenario.name == path.stem
        assert scenario.source_path == path
        again = scenario_from_dict(tomllib.loads(scenario.to_toml()))
        assert again == scenario


HOLDOUT_FILES = sorted(HOLDOUT_DIR.glob("*.toml"))


def test_holdout_scenarios_validate_and_stay_out_of_the_default_suite():
    # Scenes no default was tuned on: named by their files, unlike any shipped scenario, said to
    # be held out, each with a Table I row or obstacles to score; never in the default suite.
    assert [p.stem for p in HOLDOUT_FILES] == [
        "down_landing_turn",
        "down_low_steps",
        "down_shallow_steps",
        "down_slant_turn",
        "rock_field",
        "stairs_35_65_100",
        "stairs_40_75_110",
        "stairs_45_70_95",
    ]
    shipped = {p.stem for p in find_scenario_files()}
    assert find_scenario_files(HOLDOUT_DIR) == HOLDOUT_FILES
    assert not shipped & {p.stem for p in HOLDOUT_FILES}
    assert not set(find_scenario_files()) & set(HOLDOUT_FILES)
    for path in HOLDOUT_FILES:
        scenario = load_scenario(path)
        assert scenario.name == path.stem
        assert scenario.description.startswith("Held out (never tuned on")
        assert scenario.mapper == {} and scenario.segmentation == {}  # the defaults, untouched
        assert scenario.objects and scenario.route
        assert scenario_from_dict(tomllib.loads(scenario.to_toml())) == scenario


def test_every_look_of_every_scenario_is_within_its_robots_neck_reach():
    # A look beyond the neck used to be clamped silently: two held-out scenes asked for 55° down
    # and iCub looked 40° down, so their descending starts never saw the top step. The
    # planner refuses such a look now (tests/test_walking.py); no scene may ask for one.
    robots = {}
    looks = 0
    for path in find_scenario_files() + HOLDOUT_FILES:
        scenario = load_scenario(path)
        model = scenario.robot.model
        reach = robots.setdefault(model, load_robot(model)).look_range
        for step in scenario.route:
            if step.look is not None:
                assert reach.refusal(*step.look) is None, f"{path.name}: look {step.look}"
                looks += 1
    assert set(robots) == {"icub", "talos"} and looks > 40


def test_holdout_edges_do_not_all_lie_on_cell_boundaries():
    # The shipped staircases put every tread edge on a 4 cm cell boundary; a held-out one must
    # not, or the scenes would hide cells that straddle a riser (the truth's obstacles).
    cell_m = 0.04
    off = 0
    for path in HOLDOUT_FILES:
        for obj in load_scenario(path).objects:
            for axis in (0, 1):
                for sign in (-1.0, 1.0):
                    edge = obj.center[axis] + sign * obj.size[axis] / 2.0
                    off += abs(edge / cell_m - round(edge / cell_m)) > 1e-6
    assert off >= 10


def test_stage_matches_the_paper_course():
    stage = load_scenario("stage")
    heights = {o.name: o.size[2] for o in stage.objects if o.walkable}
    assert heights == pytest.approx(
        {"sill": 0.038, "step_1": 0.031, "step_2": 0.061, "step_3": 0.092, "platform": 0.122},
        abs=1e-12,
    )
    assert sum(not o.walkable for o in stage.objects) >= 3
    assert stage.robot.start == (0.0, 0.5, 0.0)  # the stage's near edge: every box in view
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


def test_a_parameter_table_may_be_named_by_its_short_prefix():
    # The README, the tuner and the bench tools name parameters `head.`, `seg.`, `pipe.`,
    # `ref.`, `elev.`: the same keys go into the scenario's tables; an unknown prefix is
    # still refused with the tables listed, under the key as given.
    stage = load_scenario("stage")
    short = stage.with_overrides(["head.min_contrast=0.2", "pipe.heading_rebuild_frames=10"])
    long = stage.with_overrides(["heading.min_contrast=0.2", "pipeline.heading_rebuild_frames=10"])
    assert short == long
    assert short.heading == {"min_contrast": 0.2}
    assert short.pipeline == {"heading_rebuild_frames": 10}
    with pytest.raises(ScenarioError, match=r"key 'hed\.min_contrast': 'hed' is not a table"):
        stage.with_overrides(["hed.min_contrast=0.2"])
    with pytest.raises(ScenarioError, match=r"heading\.nonsense: unknown heading parameter"):
        stage.with_overrides(["head.nonsense=1"])


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
    with pytest.raises(
        ScenarioError,
        match=r"mapper\.p_ocx: unknown mapper parameter\(s\) \['p_ocx'\]; allowed: .*p_occ",
    ):
        stage.with_overrides(["mapper.p_ocx=0.7"])
    seg_field = next(iter(segmentation.SegmentationParams.__dataclass_fields__))
    assert stage.with_overrides([f"segmentation.{seg_field}=0.1"]).segmentation
    with pytest.raises(
        ScenarioError, match=r"segmentation\.nonsense: unknown segmentation parameter"
    ):
        stage.with_overrides(["segmentation.nonsense=1"])
    assert mapper.MapperParams


# --------------------------------------------------------------------- known answers per file

SHIPPED = {
    # name: (seed, robot model, start (x [m], y [m], yaw [deg]), camera mode,
    #        (bias, noise, head bias, head noise) [deg], objects)
    "box_removal": (2, "icub", (0.3, 0.5, 0.0), "depth", (0.5, 0.2, 0.5, 0.2), 1),
    "eth_stairs": (1, "icub", (-0.3, 0.5, 0.0), "depth", (0.05, 0.02, 4.0, 0.3), 1),
    "flat_floor": (5, "icub", (0.3, 0.5, 0.0), "depth", (0.05, 0.02, 4.0, 0.3), 0),
    "flat_floor_talos": (5, "talos", (0.3, 0.5, 0.0), "depth", (0.05, 0.02, 4.0, 0.3), 0),
    "moving_box": (3, "icub", (0.3, 0.5, 0.0), "depth", (0.5, 0.2, 0.5, 0.2), 1),
    "room": (2, "icub", (0.3, 0.5, 0.0), "depth", (0.05, 0.02, 4.0, 0.3), 8),
    "simulated_world": (4, "icub", (0.3, 0.5, 0.0), "ideal", (0.0, 0.0, 0.0, 0.0), 4),
    "stage": (1, "icub", (0.0, 0.5, 0.0), "depth", (0.05, 0.02, 4.0, 0.3), 9),
    "stage_down": (1, "icub", (3.75, 0.5, 180.0), "depth", (0.05, 0.02, 4.0, 0.3), 9),
    "stage_offgrid": (1, "icub", (0.0, 0.5, 0.0), "depth", (0.05, 0.02, 4.0, 0.3), 9),
    "stage_zigzag": (1, "icub", (-0.3, 0.5, 0.0), "depth", (0.05, 0.02, 4.0, 0.3), 9),
    "stairs": (1, "icub", (0.3, 0.5, 0.0), "depth", (0.05, 0.02, 4.0, 0.3), 4),
    "table": (6, "icub", (0.3, 0.5, 0.0), "depth", (0.05, 0.02, 4.0, 0.3), 2),
    "talos_course": (3, "talos", (0.3, 0.5, 0.0), "depth", (0.05, 0.02, 4.0, 0.3), 9),
    "untextured": (1, "icub", (0.3, 0.5, 0.0), "stereo", (0.5, 0.2, 0.5, 0.2), 2),
}


def _types(value: object) -> object:
    """The value with every leaf replaced by its type (tuples, dataclasses kept; as ``==``)."""
    if dataclasses.is_dataclass(value):
        fields = [f for f in dataclasses.fields(value) if f.compare]
        return (type(value), tuple(_types(getattr(value, f.name)) for f in fields))
    if isinstance(value, tuple):
        return tuple(_types(v) for v in value)
    if isinstance(value, dict):
        return {k: _types(v) for k, v in value.items()}
    return type(value)


@pytest.mark.parametrize("path", find_scenario_files(), ids=lambda p: p.stem)
def test_every_shipped_file_decodes_to_its_known_values(path):
    scenario = load_scenario(path)
    seed, model, start, mode, encoders, n_objects = SHIPPED[path.stem]
    assert scenario.name == path.stem and scenario.source_path == path
    assert scenario.seed == seed and scenario.frame_rate_hz == 12.5
    assert scenario.robot == RobotSpec(model=model, start=start)
    assert scenario.camera.mode == mode and scenario.camera.fov_deg == (47.0, 39.0)
    e = scenario.encoders
    assert (e.bias_deg, e.noise_deg, e.head_bias_deg, e.head_noise_deg) == encoders
    assert len(scenario.objects) == n_objects
    assert scenario.mapper == {} and scenario.segmentation == {}
    # Types as the file's contract says: floats stay floats (an int in the file becomes one),
    # arrays become tuples.
    assert type(scenario.robot.start) is tuple and type(scenario.robot.start[0]) is float
    assert all(type(x) is float for o in scenario.objects for x in (*o.center, *o.size))
    assert all(type(s.kind) is str for s in scenario.route)


def test_shipped_routes_and_events_are_read_exactly():
    box_removal = load_scenario("box_removal")
    assert box_removal.route == (RouteStep(look=(0.0, -35.0)), RouteStep(wait=9.0))
    assert box_removal.events == (Event(at=4.0, remove="flat_box"),)
    (event,) = box_removal.events
    assert (event.kind, event.target, event.to, event.speed) == ("remove", "flat_box", None, None)
    (move,) = load_scenario("moving_box").events
    assert move == Event(at=2.0, move="flat_box", to=(1.35, 1.0), speed=0.08)
    assert (move.kind, move.target) == ("move", "flat_box")
    assert load_scenario("moving_box").object("flat_box").size == (0.3, 0.3, 0.06)


# --------------------------------------------------------------------- messages, word for word


def _error(tmp_path: Path, text: str) -> tuple[Path, str]:
    path = _write(tmp_path, text)
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    return path, str(info.value)


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        # a wrong type
        (("seed = 1", 'seed = "one"'), "seed: must be an integer in [0, 4294967295], got 'one'"),
        (
            ("seed = 1", "seed = 1\n[camera]\nwidth = 2.5"),
            "camera.width: must be an integer in [8, 2048], got 2.5",
        ),
        # an out-of-range value
        (
            ("seed = 1", "seed = 1\n[encoders]\nbias_deg = -1"),
            "encoders.bias_deg: must be a number in [0.0, 10.0], got -1",
        ),
        # an unknown key, with every allowed one
        (
            ("seed = 1", "seed = 1\ncolour = 3"),
            "colour: unknown key; allowed: name, description, seed, frame_rate_hz, robot, camera, "
            "encoders, objects, route, events, mapper, segmentation",
        ),
        (
            ("seed = 1", 'seed = 1\nsource_path = "x.toml"'),
            "source_path: unknown key; allowed: name, description",
        ),
        # an unknown choice, in the schema's order
        (
            ("seed = 1", "seed = 1\n[camera]\nmode = 'lidar'"),
            "camera.mode: must be one of ideal, depth, stereo, got 'lidar'",
        ),
        # a value nested in an array of tables
        (
            (
                "[[route]]",
                '[[objects]]\nname = "b2"\ncenter = [0, 0]\nsize = [0.2, 0.2]\n[[route]]',
            ),
            "objects[1].size: must be an array of 3 numbers in [0.005, 100.0], got [0.2, 0.2]",
        ),
        (
            (
                "[[route]]",
                '[[objects]]\nname = "b2"\ncenter = [0, 0]\nsize = [0.2, 0.2, 0]\n[[route]]',
            ),
            "objects[1].size[2]: must be a number in [0.005, 100.0], got 0",
        ),
        (
            ('name = "box"', 'name = "a box"'),
            "objects[0].name: must be letters, digits, '_' or '-', got 'a box'",
        ),
        (("[[route]]", "[[route]]\nwait = 1.0"), "route[0]: must have exactly one of walk_to"),
        # [mapper] and [segmentation] are checked at load, by the parameter classes' own rules
        (
            ("seed = 1", "seed = 1\n[mapper]\np_occ = 1.5"),
            "mapper.p_occ: MapperParams.p_occ must be in (0.5, 1), got 1.5",
        ),
        (
            ("seed = 1", "seed = 1\n[segmentation]\nmin_plane_pixels = 2.5"),
            "segmentation.min_plane_pixels: must be an integer, got 2.5",
        ),
        # resource bounds (issue 13): rates, image sides, positions and sizes, finite numbers
        (
            ("seed = 1", "seed = 1\nframe_rate_hz = 100.5"),
            "frame_rate_hz: must be a number in [0.1, 100.0], got 100.5",
        ),
        (
            ("seed = 1", "seed = 1\n[camera]\nheight = 4096"),
            "camera.height: must be an integer in [8, 2048], got 4096",
        ),
        (
            ("center = [1.0, 0.5]", "center = [nan, 1000.5]"),
            "objects[0].center[0]: must be a number in [-1000.0, 1000.0], got nan",
        ),
        (
            ("center = [1.0, 0.5]", "center = [1.0, inf]"),
            "objects[0].center[1]: must be a number in [-1000.0, 1000.0], got inf",
        ),
        (
            ("center = [1.0, 0.5]", "center = [1000.5, 0.5]"),
            "objects[0].center[0]: must be a number in [-1000.0, 1000.0], got 1000.5",
        ),
        (
            ("size = [0.2, 0.2, 0.1]", "size = [0.2, 100.5, 0.1]"),
            "objects[0].size[1]: must be a number in [0.005, 100.0], got 100.5",
        ),
        (
            ("walk_to = [1.0, 0.5]", "walk_to = [-inf, 0.5]"),
            "route[0].walk_to[0]: must be a number in [-1000.0, 1000.0], got -inf",
        ),
        (
            ("walk_to = [1.0, 0.5]", "wait = nan"),
            "route[0].wait: must be a number in [0.001, 3600.0], got nan",
        ),
    ],
)
def test_error_messages_name_file_key_value_and_what_is_allowed(tmp_path, edit, message):
    old, new = edit
    assert old in MINIMAL
    path, got = _error(tmp_path, MINIMAL.replace(old, new, 1))
    assert got.startswith(f"{path}: {message}")


def test_rules_across_fields_hold_for_direct_construction_too():
    with pytest.raises(ScenarioError, match="walkable: a rough top is no plane"):
        SceneObject("b", (0.0, 0.0), (1.0, 1.0, 1.0), surface="rough", walkable=True)
    with pytest.raises(ScenarioError, match=r"range_m: must be \[min, max\] with min < max"):
        dataclasses.replace(load_scenario("stage").camera, range_m=(2.0, 1.0))
    with pytest.raises(ScenarioError, match="speed: is required with move"):
        Event(at=1.0, move="b", to=(0.0, 0.0))


def test_head_encoder_levels_default_to_the_body_levels_a_file_gives():
    only_bias = scenario_from_dict({"name": "t", "encoders": {"bias_deg": 1}}).encoders
    assert (only_bias.head_bias_deg, only_bias.head_noise_deg) == (1.0, 0.3)
    assert type(only_bias.head_bias_deg) is float
    explicit = scenario_from_dict({"name": "t", "encoders": {"bias_deg": 1, "head_bias_deg": 2}})
    assert explicit.encoders.head_bias_deg == 2.0
    assert scenario_from_dict({"name": "t"}).encoders.head_bias_deg == 4.0


# --------------------------------------------------------------------- writing and finding

EVERYTHING = {
    "name": "everything",
    "description": 'quotes " and \\ and a\nnew line',
    "seed": 4294967295,
    "frame_rate_hz": 25,
    "robot": {"model": "talos", "start": [-1, 2.5, 90]},
    "camera": {"mode": "stereo", "range_m": [0.2, 3.0], "dropout": 0},
    "encoders": {"noise_deg": 0.1},
    "objects": [
        {"name": "rough_1", "center": [1, 0], "size": [0.2, 0.2, 0.3], "surface": "rough"},
        {"name": "slab", "center": [2, 0], "size": [1, 1, 0.1], "walkable": True, "base": 0.1},
    ],
    "route": [{"walk_to": [1, 2]}, {"turn_to": -90}, {"look": [0, -30]}, {"wait": 0.5}],
    "events": [
        {"at": 1, "remove": "rough_1"},
        {"at": 2, "move": "slab", "to": [3, 0], "speed": 0.05},
    ],
    "mapper": {"p_occ": 0.7, "nx": 120, "clear_outside": False, "max_range_m": float("inf")},
    "segmentation": {"min_plane_pixels": 30},
    "heading": {"interior_peak": False, "structure_stall_keyframes": 8, "min_contrast": 0.2},
    "pipeline": {"heading_rebuild_frames": 800},
    "reference": {"gate_m": 0.03},
    "elevation": {"gain": 0.5},
}


@pytest.mark.parametrize("source", [*find_scenario_files(), "everything"], ids=str)
def test_toml_round_trip_is_exact(source):
    scenario = scenario_from_dict(EVERYTHING) if source == "everything" else load_scenario(source)
    text = scenario.to_toml()
    assert tomllib.loads(text) == scenario.to_dict()
    again = scenario_from_toml(text)
    assert again == scenario
    assert _types(again) == _types(scenario)  # an int stays an int, a float a float


def test_find_scenario_files_by_name_path_directory_or_nothing(tmp_path):
    shipped = find_scenario_files()
    assert shipped == sorted(SCENARIOS_DIR.glob("*.toml"))
    assert find_scenario_files("stage") == [SCENARIOS_DIR / "stage.toml"]
    assert find_scenario_files(SCENARIOS_DIR / "stage.toml") == [SCENARIOS_DIR / "stage.toml"]
    assert find_scenario_files(SCENARIOS_DIR) == shipped
    with pytest.raises(ScenarioError, match=r"no scenario file 'nope'.*known scenarios: .*stage"):
        find_scenario_files("nope")
    with pytest.raises(ScenarioError, match=r"no scenario files \(\*\.toml\) in"):
        find_scenario_files(tmp_path)
    with pytest.raises(ScenarioError, match=f"is a directory of {len(shipped)} scenario files"):
        load_scenario(SCENARIOS_DIR)
    assert CAMERA_MODES == ("ideal", "depth", "stereo")


# --------------------------------------------------------------------- hostile input (issue 13)


@pytest.mark.parametrize(
    "name", ["../../x", "/etc/passwd", "a/b", "..", ".", ".hidden", "-rf", "a..b", "x" * 65, ""]
)
def test_a_scenario_name_must_be_a_safe_file_name(tmp_path, name):
    path, got = _error(tmp_path, MINIMAL.replace('name = "t"', f"name = {name!r}", 1))
    assert got.startswith(f"{path}: name: must be a safe file name: ")
    assert SCENARIO_NAME_PATTERN in got and got.endswith(f"got {name!r}")


def test_safe_names_pass_and_every_way_to_a_name_is_checked():
    assert scenario_from_dict({"name": "a.b-c_1"}).name == "a.b-c_1"
    assert scenario_from_dict({"name": "x" * 64}).name == "x" * 64
    embedded = 'name = "../../x"\n'  # a recording's scenario decodes through the same function
    with pytest.raises(ScenarioError, match=r"^recording r\.npz: name: must be a safe file name"):
        scenario_from_toml(embedded, where="recording r.npz")
    with pytest.raises(ScenarioError, match=r"\(override\): name: must be a safe file name"):
        load_scenario("stage").with_overrides(["name=../x"])
    with pytest.raises(ScenarioError, match="name: must be a safe file name"):
        dataclasses.replace(load_scenario("stage"), name="/tmp/x")


def test_unreadable_or_non_text_files_name_the_file(tmp_path, monkeypatch):
    binary = tmp_path / "binary.toml"
    binary.write_bytes(b"name = 't'\n\x00\xff\xfe junk")
    with pytest.raises(
        ScenarioError, match=r"binary\.toml: not UTF-8 text \(byte 12 is b'\\xff'\)"
    ):
        load_scenario(binary)
    latin = tmp_path / "latin.toml"
    latin.write_bytes('name = "café"\n'.encode("latin-1"))
    with pytest.raises(ScenarioError, match=r"latin\.toml: not UTF-8 text \(byte 11 is b'\\xe9'\)"):
        load_scenario(latin)
    (tmp_path / "folder.toml").mkdir()
    with pytest.raises(ScenarioError, match=r"folder\.toml is a directory of 0 scenario files"):
        load_scenario(tmp_path / "folder.toml")
    locked = _write(tmp_path, MINIMAL)

    def refuse(self, *args, **kwargs):  # the tests run as root: chmod 000 would not stop a read
        raise PermissionError(13, "Permission denied", str(self))

    monkeypatch.setattr(Path, "open", refuse)
    with pytest.raises(
        ScenarioError, match=r"bad\.toml: cannot read the scenario file: Permission"
    ):
        load_scenario(locked)


def test_huge_files_deep_nesting_and_huge_integers_name_the_file(tmp_path):
    huge = tmp_path / "huge.toml"
    huge.write_bytes(b"#" * (MAX_SCENARIO_FILE_BYTES + 1))
    with pytest.raises(ScenarioError, match=r"huge\.toml: larger than 1048576 bytes"):
        load_scenario(huge)
    deep = _write(tmp_path, "name = 't'\nx = " + "[" * 5000 + "]" * 5000)
    with pytest.raises(ScenarioError, match=r"bad\.toml: arrays or tables nested too deeply"):
        load_scenario(deep)
    with pytest.raises(ScenarioError, match=r"not valid TOML: Exceeds the limit \(4300 digits\)"):
        load_scenario(_write(tmp_path, "name = 't'\nseed = " + "9" * 5000))
    _, got = _error(tmp_path, "name = 't'\nseed = 0x" + "f" * 3000)
    assert got.endswith("seed: must be an integer in [0, 4294967295], got an integer of 12000 bits")
    _, got = _error(tmp_path, "name = 't'\n[mapper]\np_occ = 0x" + "f" * 3000)
    assert got.endswith("mapper.p_occ: must be a number, got an integer of 12000 bits")
    for name in ("x" * 5000, "a\x00b"):  # too long for the file system; no file has a NUL
        with pytest.raises(ScenarioError, match=r"^no scenario file ") as info:
            load_scenario(name)
        assert len(str(info.value)) < 400


def test_long_values_and_keys_are_shortened_in_messages(tmp_path):
    _, got = _error(tmp_path, f"name = 't'\ndescription = [{'1, ' * 10000}]")
    assert got.endswith("description: must be a string, got an array of 10000 values")
    _, got = _error(tmp_path, f"name = 't'\nseed = '{'x' * 100000}'")
    assert len(got) < 300 and got.endswith("xxx'")
    _, got = _error(tmp_path, f"name = 't'\n{'k' * 100000} = 1")
    assert len(got) < 400 and f"{'k' * 40}...{'k' * 40}: unknown key" in got


def _boxes(count: int) -> str:
    return "".join(
        f'[[objects]]\nname = "b{i}"\ncenter = [{i % 10}, {i // 10}]\nsize = [0.1, 0.1, 0.1]\n'
        for i in range(count)
    )


def test_at_most_256_objects_and_256_events(tmp_path):
    assert (MAX_OBJECTS, MAX_EVENTS) == (256, 256)
    many = load_scenario(_write(tmp_path, 'name = "t"\n' + _boxes(MAX_OBJECTS)))
    assert len(many.objects) == MAX_OBJECTS
    path, got = _error(tmp_path, 'name = "t"\n' + _boxes(MAX_OBJECTS + 1))
    assert (
        got
        == f"{path}: objects: must be an array of at most 256 tables, got an array of 257 values"
    )
    events = "".join(f'[[events]]\nat = {i}\nremove = "b0"\n' for i in range(MAX_EVENTS + 1))
    path, got = _error(tmp_path, 'name = "t"\n' + _boxes(1) + events)
    assert (
        got == f"{path}: events: must be an array of at most 256 tables, got an array of 257 values"
    )


def test_the_stereo_mode_needs_a_wide_enough_image(tmp_path):
    """OpenCV's matcher crashed on a 16 px wide stereo render (8 px camera)."""
    path, got = _error(
        tmp_path, MINIMAL.replace("seed = 1", "[camera]\nmode = 'stereo'\nwidth = 17")
    )
    assert got == (
        f"{path}: camera.width: must be at least 18 px in the stereo mode (its matcher searches "
        "32 px of disparity at twice the resolution), got 17"
    )
    with pytest.raises(ScenarioError, match=r"camera\.width: must be at least 18 px"):
        load_scenario("stage").with_overrides(["camera.width=8", "camera.mode=stereo"])
    assert load_scenario("stage").with_overrides(["camera.width=8"]).camera.width == 8


@pytest.mark.parametrize(
    "size_px", [(321, 72), (MAX_CAMERA_SIDE_PX, 8), (MIN_STEREO_WIDTH_PX, MAX_CAMERA_SIDE_PX)]
)
def test_every_allowed_camera_size_fits_the_scene_s_offscreen_buffer(size_px):
    """321 × 72 crashed: the robot's MJCF held a 640 px buffer the stereo render (678) outgrew."""
    width, height = size_px
    render_width, render_height = stereo_render_px(width, height)
    assert (render_width, render_height) == (2 * width + 36, 2 * height)  # + 32 px left, 4 right
    scenario = load_scenario("flat_floor").with_overrides(
        [f"camera.width={width}", f"camera.height={height}", "camera.mode=stereo"]
    )
    robot = load_robot(scenario.robot.model)
    scene = Scene(scenario, robot)
    assert (scene.model.vis.global_.offwidth, scene.model.vis.global_.offheight) == (
        max(640, render_width),
        max(480, render_height),
    )
    camera = HeadCamera(scene.model, scene.camera_ids, scenario.camera)
    try:
        depth = camera.capture(scene.data, np.random.default_rng(0))
    finally:
        camera.close()
    assert depth.shape == (height, width)
