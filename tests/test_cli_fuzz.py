"""Property-based: generated command lines exit 0, 1, 2 or 3 as documented, never a traceback,
and write nothing outside their output.

Hypothesis builds ``fogsim run`` / ``record`` / ``suite`` command lines from valid commands with
bad values: unknown scenarios, bad ``--set``, ``--seed``, ``--seeds`` and ``--workers``, bad
``--out`` (a file, below a file, ``/proc``, ``/sys``, ``/dev/null``, ``/``, a NUL, a folder of
other files), broken recordings and baselines. Each command runs in-process (the simulation is
:class:`test_output.FakeSimulation`, the pictures a stub, so a valid command takes a fraction of
a second) in a folder whose tree is compared before and after: only the output (and the folders
leading to it) may change. Exit 2 comes with one line on standard error.
"""

from __future__ import annotations

import contextlib
import io
import os
import re
import resource
import shutil
import time
from pathlib import Path

import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st
from test_output import FRAMES, FakeSimulation, FakeThirdPersonCamera
from test_pipeline import make_frames

from fogsim.atomic import write_atomic
from fogsim.cli import main
from fogsim.config import load_scenario
from fogsim.data.recording import load_recording, save_recording
from fogsim.paths import SCENARIOS_DIR
from fogsim.run.manifest import file_entries, read_manifest

SECONDS_PER_COMMAND = 20.0
"""Time bound of one command (a valid one takes well under a second)."""
MEMORY_GROWTH_BYTES = 500 * 2**20
"""Bound of the peak memory growth over all commands."""

SCENARIOS = st.one_of(
    st.sampled_from(["flat_floor", "box_removal"]),
    st.sampled_from(["no_such_scenario", "../flat_floor", "", "x.toml", "/etc", "\0"]),
)
ASSIGNMENTS = st.one_of(
    st.sampled_from(
        [
            "mapper.p_occ=0.7",
            "mapper.p_occ=2",
            "mapper.p_occ=nan",
            "mapper.p_occ=abc",
            "seed=-1",
            "seed=1.5",
            "camera.mode=lidar",
            "camera.mode=ideal",
            "frame_rate_hz=0",
            "nope.key=1",
            "=",
            "mapper",
            "name=../../escaped",
            "name=/tmp/escaped",
            "name=..",
            "name=",
        ]
    ),
    st.builds(
        "{}={}".format,
        st.sampled_from(["mapper.p_occ", "camera.mode", "name", "seed", "robot.model"]),
        st.text(max_size=8),
    ),
)
SEEDS = st.one_of(
    st.text("12-,x", max_size=3),
    st.sampled_from(["0-4294967295", "1-100000", "4294967296", "3-1", "1,1", " "]),
)
GOOD_OUTS = ("new", "nested", "result")
NUMBERS = st.sampled_from(["-1", "0", "1", "65", "x", "1.5", "", "1e3", "99999999999999999999"])
BAD_OUTS = (
    "file",
    "below_file",
    "proc",
    "sys",
    "devnull",
    "root",
    "foreign",
    "nul",
    "long",
)


def half_valid(valid: str, bad: list[str]) -> st.SearchStrategy[str]:
    """The valid value half of the time, else one of the bad ones."""
    return st.one_of(st.just(valid), st.sampled_from(bad))


def options(draw, flag: str, values: st.SearchStrategy[str], max_size: int = 1) -> list[str]:
    return [part for value in draw(st.lists(values, max_size=max_size)) for part in (flag, value)]


@st.composite
def command_lines(draw) -> tuple[list[str], str | None]:
    """A command line, and the kind of its output (None: ``runs/<name>``, run's default)."""
    command = draw(st.sampled_from(["run", "run_seeds", "record", "suite"]))
    out = draw(st.one_of(st.sampled_from(GOOD_OUTS), st.sampled_from(BAD_OUTS)))
    common = options(draw, "--set", ASSIGNMENTS, max_size=2)
    if command == "suite":
        args = ["suite", draw(half_valid("{scenarios}", ["{missing}", "{file}"]))]
        args += ["--workers", draw(half_valid("1", ["0", "65", "x"]))]
        args += options(draw, "--seeds", SEEDS)
        args += options(draw, "--check", st.sampled_from(["{missing}", "{file}", "{garbage}"]))
        args += options(draw, "--write-baseline", st.sampled_from(["{baseline}", "{file}/b"]))
        return [*args, *common, "--out", f"{{{out}}}"], out
    args = [command.removesuffix("_seeds")]
    if command == "run" and draw(st.booleans()):
        args += ["--replay", draw(st.sampled_from(["{recording}", "{missing}", "{garbage}"]))]
        args += [draw(SCENARIOS)] if draw(st.booleans()) else []
    else:
        args.append(draw(SCENARIOS))
    if command == "run_seeds":
        args += ["--seeds", draw(SEEDS), "--workers", draw(half_valid("1", ["0", "65"]))]
    args += options(draw, "--seed", NUMBERS)
    args += options(draw, "--camera-mode", st.sampled_from(["ideal", "lidar"]))
    if command != "record":
        args += ["--no-pictures", *draw(st.sampled_from([[], ["--video"], ["--strict"]]))]
        if draw(st.booleans()):
            return [*args, *common, "--quiet"], None
    if command == "record":
        # An existing file is what a recording replaces: not the fixtures.
        files = {"new": "new_file", "nested": "nested_file", "result": "old_file"}
        out = files.get(out, "old_file" if out == "file" else out)
    return [*args, *common, "--quiet", "--out", f"{{{out}}}"], out


class Places:
    """The fixed files the commands point at, and the output paths by kind."""

    def __init__(self, root: Path) -> None:
        self.root = root
        scenarios = root / "scenarios"
        scenarios.mkdir()
        shutil.copy(SCENARIOS_DIR / "flat_floor.toml", scenarios)
        (root / "a_file").write_text("a file")
        (root / "old.npz").write_text("a recording to replace")
        (root / "garbage").write_bytes(b"\x00garbage{")
        (root / "foreign").mkdir()
        (root / "foreign" / "notes.txt").write_text("keep")
        recording = root / "rec.npz"
        save_recording(recording, make_frames(FRAMES), scenario=load_scenario("flat_floor"))
        self.paths = {
            "scenarios": scenarios,
            "recording": recording,
            "garbage": root / "garbage",
            "missing": root / "missing",
            "file": root / "a_file",
            "new": root / "out",
            "nested": root / "a" / "b" / "out",
            "result": root / "out",
            "new_file": root / "rec_out" / "new.npz",
            "old_file": root / "old.npz",
            "baseline": root / "baseline.json",
            "nested_file": root / "c" / "d.npz",
            "below_file": root / "a_file" / "out",
            "proc": Path("/proc/fogsim_fuzz"),
            "sys": Path("/sys/fogsim_fuzz"),
            "devnull": Path("/dev/null"),
            "root": Path("/"),
            "foreign": root / "foreign",
            "nul": root / "o\0ut",
            "long": root / ("x" * 300),
        }

    def fill(self, args: list[str]) -> list[str]:
        """The arguments with ``{kind}`` replaced by its path (generated text left alone)."""

        def path(match: re.Match[str]) -> str:
            return str(self.paths[match[1]]) if match[1] in self.paths else match[0]

        return [re.sub(r"\{(\w+)\}", path, arg) for arg in args]


def tree(root: Path) -> dict[str, tuple[int, int] | None]:
    """Every path below ``root``: files with (size, mtime), folders with None."""
    found: dict[str, tuple[int, int] | None] = {}
    for directory, folders, names in os.walk(root):
        for name in folders:
            found[os.path.relpath(os.path.join(directory, name), root)] = None
        for name in names:
            stat = os.lstat(os.path.join(directory, name))
            found[os.path.relpath(os.path.join(directory, name), root)] = (
                stat.st_size,
                stat.st_mtime_ns,
            )
    return found


def assert_result(args: list[str], out: Path) -> None:
    """A command that exited 0 left a complete result: a folder as its manifest says, or a
    recording that loads."""
    if args[0] == "record":
        assert load_recording(out).frames
        return
    manifest = read_manifest(out)
    assert file_entries(out) == manifest.files
    kind = "seeds" if "--seeds" in args and args[0] == "run" else args[0]
    assert manifest.kind == kind


def stub_pictures(result, scenario, out_dir):
    """One small file through the real atomic writer instead of matplotlib's pictures."""
    return [write_atomic(Path(out_dir) / "fog_map.png", lambda handle: handle.write(b"png"))]


@pytest.fixture(scope="module")
def places(tmp_path_factory):
    return Places(tmp_path_factory.mktemp("fuzz"))


@settings(
    max_examples=300,
    derandomize=True,
    deadline=None,
    database=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
@given(command_lines())
def test_generated_command_lines_exit_cleanly_and_write_only_their_output(
    places, monkeypatch, command
):
    monkeypatch.setattr("fogsim.sim.simulation.Simulation", FakeSimulation)
    monkeypatch.setattr("fogsim.sim.third_person.ThirdPersonCamera", FakeThirdPersonCamera)
    monkeypatch.setattr("fogsim.run.record.Simulation", FakeSimulation)
    monkeypatch.setattr("fogsim.run.runner.write_pictures", stub_pictures)
    monkeypatch.chdir(places.root)
    template, out_kind = command
    args = places.fill(template)
    outputs = [places.root / "runs"] if out_kind is None else [places.paths[out_kind]]
    outputs += [Path(args[i + 1]) for i, arg in enumerate(args) if arg == "--write-baseline"]
    before = tree(places.root)
    peak_before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    stdout, stderr = io.StringIO(), io.StringIO()
    start = time.monotonic()
    with contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(stderr):
        try:
            code = main(args)
        except SystemExit as exc:  # argparse: a value of the wrong type or choice
            code = exc.code
    elapsed_s = time.monotonic() - start
    err = stderr.getvalue()
    event(f"{template[0]} exit {code}")
    assert "Traceback" not in err, err
    assert code in (0, 1, 2, 3), (code, err)
    if code == 2:
        assert err.startswith("fogsim") and err.count("\n") == 1, err
    assert elapsed_s < SECONDS_PER_COMMAND
    peak_after = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    assert peak_after - peak_before < MEMORY_GROWTH_BYTES
    if code == 0 and out_kind is not None:
        assert_result(args, places.paths[out_kind])
    after = tree(places.root)
    changed = {p for p in before.keys() | after.keys() if before.get(p, 0) != after.get(p, 0)}
    for path in changed:
        full = (places.root / path).absolute()
        inside = any(
            full == output or output in full.parents or full in output.parents for output in outputs
        )
        assert inside, (path, args)
