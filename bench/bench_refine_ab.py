"""The heading refinement of another commit against this tree's, on fits captured from replays.

For work on `mapper.heading_planes`: each recording is replayed through the pipeline
(`fogsim.run.runner.run_frames`, its scenario's parameters) with every call of
``refine_heading`` captured (its arrays and the correction, information and RMS it returned);
then each captured fit runs ``--repeats`` times under the base commit's ``refine_heading``
(``git show BASE:mapper/heading_planes.py``, imported as its own module) and this tree's, the
order alternating, and both must return what the replay's call returned, bit for bit (the run
stops at the first difference). Printed per fit: its points, each version's median time
(wall, ``time.perf_counter``: a fit runs on the calling thread alone) and their ratio; with
``os.getloadavg()`` before and after. Fits of fewer than ``--min-points`` points (the warm-up's)
are left out.

Run: ``.venv/bin/python bench/bench_refine_ab.py --base e51a260 REC.npz [REC.npz ...]``
(session 58: base e51a260, the stage's depth and stereo recordings and `down_landing_turn`'s
stereo one, seed 1, ``--repeats 5``: 7 fits of 5 637–9 094 points, 71.6–141.0 → 51.6–105.4 ms,
1.29–1.39×, on a Zen 3 EPYC at load 1.3–1.8).
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))
from base_module import module_at

import mapper.heading_planes as heading_planes


@dataclass(frozen=True)
class Fit:
    """One captured ``refine_heading`` call: where from, its arguments, what it returned."""

    source: str
    args: tuple[Any, ...]
    result: tuple[float, float, float]

    @property
    def points(self) -> int:
        """Keyframe points of the fit."""
        return int(self.args[0].shape[0])


def captured_fits(recording: Path) -> list[Fit]:
    """Every ``refine_heading`` call of a replay of ``recording`` (its scenario's parameters)."""
    from fogsim.config import resolve_params
    from fogsim.data import load_recording
    from fogsim.run.runner import run_frames, sensor_fields

    rec = load_recording(recording)
    params = resolve_params(rec.scenario, sensor=sensor_fields(rec.scenario))
    fits: list[Fit] = []
    original = heading_planes.refine_heading

    def capture(*args: Any) -> tuple[float, float, float]:
        result = original(*args)
        fits.append(Fit(recording.stem, args, tuple(float(v) for v in result)))
        return result

    heading_planes.refine_heading = capture  # `refined_heading` looks it up when called
    try:
        run_frames(rec.frames, rec.truth_at, rec.scenario, params=params)
    finally:
        heading_planes.refine_heading = original
    return fits


def compare(
    fits: Iterable[Fit],
    kernels: dict[str, Callable[..., tuple[float, float, float]]],
    repeats: int,
) -> list[tuple[Fit, dict[str, float]]]:
    """Each fit's median seconds per kernel, the kernels alternating; stops at a difference.

    Raises:
        SystemExit: A kernel returned something else than the captured call did.
    """
    rows = []
    names = list(kernels)
    for fit in fits:
        times: dict[str, list[float]] = {name: [] for name in names}
        for repeat in range(repeats):
            for name in names if repeat % 2 == 0 else names[::-1]:
                start = time.perf_counter()
                result = tuple(float(v) for v in kernels[name](*fit.args))
                times[name].append(time.perf_counter() - start)
                if result != fit.result:
                    raise SystemExit(
                        f"{fit.source}, a fit of {fit.points} points: {name} returned {result}, "
                        f"the replay's call {fit.result}"
                    )
        rows.append((fit, {name: statistics.median(t) for name, t in times.items()}))
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("recordings", nargs="+", type=Path, help="recordings (fogsim record)")
    parser.add_argument("--base", default="HEAD", help="commit whose refine_heading is the base")
    parser.add_argument("--repeats", type=int, default=5, help="runs of each fit per version")
    parser.add_argument("--min-points", type=int, default=100, help="smaller fits left out")
    args = parser.parse_args()
    if args.repeats < 1:
        parser.error(f"--repeats must be >= 1, got {args.repeats}")
    fits = [
        fit
        for recording in args.recordings
        for fit in captured_fits(recording)
        if fit.points >= args.min_points
    ]
    with tempfile.TemporaryDirectory() as directory:
        base: ModuleType = module_at(args.base, "mapper/heading_planes.py", Path(directory))
        kernels = {"base": base.refine_heading, "tree": heading_planes.refine_heading}
        for fit in fits[:1]:  # compile or load both before timing
            compare([fit], kernels, 1)
        load_before = os.getloadavg()
        rows = compare(fits, kernels, args.repeats)
        load_after = os.getloadavg()
    print(f"base {args.base} against this tree, {args.repeats} runs of each fit, medians")
    print(f"{'recording':28s} {'points':>7s} {'base ms':>9s} {'tree ms':>9s} {'base/tree':>9s}")
    for fit, median in rows:
        print(
            f"{fit.source:28s} {fit.points:7d} {1e3 * median['base']:9.1f} "
            f"{1e3 * median['tree']:9.1f} {median['base'] / median['tree']:9.2f}"
        )
    print(f"every fit the same bit for bit; load {load_before} before, {load_after} after")


if __name__ == "__main__":
    main()
