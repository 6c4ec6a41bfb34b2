"""kill -9 at many points of ``fogsim run`` and ``fogsim record``: nothing half-written, nothing
of another run mixed in, no stale temporary after the next run, and the next run works.

Two kinds of points: wall-clock ones, ``python -m fogsim`` killed after a share of its
measured duration (the simulation, the pictures, the writing); and every file-system step of a
run's writing and commit, one after the other: a driver process (this file run as a script)
forks a run that kills itself with SIGKILL at its k-th ``mkdir``, ``rename``, ``replace``,
``fsync``, ``chmod``, ``unlink`` or ``rmdir``, for k = 1, 2, ... until a run gets through.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from test_pipeline import make_frames

from fogsim.atomic import TEMPORARY, remove_stale_temporaries
from fogsim.cli import main
from fogsim.config import load_scenario
from fogsim.data.recording import load_recording, save_recording
from fogsim.run.manifest import file_entries, read_manifest

ROOT = Path(__file__).resolve().parents[1]
ENV = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), str(ROOT / "tests")])}
FRACTIONS = (0.1, 0.3, 0.5, 0.7, 0.9)
"""Kill points as shares of a run's measured duration."""
STEPS = ("mkdir", "rename", "replace", "fsync", "chmod", "unlink", "rmdir")
"""The file-system calls a run's writing is made of (file contents go in before an fsync)."""
MAX_STEPS = 200


def fogsim(*args: str) -> list[str]:
    return [sys.executable, "-m", "fogsim", *args]


def call(command: list[str]) -> float:
    """Run a command to its end (it must succeed); its duration [s]."""
    start = time.monotonic()
    subprocess.run(command, check=True, env=ENV, cwd=ROOT, stdout=subprocess.DEVNULL)
    return time.monotonic() - start


def killed_after(command: list[str], delay_s: float) -> float | None:
    """Start a command and kill -9 it after ``delay_s``: None if killed, else its duration [s]."""
    start = time.monotonic()
    process = subprocess.Popen(command, env=ENV, cwd=ROOT, stdout=subprocess.DEVNULL)
    try:
        process.wait(timeout=delay_s)
    except subprocess.TimeoutExpired:
        process.kill()
        process.wait()
        return None
    assert process.returncode == 0
    return time.monotonic() - start


class KillPoints:
    """Kill points as :data:`FRACTIONS` of a command's duration, kept to its fastest run.

    A run measured on a loaded machine is slower than the next ones: a command that ends
    before its kill point shortens the duration, and that point is tried once more.
    """

    def __init__(self, duration_s: float) -> None:
        self.duration_s = duration_s

    def kill(self, command: list[str], fraction: float) -> bool:
        """Run ``command`` and kill -9 it at ``fraction`` of the duration; whether it was."""
        for _ in range(2):
            ended_s = killed_after(command, fraction * self.duration_s)
            if ended_s is None:
                return True
            self.duration_s = min(self.duration_s, ended_s)
        return False


def folder_state(out: Path) -> str | None:
    """The run id of a complete folder (its files are its manifest's), None if absent."""
    if not out.exists():
        return None
    manifest = read_manifest(out)
    assert file_entries(out) == manifest.files, f"{out} does not match its manifest"
    return manifest.run_id


def strays(folder: Path, keep: str) -> tuple[list[str], list[str]]:
    """Entries of ``folder`` other than ``keep``: (testbed temporaries, anything else)."""
    names = sorted(p.name for p in folder.iterdir() if p.name != keep)
    return [n for n in names if TEMPORARY.fullmatch(n)], [
        n for n in names if not TEMPORARY.fullmatch(n)
    ]


@pytest.mark.slow
def test_kill_9_during_a_run_leaves_the_older_result_or_nothing(tmp_path):
    out = tmp_path / "X"
    run = fogsim("run", "flat_floor", "--out", str(out), "--quiet")
    call(run)  # an older result, with pictures
    quick = [*run, "--no-pictures"]  # pictures of the older result must not survive beside it
    points = KillPoints(call([*quick, "--seed", "6"]))
    previous = folder_state(out)
    kills = 0
    for fraction in FRACTIONS:
        killed = points.kill([*quick, "--seed", "7"], fraction)
        kills += killed
        now = folder_state(out)  # complete, or absent
        if killed and now not in (previous, None):
            assert read_manifest(out).seed == 7  # killed after its own commit: complete too
        _, other = strays(tmp_path, "X")
        assert other == []
        previous = now
    assert kills >= 3, "the runs ended before they could be killed"
    call(quick)
    assert folder_state(out) is not None
    assert strays(tmp_path, "X") == ([], [])


@pytest.mark.slow
def test_kill_9_during_a_recording_leaves_the_older_file_or_nothing(tmp_path):
    path = tmp_path / "rec.npz"
    record = fogsim("record", "flat_floor", "--out", str(path), "--quiet")
    points = KillPoints(call(record))
    kills = 0
    for fraction in FRACTIONS:
        before = hashlib.sha256(path.read_bytes()).hexdigest() if path.exists() else None
        killed = points.kill([*record, "--seed", "7"], fraction)
        kills += killed
        after = hashlib.sha256(path.read_bytes()).hexdigest() if path.exists() else None
        if after != before:
            assert load_recording(path).scenario.seed == 7  # a complete new recording
        assert strays(tmp_path, "rec.npz")[1] == []
    assert kills >= 3, "the recordings ended before they could be killed"
    call(record)
    assert load_recording(path).scenario.seed == 5
    assert strays(tmp_path, "rec.npz") == ([], [])


def test_kill_9_at_every_file_system_step_of_a_run(tmp_path):

    recording = save_recording(
        tmp_path / "rec.npz", make_frames(8), scenario=load_scenario("flat_floor")
    )
    out = tmp_path / "runs" / "X"
    driver = subprocess.run(
        [sys.executable, __file__, str(out), str(recording)],
        env=ENV,
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert driver.returncode == 0, driver.stderr
    points = [json.loads(line) for line in driver.stdout.splitlines() if line.startswith("{")]
    *steps, final = points
    assert len(steps) >= 15, steps  # staging, three atomic files, the commit
    assert all(step["killed"] for step in steps[:-1]) and not steps[-1]["killed"]
    for step in steps:
        assert step["state"] in (step["before"], None) or step["committed"], step
        assert step["other"] == [], step
    seen = {step["state"] for step in steps}
    assert None in seen  # a kill between the two renames of the commit: nothing, not a mix
    assert final["left"] > 0  # a killed run left its temporaries ...
    assert final == {**final, "temporaries": [], "other": [], "complete": True}  # ... now gone


# --- The driver: forked runs that kill themselves at their k-th file-system step


def _kill_at(step: int) -> None:
    """Make this process kill itself with SIGKILL at its ``step``-th file-system call."""
    calls = itertools.count(1)

    def hook(original):
        def hooked(*args, **kwargs):
            if next(calls) == step:
                os.kill(os.getpid(), signal.SIGKILL)
            return original(*args, **kwargs)

        return hooked

    for name in STEPS:
        setattr(os, name, hook(getattr(os, name)))


def _killed_run(args: list[str], step: int) -> bool:
    """Fork a run of ``args`` that kills itself at its ``step``-th call; False if it ended."""
    pid = os.fork()
    if pid == 0:
        _kill_at(step)
        os._exit(main(args))
    _, status = os.waitpid(pid, 0)
    killed = os.WIFSIGNALED(status) and os.WTERMSIG(status) == signal.SIGKILL
    assert killed or os.WEXITSTATUS(status) == 0
    return killed


def _drive(out: Path, recording: Path) -> None:
    args = ["run", "--replay", str(recording), "--out", str(out), "--quiet", "--no-pictures"]
    assert main(args) == 0  # the older result; the children inherit the compiled kernels
    for step in range(1, MAX_STEPS):
        # Every run starts alike (an older result, no leftovers), so step k is the same call.
        remove_stale_temporaries(out.parent)
        if not out.exists():
            assert main(args) == 0
        before = folder_state(out)
        killed = _killed_run(args, step)
        state = folder_state(out)
        committed = state not in (before, None)  # complete (folder_state checked it)
        _, other = strays(out.parent, out.name)
        point = {"step": step, "killed": killed, "before": before, "state": state}
        print(json.dumps({**point, "committed": committed, "other": other}), flush=True)
        if not killed:
            break
    assert _killed_run(args, step // 2)
    left, _ = strays(out.parent, out.name)
    assert main(args) == 0  # the next run works and removes what the killed one left
    temporaries, other = strays(out.parent, out.name)
    complete = folder_state(out) is not None
    print(json.dumps({"left": len(left), "temporaries": temporaries, "other": other,
                      "complete": complete}))  # fmt: skip


if __name__ == "__main__":
    _drive(Path(sys.argv[1]), Path(sys.argv[2]))
