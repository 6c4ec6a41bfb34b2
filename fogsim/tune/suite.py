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

import numpy as np

from fogsim.config import Scenario, load_scenario
from fogsim.data.frames import RecordedFrames
from fogsim.data.recording import FORMAT_VERSION, Recording, load_recording
from fogsim.errors import TuneError
from fogsim.run.output_paths import child_path
from fogsim.run.suite import QUICK_MAX_FRAMES, QUICK_SCENARIOS
from fogsim.tune.objective import SuiteEntry

IN_MEMORY_DEPTH_BYTES = 1 << 30
"""Depth bytes [B] of one recording a tune holds in memory (1 GiB: a 832-frame stage recording
of 88 × 72 images takes 21 MB, of 176 × 144 84 MB); a longer recording's trials read the file."""


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


def _in_memory(recording: Recording) -> Recording:
    """The recording with its depth images in memory (up to :data:`IN_MEMORY_DEPTH_BYTES`).

    A recording with more depth is left as it is: every trial reads the file, as before.

    Every trial replays every recording: reading the depth from the file inflated it again
    each time (0.26 s of a 4.4 s stage trial, Intel Xeon). Pool workers share the images
    with the driver (forked); Ray workers got them in memory already (pickled frames).
    """
    frames = recording.frames
    if not isinstance(frames, RecordedFrames) or not len(frames):
        return recording
    pixels = recording.intrinsics.width * recording.intrinsics.height
    if len(frames) * pixels * np.dtype(np.float32).itemsize > IN_MEMORY_DEPTH_BYTES:
        return recording
    return dataclasses.replace(recording, frames=frames.in_memory())


def _entry(name: str, recording: Recording) -> SuiteEntry:
    if not recording.has_truth:
        raise TuneError(
            f"recording {name!r} has no ground truth for every frame; tuning scores runs "
            "against the truth, so it needs simulated recordings"
        )
    recording = _in_memory(recording)
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
