"""A recording's frames segmented in a forked process ahead of the pipeline that maps them.

:class:`~fogsim.mapping.prefetch.SegmentAhead` segments on a second thread; both threads then
share Python's GIL: in a stage replay (832 frames, Intel Xeon 2 cores, session 36) the mapping
takes 1.22 s of CPU time alone (the frames segmented before) but 1.35 s beside the thread.
:class:`SegmentInProcess` forks a process that runs the segmenter on every frame in order (the
frames are the forked copy of this process's, nothing is sent to it) and sends back each
result: the two halves then run on two cores without a shared GIL. The frame loop (in one
process, 5 interleaved repeats each, medians, load 2.2-3.0, run at nice -10 in an autogroup of
its own): stage 1.68 -> 1.45 s, room 1.00 -> 0.94 s, stage_down 2.24 -> 2.00 s, the same CPU
time. ``fogsim run --replay`` (``bench/bench_run.py --no-run``, interleaved, load about 2): the
stage 2.79 -> 2.53 s wall (7 repeats), room 2.35 -> 2.25 s, stage_down 3.40 -> 3.12 s (4);
on a machine whose cores are busy (two busy loops beside it) the same: 4.60 and 4.66 s, CPU
4.06 and 4.29 s. The results are the segmenter's bit for bit (the same code on the same frames
in the same order; pickling keeps every array's bytes).

Fork it only where a fork is safe: this process has no other thread (a forked child has only
the thread that forked; one holding a lock there would hold it for ever), and the frames are
a sequence known before the run (a recording; a simulation makes its frames on its own thread
in this process). :func:`can_segment_in_process` says whether it can. The frames must pickle
nothing: only the results and exceptions travel.

Errors: the segmentation's exception for frame k is raised when the pipeline asks for frame
k's segmentation (pickled; one that does not pickle is raised as a :class:`FogsimError` with
its text). A child that ends without a word raises :class:`FogsimError`. Stopping:
:meth:`SegmentInProcess.close` (``with``) kills the child if it still runs and waits for it.
"""

from __future__ import annotations

import mmap
import multiprocessing
import os
import pickle
import signal
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from fogsim.data.frame import Frame
from fogsim.data.frames import RecordedFrames
from fogsim.errors import FogsimError
from fogsim.mapping.segmenter import Segmented
from fogsim.sim.background import AHEAD_FRAMES
from mapper.segmentation import SegmentationResult

_POLL_S = 0.5
"""How often the pipeline, waiting for a frame's result, checks that the child still runs [s]."""

_SLOT_BYTES_PER_PIXEL = 88
"""Room a frame's message takes in the shared memory per depth pixel [bytes]: its arrays (the
result's per-point arrays: 48 bytes a valid pixel; the world points of the cells in view: 24 a
pixel; the depth image: 4 a pixel; the small tables) with room to spare. A message that does
not fit is sent through the pipe whole."""

_SLOT_SPARE_BYTES = 1 << 16
"""Room added to every slot for the small arrays (planes, floors, transforms) [bytes]."""


@dataclass(frozen=True)
class _Outcome:
    """A frame's segmentation as the child sends it: the result or the exception raised.

    Also what the ``also`` callable gave, and a recording's depth image of the frame (the
    frame is built in this process from it and the recording's columns: reading the image from
    the file again took 0.07 s of the mapping thread's CPU time in a stage replay).
    """

    result: SegmentationResult | None
    error: BaseException | None
    segmentation_ms: float
    also: object = None
    depth_m: NDArray[np.float32] | None = None


def can_segment_in_process() -> bool:
    """Whether :class:`SegmentInProcess` may fork now.

    It may when ``fork`` exists (not on Windows), no other thread of this process runs, and
    this process is no ``multiprocessing`` daemon (a daemon may have no children: a worker of
    ``multiprocessing.Pool``).
    """
    return (
        "fork" in multiprocessing.get_all_start_methods()
        and threading.active_count() == 1
        and not multiprocessing.current_process().daemon
    )


class SegmentInProcess:
    """Iterate frames whose segmentation a forked process made ahead; iterate once.

    The interface of :class:`~fogsim.mapping.prefetch.SegmentAhead`: ``with
    SegmentInProcess(frames, FrameSegmenter(params)) as ahead``, build the pipeline of the same
    ``params`` with ``segmented=ahead.segmented``, :meth:`start`, then iterate ``ahead`` and
    hand each frame to the pipeline.

    A frame's message (its outcome, pickled with protocol 5) leaves its arrays' bytes in a slot
    of a memory shared with the child, created before the fork (``ahead`` + 1 slots, handed out
    by a semaphore: the child takes one before it writes a frame's bytes, this process gives it
    back once it copied them out); a pipe carries the rest, a few kilobytes. This process copies
    the bytes out of the slot once (the arrays are built on the copies). Sent whole through a
    ``multiprocessing`` queue, pipe and pickling took 0.33 s of the mapping thread's CPU time in
    a stage replay (832 frames), 0.4 ms a frame; through the slots and the queue 0.04 s.

    Args:
        frames: The frames in order (a recording's: a sequence this process holds).
        segmenter: Called with each frame in order, in the child
            (:class:`~fogsim.mapping.segmenter.FrameSegmenter`).
        ahead: Segmented frames that may wait for the pipeline, >= 1.
        also: Called with each frame in the child too, after its segmentation (a run: the
            frame's world points for the cells in view); :meth:`also` hands it out. None:
            nothing.

    Raises:
        FogsimError: ``ahead`` < 1.

    Attributes:
        segmentation_ms: The segmentation time [ms] of the frame last handed out (measured in
            the child).
    """

    def __init__(
        self,
        frames: Sequence[Frame],
        segmenter: Segmented,
        *,
        ahead: int = AHEAD_FRAMES,
        also: Callable[[Frame], object] | None = None,
    ) -> None:
        if ahead < 1:
            raise FogsimError(f"SegmentInProcess: ahead must be >= 1 frame, got {ahead!r}")
        self._frames = frames
        self._segmenter = segmenter
        self._also = also
        pixels = int(np.asarray(frames[0].depth_m).size) if len(frames) else 0
        self._slot_bytes = _SLOT_BYTES_PER_PIXEL * pixels + _SLOT_SPARE_BYTES
        self._slots = ahead + 1
        self._shared = mmap.mmap(-1, self._slots * self._slot_bytes)  # shared with the fork
        context = multiprocessing.get_context("fork")
        self._free = context.Semaphore(self._slots)  # slots the child may write
        self._reader, self._writer = context.Pipe(duplex=False)
        self._process = context.Process(
            target=self._serve, args=(os.getpid(),), name="fogsim-segment-process", daemon=True
        )
        self._started = False
        self._current: Frame | None = None  # the frame just iterated, until `segmented`
        self._last: tuple[Frame, _Outcome] | None = None  # the frame just iterated, its outcome
        self.segmentation_ms = float("nan")

    def start(self) -> None:
        """Fork the child; it starts segmenting.

        Raises:
            FogsimError: Already started.
        """
        if self._started:
            raise FogsimError("SegmentInProcess.start: already started")
        self._started = True
        self._process.start()

    def __iter__(self) -> Iterator[Frame]:
        """The frames in order, each once its segmentation has come."""
        if not self._started:
            raise FogsimError("SegmentInProcess: start() it before iterating")
        frames = self._frames
        for position in range(len(frames)):
            outcome = self._unpack(position, self._receive())
            if isinstance(frames, RecordedFrames):  # the child's depth image, not read again
                assert outcome.depth_m is not None
                frame = frames.columns.frame(frames.rows[position], outcome.depth_m)
            else:
                frame = frames[position]
            self._current, self._last = frame, (frame, outcome)
            yield frame

    def segmented(self, frame: Frame) -> SegmentationResult:
        """The segmentation of the frame just iterated (raises its exception).

        Raises:
            FogsimError: ``frame`` is not the frame just iterated (the same object), or its
                segmentation was already asked for.
        """
        current, self._current = self._current, None
        if current is None or self._last is None or frame is not current:
            raise FogsimError(
                "SegmentInProcess.segmented: called for another frame than the one just "
                "iterated; the pipeline must ask once for each frame it is handed"
            )
        outcome = self._last[1]
        self.segmentation_ms = outcome.segmentation_ms
        if outcome.error is not None:
            raise outcome.error
        assert outcome.result is not None
        return outcome.result

    def also(self, frame: Frame) -> object:
        """What the ``also`` callable gave for the frame just iterated (the child's copy).

        None for any other frame, without an ``also`` callable, or when it raised (the consumer
        then makes it itself, and meets the error where it would have without the child).
        """
        last = self._last
        return last[1].also if last is not None and frame is last[0] else None

    def close(self) -> None:
        """Stop the child if it still runs and wait for it; idempotent."""
        if self._started and self._process.is_alive():
            self._process.kill()
        if self._started:
            self._process.join()
        self._reader.close()
        self._writer.close()
        self._shared.close()

    def __enter__(self) -> SegmentInProcess:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _receive(self) -> tuple[bytes, list[int] | None]:
        """The child's next message; raises if it ended without one."""
        while not self._reader.poll(_POLL_S):
            if not self._process.is_alive() and not self._reader.poll():
                raise FogsimError(
                    "the segmentation process ended without a word (exit status "
                    f"{self._process.exitcode})"
                )
        message = self._reader.recv()
        assert isinstance(message, tuple)
        return message

    def _unpack(self, position: int, message: tuple[bytes, list[int] | None]) -> _Outcome:
        """The outcome of the frame at ``position`` from its message (arrays copied out)."""
        data, sizes = message
        if sizes is None:  # sent whole
            outcome = pickle.loads(data)
        else:
            offset = (position % self._slots) * self._slot_bytes
            buffers = []
            # Copied once, from a view of the slot (a slice of the mmap itself is a bytes copy,
            # copied again by bytearray: 0.49 → 0.20 ms for a frame's 0.4 MB, one process).
            # The view is released before the slot is given back and before `close`.
            with memoryview(self._shared) as shared:
                for size in sizes:
                    buffers.append(bytearray(shared[offset : offset + size]))
                    offset += size
            outcome = pickle.loads(data, buffers=buffers)
        self._free.release()  # its slot copied out: the child may write it again
        assert isinstance(outcome, _Outcome)
        return outcome

    # ------------------------------------------------------------------ the child

    def _serve(self, parent_pid: int) -> None:
        """The child: segment every frame and send it; end quietly when the parent has gone.

        Ctrl-C (sent to the terminal's whole process group) is the parent's to handle: it
        stops the child (:meth:`close`).
        """
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        self._reader.close()
        try:
            for position, frame in enumerate(self._frames):
                outcome = self._segment(frame)
                while not self._free.acquire(timeout=_POLL_S):  # a slot; ends with the parent
                    if os.getppid() != parent_pid:
                        return
                self._writer.send(self._pack(position, outcome))
        except BrokenPipeError:  # the parent closed its end: nobody to send to
            return
        finally:
            self._writer.close()

    def _pack(self, position: int, outcome: _Outcome) -> tuple[bytes, list[int] | None]:
        """The message of the frame at ``position``: its arrays' bytes go to its slot."""
        buffers: list[pickle.PickleBuffer] = []
        data = pickle.dumps(outcome, protocol=5, buffer_callback=buffers.append)
        views = [buffer.raw() for buffer in buffers]
        if sum(view.nbytes for view in views) > self._slot_bytes:  # too big: sent whole
            return pickle.dumps(outcome, protocol=5), None
        offset = (position % self._slots) * self._slot_bytes
        for view in views:
            self._shared[offset : offset + view.nbytes] = view
            offset += view.nbytes
        return data, [view.nbytes for view in views]

    def _segment(self, frame: Frame) -> _Outcome:
        """Segment ``frame``; its exception is kept for the pipeline's call (pickled)."""
        start = time.perf_counter()
        try:
            result = self._segmenter(frame)
        except Exception as error:  # raised again by `segmented` for this frame
            depth_m = frame.depth_m if isinstance(self._frames, RecordedFrames) else None
            elapsed_ms = 1000.0 * (time.perf_counter() - start)
            return _Outcome(None, _picklable(error), elapsed_ms, None, depth_m)
        segmentation_ms = 1000.0 * (time.perf_counter() - start)
        also = None
        if self._also is not None:
            try:
                also = self._also(frame)
            except Exception:  # made again, and raised, by the consumer
                also = None
        # A recording's depth image goes along: built here, the frame would inflate it again.
        depth_m = frame.depth_m if isinstance(self._frames, RecordedFrames) else None
        return _Outcome(result, None, segmentation_ms, also, depth_m)


def _picklable(error: Exception) -> Exception:
    """``error`` if it pickles, else a :class:`FogsimError` with its type and text."""
    try:
        pickle.loads(pickle.dumps(error))
    except Exception:  # any: it cannot travel as it is
        return FogsimError(f"{type(error).__name__}: {error}")
    return error
