"""The occupancy insert of another commit against this tree's, interleaved in one process.

For work on `mapper.occupancy`: ``insert_frame_columns`` (the mapper's default kernel) of the
base commit (``git show BASE:mapper/occupancy.py``, imported as its own module) and of the
working tree run on the stage's own frames (a recording replayed through the pipeline, the
mapper's inputs captured: `bench_mapper.stage_frames`), each on its own grid, recentred as the
mapper is before every update. Per frame the order alternates, and after it both grids and both
return values must be identical (the run stops at the first difference: the change must give
the same map bit for bit). The figures are each kernel's median, 10th and 90th percentile per
frame over every frame of every recording (CPU time of the calling thread, ``time.thread_time``:
on a loaded machine wall time counts the waits for a core), with ``os.getloadavg()`` before and
after.

Code generation is numba's default (the host CPU) unless ``NUMBA_CPU_NAME=generic`` is set (give
it its own ``NUMBA_CACHE_DIR``); run once each way.

Run: ``.venv/bin/python bench/bench_insert_ab.py --base e38a5f4 REC.npz [REC.npz ...]``
(``--discretize``: both kernels with `MapperParams.discretize_rays`; a base from d3f75c8 on).
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path
from types import ModuleType

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from base_module import module_at
from bench_mapper import FrameSet, stage_frames

from mapper import FloorObstacleMapper, occupancy
from mapper.grid import scroll_xy


class Kernel:
    """One module's ``insert_frame_columns`` with its own grid and scratch."""

    def __init__(self, module: ModuleType, frame_set: FrameSet, discretize: bool) -> None:
        p = frame_set.params
        self.module = module
        self.discretize = discretize
        self.params = p
        dtype = module.column_mask_dtype(p.nz)
        hit, miss = module.lookup_tables(p)
        self.og = np.full((p.nx, p.ny, p.nz), 128, dtype=np.uint8)
        self.hit_cols = np.zeros(p.nx * p.ny, dtype=dtype)
        self.miss_cols = np.zeros(p.nx * p.ny, dtype=dtype)
        self.range_masks = module.layer_range_masks(p.nz)
        self.table = module.update_table(hit, miss)

    def insert(self, frame, geometry_args, shift) -> tuple[float, tuple, np.ndarray]:
        """Scroll by ``shift`` (untimed), insert one frame; (seconds, result, point cells)."""
        if shift != (0, 0):
            scroll_xy(self.og, *shift, 128)
        p = self.params
        point_cell = np.empty(len(frame.points), dtype=np.int64)
        if hasattr(self.module, "cell_set"):  # the discretized insertion's scratch, or None
            extra = (self.module.cell_set(len(frame.points)) if self.discretize else None,)
        else:  # a bool before cell_set; older kernels lack the argument
            extra = (True,) if self.discretize else ()
        t0 = time.thread_time()
        result = self.module.insert_frame_columns(
            frame.points,
            frame.sensor_origin,
            *geometry_args,
            self.og,
            self.hit_cols,
            self.miss_cols,
            self.range_masks,
            self.table,
            point_cell,
            p.free_margin_m,
            float(p.max_range_m),
            bool(p.clear_outside),
            *extra,
        )
        return time.thread_time() - t0, result, point_cell


def compare(frame_set: FrameSet, base: ModuleType, discretize: bool) -> dict[str, list[float]]:
    """Per-frame seconds of both kernels, interleaved; stops at the first difference."""
    kernels = {
        "base": Kernel(base, frame_set, discretize),
        "tree": Kernel(occupancy, frame_set, discretize),
    }
    mapper = FloorObstacleMapper(frame_set.params)  # only its recentring (geometry)
    times: dict[str, list[float]] = {name: [] for name in kernels}
    for i, frame in enumerate(frame_set.frames):
        shift = mapper.recenter(*frame.center_xy_m)
        g = mapper.geometry
        geometry_args = (*g.origin_xy_m, g.z_min_m, g.cell_m, g.layer_m)
        order = ["base", "tree"] if i % 2 == 0 else ["tree", "base"]
        out = {}
        for name in order:
            seconds, result, point_cell = kernels[name].insert(frame, geometry_args, shift)
            times[name].append(seconds)
            out[name] = (result, point_cell)
        same = out["base"][0] == out["tree"][0] and np.array_equal(out["base"][1], out["tree"][1])
        if not (same and np.array_equal(kernels["base"].og, kernels["tree"].og)):
            raise SystemExit(f"frame {i}: the kernels' results or grids differ")
    return times


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("recordings", nargs="+", help="stage recordings (fogsim record)")
    parser.add_argument("--base", default="HEAD", help="commit whose kernel is the base")
    parser.add_argument("--frames", type=int, default=100000, help="frames per recording")
    parser.add_argument(
        "--discretize",
        action="store_true",
        help="both kernels discretize (MapperParams.discretize_rays; the base must have it)",
    )
    args = parser.parse_args()
    codegen = os.environ.get("NUMBA_CPU_NAME", "host")
    with tempfile.TemporaryDirectory() as directory:
        base = module_at(args.base, "mapper/occupancy.py", Path(directory))
        frame_sets = [stage_frames(Path(path), args.frames) for path in args.recordings]
        for frame_set in frame_sets:  # compile or load both kernels before timing
            warm_up = FrameSet("warm-up", "", frame_set.params, frame_set.frames[:2])
            compare(warm_up, base, args.discretize)
        load_before = os.getloadavg()
        times: dict[str, list[float]] = {"base": [], "tree": []}
        for frame_set in frame_sets:
            for name, seconds in compare(frame_set, base, args.discretize).items():
                times[name] += seconds
        load_after = os.getloadavg()
    resolutions = sorted({s.resolution for s in frame_sets})
    print(
        f"{len(times['base'])} frames ({', '.join(resolutions)}) of {len(frame_sets)} "
        f"recordings, codegen {codegen}, discretize {args.discretize}, identical grids; "
        f"load (1, 5, 15 min) "
        f"{'/'.join(f'{v:.1f}' for v in load_before)} before, "
        f"{'/'.join(f'{v:.1f}' for v in load_after)} after"
    )
    for name, label in (("base", f"base {args.base}"), ("tree", "this tree")):
        ms = np.array(times[name]) * 1e3
        print(
            f"  {label:22s} median {np.median(ms):.3f} ms  p10 {np.percentile(ms, 10):.3f}  "
            f"p90 {np.percentile(ms, 90):.3f}"
        )
    ratio = np.median(times["base"]) / np.median(times["tree"])
    print(f"  base / tree (medians): {ratio:.3f}")


if __name__ == "__main__":
    main()
