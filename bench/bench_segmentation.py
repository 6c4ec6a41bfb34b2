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

Speed: median wall time of `segment_depth` over repeated calls on one noisy staircase frame,
88×72 and 176×144, numba on one thread (NUMBA_NUM_THREADS=1), after a warm-up call.

Run: ``.venv/bin/python bench/bench_segmentation.py [--repeats 300] [--seeds 5]``
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("NUMBA_NUM_THREADS", "1")
sys.path[:0] = [
    str(Path(__file__).resolve().parents[1]),
    str(Path(__file__).resolve().parents[1] / "tests"),
]

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


def speed(intrinsics: PinholeIntrinsics, repeats: int) -> tuple[float, float]:
    """Median and 90th percentile [ms] of segment_depth on a 1 %-noise staircase frame."""
    camera = look_down_camera((0.0, 0.0, 0.9), pitch_down_deg=30.0)
    scene = render_scene(intrinsics, camera, STAIRS)
    depth = add_depth_noise(scene.depth_m, 0.01, np.random.default_rng(0))
    segment_depth(depth, intrinsics, camera)  # compile / load the numba cache
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        segment_depth(depth, intrinsics, camera)
        times.append(time.perf_counter() - start)
    return 1e3 * float(np.median(times)), 1e3 * float(np.percentile(times, 90))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=300)
    parser.add_argument("--seeds", type=int, default=5)
    args = parser.parse_args()
    small = PinholeIntrinsics.from_fov(88, 72, 47.0, 39.0)
    large = PinholeIntrinsics.from_fov(176, 144, 47.0, 39.0)
    print(f"load average before: {os.getloadavg()}")
    for name, intrinsics in (("88x72", small), ("176x144", large)):
        median_ms, p90_ms = speed(intrinsics, args.repeats)
        print(f"speed {name}: median {median_ms:.2f} ms, p90 {p90_ms:.2f} ms per frame")
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
