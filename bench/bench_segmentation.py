"""Plane segmentation: quality on the noisy staircase and time per frame.

Quality: the paper's staircase (steps at 31, 61, 94 mm, platform at 122 mm, 0.2 m treads,
starting 1.2 m ahead) seen by the product camera (0.9 m high, looking down 25/30/35°
straight at it: "frontal"; or at 30° with yaw 20°/-30° and roll up to 5°: "oblique") with
Gaussian depth noise of 0 / 0.5 / 1 / 2 % of depth, several seeds. Reported per noise level:
share of true floor pixels that carry the right floor (floor-labelled, the floor region's
majority surface = the pixel's surface), median height error (all floor pixels; and steps/platform
only, the ground being pinned to 0 by the ground shift), 99th-percentile height error, the
worst share of a floor region's pixels from a second surface ("merge"; also over all level
regions, floor or not), pixels labelled floor that see no flat surface, and floor heights.

Speed: `segment_depth` on one thread (NUMBA_NUM_THREADS=1) after a warm-up call, as CPU time of
the calling thread (``time.thread_time``: on a loaded machine wall time counts the waits for a
core) and wall time: the median over ``--repeats`` calls on one 1 %-noise staircase frame,
88×72 and 176×144; and with ``--recording REC.npz`` (repeatable) on every frame of a recording
with the pipeline's own arguments (its believed camera transforms, the segmentation parameters
of its scenario and camera), each frame ``--frame-repeats`` times in rounds over the frames,
the fastest call of each frame counted: the median and mean over the frames.

``--tree DIR`` (repeatable) runs the speed part in a child process per tree (``PYTHONPATH`` =
the tree) ``--rounds`` times, the trees interleaved (A, B, A, B, ...) so the load hits them
alike, and prints each figure's median over the rounds and every round's value per tree.

Run: ``.venv/bin/python bench/bench_segmentation.py [--repeats 300] [--seeds 5]
[--recording REC.npz ...] [--speed-only] [--tree DIR --tree DIR --rounds 5]``
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

os.environ.setdefault("NUMBA_NUM_THREADS", "1")
TREE_VARIABLE = "SEGMENTATION_BENCH_TREE"
ROOT = Path(__file__).resolve().parents[1]
TREE = Path(os.environ.get(TREE_VARIABLE, ROOT))
"""The tree whose code is timed: this one, or a ``--tree`` of the parent (the synthetic scenes
always come from this tree's tests, so every tree segments the same frames)."""
sys.path[:0] = [str(TREE), str(ROOT / "tests")]

import numpy as np  # noqa: E402
from synthetic_depth import (  # noqa: E402
    add_depth_noise,
    floor_label_quality,
    look_down_camera,
    render_scene,
    staircase,
)

from mapper.intrinsics import PinholeIntrinsics  # noqa: E402
from mapper.segmentation import segment_depth  # noqa: E402

STAIRS = staircase()


FRONTAL = ((0.0, 0.0, 25.0, 0.0, 0.0), (0.0, 0.0, 30.0, 0.0, 0.0), (0.0, 0.0, 35.0, 0.0, 0.0))
"""Views (camera x [m], y [m], pitch down, yaw, roll [deg]) straight at the staircase."""
OBLIQUE = (
    (0.1, 0.2, 30.0, 20.0, 0.0),
    (0.1, 0.2, 30.0, 20.0, 5.0),
    (0.1, 0.2, 30.0, -30.0, -3.0),
    (0.1, 0.2, 30.0, 0.0, 5.0),
)
"""Views at an angle to the steps and with the camera rolled."""


def quality(
    intrinsics: PinholeIntrinsics, relative_noise: float, seeds: int, views=FRONTAL
) -> dict:
    """Quality figures over the views and ``seeds`` noise draws each."""
    rows = []
    for x_m, y_m, pitch, yaw, roll in views:
        camera = look_down_camera((x_m, y_m, 0.9), pitch, yaw_deg=yaw, roll_deg=roll)
        scene = render_scene(intrinsics, camera, STAIRS)
        for seed in range(seeds):
            depth = add_depth_noise(scene.depth_m, relative_noise, np.random.default_rng(seed))
            result = segment_depth(depth, intrinsics, camera)
            plane_image = result.labels_image("floor_region")
            heights = result.labels_image("floor")
            floor_planes = np.where(np.isfinite(heights), plane_image, -1)
            q_floor = floor_label_quality(scene, STAIRS, floor_planes, heights)
            q_all = floor_label_quality(scene, STAIRS, plane_image, heights)
            truth = scene.true_floor_height_m(STAIRS)
            errors = np.abs(heights - truth)[np.isfinite(heights) & np.isfinite(truth)]
            on_steps = np.isfinite(heights) & np.isfinite(truth) & (truth > 0.0)
            step_errors = np.abs(heights - truth)[on_steps]
            rows.append(
                (
                    q_floor.right_plane_fraction,
                    q_floor.median_height_error_m,
                    np.percentile(errors, 99),
                    q_floor.worst_merge_share,
                    q_all.worst_merge_share,
                    q_floor.false_floor_pixels,
                    np.sort(result.floors.heights_m[result.floors.is_floor]),
                    float(np.median(step_errors)) if step_errors.size else float("nan"),
                )
            )
    right = np.array([r[0] for r in rows])
    return {
        "frames": len(rows),
        "right_plane_min": right.min(),
        "right_plane_mean": right.mean(),
        "median_err_mm_max": 1e3 * max(r[1] for r in rows),
        "median_err_steps_only_mm_max": 1e3 * max(r[7] for r in rows),
        "p99_err_mm_median": 1e3 * float(np.median([r[2] for r in rows])),
        "floor_merge_max": max(r[3] for r in rows),
        "any_plane_merge_max": max(r[4] for r in rows),
        "false_floor_px_mean": float(np.mean([r[5] for r in rows])),
        "example_floor_heights_mm": np.round(1e3 * rows[0][6], 1).tolist(),
    }


def speed(intrinsics: PinholeIntrinsics, repeats: int) -> dict[str, float]:
    """Median thread CPU and wall time [ms] of segment_depth on a 1 %-noise staircase frame."""
    camera = look_down_camera((0.0, 0.0, 0.9), pitch_down_deg=30.0)
    scene = render_scene(intrinsics, camera, STAIRS)
    depth = add_depth_noise(scene.depth_m, 0.01, np.random.default_rng(0))
    segment_depth(depth, intrinsics, camera)  # compile / load the numba cache
    cpu, wall = [], []
    for _ in range(repeats):
        start_cpu, start = time.thread_time(), time.perf_counter()
        segment_depth(depth, intrinsics, camera)
        cpu.append(time.thread_time() - start_cpu)
        wall.append(time.perf_counter() - start)
    return {"cpu_ms": 1e3 * float(np.median(cpu)), "wall_ms": 1e3 * float(np.median(wall))}


def recording_speed(path: str, repeats: int) -> dict[str, float]:
    """Thread CPU time [ms] of segment_depth on every frame of a recording, as the pipeline
    calls it: the fastest of ``repeats`` calls per frame; median and mean over the frames."""
    from fogsim.config import resolve_params
    from fogsim.data.recording import load_recording
    from fogsim.mapping.segmenter import pipeline_segmentation_params
    from fogsim.run.runner import sensor_fields

    recording = load_recording(path)
    scenario = recording.scenario
    params = pipeline_segmentation_params(resolve_params(scenario, None, sensor_fields(scenario)))
    calls = [
        (frame.depth_m, frame.intrinsics, frame.transform_camera_to_robot_believed, params)
        for frame in recording.frames
    ]
    segment_depth(*calls[0])
    best = np.full(len(calls), np.inf)
    for _ in range(repeats):
        for i, call in enumerate(calls):
            start = time.thread_time()
            segment_depth(*call)
            best[i] = min(best[i], time.thread_time() - start)
    return {"median_ms": 1e3 * float(np.median(best)), "mean_ms": 1e3 * float(np.mean(best))}


def speed_figures(args: argparse.Namespace) -> dict[str, float]:
    """Every speed figure of this tree: name → milliseconds."""
    small = PinholeIntrinsics.from_fov(88, 72, 47.0, 39.0)
    large = PinholeIntrinsics.from_fov(176, 144, 47.0, 39.0)
    figures = {}
    for name, intrinsics in (("88x72", small), ("176x144", large)):
        for kind, value in speed(intrinsics, args.repeats).items():
            figures[f"staircase {name} {kind}"] = value
    for path in args.recording:
        for kind, value in recording_speed(path, args.frame_repeats).items():
            figures[f"{Path(path).stem} cpu {kind}"] = value
    return figures


def interleaved(args: argparse.Namespace) -> None:
    """The speed figures of every ``--tree``, ``--rounds`` child runs each, interleaved."""
    command = [sys.executable, str(Path(__file__).resolve()), "--speed-only", "--json"]
    command += ["--repeats", str(args.repeats), "--frame-repeats", str(args.frame_repeats)]
    for path in args.recording:
        command += ["--recording", path]
    values: dict[str, list[dict[str, float]]] = {str(tree): [] for tree in args.tree}
    print(f"load average before: {os.getloadavg()}")
    for _ in range(args.rounds):
        for tree in args.tree:
            env = {**os.environ, "PYTHONPATH": str(tree), TREE_VARIABLE: str(tree)}
            child = subprocess.run(
                command, env=env, cwd=tree, check=True, capture_output=True, text=True
            )
            values[str(tree)].append(json.loads(child.stdout.splitlines()[-1]))
    print(f"load average after: {os.getloadavg()}")
    for tree, rounds in values.items():
        print(tree)
        for name in rounds[0]:
            column = [r[name] for r in rounds]
            listed = " ".join(f"{v:.3f}" for v in column)
            print(f"  {name}: median {np.median(column):.3f} ms ({listed})")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=300)
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--recording", action="append", default=[], help="time its frames too")
    parser.add_argument("--frame-repeats", type=int, default=3, help="calls per recorded frame")
    parser.add_argument("--speed-only", action="store_true", help="no quality figures")
    parser.add_argument("--tree", type=Path, action="append", help="interleaved A/B (children)")
    parser.add_argument("--rounds", type=int, default=5, help="child runs per --tree")
    parser.add_argument("--json", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.tree:
        interleaved(args)
        return
    if args.json:
        print(json.dumps(speed_figures(args)))
        return
    print(f"load average before: {os.getloadavg()}")
    for name, value in speed_figures(args).items():
        print(f"speed {name}: {value:.3f} ms per frame")
    if not args.speed_only:
        small = PinholeIntrinsics.from_fov(88, 72, 47.0, 39.0)
        large = PinholeIntrinsics.from_fov(176, 144, 47.0, 39.0)
        for name, intrinsics in (("88x72", small), ("176x144", large)):
            for views_name, views in (("frontal", FRONTAL), ("oblique", OBLIQUE)):
                for noise in (0.0, 0.005, 0.01, 0.02):
                    figures = quality(intrinsics, noise, args.seeds if noise > 0 else 1, views)
                    text = ", ".join(
                        f"{k} {v:.3f}" if isinstance(v, float) else f"{k} {v}"
                        for k, v in figures.items()
                    )
                    print(f"quality {name} {views_name} noise {100 * noise:.1f}%: {text}")
    print(f"load average after: {os.getloadavg()}")


if __name__ == "__main__":
    main()
