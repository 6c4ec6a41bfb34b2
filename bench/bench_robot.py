"""Per-frame robot kinematics cost: leg IK, FK of readings, odometry, self-filter.

Run: .venv/bin/python bench/bench_robot.py [--repeats 7]
Prints the median (and min) time per frame of each part, pinocchio parts separately, with
MuJoCo's forward kinematics of the same robot as a peer for pinocchio's.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
os.environ.setdefault("MUJOCO_GL", "egl")

import mujoco

from fogsim.robot import EncoderModel, Odometry, SelfFilter, load_robot, plan_route
from mapper.intrinsics import PinholeIntrinsics


def stage_support(xy: np.ndarray) -> np.ndarray:
    x = np.asarray(xy, dtype=float)[:, 0]
    h = np.zeros(x.size)
    h = np.where((x >= 1.15) & (x <= 1.25), 0.038, h)
    for k, z in enumerate((0.031, 0.061, 0.092)):
        h = np.where((x >= 2.6 + 0.2 * k) & (x < 2.8 + 0.2 * k), z, h)
    return np.where((x >= 3.2) & (x <= 4.0), 0.122, h)


def per_frame_us(function, frames: int, repeats: int) -> tuple[float, float]:
    """Median and min over repeats of the time per frame [µs]."""
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        function()
        times.append((time.perf_counter() - start) / frames * 1e6)
    return float(np.median(times)), float(np.min(times))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--robot", default="icub")
    args = parser.parse_args()
    robot = load_robot(args.robot)
    route = [{"walk_to": (2.0, 0.5)}, {"walk_to": (3.6, 0.5)}]
    traj = plan_route(robot, (0.3, 0.5, 0.0), route, stage_support, 12.5)
    frames = traj.frame_count
    rows: list[tuple[str, float, float]] = []

    rows.append(
        (
            "plan_route (footsteps + leg IK + head), whole stage walk",
            *per_frame_us(
                lambda: plan_route(robot, (0.3, 0.5, 0.0), route, stage_support, 12.5),
                frames,
                args.repeats,
            ),
        )
    )
    encoders = EncoderModel(0.5, 0.2, np.random.default_rng(0))
    readings = np.stack([encoders.read(q) for q in traj.q])
    rows.append(
        (
            "EncoderModel.read",
            *per_frame_us(lambda: [encoders.read(q) for q in traj.q], frames, args.repeats),
        )
    )

    def fk_readings() -> None:
        for r, ref in zip(readings, traj.reference_foot, strict=True):
            robot.transform_camera_to_robot(r, ref)

    rows.append(
        (
            "pinocchio FK of readings -> camera in R",
            *per_frame_us(fk_readings, frames, args.repeats),
        )
    )

    def odometry() -> None:
        odo = Odometry(robot, traj.robot_pose_true[0], readings[0], traj.stance[0])
        for r, stance in zip(readings, traj.stance, strict=True):
            odo.update(r, stance)

    rows.append(("pinocchio odometry update", *per_frame_us(odometry, frames, args.repeats)))

    model = mujoco.MjModel.from_xml_path(str(robot.mjcf_path))
    data = mujoco.MjData(model)
    qpos = np.stack([robot.qpos_mujoco(q) for q in traj.q])

    def mujoco_fk() -> None:
        for row in qpos:
            data.qpos[:] = row
            mujoco.mj_kinematics(model, data)

    rows.append(
        ("peer: MuJoCo mj_kinematics (all bodies)", *per_frame_us(mujoco_fk, frames, args.repeats))
    )

    # self-filter on an 88x72 depth image of the floor seen from the walking pose
    width, height = 88, 72
    focal = 0.5 * height / math.tan(math.radians(39.0) / 2)
    intrinsics = PinholeIntrinsics(width, height, focal, focal, (width - 1) / 2, (height - 1) / 2)
    rays = intrinsics.ray_directions_camera()
    self_filter = SelfFilter(robot)
    transforms = [
        robot.transform_camera_to_robot(r, ref)
        for r, ref in zip(readings, traj.reference_foot, strict=True)
    ]
    depths = []
    for t in transforms:  # depth of the ground plane z_R = 0, NaN above the horizon
        dz = rays @ t[2, :3]
        with np.errstate(divide="ignore", invalid="ignore"):
            d = np.where(dz < -1e-6, -t[2, 3] / dz, np.nan)
        depths.append(d.astype(np.float32))
    self_filter.mask(depths[0], intrinsics, readings[0], transforms[0])  # numba compile

    def boxes() -> None:
        for r in readings:
            self_filter.boxes_in_camera(r)

    def mask() -> None:
        for d, r, t in zip(depths, readings, transforms, strict=True):
            self_filter.mask(d, intrinsics, r, t)

    rows.append(
        (
            "self-filter boxes (MuJoCo FK of readings + 28 boxes)",
            *per_frame_us(boxes, frames, args.repeats),
        )
    )
    rows.append(("self-filter mask 88x72 (incl. boxes)", *per_frame_us(mask, frames, args.repeats)))

    print(
        f"robot={args.robot} frames={frames} repeats={args.repeats} (other jobs may share the CPU)"
    )
    print(f"{'part':58s} {'median µs/frame':>16s} {'min':>8s}")
    for name, median, minimum in rows:
        print(f"{name:58s} {median:16.1f} {minimum:8.1f}")


if __name__ == "__main__":
    main()
