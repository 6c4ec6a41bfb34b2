"""The comparison: the step rule, height scans, one run of every map on a synthetic scene with
known truth, and the same recording giving the same table twice, bit for bit."""

import dataclasses
import json

import numpy as np
import pytest
from synthetic_depth import Box, render_scene
from test_pipeline import CAMERA_IN_ROBOT, INTR, RATE_HZ, ROBOT_POSE, camera_in_world
from test_pipeline_heading import BOXES as WALK_BOXES
from test_pipeline_heading import FIRST_ESTIMATE
from test_pipeline_heading import FRAMES as WALK

from fogsim.compare.command import run_compare
from fogsim.compare.maps import parse_maps, row_names
from fogsim.compare.replay import compare_frames
from fogsim.compare.scans import (
    HeightScanParams,
    sample_heights,
    scan_pattern_robot,
    scan_points_world,
)
from fogsim.compare.table import run_figures
from fogsim.config import PipelineParams, resolve_params
from fogsim.data.frame import Frame
from fogsim.data.recording import save_recording
from fogsim.errors import FogsimError
from fogsim.run.runner import run_frames
from fogsim.world.truth import ObjectState, SceneTruth
from mapper import CellType, GridGeometry, InvalidParameterError, MapperParams
from mapper.backends import StepRuleParams, label_by_step

TOP_M = 0.3
BOX = Box((1.35, 0.5), (0.3, 0.4, TOP_M))
STATE = ObjectState("tall_box", (1.35, 0.5), (0.3, 0.4, TOP_M), 0.0, 0.0, True)
TRUTH = SceneTruth(0.0, (STATE,), ("ground", "tall_box"), {"ground": 0.0, "tall_box": TOP_M})
FRAMES = 6
MAPS = ("fog", "averaging", "elevation", "last")  # OctoMap: tests/test_octomap_map.py

PER_FRAME = dataclasses.replace(
    resolve_params(None),
    pipeline=PipelineParams(use_height_reference=False),
)
"""Six synthetic frames, fewer than the height reference needs to converge: the paper's
per-frame rule maps every frame, so every map gets every frame's data."""


def make_frames(count=FRAMES):
    depth = render_scene(INTR, camera_in_world(), [BOX]).depth_m.astype(np.float32)
    return [
        Frame(
            index=i,
            time_s=i / RATE_HZ,
            depth_m=depth,
            intrinsics=INTR,
            transform_camera_to_robot_believed=CAMERA_IN_ROBOT,
            robot_pose_believed=ROBOT_POSE,
            transform_camera_to_world_true=camera_in_world(),
            robot_pose_true=ROBOT_POSE,
        )
        for i in range(count)
    ]


def test_the_step_rule_by_hand():
    nan = np.nan
    heights = np.array(
        [
            [0.00, 0.00, 0.00, 0.00, 0.00],
            [0.00, 0.04, 0.00, 0.00, nan],
            [0.00, 0.00, 0.00, 0.00, 0.20],
        ]
    )
    labels = label_by_step(heights)
    F, X, U = CellType.FLOOR, CellType.OBSTACLE, CellType.UNKNOWN
    expected = [[F, F, F, F, F], [F, F, F, X, U], [F, F, F, X, X]]
    np.testing.assert_array_equal(labels, expected)  # 4 cm within δ = 5 cm: still floor
    wide = label_by_step(heights, StepRuleParams(window_cells=5, max_step_m=0.05))
    assert wide[2, 2] == X and wide[0, 0] == F  # 0.20 m now two cells away is in the window
    with pytest.raises(InvalidParameterError, match="window_cells"):
        StepRuleParams(window_cells=2)


def test_the_scan_pattern_is_the_common_rl_grid_placed_with_the_robot_pose():
    pattern = scan_pattern_robot(HeightScanParams())
    assert pattern.shape == (17 * 11, 2)
    np.testing.assert_allclose(pattern.min(axis=0), [-0.8, -0.5])
    np.testing.assert_allclose(pattern.max(axis=0), [0.8, 0.5])
    world = scan_points_world(np.array([[0.8, 0.0]]), np.array([1.0, 2.0, 0.0, np.pi / 2]))
    np.testing.assert_allclose(world, [[1.0, 2.8]], atol=1e-12)  # ahead = +y at yaw 90°
    geometry = GridGeometry.from_params(MapperParams(nx=10, ny=10))
    heights = np.full((10, 10), np.nan)
    heights[5, 5] = 0.1
    values = sample_heights(heights, geometry, np.array([[0.02, 0.02], [0.06, 0.02], [9.0, 0]]))
    np.testing.assert_array_equal(values, [0.1, np.nan, np.nan])
    with pytest.raises(FogsimError, match="every_frames"):
        HeightScanParams(every_frames=0)


def test_maps_are_parsed_in_table_order_with_the_fog_always_first():
    assert parse_maps("last,elevation") == ("fog", "elevation", "last")
    assert row_names(("fog", "averaging", "last")) == (
        "fog",
        "fog+rule",
        "averaging",
        "averaging+rule",
        "last",
    )
    with pytest.raises(FogsimError, match="unknown map 'voxblox'"):
        parse_maps("fog,voxblox")


@pytest.fixture(scope="module")
def compared():
    return compare_frames("synthetic", make_frames(), lambda t: TRUTH, None, PER_FRAME, MAPS)


def test_every_map_is_scored_against_the_same_truth_on_the_same_cells(compared):
    assert set(compared.scores) == set(row_names(MAPS))
    assert compared.frames == FRAMES and compared.withdrawn == 0
    shapes = {a.fog_heights_m.shape for a in compared.archives.values()}
    assert len(shapes) == 1  # one lattice for all
    for m in MAPS:  # every map is updated on every frame, timed
        assert compared.maps[m].update_ms.shape == (FRAMES,)
        assert np.isfinite(compared.maps[m].update_ms).all()
    figures = run_figures(compared)
    for row in ("fog", "elevation", "last"):
        # exact depth of a flat floor and a flat 0.3 m top: Table I within 5 mm
        assert figures[row]["table1_worst_abs_error_mm"] < 5.0, row
        assert figures[row]["floor_height_median_mm"] < 5.0, row
    box_rows = {r.name: r for r in compared.scores["elevation"].table1.fog}
    assert box_rows["tall_box"].estimated_mm == pytest.approx(300.0, abs=5.0)
    # the robot stands 1 m before the box looking at it: the scan's near half is unseen
    assert 0.0 < figures["fog"]["scan_coverage"] < 0.6
    assert figures["fog"]["scan_median_abs_error_mm"] < 5.0


REFERENCE_MIN_FRAMES = 8
"""The synthetic frames measure the ground under the feet from the first one: the height
reference (``mapper.reference``, ``min_frames`` 8) is known from the 8th frame on."""


@pytest.mark.parametrize("count", [REFERENCE_MIN_FRAMES - 2, REFERENCE_MIN_FRAMES + 4])
def test_frames_deferred_by_the_height_reference_reach_every_map(count):
    # 6 frames: the run ends before the reference is known, every frame is still deferred and
    # only Pipeline.finish maps them; 12: the 8th frame maps the 7 deferred ones before itself
    # (8 FOG updates in one frame), and every other map must get all 8 too.
    compared = compare_frames(
        "synthetic", make_frames(count), lambda t: TRUTH, None, resolve_params(None), MAPS
    )
    assert compared.frames == count and compared.withdrawn == 0
    for m in MAPS:
        assert compared.maps[m].update_ms.shape == (count,), m
        assert np.isfinite(compared.maps[m].update_ms).all(), m
    for row, scores in compared.scores.items():
        box = {r.name: r for r in scores.table1.fog}["tall_box"]
        assert box.estimated_mm == pytest.approx(TOP_M * 1000.0, abs=5.0), row


def test_the_same_recording_gives_the_same_tables_twice_bit_for_bit(tmp_path):
    frames = make_frames(4)
    path = save_recording(tmp_path / "rec.npz", frames, scenario=None, truths=[TRUTH] * 4)
    outputs = []
    for k in range(2):
        out = tmp_path / f"out{k}"
        run_compare([str(path)], ("fog", "elevation", "last"), out, pictures=k == 0)
        outputs.append(((out / "compare.json").read_bytes(), (out / "compare.md").read_bytes()))
    assert outputs[0] == outputs[1]
    data = json.loads(outputs[0][0])
    assert data["format"] == "fogsim-compare-1" and list(data["groups"]) == ["rec"]
    assert (tmp_path / "out0" / "rec.png").stat().st_size > 0
    rows = data["groups"]["rec"]["rows"]
    assert set(rows) == {"fog", "fog+rule", "elevation", "last"}
    assert rows["fog"]["unsafe_cells"]["runs"] == 1


def test_a_name_that_is_no_file_needs_seeds(tmp_path):
    with pytest.raises(FogsimError, match="--seeds"):
        run_compare(["stage"], ("fog",), tmp_path / "out")


def test_a_mean_over_runs_that_never_cleared_is_shown_as_a_count():
    from fogsim.compare.table import _cell, aggregate
    from fogsim.run.baseline import NEVER_FRAMES

    key = "events.box.cleared_frames"
    runs = [{"fog": {key: 5.0}}, {"fog": {key: float(NEVER_FRAMES)}}, {"fog": {key: 7.0}}]
    stat = aggregate(runs)["fog"][key]
    assert (stat.worst, stat.runs, stat.nevers) == (NEVER_FRAMES, 3, 1)
    assert _cell(stat) == "never (never on 1 of 3)"
    cleared = aggregate([runs[0], runs[2]])["fog"][key]
    assert (cleared.mean, cleared.nevers) == (6.0, 0) and _cell(cleared) == "7 (6)"


def _walk_truth():
    """The truth of `test_pipeline_heading`'s walk: its three boxes on the ground."""
    names = tuple(f"box_{i}" for i in range(len(WALK_BOXES)))
    states = tuple(
        ObjectState(name, box.center_xy_m, box.size_m, 0.0, 0.0, True)
        for name, box in zip(names, WALK_BOXES, strict=True)
    )
    tops = zip(names, WALK_BOXES, strict=True)
    heights = {"ground": 0.0} | {name: box.size_m[2] for name, box in tops}
    return SceneTruth(0.0, states, ("ground", *names), heights)


def test_the_comparison_rebuilds_every_map_with_the_heading_as_a_run_rebuilds_the_fog():
    # The walk of test_pipeline_heading: the camera believed 3° off in yaw; the heading's first
    # estimate comes at frame 17 and the pipeline maps the frames before it again. Every map
    # starts anew there and gets those frames again, and the comparison's FOG scores what
    # `fogsim run` scores (before session 36 it ran without the rebuild).
    truth = _walk_truth()
    params = resolve_params(None)
    assert params.pipeline.heading_rebuild_frames >= FIRST_ESTIMATE
    compared = compare_frames("walk", WALK, lambda t: truth, None, params, MAPS)
    updates = compared.maps["fog"].update_ms.size
    assert updates > len(WALK)  # frames mapped twice: before the estimate and with it
    for m in MAPS:
        assert compared.maps[m].update_ms.size == updates, m
    run = run_frames(WALK, lambda t: truth, None, params=params, segment_ahead=False)
    assert run.scores is not None
    fog = compared.scores["fog"]  # its averaging rows score the FOG's heights: not compared
    assert fog.cells.fog == run.scores.cells.fog
    assert fog.cells.obstacles == run.scores.cells.obstacles
    assert fog.table1.fog == run.scores.table1.fog
    assert fog.safety == run.scores.safety
    assert fog.step_edges == run.scores.step_edges
