"""The ``fogsim`` command line: ``list``, ``run``, ``record``, ``suite``.

Exit codes: 0 success, 1 a ``--check`` found worse metrics or a suite scenario failed,
2 bad input (unknown scenario, invalid ``--set``, unreadable recording).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from fogsim.atomic import write_text_atomic
from fogsim.config import CAMERA_MODES, Scenario, find_scenario_files, load_scenario
from fogsim.data.recording import load_recording
from fogsim.errors import FogsimError
from fogsim.eval.report import format_table1
from fogsim.run.baseline import load_baseline, write_baseline
from fogsim.run.record import record_scenario
from fogsim.run.runner import run_scenario
from fogsim.run.suite import check_against_baseline, run_suite, summary_markdown, update_baseline
from fogsim.sim.camera.depth import DEPTH_BACKENDS
from fogsim.tune.cli import add_tune_arguments
from mapper.errors import MapperError


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="fogsim",
        description="Floor and obstacle height map (Gutmann et al.) on a simulated humanoid.",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    sub.add_parser("list", help="list the scenarios")

    def scenario_options(p: argparse.ArgumentParser) -> None:
        p.add_argument(
            "--set",
            dest="assignments",
            action="append",
            default=[],
            metavar="KEY=VALUE",
            help="override a scenario value, e.g. mapper.p_occ=0.7 (repeatable)",
        )
        p.add_argument("--seed", type=int, help="random seed (overrides the scenario's)")
        p.add_argument("--camera-mode", choices=CAMERA_MODES, help="camera mode to simulate")
        p.add_argument(
            "--depth-backend",
            choices=DEPTH_BACKENDS,
            default="renderer",
            help="depth by mujoco.Renderer (EGL) or by mj_multiRay (no OpenGL)",
        )

    run = sub.add_parser("run", help="run a scenario and write report.json + pictures")
    run.add_argument("scenario", nargs="?", help="scenario name or TOML path")
    run.add_argument("--out", type=Path, help="output folder (default runs/<scenario>)")
    scenario_options(run)
    run.add_argument("--replay", type=Path, metavar="FILE", help="feed a recording instead")
    run.add_argument("--video", action="store_true", help="also write run.mp4")
    run.add_argument("--no-pictures", action="store_true", help="skip the PNGs")
    run.add_argument("--quiet", action="store_true", help="no progress bar")

    record = sub.add_parser("record", help="simulate a scenario and save every frame to FILE")
    record.add_argument("scenario", help="scenario name or TOML path")
    record.add_argument("--out", type=Path, required=True, metavar="FILE", help="recording file")
    scenario_options(record)
    record.add_argument("--quiet", action="store_true", help="no progress bar")

    suite = sub.add_parser("suite", help="run every scenario in parallel and summarise")
    suite.add_argument("directory", nargs="?", type=Path, help="scenario folder")
    suite.add_argument("--out", type=Path, required=True, help="output folder")
    suite.add_argument("--workers", type=int, default=2, help="parallel processes (default 2)")
    suite.add_argument("--check", type=Path, metavar="BASELINE.json", help="compare metrics")
    suite.add_argument("--quick", action="store_true", help="quick subset (short runs)")
    suite.add_argument(
        "--write-baseline", type=Path, metavar="FILE", help="store the metrics as a baseline"
    )
    suite.add_argument(
        "--set",
        dest="assignments",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="override a value in every scenario",
    )
    add_tune_arguments(sub)
    return parser


def _load(name_or_path: str, args: argparse.Namespace) -> Scenario:
    """Load a scenario and apply ``--set``, ``--seed`` and ``--camera-mode``."""
    scenario = load_scenario(name_or_path)
    return _with_options(scenario, args)


def _with_options(scenario: Scenario, args: argparse.Namespace) -> Scenario:
    """Apply ``--set``, ``--seed`` and ``--camera-mode`` to a loaded scenario."""
    assignments = list(args.assignments)
    if args.seed is not None:
        assignments.append(f"seed={args.seed}")
    if getattr(args, "camera_mode", None):
        assignments.append(f"camera.mode={args.camera_mode}")
    return scenario.with_overrides(assignments) if assignments else scenario


def _cmd_list() -> int:
    for path in find_scenario_files():
        try:
            scenario = load_scenario(path)
            print(f"{scenario.name:<18} {scenario.description}")
        except FogsimError as exc:
            print(f"{path.stem:<18} (invalid: {exc})")
    return 0


def _cmd_run(args: argparse.Namespace) -> int:
    replay = None
    if args.replay is not None:
        replay = load_recording(args.replay)
        scenario = replay.scenario
        if args.scenario is not None:
            scenario = load_scenario(args.scenario)
        if scenario is not None:
            scenario = _with_options(scenario, args)
        elif args.assignments:
            raise FogsimError(
                "--set needs a scenario: this recording has none (real data); name one, e.g. "
                "`fogsim run flat_floor --replay FILE --set mapper.p_occ=0.7`"
            )
    elif args.scenario is None:
        raise FogsimError("run needs a SCENARIO (see `fogsim list`) or --replay FILE")
    else:
        scenario = _load(args.scenario, args)
    name = scenario.name if scenario is not None else Path(args.replay).stem
    out = args.out if args.out is not None else Path("runs") / name
    report = run_scenario(
        scenario,
        out,
        replay=replay,
        pictures=not args.no_pictures,
        video=args.video,
        progress=not args.quiet,
        depth_backend=args.depth_backend,
    )
    print(format_table1(report))
    timing = report.timing
    print(
        f"{timing.frames} frames, mapper update {timing.update_ms.median} ms median, "
        f"wall {timing.wall_s} s -> {out / 'report.json'}"
    )
    return 0


def _cmd_record(args: argparse.Namespace) -> int:
    start = time.perf_counter()
    scenario = _load(args.scenario, args)
    path, frames = record_scenario(
        scenario, args.out, depth_backend=args.depth_backend, progress=not args.quiet
    )
    size_mb = os.path.getsize(path) / 1e6
    print(
        f"recorded {frames} frames of {scenario.name} to {path} "
        f"({size_mb:.1f} MB, {time.perf_counter() - start:.1f} s)"
    )
    return 0


def _cmd_suite(args: argparse.Namespace) -> int:
    baseline = load_baseline(args.check) if args.check is not None else None
    summary = run_suite(
        args.directory,
        args.out,
        workers=args.workers,
        quick=args.quick,
        overrides=args.assignments,
    )
    failed = [name for name, run in summary.scenarios.items() if run.error]
    for name in failed:
        print(f"FAILED {name}: {summary.scenarios[name].error}", file=sys.stderr)
    problems: list[str] = []
    if baseline is not None:
        problems = check_against_baseline(summary, baseline)
        write_text_atomic(args.out / "summary.md", summary_markdown(summary, problems))
        for line in problems:
            print(f"WORSE {line}", file=sys.stderr)
    if args.write_baseline is not None:
        existing = None
        if args.write_baseline.exists():
            existing = load_baseline(args.write_baseline)
        write_baseline(args.write_baseline, update_baseline(existing, summary))
    print(
        f"{len(summary.scenarios)} scenarios in {summary.wall_s} s; "
        f"{len(failed)} failed; {len(problems)} metrics worse than the baseline -> "
        f"{args.out / 'summary.md'}"
    )
    return 1 if failed or problems else 0


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``fogsim`` command; returns the exit code.

    Errors of the testbed (:class:`FogsimError`) and of the mapper library it drives
    (:class:`MapperError`, e.g. a recording whose data the mapper rejects) are bad input: one
    line on standard error and exit code 2, never a traceback.
    """
    args = _parser().parse_args(argv)
    try:
        if args.command == "list":
            return _cmd_list()
        if args.command == "run":
            return _cmd_run(args)
        if args.command == "record":
            return _cmd_record(args)
        if args.command == "tune":
            return args.func(args)
        return _cmd_suite(args)
    except (FogsimError, MapperError) as exc:
        print(f"fogsim: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
