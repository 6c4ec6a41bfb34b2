"""The Rerun recording of a run, read back from the .rrd: a synthetic scene with known truth."""

import sys
from collections import defaultdict
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pytest
from synthetic_depth import Box, render_scene
from test_pipeline import CAMERA_IN_ROBOT, INTR, RATE_HZ, ROBOT_POSE, camera_in_world

from fogsim.cli import main
from fogsim.config import PipelineParams, RunParams
from fogsim.data.frame import Frame
from fogsim.data.recording import save_recording
from fogsim.errors import FogsimError, OutputError
from fogsim.run.runner import run_frames
from fogsim.viz.rerun_log import DISPLAY_VARIABLES, RerunLogger, check_display
from fogsim.viz.style import CMAP
from fogsim.world.truth import ObjectState, SceneTruth

TOP_M = 0.3
BOX = Box((1.35, 0.5), (0.3, 0.4, TOP_M))  # tall: its sides are obstacle, its top a floor
STATE = ObjectState("tall_box", (1.35, 0.5), (0.3, 0.4, TOP_M), 0.0, 0.0, True)
TRUTH = SceneTruth(0.0, (STATE,), ("ground", "tall_box"), {"ground": 0.0, "tall_box": TOP_M})
EMPTY = SceneTruth(0.0, (), ("ground", "tall_box"), {"ground": 0.0, "tall_box": TOP_M})
FRAMES = 5
TRUE_OFFSET = np.array([0.01, 0.0, 0.0, 0.0])  # the true pose differs from the believed one
ENTITIES = {
    "/world",
    "/camera/depth",
    "/world/camera",
    "/world/points/floor",
    "/world/points/obstacle",
    "/world/occupied",
    "/world/fog/floor",
    "/world/fog/obstacle",
    "/world/robot/believed",
    "/world/robot/true",
    "/world/robot/path_believed",
    "/world/robot/path_true",
    "/world/truth",
}
PER_FRAME = RunParams(pipeline=PipelineParams(use_height_reference=False))
"""These runs are a few synthetic frames, fewer than the height reference needs to converge
(its frames wait, then map at once): the paper's per-frame rule maps and logs every frame."""


def frames_and_rendering(count):
    rendering = render_scene(INTR, camera_in_world(), [BOX])
    rendering.depth_m[:4] = np.nan  # the top rows unmeasured (as the self-filter leaves them)
    frames = [
        Frame(
            index=i,
            time_s=i / RATE_HZ,
            depth_m=rendering.depth_m.astype(np.float32),
            intrinsics=INTR,
            transform_camera_to_robot_believed=CAMERA_IN_ROBOT,
            robot_pose_believed=ROBOT_POSE,
            transform_camera_to_world_true=camera_in_world(),
            robot_pose_true=ROBOT_POSE + TRUE_OFFSET,
        )
        for i in range(count)
    ]
    return frames, rendering


def rerun_chunk():
    """rerun-sdk's chunk reader module; the test is skipped without the viewer extra."""
    return pytest.importorskip("rerun.chunk", reason="rerun-sdk (fogsim[viewer]) not installed")


def log_run(path, frames, truth_at):
    rerun_chunk()
    with RerunLogger(path, "test", truth_at) as logger:
        result = run_frames(frames, truth_at, None, params=PER_FRAME, on_frame=logger.add)
    return result


def read_rrd(path):
    """entity path → its rows (column name → value), temporal rows in frame order."""
    rows = defaultdict(list)
    for chunk in rerun_chunk().RrdReader(path).stream():
        batch = chunk.to_record_batch()
        rows[chunk.entity_path].extend(batch.drop_columns(["rerun.controls.RowId"]).to_pylist())
    return {entity: sorted(r, key=lambda row: row.get("frame", -1)) for entity, r in rows.items()}


@pytest.fixture(scope="module")
def logged(tmp_path_factory):
    path = tmp_path_factory.mktemp("rrd") / "run.rrd"
    frames, rendering = frames_and_rendering(FRAMES)
    result = log_run(path, frames, lambda t: TRUTH)
    return read_rrd(path), result, rendering, path


def test_the_file_holds_every_entity_once_per_frame_on_both_timelines(logged):
    rows, _, _, path = logged
    assert set(rows) == ENTITIES
    assert [p.name for p in path.parent.iterdir()] == ["run.rrd"]  # no temporary left
    for entity in ENTITIES - {"/world", "/world/truth"} - {e for e in ENTITIES if "path" in e}:
        assert [row["frame"] for row in rows[entity]] == list(range(FRAMES)), entity
        times_s = [row["sim_time"].total_seconds() for row in rows[entity]]
        np.testing.assert_allclose(times_s, np.arange(FRAMES) / RATE_HZ, atol=1e-9)
        assert "log_time" not in rows[entity][0]  # no wall clock in the data


def test_the_depth_image_is_the_frames_with_zero_for_none(logged):
    rows, _, rendering, _ = logged
    (row, *_) = rows["/camera/depth"]
    width, height = row["DepthImage:format"][0]["width"], row["DepthImage:format"][0]["height"]
    assert (width, height) == (INTR.width, INTR.height)
    depth = np.frombuffer(bytes(row["DepthImage:buffer"][0]), dtype=np.float32)
    expected = np.nan_to_num(rendering.depth_m.astype(np.float32), nan=0.0).ravel()
    np.testing.assert_array_equal(depth, expected)


def test_labelled_points_are_where_the_camera_saw_the_box_and_ground(logged):
    rows, _, rendering, _ = logged
    true_floor_m = rendering.true_floor_height_m([BOX])
    seen = np.isfinite(rendering.depth_m)
    expected_obstacle = int(np.count_nonzero(seen & np.isnan(true_floor_m)))
    expected_floor = int(np.count_nonzero(seen & np.isfinite(true_floor_m)))
    assert expected_obstacle > 300  # the box's front face fills part of the image
    floor = rows["/world/points/floor"][-1]
    obstacle = rows["/world/points/obstacle"][-1]
    floor_xyz = np.array(floor["Points3D:positions"])
    obstacle_xyz = np.array(obstacle["Points3D:positions"])
    # Every pixel is a point; the segmentation's labels match the truth but at plane edges.
    assert len(floor_xyz) + len(obstacle_xyz) == np.count_nonzero(seen)
    assert abs(len(obstacle_xyz) - expected_obstacle) <= 0.05 * expected_obstacle
    assert abs(len(floor_xyz) - expected_floor) <= 0.05 * expected_obstacle
    # Floor points lie on the ground or on the box top (exact depth: within a millimetre).
    on_ground = np.abs(floor_xyz[:, 2]) < 1e-3
    on_top = np.abs(floor_xyz[:, 2] - TOP_M) < 1e-3
    assert (on_ground | on_top).all() and on_top.sum() > 50
    # Obstacle points on the box's faces (within 2 cm: a few edge pixels may be labelled so).
    x, y, z = obstacle_xyz.T
    on_box = (np.abs(x - 1.35) < 0.17) & (np.abs(y - 0.5) < 0.22) & (z > -0.02)
    assert on_box.mean() > 0.97
    # Colours: obstacle points red; ground points the colour map's low end, top its high end.
    assert obstacle["Points3D:colors"] == [0xFF0000FF]
    colours = np.array(floor["Points3D:colors"], dtype=np.uint32)
    low, high = (
        int.from_bytes(
            bytes([*np.round(np.array(plt.get_cmap(CMAP)(v)[:3]) * 255).astype(int), 255])
        )
        for v in (0.0, 1.0)
    )
    assert set(colours[on_ground]) == {low} and set(colours[on_top]) == {high}


def test_occupied_cells_and_fog_tiles_are_the_mappers_at_each_frame(logged):
    rows, result, _, _ = logged
    mapper, params = result.mapper, result.params.mapper
    # One hit gives p_sense = 0.63 < p_occ = 0.65: nothing is occupied after the first frame.
    assert (params.p_sense, params.p_occ) == (0.63, 0.65)
    assert rows["/world/occupied"][0]["Boxes3D:centers"] == []
    ix, iy, iz = np.nonzero(mapper.occupancy_levels() > params.occ_threshold_level)
    occupied = rows["/world/occupied"][-1]
    centers = np.array(occupied["Boxes3D:centers"])
    np.testing.assert_allclose(centers, mapper.cell_center(ix, iy, iz), atol=1e-6)
    half = (params.cell_m / 2, params.cell_m / 2, params.layer_m / 2)
    np.testing.assert_allclose(occupied["Boxes3D:half_sizes"], [half], atol=1e-7)
    # The ground's layer (centre z = 0) or the box: nothing else is occupied.
    x, y, z = centers.T
    in_box = (np.abs(x - 1.35) < 0.15 + params.cell_m) & (np.abs(y - 0.5) < 0.2 + params.cell_m)
    assert ((np.abs(z) < 1e-6) | (in_box & (z < TOP_M + params.layer_m))).all()
    assert (in_box & (z > 0.1)).any()
    types, heights = mapper.fog()
    for kind, name in ((1, "floor"), (2, "obstacle")):
        tiles = np.array(rows[f"/world/fog/{name}"][-1]["Boxes3D:centers"])
        assert len(tiles) == np.count_nonzero(types == kind) > 0, name
        np.testing.assert_allclose(np.sort(tiles[:, 2]), np.sort(heights[types == kind]), atol=1e-6)
    assert rows["/world/fog/obstacle"][-1]["Boxes3D:colors"] == [0x000000FF]
    floor_z = np.array(rows["/world/fog/floor"][-1]["Boxes3D:centers"])[:, 2]
    assert ((np.abs(floor_z) < 0.01) | (np.abs(floor_z - TOP_M) < 0.01)).all()


def test_truth_poses_and_paths(logged):
    rows, _, _, _ = logged
    (truth,) = rows["/world/truth"]  # static truth: logged once
    assert truth["frame"] == 0 and truth["Boxes3D:labels"] == ["tall_box"]
    np.testing.assert_allclose(truth["Boxes3D:centers"], [[1.35, 0.5, TOP_M / 2]], atol=1e-6)
    np.testing.assert_allclose(truth["Boxes3D:half_sizes"], [[0.15, 0.2, TOP_M / 2]], atol=1e-6)
    believed = [row["Points3D:positions"][0] for row in rows["/world/robot/believed"]]
    true = [row["Points3D:positions"][0] for row in rows["/world/robot/true"]]
    np.testing.assert_allclose(believed, [ROBOT_POSE[:3]] * FRAMES, atol=1e-6)
    np.testing.assert_allclose(true, [(ROBOT_POSE + TRUE_OFFSET)[:3]] * FRAMES, atol=1e-6)
    for name, expected in (("path_believed", believed), ("path_true", true)):
        (row,) = rows[f"/world/robot/{name}"]
        assert "frame" not in row  # static: the whole path at every time
        np.testing.assert_allclose(row["LineStrips3D:strips"], [expected], atol=1e-6)


def test_the_truth_is_logged_again_when_an_event_changes_it(tmp_path):
    frames, _ = frames_and_rendering(4)
    log_run(tmp_path / "run.rrd", frames, lambda t: TRUTH if t < 0.2 else EMPTY)
    truth = read_rrd(tmp_path / "run.rrd")["/world/truth"]
    assert [(row["frame"], row["Boxes3D:labels"]) for row in truth] == [(0, ["tall_box"]), (3, [])]


def test_same_frames_same_logged_data(tmp_path, logged):
    frames, _ = frames_and_rendering(FRAMES)
    log_run(tmp_path / "again.rrd", frames, lambda t: TRUTH)
    assert read_rrd(tmp_path / "again.rrd") == logged[0]


def test_a_failed_run_leaves_no_file(tmp_path):
    rerun_chunk()
    frames, _ = frames_and_rendering(2)
    with pytest.raises(RuntimeError), RerunLogger(tmp_path / "run.rrd", "test") as logger:
        run_frames(frames, None, None, params=PER_FRAME, on_frame=logger.add)
        raise RuntimeError("interrupted")
    assert list(tmp_path.iterdir()) == []


def test_without_rerun_the_error_says_how_to_install_it(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "rerun", None)  # import rerun → ImportError
    with pytest.raises(FogsimError, match=r"pip install 'fogsim\[viewer\]'"):
        RerunLogger(tmp_path / "run.rrd", "test")
    assert list(tmp_path.iterdir()) == []


def test_the_folder_is_made_and_an_unwritable_path_is_an_output_error(tmp_path):
    rerun_chunk()
    frames, _ = frames_and_rendering(1)
    log_run(tmp_path / "new" / "folder" / "run.rrd", frames, None)
    assert (tmp_path / "new" / "folder" / "run.rrd").is_file()
    (tmp_path / "file").write_text("")
    with pytest.raises(OutputError, match=r"cannot write .*file/run\.rrd"):
        RerunLogger(tmp_path / "file" / "run.rrd", "test")


def test_fogsim_run_rerun_writes_the_file_beside_the_run(tmp_path, capsys):
    rerun_chunk()
    frames, _ = frames_and_rendering(FRAMES)
    recording = save_recording(tmp_path / "rec.npz", frames, truths=[TRUTH] * FRAMES)
    rrd = tmp_path / "view" / "run.rrd"
    args = ["run", "--replay", str(recording), "--out", str(tmp_path / "run"), "--quiet"]
    assert main([*args, "--no-pictures", "--rerun", str(rrd)]) == 0, capsys.readouterr().err
    rows = read_rrd(rrd)
    # A real-data run maps with the height reference: these few frames all wait for it and are
    # mapped at the run's end, after the last frame was logged, so no labelled points are
    # logged (a known limitation: deferred frames are not logged when they are mapped).
    points = {"/world/points/floor", "/world/points/obstacle"}
    assert set(rows) == ENTITIES - points and len(rows["/camera/depth"]) == FRAMES
    assert (tmp_path / "run" / "report.json").is_file()


def test_fogsim_run_rerun_refuses_a_folder_and_seeds(tmp_path, capsys):
    assert main(["run", "stage", "--rerun", str(tmp_path), "--quiet"]) == 2
    assert "--rerun" in capsys.readouterr().err
    assert main(["run", "stage", "--seeds", "1-2", "--rerun", str(tmp_path / "a.rrd")]) == 2
    assert "--rerun logs one run" in capsys.readouterr().err


# ---------------------------------------------------------------------- --rerun-spawn


@pytest.mark.parametrize(
    ("environ", "platform", "has_display"),
    [
        ({}, "linux", False),
        ({"DISPLAY": ""}, "linux", False),
        ({"DISPLAY": ":0"}, "linux", True),
        ({"WAYLAND_DISPLAY": "wayland-0"}, "linux", True),
        ({}, "darwin", True),
        ({}, "win32", True),
    ],
)
def test_a_display_is_display_or_wayland_display_on_linux(environ, platform, has_display):
    if has_display:
        check_display(environ, platform)
    else:
        with pytest.raises(FogsimError, match="neither DISPLAY nor WAYLAND_DISPLAY is set"):
            check_display(environ, platform)


def headless(monkeypatch):
    for name in DISPLAY_VARIABLES:
        monkeypatch.delenv(name, raising=False)


def test_spawning_the_viewer_headless_is_an_error_saying_what_to_do(tmp_path, monkeypatch):
    headless(monkeypatch)
    advice = r"neither DISPLAY nor .* is set; write a file instead \(fogsim run \.\.\. --rerun FILE"
    with pytest.raises(FogsimError, match=advice):
        RerunLogger(None, "test", spawn=True)
    with pytest.raises(FogsimError, match="give a path or spawn=True"):
        RerunLogger(tmp_path / "run.rrd", "test", spawn=True)
    with pytest.raises(FogsimError, match="give a path or spawn=True"):
        RerunLogger(None, "test")
    assert list(tmp_path.iterdir()) == []


def test_fogsim_run_rerun_spawn_headless_exits_2_before_running(tmp_path, capsys, monkeypatch):
    headless(monkeypatch)
    frames, _ = frames_and_rendering(2)
    recording = save_recording(tmp_path / "rec.npz", frames, truths=[TRUTH] * 2)
    out = tmp_path / "run"
    args = ["run", "--replay", str(recording), "--out", str(out), "--quiet", "--no-pictures"]
    assert main([*args, "--rerun-spawn"]) == 2
    err = capsys.readouterr().err
    assert "neither DISPLAY nor WAYLAND_DISPLAY is set" in err and "--rerun FILE.rrd" in err
    assert not out.exists()
    assert main([*args, "--rerun-spawn", "--rerun", str(tmp_path / "a.rrd")]) == 2
    assert "give --rerun FILE.rrd or --rerun-spawn, not both" in capsys.readouterr().err
    assert main(["run", "stage", "--seeds", "1-2", "--rerun-spawn"]) == 2
    assert "--rerun logs one run" in capsys.readouterr().err


def test_with_a_display_the_run_streams_to_the_spawned_viewer(tmp_path, monkeypatch):
    rr = pytest.importorskip("rerun")
    rerun_chunk()
    monkeypatch.setenv("DISPLAY", ":0")
    monkeypatch.setenv("PATH", str(tmp_path))  # no rerun on the PATH: the one beside Python
    viewer = tmp_path / "viewer.rrd"
    spawned = []

    def spawn(*, recording, executable_path):  # the viewer's end of the stream: a file here
        spawned.append(executable_path)
        recording.save(str(viewer))

    monkeypatch.setattr(rr, "spawn", spawn)
    frames, _ = frames_and_rendering(FRAMES)
    with RerunLogger(None, "test", lambda t: TRUTH, spawn=True) as logger:
        run_frames(frames, lambda t: TRUTH, None, params=PER_FRAME, on_frame=logger.add)
    assert spawned == [str(Path(sys.executable).with_name("rerun"))] and logger.path is None
    rows = read_rrd(viewer)
    assert set(rows) == ENTITIES and len(rows["/camera/depth"]) == FRAMES
    assert [p.name for p in tmp_path.iterdir()] == ["viewer.rrd"]  # no file of the logger's


@pytest.mark.slow  # Rerun gives up connecting after 6 s and waits 5 s more at shutdown
def test_a_viewer_that_never_listens_is_an_error_when_the_log_ends(monkeypatch):
    rr = pytest.importorskip("rerun")
    monkeypatch.setenv("DISPLAY", ":0")

    def spawn(*, recording, executable_path):  # a viewer that died: nothing listens (loopback)
        recording.connect_grpc("rerun+http://127.0.0.1:9/proxy")

    monkeypatch.setattr(rr, "spawn", spawn)
    frames, _ = frames_and_rendering(1)
    with (
        pytest.raises(FogsimError, match="the Rerun viewer did not take the log"),
        RerunLogger(None, "test", spawn=True) as logger,
    ):
        run_frames(frames, None, None, params=PER_FRAME, on_frame=logger.add)
