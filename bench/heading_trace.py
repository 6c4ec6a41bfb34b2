"""Every try of the heading estimator on a replay, against the correction the run needed.

For each recording, one replay (with ``--true-pose``: every frame's believed camera pose made
the true one, `heading_oracle.true_pose_frame`, so any estimate but 0 is the estimator's own
error); each time the estimator scores its keyframes (`mapper.heading.HeadingEstimator`) one
line: the frame, which score (``S`` structure points, ``E`` edge points), keyframes, the span
of their cameras [m], the contrast ``(best − median) / best``, whether the estimate was
accepted, the correction after the try [deg] and its error against the correction the run
needed (the median over its frames of the yaw between the believed and the true camera pose in
the robot frame, `fogsim.eval.pose_error.heading_error_deg`) [deg].

With ``--true-pose`` the run needs no correction: `heading_oracle.true_pose_frame` puts the true
camera pose into the *believed* robot frame, so every frame's world points are exact and the
right answer is 0; the error is then the correction itself. (The yaw between the believed and
the true camera pose in the *true* robot frame is then the odometry's yaw error alone, which no
camera correction should follow; the header shows it as ``odometry``. Up to session 36 the error
was taken against it, which made the stage depth's exact 0.00° on every seed read −0.55…+0.82°
off.)

Session 36 (seeds 1–8, ``--true-pose``, error against 0): the structure score's accepted
estimates are +0.25…+1.0° on `room` depth (+0.5…+0.75° at the last), −1.0…+0.25° at the end of
the zig-zag stage's stereo recordings, 0.00° on the stage depth: the estimator's own bias, not
the poses' errors (`HeadingParams.voxel_estimate` has the figures with one point per voxel,
against the odometry then).

With ``--summary``, one more line over all the recordings (`summarize`): the first accepted
estimate's error, every accepted estimate's and the final correction's, mean |error| and the
worst recording, and the recordings that accepted none. Session 52, the 32 held-out depth
recordings of seeds 1–4 and 5–8 (`fogsim record scenarios/holdout/X.toml --seed N`): see
README "The first heading estimate of a descending start".

Usage::

    python bench/heading_trace.py [--true-pose] [--summary] [--set KEY=VALUE ...] REC.npz ...
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from heading_oracle import true_pose_frame

import mapper.heading as heading_module
from fogsim.config import resolve_params
from fogsim.data.frame import Frame
from fogsim.data.recording import load_recording
from fogsim.eval.pose_error import heading_error_deg
from fogsim.run.runner import run_frames, sensor_fields
from mapper.transforms import planar_pose_to_matrix


def needed_deg(frame: Frame) -> float:
    """The correction [deg] that undoes the frame's believed camera yaw error (robot frame)."""
    true_in_robot = (
        np.linalg.inv(planar_pose_to_matrix(frame.robot_pose_true))
        @ frame.transform_camera_to_world_true
    )
    believed = np.asarray(frame.transform_camera_to_robot_believed, dtype=np.float64)
    return -heading_error_deg(believed[:3, :3], true_in_robot[:3, :3])


@dataclass(frozen=True)
class EstimateErrors:
    """One replay's heading estimates against the correction the run needed [deg].

    Attributes:
        recording: The recording's file name.
        accepted_deg: Each accepted estimate's correction minus the need, in order.
        final_deg: The correction after the last frame minus the need.
    """

    recording: str
    accepted_deg: tuple[float, ...]
    final_deg: float


def summarize(results: list[EstimateErrors]) -> str:
    """One line over the replays: mean |error| (worst, its recording) of the first accepted
    estimates, of every accepted estimate, of the final corrections; the replays with none."""

    def mean_worst(pairs: list[tuple[float, str]]) -> str:
        if not pairs:
            return "none"
        worst = max(pairs, key=lambda pair: abs(pair[0]))
        mean = sum(abs(error) for error, _ in pairs) / len(pairs)
        return f"{mean:.3f}° (worst {abs(worst[0]):.2f}°, {worst[1]})"

    first = [(r.accepted_deg[0], r.recording) for r in results if r.accepted_deg]
    every = [(error, r.recording) for r in results for error in r.accepted_deg]
    final = [(r.final_deg, r.recording) for r in results]
    none = [r.recording for r in results if not r.accepted_deg]
    return (
        f"{len(results)} replays: first accepted estimate |error| {mean_worst(first)}; every "
        f"accepted estimate {mean_worst(every)} over {len(every)}; final correction "
        f"{mean_worst(final)}; no estimate: {', '.join(none) or 'none'}"
    )


def trace(
    path: Path, overrides: dict[str, object], true_pose: bool
) -> tuple[list[str], EstimateErrors]:
    """The lines of one recording's replay (module docstring) and its estimates' errors."""
    recording = load_recording(path)
    params = resolve_params(recording.scenario, overrides, sensor_fields(recording.scenario))
    frames = [true_pose_frame(f) for f in recording.frames] if true_pose else recording.frames
    tries: list[tuple[int, bool, int, float, float, bool, float]] = []
    position = [0]
    final = [0.0]
    scores: list[np.ndarray] = []
    estimate = heading_module.HeadingEstimator._estimate
    plain, weighted = heading_module.heading_scores, heading_module.weighted_heading_scores

    def keep(score):
        def scored(*args):
            scores.append(score(*args))
            return scores[-1]

        return scored

    def estimate_and_note(self, edges: bool) -> None:
        scores.clear()
        before = self.estimates
        estimate(self, edges)
        if not scores:
            return  # no try: no baseline, or the edge score not standing in
        keyframes = self._edge_keyframes if edges else self._keyframes
        span = float(np.ptp(np.array([k.camera_xy for k in keyframes]), axis=0).max())
        best, median = float(scores[0].max()), float(np.median(scores[0]))
        contrast = (best - median) / best if best > 0.0 else 0.0
        accepted = self.estimates > before
        correction = math.degrees(self.correction_rad)
        tries.append((position[0], edges, len(keyframes), span, contrast, accepted, correction))

    heading_module.HeadingEstimator._estimate = estimate_and_note
    heading_module.heading_scores, heading_module.weighted_heading_scores = (
        keep(plain),
        keep(weighted),
    )
    try:

        def count(frame, pipeline) -> None:
            position[0] += 1
            final[0] = math.degrees(pipeline.heading.correction_rad)

        odometry = float(np.median([needed_deg(f) for f in frames]))
        needed = 0.0 if true_pose else odometry
        run_frames(frames, recording.truth_at, recording.scenario, params=params, on_frame=count)
    finally:
        heading_module.HeadingEstimator._estimate = estimate
        heading_module.heading_scores, heading_module.weighted_heading_scores = plain, weighted
    lines = [
        f"== {path.name}: needed {needed:+.2f}°"
        + (f" (odometry {odometry:+.2f}°)" if true_pose else "")
    ]
    for frame, edges, keyframes, span, contrast, accepted, correction in tries:
        lines.append(
            f"  frame {frame:4d} {'E' if edges else 'S'} keyframes {keyframes:3d} span "
            f"{span:4.2f} m contrast {contrast:5.3f} {'accepted' if accepted else '        '} "
            f"correction {correction:+6.2f}° error {correction - needed:+6.2f}°"
        )
    errors = tuple(correction - needed for *_, accepted, correction in tries if accepted)
    return lines, EstimateErrors(path.name, errors, final[0] - needed)


def recordings_parser(doc: str) -> argparse.ArgumentParser:
    """A bench tool's parser: its docstring's first line, ``REC.npz ...`` and ``--set KEY=VALUE``
    (repeatable; the tool adds its own options)."""
    parser = argparse.ArgumentParser(description=doc.splitlines()[0])
    parser.add_argument("recordings", nargs="+", type=Path)
    parser.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="a parameter override, e.g. head.voxel_estimate=true (VALUE as JSON, else a string)",
    )
    return parser


def overrides_of(items: list[str]) -> dict[str, object]:
    """The parameter overrides of ``--set`` items (a VALUE that is no JSON is a string)."""
    overrides: dict[str, object] = {}
    for item in items:
        key, _, value = item.partition("=")
        try:
            overrides[key] = json.loads(value)
        except json.JSONDecodeError:
            overrides[key] = value
    return overrides


def main() -> None:
    parser = recordings_parser(__doc__)
    parser.add_argument("--true-pose", action="store_true", help="replay with the true pose")
    parser.add_argument("--summary", action="store_true", help="a line over all recordings")
    args = parser.parse_args()
    overrides = overrides_of(args.set)
    results = []
    for path in args.recordings:
        lines, errors = trace(path, overrides, args.true_pose)
        results.append(errors)
        print("\n".join(lines), flush=True)
    if args.summary:
        print(summarize(results))


if __name__ == "__main__":
    main()
