"""Wall time of whole runs: simulate + map + score a scenario, and replay the same frames.

Usage:
    .venv/bin/python bench/bench_run.py [SCENARIO] [--repeats N] [--backend renderer|raycast]

Prints, side by side in one process: the full run (setup included: robot loading, scene
building, rendering, segmentation, mapping, scoring; pictures excluded) and the replay of the
recorded frames (pipeline + scoring only), each as the median of N repeats, plus the
per-frame pipeline times from the report, the scene set-up compiled from MJCF against loaded
from the compiled-model cache, and the load average (``os.getloadavg``) before and after. The
first repeat also pays numba's compile (or cache load); the median hides it for N >= 3.
"""

import argparse
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")
os.environ.setdefault("PYOPENGL_PLATFORM", "egl")
os.environ.setdefault("MESA_SHADER_CACHE_DISABLE", "true")
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from fogsim.config import load_scenario
from fogsim.data.recording import load_recording, save_recording
from fogsim.robot import load_robot
from fogsim.run.runner import run_scenario
from fogsim.sim.scene import Scene, compile_scene
from fogsim.sim.simulation import Simulation


def load_note() -> str:
    """The 1, 5 and 15 minute load averages."""
    return "load " + " / ".join(f"{x:.2f}" for x in os.getloadavg())


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("scenario", nargs="?", default="stage")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--backend", default="renderer", choices=("renderer", "raycast"))
    args = parser.parse_args()
    scenario = load_scenario(args.scenario)
    load_before = load_note()

    full, reports = [], []
    for _ in range(args.repeats):
        start = time.perf_counter()
        reports.append(run_scenario(scenario, None, depth_backend=args.backend))
        full.append(time.perf_counter() - start)

    with tempfile.TemporaryDirectory() as tmp:
        sim = Simulation(scenario, depth_backend=args.backend)
        frames = list(sim.frames())
        truths = [sim.truth_at(f.time_s) for f in frames]
        path = save_recording(Path(tmp) / "rec.npz", frames, scenario=scenario, truths=truths)
        replay = []
        for _ in range(args.repeats):
            start = time.perf_counter()
            rec = load_recording(path)
            run_scenario(scenario, None, replay=rec)
            replay.append(time.perf_counter() - start)

    robot = load_robot(scenario.robot.model)
    compiled, cached = [], []
    for _ in range(args.repeats):
        start = time.perf_counter()
        compile_scene(scenario, robot)
        compiled.append(time.perf_counter() - start)
        start = time.perf_counter()
        Scene(scenario, robot)
        cached.append(time.perf_counter() - start)

    timing = reports[-1].timing
    duration = timing.frames / scenario.frame_rate_hz
    print(
        f"scenario {scenario.name}: {timing.frames} frames = {duration:.1f} s simulated, "
        f"camera {scenario.camera.mode}, backend {args.backend}, {args.repeats} repeats"
    )
    print(
        f"  full run (setup incl.)   median {statistics.median(full):7.2f} s   "
        f"all {[round(t, 2) for t in full]}"
    )
    print(
        f"  replay (load + pipeline) median {statistics.median(replay):7.2f} s   "
        f"all {[round(t, 2) for t in replay]}"
    )
    print(
        f"  scene: compiled from MJCF median {statistics.median(compiled):.3f} s, "
        f"from the model cache median {statistics.median(cached):.3f} s"
    )
    print(f"  {load_before} before, {load_note()} after (2 cores)")
    for key in ("segmentation_ms", "update_ms", "frame_ms"):
        s = getattr(timing, key)
        print(f"  {key:<16} median {s.median:.2f} ms  p99 {s.p99:.2f} ms  max {s.max:.2f}")


if __name__ == "__main__":
    main()
