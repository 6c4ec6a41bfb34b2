"""One segmentation per recorded frame, shared by the trials a tune process scores.

A trial replays every recording with its parameters, and segmenting the depth images is about
40 % of a replay (stage, depth: 1.8 of 4.4 s CPU). The mapper, z-match, elevation and pipeline
parameters a tune usually searches do not change the segmentation, so a process keeps each
frame's :class:`~mapper.segmentation.SegmentationResult` and hands it to the next trial.

The key is every argument of :func:`~mapper.segmentation.segment_depth`: the depth image's bytes,
shape and dtype, the camera's intrinsics, its believed transform and the segmentation
parameters. A trial that tunes a segmentation parameter (or a scenario whose camera differs)
asks with another key and is segmented afresh, so a cached result is exactly what
``segment_depth`` would return (it is deterministic); :func:`cached_replay_report` does not even
ask when the overrides hold a ``seg.`` parameter (each trial's key would be new). Cached arrays
are made read-only: a consumer that wrote into a result shared between trials would raise
instead of changing the next trial's input.

The cells each frame saw (the scoring's ``in_view``, :class:`ViewCache`) are the same in every
trial too (they depend on the frame and the grid's place only), so they are kept alike: 0.3 s
of a 4.4 s stage trial (Intel Xeon).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
from typing import Any, Generic, TypeVar

import numpy as np
from numpy.typing import NDArray

from fogsim.data.frame import Frame
from fogsim.data.recording import Recording
from fogsim.errors import TuneError
from fogsim.eval.archive import cells_in_view
from fogsim.eval.report import Report
from fogsim.run.runner import replay_report
from mapper.grid import GridGeometry
from mapper.intrinsics import PinholeIntrinsics
from mapper.segmentation import SegmentationParams, SegmentationResult, segment_depth

_Value = TypeVar("_Value")

CACHE_BYTES = 512 * 2**20
"""Bytes of segmentation results one process keeps (512 MiB). A stage recording's results take
~300 MB (832 frames of 88×72 pixels, ~0.36 MB each: the (N, 3) points, the per-point heights
and ids, and the depth image of the key), box_removal's 132 frames ~50 MB, so the default
suite (``bench/bench_tune.py``: stage and box_removal) fits; a tune holds at most this much
per worker. Beyond it new results are not kept (see :class:`SegmentationCache`)."""


def result_bytes(value: Any) -> int:
    """Bytes of the numpy arrays in a (nested) frozen dataclass such as a segmentation result."""
    if isinstance(value, np.ndarray):
        return int(value.nbytes)
    if dataclasses.is_dataclass(value):
        return sum(result_bytes(getattr(value, f.name)) for f in dataclasses.fields(value))
    return 0


def _freeze(value: Any) -> None:
    """Make every numpy array in a (nested) dataclass read-only."""
    if isinstance(value, np.ndarray):
        value.flags.writeable = False
    elif dataclasses.is_dataclass(value):
        for f in dataclasses.fields(value):
            _freeze(getattr(value, f.name))


def _arrays_key(*arrays: NDArray[Any]) -> tuple[tuple[Any, ...], int]:
    """A cache key of the arrays' bytes, shapes and dtypes, and the bytes the key holds."""
    parts: list[Any] = []
    nbytes = 0
    for array in arrays:
        contiguous = np.ascontiguousarray(array)
        parts += [contiguous.tobytes(), contiguous.shape, contiguous.dtype.str]
        nbytes += contiguous.nbytes
    return tuple(parts), nbytes


class _KeepFirstCache(Generic[_Value]):
    """Values by key, the first ones kept up to a byte cap (the caches below).

    When the cap is reached new values are computed but not kept; the ones kept stay. Every
    trial replays the suite in the same order, so a least-recently-used cache smaller than the
    suite would evict exactly the frame the next trial asks for first and never hit; keeping
    the first values makes as much of the suite hit as fits.

    Args:
        max_bytes: The cap [bytes] on the kept values and their keys' array bytes, >= 0.

    Raises:
        TuneError: ``max_bytes`` < 0.

    Attributes:
        hits: Values handed out again.
        misses: Values computed.
        stored_bytes: Bytes kept.
    """

    what = "cache"
    """What error messages call the cache."""

    def __init__(self, max_bytes: int) -> None:
        if max_bytes < 0:
            raise TuneError(f"{self.what} max_bytes must be >= 0, got {max_bytes!r}")
        self.max_bytes = max_bytes
        self.hits = self.misses = self.stored_bytes = 0
        self._kept: dict[tuple[Any, ...], _Value] = {}

    def _cached(
        self,
        key: tuple[Any, ...],
        key_bytes: int,
        make: Callable[[], _Value],
        value_bytes: Callable[[_Value], int],
        freeze: Callable[[_Value], None],
    ) -> _Value:
        """The value kept under ``key``, else ``make()``, kept (frozen) if it fits the cap."""
        found = self._kept.get(key)
        if found is not None:
            self.hits += 1
            return found
        self.misses += 1
        value = make()
        size = value_bytes(value) + key_bytes
        if self.stored_bytes + size <= self.max_bytes:
            freeze(value)
            self._kept[key] = value
            self.stored_bytes += size
        return value


class SegmentationCache(_KeepFirstCache[SegmentationResult]):
    """Segmentation results by every argument of ``segment_depth``, up to a byte cap.

    The first results are kept (:class:`_KeepFirstCache`); results are read-only.

    Args:
        max_bytes: The cap [bytes] on the kept results' arrays (:func:`result_bytes`) and
            their keys' depth and transform bytes, >= 0.

    Raises:
        TuneError: ``max_bytes`` < 0.
    """

    what = "segmentation cache"

    def __init__(self, max_bytes: int = CACHE_BYTES) -> None:
        super().__init__(max_bytes)

    def segment(
        self,
        depth_m: NDArray[np.floating],
        intrinsics: PinholeIntrinsics,
        transform_camera_to_robot: NDArray[np.floating],
        params: SegmentationParams,
    ) -> SegmentationResult:
        """``segment_depth(depth_m, intrinsics, transform_camera_to_robot, params)``, cached."""
        arrays, key_bytes = _arrays_key(depth_m, transform_camera_to_robot)
        return self._cached(
            (*arrays, intrinsics, params),
            key_bytes,
            lambda: segment_depth(depth_m, intrinsics, transform_camera_to_robot, params),
            result_bytes,
            _freeze,
        )


VIEW_CACHE_BYTES = 128 * 2**20
"""Bytes of cells-in-view masks one process keeps (128 MiB): a stage trial asks for ~950, one
per frame and per frame mapped again, of 10 kB each on the default 100 × 100 grid."""


class ViewCache(_KeepFirstCache[NDArray[np.bool_]]):
    """The cells of a grid a frame saw (:func:`~fogsim.eval.archive.cells_in_view`), cached.

    The cells a frame saw depend on its depth image, intrinsics and true camera pose, and on
    the grid's place, never on the parameters a trial changes (the grid follows the believed
    poses of the recording): every trial asks for the same ones. The key is all of that, so a
    cached mask is exactly what ``cells_in_view`` returns (it is deterministic). Masks are
    read-only; the first are kept up to ``max_bytes`` (:class:`_KeepFirstCache`).

    Args:
        max_bytes: The cap [bytes] on the kept masks and their keys' depth and pose bytes,
            >= 0.

    Raises:
        TuneError: ``max_bytes`` < 0.
    """

    what = "view cache"

    def __init__(self, max_bytes: int = VIEW_CACHE_BYTES) -> None:
        super().__init__(max_bytes)

    def cells_in_view(
        self,
        frame: Frame,
        geometry: GridGeometry,
        points_world: NDArray[np.float64] | None = None,
    ) -> NDArray[np.bool_]:
        """``cells_in_view(frame, geometry, points_world)``, cached (read-only)."""
        arrays, key_bytes = _arrays_key(frame.depth_m, frame.transform_camera_to_world_true)
        return self._cached(
            (*arrays, frame.intrinsics, geometry),
            key_bytes,
            lambda: cells_in_view(frame, geometry, points_world),
            lambda mask: int(mask.nbytes),
            _freeze,
        )


_PROCESS_CACHE = SegmentationCache()
"""This process's cache: a pool worker's or Ray worker's own (a forked worker starts with the
driver's, which scores nothing in a pool)."""

_PROCESS_VIEWS = ViewCache()
"""This process's cells-in-view cache (as :data:`_PROCESS_CACHE`)."""


def cached_replay_report(recording: Recording, overrides: Mapping[str, float]) -> Report:
    """:func:`~fogsim.run.runner.replay_report` with this process's segmentation and view caches.

    The report function of ``fogsim tune``: module-level, so it pickles by name for pool and
    Ray workers, each of which keeps its own cache. With a ``seg.`` parameter among the
    overrides it segments afresh and keeps nothing.
    """
    views = _PROCESS_VIEWS.cells_in_view
    if any(name.startswith("seg.") for name in overrides):
        return replay_report(recording, overrides, segment_ahead=False, in_view=views)
    return replay_report(
        recording, overrides, segment=_PROCESS_CACHE.segment, segment_ahead=False, in_view=views
    )
