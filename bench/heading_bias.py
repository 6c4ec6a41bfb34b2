"""Each accepted structure estimate of a replay against its keyframes' yaw error in the world.

For each recording, one replay (the defaults, or ``--set`` overrides); at every accepted try of
the structure score (`mapper.heading.HeadingEstimator`) one line: the frame, the keyframes, the
mean and range over the keyframes of ψ, the yaw that turns each keyframe's believed camera pose
into its true one in the world (what a constant correction can make agree:
`heading_decompose._world`), the correction and its error against the mean ψ. Then per
scenario_mode: the errors' mean (the bias), mean |error| and worst |error| over the accepted
tries.

Session 39, depth seeds 1–8, error mean (mean |error|, worst |error|): defaults `table` +1.44
(1.44, 1.71)°, `room` +0.63 (0.71, 1.39)°: the estimator is biased, one sign on every `table`
seed; with ``--set head.surface_power=3`` `table` −0.12 (0.28, 0.54)°, `room` +0.31 (0.44,
0.95)° (`HeadingParams.surface_power`).

Usage::

    python bench/heading_bias.py [--set KEY=VALUE ...] /work/rec/table_depth_s{1..8}.npz
"""

from __future__ import annotations

import math
import re
import sys
from collections import defaultdict
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from heading_decompose import _world, accepted_tries
from heading_trace import overrides_of, recordings_parser

from fogsim.config import resolve_params
from fogsim.data.recording import load_recording
from fogsim.run.runner import sensor_fields


def accepted_errors(
    path: Path, overrides: dict[str, object]
) -> list[tuple[int, int, float, float, float, float]]:
    """(frame, keyframes, mean ψ, min ψ, max ψ, correction) [deg] of each accepted try."""
    recording = load_recording(path)
    params = resolve_params(recording.scenario, overrides, sensor_fields(recording.scenario))
    frames = {f.index: f for f in recording.frames}
    out = []
    for frame, kept in accepted_tries(recording, params):
        psi = np.array([_world(k, frames[k["frame"]])[4] for k in kept])
        correction = math.degrees(kept[-1]["correction_rad"])
        out.append((frame, psi.size, psi.mean(), psi.min(), psi.max(), correction))
    return out


def main() -> None:
    args = recordings_parser(__doc__).parse_args()
    overrides = overrides_of(args.set)
    errors: dict[str, list[float]] = defaultdict(list)
    for path in args.recordings:
        print(f"== {path.name}", flush=True)
        for frame, keyframes, psi, low, high, correction in accepted_errors(path, overrides):
            print(
                f"  frame {frame:4d} keyframes {keyframes:3d} ψ {psi:+.2f}° "
                f"({low:+.2f}…{high:+.2f}) correction {correction:+.2f}° "
                f"error {correction - psi:+.2f}°",
                flush=True,
            )
            errors[re.sub(r"_s\d+$", "", path.stem)].append(correction - psi)
    for scenario, values in sorted(errors.items()):
        e = np.array(values)
        print(
            f"{scenario}: {e.size} accepted, error mean {e.mean():+.2f}°, |error| mean "
            f"{np.abs(e).mean():.2f}°, worst {np.abs(e).max():.2f}°"
        )


if __name__ == "__main__":
    main()
