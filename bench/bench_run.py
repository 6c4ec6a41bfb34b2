"""Wall time of ``fogsim run`` as the user sees it, and where it goes.

Usage:
    .venv/bin/python bench/bench_run.py [SCENARIO] [--repeats N] [--replay FILE] [--cold N]
        [--parts] [--overlap N] [--ahead N] [--no-commands] [--no-run] [--tree DIR ...]

Every figure is the median of N repeats (their minimum and all of them printed), each command
a fresh ``python -m fogsim`` process run from this tree (``PYTHONPATH`` = the tree), with the load
average (``os.getloadavg``, 2 cores) noted before and after each measurement. With
``--tree DIR`` (repeatable) the commands (``run``, ``replay``, ``cold``) run from each tree
instead, their repeats interleaved (tree A, tree B, tree A, ...) so the load hits them alike;
the in-process figures (``--overlap``, ``--ahead``, ``--parts``) are this tree's:

- ``run``: ``fogsim run SCENARIO --out TMP --quiet`` with pictures, warm caches; its CPU time (user
  + sys of the child and of the picture processes it forks) beside the wall time: on a loaded
  machine the wall time hides what the run costs, the CPU time does not show the overlap of
  simulation and mapping; and the CPU time of its main, simulation and segmentation threads (on a
  loaded machine the longest of them bounds the wall time a quiet one would show);
- ``teardown``: of ``run``, the time from the last ``atexit`` handler to the process's exit
  (the interpreter's finalisation: modules freed, native destructors);
- ``replay`` (``--replay FILE``): ``fogsim run --replay FILE --out TMP --quiet``, pictures on
  (``--no-run``: the replay without ``run``: the caches are warmed by a replay); its CPU time
  counts the segmentation process it forks (``fogsim.mapping.segment_process``), whose thread
  figure is then 0;
- ``cold`` (``--cold N``, N repeats): ``run`` on a fresh machine: ``NUMBA_CACHE_DIR`` and
  ``FOGSIM_CACHE`` empty folders (numba compiles every kernel, the robot's meshes are
  converted, the scene compiled);
- ``--overlap N``: in this process, interleaved N times (so the load hits both alike), the
  frame loop of a run (simulation + pipeline + scoring, no set-up, no pictures) with the
  simulation on its own thread (:class:`~fogsim.sim.background.BackgroundSimulation`) and in
  line (frames from :meth:`Simulation.frames` fed as they come);
- ``--ahead N`` (with ``--replay``): in this process, interleaved N times, the frame loop of
  the replay with its frames segmented on a second thread
  (:class:`~fogsim.mapping.prefetch.SegmentAhead`) and in line: wall, CPU and the main
  thread's CPU;
- ``--parts``: the run's stages one after the other in this process (imports in a child):
  scene set-up, simulation alone, pipeline + scoring on the simulated frames, pictures.
"""

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
os.environ.setdefault("MUJOCO_GL", "egl")
os.environ.setdefault("MESA_SHADER_CACHE_DISABLE", "true")
sys.path.insert(0, str(ROOT))

_CHILD = (
    "import atexit, runpy, sys, threading, time\n"
    "sys.argv = ['fogsim', *sys.argv[1:]]\n"
    "atexit.register(lambda: print(f'@main_end {time.time()!r}', file=sys.stderr, flush=True))\n"
    "def _cpu(name): print(f'@thread {name} {time.thread_time()!r}', file=sys.stderr, flush=True)\n"
    "atexit.register(lambda: _cpu('main'))\n"
    "_run = threading.Thread.run\n"
    "def _timed_run(self):\n"
    "    try:\n"
    "        _run(self)\n"
    "    finally:\n"
    "        _cpu(self.name)\n"
    "threading.Thread.run = _timed_run\n"
    "runpy.run_module('fogsim', run_name='__main__')\n"
)
"""``python -m fogsim`` that prints the time its last ``atexit`` handler ran (registered first,
it runs last, also with :func:`fogsim.run.process_exit.exit_process`): the rest is teardown;
and the CPU time of each of its threads when it ends (the main thread's at exit)."""

THREADS = ("main", "fogsim-simulation", "fogsim-segment-ahead")
"""The threads whose CPU time ``run`` and ``replay`` report (0 when a run has no such thread)."""


def load_note() -> str:
    """The 1, 5 and 15 minute load averages."""
    return "load " + "/".join(f"{x:.1f}" for x in os.getloadavg())


def fogsim(args: list[str], env: dict[str, str], tree: Path = ROOT) -> tuple[float, ...]:
    """Run ``fogsim ARGS`` in a child from ``tree`` (its ``PYTHONPATH`` in ``env``): wall [s],
    CPU user + sys [s], teardown [s], then the CPU time [s] of each of :data:`THREADS`."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-c", _CHILD, *args],
        env=env,
        cwd=tree,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        check=False,
    )
    end_wall, wall = time.time(), time.perf_counter() - start
    if done.returncode != 0:
        raise SystemExit(f"fogsim {' '.join(args)} failed:\n{done.stderr}")
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    main_end = float(done.stderr.rsplit("@main_end ", 1)[1].split()[0])
    threads = dict.fromkeys(THREADS, 0.0)
    for line in done.stderr.splitlines():
        if line.startswith("@thread "):
            name, seconds = line.removeprefix("@thread ").rsplit(" ", 1)
            threads[name] = threads.get(name, 0.0) + float(seconds)
    return wall, cpu, end_wall - main_end, *(threads[name] for name in THREADS)


def repeat(
    label: str,
    n: int,
    measure: Callable[[Path], tuple[float, ...]],
    names: tuple[str, ...],
    trees: list[Path],
) -> None:
    """Print the median and all values of each figure ``measure(tree)`` returns over ``n``
    calls per tree, the trees interleaved (named when there are several)."""
    note = load_note()
    values: dict[Path, list[tuple[float, ...]]] = {tree: [] for tree in trees}
    for _ in range(n):
        for tree in trees:
            values[tree].append(measure(tree))
    for tree in trees:
        if len(trees) > 1:
            print(f"  {tree}")
        for i, name in enumerate(names):
            column = [v[i] for v in values[tree]]
            print(
                f"  {label + ' ' + name:<34} median {statistics.median(column):6.2f} s   "
                f"min {min(column):6.2f} s   "
                f"all {[round(v, 2) for v in column]}"
            )
    print(f"  {'':<34} {note} before, {load_note()} after")


def parts(scenario_name: str, n: int, env: dict[str, str]) -> None:
    """The run's stages one after the other, each the median of ``n``."""
    imports = [fogsim_import(env) for _ in range(n)]  # children: this process has imported
    from fogsim.config import load_scenario, resolve_params
    from fogsim.run.runner import run_frames
    from fogsim.run.warmup import warm_up_kernels
    from fogsim.sim.simulation import Simulation
    from fogsim.viz.pictures import write_pictures

    scenario = load_scenario(scenario_name)
    warm_up_kernels(resolve_params(scenario), stream=None)
    rows: dict[str, list[float]] = {
        name: [] for name in ("set-up", "simulation", "pipeline+scoring", "pictures")
    }
    note = load_note()
    for _ in range(n):
        start = time.perf_counter()
        simulation = Simulation(scenario)
        rows["set-up"].append(time.perf_counter() - start)
        start = time.perf_counter()
        frames = list(simulation.frames())
        rows["simulation"].append(time.perf_counter() - start)
        simulation.close()
        start = time.perf_counter()
        result = run_frames(frames, simulation.truth_at, scenario)
        rows["pipeline+scoring"].append(time.perf_counter() - start)
        with tempfile.TemporaryDirectory() as tmp:
            start = time.perf_counter()
            write_pictures(result, scenario, tmp)
            rows["pictures"].append(time.perf_counter() - start)
    print(
        f"  {'imports (child)':<24} median {statistics.median(imports):6.2f} s   "
        f"all {[round(v, 2) for v in imports]}"
    )
    for name, column in rows.items():
        print(
            f"  {name:<24} median {statistics.median(column):6.2f} s   "
            f"all {[round(v, 2) for v in column]}"
        )
    print(f"  {'':<24} {note} before, {load_note()} after")


def overlap(scenario_name: str, n: int) -> None:
    """The frame loop with the simulation on its own thread against in line, interleaved."""
    from fogsim.config import load_scenario, resolve_params
    from fogsim.run.runner import run_frames
    from fogsim.run.warmup import warm_up_kernels
    from fogsim.sim.background import BackgroundSimulation
    from fogsim.sim.simulation import Simulation

    scenario = load_scenario(scenario_name)
    warm_up_kernels(resolve_params(scenario), stream=None)
    rows: dict[str, list[float]] = {"frames in line": [], "frames overlapped": []}
    note = load_note()
    for _ in range(n):
        with Simulation(scenario) as simulation:
            start = time.perf_counter()
            # In line: the frames made on this thread (`segment_ahead` would pull them on a
            # second thread, where the renderer's OpenGL context is not current).
            run_frames(simulation.frames(), simulation.truth_at, scenario, segment_ahead=False)
            rows["frames in line"].append(time.perf_counter() - start)
        with BackgroundSimulation(lambda: Simulation(scenario)) as background:
            background.frame_count  # noqa: B018 (waits for the set-up: not timed)
            start = time.perf_counter()
            run_frames(background, background.truth_at, scenario)
            rows["frames overlapped"].append(time.perf_counter() - start)
    for name, column in rows.items():
        print(
            f"  {name:<24} median {statistics.median(column):6.2f} s   "
            f"all {[round(v, 2) for v in column]}"
        )
    print(f"  {'':<24} {note} before, {load_note()} after")


def ahead(recording: Path, n: int) -> None:
    """The frame loop of a replay with the frames segmented ahead against in line, interleaved.

    Wall, process CPU and main-thread CPU (the critical path when a core is free) of
    :func:`~fogsim.run.runner.run_frames` on the recording's frames (no set-up, no writing).
    """
    from fogsim.config import resolve_params
    from fogsim.data.recording import load_recording
    from fogsim.run.runner import run_frames, sensor_fields
    from fogsim.run.warmup import warm_up_kernels

    replay = load_recording(recording)
    params = resolve_params(replay.scenario, sensor=sensor_fields(replay.scenario))
    warm_up_kernels(params, stream=None, simulated=False)
    rows: dict[str, list[tuple[float, float, float]]] = {"in line": [], "segmented ahead": []}
    note = load_note()
    for _ in range(n):
        for name, segment_ahead in (("in line", False), ("segmented ahead", True)):
            wall, cpu, main = time.perf_counter(), time.process_time(), time.thread_time()
            run_frames(
                replay.frames,
                replay.truth_at,
                replay.scenario,
                params=params,
                segment_ahead=segment_ahead,
            )
            rows[name].append(
                (
                    time.perf_counter() - wall,
                    time.process_time() - cpu,
                    time.thread_time() - main,
                )
            )
    for name, values in rows.items():
        for i, figure in enumerate(("wall", "cpu", "cpu main")):
            column = [v[i] for v in values]
            print(
                f"  {name + ' ' + figure:<34} median {statistics.median(column):6.2f} s   "
                f"all {[round(v, 2) for v in column]}"
            )
    print(f"  {'':<34} {note} before, {load_note()} after")


def fogsim_import(env: dict[str, str]) -> float:
    """Wall time [s] of a child importing the CLI, less that of a bare interpreter."""
    times = []
    for code in ("import fogsim.cli", "pass"):
        start = time.perf_counter()
        subprocess.run([sys.executable, "-c", code], env=env, cwd=ROOT, check=True)
        times.append(time.perf_counter() - start)
    return times[0] - times[1]


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("scenario", nargs="?", default="stage")
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--replay", type=Path, help="a recording of SCENARIO to replay")
    parser.add_argument("--cold", type=int, default=0, help="repeats of the first run (0: none)")
    parser.add_argument("--parts", action="store_true", help="also the stages in one process")
    parser.add_argument("--overlap", type=int, default=0, help="repeats of overlap vs in line")
    parser.add_argument(
        "--ahead", type=int, default=0, help="repeats of the replay's frame loop, ahead vs in line"
    )
    parser.add_argument("--no-commands", action="store_true", help="skip run/replay/cold")
    parser.add_argument(
        "--no-run", action="store_true", help="skip the simulated run (replay and cold only)"
    )
    parser.add_argument(
        "--tree",
        type=Path,
        action="append",
        help="run the commands from this tree (repeatable: interleaved A/B); default this one",
    )
    args = parser.parse_args()
    trees = [tree.resolve() for tree in args.tree] if args.tree else [ROOT]
    envs = {tree: {**os.environ, "PYTHONPATH": str(tree)} for tree in trees}
    print(f"fogsim run {args.scenario} from {ROOT}, {args.repeats} repeats, {os.cpu_count()} cores")
    if args.overlap:
        overlap(args.scenario, args.overlap)
    if args.ahead:
        if args.replay is None:
            raise SystemExit("--ahead measures the frame loop of --replay FILE: give it")
        ahead(args.replay, args.ahead)
    if args.parts:
        parts(args.scenario, args.repeats, {**os.environ, "PYTHONPATH": str(ROOT)})
    if args.no_commands:
        return
    if args.no_run and args.replay is None:
        raise SystemExit("--no-run leaves the replay: give --replay FILE")
    with tempfile.TemporaryDirectory() as tmp:
        out = str(Path(tmp) / "out")
        run = ["run", args.scenario, "--out", out, "--quiet"]
        replay = ["run", "--replay", str(args.replay.resolve()) if args.replay else "", "--out"]
        replay += [out, "--quiet"]
        for tree in trees:
            fogsim(replay if args.no_run and args.replay else run, envs[tree], tree)  # warm
        figures = ("wall", "cpu", "teardown", *(f"cpu {name}" for name in THREADS))
        if not args.no_run:
            repeat("run", args.repeats, lambda tree: fogsim(run, envs[tree], tree), figures, trees)
        if args.replay is not None:
            repeat(
                "replay",
                args.repeats,
                lambda tree: fogsim(replay, envs[tree], tree),
                figures,
                trees,
            )
        if args.cold:
            repeat(
                "cold",
                args.cold,
                lambda tree: cold(args.scenario, out, envs[tree], tree),
                ("wall", "cpu", "teardown"),
                trees,
            )


def cold(scenario: str, out: str, env: dict[str, str], tree: Path = ROOT) -> tuple[float, ...]:
    """``fogsim run`` of ``tree`` with empty numba and fogsim caches."""
    with tempfile.TemporaryDirectory() as numba, tempfile.TemporaryDirectory() as cache:
        cold_env = {**env, "NUMBA_CACHE_DIR": numba, "FOGSIM_CACHE": cache}
        return fogsim(["run", scenario, "--out", out, "--quiet"], cold_env, tree)


if __name__ == "__main__":
    main()
