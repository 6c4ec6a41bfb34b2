"""The simulation on a second thread: the same frames and maps as in line, bounded, errors raised
with their message, stopped cleanly."""

from __future__ import annotations

import itertools
import threading
import time

import numpy as np
import pytest
from test_simulation import assert_frames_identical

from fogsim.config import load_scenario
from fogsim.data.recording import Recording
from fogsim.errors import FogsimError
from fogsim.run.runner import run_scenario
from fogsim.sim import simulation
from fogsim.sim.background import (
    AHEAD_BYTES,
    AHEAD_BYTES_PER_PIXEL,
    AHEAD_FRAMES,
    MAX_AHEAD_FRAMES,
    BackgroundSimulation,
    frames_ahead,
)
from fogsim.sim.simulation import Simulation

FRAMES = 12
"""Frames of the flat floor walk each test takes (the walk's first second)."""


@pytest.fixture(scope="module")
def scenario():
    return load_scenario("flat_floor")


@pytest.fixture(scope="module")
def inline_frames(scenario):
    with Simulation(scenario) as inline:
        return list(itertools.islice(inline.frames(), FRAMES))


def simulation_threads() -> list[threading.Thread]:
    return [t for t in threading.enumerate() if t.name == "fogsim-simulation"]


def test_same_frames_bit_for_bit_as_the_simulation_in_line(scenario, inline_frames):
    with BackgroundSimulation(lambda: Simulation(scenario), max_frames=FRAMES) as source:
        assert source.frame_count == FRAMES
        assert_frames_identical(inline_frames, list(source))
    assert not simulation_threads()


def test_same_maps_bit_for_bit_with_and_without_overlap(scenario, inline_frames, tmp_path):
    """maps.npz of a run simulating in the background = of the same frames fed in line."""
    with Simulation(scenario) as inline:
        truths = tuple(inline.truth_at(frame.time_s) for frame in inline_frames)
    recording = Recording(inline_frames, scenario, truths, inline_frames[0].intrinsics)
    run_scenario(scenario, tmp_path / "overlap", pictures=False, max_frames=FRAMES)
    run_scenario(scenario, tmp_path / "inline", replay=recording, pictures=False)
    with (
        np.load(tmp_path / "overlap" / "maps.npz") as overlap,
        np.load(tmp_path / "inline" / "maps.npz") as inline_maps,
    ):
        assert sorted(overlap.files) == sorted(inline_maps.files)
        for name in overlap.files:
            np.testing.assert_array_equal(overlap[name], inline_maps[name], err_msg=name)


def test_runs_at_most_ahead_frames_ahead_and_stops_when_closed(scenario):
    source = BackgroundSimulation(lambda: Simulation(scenario), max_frames=FRAMES)
    deadline = time.monotonic() + 60.0
    while source._handoff.qsize() < AHEAD_FRAMES and time.monotonic() < deadline:
        time.sleep(0.05)
    time.sleep(0.3)  # room for a frame too many, were the queue unbounded
    assert source._handoff.qsize() == AHEAD_FRAMES
    assert simulation_threads()
    source.close()
    assert not simulation_threads()
    source.close()  # idempotent


def test_runs_as_many_frames_ahead_as_it_is_given(scenario):
    ahead = 7
    with BackgroundSimulation(
        lambda: Simulation(scenario), max_frames=FRAMES, ahead=ahead
    ) as source:
        deadline = time.monotonic() + 60.0
        while source._handoff.qsize() < ahead and time.monotonic() < deadline:
            time.sleep(0.05)
        time.sleep(0.3)
        assert source._handoff.qsize() == ahead


def test_ahead_below_one_frame_is_refused(scenario):
    with pytest.raises(FogsimError, match="ahead must be >= 1 frame, got 0"):
        BackgroundSimulation(lambda: Simulation(scenario), ahead=0)
    assert not simulation_threads()


@pytest.mark.parametrize(
    ("pixels", "frames"),
    [
        (88 * 72, 32),  # 24 MiB / (88 B * 6336) = 45: capped at 32
        (176 * 144, 11),  # 25165824 // 2230272 = 11
        (640 * 480, 4),  # 0 fit: the floor of 4
        (AHEAD_BYTES // (AHEAD_BYTES_PER_PIXEL * 20), 20),
        (0, MAX_AHEAD_FRAMES),
    ],
)
def test_frames_ahead_fill_the_memory_budget_between_the_bounds(pixels, frames):
    assert frames_ahead(pixels) == frames
    assert AHEAD_FRAMES <= frames_ahead(pixels) <= MAX_AHEAD_FRAMES


def test_an_error_in_a_frame_is_raised_with_its_message(scenario, monkeypatch):
    original = Simulation.frames

    def failing_frames(self):
        for frame in original(self):
            if frame.index == 3:
                raise FogsimError("frame 3: the head camera fell off")
            yield frame

    monkeypatch.setattr(simulation.Simulation, "frames", failing_frames)
    with BackgroundSimulation(lambda: Simulation(scenario), max_frames=FRAMES) as source:
        seen = []
        with pytest.raises(FogsimError, match="frame 3: the head camera fell off") as raised:
            seen.extend(frame.index for frame in source)
    assert seen == [0, 1, 2]
    assert "failing_frames" in {entry.name for entry in raised.traceback}  # the thread's
    assert not simulation_threads()


def test_an_error_in_the_set_up_is_raised_by_frame_count_and_iteration(scenario, monkeypatch):
    def failing_init(self, scenario, *, depth_backend="renderer"):
        raise FogsimError("robot model 'r2d2' not found")

    monkeypatch.setattr(simulation.Simulation, "__init__", failing_init)
    source = BackgroundSimulation(lambda: Simulation(scenario))
    with pytest.raises(FogsimError, match="r2d2"):
        source.frame_count  # noqa: B018 (the property raises)
    with pytest.raises(FogsimError, match="r2d2"):
        list(source)
    source.close()
    assert not simulation_threads()
