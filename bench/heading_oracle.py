"""What a perfect heading would give: replays with the camera's true yaw against the pipeline's.

For each recording, two replays: ``pipeline`` (as ``fogsim run --replay``) and ``true yaw`` —
every frame's believed camera-to-robot transform turned about the vertical through the camera
centre by the yaw between it and the true camera pose in the *believed* robot frame (so the
odometry's yaw error is taken out too), with the heading estimator off (``head.correct_heading``
False). Everything else (tilt, height reference, z-match, the maps) runs as usual. The gap
between the two rows is the most any heading work can gain on those frames; a scenario whose
rows agree has its errors elsewhere.

Prints one line per recording and mode, then mean (worst) per mode: obstacle recall, floor
precision [%], unsafe cells, the worst Table I row [mm] and the residual heading [deg].

Usage::

    python bench/heading_oracle.py /work/rec/room_depth_s{1..8}.npz
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import statistics
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fogsim.config import resolve_params
from fogsim.data.frame import Frame
from fogsim.data.recording import load_recording
from fogsim.eval.pose_error import heading_error_deg
from fogsim.eval.report import build_report
from fogsim.eval.report.schema import Report
from fogsim.run.runner import run_frames, sensor_fields
from mapper.heading import yaw_about_pivot
from mapper.transforms import planar_pose_to_matrix


@dataclass(frozen=True)
class Figures:
    """The figures of one replay."""

    obstacle_recall_pct: float
    floor_precision_pct: float
    unsafe_cells: int
    worst_row_mm: float
    residual_heading_deg: float


def true_yaw_frame(frame: Frame) -> Frame:
    """The frame with its believed camera yaw replaced by the true one (module docstring)."""
    believed = np.asarray(frame.transform_camera_to_robot_believed, dtype=np.float64)
    true_in_believed_robot = (
        np.linalg.inv(planar_pose_to_matrix(frame.robot_pose_believed))
        @ frame.transform_camera_to_world_true
    )
    error_rad = math.radians(heading_error_deg(believed[:3, :3], true_in_believed_robot[:3, :3]))
    corrected = yaw_about_pivot(-error_rad, believed[:3, 3]) @ believed
    return dataclasses.replace(frame, transform_camera_to_robot_believed=corrected)


def figures(report: Report) -> Figures:
    """The figures of a replay's report (NaN where the report has none)."""
    classes = report.cells.fog.classes
    errors = [abs(row.error_mm) for row in report.table1.fog if row.error_mm is not None]
    heading = report.pose_error.residual_heading_deg
    return Figures(
        obstacle_recall_pct=100.0 * (classes.obstacle.recall or math.nan),
        floor_precision_pct=100.0 * (classes.floor.precision or math.nan),
        unsafe_cells=report.safety.unsafe_cells,
        worst_row_mm=max(errors, default=math.nan),
        residual_heading_deg=getattr(heading, "median", math.nan),
    )


def replay(path: Path, true_yaw: bool) -> Figures:
    """One replay of the recording at ``path`` (true yaw, heading estimator off, or as is)."""
    recording = load_recording(path)
    overrides = {"head.correct_heading": 0.0} if true_yaw else {}
    params = resolve_params(recording.scenario, overrides, sensor_fields(recording.scenario))
    frames = [true_yaw_frame(f) for f in recording.frames] if true_yaw else recording.frames
    result = run_frames(
        frames, recording.truth_at, recording.scenario, params=params, segment_ahead=False
    )
    return figures(build_report(result, recording.scenario, source="replay"))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("recordings", nargs="+", type=Path)
    args = parser.parse_args()
    rows: dict[str, list[Figures]] = {"pipeline": [], "true yaw": []}
    for path in args.recordings:
        for mode, rows_of_mode in rows.items():
            f = replay(path, true_yaw=mode == "true yaw")
            rows_of_mode.append(f)
            print(f"{path.name:28s} {mode:9s} {f}", flush=True)
    print("mean (worst): obstacle recall %, floor precision %, unsafe cells, worst row mm, heading")
    for mode, found in rows.items():
        recall = [f.obstacle_recall_pct for f in found]
        precision = [f.floor_precision_pct for f in found]
        unsafe = [f.unsafe_cells for f in found]
        row = [f.worst_row_mm for f in found]
        heading = [f.residual_heading_deg for f in found]
        print(
            f"{mode:9s} {statistics.mean(recall):.1f} ({min(recall):.1f})  "
            f"{statistics.mean(precision):.2f} ({min(precision):.2f})  "
            f"{statistics.mean(unsafe):.1f} ({max(unsafe)})  "
            f"{statistics.mean(row):.2f} ({max(row):.2f})  "
            f"{statistics.mean(heading):.2f} ({max(heading):.2f})"
        )


if __name__ == "__main__":
    main()
