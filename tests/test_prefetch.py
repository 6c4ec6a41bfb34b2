"""Frames segmented ahead on a second thread: a segmenter's results (segmentation and tilt filter)
in order, the same run bit for bit, errors raised as the frame's own, bounded, stopped with the
run."""

from __future__ import annotations

import dataclasses
import threading
import time

import numpy as np
import pytest
from synthetic_depth import Box, add_depth_noise, look_down_camera, render_boxes

from fogsim.config import RunParams
from fogsim.data.frame import Frame
from fogsim.errors import FogsimError, FrameError
from fogsim.eval.archive import view_points_world
from fogsim.eval.maps import write_maps
from fogsim.mapping.prefetch import SegmentAhead
from fogsim.mapping.segmenter import FrameSegmenter
from fogsim.run.runner import run_frames
from fogsim.world.truth import ObjectState, SceneTruth
from mapper.intrinsics import PinholeIntrinsics
from mapper.segmentation import segment_depth

INTR = PinholeIntrinsics.from_fov(88, 72, 47.0, 39.0)
CAMERA_IN_ROBOT = look_down_camera((0.0, 0.0, 0.9), pitch_down_deg=35.0)
BOX = Box((1.5, 0.0), (0.3, 0.4, 0.05))
TRUTH = SceneTruth(
    0.0,
    (ObjectState("flat_box", (1.5, 0.0), (0.3, 0.4, 0.05), 0.0, 0.0, True),),
    ("ground", "flat_box"),
    {"ground": 0.0, "flat_box": 0.05},
)
FRAMES = 10


def walk_frames(n: int = FRAMES) -> list[Frame]:
    """A robot walking 3 cm a frame towards a flat box, noisy depth: every frame differs."""
    rng = np.random.default_rng(7)
    frames = []
    for i in range(n):
        pose = np.array([0.03 * i, 0.0, 0.0, 0.0])
        camera_in_world = np.eye(4)
        camera_in_world[:3, 3] = pose[:3]
        camera_in_world = camera_in_world @ CAMERA_IN_ROBOT
        depth = add_depth_noise(render_boxes(INTR, camera_in_world, [BOX]), 0.002, rng)
        frames.append(
            Frame(
                i,
                i / 12.5,
                depth.astype(np.float32),
                INTR,
                CAMERA_IN_ROBOT.copy(),
                pose,
                camera_in_world,
                pose,
            )
        )
    return frames


def ahead_threads() -> list[threading.Thread]:
    return [t for t in threading.enumerate() if t.name == "fogsim-segment-ahead"]


def assert_same_result(a, b, where: str) -> None:
    """Two (nested) segmentation results equal, every array bit for bit."""
    if isinstance(a, np.ndarray):
        np.testing.assert_array_equal(a, b, err_msg=where, strict=True)
    elif dataclasses.is_dataclass(a):
        assert type(a) is type(b), where
        for field in dataclasses.fields(a):
            assert_same_result(
                getattr(a, field.name), getattr(b, field.name), where + "." + field.name
            )
    else:
        assert a == b or (a != a and b != b), where  # NaN == NaN here


@pytest.fixture(scope="module")
def frames():
    return walk_frames()


def test_hands_out_exactly_the_segmenters_results_in_order(frames):
    """The tilt-filtered segmentations, each that of a segmenter fed the frames in line."""
    in_line = FrameSegmenter(RunParams())
    assert in_line.tilt is not None  # the filter's state carries over the frames
    with SegmentAhead(frames, FrameSegmenter(RunParams()), ahead=2) as ahead:
        ahead.start()
        seen = []
        for frame in ahead:
            result = ahead.segmented(frame)
            assert_same_result(result, in_line(frame), f"frame {frame.index}")
            assert ahead.segmentation_ms > 0.0
            seen.append(frame.index)
    assert seen == list(range(FRAMES))
    assert not ahead_threads()


def assert_same_run(inline, other, tmp_path):
    """Two `run_frames` results have the same maps (written files), counts and scores."""
    for name, result in (("inline", inline), ("other", other)):
        write_maps(tmp_path / f"{name}.npz", result, result.final_truth)
    with np.load(tmp_path / "inline.npz") as a, np.load(tmp_path / "other.npz") as b:
        assert sorted(a.files) == sorted(b.files)
        for name in a.files:
            np.testing.assert_array_equal(a[name], b[name], err_msg=name, strict=True)
    assert (inline.frames, inline.withdrawn, inline.z_matched) == (
        other.frames,
        other.withdrawn,
        other.z_matched,
    )
    assert inline.scores == other.scores
    assert inline.scores.table1.fog  # something was scored


def test_a_run_segmented_ahead_equals_the_run_in_line(frames, tmp_path):
    """run_frames' maps, archive, counts and scores are the same with and without the thread."""
    inline, ahead = (
        run_frames(frames, lambda t: TRUTH, None, segment_ahead=ahead) for ahead in (False, True)
    )
    assert_same_run(inline, ahead, tmp_path)
    np.testing.assert_array_equal(np.isnan(inline.update_ms), np.isnan(ahead.update_ms))
    assert not ahead_threads()


def test_a_segmentation_error_in_frame_k_surfaces_as_frame_ks(frames):
    """Frames 0-2 are mapped; frame 3's error is raised when the pipeline segments frame 3."""
    calls = []

    def failing(depth_m, intrinsics, transform, params):
        calls.append(len(calls))
        if len(calls) == 4:
            raise FogsimError("frame 3: the segmentation choked")
        return segment_depth(depth_m, intrinsics, transform, params)

    mapped = []
    with pytest.raises(FogsimError, match="frame 3: the segmentation choked") as raised:
        run_frames(
            frames, None, None, segment=failing, on_frame=lambda f, p: mapped.append(f.index)
        )
    assert mapped == [0, 1, 2]
    assert "failing" in {entry.name for entry in raised.traceback}  # the thread's traceback
    assert not ahead_threads()


def test_the_frame_check_of_frame_k_comes_first_as_in_line(frames):
    """A refused pose in frame 5 stops the run at frame 5 (FrameError), thread stopped."""
    bad = list(frames)
    bad[5] = dataclasses.replace(bad[5], robot_pose_believed=np.array([np.nan, 0.0, 0.0, 0.0]))
    mapped: dict[bool, list[int]] = {False: [], True: []}
    for ahead in (False, True):
        with pytest.raises(FrameError, match="frame 5"):
            run_frames(
                bad,
                None,
                None,
                segment_ahead=ahead,
                on_frame=lambda f, p, seen=mapped[ahead]: seen.append(f.index),
            )
    assert mapped == {False: [0, 1, 2, 3, 4], True: [0, 1, 2, 3, 4]}
    assert not ahead_threads()


def test_an_error_of_the_frames_source_is_raised_where_it_happened(frames):
    def source():
        yield from frames[:2]
        raise FogsimError("frame 2: the head camera fell off")

    mapped = []
    with pytest.raises(FogsimError, match="head camera fell off"):
        run_frames(source(), None, None, on_frame=lambda f, p: mapped.append(f.index))
    assert mapped == [0, 1]
    assert not ahead_threads()


def test_an_interrupt_in_the_consumer_stops_the_thread(frames):
    def interrupt(frame, pipeline):
        if frame.index == 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_frames(frames, None, None, on_frame=interrupt)
    assert not ahead_threads()


def test_looks_ahead_at_most_ahead_frames_and_stops_when_closed():
    """One frame handed out: `ahead` queued and one more segmented, then the thread waits."""
    pulled = []

    def endless():
        for i in range(10**9):
            pulled.append(i)
            yield Frame(
                i,
                0.0,
                np.zeros((1, 1), np.float32),
                INTR,
                np.eye(4),
                np.zeros(4),
                np.eye(4),
                np.zeros(4),
            )

    source = SegmentAhead(endless(), lambda frame: "segmented", ahead=3)
    source.start()
    iterator = iter(source)
    next(iterator)
    deadline = time.monotonic() + 30.0
    while len(pulled) < 5 and time.monotonic() < deadline:
        time.sleep(0.01)
    time.sleep(0.3)  # room for a frame too many, were the queue unbounded
    assert len(pulled) == 5  # 1 handed out + 3 queued + 1 waiting for room
    assert ahead_threads()
    source.close()
    assert not ahead_threads()
    assert len(pulled) == 5
    source.close()  # idempotent


def assert_refuses_another_frame_and_a_second_ask(ahead, frames) -> None:
    """``ahead`` (started, over ``frames[:3]``) refuses another frame, a copy, a second ask."""
    iterator = iter(ahead)
    frame = next(iterator)
    with pytest.raises(FogsimError, match="another frame"):
        ahead.segmented(frames[1])
    frame = next(iterator)
    with pytest.raises(FogsimError, match="another frame"):  # an equal copy is not it
        ahead.segmented(dataclasses.replace(frame))
    frame = next(iterator)
    assert ahead.segmented(frame) is not None
    with pytest.raises(FogsimError, match="another frame"):  # asked already
        ahead.segmented(frame)


def test_refuses_another_frame_and_a_second_ask(frames):
    with SegmentAhead(frames[:3], FrameSegmenter(RunParams())) as ahead:
        ahead.start()
        assert_refuses_another_frame_and_a_second_ask(ahead, frames)


def test_refuses_no_look_ahead_and_iterating_before_start(frames):
    with pytest.raises(FogsimError, match="ahead must be >= 1 frame, got 0"):
        SegmentAhead(frames, FrameSegmenter(RunParams()), ahead=0)
    with pytest.raises(FogsimError, match="start"):
        next(iter(SegmentAhead(frames, FrameSegmenter(RunParams()))))


def test_also_hands_out_what_the_thread_made_of_the_frame_just_iterated(frames):
    """``also``: made on the thread for each frame, handed out for that frame only."""
    made_on = []

    def points(frame):
        made_on.append(threading.current_thread().name)
        if frame.index == 2:
            raise ValueError("made again by the consumer")
        return view_points_world(frame)

    with SegmentAhead(frames[:4], FrameSegmenter(RunParams()), also=points) as ahead:
        ahead.start()
        previous = None
        for frame in ahead:
            got = ahead.also(frame)
            if frame.index == 2:
                assert got is None  # it raised on the thread
            else:
                assert got.tobytes() == view_points_world(frame).tobytes()
            assert ahead.also(dataclasses.replace(frame)) is None  # an equal copy is not it
            if previous is not None:
                assert ahead.also(previous) is None
            ahead.segmented(frame)
            assert ahead.also(frame) is got  # still this frame's after its segmentation
            previous = frame
    assert made_on == ["fogsim-segment-ahead"] * 4
    with SegmentAhead(frames[:1], FrameSegmenter(RunParams())) as ahead:  # no `also`
        ahead.start()
        assert all(ahead.also(frame) is None for frame in ahead)
