"""How much of the segmentation thread's time holds the GIL: the part outside numba kernels.

The run segments on a second thread beside the mapping (``fogsim.mapping.prefetch``); only the
time inside the ``nogil`` numba kernels lets the mapping run meanwhile. This replays a
recording's frames through a `FrameSegmenter` (``segment_depth`` and the tilt filter, as a run
calls them) on one thread and counts its CPU time (``time.thread_time``) in total and inside
the kernels the Python code calls (every numba dispatcher of ``mapper.scanline`` and
``mapper.tilt_kernels`` reached from ``mapper.segmentation``, ``mapper.pose_correction`` and
``mapper.tilt_filter``, wrapped; the wrapper's own call costs a few µs per kernel, counted as
inside).

Run: ``PYTHONPATH=TREE .venv/bin/python bench/segmentation_gil.py REC.npz [REC.npz ...]``
(any tree: kernels are found by type, so the base tree is measured alike).
"""

from __future__ import annotations

import os
import sys
import time
import types

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

from numba.core.dispatcher import Dispatcher

import mapper.pose_correction as pose_correction
import mapper.segmentation as segmentation
import mapper.tilt_filter as tilt_filter
from fogsim.config import resolve_params
from fogsim.data.recording import load_recording
from fogsim.mapping.segmenter import FrameSegmenter
from fogsim.run.runner import sensor_fields

_INSIDE = [0.0]
"""Thread CPU time inside the wrapped kernels [s]."""


def _timed(kernel):
    def call(*args):
        start = time.thread_time()
        result = kernel(*args)
        _INSIDE[0] += time.thread_time() - start
        return result

    return call


def _wrapped_module(module: types.ModuleType) -> types.SimpleNamespace:
    """A stand-in for ``module`` whose kernels are timed (the kernels calling each other are
    not: they call the originals, inside numba)."""
    return types.SimpleNamespace(
        **{
            name: _timed(value) if isinstance(value, Dispatcher) else value
            for name, value in vars(module).items()
            if not name.startswith("__")
        }
    )


def _wrap_kernels() -> None:
    for module in (segmentation, pose_correction):
        for name in ("scanline", "tilt_kernels"):
            if hasattr(module, name):
                setattr(module, name, _wrapped_module(getattr(module, name)))
    for module in (segmentation, tilt_filter):
        for name, value in list(vars(module).items()):
            if isinstance(value, Dispatcher):
                setattr(module, name, _timed(value))


def measure(path: str) -> tuple[float, float, int]:
    """(total, inside kernels) thread CPU time [s] over the recording's frames, and frames."""
    recording = load_recording(path)
    params = resolve_params(recording.scenario, None, sensor_fields(recording.scenario))
    segmenter = FrameSegmenter(params)
    for frame in recording.frames[:3]:  # compile or load the cache
        segmenter(frame)
    segmenter = FrameSegmenter(params)
    _INSIDE[0] = 0.0
    start = time.thread_time()
    for frame in recording.frames:
        segmenter(frame)
    return time.thread_time() - start, _INSIDE[0], len(recording.frames)


def main() -> None:
    _wrap_kernels()
    print(f"load average before: {os.getloadavg()}")
    for path in sys.argv[1:]:
        total, inside, n = measure(path)
        print(
            f"{path}: {1e3 * total / n:.3f} ms a frame, {1e3 * inside / n:.3f} ms in nogil "
            f"kernels ({100 * inside / total:.1f} %), {1e3 * (total - inside) / n:.3f} ms "
            "holding the GIL"
        )
    print(f"load average after: {os.getloadavg()}")


if __name__ == "__main__":
    main()
