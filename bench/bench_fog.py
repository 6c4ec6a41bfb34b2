"""`mapper.fog.update_fog_area` alone: this tree's against a base tree's, same inputs, one process.

The FOG kernel's inputs are captured while recordings are replayed through the pipeline
(`mapper.mapper.update_fog_area` wrapped: the occupancy grid, the floor, obstacle and cover
maps and the area of every ``--every``-th call, copied). Then for each captured call both
kernels run on copies of the maps they write (``obstacle``, ``fog_types``, ``fog_heights``),
interleaved in blocks of ``--block`` calls so that load hits them alike, and

- their outputs are compared byte for byte (a pure speed change keeps them identical);
- each call's thread CPU time (``time.thread_time``) is recorded; the medians are printed,
  with the load average before and after.

``--variants N`` also compares the two kernels on every captured state with N random
parameter sets and random areas (margin, band, narrow rise, shadow reach, island rule, spill
and seen-drop rules on and off), so that code paths the defaults do not take are checked too.

The base tree's kernel is loaded from its file under another module name; run with a fresh
``NUMBA_CACHE_DIR`` (numba's cache keys on the file name, which both trees share).

Run: ``NUMBA_CACHE_DIR=$(mktemp -d) PYTHONPATH=TREE .venv/bin/python bench/bench_fog.py
--base /work/wt32-base /work/rec/stage_depth_s1.npz [--every 4] [--variants 8]``.
"""

from __future__ import annotations

import argparse
import importlib.util
import inspect
import os
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import mapper.fog as fog_new
import mapper.mapper as mapper_module
from fogsim.config.params import resolve_params
from fogsim.data.recording import load_recording
from fogsim.mapping.pipeline import Pipeline
from fogsim.run.runner import sensor_fields

OUT = (2, 3, 4)  # argument positions the kernel writes: obstacle, fog_types, fog_heights
AREA = (9, 10, 11, 12)  # ix0, ix1, iy0, iy1


@dataclass(frozen=True)
class Call:
    """One captured call: its positional arguments (arrays copied)."""

    args: tuple


def load_base(tree: Path):
    """The base tree's ``mapper/fog.py`` as module ``fog_base``."""
    spec = importlib.util.spec_from_file_location("fog_base", tree / "mapper" / "fog.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules["fog_base"] = module
    spec.loader.exec_module(module)
    return module


def capture(path: Path, every: int) -> list[Call]:
    """Every ``every``-th FOG call of the recording's replay (heading rebuild off)."""
    recording = load_recording(path)
    scenario = recording.scenario
    pipeline = Pipeline(
        resolve_params(scenario, {"pipe.heading_rebuild_frames": 0}, sensor=sensor_fields(scenario))
    )
    calls: list[Call] = []
    original = mapper_module.update_fog_area
    count = [0]

    def wrapped(*args):
        if count[0] % every == 0:
            calls.append(Call(tuple(a.copy() if isinstance(a, np.ndarray) else a for a in args)))
        count[0] += 1
        return original(*args)

    mapper_module.update_fog_area = wrapped
    try:
        for frame in recording.frames:
            pipeline.process(frame)
    finally:
        mapper_module.update_fog_area = original
    return calls


def run(kernel, args: tuple) -> tuple[float, tuple]:
    """CPU seconds of one call on copies of its outputs, and the outputs."""
    # A base tree from before a rule's flag takes only the arguments it knows (the flag off).
    a = list(args)[: len(inspect.signature(getattr(kernel, "py_func", kernel)).parameters)]
    for i in OUT:
        a[i] = a[i].copy()
    t0 = time.thread_time()
    kernel(*a)
    spent = time.thread_time() - t0
    return spent, tuple(a[i] for i in OUT)


def same(x: tuple, y: tuple) -> bool:
    """Byte-identical outputs (NaN payloads included)."""
    return all(
        np.array_equal(a.view(np.uint8), b.view(np.uint8)) for a, b in zip(x, y, strict=True)
    )


def variant_args(args: tuple, rng: np.random.Generator) -> tuple:
    """``args`` with random rule parameters and a random area (within the grid)."""
    a = list(args)
    nx, ny = a[1].shape
    x0, y0 = rng.integers(0, nx - 1), rng.integers(0, ny - 1)
    a[9], a[10] = int(x0), int(rng.integers(x0 + 1, nx + 1))
    a[11], a[12] = int(y0), int(rng.integers(y0 + 1, ny + 1))
    a[16] = float(rng.choice([0.0, 0.2, 0.5]))  # pass_fraction
    a[17] = int(rng.integers(0, 3))  # margin
    a[18] = float(rng.choice([0.0, 0.02, 0.05]))  # band
    a[19] = bool(rng.integers(0, 2))  # beside_obstacles
    a[20] = int(rng.choice([0, 2, 4, 6]))  # rise cells
    a[21] = int(rng.choice([0, 1, 4, 6]))  # shadow cells
    a[22] = int(rng.choice([0, 0, 2, 4]))  # min floor neighbours
    a[23] = bool(rng.integers(0, 2))  # rim over spill
    a[24] = bool(rng.integers(0, 2))  # seen drop
    if len(a) > 25:
        a[25] = bool(rng.integers(0, 2))  # ground noise
    return tuple(a)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("recordings", nargs="+", type=Path)
    parser.add_argument("--base", type=Path, required=True, help="the base tree")
    parser.add_argument("--every", type=int, default=4, help="capture every n-th call")
    parser.add_argument("--block", type=int, default=10)
    parser.add_argument("--repeats", type=int, default=3, help="timed passes over the calls")
    parser.add_argument("--variants", type=int, default=0)
    args = parser.parse_args()
    fog_base = load_base(args.base)
    kernels = {"base": fog_base.update_fog_area, "this": fog_new.update_fog_area}
    print(f"this tree: {fog_new.__file__}; base: {fog_base.__file__}")
    for path in args.recordings:
        calls = capture(path, args.every)
        for kernel in kernels.values():  # warm: compile (or load) both
            run(kernel, calls[0].args)
        differ = 0
        times = {name: [] for name in kernels}
        load_before = os.getloadavg()
        for _ in range(args.repeats):
            for b in range(0, len(calls), args.block):
                outs = {}
                for name, kernel in kernels.items():
                    for c in calls[b : b + args.block]:
                        spent, out = run(kernel, c.args)
                        times[name].append(spent)
                        outs.setdefault(name, []).append(out)
                differ += sum(
                    not same(x, y) for x, y in zip(outs["base"], outs["this"], strict=True)
                )
        load_after = os.getloadavg()
        areas = np.array([[c.args[10] - c.args[9], c.args[12] - c.args[11]] for c in calls])
        med = {name: 1e3 * float(np.median(t)) for name, t in times.items()}
        print(
            f"{path.name}: {len(calls)} calls, area median {np.median(areas, axis=0)} cells; "
            f"median ms base {med['base']:.3f}, this {med['this']:.3f} "
            f"(x{med['base'] / med['this']:.2f}); outputs differing: {differ}; "
            f"load {load_before[0]:.2f} -> {load_after[0]:.2f}"
        )
        if args.variants:
            rng = np.random.default_rng(0)
            bad = 0
            total = 0
            for c in calls:
                for _ in range(args.variants):
                    v = variant_args(c.args, rng)
                    _, x = run(kernels["base"], v)
                    _, y = run(kernels["this"], v)
                    total += 1
                    if not same(x, y):
                        bad += 1
                        if bad <= 3:
                            print("  variant differs:", v[9:13], v[16:])
            print(f"  variants: {total} compared, {bad} differing")


if __name__ == "__main__":
    main()
