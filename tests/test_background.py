"""The simulation on a second thread and in a child process (forked and spawned): the same
frames and maps as in line, bounded, errors raised with their message (and the child's
traceback), a child that dies named, stopped cleanly."""

from __future__ import annotations

import functools
import itertools
import os
import pickle
import subprocess
import sys
import threading
import time
from pathlib import Path

import mujoco.egl
import numpy as np
import pytest
from test_simulation import assert_frames_identical

from fogsim.config import load_scenario
from fogsim.data.recording import Recording
from fogsim.errors import FogsimError
from fogsim.run.runner import run_scenario
from fogsim.sim import simulation
from fogsim.sim.background import (
    AHEAD_FRAMES,
    BackgroundSimulation,
    SimulationProcess,
    default_start_method,
)
from fogsim.sim.simulation import Simulation
from fogsim.world import SceneTruth

FRAMES = 12
"""Frames of the flat floor walk each test takes (the walk's first second)."""

ROOT = Path(__file__).resolve().parent.parent


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
    while source._queue.qsize() < AHEAD_FRAMES and time.monotonic() < deadline:
        time.sleep(0.05)
    time.sleep(0.3)  # room for a frame too many, were the queue unbounded
    assert source._queue.qsize() == AHEAD_FRAMES
    assert simulation_threads()
    source.close()
    assert not simulation_threads()
    source.close()  # idempotent


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


def _process(scenario, make=None, **kwargs) -> SimulationProcess:
    return SimulationProcess(
        make or functools.partial(Simulation, scenario),
        functools.partial(SceneTruth.from_scenario, scenario),
        **kwargs,
    )


def test_spawned_child_gives_the_frames_in_line_bit_for_bit(scenario, inline_frames):
    # This process has an EGL display open (the in-line simulation): the child is spawned.
    assert mujoco.egl.EGL_DISPLAY is not None
    assert default_start_method() == "spawn"
    with _process(scenario, max_frames=FRAMES) as source:
        assert source.frame_count == FRAMES
        assert_frames_identical(inline_frames, list(source))
        assert source._process.pid is not None
    assert not source._process.is_alive()


_FORKED = """
import functools, itertools, pickle, sys
from fogsim.config import load_scenario
from fogsim.sim.background import SimulationProcess, default_start_method
from fogsim.sim.simulation import Simulation
from fogsim.world import SceneTruth

scenario = load_scenario("flat_floor")
method = default_start_method()
with SimulationProcess(
    functools.partial(Simulation, scenario),
    functools.partial(SceneTruth.from_scenario, scenario),
    max_frames=int(sys.argv[1]),
) as source:
    frames = list(source)
sys.stdout.buffer.write(pickle.dumps((method, frames)))
"""


def test_forked_child_gives_the_frames_in_line_bit_for_bit(inline_frames):
    """A process without an OpenGL display forks its child: the same frames."""
    env = {**os.environ, "PYTHONPATH": str(ROOT), "MUJOCO_GL": "egl"}
    done = subprocess.run(
        [sys.executable, "-c", _FORKED, str(FRAMES)], env=env, capture_output=True, check=True
    )
    method, frames = pickle.loads(done.stdout)
    assert method == "fork"
    assert_frames_identical(inline_frames, frames)


def test_start_method_is_fork_only_before_an_egl_display_with_egl(monkeypatch):
    monkeypatch.setattr(mujoco.egl, "EGL_DISPLAY", None)
    monkeypatch.setenv("MUJOCO_GL", "egl")
    assert default_start_method() == "fork"
    monkeypatch.setenv("MUJOCO_GL", "osmesa")
    assert default_start_method() == "spawn"
    monkeypatch.setenv("MUJOCO_GL", "egl")
    monkeypatch.setattr(mujoco.egl, "EGL_DISPLAY", object())
    assert default_start_method() == "spawn"


def test_process_runs_at_most_ahead_frames_ahead_and_stops_when_closed(scenario):
    source = _process(scenario, max_frames=FRAMES)
    assert source.frame_count == FRAMES
    deadline = time.monotonic() + 60.0
    while source._queue.qsize() < AHEAD_FRAMES and time.monotonic() < deadline:
        time.sleep(0.05)
    time.sleep(0.3)  # room for a frame too many, were the queue unbounded
    assert source._queue.qsize() == AHEAD_FRAMES
    assert source._process.is_alive()
    source.close()
    assert not source._process.is_alive()
    source.close()  # idempotent


class _FailingFrames:
    """A simulation (picklable, spawned) whose frame 3 raises."""

    def __init__(self, scenario):
        self.simulation = Simulation(scenario)
        self.frame_count = self.simulation.frame_count

    def frames(self):
        for frame in self.simulation.frames():
            if frame.index == 3:
                raise FogsimError("frame 3: the head camera fell off")
            yield frame

    def close(self):
        self.simulation.close()


def test_an_error_in_a_frame_is_raised_with_the_childs_traceback(scenario):
    with _process(scenario, functools.partial(_FailingFrames, scenario)) as source:
        seen = []
        with pytest.raises(FogsimError, match="frame 3: the head camera fell off") as raised:
            seen.extend(frame.index for frame in source)
    assert seen == [0, 1, 2]
    (note,) = raised.value.__notes__
    assert note.startswith("in the simulation process:") and "in frames" in note
    assert not source._process.is_alive()


def _no_robot(scenario):
    raise FogsimError("robot model 'r2d2' not found")


class _UnpicklableError(Exception):
    def __reduce__(self):
        raise TypeError("not picklable")


def _unpicklable(scenario):
    raise _UnpicklableError("a lock in the exception")


def _dies(scenario):
    os._exit(3)


def test_process_an_error_in_the_set_up_is_raised_by_frame_count_and_iteration(scenario):
    source = _process(scenario, functools.partial(_no_robot, scenario))
    with pytest.raises(FogsimError, match="r2d2"):
        source.frame_count  # noqa: B018 (the property raises)
    source.close()
    source = _process(scenario, functools.partial(_no_robot, scenario))
    with pytest.raises(FogsimError, match="r2d2"):
        list(source)
    source.close()


def test_an_exception_that_does_not_pickle_comes_as_its_name_and_message(scenario):
    with (
        _process(scenario, functools.partial(_unpicklable, scenario)) as source,
        pytest.raises(RuntimeError, match=r"^_UnpicklableError: a lock in the exception\n"),
    ):
        source.frame_count  # noqa: B018 (the property raises)


def test_a_child_that_dies_without_a_word_is_an_error_naming_its_exit_status(scenario):
    with (
        _process(scenario, functools.partial(_dies, scenario)) as source,
        pytest.raises(FogsimError, match=r"ended without its frames \(exit status 3\)"),
    ):
        list(source)
