"""How well each frame's tilt measurement knows its own error: the tilt filter's input checked.

Usage:
    PYTHONPATH=. python bench/tilt_calibration.py REC.npz ... [--every N] [--set KEY=VALUE ...]

For every ``N``-th frame of each recording the depth image is segmented as a run does (the
pipeline's segmentation parameters, `fogsim.mapping.segmenter.pipeline_segmentation_params`)
and `mapper.tilt_filter.measured_tilt` gives the measured tilt ``z`` (the ground normal's
(x, y) in the believed robot frame) and its predicted std ``σ`` per axis. The truth ``x`` is
the true up vector seen from the believed robot frame, ``(R_believed · R_trueᵀ · e_z)[:2]``,
``R_true`` the true camera rotation in the true robot frame. Printed per recording set (the
name before ``_s<seed>``), per axis (x: pitch, the normal's forward part; y: roll):

- ``err``: robust std (1.4826·MAD) of ``z − x`` [deg], and its median;
- ``norm``: robust std of ``(z − x)/σ``: 1 when ``σ`` is right, above 1 when the measurement
  is worse than it claims (the filter then trusts it too much, and its gate refuses good
  frames and lets bad ones re-start it);
- ``tail``: the fraction of frames with ``|z − x|/σ`` beyond 3.7 on either axis (the filter's
  gate, χ² 13.8 over two axes): gross errors, a wrong plane winning the consensus.

Session 39, stereo recordings, every 4th frame of seeds 1-4 (factor 1): norm x / y = stage
1.86 / 0.84, room 1.79 / 0.69, stage_zigzag 1.61 / 0.78, stairs 1.79 / 0.71, talos_course
2.05 / 0.68; depth mode stage 1.27 / 1.19, room 1.31 / 1.14 (σ is 0.02° there, far below the
filter's 0.3° encoder noise, so it barely matters).
"""

from __future__ import annotations

import argparse
from collections import defaultdict
from pathlib import Path

import numpy as np
from trace_replay import parse_overrides

from fogsim.config import resolve_params
from fogsim.data.recording import load_recording
from fogsim.mapping.segmenter import pipeline_segmentation_params
from fogsim.run.runner import sensor_fields
from mapper.segmentation import segment_depth
from mapper.tilt_filter import measured_tilt
from mapper.transforms import planar_pose_to_matrix

GATE_SIGMAS = float(np.sqrt(-2.0 * np.log(1e-3)))
"""The tilt filter's gate (χ² 13.8155 over two axes) as a number of standard deviations."""


def robust_std(values: np.ndarray) -> np.ndarray:
    """1.4826 × the median absolute deviation from the median, per column."""
    return 1.4826 * np.median(np.abs(values - np.median(values, axis=0)), axis=0)


def true_tilt(frame) -> np.ndarray:
    """(2,) the truth a frame's tilt measurement measures: the true up vector's (x, y) seen
    from the believed robot frame, ``(R_believed · R_trueᵀ · e_z)[:2]``."""
    true_in_robot = (
        np.linalg.inv(planar_pose_to_matrix(frame.robot_pose_true))
        @ frame.transform_camera_to_world_true
    )
    believed = np.asarray(frame.transform_camera_to_robot_believed)[:3, :3]
    return (believed @ true_in_robot[:3, :3].T @ np.array([0.0, 0.0, 1.0]))[:2]


def frame_errors(path: Path, every: int, overrides: dict[str, object]) -> np.ndarray:
    """(n, 4) per measured frame: ``z − x`` (2,) [rad] and ``σ`` (2,) [rad]."""
    recording = load_recording(path)
    params = resolve_params(recording.scenario, overrides, sensor_fields(recording.scenario))
    segmentation_params = pipeline_segmentation_params(params)
    rows = []
    for index, frame in enumerate(recording.frames):
        if index % every:
            continue
        result = segment_depth(
            frame.depth_m,
            frame.intrinsics,
            frame.transform_camera_to_robot_believed,
            segmentation_params,
        )
        measured, sigma = measured_tilt(result, segmentation_params)
        if measured is None:
            continue
        truth = true_tilt(frame)
        rows.append(np.concatenate([measured - truth, np.broadcast_to(sigma, (2,))]))
    return np.array(rows).reshape(-1, 4)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("recordings", nargs="+", type=Path)
    parser.add_argument("--every", type=int, default=4, help="every N-th frame (default 4)")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    args = parser.parse_args()
    overrides = parse_overrides(args.set)
    sets: dict[str, list[np.ndarray]] = defaultdict(list)
    for path in args.recordings:
        sets[path.stem.rsplit("_s", 1)[0]].append(frame_errors(path, args.every, overrides))
    for name, parts in sets.items():
        rows = np.concatenate(parts)
        error, sigma = rows[:, :2], rows[:, 2:]
        normalised = error / sigma
        err_deg = np.degrees(robust_std(error))
        median_deg = np.degrees(np.median(error, axis=0))
        norm = robust_std(normalised)
        tail = float((np.abs(normalised) > GATE_SIGMAS).any(axis=1).mean())
        print(
            f"{name:24s} frames {len(rows):5d}  σ median {np.degrees(np.median(sigma)):.3f}°  "
            f"err x/y {err_deg[0]:.3f} / {err_deg[1]:.3f}° (median {median_deg[0]:+.3f} / "
            f"{median_deg[1]:+.3f})  norm x/y {norm[0]:.2f} / {norm[1]:.2f}  tail {tail:.3f}"
        )


if __name__ == "__main__":
    main()
