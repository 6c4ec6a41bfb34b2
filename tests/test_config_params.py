"""replace_params, the one mapping → parameter dataclass helper, and resolve_params on top."""

from __future__ import annotations

import dataclasses
import math
import tomllib

import pytest

from fogsim.config import (
    PipelineParams,
    RunParams,
    load_scenario,
    replace_params,
    resolve_params,
    scenario_from_dict,
)
from fogsim.errors import FogsimError, ParameterError, ScenarioError
from fogsim.run.runner import sensor_fields
from mapper import ElevationFilterParams, MapperParams
from mapper.segmentation import SegmentationParams

MAPPER_FIELDS = [f.name for f in dataclasses.fields(MapperParams)]


def test_no_changes_give_the_same_object():
    params = MapperParams()
    assert replace_params(params, {}, "mapper") is params


def test_values_are_typed_by_the_field():
    params = replace_params(
        MapperParams(), {"nx": 120.0, "clear_outside": 0, "eps_m": 0, "p_occ": 0.7}, "mapper"
    )
    assert params.nx == 120 and type(params.nx) is int  # integral float → int field
    assert params.clear_outside is False  # 1 / 0 → bool field
    assert params.eps_m == 0 and type(params.eps_m) is int  # a number is kept as given
    assert params.p_occ == 0.7
    assert replace_params(SegmentationParams(), {"correct_tilt": True}, "seg").correct_tilt


@pytest.mark.parametrize(
    ("params", "changes", "where", "message"),
    [
        # unknown names, with the allowed ones
        (
            MapperParams(),
            {"p_ocx": 0.7, "zz": 1},
            "mapper",
            f"mapper.p_ocx: unknown mapper parameter(s) ['p_ocx', 'zz']; allowed: {MAPPER_FIELDS}",
        ),
        # wrong types, naming the field
        (MapperParams(), {"p_occ": "high"}, "mapper", "mapper.p_occ: must be a number, got 'high'"),
        (MapperParams(), {"p_occ": True}, "mapper", "mapper.p_occ: must be a number, got True"),
        (MapperParams(), {"p_occ": math.nan}, "mapper", "mapper.p_occ: must be a number, got nan"),
        (MapperParams(), {"nx": 2.5}, "mapper", "mapper.nx: must be an integer, got 2.5"),
        # integers beyond the float range, strings of any length: shown short
        (
            MapperParams(),
            {"p_occ": 2**2000},
            "mapper",
            "mapper.p_occ: must be a number, got an integer of 2001 bits",
        ),
        (
            MapperParams(),
            {"nx": 16**3000},
            "mapper",
            "mapper.nx: must be a number, got an integer of 12001 bits",
        ),
        (
            MapperParams(),
            {"p_occ": "x" * 10_000},
            "mapper",
            f"mapper.p_occ: must be a number, got '{'x' * 37}...{'x' * 38}'",
        ),
        (
            MapperParams(),
            {"clear_outside": 2},
            "mapper",
            "mapper.clear_outside: must be true or false (or 1 / 0), got 2",
        ),
        # the dataclass's own ranges, naming the field it rejects
        (
            MapperParams(),
            {"p_occ": 1.5},
            "mapper",
            "mapper.p_occ: MapperParams.p_occ must be in (0.5, 1), got 1.5",
        ),
        (
            SegmentationParams(),
            {"min_plane_pixels": 1},
            "segmentation",
            "segmentation.min_plane_pixels: SegmentationParams.min_plane_pixels must be an "
            "integer >= 3, got 1",
        ),
        (
            ElevationFilterParams(),
            {"gain": 0.0},
            "elevation",
            "elevation.gain: ElevationFilterParams.gain must be in (0, 1], got 0.0",
        ),
        (
            PipelineParams(),
            {"event_tolerance_m": 0},
            "pipeline",
            "pipeline.event_tolerance_m: PipelineParams.event_tolerance_m must be > 0 m, got 0",
        ),
        # a relation broken by a change to another field names the table
        (
            MapperParams(),
            {"p_max": 0.6},
            "mapper",
            "mapper: MapperParams.p_occ must be below p_max=0.6 after 8-bit quantisation, got 0.65",
        ),
    ],
)
def test_errors_name_key_value_and_what_is_allowed(params, changes, where, message):
    with pytest.raises(ParameterError) as info:
        replace_params(params, changes, where)
    assert str(info.value) == message
    assert isinstance(info.value, ValueError) and isinstance(info.value, FogsimError)


def test_the_head_s_parameters_go_below_the_scenario_into_their_groups():
    # sensor_fields: the camera's noise model (segmentation fields by name) and the neck
    # (the height reference's, "ref." like an override); the scenario and overrides win.
    scenario = scenario_from_dict({"name": "t", "segmentation": {"min_noise_m": 0.002}})
    sensor = {"min_noise_m": 0.004, "disparity_noise_px": 0.1, "stereo_baseline_m": 0.068}
    sensor |= {"ref.neck_in_camera_y_m": 0.10, "ref.neck_in_camera_z_m": -0.09}
    params = resolve_params(scenario, {"ref.neck_in_camera_z_m": -0.05}, sensor)
    assert params.segmentation.min_noise_m == 0.002
    assert params.segmentation.disparity_noise_px == 0.1
    assert params.reference.neck_in_camera_y_m == 0.10
    assert params.reference.neck_in_camera_z_m == -0.05


def test_the_stereo_head_sets_its_heading_and_border_fields_below_the_scenario():
    stereo = scenario_from_dict({"name": "t", "camera": {"mode": "stereo"}})
    params = resolve_params(stereo, sensor=sensor_fields(stereo))
    assert params.heading.flat_contrast == params.heading.min_contrast == 0.1
    assert params.segmentation.structure_border_px == 1
    depth = scenario_from_dict({"name": "t", "camera": {"mode": "depth"}})
    params = resolve_params(depth, sensor=sensor_fields(depth))
    assert params.heading.flat_contrast == 0.05
    assert params.segmentation.structure_border_px == 0
    table = scenario_from_dict(
        {"name": "t", "camera": {"mode": "stereo"}, "heading": {"flat_contrast": 0.02}}
    )
    assert resolve_params(table, sensor=sensor_fields(table)).heading.flat_contrast == 0.02


def test_a_scenario_s_robot_sets_its_neck_for_the_height_reference():
    icub = scenario_from_dict({"name": "t"})
    talos = scenario_from_dict({"name": "t", "robot": {"model": "talos"}})
    neck = resolve_params(icub, sensor=sensor_fields(icub)).reference.neck_in_camera_m
    assert neck.tolist() == [0.0, 0.10, -0.09]
    neck = resolve_params(talos, sensor=sensor_fields(talos)).reference.neck_in_camera_m
    assert neck.tolist() == [0.0, 0.198, -0.116]


def test_a_scenario_s_heading_pipeline_reference_and_elevation_tables_reach_the_run():
    # Each parameter table of a scenario file sets its RunParams group; the robot's neck pivot
    # (sensor) lies below the [reference] table, and an override key above every table.
    scenario = scenario_from_dict(
        {
            "name": "t",
            "heading": {"structure_stall_keyframes": 0, "interior_peak": False},
            "pipeline": {"heading_rebuild_frames": 800},
            "reference": {"gate_m": 0.03, "neck_in_camera_z_m": -0.05},
            "elevation": {"gain": 0.5},
        }
    )
    params = resolve_params(scenario, {"head.interior_peak": 1}, sensor_fields(scenario))
    assert params.heading.structure_stall_keyframes == 0
    assert params.heading.interior_peak is True  # the override wins
    assert params.pipeline.heading_rebuild_frames == 800
    assert params.reference.gate_m == 0.03
    assert params.reference.neck_in_camera_m.tolist() == [0.0, 0.10, -0.05]  # table over sensor
    assert params.elevation.gain == 0.5
    again = scenario_from_dict(tomllib.loads(scenario.to_toml()))
    assert again == scenario and again.heading == {
        "structure_stall_keyframes": 0,
        "interior_peak": False,
    }
    # `--set heading.<field>=...` goes into the table like `mapper.<field>`.
    stage = load_scenario("stage").with_overrides(["heading.interior_peak=false"])
    assert resolve_params(stage).heading.interior_peak is False
    with pytest.raises(
        ScenarioError, match=r"heading\.nope: unknown heading parameter.*interior_peak"
    ):
        scenario_from_dict({"name": "t", "heading": {"nope": 1}})
    with pytest.raises(ScenarioError, match=r"pipeline\.heading_rebuild_frames"):
        scenario_from_dict({"name": "t", "pipeline": {"heading_rebuild_frames": -1}})
    # Since session 59 a table may be named by its override prefix (`head.` is `heading.`);
    # a key through no table is still refused with the tables listed.
    short = load_scenario("stage").with_overrides(["head.interior_peak=false"])
    assert short.heading == {"interior_peak": False}
    with pytest.raises(ScenarioError, match=r"tables: .*heading, pipeline, reference, elevation"):
        load_scenario("stage").with_overrides(["heads.interior_peak=false"])


def test_resolve_params_layers_defaults_scenario_and_overrides():
    assert resolve_params(None) == RunParams()
    scenario = scenario_from_dict(
        {"name": "t", "mapper": {"p_occ": 0.7, "nx": 120}, "segmentation": {"min_depth_m": 0.1}}
    )
    params = resolve_params(
        scenario,
        {
            "eps_m": 0.02,
            "mapper.nx": 80.0,
            "seg.min_plane_pixels": 30,
            "elev.gain": 0.5,
            "pipe.use_z_match": 0,
        },
    )
    assert params == RunParams(
        mapper=dataclasses.replace(MapperParams(), p_occ=0.7, nx=80, eps_m=0.02),
        segmentation=dataclasses.replace(
            SegmentationParams(), min_depth_m=0.1, min_plane_pixels=30
        ),
        elevation=ElevationFilterParams(gain=0.5),
        pipeline=PipelineParams(use_z_match=False),
    )
    assert scenario.mapper == {"p_occ": 0.7, "nx": 120}  # the scenario is untouched
    with pytest.raises(
        ParameterError,
        match=r"^elevation\.gate: unknown elevation parameter\(s\) \['gate'\]; "
        r"allowed: \['gain', 'gate_m'\]$",
    ):
        resolve_params(None, {"elev.gate_m": 0.1, "elev.gate": 1})
