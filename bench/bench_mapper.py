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
Peers run interleaved in blocks of ``--block`` frames (10: each implementation runs frames
i … i+9, then the next one does), so load from other processes hits them alike while each keeps
its caches warm within a block as in a loop of its own; ``--block 1`` measures every frame after
the others' (caches flushed by OctoMap's tree, as in a pipeline that does other work between
frames). "cell marks" is the mapper with its
per-cell mark kernel (`insert_frame`, the implementation before the column kernel), the same
map, for a before/after figure in one process.
Run: ``.venv/bin/python bench/bench_mapper.py [--frames 300] [--scene edge|centre|both]``.
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


def time_interleaved(impls: dict, frames, block: int) -> dict[str, np.ndarray]:
    """Per-frame times [ms] of each implementation, interleaved in blocks of frames."""
    times = {name: np.empty(len(frames)) for name in impls}
    for start in range(0, len(frames), block):
        for name, insert in impls.items():
            for i in range(start, min(start + block, len(frames))):
                points, heights, camera = frames[i]
                t0 = time.perf_counter()
                insert(points, heights, camera)
                times[name][i] = time.perf_counter() - t0
    return {name: t * 1e3 for name, t in times.items()}


def run_scene(scene: str, frames_count: int, octomap_too: bool, block: int) -> list[tuple]:
    params = MapperParams()
    rows = []
    for width, height in ((88, 72), (176, 144)):
        frames = make_frames(width, height, frames_count, scene=scene)
        points0, _, camera0 = frames[0]
        valid = np.count_nonzero(np.all(np.isfinite(points0), axis=1))
        ranges = np.linalg.norm(points0 - camera0, axis=1)
        probe = FloorObstacleMapper(params).update(*frames[0])
        print(
            f"{scene} {width}x{height}: {valid} finite points, ranges {np.nanmin(ranges):.2f}-"
            f"{np.nanmax(ranges):.2f} m, {probe.points_used} inside the grid, "
            f"{probe.cells_updated} cells updated per frame"
        )
        # warm-up (JIT compile, caches) on separate instances
        t0 = time.perf_counter()
        FloorObstacleMapper(params).update(*frames[0])
        first_ms = (time.perf_counter() - t0) * 1e3
        FloorObstacleMapper(params, column_marks=False).update(*frames[0])
        impls = {
            "FloorObstacleMapper": FloorObstacleMapper(params).update,
            "FloorObstacleMapper (cell marks)": FloorObstacleMapper(
                params, column_marks=False
            ).update,
            "AveragingMap": AveragingMap(params).update,
        }
        if octomap_too:
            import octomap

            tree = octomap.OcTree(params.cell_m)

            def octo(points, heights, camera, tree=tree):
                finite = np.all(np.isfinite(points), axis=1)
                tree.insertPointCloud(np.ascontiguousarray(points[finite]), camera)

            impls["octomap.OcTree.insertPointCloud"] = octo
        for name, times in time_interleaved(impls, frames, block).items():
            rows.append(
                (
                    scene,
                    name,
                    f"{width}x{height}",
                    valid,
                    np.median(times),
                    np.percentile(times, 90),
                )
            )
        print(f"{scene} {width}x{height}: first FloorObstacleMapper call {first_ms:.0f} ms")
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--frames", type=int, default=300)
    parser.add_argument("--no-octomap", action="store_true")
    parser.add_argument("--scene", choices=[*sorted(SCENES), "both"], default="edge")
    parser.add_argument("--block", type=int, default=10, help="frames per interleaved block")
    args = parser.parse_args()
    scenes = sorted(SCENES) if args.scene == "both" else [args.scene]
    rows = []
    for scene in scenes:
        rows += run_scene(scene, args.frames, not args.no_octomap, args.block)
    print(
        f"\n{'scene':7s} {'implementation':34s} {'frame':>8s} {'points':>7s} "
        f"{'median ms':>10s} {'p90 ms':>8s}"
    )
    for scene, name, res, n, med, p90 in rows:
        print(f"{scene:7s} {name:34s} {res:>8s} {n:7d} {med:10.3f} {p90:8.3f}")
    by = {(r[0], r[1], r[2]): r[4] for r in rows}
    for scene in scenes:
        for res in ("88x72", "176x144"):
            ours = by[(scene, "FloorObstacleMapper", res)]
            before = by[(scene, "FloorObstacleMapper (cell marks)", res)]
            line = f"{scene} {res}: column vs cell marks {before / ours:.2f}x"
            key = (scene, "octomap.OcTree.insertPointCloud", res)
            if key in by:
                line += f", speed-up vs OctoMap {by[key] / ours:.1f}x"
            print(line)


if __name__ == "__main__":
    main()
