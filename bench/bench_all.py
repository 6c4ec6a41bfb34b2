"""Every benchmark the README quotes, in one run, with the machine it ran on.

Usage:
    .venv/bin/python bench/bench_all.py [--out bench/RESULTS.md] [--only NAME ...] [--quick]

Runs each script of ``bench/`` that the README's "Benchmarks" section quotes, one after the
other in child processes (``PYTHONPATH`` = this tree), with the arguments that section names,
and writes one Markdown file (atomically, `fogsim.atomic.write_text_atomic`): the machine (CPU
model, cores, memory, OS, Python and the versions of the packages that set the speed), the
tree's commit (``+dirty`` when it has uncommitted changes), then per benchmark its command, its
wall time, the load average (``os.getloadavg``, 2 cores) before and after, and what it printed.
The README's figures are copied from that one file, so they all come from one machine and one
day — on this project's machines the same code ran 10-25 % apart from one day to the next, so
only figures of one run compare.

A recording of the stage (``fogsim record stage --seed 1``) is made first into a temporary
folder: the run/replay and segmentation benchmarks time its frames; and, for the segmentation,
the same walk through the stereo head (``--set camera.mode=stereo``), whose segmentation does
more (side bands, borders, the tilt's step test). ``--quick`` runs every
benchmark with few repeats (a smoke test of this script, not figures to quote).
"""

from __future__ import annotations

import argparse
import os
import platform
import subprocess
import sys
import tempfile
import time
from collections.abc import Mapping
from dataclasses import dataclass
from datetime import UTC, datetime
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from machine import cpu_model  # noqa: E402  (bench/machine.py, beside this script)

from fogsim.atomic import write_text_atomic  # noqa: E402

#: Packages whose versions set the figures (compilers, renderers, peers).
PACKAGES = (
    "numpy",
    "numba",
    "llvmlite",
    "mujoco",
    "opencv-python-headless",
    "pin",
    "octomap-python",
)

#: Placeholder in a step's arguments for the stage recording's path.
RECORDING = "{recording}"
#: Placeholder for the same walk recorded through the stereo head (``camera.mode=stereo``).
STEREO_RECORDING = "{stereo_recording}"
#: What ``fogsim record stage`` is given for each placeholder, besides ``--out``.
RECORD_ARGUMENTS = {
    RECORDING: ("--seed", "1"),
    STEREO_RECORDING: ("--seed", "1", "--set", "camera.mode=stereo"),
}
#: How the printed commands name each recording.
RECORDING_NAMES = {RECORDING: "REC", STEREO_RECORDING: "STEREO_REC"}


@dataclass(frozen=True)
class Step:
    """One benchmark: its name (for ``--only``), what it measures and its arguments.

    Attributes:
        name: Short name, unique.
        what: What it measures, as the README's row says.
        argv: The script under ``bench/`` and its arguments (`RECORDING` and
            `STEREO_RECORDING` replaced by the recordings' paths).
        quick_argv: The same with few repeats (``--quick``).
        one_core: Pinned to CPU 0 (``taskset -c 0``), as the README's row says.
    """

    name: str
    what: str
    argv: tuple[str, ...]
    quick_argv: tuple[str, ...]
    one_core: bool = False

    def arguments(self, quick: bool) -> tuple[str, ...]:
        """The script and its arguments: `quick_argv` with ``quick``, else `argv`."""
        return self.quick_argv if quick else self.argv


STEPS = (
    Step(
        "mapper",
        "mapper update on the stage's frames (88×72, 176×144) and synthetic scenes, host, "
        "x86-64-v2 (the shipped build's) and generic codegen, OctoMap alongside",
        (
            "bench_mapper.py",
            "--frames",
            "200",
            "--sets",
            "stage",
            "edge",
            "centre",
            "--stages",
            "--codegen",
            "all",
        ),
        ("bench_mapper.py", "--frames", "20", "--sets", "centre", "--codegen", "host"),
    ),
    Step(
        "segmentation",
        "plane segmentation per frame: noisy staircase quality, 88×72 / 176×144 and the stage "
        "recording's frames, depth and stereo",
        (
            "bench_segmentation.py",
            "--repeats",
            "200",
            "--frame-repeats",
            "3",
            "--recording",
            RECORDING,
            "--recording",
            STEREO_RECORDING,
        ),
        ("bench_segmentation.py", "--repeats", "5", "--seeds", "1", "--speed-only"),
    ),
    Step(
        "camera",
        "camera frame in depth and stereo mode (render, noise, encoders, pose, self-filter)",
        ("bench_camera.py", "--frames", "30", "--repeats", "3", "--cpu"),
        ("bench_camera.py", "--frames", "3", "--repeats", "1", "--cpu"),
        one_core=True,
    ),
    Step(
        "robot",
        "pinocchio per frame: FK of the readings, odometry, self-filter",
        ("bench_robot.py", "--repeats", "5"),
        ("bench_robot.py", "--repeats", "1"),
    ),
    Step(
        "run",
        "the whole stage walk (`fogsim run stage`, warm) and the replay of its recording",
        ("bench_run.py", "stage", "--repeats", "3", "--replay", RECORDING, "--cold", "0"),
        ("bench_run.py", "stage", "--repeats", "1", "--replay", RECORDING, "--cold", "0"),
    ),
    Step(
        "cold",
        "the first run on a fresh machine (empty numba and fogsim caches)",
        ("bench_cold.py", "run", "--repeats", "1"),
        ("bench_cold.py", "kernels", "--repeats", "1", "--group", "mapper"),
    ),
    Step(
        "tune",
        "100 tuning trials over stage + box_removal on 2 workers",
        ("bench_tune.py", "--trials", "100", "--workers", "2"),
        ("bench_tune.py", "--trials", "2", "--workers", "2"),
    ),
)


@dataclass(frozen=True)
class StepResult:
    """What one benchmark printed and how long it took.

    Attributes:
        step: The benchmark.
        command: The command line as run (paths relative to the tree).
        wall_s: Wall time of the child [s].
        load_before: Load average (1, 5, 15 min) before it.
        load_after: Load average after it.
        returncode: The child's exit code (0: figures valid).
        output: Its standard output (and the tail of its standard error if it failed).
    """

    step: Step
    command: str
    wall_s: float
    load_before: tuple[float, float, float]
    load_after: tuple[float, float, float]
    returncode: int
    output: str


def machine_lines() -> list[str]:
    """The machine: CPU model and cores, memory, OS, Python and package versions."""
    memory = ""
    meminfo = Path("/proc/meminfo")
    if meminfo.is_file():
        total = [line for line in meminfo.read_text().splitlines() if line.startswith("MemTotal")]
        memory = f", {int(total[0].split()[1]) / 2**20:.1f} GiB" if total else ""
    versions = []
    for package in PACKAGES:
        try:
            versions.append(f"{package} {version(package)}")
        except PackageNotFoundError:
            versions.append(f"{package} (not installed)")
    return [
        f"- CPU: {cpu_model()}, {os.cpu_count()} cores{memory}",
        f"- OS: {platform.platform()}",
        f"- Python {platform.python_version()}; {', '.join(versions)}",
    ]


def commit() -> str:
    """This tree's commit, ``+dirty`` when tracked files have uncommitted changes."""

    def git(*args: str) -> str:
        return subprocess.run(
            ["git", *args], cwd=ROOT, capture_output=True, text=True, check=False
        ).stdout.strip()

    head = git("rev-parse", "--short", "HEAD") or "unknown"
    return head + ("+dirty" if git("status", "--porcelain", "--untracked-files=no") else "")


def run_step(
    step: Step, recordings: Mapping[str, Path], quick: bool, env: dict[str, str]
) -> StepResult:
    """Run one benchmark in a child process; its output, wall time and the load around it.

    ``recordings`` maps each placeholder (`RECORDING`, `STEREO_RECORDING`) to its file.
    """
    script, *rest = step.arguments(quick)
    prefix = ["taskset", "-c", "0"] if step.one_core else []
    command = [*prefix, sys.executable, str(ROOT / "bench" / script)]
    shown = [*prefix, "python", f"bench/{script}"]
    for a in rest:
        command.append(str(recordings[a]) if a in RECORDING_NAMES else a)
        shown.append(RECORDING_NAMES.get(a, a))
    load_before = os.getloadavg()
    start = time.perf_counter()
    done = subprocess.run(command, cwd=ROOT, env=env, capture_output=True, text=True, check=False)
    wall_s = time.perf_counter() - start
    output = done.stdout.rstrip()
    if done.returncode != 0:
        output += "\n--- stderr (tail) ---\n" + "\n".join(done.stderr.splitlines()[-20:])
    return StepResult(
        step, " ".join(shown), wall_s, load_before, os.getloadavg(), done.returncode, output
    )


def render(results: list[StepResult], header: list[str], quick: bool) -> str:
    """The Markdown file: machine and commit, then one section per benchmark."""
    lines = ["# Benchmarks: one run of `python bench/bench_all.py`", "", *header, ""]
    if quick:
        lines += ["**`--quick`: few repeats, a smoke test — not figures to quote.**", ""]
    for r in results:
        status = "" if r.returncode == 0 else f" — **failed (exit {r.returncode})**"
        load = " / ".join(
            "/".join(f"{v:.1f}" for v in pair) for pair in (r.load_before, r.load_after)
        )
        lines += [
            f"## {r.step.name}{status}",
            "",
            f"{r.step.what}. `{r.command}`: {r.wall_s:.0f} s wall, load (1/5/15 min) "
            f"before / after {load}.",
            "",
            "```",
            r.output,
            "```",
            "",
        ]
    return "\n".join(lines)


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """The command line; an unknown ``--only`` name exits 2 naming the valid ones."""
    names = [s.name for s in STEPS]
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=ROOT / "bench" / "RESULTS.md")
    parser.add_argument(
        "--only",
        action="append",
        choices=names,
        metavar="NAME",
        help=f"run only this benchmark (repeatable): one of {', '.join(names)}",
    )
    parser.add_argument("--quick", action="store_true", help="few repeats: a smoke test")
    return parser.parse_args(argv)


def main(argv: list[str] | None = None) -> int:
    """Run the benchmarks, write the file, print where; exit 1 if one failed."""
    args = parse_args(argv)
    steps = [s for s in STEPS if not args.only or s.name in args.only]
    env = dict(os.environ, PYTHONPATH=str(ROOT), MUJOCO_GL=os.environ.get("MUJOCO_GL", "egl"))
    env.setdefault("MESA_SHADER_CACHE_DISABLE", "true")
    started = datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC")
    header = [f"- Date: {started}; tree {commit()}", *machine_lines()]
    results: list[StepResult] = []
    with tempfile.TemporaryDirectory(prefix="fogsim-bench-") as folder:
        recordings = {
            RECORDING: Path(folder) / "stage_s1.npz",
            STEREO_RECORDING: Path(folder) / "stage_stereo_s1.npz",
        }
        for placeholder, path in recordings.items():
            if any(placeholder in s.arguments(args.quick) for s in steps):
                subprocess.run(
                    [
                        sys.executable,
                        "-m",
                        "fogsim",
                        "record",
                        "stage",
                        *RECORD_ARGUMENTS[placeholder],
                        "--out",
                        str(path),
                    ],
                    cwd=ROOT,
                    env=env,
                    check=True,
                    capture_output=True,
                )
        for step in steps:
            print(f"{step.name} ...", flush=True)
            results.append(run_step(step, recordings, args.quick, env))
            print(
                f"{step.name}: {results[-1].wall_s:.0f} s, exit {results[-1].returncode}",
                flush=True,
            )
    write_text_atomic(args.out, render(results, header, args.quick) + "\n")
    print(f"wrote {args.out}")
    return 0 if all(r.returncode == 0 for r in results) else 1


if __name__ == "__main__":
    sys.exit(main())
