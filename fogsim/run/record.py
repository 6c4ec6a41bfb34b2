"""Recording a scenario: simulate it once and save every frame with its ground truth.

Thresholds do not change what the camera sees, so ``fogsim record`` and the tune's recording
cache both simulate a scenario once with :func:`record_scenario` and replay the file after.

The file is checked before the simulation (:func:`fogsim.run.output_paths.check_output_path`)
and written atomically: killed at any point, the target holds the older complete recording or
nothing; the owned temporary a killed run leaves is removed by the next write into the folder.
"""

from __future__ import annotations

import itertools
import os
import sys
from contextlib import closing
from pathlib import Path

from fogsim.config import Scenario
from fogsim.data.recording import save_recording
from fogsim.run.output_paths import check_output_path
from fogsim.run.progress import FrameProgress
from fogsim.run.warmup import install_shipped_kernels
from fogsim.sim.simulation import Simulation


def record_scenario(
    scenario: Scenario,
    path: str | os.PathLike[str],
    *,
    max_frames: int | None = None,
    depth_backend: str = "renderer",
    progress: bool = False,
) -> tuple[Path, int]:
    """Simulate ``scenario`` and save its frames and per-frame truth to ``path``.

    Args:
        scenario: The scenario (overrides already applied).
        path: The recording file to write (atomically).
        max_frames: Keep only the first frames (the suite's quick mode); None = all.
        depth_backend: ``renderer`` (OpenGL) or ``raycast`` (no OpenGL).
        progress: Show a progress bar.

    Returns:
        The written file and the number of frames in it.

    Raises:
        OutputError: ``path`` cannot be written (found before the simulation) or writing
            failed (nothing is left; an older recording there is unchanged).
    """
    check_output_path(path, "file", "recording file")
    # The simulation's self-filter kernel: on a fresh machine from the shipped build, not
    # compiled in the first frame (0.5 s).
    install_shipped_kernels(sys.stderr if progress else None)
    simulation = Simulation(scenario, depth_backend=depth_backend)
    total = (
        simulation.frame_count if max_frames is None else min(max_frames, simulation.frame_count)
    )
    frames = itertools.islice(simulation.frames(), total)
    if progress:
        with closing(FrameProgress(total, scenario.name)) as bar:
            kept = []
            for frame in frames:
                kept.append(frame)
                bar.update()
    else:
        kept = list(frames)
    truths = [simulation.truth_at(frame.time_s) for frame in kept]
    return save_recording(path, kept, scenario=scenario, truths=truths), len(kept)
