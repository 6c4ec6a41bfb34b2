"""Frames segmented ahead in a forked process: the segmenter's results bit for bit, in order, the
same run as in line, errors raised as the frame's own, the child stopped with the run."""

from __future__ import annotations

import dataclasses
import multiprocessing
import threading

import numpy as np
import pytest
from test_prefetch import (
    assert_refuses_another_frame_and_a_second_ask,
    assert_same_result,
    assert_same_run,
    walk_frames,
)

from fogsim.config import RunParams
from fogsim.data.recording import load_recording, save_recording
from fogsim.errors import FogsimError
from fogsim.eval.archive import view_points_world
from fogsim.mapping import segment_process
from fogsim.mapping.segment_process import SegmentInProcess, can_segment_in_process
from fogsim.mapping.segmenter import FrameSegmenter
from fogsim.run import runner
from fogsim.run.runner import run_frames
from fogsim.world.truth import ObjectState, SceneTruth
from mapper.segmentation import segment_depth

pytestmark = pytest.mark.skipif(
    "fork" not in multiprocessing.get_all_start_methods(), reason="needs fork"
)

TRUTH = SceneTruth(
    0.0,
    (ObjectState("flat_box", (1.5, 0.0), (0.3, 0.4, 0.05), 0.0, 0.0, True),),
    ("ground", "flat_box"),
    {"ground": 0.0, "flat_box": 0.05},
)


@pytest.fixture(scope="module")
def frames():
    return walk_frames()


@pytest.fixture
def forks(monkeypatch):
    """``run_frames`` forks its segmentation's process even if another test left a thread."""
    monkeypatch.setattr(runner, "can_segment_in_process", lambda: True)


def children() -> list[multiprocessing.process.BaseProcess]:
    return [p for p in multiprocessing.active_children() if p.name == "fogsim-segment-process"]


@pytest.mark.parametrize("whole", [False, True])
def test_hands_out_exactly_the_segmenters_results_in_order(frames, monkeypatch, whole):
    """The tilt-filtered segmentations and world points, each the in-line one, bit for bit.

    ``whole``: slots too small for any message, every result sent through the queue instead.
    """
    if whole:
        monkeypatch.setattr(segment_process, "_SLOT_BYTES_PER_PIXEL", 0)
        monkeypatch.setattr(segment_process, "_SLOT_SPARE_BYTES", 1)
    in_line = FrameSegmenter(RunParams())
    seen = []
    with SegmentInProcess(
        frames, FrameSegmenter(RunParams()), ahead=2, also=view_points_world
    ) as ahead:
        ahead.start()
        for frame in ahead:
            points = ahead.also(frame)
            result = ahead.segmented(frame)
            assert_same_result(result, in_line(frame), f"frame {frame.index}")
            np.testing.assert_array_equal(points, view_points_world(frame), strict=True)
            assert ahead.segmentation_ms > 0.0
            seen.append(frame.index)
    assert seen == [frame.index for frame in frames]
    assert not children()


def test_a_run_segmented_in_a_process_equals_the_run_in_line(frames, tmp_path, forks):
    """run_frames' maps, archive, counts and scores are the same in a process and in line."""
    inline, forked = (
        run_frames(frames, lambda t: TRUTH, None, segment_ahead=ahead, segment_process=ahead)
        for ahead in (False, True)
    )
    assert_same_run(inline, forked, tmp_path)
    assert not children()


def test_a_segmentation_error_in_frame_k_surfaces_as_frame_ks(frames, forks):
    """Frames 0-2 are mapped; frame 3's error is raised when the pipeline segments frame 3."""
    calls = []

    def failing(depth_m, intrinsics, transform, params):
        calls.append(len(calls))  # the child's list
        if len(calls) == 4:
            raise FogsimError("frame 3: the segmentation choked")
        return segment_depth(depth_m, intrinsics, transform, params)

    mapped = []
    with pytest.raises(FogsimError, match="frame 3: the segmentation choked"):
        run_frames(
            frames,
            None,
            None,
            segment=failing,
            segment_process=True,
            on_frame=lambda f, p: mapped.append(f.index),
        )
    assert mapped == [0, 1, 2]
    assert not calls  # segmented in the child, not here
    assert not children()


def test_an_unpicklable_error_travels_as_its_text(frames):
    class LocalError(Exception):  # a local class does not pickle
        pass

    def failing(frame):
        raise LocalError("no pickle for me")

    with SegmentInProcess(frames[:2], failing) as ahead:
        ahead.start()
        frame = next(iter(ahead))
        with pytest.raises(FogsimError, match="LocalError: no pickle for me"):
            ahead.segmented(frame)
    assert not children()


def test_an_interrupt_in_the_consumer_stops_the_child(frames, forks):
    def interrupt(frame, pipeline):
        if frame.index == 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_frames(frames, None, None, segment_process=True, on_frame=interrupt)
    assert not children()


def test_a_child_that_dies_is_an_error(frames):
    def dying(frame):
        import os

        os._exit(3)

    with SegmentInProcess(frames, dying) as ahead:
        ahead.start()
        with pytest.raises(FogsimError, match="ended without a word \\(exit status 3\\)"):
            next(iter(ahead))
    assert not children()


def test_refuses_another_frame_a_second_ask_and_bad_use(frames):
    with pytest.raises(FogsimError, match="ahead must be >= 1 frame, got 0"):
        SegmentInProcess(frames, FrameSegmenter(RunParams()), ahead=0)
    with SegmentInProcess(frames[:3], FrameSegmenter(RunParams())) as ahead:
        with pytest.raises(FogsimError, match="start"):
            next(iter(ahead))
        ahead.start()
        with pytest.raises(FogsimError, match="already started"):
            ahead.start()
        assert_refuses_another_frame_and_a_second_ask(ahead, frames)
        assert ahead.also(frames[2]) is None  # no `also` callable (and another frame)
    ahead.close()  # idempotent


def test_a_recordings_frames_are_built_here_from_the_childs_depth(frames, tmp_path, forks):
    """A recording's frames come out equal to its own, depth included, read once by the child."""
    recorded = load_recording(save_recording(tmp_path / "walk.npz", frames)).frames
    mapped = []
    with SegmentInProcess(recorded, FrameSegmenter(RunParams())) as ahead:
        ahead.start()
        for frame, own in zip(ahead, recorded, strict=True):
            assert ahead.segmented(frame) is not None
            for field in dataclasses.fields(own):
                a, b = getattr(frame, field.name), getattr(own, field.name)
                if isinstance(a, np.ndarray):
                    np.testing.assert_array_equal(a, b, strict=True)
                else:
                    assert a == b, field.name
            mapped.append(frame.index)
    assert mapped == list(range(len(frames)))
    results = {
        name: run_frames(recorded, None, None, segment_ahead=ahead, segment_process=ahead)
        for name, ahead in (("inline", False), ("process", True))
    }
    np.testing.assert_array_equal(
        results["inline"].archive.fog_types, results["process"].archive.fog_types, strict=True
    )
    assert not children()


def test_no_fork_beside_another_thread():
    """A thread of this process running: the run segments on a thread instead (no fork)."""
    release = threading.Event()
    waiting = threading.Thread(target=release.wait)
    waiting.start()
    try:
        assert not can_segment_in_process()
    finally:
        release.set()
        waiting.join()
