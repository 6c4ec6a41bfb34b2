"""Which pose error moves the heading estimate: each accepted try re-scored with one error alone.

For each recording, one replay with the defaults (or ``--set`` overrides); at every accepted
try of the structure score (`mapper.heading.HeadingEstimator`) its keyframes are kept, each
with its frame's true camera pose. Every keyframe point is then put into the world five ways
and the counts score (`heading_scores`, the default) and the overlap score
(`overlap_heading_scores`, ``--overlap-cells``, centred by its noise band, ``--noise-band``)
are estimated on each, the error printed against what that placement needs:

- ``run``: the believed points (what the estimator saw), against ``ψ``, the mean over the
  keyframes of the yaw that turns each keyframe's believed camera pose into its true one in
  the world (the neck's error and odometry's yaw; the header also shows the robot-frame
  correction the run needed, `heading_trace.needed_deg`, which leaves odometry's yaw out);
- ``yaw``: the true points turned by a constant −ψ about each true camera centre (a pure,
  constant yaw error), against ψ;
- ``yaw_k``: the same by each keyframe's own ψ_k (the yaw error varying over the keyframes);
- ``xy``: the true points moved with their camera to the believed camera position (odometry's
  and the kinematics' position errors alone), against 0;
- ``tilt_z``: the believed points with their yaw and camera position errors undone (the tilt
  correction's and the height's residual errors alone), against 0.

Session 37 (`room`, stage and zig-zag stage depth, seeds 1–8): ``yaw`` is recovered to
±0.25…0.7° (the 0.5° grid's phase; with ``--true-pose`` in `heading_trace.py` the truth lies
on a candidate), ``xy`` moves the estimates by −0.75…+1.5° and ``tilt_z`` by −0.5…+0.75°, for
both scores: the runs' position and tilt errors, not the overlap score's normalisation alone,
make it under-correct where it does (`HeadingParams.noise_band` has the figures).

Usage::

    python bench/heading_decompose.py [--set KEY=VALUE ...] /work/rec/stage_depth_s3.npz
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from heading_trace import needed_deg, overrides_of, recordings_parser

import fogsim.mapping.pipeline as pipeline_module
import mapper.heading as heading_module
from fogsim.config import resolve_params
from fogsim.data.recording import load_recording
from fogsim.eval.pose_error import heading_error_deg
from fogsim.run.runner import run_frames, sensor_fields
from mapper.transforms import planar_pose_to_matrix

COARSE_DEG = np.arange(-24, 25) * 0.5
"""The estimator's default candidates [deg] (±`max_correction_deg` 12 at `coarse_step_deg`)."""


def _rotate_about(points, centre_xy, angle_deg):
    """(N, 3) points turned by ``angle_deg`` about the vertical axis through ``centre_xy``."""
    c, s = math.cos(math.radians(angle_deg)), math.sin(math.radians(angle_deg))
    out = points.copy()
    out[:, :2] = centre_xy + (points[:, :2] - centre_xy) @ np.array([[c, s], [-s, c]])
    return out


def _scores_data(keyframes):
    """`heading_scores`' arguments (world-aligned offsets, yaw 0) of (points, camera_xy) pairs."""
    offsets = np.ascontiguousarray(np.concatenate([p[:, :2] - c for p, c in keyframes]))
    z = np.concatenate([p[:, 2] for p, _ in keyframes])
    starts = np.concatenate([[0], np.cumsum([p.shape[0] for p, _ in keyframes])])
    cameras = np.array([c for _, c in keyframes])
    return offsets, z, starts.astype(np.int64), cameras, np.zeros(len(keyframes))


def _estimates(keyframes, overlap_cells, noise_band, peak_band):
    """The counts' and the overlap's estimates [deg] of the keyframes."""
    data = (*_scores_data(keyframes), np.radians(COARSE_DEG), 0.03, 0.04)
    counts = heading_module.heading_scores(*data)
    drop = peak_band * (counts.max() - float(np.median(counts)))
    overlap = heading_module.overlap_heading_scores(*data, overlap_cells)
    overlap_drop = noise_band * math.sqrt(2.0) * heading_module.score_noise(overlap)
    return (
        heading_module._band_centre_deg(COARSE_DEG, counts, drop),
        heading_module._band_centre_deg(COARSE_DEG, overlap, overlap_drop),
    )


def _world(keyframe, frame):
    """A kept keyframe's believed and true world points and camera x, y, and its ψ [deg]."""
    c, s = math.cos(keyframe["yaw"]), math.sin(keyframe["yaw"])
    xy = keyframe["camera_xy"] + keyframe["offsets_xy"] @ np.array([[c, s], [-s, c]])
    believed = np.column_stack([xy, keyframe["z_world"]])
    camera = planar_pose_to_matrix(keyframe["pose"]) @ keyframe["transform"]
    camera[2, 3] += keyframe["z_shift_m"]
    to_true = frame.transform_camera_to_world_true @ np.linalg.inv(camera)
    true = believed @ to_true[:3, :3].T + to_true[:3, 3]
    psi = heading_error_deg(frame.transform_camera_to_world_true[:3, :3], camera[:3, :3])
    return believed, camera[:2, 3], true, frame.transform_camera_to_world_true[:2, 3], psi


def accepted_tries(recording, params) -> list[tuple[int, list[dict]]]:
    """The replay's accepted structure tries: (frame, its keyframes) (module docstring).

    Each keyframe a dict of its frame, believed camera transform, pose, height shift, and its
    points (`offsets_xy`, `z_world`, `camera_xy`, `yaw`): what `_world` takes.
    """
    current = [0]
    meta: dict[int, dict] = {}
    tries: list[tuple[int, list[dict]]] = []
    observe, add = pipeline_module.Pipeline._observe_heading, heading_module.HeadingEstimator
    add_keyframe, estimate = add._add_keyframe, add._estimate

    def observe_noting(self, data):
        current[0] = data.frame.index
        return observe(self, data)

    def add_noting(self, points, floor, transform, pose, z_shift_m, *rest):
        added = add_keyframe(self, points, floor, transform, pose, z_shift_m, *rest)
        if added and not rest[-1]:  # a structure keyframe
            meta[id(self._keyframes[-1])] = dict(
                frame=current[0], transform=np.array(transform), pose=np.array(pose),
                z_shift_m=z_shift_m,
            )  # fmt: skip
        return added

    def estimate_noting(self, edges):
        before = self.estimates
        estimate(self, edges)
        if not edges and self.estimates > before:
            kept = [
                dict(meta[id(k)], offsets_xy=k.offsets_xy, z_world=k.z_world,
                     camera_xy=k.camera_xy, yaw=k.yaw_rad, correction_rad=self.correction_rad)
                for k in self._keyframes
            ]  # fmt: skip
            tries.append((current[0], kept))

    pipeline_module.Pipeline._observe_heading = observe_noting
    add._add_keyframe, add._estimate = add_noting, estimate_noting
    try:
        run_frames(recording.frames, recording.truth_at, recording.scenario, params=params)
    finally:
        pipeline_module.Pipeline._observe_heading = observe
        add._add_keyframe, add._estimate = add_keyframe, estimate
    return tries


def decompose(path: Path, overrides: dict[str, object], args) -> list[str]:
    """The lines of one recording (module docstring)."""
    recording = load_recording(path)
    params = resolve_params(recording.scenario, overrides, sensor_fields(recording.scenario))
    frames = {f.index: f for f in recording.frames}
    tries = accepted_tries(recording, params)
    needed = float(np.median([needed_deg(f) for f in recording.frames]))
    lines = [f"== {path.name}: needed {needed:+.2f}° (robot frame); errors counts / overlap"]
    for frame_index, kept in tries:
        worlds = [_world(k, frames[k["frame"]]) for k in kept]
        psi = np.array([w[4] for w in worlds])
        mean_psi = float(psi.mean())
        placements = {
            "run": ([(w[0], w[1]) for w in worlds], mean_psi),
            "yaw": ([(_rotate_about(w[2], w[3], -mean_psi), w[3]) for w in worlds], mean_psi),
            "yaw_k": ([(_rotate_about(w[2], w[3], -w[4]), w[3]) for w in worlds], mean_psi),
            "xy": ([(w[2] + np.r_[w[1] - w[3], 0.0], w[1]) for w in worlds], 0.0),
            "tilt_z": (
                [(_rotate_about(w[0], w[1], w[4]) + np.r_[w[3] - w[1], 0.0], w[3]) for w in worlds],
                0.0,
            ),
        }
        line = f"  frame {frame_index:4d} ψ {mean_psi:+.2f}° (sd {psi.std():.2f})"
        for name, (keyframes, target) in placements.items():
            counts, overlap = _estimates(
                keyframes, args.overlap_cells, args.noise_band, params.heading.peak_band
            )
            line += f" | {name} {counts - target:+.2f} / {overlap - target:+.2f}"
        lines.append(line)
    return lines


def main() -> None:
    parser = recordings_parser(__doc__)
    parser.add_argument("--overlap-cells", type=int, default=5, help="wide voxels [cells]")
    parser.add_argument("--noise-band", type=float, default=4.0, help="overlap's noise band")
    args = parser.parse_args()
    overrides = overrides_of(args.set)
    for path in args.recordings:
        print("\n".join(decompose(path, overrides, args)), flush=True)


if __name__ == "__main__":
    main()
