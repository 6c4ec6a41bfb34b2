"""A killed driver's pool workers end themselves (`fogsim.run.orphans`)."""

from __future__ import annotations

import multiprocessing
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from processes import kill_driver, process_children

from fogsim.paths import SCENARIOS_DIR
from fogsim.run.orphans import PARENT_POLL_S, watch_driver


def _watch_then_sleep(driver_pid: int) -> None:
    watch_driver(driver_pid)
    time.sleep(30.0)


def test_a_worker_whose_parent_is_not_its_driver_ends_at_once():
    # The driver died before the worker's initializer ran: its parent is another process.
    context = multiprocessing.get_context("spawn")
    orphan = context.Process(target=_watch_then_sleep, args=(os.getpid() + 10**6,))
    kept = context.Process(target=_watch_then_sleep, args=(os.getpid(),))
    orphan.start()
    kept.start()
    try:
        orphan.join(timeout=20.0)
        assert orphan.exitcode == 1  # `os._exit(1)` from the watch, long before its 30 s sleep
        time.sleep(PARENT_POLL_S + 0.5)
        assert kept.is_alive()  # its driver (this process) lives: never ended by the watch
    finally:
        for process in (orphan, kept):
            process.kill()
            process.join()


def _spawn_workers(pid: int) -> list[int]:
    """The driver's multiprocessing workers (not its resource tracker)."""
    workers = []
    for child in process_children(pid):
        try:
            command = Path(f"/proc/{child}/cmdline").read_bytes()
        except OSError:
            continue
        if b"spawn_main" in command:
            workers.append(child)
    return workers


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs Linux /proc")
def test_killing_a_suite_ends_its_run_workers(tmp_path):
    # Before session 43 the seed runner's workers outlived a killed `fogsim suite`, finished
    # their runs into its temporary folder, and the next suite failed to remove it as stale.
    scenarios = tmp_path / "scenarios"
    scenarios.mkdir()
    shutil.copy(SCENARIOS_DIR / "flat_floor.toml", scenarios)
    command = [sys.executable, "-m", "fogsim", "suite", str(scenarios), "--seeds", "1-2"]
    driver = subprocess.Popen(
        [*command, "--workers", "2", "--out", str(tmp_path / "out")],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    workers: list[int] = []
    try:
        deadline = time.monotonic() + 60.0
        while len(workers) < 2 and time.monotonic() < deadline and driver.poll() is None:
            time.sleep(0.05)
            workers = _spawn_workers(driver.pid)
        assert len(workers) == 2, "the suite's two workers never started"
    finally:
        left = kill_driver(driver, workers, PARENT_POLL_S + 10.0)
    assert not left, "orphaned suite workers still run"


def _die(job):  # a run whose worker is killed from outside
    os.kill(os.getpid(), signal.SIGKILL)


def test_a_killed_worker_is_a_clear_error_not_a_traceback(monkeypatch):
    # A pool worker killed mid-run (out of memory, a stray kill) broke the pool: the command
    # printed concurrent.futures' BrokenProcessPool traceback. It is a FogsimError now, which
    # the command reports in one line.
    from fogsim.errors import FogsimError
    from fogsim.run import seeds

    monkeypatch.setattr(seeds, "run_seed", _die)
    with pytest.raises(FogsimError, match="worker process ended abruptly"):
        seeds.run_jobs([object(), object()], workers=2)
