"""A simulation stepped on a second thread, a few frames ahead of the code that maps them.

``fogsim run`` spends about as long simulating a frame (posing the robot, rendering depth, the
stereo error model, the encoders and the self-filter) as mapping it.
:class:`BackgroundSimulation` builds and steps the :class:`~fogsim.sim.simulation.Simulation` on
its own thread and hands frames over through a queue of at most ``ahead`` frames
(:func:`frames_ahead`), so frame k + 1 is simulated while frame k is mapped. What runs in
parallel is what releases Python's GIL: MuJoCo's rendering and kinematics and numpy's array
work; numba kernels compiled without ``nogil`` take turns.

The simulation in a forked process instead (session 53, a ``SimulationProcess`` with this
class's interface: the child built and stepped the simulation and sent each pickled frame
through a pipe, the truth answered here from the scenario; the same maps bit for bit) was
measured and not kept: ``fogsim run stage``, `bench/bench_run.py --tree A --tree B`, 5
interleaved repeats, AMD EPYC 2 cores, load 1.0-1.6, 4.96 -> 4.80 s wall median (min 4.57 ->
4.47), the main thread's CPU 3.02 -> 2.74 s. On two cores the run is bound by its CPU time in
all (the simulation 1.6-1.8 s beside the mapping's 2.7-3.0 and the segmentation's 1.5-1.6),
not by the GIL, so a process takes off little; and a child that makes an OpenGL context after
a fork is safe only where this process made none before (not so in a test process that has
rendered).

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
import queue
import threading
from collections.abc import Callable, Iterator
from concurrent.futures import Future
from dataclasses import dataclass
from typing import Protocol

from fogsim.data.frame import Frame
from fogsim.errors import FogsimError
from fogsim.world import SceneTruth

AHEAD_FRAMES = 4
"""Fewest frames a stage of a run (this simulation, the segmentation ahead of the mapping) may
work ahead of the next: enough to carry it over a slow frame on either side (a first z-match,
a frame with many planes: 3-5 times the median), and what frames too big for
:data:`AHEAD_BYTES` get (:func:`frames_ahead`)."""

MAX_AHEAD_FRAMES = 32
"""Most frames a stage may work ahead (:func:`frames_ahead`): the mapping stops for tens of
milliseconds now and then (the heading's refinement: 3 frames of about 65 ms in a stage run,
its estimates: 12 of about 10 ms), while the other stages make a frame in 1-2 ms; with 4 frames
of room they stood still through those stops. Stage, interleaved, 3-4 repeats each, in-process
wall of the run (AMD EPYC, load about 1.5): ``fogsim run stage`` 3.87 -> 3.72 s with 32 frames
ahead for the simulation and the segmentation (3.72 / 3.76 s with either alone), the replay's
(segmentation process) 2.69 -> 2.52 s."""

AHEAD_BYTES = 24 * 2**20
"""Memory the frames a stage works ahead may take [bytes] (:func:`frames_ahead`)."""

AHEAD_BYTES_PER_PIXEL = 88
"""A frame's size per depth pixel as :func:`frames_ahead` counts it [bytes]: the largest of the
stages' (the segmentation process's slot, `fogsim.mapping.segment_process`; a segmented frame
on the thread takes about 57, a simulated frame about 5)."""


def frames_ahead(pixels: int) -> int:
    """Frames a stage of a run may work ahead of the next, for frames of ``pixels`` pixels.

    As many as :data:`AHEAD_BYTES` hold at :data:`AHEAD_BYTES_PER_PIXEL`, between
    :data:`AHEAD_FRAMES` and :data:`MAX_AHEAD_FRAMES`: 32 at 88 × 72, 11 at 176 × 144, 4 at
    640 × 480.
    """
    fits = AHEAD_BYTES // (AHEAD_BYTES_PER_PIXEL * max(int(pixels), 1))
    return max(AHEAD_FRAMES, min(MAX_AHEAD_FRAMES, fits))


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
    """The producer's exception, queued in place of an item."""

    error: BaseException


_END = object()
"""Queued after the last item."""


class HandOff:
    """A bounded queue from a producer thread to its consumer, who can tell the producer to stop.

    The producer calls :meth:`put` for each item, then :meth:`finish` (or :meth:`fail` with its
    exception); the consumer iterates :meth:`items`.

    Args:
        size: Items that may wait for the consumer, >= 1.
    """

    def __init__(self, size: int) -> None:
        self._queue: queue.Queue[object] = queue.Queue(maxsize=size)
        self._stop = threading.Event()

    @property
    def stopped(self) -> bool:
        """The consumer told the producer to stop."""
        return self._stop.is_set()

    def put(self, item: object) -> bool:
        """Queue ``item`` once there is room (producer); False if told to stop first."""
        while not self._stop.is_set():
            try:
                self._queue.put(item, timeout=_POLL_S)
            except queue.Full:
                continue
            return True
        return False

    def finish(self) -> bool:
        """Mark the end of the items (producer); False if told to stop first."""
        return self.put(_END)

    def fail(self, error: BaseException) -> bool:
        """End the items with ``error`` (producer); False if told to stop first."""
        return self.put(_Failed(error))

    def items(self) -> Iterator[object]:
        """The items in order (consumer; waits for each); raises the producer's :meth:`fail`."""
        while True:
            item = self._queue.get()
            if item is _END:
                return
            if isinstance(item, _Failed):
                raise item.error
            yield item

    def qsize(self) -> int:
        """Items waiting now."""
        return self._queue.qsize()

    def close(self, producer: threading.Thread) -> None:
        """Tell ``producer`` to stop and wait for it, emptying the queue meanwhile; idempotent."""
        self._stop.set()
        while producer.is_alive():
            self._drain()
            producer.join(_POLL_S)
        self._drain()

    def _drain(self) -> None:
        """Empty the queue (a producer blocked on it gets its stop signal sooner)."""
        try:
            while True:
                self._queue.get_nowait()
        except queue.Empty:
            pass


class BackgroundSimulation:
    """The frames of a simulation, made on a second thread; iterate them once.

    Args:
        make_simulation: Builds the simulation (called on the simulation thread), e.g.
            ``lambda: Simulation(scenario)``.
        max_frames: Stop after this many frames; None = all of them.
        ahead: Frames the simulation may run ahead of the consumer, >= 1
            (:func:`frames_ahead` of the camera's image).

    Raises:
        FogsimError: ``ahead`` < 1.
    """

    def __init__(
        self,
        make_simulation: Callable[[], FrameSimulation],
        *,
        max_frames: int | None = None,
        ahead: int = AHEAD_FRAMES,
    ) -> None:
        if ahead < 1:
            raise FogsimError(f"BackgroundSimulation: ahead must be >= 1 frame, got {ahead!r}")
        self._make_simulation = make_simulation
        self._max_frames = max_frames
        self._simulation: Future[FrameSimulation] = Future()
        self._handoff = HandOff(ahead)
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
        try:
            for item in self._handoff.items():
                assert isinstance(item, Frame)
                yield item
        except BaseException:
            self.close()
            raise

    def close(self) -> None:
        """Stop the simulation thread, wait for it (it frees its renderer); idempotent."""
        self._handoff.close(self._thread)

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
            self._handoff.fail(error)
            return
        self._simulation.set_result(simulation)
        try:
            for frame in itertools.islice(simulation.frames(), self._max_frames):
                if not self._handoff.put(frame):
                    return
            self._handoff.finish()
        except BaseException as error:
            self._handoff.fail(error)
        finally:
            simulation.close()
