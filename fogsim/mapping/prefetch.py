"""Frames segmented on a second thread, a few frames ahead of the pipeline that maps them.

Segmenting a frame and filtering its tilt depend only on the frames (their depth images,
intrinsics and believed camera transforms, in order) and the parameters, never on the maps
(:class:`~fogsim.mapping.segmenter.FrameSegmenter`): :class:`SegmentAhead` runs a segmenter on
frames k + 1, k + 2, ... on its own thread while the pipeline maps frame k (a stage replay:
segmentation 1.8 s, mapping and scoring 1.7 s of the frame loop, one core each). It hands the
pipeline, through its ``segmented`` hook (:class:`~fogsim.mapping.pipeline.Pipeline`), exactly
the result the segmenter returned for that frame, so the maps are the same bit for bit. What
runs in parallel is what releases Python's GIL: the segmentation kernels are compiled with
``nogil`` (:mod:`mapper.scanline`), numpy's array work releases it too.

Bounded: at most ``ahead`` segmented frames wait for the pipeline (a run's:
`fogsim.sim.background.frames_ahead`), whatever the input's length. Errors: the segmentation's
exception for frame k is raised when the pipeline asks for frame k's segmentation (after its own
checks of frame k, as in line); an exception of the frames' iterator (a simulation's) is raised
by the iteration where it happened. Stopping: :meth:`SegmentAhead.close` (``with``, also on an
exception or Ctrl-C in the consumer) tells the thread to stop and waits for it; it stops once
its current frame is segmented or its source hands it the next one.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass

from fogsim.data.frame import Frame
from fogsim.errors import FogsimError
from fogsim.mapping.segmenter import Segmented
from fogsim.sim.background import AHEAD_FRAMES, HandOff
from mapper.segmentation import SegmentationResult


@dataclass(frozen=True)
class _Segmented:
    """A frame and the outcome of its segmentation (the result or the exception raised)."""

    frame: Frame
    result: SegmentationResult | None
    error: BaseException | None
    segmentation_ms: float
    also: object = None


class SegmentAhead:
    """Iterate frames whose segmentation was done ahead on a second thread; iterate once.

    Use: ``with SegmentAhead(frames, FrameSegmenter(params)) as ahead``, build the pipeline of
    the same ``params`` with ``segmented=ahead.segmented``, :meth:`start`, then iterate
    ``ahead`` and hand each frame to the pipeline. The pipeline's ``segmented`` call for the
    frame just iterated returns its result; a call for any other frame raises.

    Args:
        frames: The frames in order (a list, or a simulation's frames); iterated on the thread.
        segmenter: Called with each frame in order, on the thread
            (:class:`~fogsim.mapping.segmenter.FrameSegmenter`).
        ahead: Segmented frames that may wait for the pipeline, >= 1.
        also: Called with each frame on the thread too, after its segmentation: what else the
            consumer needs of a frame alone, made off its thread (a run: the frame's world
            points for the cells in view); :meth:`also` hands it out. None: nothing.

    Raises:
        FogsimError: ``ahead`` < 1.

    Attributes:
        segmentation_ms: The segmentation time [ms] of the frame last handed out (measured on
            the thread, waiting for the GIL included).
    """

    def __init__(
        self,
        frames: Iterable[Frame],
        segmenter: Segmented,
        *,
        ahead: int = AHEAD_FRAMES,
        also: Callable[[Frame], object] | None = None,
    ) -> None:
        if ahead < 1:
            raise FogsimError(f"SegmentAhead: ahead must be >= 1 frame, got {ahead!r}")
        self._frames = frames
        self._segmenter = segmenter
        self._handoff = HandOff(ahead)
        self._thread: threading.Thread | None = None
        self._current: _Segmented | None = None
        self._also = also
        self._last: _Segmented | None = None  # the frame just iterated, for `also`
        self.segmentation_ms = float("nan")

    def start(self) -> None:
        """Start segmenting."""
        if self._thread is not None:
            raise FogsimError("SegmentAhead.start: already started")
        self._thread = threading.Thread(target=self._run, name="fogsim-segment-ahead", daemon=True)
        self._thread.start()

    def __iter__(self) -> Iterator[Frame]:
        """The frames in order; raises the frames' iterator's exception where it happened."""
        if self._thread is None:
            raise FogsimError("SegmentAhead: start() it before iterating")
        for item in self._handoff.items():
            assert isinstance(item, _Segmented)
            self._current = self._last = item
            yield item.frame

    def segmented(self, frame: Frame) -> SegmentationResult:
        """The segmentation of the frame just iterated (raises its exception).

        Raises:
            FogsimError: ``frame`` is not the frame just iterated (the same object), or its
                segmentation was already asked for.
        """
        current, self._current = self._current, None
        if current is None or frame is not current.frame:
            raise FogsimError(
                "SegmentAhead.segmented: called for another frame than the one just iterated; "
                "the pipeline must ask once for each frame it is handed"
            )
        self.segmentation_ms = current.segmentation_ms
        if current.error is not None:
            raise current.error
        assert current.result is not None
        return current.result

    def also(self, frame: Frame) -> object:
        """What the ``also`` callable gave for the frame just iterated (the same object).

        None for any other frame, without an ``also`` callable, or when it raised (the consumer
        then makes it itself, and meets the error where it would have without the thread).
        """
        last = self._last
        return last.also if last is not None and frame is last.frame else None

    def close(self) -> None:
        """Stop the thread and wait for it; idempotent."""
        if self._thread is not None:
            self._handoff.close(self._thread)

    def __enter__(self) -> SegmentAhead:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ------------------------------------------------------------------ the thread

    def _run(self) -> None:
        frames = iter(self._frames)
        try:
            while not self._handoff.stopped:  # checked before taking a frame from the source
                frame = next(frames, None)
                if frame is None:
                    self._handoff.finish()
                    return
                self._handoff.put(self._segment(frame))
        except BaseException as error:  # the frames' iterator's: raised where it happened
            self._handoff.fail(error)

    def _segment(self, frame: Frame) -> _Segmented:
        """Segment ``frame``; its exception is kept for the pipeline's call."""
        start = time.perf_counter()
        try:
            result = self._segmenter(frame)
        except Exception as error:  # raised again by `segment` for this frame
            return _Segmented(frame, None, error, 1000.0 * (time.perf_counter() - start))
        segmentation_ms = 1000.0 * (time.perf_counter() - start)
        also = None
        if self._also is not None:
            try:
                also = self._also(frame)
            except Exception:  # made again, and raised, by the consumer (`also`)
                also = None
        return _Segmented(frame, result, None, segmentation_ms, also)
