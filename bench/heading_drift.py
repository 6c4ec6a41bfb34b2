"""Odometry's yaw drift against the heading correction: robot-frame and world-frame yaw errors.

For each recording, one replay (the defaults, or ``--set`` overrides); per frame (signed, deg):

* ``odo``: odometry's yaw error, believed − true robot yaw;
* ``robot``: the yaw between the corrected camera pose and the true one in the robot frame (as
  the frame was last mapped: `fogsim.eval.pose_error`'s ``map_heading_deg``, signed);
* ``world``: the same in the world, the corrected camera pose through the *believed* robot
  pose against the true camera pose in the world: what the map, built in the odometry frame
  and scored against the true world, holds (``world ≈ robot + odo``).

One line per recording: odometry's yaw error at the first and last frame and its range
(max − min: the drift), the medians over frames of |robot| and |world| (as last mapped),
``const``: the median |world − median(world)| (what the best *constant* world-frame
correction would leave: the part of the world error only a drifting correction removes), and
the world error's first and last values. Then mean (worst) per scenario_mode.

With ``--odometry`` no replay: from the recordings' poses alone, odometry's yaw error at the
last frame, its range, the median |error − median(error)| (what the best constant leaves) and
the distance walked (true, [m]); then mean (worst) per scenario_mode.

Session 38, every recording (depth and stereo share their trajectories): odometry's yaw error
ranges over a run by at most 1.18° (stage, stage_down, zig-zag: 0.70–0.77° mean over seeds;
room, stairs, talos course 0.34–0.38°; table 0.24°; the standing moving_box and box_removal
0.71–0.74°), and the best constant leaves a median of at most 0.34° (zig-zag seed; 0.05–0.16°
mean per scenario): the drift a correction could follow is a fraction of the estimator's own
±0.5–1° (`mapper.heading.HeadingParams.noise_band`).

Replays (session 38), every 10 % of the frames: stage stereo seed 7, odometry 0 → +1.07°, the
robot-frame residual scattering −1.64…+0.66° with the estimates, the world one −0.95…+1.47°
(median |.| 0.72° robot, 0.42° world); with `head.drift_deg_per_m` 0.6 1.57° and 1.16°. The
zig-zag depth seed 1: odometry 0 → +0.79°, residual −1.89…+1.12° (0.79° robot, 0.55° world),
with the drift model 1.42° and 1.49°.

Usage::

    python bench/heading_drift.py [--set KEY=VALUE ...] [--workers 2] /work/rec/room_depth_s3.npz
    python bench/heading_drift.py --odometry /work/rec/*_s[1-8].npz
"""

from __future__ import annotations

import math
import os
import sys
from collections import defaultdict
from multiprocessing import Pool
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from heading_trace import overrides_of, recordings_parser

from fogsim.config import resolve_params
from fogsim.data.recording import load_recording
from fogsim.eval.pose_error import heading_error_deg
from fogsim.run.runner import run_frames, sensor_fields
from mapper.transforms import planar_pose_to_matrix

os.environ.setdefault("MUJOCO_GL", "egl")

FIELDS = (
    "odo_first",
    "odo_last",
    "odo_range",
    "robot",
    "world",
    "const",
    "world_first",
    "world_last",
)


def wrap_deg(angle_rad: float) -> float:
    """An angle [rad] as degrees in (−180, 180]."""
    return math.degrees(math.atan2(math.sin(angle_rad), math.cos(angle_rad)))


def per_frame(path: Path, overrides: dict[str, object]) -> dict[str, np.ndarray]:
    """The signed per-frame yaw errors [deg] of one replay (module docstring)."""
    recording = load_recording(path)
    params = resolve_params(recording.scenario, overrides, sensor_fields(recording.scenario))
    rows: list[tuple[float, np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = []
    held = {}

    def note(frame, pipeline) -> None:
        held["pipeline"] = pipeline
        pose_true = np.asarray(frame.robot_pose_true, dtype=np.float64)
        pose_believed = np.asarray(frame.robot_pose_believed, dtype=np.float64)
        world_true = np.asarray(frame.transform_camera_to_world_true, dtype=np.float64)
        if not (np.isfinite(pose_true).all() and np.isfinite(world_true).all()):
            rows.append(None)
            return
        rows.append(
            (
                wrap_deg(pose_believed[3] - pose_true[3]),
                np.array(pipeline.heading.transform_camera_to_robot),
                np.linalg.inv(planar_pose_to_matrix(pose_true)) @ world_true,
                planar_pose_to_matrix(pose_believed),
                world_true,
            )
        )

    run_frames(
        recording.frames, recording.truth_at, recording.scenario, params=params, on_frame=note
    )
    last = {late.position: late.transform_camera_to_robot for late in held["pipeline"].mapped_late}
    odo, robot, world = [], [], []
    for position, row in enumerate(rows):
        if row is None:
            continue
        odo_deg, corrected, true_in_robot, robot_believed, world_true = row
        corrected = last.get(position, corrected)
        odo.append(odo_deg)
        robot.append(heading_error_deg(corrected[:3, :3], true_in_robot[:3, :3]))
        world.append(heading_error_deg((robot_believed @ corrected)[:3, :3], world_true[:3, :3]))
    return {"odo": np.array(odo), "robot": np.array(robot), "world": np.array(world)}


def summary(path: Path, overrides: dict[str, object]) -> tuple[str, dict[str, float]]:
    """One recording's figures (module docstring)."""
    e = per_frame(path, overrides)
    world = e["world"]
    return path.stem, {
        "odo_first": float(e["odo"][0]),
        "odo_last": float(e["odo"][-1]),
        "odo_range": float(np.ptp(e["odo"])),
        "robot": float(np.median(np.abs(e["robot"]))),
        "world": float(np.median(np.abs(world))),
        "const": float(np.median(np.abs(world - np.median(world)))),
        "world_first": float(world[0]),
        "world_last": float(world[-1]),
    }


def odometry_only(paths: list[Path]) -> None:
    """Print odometry's yaw error figures of the recordings, no replay (module docstring)."""
    groups: dict[str, list[tuple[float, ...]]] = defaultdict(list)
    for path in paths:
        errors, walked, previous = [], 0.0, None
        for frame in load_recording(path).frames:
            believed = np.asarray(frame.robot_pose_believed, dtype=np.float64)
            true = np.asarray(frame.robot_pose_true, dtype=np.float64)
            if not np.isfinite(true).all():
                continue
            errors.append(wrap_deg(believed[3] - true[3]))
            if previous is not None:
                walked += math.hypot(*(true[:2] - previous[:2]))
            previous = true
        e = np.array(errors)
        row = (e[-1], np.ptp(e), np.median(np.abs(e - np.median(e))), walked)
        print(
            f"{path.stem:24s} last {row[0]:+.2f} range {row[1]:.2f} const {row[2]:.2f} "
            f"walked {row[3]:.1f} m",
            flush=True,
        )
        groups[path.stem.rsplit("_s", 1)[0]].append(row)
    print("mean (worst) per scenario_mode: last, range, const, walked")
    for group, rows in groups.items():
        v = np.array(rows)
        worst_last = v[np.argmax(np.abs(v[:, 0])), 0]
        print(
            f"{group:22s} last {v[:, 0].mean():+.2f} ({worst_last:+.2f})  range "
            f"{v[:, 1].mean():.2f} ({v[:, 1].max():.2f})  const {v[:, 2].mean():.2f} "
            f"({v[:, 2].max():.2f})  walked {v[:, 3].mean():.1f}"
        )


def main() -> None:
    parser = recordings_parser(__doc__)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--odometry", action="store_true", help="poses only, no replay")
    args = parser.parse_args()
    if args.odometry:
        odometry_only(args.recordings)
        return
    overrides = overrides_of(args.set)
    groups: dict[str, list[dict[str, float]]] = defaultdict(list)
    print("recording".ljust(24) + "".join(f"{f:>12}" for f in FIELDS), flush=True)
    with Pool(args.workers) as pool:
        jobs = [(p, overrides) for p in args.recordings]
        for name, figures in pool.starmap(summary, jobs):
            print(name.ljust(24) + "".join(f"{figures[f]:+12.2f}" for f in FIELDS), flush=True)
            groups[name.rsplit("_s", 1)[0]].append(figures)
    print("mean (worst |.|) per scenario_mode")
    for group, rows in groups.items():
        cells = []
        for f in FIELDS:
            values = np.array([r[f] for r in rows])
            cells.append(f"{values.mean():+6.2f} ({values[np.argmax(np.abs(values))]:+5.2f})")
        print(group.ljust(24) + "".join(f"{c:>16}" for c in cells))


if __name__ == "__main__":
    main()
