"""A simulation stepped beside the code that maps its frames, a few frames ahead of it.

:class:`SimulationProcess` (what ``fogsim run`` uses) steps it in a child process: nothing is
shared with the mapping, not even Python's GIL. :class:`BackgroundSimulation` (``fogsim run
--video``, whose third-person pictures are taken from the simulation's own renderer) steps it
on a second thread; what follows is about that thread.

``fogsim run`` spends about as long simulating a frame (posing the robot, rendering depth, the
stereo error model, the encoders and the self-filter) as mapping it. :class:`BackgroundSimulation`
builds and steps the :class:`~fogsim.sim.simulation.Simulation` on its own thread and hands
frames over through a queue of at most :data:`AHEAD_FRAMES`, so frame k + 1 is simulated while
frame k is mapped. What runs in parallel is what releases Python's GIL: MuJoCo's rendering and
kinematics and numpy's array work; numba kernels compiled without ``nogil`` take turns.

Everything of the simulation stays on its thread: an OpenGL (EGL) context is current in one
thread only, so the renderer is created, used and freed there, and the MuJoCo state is never
read from outside. The frames are the ones :meth:`Simulation.frames` yields, in the same order,
bit for bit: nothing random depends on timing.

Errors: an exception of the set-up or of a frame is raised again, the same object with the
simulation thread's traceback, by whichever of :attr:`BackgroundSimulation.frame_count` or the
iteration meets it first. Stopping: :meth:`BackgroundSimulation.close` (also on Ctrl-C in the
consumer, through ``with``) tells the thread to stop at its next frame, waits for it and frees
the renderer; the thread is a daemon, so a process that ends without closing is not held.
"""

from __future__ import annotations

import itertools
import multiprocessing
import os
import pickle
import queue
import sys
import threading
import traceback
from collections.abc import Callable, Iterator
from concurrent.futures import Future
from dataclasses import dataclass
from typing import NoReturn, Protocol

from fogsim.data.frame import Frame
from fogsim.errors import FogsimError
from fogsim.world import SceneTruth

AHEAD_FRAMES = 4
"""Frames the simulation may run ahead of the consumer: enough to carry it over a slow frame
on either side (a first z-match, a frame with many planes: 3-5 times the median), few enough
to bound the memory (a stage frame is ~30 KB) and the work thrown away when a run stops."""

_POLL_S = 0.05
"""How often a simulation thread blocked on a full queue checks whether it should stop [s]."""


class FrameSimulation(Protocol):
    """What :class:`BackgroundSimulation` uses of a :class:`~fogsim.sim.simulation.Simulation`."""

    @property
    def frame_count(self) -> int:
        """Frames :meth:`frames` yields."""
        ...

    def frames(self) -> Iterator[Frame]:
        """The frames in order."""
        ...

    def truth_at(self, time_s: float) -> SceneTruth:
        """Ground truth at ``time_s``; called from other threads (a function of the scenario)."""
        ...

    def close(self) -> None:
        """Free what the simulation holds (its renderer)."""
        ...


@dataclass(frozen=True)
class _Failed:
    """The simulation thread's exception, queued in place of a frame."""

    error: BaseException


_END = object()
"""Queued after the last frame."""


class BackgroundSimulation:
    """The frames of a simulation, made on a second thread; iterate them once.

    Args:
        make_simulation: Builds the simulation (called on the simulation thread), e.g.
            ``lambda: Simulation(scenario)``.
        max_frames: Stop after this many frames; None = all of them.
    """

    def __init__(
        self, make_simulation: Callable[[], FrameSimulation], *, max_frames: int | None = None
    ) -> None:
        self._make_simulation = make_simulation
        self._max_frames = max_frames
        self._simulation: Future[FrameSimulation] = Future()
        self._queue: queue.Queue[object] = queue.Queue(maxsize=AHEAD_FRAMES)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="fogsim-simulation", daemon=True)
        self._thread.start()

    @property
    def frame_count(self) -> int:
        """Frames the iteration yields (waits for the set-up; raises its error)."""
        count = self._simulation.result().frame_count
        return count if self._max_frames is None else min(count, self._max_frames)

    @property
    def simulation(self) -> FrameSimulation:
        """The simulation (waits for the set-up; raises its error).

        Its state belongs to the simulation thread: use only what is safe from another one.
        """
        return self._simulation.result()

    def truth_at(self, time_s: float) -> SceneTruth:
        """The simulation's ground truth at ``time_s`` [s] (waits for the set-up)."""
        return self._simulation.result().truth_at(time_s)

    def __iter__(self) -> Iterator[Frame]:
        """The frames in order; raises the simulation thread's exception where it happened."""
        while True:
            item = self._queue.get()
            if item is _END:
                return
            if isinstance(item, _Failed):
                self.close()
                raise item.error
            assert isinstance(item, Frame)
            yield item

    def close(self) -> None:
        """Stop the simulation thread, wait for it (it frees its renderer); idempotent."""
        self._stop.set()
        while self._thread.is_alive():
            self._drain()
            self._thread.join(_POLL_S)

    def __enter__(self) -> BackgroundSimulation:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ------------------------------------------------------------------ the simulation thread

    def _run(self) -> None:
        try:
            simulation = self._make_simulation()
        except BaseException as error:
            self._simulation.set_exception(error)
            self._put(_Failed(error))
            return
        self._simulation.set_result(simulation)
        try:
            for frame in itertools.islice(simulation.frames(), self._max_frames):
                if not self._put(frame):
                    return
            self._put(_END)
        except BaseException as error:
            self._put(_Failed(error))
        finally:
            simulation.close()

    def _put(self, item: object) -> bool:
        """Queue ``item`` once there is room; False if told to stop first."""
        while not self._stop.is_set():
            try:
                self._queue.put(item, timeout=_POLL_S)
            except queue.Full:
                continue
            return True
        return False

    def _drain(self) -> None:
        """Empty the queue (a stopping thread blocked on it gets its stop signal sooner)."""
        try:
            while True:
                self._queue.get_nowait()
        except queue.Empty:
            pass


def default_start_method() -> str:
    """``fork`` while this process has no OpenGL display, else ``spawn``.

    A forked child has this process's modules already imported (the stage's set-up starts at
    once instead of after ~0.6 s CPU of imports) but also a copy of its OpenGL driver state
    without the driver's threads: only safe before MuJoCo's EGL backend opened its display
    (``mujoco.egl.EGL_DISPLAY``, once per process, when the first renderer is made). With
    another backend (``MUJOCO_GL``) or a display already open, the child is spawned.
    """
    egl = sys.modules.get("mujoco.egl")
    no_display = egl is not None and getattr(egl, "EGL_DISPLAY", None) is None
    fresh = os.environ.get("MUJOCO_GL") == "egl" and no_display
    return "fork" if fresh and "fork" in multiprocessing.get_all_start_methods() else "spawn"


_COUNT = "count"
"""Tag of the simulation process's first message: its frame count after the set-up."""


@dataclass(frozen=True)
class ChildFailure:
    """A child process's exception (pickled) and its traceback as text, sent to its parent.

    Attributes:
        error: The pickled exception; one that does not pickle is sent as a RuntimeError
            with its type's name and its message.
        traceback: The child's traceback.
    """

    error: bytes
    traceback: str

    @classmethod
    def of(cls, error: BaseException) -> ChildFailure:
        """``error`` as the child sends it."""
        text = "".join(traceback.format_exception(error))
        try:
            pickled = pickle.dumps(error)
            pickle.loads(pickled)
        except Exception:
            pickled = pickle.dumps(RuntimeError(f"{type(error).__name__}: {error}"))
        return cls(pickled, text)

    def reraise(self, where: str) -> NoReturn:
        """Raise the exception here, with the child's traceback as a note naming ``where``."""
        error = pickle.loads(self.error)
        error.add_note(f"in {where}:\n{self.traceback}")
        raise error


class SimulationProcess:
    """The frames of a simulation, made in a child process; iterate them once.

    The same frames as :class:`BackgroundSimulation`, bit for bit, made beside the mapping
    without sharing Python's GIL with it: on a thread the simulation's Python work and the
    mapping's numba kernels take turns, in a process they run at once on two cores. Frames
    (~30 KB on the stage) come through a pipe, at most :data:`AHEAD_FRAMES` ahead.

    The child is forked when that is safe (:func:`default_start_method`: it then costs no
    imports), else spawned; ``make_simulation`` must be picklable for a spawned child (e.g.
    :func:`functools.partial` of the :class:`~fogsim.sim.simulation.Simulation` class), and a
    script that runs one must guard its work with ``if __name__ == "__main__"`` (a spawned
    child imports the main module). The ground truth is computed here by
    ``truth_at`` (it is a function of the scenario, not of the simulation's state).

    Errors: an exception of the set-up or of a frame is raised again here, by whichever of
    :attr:`frame_count` or the iteration meets it first, with the child's traceback added as
    a note. Stopping: :meth:`close` (also through ``with``) tells the child to stop at its next
    frame and waits for it (it frees its renderer).

    Args:
        make_simulation: Builds the simulation (called in the child).
        truth_at: The ground truth at a time [s].
        max_frames: Stop after this many frames; None = all of them.
        start_method: ``multiprocessing`` start method of the child; None =
            :func:`default_start_method`.
    """

    def __init__(
        self,
        make_simulation: Callable[[], FrameSimulation],
        truth_at: Callable[[float], SceneTruth],
        *,
        max_frames: int | None = None,
        start_method: str | None = None,
    ) -> None:
        context = multiprocessing.get_context(start_method or default_start_method())
        self.truth_at = truth_at
        self._max_frames = max_frames
        self._count: int | None = None
        self._queue = context.Queue(maxsize=AHEAD_FRAMES)
        self._stop = context.Event()
        self._process = context.Process(
            target=_simulate_into,
            args=(make_simulation, max_frames, self._queue, self._stop),
            name="fogsim-simulation",
            daemon=True,
        )
        self._process.start()

    @property
    def frame_count(self) -> int:
        """Frames the iteration yields (waits for the set-up; raises its error)."""
        if self._count is None:
            message = self._get()
            assert isinstance(message, tuple) and message[0] == _COUNT
            count = int(message[1])
            self._count = count if self._max_frames is None else min(count, self._max_frames)
        return self._count

    def __iter__(self) -> Iterator[Frame]:
        """The frames in order; raises the simulation's exception where it happened."""
        self.frame_count  # noqa: B018 (the set-up's message comes first)
        while True:
            item = self._get()
            if item is None:
                return
            assert isinstance(item, Frame)
            yield item

    def _get(self) -> object:
        """The child's next message; its exception raised (the child stopped).

        Raises:
            FogsimError: The child ended without a message (killed, or crashed in native code).
        """
        while True:
            try:
                item = self._queue.get(timeout=_POLL_S)
                break
            except queue.Empty:
                if self._process.is_alive():
                    continue
            try:  # it may have sent its last message just before it ended
                item = self._queue.get(timeout=_POLL_S)
                break
            except queue.Empty:
                raise FogsimError(
                    "the simulation process ended without its frames "
                    f"(exit status {self._process.exitcode})"
                ) from None
        if isinstance(item, ChildFailure):
            self.close()
            item.reraise("the simulation process")
        return item

    def close(self) -> None:
        """Stop the child, wait for it (it frees its renderer); idempotent."""
        self._stop.set()
        while self._process.is_alive():
            try:
                while True:
                    self._queue.get_nowait()
            except queue.Empty:
                pass
            self._process.join(_POLL_S)

    def __enter__(self) -> SimulationProcess:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _simulate_into(
    make_simulation: Callable[[], FrameSimulation],
    max_frames: int | None,
    frames: multiprocessing.Queue,
    stop: threading.Event,
) -> None:
    """The simulation process: its frame count, its frames and None at the end, into ``frames``.

    An exception is sent in place of the next message (:class:`ChildFailure`).
    """

    def put(item: object) -> bool:
        while not stop.is_set():
            try:
                frames.put(item, timeout=_POLL_S)
            except queue.Full:
                continue
            return True
        frames.cancel_join_thread()  # nobody reads what is left: exit without flushing it
        return False

    try:
        simulation = make_simulation()
    except BaseException as error:
        put(ChildFailure.of(error))
        return
    try:
        if not put((_COUNT, simulation.frame_count)):
            return
        for frame in itertools.islice(simulation.frames(), max_frames):
            if not put(frame):
                return
        put(None)
    except BaseException as error:
        put(ChildFailure.of(error))
    finally:
        simulation.close()
