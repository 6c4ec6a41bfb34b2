"""What a true heading or camera pose would give: replays with it beside the pipeline's.

For each recording, one replay per mode (``--modes``, default all):

* ``pipeline``: as ``fogsim run --replay``;
* ``true yaw``: every frame's believed camera-to-robot transform turned about the vertical
  through the camera centre by the yaw between it and the true camera pose in the *believed*
  robot frame (so the odometry's yaw error is taken out too);
* ``true neck yaw``: as ``true yaw`` but against the true camera pose in the *true* robot frame:
  the camera's own (neck) yaw error taken out, odometry's yaw error left in (a heading
  correction exact in the robot frame, ``map_heading_deg`` 0; ``true yaw`` is exact in the
  world, ``world_heading_deg`` 0);
* ``true position``: the camera's position made the true one in the believed robot frame, its
  believed rotation kept;
* ``true pose``: the whole transform replaced by the true camera pose in the believed robot
  frame (the camera lands where it truly was: every encoder and odometry error taken out);
* ``true xy``: the robot's believed (x, y) replaced by the true one, its yaw, z and the
  camera's encoders as believed, the heading estimator on: what taking out odometry's
  horizontal drift alone would give (its yaw error, integrated over the walk, drifts the robot
  2–3 cm sideways by the stage's platform: session 48);
* ``true tilt``: the frames as recorded, but each frame's segmentation turned by the camera's
  true tilt in the believed robot frame instead of the tilt filter's estimate
  (`fogsim.mapping.segmenter.FrameSegmenter`; the heading estimator on): what the tilt
  filter's error costs. Unlike ``true pose`` (whose frames still go through the tilt filter,
  which then estimates the tilt left over from the scene, with its own error) it takes out the
  applied tilt's whole error and nothing else.

The heading estimator is off (``head.correct_heading`` False) in every mode but ``pipeline``,
``true xy`` and ``true tilt``;
everything else (tilt, height reference, z-match, the maps) runs as usual. The gap between
``pipeline`` and ``true yaw`` is the most any heading work can gain on those frames; between
``true yaw`` and ``true pose``, what the camera's position and tilt errors still cost; a
scenario whose ``true pose`` row is still short has its errors in the sensing or the map, not
the pose (moving_box, depth seeds 1-8, where the standing robot sees nothing static but the
ground, so its camera's x, y and yaw cannot be estimated from the scene: README "Known
limitations").

Prints one line per recording and mode, then mean (worst) per mode: obstacle recall, floor
precision [%], unsafe cells, the worst Table I row [mm], the mean |error| of the Table I rows
[mm] and the residual heading [deg].

Session 53, held-out stereo (``fogsim record scenarios/holdout/SCENE.toml --seed N
--camera-mode stereo``, seeds 1–8): README "Known limitations", "Stereo's tilt".

Usage::

    python bench/heading_oracle.py /work/rec/room_depth_s{1..8}.npz
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import statistics
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from zlock_trace import true_tilt_rad

import fogsim.mapping.segmenter as segmenter
from fogsim.config import resolve_params
from fogsim.data.frame import Frame
from fogsim.data.recording import load_recording
from fogsim.eval.pose_error import heading_error_deg
from fogsim.eval.report import build_report
from fogsim.eval.report.schema import Report
from fogsim.run.runner import run_frames, sensor_fields
from mapper.heading import yaw_about_pivot
from mapper.segmentation import SegmentationResult
from mapper.tilt_filter import apply_tilt
from mapper.transforms import planar_pose_to_matrix


@dataclass(frozen=True)
class Figures:
    """The figures of one replay."""

    obstacle_recall_pct: float
    floor_precision_pct: float
    unsafe_cells: int
    worst_row_mm: float
    mean_row_mm: float
    residual_heading_deg: float


def true_yaw_frame(frame: Frame) -> Frame:
    """The frame with its believed camera yaw replaced by the true one (module docstring)."""
    return _yaw_made_true(frame, frame.robot_pose_believed)


def true_neck_yaw_frame(frame: Frame) -> Frame:
    """The frame with its believed camera yaw in the robot frame made the true one."""
    return _yaw_made_true(frame, frame.robot_pose_true)


def _yaw_made_true(frame: Frame, robot_pose) -> Frame:
    """The frame's believed camera turned about its centre to the true camera's yaw as seen
    from ``robot_pose`` (the believed one: exact in the world; the true one: in the robot)."""
    believed = np.asarray(frame.transform_camera_to_robot_believed, dtype=np.float64)
    true_in_robot = np.linalg.inv(planar_pose_to_matrix(robot_pose)) @ (
        frame.transform_camera_to_world_true
    )
    error_rad = math.radians(heading_error_deg(believed[:3, :3], true_in_robot[:3, :3]))
    corrected = yaw_about_pivot(-error_rad, believed[:3, 3]) @ believed
    return dataclasses.replace(frame, transform_camera_to_robot_believed=corrected)


def true_pose_frame(frame: Frame) -> Frame:
    """The frame with its believed camera pose replaced by the true one (module docstring)."""
    true_in_believed_robot = (
        np.linalg.inv(planar_pose_to_matrix(frame.robot_pose_believed))
        @ frame.transform_camera_to_world_true
    )
    return dataclasses.replace(frame, transform_camera_to_robot_believed=true_in_believed_robot)


def true_position_frame(frame: Frame) -> Frame:
    """The frame with its believed camera position replaced by the true one, rotation kept."""
    believed = np.array(frame.transform_camera_to_robot_believed, dtype=np.float64)
    believed[:3, 3] = true_pose_frame(frame).transform_camera_to_robot_believed[:3, 3]
    return dataclasses.replace(frame, transform_camera_to_robot_believed=believed)


def true_xy_frame(frame: Frame) -> Frame:
    """The frame with the robot's believed (x, y) replaced by the true one, the rest kept."""
    pose = np.array(frame.robot_pose_believed, dtype=np.float64)
    pose[:2] = np.asarray(frame.robot_pose_true, dtype=np.float64)[:2]
    return dataclasses.replace(frame, robot_pose_believed=pose)


MODES = {
    "pipeline": None,
    "true yaw": true_yaw_frame,
    "true neck yaw": true_neck_yaw_frame,
    "true position": true_position_frame,
    "true pose": true_pose_frame,
    "true xy": true_xy_frame,
}
"""Replay modes: how each frame's believed camera pose is changed (None: as recorded)."""
TILT_MODES = ("true tilt",)
"""Modes that change the segmenter instead of the frames: the true tilt applied."""
ALL_MODES = (*MODES, *TILT_MODES)
"""Every mode ``--modes`` takes."""
HEADING_MODES = ("pipeline", "true xy")
"""The frame modes that keep the heading estimator on (the others give it the true yaw or
pose); the tilt modes keep it on too."""


def figures(report: Report) -> Figures:
    """The figures of a replay's report (NaN where the report has none)."""
    classes = report.cells.fog.classes
    errors = [abs(row.error_mm) for row in report.table1.fog if row.error_mm is not None]
    heading = report.pose_error.residual_heading_deg
    return Figures(
        obstacle_recall_pct=_percent(classes.obstacle.recall),
        floor_precision_pct=_percent(classes.floor.precision),
        unsafe_cells=report.safety.unsafe_cells,
        worst_row_mm=max(errors, default=math.nan),
        mean_row_mm=statistics.mean(errors) if errors else math.nan,
        residual_heading_deg=getattr(heading, "median", math.nan),
    )


def _percent(value: float | None) -> float:
    """A fraction in percent, NaN for none (no cell to count); 0 stays 0."""
    return math.nan if value is None else 100.0 * value


def replay(path: Path, mode: str) -> Figures:
    """One replay of the recording at ``path`` in a :data:`MODES` mode.

    Raises:
        ValueError: An unknown mode (the known ones are named).
    """
    if mode not in ALL_MODES:
        raise ValueError(f"unknown mode {mode!r}; modes: {', '.join(ALL_MODES)}")
    change = MODES.get(mode)
    recording = load_recording(path)
    heading_on = mode in HEADING_MODES or mode in TILT_MODES
    overrides = {} if heading_on else {"head.correct_heading": 0.0}
    params = resolve_params(recording.scenario, overrides, sensor_fields(recording.scenario))
    frames = [change(f) for f in recording.frames] if change is not None else recording.frames
    filtered_tilt = segmenter.FrameSegmenter._filtered_tilt
    if mode in TILT_MODES:  # segmented in line (segment_ahead False): this process's class
        segmenter.FrameSegmenter._filtered_tilt = _true_tilt
    try:
        result = run_frames(
            frames, recording.truth_at, recording.scenario, params=params, segment_ahead=False
        )
    finally:
        segmenter.FrameSegmenter._filtered_tilt = filtered_tilt
    return figures(build_report(result, recording.scenario, source="replay"))


def _true_tilt(
    _segmenter: segmenter.FrameSegmenter, seg: SegmentationResult, frame: Frame
) -> SegmentationResult:
    """`FrameSegmenter._filtered_tilt` with the camera's true tilt instead of the filter's."""
    return apply_tilt(seg, true_tilt_rad(frame))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("recordings", nargs="+", type=Path)
    parser.add_argument(
        "--modes",
        default=",".join(ALL_MODES),
        help=f"comma-separated replay modes, of: {', '.join(ALL_MODES)} (default: all)",
    )
    args = parser.parse_args()
    modes = [m.strip() for m in args.modes.split(",") if m.strip()]
    unknown = [m for m in modes if m not in ALL_MODES]
    if unknown or not modes:
        parser.error(f"--modes: unknown {unknown or 'empty'}; modes: {', '.join(ALL_MODES)}")
    rows: dict[str, list[Figures]] = {mode: [] for mode in modes}
    for path in args.recordings:
        for mode, rows_of_mode in rows.items():
            f = replay(path, mode)
            rows_of_mode.append(f)
            print(f"{path.name:28s} {mode:13s} {f}", flush=True)
    print(
        "mean (worst): obstacle recall %, floor precision %, unsafe cells, worst row mm,"
        " mean |row| mm, heading"
        " (a figure a run has none of, as recall with no obstacle cell labelled, is left out and"
        " counted)"
    )
    for mode, found in rows.items():
        print(
            f"{mode:13s} {_mean_worst([f.obstacle_recall_pct for f in found], min, 1)}  "
            f"{_mean_worst([f.floor_precision_pct for f in found], min, 2)}  "
            f"{_mean_worst([float(f.unsafe_cells) for f in found], max, 1)}  "
            f"{_mean_worst([f.worst_row_mm for f in found], max, 2)}  "
            f"{_mean_worst([f.mean_row_mm for f in found], max, 2)}  "
            f"{_mean_worst([f.residual_heading_deg for f in found], max, 2)}"
        )


def _mean_worst(values: list[float], worst: Callable[[list[float]], float], digits: int) -> str:
    """``mean (worst)`` of the finite values, with how many runs had none (NaN)."""
    finite = [v for v in values if math.isfinite(v)]
    missing = len(values) - len(finite)
    if not finite:
        return "none"
    text = f"{statistics.mean(finite):.{digits}f} ({worst(finite):.{digits}f})"
    return text + (f" [{missing} none]" if missing else "")


if __name__ == "__main__":
    main()
