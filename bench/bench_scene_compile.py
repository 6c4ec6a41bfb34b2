"""What a cold cache costs: building and compiling a scene, and loading a robot, median of repeats.

Usage:
    PYTHONPATH=TREE .venv/bin/python bench/bench_scene_compile.py [--repeats N]

Run it once per tree to compare trees (interleave the runs: the machine's load varies).

- ``scene``: :func:`fogsim.sim.scene.compile_scene` (the MJCF built with ``dm_control``, its
  text and assets, MuJoCo's parse and compile: what a miss of the compiled-scene cache costs)
  for ``stage`` (iCub) and ``talos_course`` (TALOS); the robot is loaded first and one compile
  warms the imports.
- ``robot``: ``fogsim.robot.model._load`` (URDF and meshes loaded, the MJCF and its mesh files
  written, MuJoCo's compile: what a miss of the robot cache costs) into a fresh empty
  ``FOGSIM_CACHE`` each repeat.

Printed: per item the median, minimum and maximum wall time [ms] over the repeats, and the
median CPU time of the process [ms] (the measure on a shared machine; the wall time also holds
waits for the disk: the robot's files are written with ``fsync``).
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time
import warnings
from collections.abc import Callable

from fogsim.config import load_scenario
from fogsim.robot import load_robot
from fogsim.robot import model as robot_model
from fogsim.robot.description import load_description
from fogsim.sim.scene import compile_scene


def _times_ms(action: Callable[[], object], repeats: int) -> tuple[list[float], list[float]]:
    """Wall and CPU (this process's) times [ms] of ``action()``, once per repeat."""
    wall, cpu = [], []
    for _ in range(repeats):
        start, start_cpu = time.perf_counter(), time.process_time()
        action()
        wall.append(1e3 * (time.perf_counter() - start))
        cpu.append(1e3 * (time.process_time() - start_cpu))
    return wall, cpu


def _print(label: str, times_ms: tuple[list[float], list[float]]) -> None:
    wall, cpu = times_ms
    print(
        f"{label}: wall median {statistics.median(wall):.0f} ms "
        f"(min {min(wall):.0f}, max {max(wall):.0f}), CPU median {statistics.median(cpu):.0f} ms, "
        f"n={len(wall)}",
        flush=True,
    )


def _load_robot_cold(name: str) -> None:
    """Load robot ``name`` as on a cache miss, into a fresh empty cache folder."""
    with tempfile.TemporaryDirectory() as folder:
        previous = os.environ.get("FOGSIM_CACHE")
        os.environ["FOGSIM_CACHE"] = folder
        try:
            robot_model._load(load_description(name))
        finally:
            if previous is None:
                del os.environ["FOGSIM_CACHE"]
            else:
                os.environ["FOGSIM_CACHE"] = previous


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7, help="repeats per item (default 7)")
    args = parser.parse_args()
    warnings.simplefilter("ignore")  # example-robot-data's and pinocchio's deprecation notes
    for name in ("stage", "talos_course"):
        scenario = load_scenario(name)
        robot = load_robot(scenario.robot.model)
        compile_scene(scenario, robot)  # imports warmed
        _print(
            f"scene {name}",
            _times_ms(lambda s=scenario, r=robot: compile_scene(s, r), args.repeats),
        )
    for name in ("icub", "talos"):
        _print(f"robot {name}", _times_ms(lambda n=name: _load_robot_cold(n), args.repeats))


if __name__ == "__main__":
    main()
