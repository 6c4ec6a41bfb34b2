"""`FrameSegmenter`'s camera turn: what scales the tilt filter's process noise."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

import fogsim.mapping.segmenter as segmenter_module
from fogsim.config import RunParams
from fogsim.config.params import PipelineParams
from fogsim.data.frame import Frame
from fogsim.errors import ParameterError
from fogsim.mapping.segmenter import FrameSegmenter
from mapper.intrinsics import PinholeIntrinsics
from mapper.tilt_filter import TiltEstimate

INTRINSICS = PinholeIntrinsics(4, 3, 4.0, 4.0, 2.0, 1.5)


def pitched(deg: float) -> np.ndarray:
    """A believed camera pose turned ``deg`` about the robot's y axis."""
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    out = np.eye(4)
    out[:3, :3] = [[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]]
    return out


def frames(angles_deg):
    return [
        Frame(
            index=i,
            time_s=i / 12.5,
            depth_m=np.ones((3, 4), dtype=np.float32),
            intrinsics=INTRINSICS,
            transform_camera_to_robot_believed=pitched(a),
            robot_pose_believed=np.zeros(4),
            transform_camera_to_world_true=np.eye(4),
            robot_pose_true=np.zeros(4),
        )
        for i, a in enumerate(angles_deg)
    ]


class TurnRecorder:
    """Stands in for the tilt filter: keeps the turns it is given."""

    def __init__(self):
        self.turns_deg = []

    def update(self, measured, sigma, turn_rad):
        self.turns_deg.append(math.degrees(turn_rad))
        return TiltEstimate(np.zeros(2), np.zeros(2), measured=False)


def turns(angles_deg, turn_frames, monkeypatch):
    monkeypatch.setattr(segmenter_module, "measured_tilt", lambda seg, params: (None, math.inf))
    monkeypatch.setattr(segmenter_module, "apply_tilt", lambda seg, tilt: seg)
    params = RunParams(pipeline=PipelineParams(tilt_turn_frames=turn_frames))
    segmenter = FrameSegmenter(params, segment=lambda *args: "segmented")
    recorder = TurnRecorder()
    segmenter.tilt = recorder
    for frame in frames(angles_deg):
        assert segmenter(frame) == "segmented"
    return recorder.turns_deg


# A held head whose readings jitter ±0.5° from frame to frame, and a steady 1° a frame.
JITTER = [0.5 * (-1) ** i for i in range(8)]
STEADY = [float(i) for i in range(8)]


def test_one_frame_turns_are_the_angles_between_consecutive_frames(monkeypatch):
    assert turns(JITTER, 1, monkeypatch) == pytest.approx([0.0] + [1.0] * 7)
    assert turns(STEADY, 1, monkeypatch) == pytest.approx([0.0] + [1.0] * 7)


def test_over_four_frames_the_jitter_averages_out_and_a_steady_turn_keeps_its_rate(monkeypatch):
    # Frame k: the angle to frame k − 4 (to frame 0 while fewer came), over the frames between.
    assert turns(JITTER, 4, monkeypatch) == pytest.approx([0.0, 1.0, 0.0, 1 / 3, 0, 0, 0, 0])
    assert turns(STEADY, 4, monkeypatch) == pytest.approx([0.0] + [1.0] * 7)


@pytest.mark.parametrize("value", [0, 101, 2.5, True])
def test_tilt_turn_frames_outside_1_to_100_is_refused_by_name(value):
    with pytest.raises(ParameterError, match=r"tilt_turn_frames must be an integer in \[1, 100\]"):
        dataclasses.replace(PipelineParams(), tilt_turn_frames=value)
