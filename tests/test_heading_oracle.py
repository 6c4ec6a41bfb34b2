"""`bench/heading_oracle.py`'s replay modes: what each changes in a frame, by hand."""

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "bench"))
heading_oracle = pytest.importorskip("heading_oracle")

from fogsim.data.frame import Frame  # noqa: E402
from mapper.intrinsics import PinholeIntrinsics  # noqa: E402


def frame() -> Frame:
    """A frame whose believed robot pose is 25 mm off sideways, 3 mm high and 0.8° turned."""
    camera = np.eye(4)
    camera[:3, 3] = (0.1, 0.0, 0.9)
    return Frame(
        index=7,
        time_s=0.56,
        depth_m=np.ones((72, 88), np.float32),
        intrinsics=PinholeIntrinsics.from_fov(88, 72, 47.0, 39.0),
        transform_camera_to_robot_believed=camera,
        robot_pose_believed=np.array([3.6, 0.525, 0.125, np.radians(0.8)]),
        transform_camera_to_world_true=camera.copy(),
        robot_pose_true=np.array([3.601, 0.5, 0.122, 0.0]),
    )


def test_true_xy_takes_out_odometry_s_horizontal_drift_only():
    original = frame()
    changed = heading_oracle.true_xy_frame(original)
    # x and y the true ones; z, yaw, the camera's believed transform and the rest as believed.
    np.testing.assert_array_equal(changed.robot_pose_believed[:2], [3.601, 0.5])
    np.testing.assert_array_equal(changed.robot_pose_believed[2:], [0.125, np.radians(0.8)])
    np.testing.assert_array_equal(
        changed.transform_camera_to_robot_believed, original.transform_camera_to_robot_believed
    )
    assert changed.index == 7 and changed.depth_m is original.depth_m
    # The frame it came from is left as it was.
    np.testing.assert_array_equal(original.robot_pose_believed[:2], [3.6, 0.525])


def test_only_the_pipeline_and_true_xy_keep_the_heading_estimator():
    assert set(heading_oracle.HEADING_MODES) == {"pipeline", "true xy"}
    assert set(heading_oracle.HEADING_MODES) <= set(heading_oracle.MODES)
    assert heading_oracle.MODES["true xy"] is heading_oracle.true_xy_frame


def test_true_tilt_replaces_the_filter_during_its_replay_only(monkeypatch):
    import types

    import fogsim.mapping.segmenter as segmenter

    filtered_tilt = segmenter.FrameSegmenter._filtered_tilt
    recording = types.SimpleNamespace(scenario="scene", frames=["frame"], truth_at=None)
    seen = {}

    def run_frames(frames, truth_at, scenario, *, params, segment_ahead):
        # In line (the patch is this process's), heading on, the frames as recorded.
        seen["tilt"] = segmenter.FrameSegmenter._filtered_tilt
        seen["args"] = (frames, params, segment_ahead)
        raise RuntimeError("stop here")

    monkeypatch.setattr(heading_oracle, "load_recording", lambda path: recording)
    monkeypatch.setattr(heading_oracle, "sensor_fields", lambda scenario: ())
    monkeypatch.setattr(
        heading_oracle, "resolve_params", lambda scenario, overrides, fields: overrides
    )
    monkeypatch.setattr(heading_oracle, "run_frames", run_frames)
    with pytest.raises(RuntimeError, match="stop here"):
        heading_oracle.replay(Path("rec.npz"), "true tilt")
    assert seen["tilt"] is heading_oracle._true_tilt
    assert seen["args"] == (["frame"], {}, False)
    # Restored although the replay failed; the pipeline's replay keeps the filter.
    assert segmenter.FrameSegmenter._filtered_tilt is filtered_tilt
    with pytest.raises(RuntimeError, match="stop here"):
        heading_oracle.replay(Path("rec.npz"), "pipeline")
    assert seen["tilt"] is filtered_tilt


def test_an_unknown_mode_is_refused_naming_every_mode():
    with pytest.raises(ValueError, match="true tilt") as refused:
        heading_oracle.replay(Path("rec.npz"), "true roll")
    assert all(mode in str(refused.value) for mode in heading_oracle.MODES)
