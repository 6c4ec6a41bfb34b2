"""`bench/bench_run.py`'s options: which measurements each combination runs."""

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "bench"))
bench_run = pytest.importorskip("bench_run")


@pytest.fixture
def calls(monkeypatch):
    """The in-process measurements and the commands, recorded instead of run."""
    seen = []
    monkeypatch.setattr(bench_run, "parts", lambda *args: seen.append("parts"))
    monkeypatch.setattr(bench_run, "overlap", lambda *args: seen.append("overlap"))
    monkeypatch.setattr(bench_run, "fogsim", lambda *args: seen.append("command") or (0.0,))
    monkeypatch.setattr(bench_run, "repeat", lambda *args: seen.append("repeat"))
    return seen


def test_parts_and_overlap_run_without_the_commands(calls, monkeypatch):
    monkeypatch.setattr(sys, "argv", ["bench_run.py", "stage", "--no-commands", "--parts"])
    bench_run.main()
    assert calls == ["parts"]
    calls.clear()
    monkeypatch.setattr(sys, "argv", ["bench_run.py", "stage", "--no-commands", "--overlap", "2"])
    bench_run.main()
    assert calls == ["overlap"]


def test_parts_run_beside_the_commands(calls, monkeypatch):
    monkeypatch.setattr(sys, "argv", ["bench_run.py", "stage", "--parts", "--repeats", "1"])
    bench_run.main()
    # The stages first, then the warm-up command and the run's repeats.
    assert calls[0] == "parts" and "command" in calls and "repeat" in calls
