"""Trace, frame by frame, where a replay's floor heights leave the truth and which stage moves them.

Usage:
    PYTHONPATH=. python bench/zlock_trace.py REC.npz [--set KEY=VALUE ...]
        [--probe NAME=X,Y ...] [--every N] [--tilt-oracle]

Replays the recording in line (no second thread) and prints one line per frame mapped (a
frame mapped again in a heading rebuild is printed again), in the order the pipeline maps them:

- ``pos``: the frame's place in the run; ``x``: the robot's true x [m];
- ``zt / zb / zmap``: the robot's true, odometry's and the mapped elevation [mm] (the elevation
  filter's, or the start surface's, before the z-match);
- ``off``: the elevation filter's offset before > after the frame [mm];
- ``tilt``: the frame's applied tilt minus the true one (pitch about the robot's y, roll about
  its x) [deg], after the tilt filter;
- ``ref``: the height reference's shift of the frame [mm], its own ground measurement [mm]
  (``-``: none) and whether it agreed with the estimate (``a``);
- ``zm``: the z-match's shift [mm] / pairs kept / accepted (``-``: not z-matched: deferred,
  on the start surface, or the match is off), then ``M`` when the shift was applied and ``W``
  when the frame was withdrawn;
- the FOG map's floor height [mm] at each ``--probe`` point after the frame (NaN: none).

``--tilt-oracle`` replaces the tilt filter's estimate by the true tilt (the believed camera
rotation against the true one), to see what is left without the tilt's error.

Session 38, ``talos_course`` stereo seeds 5 and 6 (every Table I row −29 / −53 mm): with the
true tilt both map within 3.1 mm. Seed 5: the tilt filter's pitch is +0.8…+1.0° off over frames
~90-200 (its measurements biased by the narrow threshold top and ground strips, whose far and
near border rows blend with the surfaces behind and in front); step_1 and step_2, first seen from
1.7-1.9 m, go into the map about 30 mm low; from then on every frame that sees them is z-matched
by −20…−30 mm onto them (accepted: ``zmatch_max_shift_m`` 80 mm), so the frames standing on the
steps, tilt and elevation right, are put into the map 25-30 mm low and the map stays there.
Seed 6: from the start pose the stereo ground region takes in the threshold top (about 260
pixels a frame, 40 mm) and part of step_1; frames from x ≈ 0.9 m on see mostly the threshold,
its cells hold the ground's height, and the z-match shifts them by −25…−53 mm onto it, taking
every surface seen after it down by about 45 mm.
"""

from __future__ import annotations

import argparse
import math
import os

import numpy as np
from trace_replay import parse_overrides, replay_traced

os.environ.setdefault("MUJOCO_GL", "egl")


def tilt_error_deg(
    transform_camera_to_robot, transform_camera_to_world_true
) -> tuple[float, float]:
    """The applied tilt minus the true one: (pitch, roll) [deg] in the tilt-corrected robot frame.

    The robot frame R is level with the world (yaw only), so the true vertical seen from the
    corrected frame is ``R_c · R_tᵀ · z``; its (x, y) are the tilts left (small angles).

    Args:
        transform_camera_to_robot: 4×4 tilt-corrected camera pose in the robot frame.
        transform_camera_to_world_true: 4×4 true camera pose in the world.
    """
    corrected = np.asarray(transform_camera_to_robot, dtype=np.float64)[:3, :3]
    true = np.asarray(transform_camera_to_world_true, dtype=np.float64)[:3, :3]
    up = corrected @ (true.T @ np.array([0.0, 0.0, 1.0]))
    return math.degrees(math.asin(-up[0])), math.degrees(math.asin(-up[1]))


def true_tilt_rad(frame) -> np.ndarray:
    """The true ground normal's (x, y) in the believed robot frame [rad] (the tilt filter's)."""
    believed = np.asarray(frame.transform_camera_to_robot_believed, dtype=np.float64)[:3, :3]
    true = np.asarray(frame.transform_camera_to_world_true, dtype=np.float64)[:3, :3]
    return (believed @ (true.T @ np.array([0.0, 0.0, 1.0])))[:2].copy()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("recording")
    parser.add_argument("--set", action="append", default=[], help="KEY=VALUE override")
    parser.add_argument("--probe", action="append", default=[], help="NAME=X,Y world [m]")
    parser.add_argument("--every", type=int, default=1, help="print every Nth frame mapped")
    parser.add_argument("--tilt-oracle", action="store_true", help="apply the true tilt")
    args = parser.parse_args()

    import fogsim.mapping.segmenter as segmenter
    from fogsim.data.recording import load_recording
    from mapper.tilt_filter import apply_tilt

    overrides = parse_overrides(args.set)
    probes = {}
    for item in args.probe:
        name, xy = item.split("=", 1)
        x_m, y_m = (float(v) for v in xy.split(","))
        probes[name] = (x_m, y_m)
    if args.tilt_oracle:
        segmenter.FrameSegmenter._filtered_tilt = lambda self, seg, frame: apply_tilt(
            seg, true_tilt_rad(frame)
        )

    mapped = [0]

    def traced_map(self, job, plain_map):
        seen = {}
        match_z = self.mapper.match_z

        def recording_match(points, floors):
            seen["match"] = match = match_z(points, floors)
            return match

        self.mapper.match_z = recording_match
        offset_before = self.elevation.offset_m
        zmap = self.robot_pose(job.data.frame)[2]
        outcome = plain_map(self, job)
        self.mapper.match_z = match_z
        mapped[0] += 1
        if (mapped[0] - 1) % args.every:
            return outcome
        frame = job.data.frame
        pitch, roll = tilt_error_deg(
            job.data.transform_camera_to_robot, frame.transform_camera_to_world_true
        )
        own = job.data.measured_shift_m
        match = seen.get("match")
        z_true, z_odometry = frame.robot_pose_true[2], frame.robot_pose_believed[2]
        offset_after = self.elevation.offset_m
        line = (
            f"{job.data.position:4d} x={frame.robot_pose_true[0]:5.2f}"
            f" zt={1e3 * z_true:+6.1f} zb={1e3 * z_odometry:+6.1f} zmap={1e3 * zmap:+6.1f}"
            f" off={1e3 * offset_before:+5.1f}>{1e3 * offset_after:+5.1f}"
            f" tilt={pitch:+5.2f},{roll:+5.2f}"
            f" ref={1e3 * job.shift_m:+5.1f}/{'  -  ' if own is None else f'{1e3 * own:+5.1f}'}"
            f"{'a' if job.agrees else ' '}"
        )
        if match is None:
            line += " zm=      -      "
        else:
            line += f" zm={1e3 * match.shift_m:+6.1f}/{match.pairs:4d}/{int(match.accepted)}"
        line += f" {'M' if outcome.z_matched else ' '}{'W' if outcome.withdrawn else ' '} |"
        for name, (x_m, y_m) in probes.items():
            line += f" {name}={1e3 * self.mapper.floor_at(x_m, y_m):+6.1f}"
        print(line, flush=True)
        return outcome

    replay_traced(load_recording(args.recording), overrides, traced_map)


if __name__ == "__main__":
    main()
