"""The ``fogsim`` command line: list, run, record, suite, import-bag, scene, compare.

Exit codes: 0 success; 1 a ``--check`` found worse figures, a suite scenario failed (it raised
or its map is poor) or a seed of ``run --seeds`` raised; 2 bad input (unknown scenario, invalid
``--set`` or ``--seeds``, unreadable recording, missing baseline, an argument argparse rejects,
an output path that cannot be written — checked before any work — or a write that failed, e.g.
a full disk); 3 ``run --strict`` and a run's map is poor (the report's ``quality.poor``; the
reasons are printed); 130 interrupted (Ctrl-C). Every error is one line on standard error,
never a traceback; a failed or interrupted run leaves nothing of itself (an earlier result in
its folder stays as it was).

What one command or option alone needs (rosbags, the comparison, the scene export, the
recorder, Rerun's display check, the runners of ``run --seeds`` and of ``suite``, the baselines'
rules of ``suite`` and ``run --strict``, the tuner's) is imported by that command, not here:
``fogsim run`` starts without them (the parser's help needs only ``--seeds``' spec,
:mod:`fogsim.run.seed_spec`).
"""

from __future__ import annotations

import argparse
import gc
import os
import sys
import time
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, NoReturn, TextIO

from fogsim.bags.topics import (
    DEFAULT_BASE_FRAME,
    DEFAULT_DEPTH_TOPIC,
    DEFAULT_JOINT_STATES_TOPIC,
    DEFAULT_MAX_DT_MS,
    DEFAULT_ODOM_FRAME,
    BagOptions,
)
from fogsim.compare.maps import MAP_NAMES
from fogsim.config import CAMERA_MODES, Scenario, find_scenario_files, load_scenario
from fogsim.data.recording import load_recording
from fogsim.errors import FogsimError
from fogsim.eval.report import format_table1
from fogsim.run.output_paths import check_output_path, child_path
from fogsim.run.process_exit import exit_process
from fogsim.run.ray_cluster import RAY_ADDRESS_HELP
from fogsim.run.run_folder import check_run_folder
from fogsim.run.runner import run_scenario
from fogsim.run.seed_spec import SEEDS_ALLOWED, parse_seeds
from fogsim.sim.camera.backends import DEPTH_BACKENDS
from fogsim.tune.cli import add_tune_arguments
from mapper.errors import MapperError

if TYPE_CHECKING:
    from fogsim.run.targets import TargetResult


class _Parser(argparse.ArgumentParser):
    """argparse with its errors on one line (``fogsim run: error: ...``), exit code 2."""

    def error(self, message: str) -> NoReturn:
        """Print the error and the help hint on one line and exit with code 2."""
        self.exit(2, f"{self.prog}: error: {message} (see `{self.prog} --help`)\n")


def _parser() -> argparse.ArgumentParser:
    parser = _Parser(
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
    run.add_argument(
        "--rerun",
        type=Path,
        metavar="FILE.rrd",
        help="also log every frame for the Rerun viewer (needs fogsim[viewer])",
    )
    run.add_argument(
        "--rerun-spawn",
        action="store_true",
        help="log every frame live into a Rerun viewer opened now (needs a display and "
        "fogsim[viewer]; instead of --rerun)",
    )
    run.add_argument("--no-pictures", action="store_true", help="skip the PNGs")
    run.add_argument("--quiet", action="store_true", help="no progress bar")
    run.add_argument(
        "--seeds",
        metavar="SPEC",
        help=f"run once per seed in parallel, into OUT/seed_<n>/, and summarise: {SEEDS_ALLOWED}",
    )
    run.add_argument("--workers", type=int, help="parallel processes for --seeds (default 2)")
    run.add_argument("--ray", metavar="ADDRESS", help=f"for --seeds: {RAY_ADDRESS_HELP}")
    run.add_argument(
        "--strict", action="store_true", help="exit 3 when a run's map is poor (quality.poor)"
    )
    run.add_argument(
        "--targets",
        type=Path,
        metavar="TARGETS.toml",
        help="with --seeds: check the figures against accuracy targets (exit 1 when missed)",
    )
    run.add_argument(
        "--mcap",
        type=Path,
        metavar="BAG",
        help="also write the FOG per frame as grid_map_msgs/GridMap (+ robot pose) into the "
        "rosbag2 bag folder BAG, MCAP storage",
    )

    record = sub.add_parser("record", help="simulate a scenario and save every frame to FILE")
    record.add_argument("scenario", help="scenario name or TOML path")
    record.add_argument("--out", type=Path, required=True, metavar="FILE", help="recording file")
    scenario_options(record)
    record.add_argument("--quiet", action="store_true", help="no progress bar")

    scene = sub.add_parser(
        "scene", help="save the built MuJoCo scene for `python -m mujoco.viewer --mjcf FILE`"
    )
    scene.add_argument("scenario", help="scenario name or TOML path")
    scene.add_argument("--out", type=Path, required=True, metavar="FILE", help="MJCF file")
    scenario_options(scene)

    suite = sub.add_parser("suite", help="run every scenario in parallel and summarise")
    suite.add_argument("directory", nargs="?", type=Path, help="scenario folder")
    suite.add_argument("--out", type=Path, required=True, help="output folder")
    suite.add_argument("--workers", type=int, help="parallel processes (default 2)")
    suite.add_argument("--ray", metavar="ADDRESS", help=RAY_ADDRESS_HELP)
    suite.add_argument(
        "--check", type=Path, metavar="BASELINE.json", help="compare the figures with a baseline"
    )
    suite.add_argument(
        "--targets",
        type=Path,
        metavar="TARGETS.toml",
        help="check the figures against accuracy targets (scenarios/targets.toml: issue 11's)",
    )
    suite.add_argument("--quick", action="store_true", help="quick subset (short runs)")
    suite.add_argument(
        "--seeds", metavar="SPEC", help=f"run every scenario over these seeds: {SEEDS_ALLOWED}"
    )
    suite.add_argument(
        "--write-baseline",
        type=Path,
        metavar="FILE",
        help="store the figures as the baseline's set of this kind of run",
    )
    suite.add_argument(
        "--set",
        dest="assignments",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="override a value in every scenario (e.g. camera.mode=stereo); the baseline keeps "
        "such a run's figures in a set of their own",
    )
    targets = sub.add_parser(
        "targets", help="check a finished suite's (or seeds run's) summary against targets"
    )
    targets.add_argument(
        "suite_dir", type=Path, help="a `fogsim suite --out` or `fogsim run --seeds` folder"
    )
    targets.add_argument("--targets", type=Path, required=True, metavar="TARGETS.toml")
    bag = sub.add_parser(
        "import-bag", help="turn a ROS 1 / ROS 2 bag into a recording that run --replay maps"
    )
    bag.add_argument("bag", type=Path, help="ROS 1 .bag file or ROS 2 bag folder (sqlite3, MCAP)")
    bag.add_argument("--out", type=Path, metavar="FILE", help="recording file to write (.npz)")
    bag.add_argument("--list", action="store_true", help="list the bag's topics and stop")
    bag.add_argument(
        "--depth-topic",
        default=DEFAULT_DEPTH_TOPIC,
        help=f"depth images, 32FC1 [m] or 16UC1 [mm] (default {DEFAULT_DEPTH_TOPIC})",
    )
    bag.add_argument(
        "--camera-info-topic", help="CameraInfo topic (default: camera_info beside the depth topic)"
    )
    bag.add_argument(
        "--odom-frame",
        default=DEFAULT_ODOM_FRAME,
        help=f"world frame (default {DEFAULT_ODOM_FRAME})",
    )
    bag.add_argument(
        "--base-frame",
        default=DEFAULT_BASE_FRAME,
        help=f"robot frame on the ground (default {DEFAULT_BASE_FRAME})",
    )
    bag.add_argument(
        "--urdf",
        type=Path,
        metavar="FILE",
        help="the robot's URDF: the camera in the base frame from joint states through it "
        "(default: from /tf)",
    )
    bag.add_argument(
        "--joint-states-topic",
        default=DEFAULT_JOINT_STATES_TOPIC,
        help=f"JointState topic read with --urdf (default {DEFAULT_JOINT_STATES_TOPIC})",
    )
    bag.add_argument(
        "--max-dt-ms",
        type=float,
        default=DEFAULT_MAX_DT_MS,
        help=f"largest gap from an image's stamp to a tf or joint state sample [ms] "
        f"(default {DEFAULT_MAX_DT_MS:g})",
    )
    compare = sub.add_parser(
        "compare", help="replay recordings into every height map and score them with the truth"
    )
    compare.add_argument(
        "inputs",
        nargs="+",
        metavar="RECORDING|SCENARIO",
        help="recordings, or scenarios to simulate",
    )
    compare.add_argument("--out", type=Path, required=True, help="folder for the tables")
    compare.add_argument(
        "--maps",
        default=",".join(MAP_NAMES),
        help=f"maps to compare, the FOG always among them (default {','.join(MAP_NAMES)})",
    )
    compare.add_argument(
        "--seeds", metavar="SPEC", help=f"seeds of SCENARIO inputs: {SEEDS_ALLOWED}"
    )
    compare.add_argument("--no-pictures", action="store_true", help="skip the PNGs")
    compare.add_argument("--quiet", action="store_true", help="print only the files written")
    compare.add_argument("--ray", metavar="ADDRESS", help=RAY_ADDRESS_HELP)
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


def _check_replay_camera(scenario: Scenario, recorded: Scenario | None) -> None:
    """Refuse ``--camera-mode`` / ``--set camera.*`` that contradict a recording's camera.

    A replay maps the recorded frames; its segmentation's noise model follows the camera that
    made them, so a replay keeps the recording's camera table whichever scenario is named.
    """
    if recorded is None or scenario.camera == recorded.camera:
        return
    raise FogsimError(
        f"a replay maps the recording's frames, made by its camera (mode "
        f"'{recorded.camera.mode}'); --camera-mode and --set camera.* can't change them: "
        f"leave them out, or simulate with `fogsim run {scenario.name} "
        f"--camera-mode {scenario.camera.mode}`"
    )


def _out(args: argparse.Namespace, name: str) -> Path:
    """The run's folder: ``--out``, or ``runs/<name>`` (a name from data must stay in runs/)."""
    if args.out is not None:
        return args.out
    out = child_path(Path("runs"), name, "scenario name")
    check_run_folder(out, "output folder (default of --out)")
    return out


def _cmd_list() -> int:
    """Every scenario with its description; a file that does not load is listed as invalid."""
    for path in find_scenario_files():
        try:
            scenario = load_scenario(path)
            print(f"{scenario.name:<18} {scenario.description}")
        except FogsimError as exc:
            reason = " ".join(str(exc).split())  # one line per file
            print(f"{path.stem:<18} (invalid: {reason})")
    return 0


def _print_missed(results: Sequence[TargetResult], stream: TextIO) -> list[TargetResult]:
    """Print a ``MISSED`` line for each missed target check on ``stream``; the missed ones."""
    missed = [result for result in results if not result.met]
    for result in missed:
        print(f"MISSED {result.line()}", file=stream)
    return missed


def _strict_exit(reasons_by_run: dict[str, tuple[str, ...]]) -> int:
    """Exit code of ``--strict``: 3 (reasons printed) when a run's map is poor, else 0."""
    poor = {run: reasons for run, reasons in reasons_by_run.items() if reasons}
    for run, reasons in poor.items():
        for reason in reasons:
            print(f"fogsim: --strict: {run}: poor map: {reason}", file=sys.stderr)
    return 3 if poor else 0


def _cmd_run(args: argparse.Namespace) -> int:
    if args.seeds is not None:
        return _cmd_run_seeds(args)
    if args.workers is not None:
        raise FogsimError("--workers sets the processes of --seeds; give --seeds SPEC too")
    if args.ray is not None:
        raise FogsimError("--ray runs the seeds of --seeds on a cluster; give --seeds SPEC too")
    if args.targets is not None:
        raise FogsimError(
            "--targets bounds figures over seeds (the worst seed, the mean): give --seeds SPEC "
            "too, or check a suite (`fogsim suite --targets`)"
        )
    if args.out is not None:
        check_run_folder(args.out, "--out")
    if args.mcap is not None:
        from fogsim.bags.write import check_bag_target  # rosbags: only for --mcap

        check_output_path(check_bag_target(args.mcap, "--mcap"), "folder", "--mcap")
    if args.rerun is not None:
        check_output_path(args.rerun, "file", "--rerun")
    if args.rerun_spawn:
        if args.rerun is not None:
            raise FogsimError(
                "give --rerun FILE.rrd or --rerun-spawn, not both (the viewer can save what it "
                "shows)"
            )
        from fogsim.viz.rerun_log import check_display  # matplotlib: only for Rerun

        check_display()
    replay = None
    if args.replay is not None:
        replay = load_recording(args.replay)
        scenario = replay.scenario
        if args.scenario is not None:
            scenario = load_scenario(args.scenario)
            if replay.scenario is not None:  # the frames were made by the recording's camera
                scenario = replace(scenario, camera=replay.scenario.camera)
        if scenario is not None:
            scenario = _with_options(scenario, args)
            _check_replay_camera(scenario, replay.scenario)
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
    out = _out(args, name)
    report = run_scenario(
        scenario,
        out,
        replay=replay,
        pictures=not args.no_pictures,
        video=args.video,
        progress=not args.quiet,
        depth_backend=args.depth_backend,
        mcap=args.mcap,
        rerun=args.rerun,
        rerun_spawn=args.rerun_spawn,
    )
    print(format_table1(report))
    timing = report.timing
    print(
        f"{timing.frames} frames, mapper update {timing.update_ms.median} ms median, "
        f"wall {timing.wall_s} s -> {out / 'report.json'}"
    )
    if not args.strict:
        return 0
    from fogsim.run.baseline import poor_reasons  # only for --strict

    return _strict_exit({name: poor_reasons(report)})


def _workers(args: argparse.Namespace) -> int:
    """``--workers`` (default 2), checked; refused beside ``--ray`` (the cluster's CPUs run)."""
    if args.ray is not None and args.workers is not None:
        raise FogsimError(
            "give --workers N (local processes) or --ray ADDRESS (the cluster's CPUs), not both"
        )
    from fogsim.run.seeds import check_workers  # the runner of seeds: only for --workers

    workers = args.workers if args.workers is not None else 2
    check_workers(workers)
    return workers


def _cmd_run_seeds(args: argparse.Namespace) -> int:
    """``fogsim run SCENARIO --seeds SPEC``: the seeds in parallel, then their summary."""
    from fogsim.run.seeds import run_seeds, worst_lines  # only for --seeds
    from fogsim.run.targets import check_seeds_targets, load_targets

    if args.replay is not None:
        raise FogsimError(
            "--seeds simulates the scenario once per seed; a recording (--replay) has fixed "
            "frames: give one of them"
        )
    if args.seed is not None:
        raise FogsimError("give either --seed N or --seeds SPEC, not both")
    if args.mcap is not None:
        raise FogsimError("--mcap writes one run's maps; give --seed N instead of --seeds SPEC")
    if args.rerun is not None or args.rerun_spawn:
        raise FogsimError("--rerun logs one run: give --seed N instead of --seeds SPEC")
    if args.scenario is None:
        raise FogsimError("run --seeds needs a SCENARIO (see `fogsim list`)")
    targets = load_targets(args.targets) if args.targets is not None else None  # before runs
    seeds = parse_seeds(args.seeds)
    workers = _workers(args)
    if args.out is not None:
        check_run_folder(args.out, "--out")
    scenario = _load(args.scenario, args)
    out = _out(args, scenario.name)
    summary = run_seeds(
        scenario,
        seeds,
        out,
        workers=workers,
        pictures=not args.no_pictures,
        video=args.video,
        depth_backend=args.depth_backend,
        ray_address=args.ray,
    )
    for run in summary.runs:
        print(f"seed {run.seed}: {run.frames} frames, {run.wall_s} s, {run.status()}")
    for line in worst_lines(summary.figures):
        print(line)
    print(
        f"{summary.scenario}: {len(summary.runs)} seeds in {summary.wall_s} s "
        f"-> {out / 'summary.md'}"
    )
    failed = [run for run in summary.runs if run.error is not None]
    for run in failed:
        print(f"FAILED seed {run.seed}: {run.error}", file=sys.stderr)
    missed = []
    if targets is not None:
        results = check_seeds_targets(summary, targets)
        missed = _print_missed(results, sys.stderr)
        print(f"targets: {len(results) - len(missed)} of {len(results)} checks met")
    if failed or missed:
        return 1
    return _strict_exit({f"seed {r.seed}": r.poor for r in summary.runs}) if args.strict else 0


def _cmd_record(args: argparse.Namespace) -> int:
    from fogsim.run.record import record_scenario

    start = time.perf_counter()
    check_output_path(args.out, "file", "--out")
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


def _cmd_scene(args: argparse.Namespace) -> int:
    from fogsim.sim.export import export_scene

    check_output_path(args.out, "file", "--out")
    scenario = _load(args.scenario, args)
    path = export_scene(scenario, args.out)
    size_kb = os.path.getsize(path) / 1e3
    print(
        f"saved the scene of {scenario.name} to {path} ({size_kb:.0f} kB; the meshes, height "
        f"fields and textures it names beside it); "
        f"open it with `python -m mujoco.viewer --mjcf {path}`"
    )
    return 0


def _cmd_suite(args: argparse.Namespace) -> int:
    from fogsim.run.baseline import REGENERATE, baseline_to_update, load_baseline, write_baseline
    from fogsim.run.suite import (
        check_against_baseline,
        check_suite_targets,
        run_suite,
        update_baseline,
    )
    from fogsim.run.targets import load_targets, missed_summary

    seeds = parse_seeds(args.seeds) if args.seeds is not None else None
    workers = _workers(args)
    check_run_folder(args.out, "--out")
    if args.write_baseline is not None:
        check_output_path(args.write_baseline, "file", "--write-baseline")
    baseline = None
    if args.check is not None:
        if not args.check.is_file():
            raise FogsimError(
                f"--check {args.check}: no such baseline file; write one with "
                f"`{REGENERATE.format(path=args.check)}`"
            )
        baseline = load_baseline(args.check)
    targets = load_targets(args.targets) if args.targets is not None else None  # before the runs
    # Read the baseline to extend now: a broken file fails before the runs, not after them.
    existing = None
    if args.write_baseline is not None:
        existing = baseline_to_update(args.write_baseline)
    summary = run_suite(
        args.directory,
        args.out,
        workers=workers,
        quick=args.quick,
        seeds=seeds,
        overrides=args.assignments,
        baseline=baseline,
        ray_address=args.ray,
        targets=targets,
    )
    failures = summary.failures()
    for name, reasons in failures.items():
        for reason in reasons:
            print(f"FAILED {name}: {reason}", file=sys.stderr)
    comparison = None
    if baseline is not None:
        comparison = check_against_baseline(summary, baseline)  # as summary.md shows it
        for line in comparison:
            print(f"WORSE {line}", file=sys.stderr)
    missed = []
    if targets is not None:
        results = check_suite_targets(summary, targets)
        missed = _print_missed(results, sys.stderr)
        if missed:
            print(f"MISSED per scenario: {missed_summary(results)}", file=sys.stderr)
    if args.write_baseline is not None:
        write_baseline(args.write_baseline, update_baseline(existing, summary))
    compared = (
        "no baseline given: nothing compared"
        if comparison is None
        else f"{len(comparison)} figures worse than the baseline"
    )
    over = f" over seeds {summary.seeds}" if summary.seeds is not None else ""
    aimed = f"; {len(missed)} targets missed" if targets is not None else ""
    print(
        f"{len(summary.scenarios)} scenarios{over} in {summary.wall_s} s; "
        f"{len(failures)} failed; {compared}{aimed} -> {args.out / 'summary.md'}"
    )
    return 1 if failures or comparison or missed else 0


def _cmd_targets(args: argparse.Namespace) -> int:
    """``fogsim targets DIR --targets FILE``: exit 1 when a target is missed.

    ``DIR`` is a suite's folder or one of ``fogsim run SCENARIO --seeds`` (its summary's
    ``format`` says which; anything else is read as a suite's, whose loader names the problem).
    """
    import json

    from fogsim.eval.report.io import load_json
    from fogsim.run.seeds import SeedsSummary
    from fogsim.run.suite import check_suite_targets, load_suite_summary
    from fogsim.run.targets import check_seeds_targets, load_targets, missed_summary

    targets = load_targets(args.targets)
    path = args.suite_dir / "summary.json"
    try:
        kind = json.loads(path.read_bytes()).get("format")
    except (OSError, ValueError, AttributeError):
        kind = None  # the suite loader below says what is wrong
    if kind == "fogsim-seeds":
        results = check_seeds_targets(load_json(path, SeedsSummary, "seeds summary"), targets)
    else:
        results = check_suite_targets(load_suite_summary(path), targets)
    missed = _print_missed(results, sys.stdout)
    print(f"per scenario: {missed_summary(results)}")
    print(
        f"{len(results) - len(missed)} of {len(results)} checks met, {len(missed)} missed "
        f"({args.targets} on {args.suite_dir})"
    )
    return 1 if missed else 0


def _cmd_import_bag(args: argparse.Namespace) -> int:
    """``fogsim import-bag BAG --out FILE`` (or ``--list``)."""
    from fogsim.bags.read import bag_topics, import_bag  # rosbags: only for this command

    if args.list:
        for topic in bag_topics(args.bag):
            print(f"{topic.name:<40} {topic.msgtype:<36} {topic.count:>8}")
        return 0
    if args.out is None:
        raise FogsimError("import-bag needs --out FILE (the recording to write) or --list")
    check_output_path(args.out, "file", "--out")
    options = BagOptions(
        depth_topic=args.depth_topic,
        camera_info_topic=args.camera_info_topic,
        odom_frame=args.odom_frame,
        base_frame=args.base_frame,
        max_dt_ms=args.max_dt_ms,
        urdf_path=args.urdf,
        joint_states_topic=args.joint_states_topic,
    )
    imported = import_bag(args.bag, args.out, options)
    intrinsics = imported.intrinsics
    print(
        f"imported {imported.frames} frames ({intrinsics.width}×{intrinsics.height}, "
        f"{imported.last_s - imported.first_s:.2f} s) of {args.bag} to {imported.path}; map "
        f"them with `fogsim run --replay {imported.path}`"
    )
    return 0


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
        if args.command == "import-bag":
            return _cmd_import_bag(args)
        if args.command == "scene":
            return _cmd_scene(args)
        if args.command == "targets":
            return _cmd_targets(args)
        if args.command == "compare":
            from fogsim.compare.command import compare_main  # only for this command

            return compare_main(
                args.inputs,
                args.maps,
                args.out,
                seeds=args.seeds,
                pictures=not args.no_pictures,
                quiet=args.quiet,
                ray_address=args.ray,
            )
        return _cmd_suite(args)
    except (FogsimError, MapperError) as exc:
        print(f"fogsim: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("fogsim: interrupted; nothing of this run was written", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())


def entry() -> NoReturn:
    """The installed ``fogsim`` command: :func:`main`, then the process ends at once.

    The objects its imports made (modules, numba's types and registries: about 0.45 s of
    them) are moved out of the garbage collector's sight first (`gc.freeze`): they live as
    long as the process, and every full collection of a run walked them all again. Without
    the interpreter's teardown: :func:`fogsim.run.process_exit.exit_process`.
    """
    gc.freeze()
    exit_process(main())
