"""Linux /proc helpers of the tests that kill a driver and look for its pool workers."""

from __future__ import annotations

import signal
import subprocess
import time
from pathlib import Path


def process_children(pid: int) -> list[int]:
    """Pids whose parent is ``pid`` (Linux /proc)."""
    children = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            text = stat.read_text()
        except OSError:
            continue
        if int(text[text.rindex(")") + 2 :].split()[1]) == pid:
            children.append(int(stat.parent.name))
    return children


def process_alive(pid: int) -> bool:
    """The process exists and is not a zombie (Linux /proc)."""
    try:
        text = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return text[text.rindex(")") + 2] != "Z"


def kill_driver(driver: subprocess.Popen, workers: list[int], grace_s: float) -> list[int]:
    """SIGKILL ``driver`` (a ``subprocess.Popen``); which of its ``workers`` outlive ``grace_s``.

    Waits until every worker has ended or ``grace_s`` seconds have passed.
    """
    try:
        driver.send_signal(signal.SIGKILL)
        driver.wait(timeout=10)
    finally:
        if driver.poll() is None:
            driver.kill()
    deadline = time.monotonic() + grace_s
    while any(process_alive(w) for w in workers) and time.monotonic() < deadline:
        time.sleep(0.1)
    return [w for w in workers if process_alive(w)]
