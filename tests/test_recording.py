"""Recording format: round trip, truths, validation errors naming what is wrong."""

import json

import numpy as np
import pytest

from fogsim.config import load_scenario
from fogsim.data.frame import Frame
from fogsim.data.recording import FORMAT_VERSION, load_recording, save_recording
from fogsim.errors import RecordingError
from fogsim.world import ObjectState, SceneTruth
from mapper.intrinsics import PinholeIntrinsics

INTR = PinholeIntrinsics.from_fov(8, 6, 47.0, 39.0)


def make_frames(n=4, seed=0):
    rng = np.random.default_rng(seed)
    frames = []
    for i in range(n):
        depth = rng.uniform(0.5, 3.0, INTR.shape).astype(np.float32)
        depth[0, i] = np.nan
        cam = np.eye(4)
        cam[:3, 3] = [0.05, 0.0, 0.9 + 0.001 * i]
        world = np.eye(4)
        world[:3, 3] = [0.3 + 0.01 * i, 0.5, 0.9]
        frames.append(
            Frame(
                index=i,
                time_s=i / 12.5,
                depth_m=depth,
                intrinsics=INTR,
                transform_camera_to_robot_believed=cam,
                robot_pose_believed=np.array([0.3 + 0.01 * i, 0.5, 0.0, 0.01 * i]),
                transform_camera_to_world_true=world,
                robot_pose_true=np.array([0.3 + 0.01 * i, 0.5, 0.0, 0.0]),
                self_filtered_pixels=i,
            )
        )
    return frames


BOX = ObjectState("box", (1.0, 0.5), (0.3, 0.4, 0.05), 0.0, 0.0, True)
NAMES = ("ground", "box")


def test_round_trip_keeps_every_field_bit_for_bit(tmp_path):
    frames = make_frames()
    with_box = SceneTruth(0.0, (BOX,), NAMES, {"ground": 0.0, "box": 0.05})
    without = SceneTruth(0.2, (), NAMES, {"ground": 0.0, "box": 0.05})
    truths = [with_box, with_box, without, without]
    scenario = load_scenario("box_removal")
    path = save_recording(tmp_path / "run.npz", frames, scenario=scenario, truths=truths)
    rec = load_recording(path)
    assert len(rec.frames) == 4 and rec.intrinsics == INTR
    for a, b in zip(frames, rec.frames, strict=True):
        assert a.index == b.index and a.time_s == b.time_s
        np.testing.assert_array_equal(a.depth_m, b.depth_m)  # NaN positions included
        for name in (
            "transform_camera_to_robot_believed",
            "robot_pose_believed",
            "transform_camera_to_world_true",
            "robot_pose_true",
        ):
            np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
        assert a.self_filtered_pixels == b.self_filtered_pixels
    assert rec.scenario.name == "box_removal"
    assert rec.scenario.events == scenario.events
    assert rec.has_truth
    assert [len(t.objects) for t in rec.truths] == [1, 1, 0, 0]
    # Equal world states are stored once.
    with np.load(path) as data:
        assert len(json.loads(str(data["meta_json"]))["truths"]) == 2
    assert rec.truth_at(0.1).objects == (BOX,)
    assert rec.truth_at(10.0).objects == ()


def test_real_data_without_scenario_and_truth(tmp_path):
    path = save_recording(tmp_path / "real.npz", make_frames(2))
    rec = load_recording(path)
    assert rec.scenario is None and not rec.has_truth and rec.truths == [None, None]


def test_hand_written_minimal_file_loads(tmp_path):
    """The documented minimum a user must write for real robot data."""
    n = 3
    meta = {
        "format": "fogsim-recording",
        "version": 1,
        "intrinsics": {"width": 8, "height": 6, "fx": 9.0, "fy": 9.0, "cx": 3.5, "cy": 2.5},
    }
    np.savez(
        tmp_path / "mine.npz",
        meta_json=np.array(json.dumps(meta)),
        time_s=np.arange(n) * 0.08,
        depth_m=np.ones((n, 6, 8), np.float32),
        transform_camera_to_robot_believed=np.tile(np.eye(4), (n, 1, 1)),
        robot_pose_believed=np.zeros((n, 4)),
    )
    rec = load_recording(tmp_path / "mine.npz")
    assert len(rec.frames) == 3
    assert np.all(np.isnan(rec.frames[0].robot_pose_true))


def test_version_1_truth_is_refused_with_the_way_out(tmp_path):
    """Version 1 truths lack the object names that per-object scores need: record again."""
    frames = make_frames(2)
    truth = SceneTruth(0.0, (BOX,), NAMES, {"ground": 0.0, "box": 0.05})
    path = save_recording(tmp_path / "v2.npz", frames, truths=[truth, truth])
    with np.load(path) as data:
        meta = json.loads(str(data["meta_json"]))
    assert meta["version"] == 2
    meta["version"] = 1
    _rewrite(path, tmp_path / "v1.npz", meta_json=np.array(json.dumps(meta)))
    with pytest.raises(RecordingError, match=r"version 1 .* record the scenario again"):
        load_recording(tmp_path / "v1.npz")


def _rewrite(path, out, **changes):
    with np.load(path) as data:
        arrays = {k: data[k] for k in data.files}
    arrays.update(changes)
    np.savez(out, **arrays)


def test_errors_name_the_problem(tmp_path):
    path = save_recording(tmp_path / "ok.npz", make_frames())
    with pytest.raises(RecordingError, match="not found"):
        load_recording(tmp_path / "missing.npz")
    (tmp_path / "junk.npz").write_bytes(b"not a zip")
    with pytest.raises(RecordingError, match="not a readable"):
        load_recording(tmp_path / "junk.npz")
    with np.load(path) as data:
        meta = json.loads(str(data["meta_json"]))
    meta["version"] = FORMAT_VERSION + 1
    _rewrite(path, tmp_path / "v.npz", meta_json=np.array(json.dumps(meta)))
    with pytest.raises(RecordingError, match=r"version 3 is not supported; supported versions"):
        load_recording(tmp_path / "v.npz")
    _rewrite(path, tmp_path / "s.npz", robot_pose_believed=np.zeros((4, 3)))
    with pytest.raises(RecordingError, match=r"'robot_pose_believed' must have shape \(4, 4\)"):
        load_recording(tmp_path / "s.npz")
    _rewrite(path, tmp_path / "t.npz", time_s=np.zeros(4))
    with pytest.raises(RecordingError, match="strictly increasing"):
        load_recording(tmp_path / "t.npz")


def test_save_rejects_mixed_intrinsics(tmp_path):
    frames = make_frames(2)
    other = PinholeIntrinsics.from_fov(8, 6, 60.0, 45.0)
    frames[1] = Frame(**{**frames[1].__dict__, "intrinsics": other})
    with pytest.raises(RecordingError, match="same for all frames"):
        save_recording(tmp_path / "x.npz", frames)
    assert not (tmp_path / "x.npz").exists()
