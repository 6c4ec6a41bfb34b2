"""Kernel warm-up before a run: the compile message only with a cold numba cache, same results."""

import dataclasses
import os
import subprocess
import sys
from pathlib import Path

import pytest
from test_pipeline import INTR, make_frames, provider_removed_at

from fogsim.config import RunParams
from fogsim.data.recording import Recording
from fogsim.run import warmup
from fogsim.run.runner import run_scenario
from fogsim.run.warmup import MAPPER, MESSAGE, SEGMENTATION, SELF_FILTER, KernelGroup, cold_modules

ROOT = Path(__file__).resolve().parent.parent

WARM_UP = (
    "from numba.core import event\n"
    "from fogsim.config import RunParams\n"
    "from fogsim.run.warmup import warm_up_kernels\n"
    "compiled = set()\n"
    "class Compiled(event.Listener):\n"
    "    def on_start(self, ev): compiled.add(ev.data['dispatcher'].py_func.__module__)\n"
    "    def on_end(self, ev): pass\n"
    "event.register('numba:compile', Compiled())\n"
    "warm_up_kernels(RunParams())\n"
    "print(' '.join(sorted(compiled)))\n"
)
"""A warm-up that prints the modules whose kernels this process compiled (numba's events)."""


def _warm_up(cache_dir: Path) -> tuple[str, set[str]]:
    """A warm-up in a fresh interpreter whose numba cache is ``cache_dir``: its standard error
    and the modules whose kernels it compiled itself (not in its helper process)."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache_dir), PYTHONPATH=str(ROOT))
    process = subprocess.run(
        [sys.executable, "-c", WARM_UP], env=env, capture_output=True, text=True, check=True
    )
    return process.stderr, set(process.stdout.split())


@pytest.mark.slow
def test_message_with_a_cold_cache_only(tmp_path):
    cold, compiled_here = _warm_up(tmp_path)
    # The helper compiled the segmentation; this process the rest, and never the segmentation
    # again (a Pipeline in the mapper step segments: it compiled every scan-line kernel twice).
    assert "mapper.scanline" not in compiled_here
    assert {"mapper.occupancy", "mapper.zmatch", "mapper.heading"} <= compiled_here
    assert MESSAGE in cold
    assert "segmentation kernels ..." in cold
    assert "(second process)" in cold and "failed" not in cold  # compiled beside the others
    assert "mapper kernels ..." in cold
    assert "self-filter kernels ..." in cold
    assert "compiled in" in cold
    assert list(tmp_path.rglob("*.nbi")), "the warm-up filled the cache"
    assert _warm_up(tmp_path) == ("", set())  # everything loaded from the cache


def test_a_run_with_progress_leaves_the_cache_warm():
    run_scenario(None, None, replay=_recording(), pictures=False, progress=True)
    assert cold_modules(SEGMENTATION) == ()
    assert cold_modules(MAPPER) == ()
    assert cold_modules(SELF_FILTER) == ()


def _recording():
    frames = make_frames(4, box_until_frame=2)
    truths = [provider_removed_at(0.1)(f.time_s) for f in frames]
    return Recording(frames=frames, scenario=None, truths=truths, intrinsics=INTR)


def test_warm_up_leaves_the_results_unchanged():
    quiet = run_scenario(None, None, replay=_recording(), pictures=False, progress=False)
    shown = run_scenario(None, None, replay=_recording(), pictures=False, progress=True)
    assert dataclasses.replace(shown, timing=quiet.timing) == quiet


def test_a_failing_helper_process_is_reported_with_its_last_error_line(monkeypatch):
    monkeypatch.setattr(warmup, "HELPER_GROUP", KernelGroup("no such group", ()))
    helper = warmup._Helper(RunParams())
    failure = helper.wait()
    helper.stop()
    assert failure.startswith("ValueError: not enough values to unpack")
