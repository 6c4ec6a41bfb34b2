"""The tilt filter's output against the truth, frame by frame, for filter variants side by side.

Usage:
    PYTHONPATH=. python bench/tilt_filter_eval.py REC.npz ... [--variant NAME:KEY=VALUE,...]
        [--cache DIR] [--workers N]

Every frame of each recording is segmented once as a run does (the pipeline's segmentation
parameters, `fogsim.mapping.segmenter.pipeline_segmentation_params`; cached in ``--cache``):
its measured tilt and predicted std (`mapper.tilt_filter.measured_tilt`, pitch factor 1), the
believed camera's turn since the previous frame, and the truth (the true up vector seen from
the believed robot frame, `bench/tilt_calibration.py`'s `true_tilt`). Each variant then runs a
`mapper.tilt_filter.TiltFilter` over the frames in order, as `fogsim.mapping.segmenter` does,
and the tilt it applies is compared with the truth. A variant is ``NAME:KEY=VALUE,...`` with
keys ``pitch_factor`` (`SegmentationParams.tilt_pitch_sigma_factor`) and the fields of
`TiltFilterParams` (``tail_dof``, ``gate_chi2``, ...); ``raw`` is the measurement itself.

Printed per recording set (the name before ``_s<seed>``) and variant, over every frame of
every seed, per axis (x: pitch, y: roll) [deg]: the RMS error, its 99th percentile, the
fraction of frames more than 0.5° and 1° off, and the worst seed's RMS.
"""

from __future__ import annotations

import argparse
import math
from collections import defaultdict
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
from tilt_calibration import true_tilt

from fogsim.config import resolve_params
from fogsim.data.recording import load_recording
from fogsim.mapping.segmenter import pipeline_segmentation_params
from fogsim.run.runner import sensor_fields
from mapper.segmentation import segment_depth
from mapper.tilt_filter import TiltFilter, TiltFilterParams, measured_tilt
from mapper.transforms import rotation_angle_deg


def frame_table(path: Path, cache: Path) -> np.ndarray:
    """(T, 7) per frame: measured tilt (2, NaN if none), σ (2), turn [rad], truth (2)."""
    cached = cache / f"{path.stem}.npy"
    if cached.exists():
        return np.load(cached)
    recording = load_recording(path)
    params = resolve_params(recording.scenario, {}, sensor_fields(recording.scenario))
    segmentation_params = pipeline_segmentation_params(params)
    rows = []
    previous = None
    for frame in recording.frames:
        believed = np.asarray(frame.transform_camera_to_robot_believed, dtype=np.float64)
        result = segment_depth(frame.depth_m, frame.intrinsics, believed, segmentation_params)
        measured, sigma = measured_tilt(result, segmentation_params)
        rotation = believed[:3, :3]
        turn = 0.0 if previous is None else math.radians(rotation_angle_deg(previous.T @ rotation))
        previous = rotation
        truth = true_tilt(frame)
        z = np.full(2, np.nan) if measured is None else measured
        rows.append(np.concatenate([z, np.broadcast_to(sigma, (2,)), [turn], truth]))
    table = np.array(rows)
    cache.mkdir(parents=True, exist_ok=True)
    np.save(cached, table)
    return table


def parse_variant(text: str) -> tuple[str, dict[str, float]]:
    """``NAME:KEY=VALUE,...`` → (name, {key: value})."""
    name, _, rest = text.partition(":")
    fields = {}
    for item in filter(None, rest.split(",")):
        key, _, value = item.partition("=")
        fields[key] = float(value)
    return name, fields


def filtered(table: np.ndarray, fields: dict[str, float]) -> np.ndarray:
    """(T, 2) the tilt the variant applies to each frame [rad] (NaN: raw without a measurement)."""
    fields = dict(fields)
    if fields.pop("raw", 0.0):
        return table[:, :2]
    factor = np.array([fields.pop("pitch_factor", 1.0), 1.0])
    if "reset_refusals" in fields:
        fields["reset_refusals"] = int(fields["reset_refusals"])
    tilt_filter = TiltFilter(TiltFilterParams(**fields))
    out = np.empty((len(table), 2))
    for k, row in enumerate(table):
        measured = None if np.isnan(row[0]) else row[:2]
        out[k] = tilt_filter.update(measured, row[2:4] * factor, row[4]).tilt_rad
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("recordings", nargs="+", type=Path)
    parser.add_argument("--variant", action="append", default=[])
    parser.add_argument("--cache", type=Path, default=Path("/tmp/tilt_filter_eval"))
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    variants = [parse_variant(v) for v in (args.variant or ["default:"])]
    with ProcessPoolExecutor(args.workers) as pool:
        tables = list(pool.map(frame_table, args.recordings, [args.cache] * len(args.recordings)))
    sets: dict[str, list[np.ndarray]] = defaultdict(list)
    for path, table in zip(args.recordings, tables, strict=True):
        sets[path.stem.rsplit("_s", 1)[0]].append(table)
    for set_name, parts in sets.items():
        print(f"{set_name} ({len(parts)} recordings, {sum(len(p) for p in parts)} frames)")
        for name, fields in variants:
            errors = []
            seed_rms = []
            for table in parts:
                err = np.degrees(filtered(table, fields) - table[:, 5:7])
                err = err[np.isfinite(err).all(axis=1)]
                errors.append(err)
                seed_rms.append(np.sqrt(np.mean(err**2, axis=0)))
            err = np.abs(np.concatenate(errors))
            rms = np.sqrt(np.mean(err**2, axis=0))
            p99 = np.percentile(err, 99, axis=0)
            half = (err > 0.5).mean(axis=0)
            one = (err > 1.0).mean(axis=0)
            worst = np.max(seed_rms, axis=0)
            print(
                f"  {name:14s} rms x/y {rms[0]:.3f}/{rms[1]:.3f}  p99 {p99[0]:.2f}/{p99[1]:.2f}"
                f"  >0.5° {half[0]:.3f}/{half[1]:.3f}  >1° {one[0]:.3f}/{one[1]:.3f}"
                f"  worst-seed rms {worst[0]:.3f}/{worst[1]:.3f}"
            )


if __name__ == "__main__":
    main()
