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
    "from fogsim.config import RunParams\n"
    "from fogsim.run.warmup import warm_up_kernels\n"
    "warm_up_kernels(RunParams())\n"
)


def _warm_up_stderr(cache_dir: Path) -> str:
    """Standard error of a warm-up in a fresh interpreter whose numba cache is ``cache_dir``."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache_dir), PYTHONPATH=str(ROOT))
    process = subprocess.run(
        [sys.executable, "-c", WARM_UP], env=env, capture_output=True, text=True, check=True
    )
    return process.stderr


@pytest.mark.slow
def test_message_with_a_cold_cache_only(tmp_path):
    cold = _warm_up_stderr(tmp_path)
    assert MESSAGE in cold
    assert "segmentation kernels ..." in cold
    assert "(second process)" in cold and "failed" not in cold  # compiled beside the others
    assert "mapper kernels ..." in cold
    assert "self-filter kernels ..." in cold
    assert "compiled in" in cold
    assert list(tmp_path.rglob("*.nbi")), "the warm-up filled the cache"
    assert _warm_up_stderr(tmp_path) == ""


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
