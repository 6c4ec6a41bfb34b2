"""Mapper update speed: FloorObstacleMapper vs AveragingMap vs OctoMap on the same frames.

Scene (analytic, `mapper.synthetic`): ground plane, two boxes and a wall 3.2 m ahead, seen by a
camera 0.70 m above the ground (above the grid's 0.58 m top, as on the iCub: rays are clipped to
the grid) pitched down 22°, 47° × 39° field of view, from the grid's -x edge looking across it,
so that every ray ends inside the default 4 m × 4 m × 0.64 m grid at a range of 1–3.5 m.
±5 mm z noise; the camera sways by a few millimetres per frame so the points differ. The same
points go to every implementation (OctoMap: ``OcTree(0.04).insertPointCloud(points, origin)``,
which also updates each voxel once per cloud, occupied winning).
Scene "centre" (``--scene centre``): the robot-centred case, the same camera and scene but the
camera at the grid's centre; points beyond the grid's ±2 m are dropped (counted) by the mapper but
still given to OctoMap, whose map is unbounded.
Run: ``.venv/bin/python bench/bench_mapper.py [--frames 300] [--scene edge|centre]``.
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from mapper import (
    AveragingMap,
    FloorObstacleMapper,
    MapperParams,
    PinholeIntrinsics,
)
from mapper.synthetic import Box, camera_rays_world, cast_frame

BOXES = (
    Box((-0.6, 0.3), (0.4, 0.4, 0.07)),
    Box((0.0, -0.5), (0.3, 0.3, 0.25), walkable=False),
    Box((1.35, 0.0), (0.1, 4.0, 1.0), walkable=False),
)
# scene name -> (camera position [m], pitch down [deg]); see the module docstring
SCENES = {
    "edge": (np.array([-1.9, 0.0, 0.70]), 22.0),
    "centre": (np.array([0.0, 0.0, 0.70]), 22.0),
}


def make_frames(width: int, height: int, count: int, seed: int = 0, scene: str = "edge"):
    rng = np.random.default_rng(seed)
    intrinsics = PinholeIntrinsics.from_fov(width, height, 47.0, 39.0)
    camera0, pitch_deg = SCENES[scene]
    rays = camera_rays_world(intrinsics, yaw_deg=0.0, pitch_down_deg=pitch_deg)
    dx = camera0[0] - SCENES["edge"][0][0]  # the same boxes, at the same place ahead
    boxes = [replace(b, center_xy=(b.center_xy[0] + dx, b.center_xy[1])) for b in BOXES]
    frames = []
    for i in range(count):
        camera = camera0 + np.array([0.002 * (i % 20), 0.001 * (i % 7), 0.003 * (i % 3)])
        points, heights = cast_frame(camera, rays, boxes, max_range_m=3.5, noise_z_m=0.005, rng=rng)
        frames.append((points, heights, camera))
    return frames


def time_runs(insert, frames) -> np.ndarray:
    times = np.empty(len(frames))
    for i, (points, heights, camera) in enumerate(frames):
        t0 = time.perf_counter()
        insert(points, heights, camera)
        times[i] = time.perf_counter() - t0
    return times * 1e3


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--frames", type=int, default=300)
    parser.add_argument("--no-octomap", action="store_true")
    parser.add_argument("--scene", choices=sorted(SCENES), default="edge")
    args = parser.parse_args()
    params = MapperParams()
    rows = []
    for width, height in ((88, 72), (176, 144)):
        frames = make_frames(width, height, args.frames, scene=args.scene)
        points0, _, camera0 = frames[0]
        valid = np.count_nonzero(np.all(np.isfinite(points0), axis=1))
        ranges = np.linalg.norm(points0 - camera0, axis=1)
        probe = FloorObstacleMapper(params).update(*frames[0])
        print(
            f"{width}x{height}: {valid} finite points, ranges {np.nanmin(ranges):.2f}-"
            f"{np.nanmax(ranges):.2f} m, {probe.points_used} inside the grid, "
            f"{probe.cells_updated} cells updated per frame"
        )
        # warm-up (JIT compile, caches) on a separate instance
        warm = FloorObstacleMapper(params)
        t0 = time.perf_counter()
        warm.update(*frames[0])
        first_ms = (time.perf_counter() - t0) * 1e3
        fog = FloorObstacleMapper(params)
        avg = AveragingMap(params)
        impls = {"FloorObstacleMapper": fog.update, "AveragingMap": avg.update}
        if not args.no_octomap:
            import octomap

            tree = octomap.OcTree(params.cell_m)

            def octo(points, heights, camera, tree=tree):
                finite = np.all(np.isfinite(points), axis=1)
                tree.insertPointCloud(np.ascontiguousarray(points[finite]), camera)

            impls["octomap.OcTree.insertPointCloud"] = octo
        for name, insert in impls.items():
            times = time_runs(insert, frames)
            rows.append(
                (name, f"{width}x{height}", valid, np.median(times), np.percentile(times, 90))
            )
        print(
            f"{width}x{height}: first FloorObstacleMapper call (JIT or cache load) "
            f"{first_ms:.0f} ms"
        )
    print(
        f"\n{'implementation':34s} {'frame':>8s} {'points':>7s} {'median ms':>10s} {'p90 ms':>8s}"
    )
    for name, res, n, med, p90 in rows:
        print(f"{name:34s} {res:>8s} {n:7d} {med:10.3f} {p90:8.3f}")
    by = {(r[0], r[1]): r[3] for r in rows}
    for res in ("88x72", "176x144"):
        key = ("octomap.OcTree.insertPointCloud", res)
        if key in by:
            print(
                f"speed-up vs OctoMap at {res}: {by[key] / by[('FloorObstacleMapper', res)]:.1f}x"
            )


if __name__ == "__main__":
    main()
