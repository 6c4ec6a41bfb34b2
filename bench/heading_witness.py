"""Every plane-witness call of the heading estimator on replays: its two fits and its verdict.

The witness (`mapper.heading.HeadingEstimator._plane_witness`, `HeadingParams.plane_witness_deg`)
accepts, before the first estimate, a try whose score does not stand out when two point-to-plane
fits (`mapper.heading._plane_fit`) agree: one from the score's estimate, one from the correction
so far. For each call, one line: the frame, the keyframes' camera span [m], each fit's start and
end [deg], its information Σ w·a² [m²/rad²], its weighted RMS [mm] and its standard error
RMS / √information [deg] (what `HeadingParams.plane_witness_sigma_deg` bounds), then the verdict
(the accepted correction and its error against the correction the run needed, or ``none``). A
call that returns before fitting (the counts flat, `flat_contrast`; in stereo every call, the
stereo head's `flat_contrast` being its `min_contrast`) shows no fits.

Session 59 (seeds 1–8, depth recordings of the eight held-out scenes and of `table`, the stage,
`stage_offgrid`, `room`, `stage_zigzag`, `talos_course`, `eth_stairs`, `stairs` and
`stage_down`), before `plane_witness_sigma_deg` (``--set head.plane_witness_sigma_deg=0``): 14
witnesses taken, 12 of them with standard errors 0.036–0.055° and 0.03–0.82° off the need;
`down_low_steps` seeds 1 and 2 with 0.18° and 0.27°, 0.64° and 1.99° off, which the bound (0.1°)
refuses; with it, seed 2 takes a later witness, 0.048° and 1.40° off. 105 calls on 48 stereo
recordings, none fitted.

Usage::

    python bench/heading_witness.py [--set KEY=VALUE ...] REC.npz ...
"""

from __future__ import annotations

import contextlib
import math
import sys
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from heading_trace import needed_deg, overrides_of, recordings_parser

import mapper.heading as heading_module
from fogsim.config import resolve_params
from fogsim.data.recording import load_recording
from fogsim.run.runner import run_frames, sensor_fields


@dataclass(frozen=True)
class WitnessFit:
    """One of a witness call's two point-to-plane fits.

    Attributes:
        start_deg: The correction it started from [deg].
        end_deg: The correction it ended at [deg] (the start where refused).
        information: Σ w·a² [m²/rad²]; 0: refused.
        rms_mm: Its residuals' weighted RMS [mm].
    """

    start_deg: float
    end_deg: float
    information: float
    rms_mm: float

    @property
    def sigma_deg(self) -> float:
        """Standard error RMS / √information [deg]; inf where refused."""
        if self.information <= 0.0:
            return math.inf
        return math.degrees(self.rms_mm / 1000.0 / math.sqrt(self.information))


@dataclass(frozen=True)
class WitnessCall:
    """One `_plane_witness` call.

    Attributes:
        frame: Frames processed before it (the replay's frame count).
        span_m: The keyframes' camera span [m] (the larger of x and y).
        fits: Its fits, in order (none where it returned before fitting).
        accepted_deg: The correction it accepted [deg], None if it refused.
    """

    frame: int
    span_m: float
    fits: tuple[WitnessFit, ...]
    accepted_deg: float | None


@contextlib.contextmanager
def recorded_witnesses(frame_of=lambda: 0) -> Iterator[list[WitnessCall]]:
    """Record every witness call of any estimator while the block runs.

    Args:
        frame_of: Returns the frame count to stamp each call with.

    Yields:
        The list the calls are appended to.
    """
    calls: list[WitnessCall] = []
    fits: list[WitnessFit] = []
    witness, plane_fit = heading_module.HeadingEstimator._plane_witness, heading_module._plane_fit

    def fit(keyframes, cameras_xy, yaw_rad, start_rad, *rest):
        result = plane_fit(keyframes, cameras_xy, yaw_rad, start_rad, *rest)
        fits.append(
            WitnessFit(
                math.degrees(start_rad), math.degrees(result[0]), result[1], result[2] * 1000.0
            )
        )
        return result

    def witnessed(self, keyframes, *args):
        fits.clear()
        heading_module._plane_fit = fit
        try:
            result = witness(self, keyframes, *args)
        finally:
            heading_module._plane_fit = plane_fit
        cameras = np.array([k.camera_xy for k in keyframes])
        calls.append(
            WitnessCall(
                frame_of(),
                float(np.ptp(cameras, axis=0).max()),
                tuple(fits),
                None if result is None else math.degrees(result),
            )
        )
        return result

    heading_module.HeadingEstimator._plane_witness = witnessed
    try:
        yield calls
    finally:
        heading_module.HeadingEstimator._plane_witness = witness


def replay_witnesses(path: Path, overrides: dict[str, object]) -> tuple[float, list[WitnessCall]]:
    """One recording's replay: the correction it needed [deg] and its witness calls."""
    recording = load_recording(path)
    params = resolve_params(recording.scenario, overrides, sensor_fields(recording.scenario))
    needed = float(np.median([needed_deg(f) for f in recording.frames]))
    position = [0]

    def count(frame, pipeline) -> None:
        position[0] += 1

    with recorded_witnesses(lambda: position[0]) as calls:
        run_frames(
            recording.frames, recording.truth_at, recording.scenario, params=params, on_frame=count
        )
    return needed, calls


def line(name: str, needed: float, call: WitnessCall) -> str:
    """A call's line (module docstring)."""
    fits = " ".join(
        f"[{f.start_deg:+.2f}->{f.end_deg:+.2f} I={f.information:.3g} rms={f.rms_mm:.1f} mm "
        f"sigma={f.sigma_deg:.3f}]"
        for f in call.fits
    )
    verdict = (
        "none"
        if call.accepted_deg is None
        else f"accepted {call.accepted_deg:+.2f} error {call.accepted_deg - needed:+.2f}"
    )
    return (
        f"{name} needed {needed:+.2f} frame {call.frame:4d} span {call.span_m:.2f} m "
        f"{fits or 'no fit'} -> {verdict}"
    )


def main() -> None:
    args = recordings_parser(__doc__).parse_args()
    overrides = overrides_of(args.set)
    for path in args.recordings:
        needed, calls = replay_witnesses(path, overrides)
        for call in calls:
            print(line(path.stem, needed, call), flush=True)


if __name__ == "__main__":
    main()
