"""Speed of ``fogsim tune``: one trial split into replay and scoring, and a whole tune.

1. Records the scenarios once (cached in ``OUT/recordings/``, keyed by scenario hash; the
   recording time is printed but is not part of a tune's cost once cached).
2. One trial, per recording, median of ``--repeats`` runs in this process:
   ``replay`` = :func:`fogsim.run.runner.run_frames` without truth (segmentation, z match, mapper,
   averaging baseline), ``scoring`` = the rest of :func:`fogsim.run.runner.replay_report` (world
   archive vs ground truth, Table I, cells, events, report assembly), ``objective`` = reducing
   the report (:func:`fogsim.tune.objective.objective_terms`).
3. A fresh tune of ``--trials`` trials (TPE, three parameters) with ``--workers`` processes: wall
   time, the CPU of this process and its workers, trials per minute, best vs defaults objective.
   Its trials reuse each worker's segmentations (:mod:`fogsim.tune.segment_cache`, as ``fogsim
   tune`` does) unless ``--no-segment-cache``.

Run: ``.venv/bin/python bench/bench_tune.py [--trials 100] [--workers 2]
[--scenarios stage box_removal] [--out runs/bench_tune] [--no-segment-cache]``. Timings on a
shared machine are noisy.
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import sys
import time
from functools import partial
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
os.environ.setdefault("MUJOCO_GL", "egl")
os.environ.setdefault("PYOPENGL_PLATFORM", "egl")
os.environ.setdefault("MESA_SHADER_CACHE_DISABLE", "true")

from fogsim.config import resolve_params
from fogsim.run.runner import replay_report, run_frames, sensor_fields
from fogsim.tune import ParamSpec, TuneConfig, parameter_defaults, tune
from fogsim.tune.config import RECORDINGS_DIR
from fogsim.tune.objective import ObjectiveWeights, objective_terms
from fogsim.tune.segment_cache import cached_replay_report
from fogsim.tune.suite import load_suite

PARAMS = ("p_occ=0.55:0.95", "eps_m=0.005:0.05:log", "delta_m=0.01:0.06")


def median_s(function, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        function()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def cpu_s() -> float:
    """User + system CPU of this process and its waited-for children (the pool workers) [s]."""
    own, children = (
        resource.getrusage(resource.RUSAGE_SELF),
        resource.getrusage(resource.RUSAGE_CHILDREN),
    )
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=100)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--scenarios", nargs="+", default=["stage", "box_removal"])
    parser.add_argument("--out", type=Path, default=Path("runs/bench_tune"))
    parser.add_argument(
        "--no-segment-cache", action="store_true", help="segment every frame in every trial"
    )
    args = parser.parse_args()

    start = time.perf_counter()
    suite = load_suite(args.scenarios, args.out / RECORDINGS_DIR)
    print(f"suite ready in {time.perf_counter() - start:.1f} s (recording only the first time)")

    specs = tuple(ParamSpec.parse(text) for text in PARAMS)
    defaults = parameter_defaults([s.name for s in specs])
    weights = ObjectiveWeights()
    print(f"\none trial (defaults), median of {args.repeats}, per recording:")
    print(f"{'recording':<14}{'frames':>7}{'replay s':>10}{'scoring s':>11}{'objective s':>13}")
    totals = [0.0, 0.0, 0.0]
    for entry in suite:
        rec = entry.recording
        params = resolve_params(rec.scenario, defaults, sensor_fields(rec.scenario))
        replay = median_s(
            partial(run_frames, rec.frames, None, rec.scenario, params=params), args.repeats
        )
        full = median_s(partial(replay_report, rec, defaults), args.repeats)
        report = replay_report(rec, defaults)
        reduce = median_s(partial(objective_terms, report, weights, entry.frame_rate_hz), 20)
        scoring = max(full - replay, 0.0)
        totals = [totals[0] + replay, totals[1] + scoring, totals[2] + reduce]
        print(f"{entry.name:<14}{len(rec.frames):>7}{replay:>10.3f}{scoring:>11.3f}{reduce:>13.5f}")
    print(f"{'trial':<14}{'':>7}{totals[0]:>10.3f}{totals[1]:>11.3f}{totals[2]:>13.5f}")

    config = TuneConfig(
        params=specs, trials=args.trials, out_dir=args.out, workers=args.workers, seed=0,
        study_name=f"bench-{time.strftime('%Y%m%d-%H%M%S')}",
    )  # fmt: skip
    report_function = replay_report if args.no_segment_cache else cached_replay_report
    start, cpu_start = time.perf_counter(), cpu_s()
    result = tune(config, suite, report_function=report_function)
    wall, cpu = time.perf_counter() - start, cpu_s() - cpu_start
    print(
        f"\ntune: {result.complete} trials, {args.workers} workers, {wall:.1f} s wall, "
        f"{cpu:.1f} s CPU, segmentation cache {'off' if args.no_segment_cache else 'on'} "
        f"({60 * result.complete / wall:.1f} trials/min, target: 100 trials <= 180 s)"
    )
    print(f"defaults objective {result.defaults_value:.4f}, best {result.best_value:.4f}")
    print(f"best {result.best_params}; results in {args.out}")


if __name__ == "__main__":
    main()
