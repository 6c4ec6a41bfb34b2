"""The pipeline on synthetic frames (ray-cast depth of boxes, known truth), no MuJoCo."""

import dataclasses
import tracemalloc

import numpy as np
import pytest
from synthetic_depth import Box, add_depth_noise, look_down_camera, render_boxes

from fogsim.config import RunParams, load_scenario, resolve_params
from fogsim.config.params import PipelineParams
from fogsim.data.frame import Frame
from fogsim.data.recording import Recording
from fogsim.errors import FogsimError, ParameterError
from fogsim.eval.archive import cells_in_view
from fogsim.eval.report.build import param_tables
from fogsim.mapping.pipeline import FrameError, FrameTiming, Pipeline
from fogsim.run.runner import replay_report, run_frames, truth_params
from fogsim.world.truth import ObjectState, SceneTruth, TruthParams
from mapper import MapperParams
from mapper.grid import GridGeometry
from mapper.intrinsics import PinholeIntrinsics
from mapper.reference import HeightReferenceParams
from mapper.transforms import planar_pose_to_matrix

INTR = PinholeIntrinsics.from_fov(88, 72, 47.0, 39.0)
RATE_HZ = 12.5
CAMERA_IN_ROBOT = look_down_camera((0.0, 0.0, 0.9), pitch_down_deg=35.0)
ROBOT_POSE = np.array([0.3, 0.5, 0.0, 0.0])
BOX = Box((1.35, 0.5), (0.3, 0.4, 0.05))
BOX_STATE = ObjectState("flat_box", (1.35, 0.5), (0.3, 0.4, 0.05), 0.0, 0.0, True)
NAMES = ("ground", "flat_box")
HEIGHTS = {"ground": 0.0, "flat_box": 0.05}


def camera_in_world():
    t = np.eye(4)
    t[:3, :3] = [[1, 0, 0], [0, 1, 0], [0, 0, 1]]
    t[:3, 3] = ROBOT_POSE[:3]
    return t @ CAMERA_IN_ROBOT


def make_frames(n, box_until_frame=None, noise=0.0, seed=0):
    """Standing robot looking at a flat box; the box vanishes at ``box_until_frame``."""
    rng = np.random.default_rng(seed)
    world = camera_in_world()
    frames = []
    for i in range(n):
        boxes = [BOX] if box_until_frame is None or i < box_until_frame else []
        depth = render_boxes(INTR, world, boxes)
        if noise:
            depth = add_depth_noise(depth, noise, rng)
        frames.append(
            Frame(
                index=i,
                time_s=i / RATE_HZ,
                depth_m=depth.astype(np.float32),
                intrinsics=INTR,
                transform_camera_to_robot_believed=CAMERA_IN_ROBOT,
                robot_pose_believed=ROBOT_POSE,
                transform_camera_to_world_true=world,
                robot_pose_true=ROBOT_POSE,
            )
        )
    return frames


def provider_removed_at(time_s):
    with_box = SceneTruth(0.0, (BOX_STATE,), NAMES, HEIGHTS)
    without = SceneTruth(time_s, (), NAMES, HEIGHTS)
    return lambda t: with_box if t < time_s else without


def test_static_box_table1_within_3mm_and_cells_right():
    frames = make_frames(12, noise=0.002)
    result = run_frames(frames, provider_removed_at(1e9), None)
    rows = {r.name: r for r in result.scores.table1.fog}
    for name in NAMES:
        assert rows[name].cells > 10, rows[name]
        assert abs(rows[name].error_mm) <= 3.0, rows[name]
    cells = result.scores.cells.fog
    assert cells.accuracy >= 0.97, cells
    # The frames before the height reference converged wait, then are mapped with it: none
    # is withdrawn and every frame has its update time.
    assert result.frames == 12 and result.withdrawn == 0
    assert result.frames_without_ground_plane == 0
    assert np.isfinite(result.update_ms).all()
    # The archive keeps every map; the camera saw the cells the FOG labelled, and more.
    archive = result.archive
    floor = archive.fog_types == 1
    np.testing.assert_array_equal(archive.floor_m[floor], archive.fog_heights_m[floor])
    obstacle = archive.fog_types == 2
    np.testing.assert_array_equal(archive.obstacle_m[obstacle], archive.fog_heights_m[obstacle])
    labelled = archive.fog_types != 0
    assert archive.in_view[labelled].all() and archive.in_view.sum() > labelled.sum()
    assert result.pose_error.camera_in_robot.rotation_deg.max == pytest.approx(0, abs=1e-6)


def test_box_removal_fog_clears_within_25_frames_averaging_never():
    scenario = load_scenario("box_removal")  # event: remove flat_box at 4.0 s
    removal_frame = round(4.0 * RATE_HZ)
    frames = make_frames(removal_frame + 40, box_until_frame=removal_frame)
    result = run_frames(frames, provider_removed_at(4.0), scenario)
    (event,) = result.events
    assert event.object == "flat_box" and event.start_frame == removal_frame
    assert event.footprint_cells > 20
    assert event.seen.fog and event.seen.averaging
    assert event.cleared_frames.fog is not None and event.cleared_frames.fog <= 25, event
    assert event.cleared_frames.averaging is None, event
    assert [s.label for s in result.snapshots] == ["before", "after"]
    assert result.snapshots[0].frame_index == removal_frame - 1


def test_same_frames_same_result_bit_for_bit():
    frames = make_frames(6, noise=0.003, seed=4)
    a = run_frames(frames, None, None)
    b = run_frames(frames, None, None)
    assert a.scores is None and a.events == ()
    np.testing.assert_array_equal(a.archive.fog_heights_m, b.archive.fog_heights_m)
    np.testing.assert_array_equal(a.archive.fog_types, b.archive.fog_types)


def test_resolve_params_layers_scenario_and_overrides():
    scenario = load_scenario("box_removal")
    params = resolve_params(
        scenario, {"p_occ": 0.8, "mapper.eps_m": 0.01, "seg.min_plane_pixels": 30.0}
    )
    assert isinstance(params, RunParams)
    assert params.mapper.p_occ == 0.8 and params.mapper.eps_m == 0.01
    assert params.segmentation.min_plane_pixels == 30
    assert isinstance(params.segmentation.min_plane_pixels, int)
    assert params.to_dict()["elevation"]["gain"] == params.elevation.gain
    with pytest.raises(FogsimError, match=r"unknown mapper parameter\(s\) \['p_oc'\]; allowed"):
        resolve_params(None, {"p_oc": 0.7})
    with pytest.raises(FogsimError, match="p_occ"):
        resolve_params(None, {"p_occ": 1.5})


def test_replay_report_uses_overrides():
    frames = make_frames(5)
    truths = [provider_removed_at(1e9)(f.time_s) for f in frames]
    rec = Recording(frames=frames, scenario=None, truths=truths, intrinsics=INTR)
    report = replay_report(rec, {"p_occ": 0.8})
    assert report.params.mapper["p_occ"] == 0.8
    assert report.source == "replay"
    assert report.timing.frames == 5
    assert {r.name for r in report.table1.fog} == set(NAMES)


def paper_pipeline():
    """The paper's per-frame ground shift instead of the height reference over frames."""
    params = RunParams(pipeline=PipelineParams(use_height_reference=False))
    return Pipeline(params)


def test_process_returns_the_frames_timing_and_decisions():
    pipeline = paper_pipeline()
    first, second, third = (pipeline.process(f) for f in make_frames(3))
    assert isinstance(first, FrameTiming)
    # An empty map has no floor to match: the first frames are used unshifted, then matched.
    assert (first.z_matched, second.z_matched, third.z_matched) == (False, False, True)
    assert not any(t.withdrawn for t in (first, second, third))
    for t in (first, second, third):
        assert 0 < t.segmentation_ms + t.update_ms <= t.frame_ms


def test_last_points_are_the_frames_points_as_the_maps_received_them():
    pipeline = paper_pipeline()
    assert pipeline.last_points is None
    frame = make_frames(1)[0]
    pipeline.process(frame)
    labelled = pipeline.last_points
    assert not labelled.withdrawn
    valid = np.isfinite(frame.depth_m) & (frame.depth_m > 0)
    assert labelled.points_world.shape == (int(valid.sum()), 3)
    # Exact depth: the floor points lie on the ground or the box top, at their floor height.
    floor = np.isfinite(labelled.floor_heights_m)
    assert floor.sum() > 0.9 * floor.size
    np.testing.assert_allclose(
        labelled.points_world[floor, 2], labelled.floor_heights_m[floor], atol=1e-6
    )
    on_box = BOX_STATE.contains(labelled.points_world[floor, :2], margin_m=-0.02)
    np.testing.assert_allclose(labelled.floor_heights_m[floor][on_box], 0.05, atol=1e-3)
    np.testing.assert_allclose(
        labelled.floor_heights_m[floor][~on_box & (labelled.points_world[floor, 0] < 1.1)],
        0.0,
        atol=1e-3,
    )


def _frame_looking_down(depth, transform_camera_to_world):
    """A 2 x 2 pixel frame whose rays leave the camera at ±0.5 m per metre of depth."""
    return Frame(
        index=0,
        time_s=0.0,
        depth_m=np.array(depth, dtype=np.float32),
        intrinsics=PinholeIntrinsics(2, 2, 1.0, 1.0, 0.5, 0.5),
        transform_camera_to_robot_believed=np.eye(4),
        robot_pose_believed=np.zeros(4),
        transform_camera_to_world_true=transform_camera_to_world,
        robot_pose_true=np.zeros(4),
    )


def test_cells_in_view_are_where_true_depth_points_fall_inside_the_grid():
    # Camera 1 m above (1, 1), looking straight down (optical x = world x, y = -world y).
    down = np.array([[1.0, 0, 0, 1.0], [0, -1.0, 0, 1.0], [0, 0, -1.0, 1.0], [0, 0, 0, 1.0]])
    geometry = GridGeometry(50, 50, 16, 0.04, 0.04, -0.06)  # [0, 2] x [0, 2] x [-0.06, 0.58]
    # Top pixels hit the ground at (0.5, 1.5) and (1.5, 1.5); the bottom-left one a point at
    # 0.7 m, above the grid; the bottom-right one has no measurement.
    frame = _frame_looking_down([[1.0, 1.0], [0.3, np.nan]], down)
    seen = cells_in_view(frame, geometry)
    assert np.argwhere(seen).tolist() == [[12, 37], [37, 37]]
    unknown_pose = _frame_looking_down([[1.0, 1.0], [1.0, 1.0]], np.full((4, 4), np.nan))
    assert not cells_in_view(unknown_pose, geometry).any()


def test_truth_params_take_the_robots_foot_and_the_mappers_grid_top():
    params = truth_params(load_scenario("stage"), MapperParams())  # iCub: [-0.028, 0.128] x 0.06
    assert params.foot_length_m == pytest.approx(0.156)
    assert params.foot_width_m == pytest.approx(0.06)
    assert params.grid_top_m == pytest.approx(-0.06 + 16 * 0.04)
    talos = truth_params(load_scenario("flat_floor_talos"), MapperParams(nz=10))
    assert (talos.foot_length_m, talos.foot_width_m) == pytest.approx((0.2, 0.13))
    assert talos.grid_top_m == pytest.approx(-0.06 + 10 * 0.04)
    assert truth_params(None, MapperParams(nz=10)) == TruthParams(grid_top_m=0.34)


def _with_believed_pose(frames, first, pose):
    """The frames with the believed robot pose of frames ``first`` onwards replaced."""
    return [
        dataclasses.replace(f, robot_pose_believed=np.asarray(pose)) if f.index >= first else f
        for f in frames
    ]


@pytest.mark.parametrize(("bad", "shown"), [(np.nan, "nan"), (np.inf, "inf"), (1e30, "1e\\+30")])
def test_a_believed_pose_not_finite_or_out_of_bounds_is_refused_naming_the_frame(bad, shown):
    frames = _with_believed_pose(make_frames(4), 2, [bad, 0.5, 0.0, 0.0])
    with pytest.raises(FrameError, match=rf"^frame 2: robot_pose_believed: x = {shown}, y = 0.5"):
        run_frames(frames, None, None)
    camera = np.array(CAMERA_IN_ROBOT)
    camera[0, 3] = bad
    frames = make_frames(3)
    frames[1] = dataclasses.replace(frames[1], transform_camera_to_robot_believed=camera)
    with pytest.raises(FrameError, match=r"^frame 1: transform_camera_to_robot_believed: "):
        run_frames(frames, None, None)


@pytest.mark.parametrize("jump_m", [100.0, 300.0, 3000.0])
def test_a_believed_pose_jump_is_refused_before_the_maps_grow(jump_m):
    """Once 0.8 GB, 5.3 GB and a 42 GiB allocation error (issue 13); now an error at once."""
    frames = _with_believed_pose(make_frames(5), 3, ROBOT_POSE + np.array([0.0, jump_m, 0.0, 0.0]))
    tracemalloc.start()
    try:
        with pytest.raises(
            FrameError,
            match=rf"^frame 3: robot_pose_believed: the believed position jumped {jump_m:g} m "
            r"from the previous frame's \(0.3, 0.5, 0\).*at most 5 m",
        ):
            run_frames(frames, None, None)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak < 100 << 20, peak


def test_a_plausible_walk_is_mapped():
    """Steps up to MAX_POSE_STEP_M pass: 0.1 m a frame along x."""
    frames = make_frames(4)
    walked = [
        dataclasses.replace(f, robot_pose_believed=ROBOT_POSE + np.array([0.1 * f.index, 0, 0, 0]))
        for f in frames
    ]
    assert run_frames(walked, None, None).frames == 4


def test_height_reference_waits_for_convergence_and_is_exactly_zero_on_exact_data():
    pipeline = Pipeline()
    wait = HeightReferenceParams().min_frames - 1
    timings = [pipeline.process(f) for f in make_frames(wait + 2)]
    assert [t.withdrawn for t in timings] == [True] * wait + [False, False]
    assert pipeline.reference.converged
    assert pipeline.reference.shift_m == pytest.approx(0.0, abs=1e-6)  # float32 depth
    labelled = pipeline.last_points
    floor = np.isfinite(labelled.floor_heights_m)
    ground = floor & (labelled.points_world[:, 0] < 1.1)
    np.testing.assert_allclose(labelled.floor_heights_m[ground], 0.0, atol=1e-6)


def test_the_run_s_reference_parameters_reach_the_pipeline_and_the_report():
    """``ref.min_frames=3`` (an override, as tune and replay_report pass them): 2 frames wait."""
    params = resolve_params(None, {"ref.min_frames": 3, "ref.frame_gate_m": 0.002})
    pipeline = Pipeline(params)
    timings = [pipeline.process(f) for f in make_frames(4)]
    assert [t.withdrawn for t in timings] == [True, True, False, False]
    assert pipeline.reference.params == HeightReferenceParams(min_frames=3, frame_gate_m=0.002)
    tables = param_tables(params)
    assert tables.reference["min_frames"] == 3 and tables.reference["gate_m"] == 0.02
    with pytest.raises(ParameterError, match=r"^reference\.min_frame: unknown reference"):
        resolve_params(None, {"ref.min_frame": 3})


def test_height_reference_removes_a_camera_height_error():
    # The encoders believe the camera 8 mm lower than it is: the paper's per-frame shift and
    # the reference both put the ground back on 0; the reference after its frames.
    believed = CAMERA_IN_ROBOT.copy()
    believed[2, 3] -= 0.008
    frames = [
        dataclasses.replace(f, transform_camera_to_robot_believed=believed)
        for f in make_frames(HeightReferenceParams().min_frames, noise=0.002)
    ]
    pipeline = Pipeline()
    for f in frames:
        pipeline.process(f)
    assert pipeline.reference.shift_m == pytest.approx(0.008, abs=0.0015)
    labelled = pipeline.last_points
    ground = np.isfinite(labelled.floor_heights_m) & (labelled.points_world[:, 0] < 1.1)
    assert abs(float(np.median(labelled.floor_heights_m[ground]))) <= 0.0015


def test_the_ground_lies_exactly_on_the_feet_when_the_camera_error_changes_every_frame():
    # The encoders' noise moves the believed camera height frame to frame around a 6 mm bias.
    # Each frame measures its own ground within the reference's frame gate, so every frame's
    # ground lies exactly at the feet's height (0), not at the median's: flat scenes are exact.
    errors_m = 0.006 + 0.0015 * np.array([1, -1, 0.5, -0.5, 1, -1, 0.2, -0.8, 0.9, -0.3, 0.7, -1])
    frames = []
    for f, error_m in zip(make_frames(errors_m.size), errors_m, strict=True):
        believed = CAMERA_IN_ROBOT.copy()
        believed[2, 3] -= error_m
        frames.append(dataclasses.replace(f, transform_camera_to_robot_believed=believed))
    pipeline = Pipeline()
    for f in frames:
        pipeline.process(f)
    # One shift for the run (the median) would leave frames up to 1.6 mm off.
    assert np.abs(errors_m - pipeline.reference.shift_m).max() > 0.0015
    floor = np.asarray(pipeline.mapper.floor())
    ground = floor[np.isfinite(floor) & (floor < 0.025)]
    top = floor[np.isfinite(floor) & (floor >= 0.025)]
    assert ground.size > 100 and top.size > 20
    np.testing.assert_allclose(ground, 0.0, atol=1e-5)  # float32 depth
    np.testing.assert_allclose(top, 0.05, atol=1e-5)


def test_the_map_anchored_at_the_start_holds_while_odometry_drifts_in_z():
    # Exact depth and camera; after the reference converged, odometry's z drifts down by
    # 0.05 mm a frame (foot-to-foot kinematics; flat_floor: up to -1.6 mm in 66 frames). The
    # frames measure the ground under their feet, which the first frames saw: the robot stands
    # on it, and the ground stays exactly where the start pose put it. Without that (a start
    # surface gate too narrow to hold), the map's small disagreement (the drift) is matched
    # away (`anchor_shift_m`); without either, the map follows the unshifted frames down.
    frames = make_frames(40)
    start = HeightReferenceParams().min_frames + 2
    for i in range(start, len(frames)):
        pose = ROBOT_POSE - np.array([0.0, 0.0, 0.00005 * (i - start + 1), 0.0])
        frames[i] = dataclasses.replace(frames[i], robot_pose_believed=pose)

    def ground_after(anchor_shift_m, surface_gate_m):
        params = RunParams(
            pipeline=PipelineParams(anchor_shift_m=anchor_shift_m),
            reference=HeightReferenceParams(surface_gate_m=surface_gate_m),
        )
        pipeline = Pipeline(params)
        for f in frames:
            pipeline.process(f)
        floor = np.asarray(pipeline.mapper.floor())
        return floor[np.isfinite(floor) & (floor < 0.025)]

    anchor_m, surface_gate_m = (
        PipelineParams().anchor_shift_m,
        HeightReferenceParams().surface_gate_m,
    )
    for ground in (ground_after(anchor_m, surface_gate_m), ground_after(anchor_m, 1e-9)):
        assert ground.size > 100
        np.testing.assert_allclose(ground, 0.0, atol=1e-5)  # float32 depth
    assert np.abs(ground_after(0.0, surface_gate_m)).max() <= 1e-5
    assert np.abs(ground_after(0.0, 1e-9)).max() > 2e-4


def test_a_frame_on_the_start_surface_stands_at_the_start_pose_s_z_whatever_the_first_views():
    # Stereo-like start (seed 6): the first frames' views of the ground under the feet scatter
    # by +-13 to 16 mm in two clusters (here: their believed camera heights), so none agrees with
    # the estimate and each keeps its view. Then the elevation filter is pulled 8 mm low (noisy
    # z-matches). A frame that measures the ground under its feet stands on the start surface,
    # which the feet stood on at the start: at the start pose's z (0), exactly. Before, the views
    # within 10 mm of the filtered elevation (-13 to -16 mm) set it: the robot and its ground
    # 14.5 mm low for the rest of the run. Such a scatter settles the estimate at the start
    # level only after 16 measurements (`ref.start_known_frames`; its standard error after 8,
    # 9.5 mm, is above `ref.start_known_error_m`).
    errors_m = [0.015, -0.015, 0.014, -0.014, 0.016, -0.016, 0.013, -0.013] * 2
    frames = make_frames(len(errors_m) + 3)
    for i, error_m in enumerate(errors_m):
        believed = CAMERA_IN_ROBOT.copy()
        believed[2, 3] -= error_m
        frames[i] = dataclasses.replace(frames[i], transform_camera_to_robot_believed=believed)
    pipeline = Pipeline()
    for i, f in enumerate(frames[: len(errors_m)]):
        assert not pipeline.reference.known
        pipeline.process(f)
        assert pipeline.reference.converged == (i >= 7)
    assert pipeline.reference.known and pipeline.reference.shift_m == pytest.approx(0.0, abs=1e-4)
    pipeline.elevation.offset_m = -0.008
    for f in frames[len(errors_m) :]:
        pipeline.process(f)
        assert pipeline.elevation.offset_m == 0.0
        labelled = pipeline.last_points
        ground = np.isfinite(labelled.floor_heights_m) & (labelled.floor_heights_m < 0.025)
        assert ground.sum() > 100
        np.testing.assert_allclose(labelled.floor_heights_m[ground], 0.0, atol=1e-5)


def test_anchor_shift_must_be_finite_and_not_negative():
    for bad in (-0.001, float("nan"), float("inf")):
        with pytest.raises(FogsimError, match=r"PipelineParams\.anchor_shift_m"):
            PipelineParams(anchor_shift_m=bad)


def posed_frames(poses, camera_believed=CAMERA_IN_ROBOT, z_drift_per_frame_m=0.0):
    """Exact depth of the box scene from each true robot pose; odometry's z drifts down."""
    frames = []
    for i, pose in enumerate(poses):
        world = planar_pose_to_matrix(pose) @ CAMERA_IN_ROBOT
        frames.append(
            Frame(
                index=i,
                time_s=i / RATE_HZ,
                depth_m=render_boxes(INTR, world, [BOX]).astype(np.float32),
                intrinsics=INTR,
                transform_camera_to_robot_believed=camera_believed,
                robot_pose_believed=pose - np.array([0.0, 0.0, z_drift_per_frame_m * i, 0.0]),
                transform_camera_to_world_true=world,
                robot_pose_true=pose,
            )
        )
    return frames


def test_descending_start_defers_the_frames_until_the_ground_under_the_feet_is_seen():
    # The robot starts on a 122 mm platform that is out of view (only the ground 122 mm below
    # and the box are seen), its camera believed 6 mm too low; then it stands on the ground.
    believed = CAMERA_IN_ROBOT.copy()
    believed[2, 3] -= 0.006
    on_platform = ROBOT_POSE + np.array([0.0, 0.0, 0.122, 0.0])
    poses = [on_platform] * 5 + [ROBOT_POSE] * HeightReferenceParams().min_frames
    frames = posed_frames(poses, camera_believed=believed)
    pipeline = Pipeline()
    timings = [pipeline.process(f) for f in frames]
    # Nothing measured on the platform (the ground is 122 mm below the feet): no shift onto it.
    assert pipeline.reference.measurements_m[0] == pytest.approx(0.006, abs=1e-4)
    assert len(pipeline.reference.measurements_m) == HeightReferenceParams().min_frames
    assert [t.withdrawn for t in timings[:-1]] == [True] * (len(frames) - 1)
    assert not timings[-1].withdrawn
    # The deferred frames were mapped with the converged reference: the ground lies on 0.
    floor = np.asarray(pipeline.mapper.floor())
    ground = floor[np.isfinite(floor) & (floor < 0.025)]
    assert ground.size > 100
    np.testing.assert_allclose(ground, 0.0, atol=1e-3)


def test_walking_down_odometry_s_z_drift_is_taken_out_of_the_map():
    # Exact depth and camera. The robot starts on a 122 mm platform (out of view), sees the
    # ground from it, steps down and stands on the ground; odometry's z drifts down by 0.2 mm a
    # frame from the start (stage_down: -1 to -4 mm when the ground is reached). The frames
    # wait until the ground under the feet converges the reference; where the first frames (on
    # the platform, odometry exact) saw the ground gives the drift on arrival. Without taking it
    # out, the waiting frames and the map under the robot carry it (-3 mm here before the
    # change).
    on_platform = ROBOT_POSE + np.array([0.0, 0.0, 0.122, 0.0])
    poses = [on_platform] * 12 + [ROBOT_POSE] * (HeightReferenceParams().min_frames + 6)
    frames = posed_frames(poses, z_drift_per_frame_m=0.0002)

    def ground_and_top(use_elevation_filter):
        pipeline = Pipeline(
            RunParams(pipeline=PipelineParams(use_elevation_filter=use_elevation_filter))
        )
        for f in frames:
            pipeline.process(f)
        floor = np.asarray(pipeline.mapper.floor())
        seen = np.isfinite(floor)
        return floor[seen & (floor < 0.025)], floor[seen & (floor >= 0.025)]

    ground, top = ground_and_top(True)
    assert ground.size > 100 and top.size > 20
    # Within 0.2 mm: the drift goes on after the arrival (0.2 mm a frame, 10 times the
    # stage's), which the elevation filter follows with a lag.
    np.testing.assert_allclose(ground, 0.0, atol=2e-4)
    np.testing.assert_allclose(top, 0.05, atol=2e-4)
    # Without the elevation filter nothing carries the correction: the drift stays.
    ground_drifting, _ = ground_and_top(False)
    assert ground_drifting.min() < -0.001


def test_a_run_shorter_than_the_reference_needs_maps_its_frames_at_the_end():
    """Fewer frames than the reference needs to converge: nothing is lost, the run maps them."""
    wait = HeightReferenceParams().min_frames - 1
    frames = make_frames(wait - 2)
    result = run_frames(frames, None, None)
    assert result.frames == wait - 2 and result.withdrawn == 0
    assert np.isfinite(result.update_ms).all()
    assert np.isfinite(np.asarray(result.mapper.floor())).any()


@pytest.mark.parametrize("use_height_reference", [False, True])
def test_keeps_grid_says_when_a_frame_leaves_the_grid_where_it_is(use_height_reference):
    """True exactly when it is certain (checked against what process() then does): the believed
    position in the grid's central cell and no frames waiting for the height reference. A step
    of one cell, a position process() refuses, frames deferred (the reference not yet known
    after six frames of this standing robot): False."""
    params = RunParams(pipeline=PipelineParams(use_height_reference=use_height_reference))
    pipeline = Pipeline(params)
    cell_m = pipeline.mapper_params.cell_m
    frames = [
        dataclasses.replace(
            f, robot_pose_believed=ROBOT_POSE + np.array([cell_m * (i // 3), 0, 0, 0])
        )
        for i, f in enumerate(make_frames(6))
    ]
    answers = []
    for frame in frames:
        before = pipeline.mapper.geometry
        keeps = pipeline.keeps_grid(frame)
        pipeline.process(frame)
        assert not keeps or pipeline.mapper.geometry == before, frame.index
        answers.append(keeps)
    if use_height_reference:
        assert not pipeline.reference.known
        assert answers == [False] * 6
    else:  # frame 0: the grid is made at the origin; frame 3 steps one cell
        assert answers == [False, True, True, False, True, True]
    nan = dataclasses.replace(frames[0], robot_pose_believed=np.array([np.nan, 0, 0, 0.0]))
    assert not pipeline.keeps_grid(nan)


def test_a_frame_whose_measurement_disagrees_is_z_matched_as_any_other():
    # The anchor rule: only a frame shifted by its own measurement of the ground under its
    # feet (it agrees with the reference's estimate) is kept unshifted against the map. Here,
    # after the reference converged on exact frames, one frame's believed camera is 8 mm low
    # (beyond `frame_gate_m`, 5 mm): its measurement disagrees, the estimate shifts it, its
    # data are 8 mm off and the z-match puts them back on the map's ground. Before the rule
    # the frame was kept unshifted (8 mm > `anchor_shift_m`): its ground went 8 mm high.
    frames = make_frames(HeightReferenceParams().min_frames + 4)
    believed = CAMERA_IN_ROBOT.copy()
    believed[2, 3] -= 0.008
    frames[-1] = dataclasses.replace(frames[-1], transform_camera_to_robot_believed=believed)
    pipeline = Pipeline()
    for f in frames[:-1]:
        pipeline.process(f)
    assert pipeline.reference.known and pipeline.reference.shift_m == pytest.approx(0.0, abs=1e-4)
    timing = pipeline.process(frames[-1])
    assert timing.z_matched and not timing.withdrawn
    labelled = pipeline.last_points
    ground = np.isfinite(labelled.floor_heights_m) & (labelled.floor_heights_m < 0.025)
    assert ground.sum() > 100
    np.testing.assert_allclose(labelled.floor_heights_m[ground], 0.0, atol=2e-4)


def test_the_structure_border_reaches_the_heading_as_structure_and_the_maps_as_floor():
    # `segmentation.structure_border_px`: the box top's occluding border points come to the
    # heading estimator with no floor height (structure points), to the maps with their floor's.
    stereo = {"disparity_noise_px": 0.1, "stereo_baseline_m": 0.068, "max_depth_m": 4.0}
    seen = []

    def run(border_px):
        segmentation = dataclasses.replace(
            RunParams().segmentation, structure_border_px=border_px, **stereo
        )
        pipeline = Pipeline(
            RunParams(
                pipeline=PipelineParams(use_height_reference=False), segmentation=segmentation
            )
        )
        observe = pipeline.heading.observe

        def spy(points_robot, floor_heights_m, *args, **kwargs):
            seen.append(np.array(floor_heights_m))
            return observe(points_robot, floor_heights_m, *args, **kwargs)

        pipeline.heading.observe = spy
        pipeline.process(make_frames(1)[0])
        return pipeline.last_points.floor_heights_m

    mapped_plain, mapped_marked = run(0), run(1)
    heading_plain, heading_marked = seen
    assert np.array_equal(mapped_marked, mapped_plain, equal_nan=True)
    assert np.array_equal(heading_plain, mapped_plain, equal_nan=True)
    structure = np.isfinite(heading_plain) & np.isnan(heading_marked)
    assert structure.sum() > 10  # the border, taken from floor points only
    assert np.array_equal(np.isnan(heading_marked), np.isnan(heading_plain) | structure)
    np.testing.assert_allclose(heading_plain[structure], 0.05, atol=1e-3)  # the box top's rim
