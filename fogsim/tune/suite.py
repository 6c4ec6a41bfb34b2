"""The recordings a tune replays: suite arguments to files, and the recording cache.

Thresholds do not change what the camera sees, so a scenario file is simulated once into a
recording, cached under its scenario hash, and every trial only replays it.
"""

from __future__ import annotations

import dataclasses
import hashlib
import os
import sys
from collections.abc import Sequence
from pathlib import Path

from fogsim.config import Scenario, load_scenario
from fogsim.data.recording import FORMAT_VERSION, Recording, load_recording
from fogsim.errors import TuneError
from fogsim.run.output_paths import child_path
from fogsim.run.suite import QUICK_MAX_FRAMES, QUICK_SCENARIOS
from fogsim.tune.objective import SuiteEntry


def scenario_hash(scenario: Scenario) -> str:
    """16 hex digits of SHA-256 over the recording format and the scenario's canonical TOML.

    The recording cache key: a changed scenario or a new recording format gets a new recording.
    """
    text = f"{FORMAT_VERSION}\n{scenario.to_toml()}"
    return hashlib.sha256(text.encode("utf-8")).hexdigest()[:16]


def _first_frames(recording: Recording, max_frames: int | None) -> Recording:
    """The recording cut after ``max_frames`` frames (unchanged if shorter or None)."""
    if max_frames is None or len(recording.frames) <= max_frames:
        return recording
    return dataclasses.replace(
        recording, frames=recording.frames[:max_frames], truths=recording.truths[:max_frames]
    )


def _frame_rate_hz(recording: Recording) -> float:
    """The recording's frame rate [Hz]: its scenario's, else from the frame times."""
    if recording.scenario is not None:
        return float(recording.scenario.frame_rate_hz)
    times = recording.times_s.tolist()
    if len(times) < 2:
        raise TuneError("cannot tell the frame rate of a one-frame recording without scenario")
    return float((len(times) - 1) / (times[-1] - times[0]))


def _entry(name: str, recording: Recording) -> SuiteEntry:
    if not recording.has_truth:
        raise TuneError(
            f"recording {name!r} has no ground truth for every frame; tuning scores runs "
            "against the truth, so it needs simulated recordings"
        )
    return SuiteEntry(name=name, recording=recording, frame_rate_hz=_frame_rate_hz(recording))


def _suite_files(source: str | os.PathLike[str]) -> list[Path]:
    """Scenario files and recordings named by one suite argument."""
    path = Path(source)
    if path.is_dir():
        files = sorted([*path.glob("*.toml"), *path.glob("*.npz")])
        if not files:
            raise TuneError(f"suite directory {path} holds no *.toml or *.npz files")
        return files
    if path.is_file() and path.suffix in (".toml", ".npz"):
        return [path]
    if path.suffix == "" and not path.exists():
        scenario = load_scenario(str(source))  # a scenario name; ScenarioError lists the known
        return [scenario.source_path]
    raise TuneError(
        f"suite {str(source)!r} must be a directory of scenario files (*.toml) and/or "
        "recordings (*.npz), one such file, or a scenario name"
    )


def load_suite(
    sources: str | os.PathLike[str] | Sequence[str | os.PathLike[str]],
    cache_dir: str | os.PathLike[str],
    *,
    quick: bool = False,
) -> list[SuiteEntry]:
    """The recordings of a suite.

    Args:
        sources: Directories of scenario files and/or recordings, single files, or scenario
            names (``stage``).
        cache_dir: Where recordings made from scenario files are kept, as
            ``<name>-<scenario hash>[-<frames>f].npz``: made once, reused while the scenario
            is unchanged.
        quick: Only the suite's quick subset (:data:`fogsim.run.suite.QUICK_SCENARIOS`, cut after
            :data:`fogsim.run.suite.QUICK_MAX_FRAMES` frames), as ``fogsim suite --quick`` runs it.

    Raises:
        TuneError: a source is missing or empty, no file is left, names repeat, or a
            recording has no ground truth.
    """
    if isinstance(sources, str | os.PathLike):
        sources = [sources]
    files = [f for source in sources for f in _suite_files(source)]
    max_frames = QUICK_MAX_FRAMES if quick else None
    entries = []
    for path in files:
        if path.suffix == ".npz":
            recording = load_recording(path)
            name = path.stem if recording.scenario is None else recording.scenario.name
            if not quick or name in QUICK_SCENARIOS:
                entries.append(_entry(path.stem, _first_frames(recording, max_frames)))
            continue
        scenario = load_scenario(path)
        if quick and scenario.name not in QUICK_SCENARIOS:
            continue
        suffix = "" if max_frames is None else f"-{max_frames}f"
        cached = child_path(
            cache_dir, f"{scenario.name}-{scenario_hash(scenario)}{suffix}.npz", "scenario name"
        )
        if not cached.is_file():
            print(f"fogsim tune: recording {scenario.name} once into {cached}", file=sys.stderr)
            # MuJoCo and the robot: imported only to record (every command builds tune's parser).
            from fogsim.run.record import record_scenario

            record_scenario(scenario, cached, max_frames=max_frames)
        entries.append(_entry(scenario.name, load_recording(cached)))
    if not entries:
        raise TuneError(f"the quick subset {list(QUICK_SCENARIOS)} is not in the suite")
    names = [e.name for e in entries]
    if len(set(names)) != len(names):
        raise TuneError(f"suite names must be distinct, got {names}")
    return entries
