"""Frames segmented on a second thread, a few frames ahead of the pipeline that maps them.

Segmenting a frame depends only on the frame (its depth image, intrinsics and believed camera
transform) and the segmentation parameters, never on the maps: :class:`SegmentAhead` segments
frames k + 1, k + 2, ... on its own thread while the pipeline maps frame k (a stage replay:
segmentation 1.8 s, mapping and scoring 1.7 s of the frame loop, one core each). It hands the
pipeline, through its ``segment`` hook (:class:`~fogsim.mapping.pipeline.Pipeline`), exactly
the result the segmentation function returns for that frame, so the maps are the same bit for
bit. What runs in parallel is what releases Python's GIL: the segmentation kernels are compiled
with ``nogil`` (:mod:`mapper.scanline`), numpy's array work releases it too.

Bounded: at most :data:`AHEAD_FRAMES` segmented frames wait for the pipeline, whatever the
input's length. Errors: the segmentation's exception for frame k is raised when the pipeline
asks for frame k's segmentation (after its own checks of frame k, as in line); an exception of
the frames' iterator (a simulation's) is raised by the iteration where it happened. Stopping:
:meth:`SegmentAhead.close` (``with``, also on an exception or Ctrl-C in the consumer) tells the
thread to stop and waits for it; it stops once its current frame is segmented or its source
hands it the next one.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Iterable, Iterator
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from fogsim.data.frame import Frame
from fogsim.errors import FogsimError
from fogsim.mapping.pipeline import SegmentFunction
from fogsim.sim.background import HandOff
from mapper.intrinsics import PinholeIntrinsics
from mapper.segmentation import SegmentationParams, SegmentationResult, segment_depth

AHEAD_FRAMES = 4
"""Segmented frames that may wait for the pipeline: enough to carry either side over a slow
frame (a first z-match, a frame with many planes: 3-5 times the median), few enough to bound
the memory (a stage frame's result is ~0.36 MB) and the work thrown away when a run stops."""


@dataclass(frozen=True)
class _Segmented:
    """A frame and the outcome of its segmentation (the result or the exception raised)."""

    frame: Frame
    result: SegmentationResult | None
    error: BaseException | None
    segmentation_ms: float


class SegmentAhead:
    """Iterate frames whose segmentation was done ahead on a second thread; iterate once.

    Use: ``with SegmentAhead(frames) as ahead``, build the pipeline with
    ``segment=ahead.segment``, :meth:`start` with the pipeline's segmentation parameters, then
    iterate ``ahead`` and hand each frame to the pipeline. The pipeline's ``segment`` call for
    the frame just iterated returns its result; a call for any other frame or with other
    parameters raises.

    Args:
        frames: The frames in order (a list, or a simulation's frames); iterated on the thread.
        segment: The segmentation function (:data:`~fogsim.mapping.pipeline.SegmentFunction`),
            called on the thread.
        ahead: Segmented frames that may wait for the pipeline, >= 1.

    Raises:
        FogsimError: ``ahead`` < 1.

    Attributes:
        segmentation_ms: The segmentation time [ms] of the frame last handed out (measured on
            the thread, waiting for the GIL included).
    """

    def __init__(
        self,
        frames: Iterable[Frame],
        segment: SegmentFunction = segment_depth,
        *,
        ahead: int = AHEAD_FRAMES,
    ) -> None:
        if ahead < 1:
            raise FogsimError(f"SegmentAhead: ahead must be >= 1 frame, got {ahead!r}")
        self._frames = frames
        self._segment = segment
        self._handoff = HandOff(ahead)
        self._thread: threading.Thread | None = None
        self._params: SegmentationParams | None = None
        self._current: _Segmented | None = None
        self.segmentation_ms = float("nan")

    def start(self, params: SegmentationParams) -> None:
        """Start segmenting with ``params`` (the pipeline's: ``Pipeline.segmentation_params``)."""
        if self._thread is not None:
            raise FogsimError("SegmentAhead.start: already started")
        self._params = params
        self._thread = threading.Thread(
            target=self._run, args=(params,), name="fogsim-segment-ahead", daemon=True
        )
        self._thread.start()

    def __iter__(self) -> Iterator[Frame]:
        """The frames in order; raises the frames' iterator's exception where it happened."""
        if self._thread is None:
            raise FogsimError("SegmentAhead: start() it before iterating")
        for item in self._handoff.items():
            assert isinstance(item, _Segmented)
            self._current = item
            yield item.frame

    def segment(
        self,
        depth_m: NDArray[np.floating],
        intrinsics: PinholeIntrinsics,
        transform_camera_to_robot: NDArray[np.floating],
        params: SegmentationParams,
    ) -> SegmentationResult:
        """The segmentation of the frame just iterated (raises its exception).

        Raises:
            FogsimError: The arguments are not that frame's depth, intrinsics and believed
                transform (equal values) and the parameters given to :meth:`start`, or it was
                already asked for.
        """
        current, self._current = self._current, None
        if (
            current is None
            or not _same_array(depth_m, current.frame.depth_m)
            or intrinsics != current.frame.intrinsics
            or not _same_array(
                transform_camera_to_robot, current.frame.transform_camera_to_robot_believed
            )
            or params != self._params
        ):
            raise FogsimError(
                "SegmentAhead.segment: called for another frame than the one just iterated "
                "or with other parameters than start() got; the pipeline must segment each "
                "frame it is handed once, with the parameters given to start()"
            )
        self.segmentation_ms = current.segmentation_ms
        if current.error is not None:
            raise current.error
        assert current.result is not None
        return current.result

    def close(self) -> None:
        """Stop the thread and wait for it; idempotent."""
        if self._thread is not None:
            self._handoff.close(self._thread)

    def __enter__(self) -> SegmentAhead:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ------------------------------------------------------------------ the thread

    def _run(self, params: SegmentationParams) -> None:
        frames = iter(self._frames)
        try:
            while not self._handoff.stopped:  # checked before taking a frame from the source
                frame = next(frames, None)
                if frame is None:
                    self._handoff.finish()
                    return
                self._handoff.put(self._segmented(frame, params))
        except BaseException as error:  # the frames' iterator's: raised where it happened
            self._handoff.fail(error)

    def _segmented(self, frame: Frame, params: SegmentationParams) -> _Segmented:
        """Segment ``frame``; its exception is kept for the pipeline's call."""
        start = time.perf_counter()
        try:
            result = self._segment(
                frame.depth_m, frame.intrinsics, frame.transform_camera_to_robot_believed, params
            )
        except Exception as error:  # raised again by `segment` for this frame
            return _Segmented(frame, None, error, 1000.0 * (time.perf_counter() - start))
        return _Segmented(frame, result, None, 1000.0 * (time.perf_counter() - start))


def _same_array(given: NDArray[np.floating], expected: NDArray[np.floating]) -> bool:
    """``given`` is ``expected`` or has its shape, dtype and values (NaN equal to NaN)."""
    if given is expected:
        return True
    given = np.asarray(given)
    return (
        given.shape == expected.shape
        and given.dtype == expected.dtype
        and bool(np.array_equal(given, expected, equal_nan=True))
    )
