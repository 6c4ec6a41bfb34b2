"""Pool workers that end themselves when the process that started them is killed.

A ``concurrent.futures`` worker never notices on its own that its driver died: it blocks on the
call queue, whose pipe it holds both ends of (so no end-of-file comes), or finishes a task
nobody will read — a killed ``fogsim suite`` left its runs going on, writing into the run
folder's temporary, which the next suite then found being written while it removed it as stale
(session 43: "cannot remove …, left by a killed run: Directory not empty"). A worker's
initializer starts :func:`watch_driver`'s thread, which polls ``os.getppid()`` (POSIX and
Windows alike) against the driver's pid, passed in by the driver, so a driver that died before
the worker started is noticed at once. Linux's ``prctl(PR_SET_PDEATHSIG)`` would act at once but
is Linux-only, needs ctypes, and fires when the *thread* that forked the worker ends, not the
driver process.
"""

from __future__ import annotations

import os
import threading
import time

__all__ = ["PARENT_POLL_S", "watch_driver"]

PARENT_POLL_S = 1.0
"""Seconds between a worker's checks that its driver still lives. One wake-up a second costs
nothing beside a run's or a trial's seconds, and a killed driver's workers are gone within a
second."""


def watch_driver(driver_pid: int) -> None:
    """Start a daemon thread that ends this process once its parent is not ``driver_pid``.

    Args:
        driver_pid: The pid of the process that started the pool (``os.getpid()`` there).
    """
    threading.Thread(
        target=_exit_when_orphaned, args=(driver_pid,), name="driver-watch", daemon=True
    ).start()


def _exit_when_orphaned(driver_pid: int) -> None:
    """End this process as soon as its parent is no longer ``driver_pid``."""
    while os.getppid() == driver_pid:
        time.sleep(PARENT_POLL_S)
    os._exit(1)  # at once: no cleanup of half-done work, nobody waits for it
