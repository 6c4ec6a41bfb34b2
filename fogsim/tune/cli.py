"""The ``fogsim tune`` subcommand: its arguments, and running it from them.

Adding the arguments imports only the tuner's configuration (every ``fogsim`` command builds
the whole parser); what running it needs is imported by :func:`run_tune`.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from fogsim.tune.config import RECORDINGS_DIR, SamplerKind, TuneConfig
from fogsim.tune.objective import ObjectiveWeights
from fogsim.tune.space import ParamSpec, check_ranges


def add_tune_arguments(
    subparsers: argparse._SubParsersAction[argparse.ArgumentParser],
) -> argparse.ArgumentParser:
    """Add the ``tune`` subcommand to an argparse subparsers object; returns its parser."""
    parser = subparsers.add_parser(
        "tune",
        help="tune mapper/segmentation thresholds over a suite of recordings",
        description="Search mapper and segmentation thresholds (Optuna TPE, random or grid) "
        "by replaying a suite's recordings; results and the study database go to --out, and "
        "running the same command again resumes the study.",
        epilog="example: fogsim tune scenarios --quick --param p_occ=0.55:0.95 "
        "--param eps_m=0.005:0.05:log --trials 40 --workers 2 --out runs/tune",
    )
    parser.add_argument(
        "suite",
        nargs="+",
        help="directories of scenarios (*.toml) / recordings (*.npz), such files, or "
        "scenario names",
    )
    parser.add_argument(
        "--quick", action="store_true", help="only the suite's quick subset, cut short"
    )
    parser.add_argument(
        "--param",
        action="append",
        required=True,
        metavar="NAME=LO:HI[:log]",
        help="a tuned parameter and its range, e.g. p_occ=0.55:0.95 or seg.<name>=1:9",
    )
    parser.add_argument("--trials", type=int, default=50, help="total scored trials (default 50)")
    parser.add_argument(
        "--sampler", choices=[s.value for s in SamplerKind], default=SamplerKind.TPE.value
    )
    parser.add_argument("--grid-points", type=int, default=5, help="values per axis (grid)")
    parser.add_argument("--seed", type=int, default=0, help="sampler seed (default 0)")
    where = parser.add_mutually_exclusive_group()
    where.add_argument("--workers", type=int, default=1, help="local scoring processes")
    where.add_argument(
        "--ray",
        metavar="ADDRESS",
        default=None,
        help="run trials on a Ray cluster: auto (this machine's), HOST:PORT (a head), or "
        "local (a private instance on 127.0.0.1)",
    )
    parser.add_argument(
        "--weight",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="objective weight (repeatable): table1_mm, cell_error_pct, unknown_pct, "
        "obstacle_missed_pct, unsafe_cells, clearing_s, missing_row_mm, never_cleared_s; "
        "see fogsim.tune.objective",
    )
    parser.add_argument("--out", required=True, type=Path, help="output directory")
    parser.add_argument("--study-name", default="fogsim-tune")
    parser.add_argument("--top", type=int, default=10, help="rows of the top-trials table")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    parser.add_argument("--no-pictures", action="store_true", help="no per-parameter PNGs")
    parser.set_defaults(func=run_tune)
    return parser


def run_tune(args: argparse.Namespace) -> int:
    """Run ``fogsim tune`` from parsed arguments; prints the best block and the top table."""
    from fogsim.tune.executors import check_ray_address
    from fogsim.tune.segment_cache import cached_replay_report
    from fogsim.tune.study import tune  # Optuna: imported by this command only (package doc)
    from fogsim.tune.suite import load_suite

    params = tuple(ParamSpec.parse(text) for text in args.param)
    check_ranges(params)  # before the suite is recorded: errors come before long work
    config = TuneConfig(
        params=params,
        trials=args.trials,
        out_dir=args.out,
        sampler=SamplerKind(args.sampler),
        seed=args.seed,
        workers=args.workers,
        ray_address=args.ray,
        weights=ObjectiveWeights.from_assignments(args.weight),
        grid_points=args.grid_points,
        study_name=args.study_name,
        top=args.top,
        progress=not args.no_progress,
        pictures=not args.no_pictures,
    )
    if config.ray_address is not None:
        check_ray_address(config.ray_address)
    suite = load_suite(args.suite, config.out_dir / RECORDINGS_DIR, quick=args.quick)
    result = tune(config, suite, report_function=cached_replay_report)
    print((result.out_dir / "best_params.toml").read_text(encoding="utf-8"))
    print((result.out_dir / "trials.md").read_text(encoding="utf-8"))
    return 0
