"""Trace a replay's unsafe cells back to the frames, pixels and floor regions that put them there.

Usage:
    PYTHONPATH=. python bench/spill_trace.py REC.npz [--set KEY=VALUE ...] [--cells N]
        [--cell IX,IY ...] [--json OUT] [--maps MAPS.npz] [--pose MODE]

Replays the recording in line (no second thread), keeping every frame's segmentation (after the
tilt filter) and every point set the FOG mapper received. For each unsafe cell of the final
maps (as `bench/unsafe_cells.py`: FOG floor on a true obstacle or more than 20 mm off the true
floor) it lists the mapped frames whose floor points landed in the cell: per frame the points'
floor heights, their pixels, the floor region they belong to (its height and pixel count), the
measured depth against the true depth of the left camera (a ray cast of the scenario's boxes
and the ground with the frame's true camera pose, rough tops taken flat) and what the true ray
hits there, where the true hit lies and where the map put the point, and what the pixels of each
region truly hit. Printed: per cell, how many of its floor points truly hit which surface at
which floor height (10 mm bins); ``--json`` keeps every point, ``--cell`` traces a cell that
is not unsafe too, ``--maps`` writes the final maps (``bench/unsafe_cells.py`` reads them as
``FOLDER/seed_N/maps.npz``). The `fogsim` replay's maps are the same (in line instead of the
second thread: the same results, `fogsim.mapping.prefetch`). Each point also keeps
``meas_xyz``, where the true camera pose puts its measured depth (world, m): against
``pt_xyz`` the believed pose's share of its error, against ``hit_xyz`` the depth's
(`bench/unsafe_causes.py` counts the cells by cause from them). ``--pose`` replays with one of
`bench/heading_oracle.py`'s believed poses ('true yaw', 'true position', 'true pose'; the
heading estimator off), to see what is left without the pose's errors.

Session 37, stage stereo seeds 1 and 4: the cells beside step_1's side edge got 300-420 floor
points a run at the step's height from ground pixels 2-6 cm past the edge, at the right depth,
in step_1's region (`mapper.floor_sides`). Zig-zag stage stereo seeds 1-8: 249 unsafe cells,
142 with the true yaw, 108 with the true pose (`bench/unsafe_causes.py`).
"""

from __future__ import annotations

import argparse
import json
import os
from collections import defaultdict

import numpy as np
from trace_replay import parse_overrides

os.environ.setdefault("MUJOCO_GL", "egl")


def cast_boxes(origin, directions, objects):
    """Distance along each unit-speed ray to the first box or the ground z = 0, and what it hits.

    Args:
        origin: (3,) ray origin in the world [m].
        directions: (N, 3) ray directions in the world (any length; t scales with it).
        objects: The truth's `ObjectState` boxes (rough tops taken flat).

    Returns:
        (N,) t of the hit (inf: none), (N,) int index of the object hit (-1 ground, -2 none).
    """
    n = directions.shape[0]
    best = np.full(n, np.inf)
    hit = np.full(n, -2)
    with np.errstate(divide="ignore", invalid="ignore"):
        t_ground = -origin[2] / directions[:, 2]
    ok = (t_ground > 0) & np.isfinite(t_ground)
    best[ok] = t_ground[ok]
    hit[ok] = -1
    for k, obj in enumerate(objects):
        c, s = np.cos(obj.yaw_rad), np.sin(obj.yaw_rad)
        rot = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])  # world -> box
        centre = np.array([obj.center_xy[0], obj.center_xy[1], obj.base_m + obj.size[2] / 2])
        o = rot @ (origin - centre)
        d = directions @ rot.T
        half = np.asarray(obj.size) / 2
        with np.errstate(divide="ignore", invalid="ignore"):
            t1 = (-half - o) / d
            t2 = (half - o) / d
        t_near = np.nanmax(np.minimum(t1, t2), axis=1)
        t_far = np.nanmin(np.maximum(t1, t2), axis=1)
        good = (t_near <= t_far) & (t_near > 0) & (t_near < best)
        best[good] = t_near[good]
        hit[good] = k
    return best, hit


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("recording")
    parser.add_argument("--set", action="append", default=[])
    parser.add_argument("--cells", type=int, default=50)
    parser.add_argument("--json")
    parser.add_argument("--cell", action="append", default=[], help="IX,IY: trace this cell too")
    parser.add_argument("--maps", help="write the final maps here (fogsim's maps.npz)")
    parser.add_argument(
        "--pose",
        default="pipeline",
        help="the believed camera pose: pipeline, 'true yaw', 'true position' or 'true pose'"
        " (`bench/heading_oracle.py`'s modes; the heading estimator off but in pipeline)",
    )
    args = parser.parse_args()

    from fogsim.config.params import resolve_params
    from fogsim.data.recording import load_recording
    from fogsim.eval.maps import archive_maps
    from fogsim.mapping import pipeline as pipeline_module
    from fogsim.mapping import segmenter as segmenter_module
    from fogsim.run.runner import run_frames, sensor_fields
    from mapper.mapper import FloorObstacleMapper

    overrides = parse_overrides(args.set)
    rec = load_recording(args.recording)
    if args.pose != "pipeline":
        import dataclasses
        import sys
        from pathlib import Path

        sys.path.insert(0, str(Path(__file__).resolve().parent))
        from heading_oracle import MODES

        change = MODES[args.pose]
        overrides.setdefault("head.correct_heading", 0.0)
        rec = dataclasses.replace(rec, frames=[change(f) for f in rec.frames])
    segs = {}
    updates = []  # (frame index, points_world, floor_world)
    current = {"frame": -1}

    original_call = segmenter_module.FrameSegmenter.__call__

    def call(self, frame):
        seg = original_call(self, frame)
        segs[frame.index] = seg
        return seg

    original_map = pipeline_module.Pipeline._map

    def map_job(self, job):
        current["frame"] = job.data.frame.index
        return original_map(self, job)

    original_update = FloorObstacleMapper.update

    def update(self, points, floor, origin, *a, **k):
        updates.append((current["frame"], np.array(points), np.array(floor), np.array(origin)))
        return original_update(self, points, floor, origin, *a, **k)

    segmenter_module.FrameSegmenter.__call__ = call
    pipeline_module.Pipeline._map = map_job
    FloorObstacleMapper.update = update
    params = resolve_params(rec.scenario, overrides, sensor_fields(rec.scenario))
    result = run_frames(rec.frames, rec.truth_at, rec.scenario, params=params, segment_ahead=False)
    maps = archive_maps(result.archive, result.final_truth)
    if args.maps:
        from fogsim.eval.maps import save_maps

        save_maps(args.maps, maps)
    truth = maps.truth
    cell = maps.cell_m
    floor = maps.fog_types == 1
    off = (truth.labels == 1) & (np.abs(maps.fog_heights_m - truth.floor_m) > 0.02)
    unsafe = maps.visited & floor & ((truth.labels == 2) | off)
    frames = {f.index: f for f in rec.frames}
    report = []
    # Keep only the last mapping of each frame (a heading rebuild maps frames again).
    last_update = {}
    for i, u in enumerate(updates):
        last_update[u[0]] = i
    kept = [updates[i] for i in sorted(last_update.values())]
    cells = [tuple(c) for c in np.argwhere(unsafe)[: args.cells]]
    cells += [tuple(int(v) for v in c.split(",")) for c in args.cell]
    for ix, iy in cells:
        x, y = maps.cell_centers_xy[ix, iy]
        oid = truth.object_id[ix, iy]
        entry = {
            "cell": [int(ix), int(iy)],
            "xy": [round(float(x), 3), round(float(y), 3)],
            "truth": truth.object_names[oid] if oid >= 0 else "ground",
            "truth_floor_mm": float(truth.floor_m[ix, iy] * 1e3),
            "fog_mm": float(maps.fog_heights_m[ix, iy] * 1e3),
            "frames": [],
        }
        for index, points, floor_w, _origin in kept:
            inside = (
                (np.abs(points[:, 0] - x) <= cell / 2)
                & (np.abs(points[:, 1] - y) <= cell / 2)
                & np.isfinite(floor_w)
            )
            if not inside.any():
                continue
            seg = segs[index]
            frame = frames[index]
            pix = seg.pixel_index[inside]
            regions = seg.floor_ids[inside]
            rays = frame.intrinsics.ray_directions_camera().reshape(-1, 3)[pix]
            pose = frame.transform_camera_to_world_true
            dirs = rays @ pose[:3, :3].T
            t, hit = cast_boxes(pose[:3, 3], dirs, truth_objects(rec, frame))
            depth = frame.depth_m.reshape(-1)[pix]
            hit_xyz = pose[:3, 3] + t[:, None] * dirs
            # What the region's own pixels hit (its true surface) and its height.
            region_hits = {}
            all_rays = frame.intrinsics.ray_directions_camera().reshape(-1, 3)
            for r in set(int(v) for v in regions):
                rpix = seg.pixel_index[seg.floor_ids == r]
                _, rh = cast_boxes(
                    pose[:3, 3], all_rays[rpix] @ pose[:3, :3].T, truth_objects(rec, frame)
                )
                vals, cnt = np.unique(rh, return_counts=True)
                region_hits[r] = {
                    ("ground" if v == -1 else truth.object_names[v] if v >= 0 else "-"): int(c)
                    for v, c in zip(vals, cnt, strict=True)
                }
            names = [
                "ground" if h == -1 else (truth.object_names[h] if h >= 0 else "-") for h in hit
            ]
            w = frame.intrinsics.width
            entry["frames"].append(
                {
                    "frame": int(index),
                    "n": int(inside.sum()),
                    "floor_mm": [round(float(v) * 1e3, 1) for v in floor_w[inside]],
                    "region": [int(r) for r in regions],
                    "region_px": [int(seg.floors.pixel_counts[r]) for r in regions],
                    "uv": [[int(p % w), int(p // w)] for p in pix],
                    "depth_m": [round(float(v), 3) for v in depth],
                    "true_m": [round(float(v), 3) for v in t],
                    "true_hit": names,
                    "pt_xyz": [[round(float(c), 3) for c in q] for q in points[inside]],
                    "hit_xyz": [[round(float(c), 3) for c in h] for h in hit_xyz],
                    "meas_xyz": [
                        [round(float(c), 3) for c in q] for q in pose[:3, 3] + depth[:, None] * dirs
                    ],
                    "region_hits": {str(k): v for k, v in region_hits.items()},
                    "region_height_mm": {
                        str(r): round(float(seg.floors.heights_m[r]) * 1e3, 1) for r in region_hits
                    },
                }
            )
        report.append(entry)
    by_truth = defaultdict(int)
    for e in report:
        by_truth[e["truth"]] += 1
    print(json.dumps(dict(by_truth)), "unsafe", int(unsafe.sum()))
    for e in report:
        hits = defaultdict(int)
        for fr in e["frames"]:
            for h, fmm in zip(fr["true_hit"], fr["floor_mm"], strict=True):
                hits[(h, round(fmm / 10) * 10)] += 1
        print(
            e["cell"],
            e["xy"],
            e["truth"],
            f"true {e['truth_floor_mm']:.0f} fog {e['fog_mm']:.1f}",
            "frames",
            len(e["frames"]),
            dict(hits),
        )
    if args.json:
        with open(args.json, "w") as f:
            json.dump(report, f)


def truth_objects(rec, frame):
    """The boxes present at the frame's time."""
    return rec.truth_at(frame.time_s).objects


if __name__ == "__main__":
    main()
