"""Output paths and run folders: checked before any work, written whole, never mixed, cleaned.

Runs here simulate nothing: :class:`FakeSimulation` stands in for MuJoCo with the synthetic
frames of ``test_pipeline`` (a standing robot before a box), so a whole ``fogsim run`` takes a
fraction of a second and every byte it writes goes through the real writers.
"""

from __future__ import annotations

import errno
import json
import os
import re
import shutil
import subprocess
import sys
import threading
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from test_pipeline import make_frames, provider_removed_at

import fogsim.run.record  # noqa: F401 (bound to the real Simulation before any test patches it)
from fogsim.atomic import TEMPORARY, OutputError, temporary_prefix
from fogsim.cli import main
from fogsim.config import load_scenario
from fogsim.data.recording import save_recording
from fogsim.eval.report.io import load_report
from fogsim.run.manifest import MANIFEST_NAME, file_entries, read_manifest
from fogsim.run.output_paths import check_output_path, child_path
from fogsim.run.run_folder import RunFolder, foreign_file
from fogsim.run.runner import run_scenario

ROOT = Path(__file__).resolve().parents[1]
FRAMES = 12


class FakeSimulation:
    """What the runner and the recorder use of a Simulation, from synthetic frames."""

    def __init__(self, scenario, *, depth_backend="renderer"):
        self.scenario = scenario
        self.truth_at = provider_removed_at(1e9)
        self.trajectory = SimpleNamespace(times_s=[f.time_s for f in make_frames(FRAMES)])
        self.frame_count = FRAMES
        self.scene = SimpleNamespace(model=None)

    def frames(self, on_pose=None):
        for frame in make_frames(FRAMES):
            if on_pose is not None:
                on_pose(frame.index, None)
            yield frame

    def close(self):
        """Nothing to free."""


class FakeThirdPersonCamera:
    """What the runner uses of a ThirdPersonCamera: a black 480 × 360 picture per frame."""

    def __init__(self, model):
        self._pictures = {}

    def capture(self, index, data):
        self._pictures[index] = np.zeros((360, 480, 3), dtype=np.uint8)

    def take(self, index):
        return self._pictures.pop(index)

    def close(self):
        pass


@pytest.fixture
def fake_simulation(monkeypatch):
    monkeypatch.setattr("fogsim.sim.simulation.Simulation", FakeSimulation)
    monkeypatch.setattr("fogsim.sim.third_person.ThirdPersonCamera", FakeThirdPersonCamera)
    monkeypatch.setattr("fogsim.run.record.Simulation", FakeSimulation)


def no_work(*args, **kwargs):
    raise AssertionError("the run started before its output was checked")


def temporaries(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if TEMPORARY.fullmatch(p.name))


def assert_complete(folder: Path) -> str:
    """The folder holds exactly its manifest's files, unchanged; returns the run id."""
    manifest = read_manifest(folder)
    assert file_entries(folder) == manifest.files
    return manifest.run_id


def run(out, *options, scenario="flat_floor"):
    return main(["run", scenario, "--out", str(out), "--quiet", *options])


# --- Checked before any work: exit 2 naming the argument, the path and the problem


@pytest.fixture
def a_file(tmp_path):
    path = tmp_path / "a_file"
    path.write_text("not a folder")
    return path


@pytest.mark.parametrize(
    ("make_out", "problem"),
    [
        (lambda f: f, "is a file, not a folder"),
        (lambda f: f / "below", "is a file, not a folder, so it cannot hold below"),
        (lambda f: Path("/proc/fogsim_out"), "is under /proc, a kernel pseudo-filesystem"),
        (lambda f: Path("/sys/fogsim_out"), "is under /sys, a kernel pseudo-filesystem"),
        (lambda f: Path("/dev/null"), "is under /dev, a kernel pseudo-filesystem"),
        (lambda f: Path("/"), "is the root folder"),
        (lambda f: f.parent / "a\0b", "contains a NUL character"),
        (lambda f: f.parent, "which no run wrote"),
    ],
)
def test_a_bad_out_exits_2_before_any_work(make_out, problem, a_file, monkeypatch, capsys):
    monkeypatch.setattr("fogsim.sim.simulation.Simulation", no_work)
    monkeypatch.setattr("fogsim.run.record.Simulation", no_work)
    out = make_out(a_file)
    shown = repr(str(out)) if "\0" in str(out) else str(out)  # a NUL is not printed raw
    for command in (
        ["run", "flat_floor"],
        ["run", "flat_floor", "--seeds", "1-2", "--workers", "1"],
        ["suite", "--quick", "--workers", "1"],
    ):
        assert main([*command, "--out", str(out)]) == 2
        err = capsys.readouterr().err
        assert err.startswith(f"fogsim: error: --out {shown}: ") and problem in err, err
        assert err.count("\n") == 1
    assert a_file.read_text() == "not a folder"


@pytest.mark.parametrize(
    ("make_out", "problem"),
    [
        (lambda f: f.parent, "is a folder; give the file to write"),
        (lambda f: f / "rec.npz", "is a file, not a folder, so it cannot hold rec.npz"),
        (lambda f: Path("/dev/null"), "is under /dev"),
        (lambda f: Path("/proc/self/rec.npz"), "is under /proc"),
    ],
)
def test_a_bad_recording_file_exits_2_before_simulating(make_out, problem, a_file, monkeypatch):
    monkeypatch.setattr("fogsim.run.record.Simulation", no_work)
    out = make_out(a_file)
    with pytest.raises(OutputError, match="^--out .*" + problem):
        check_output_path(out, "file", "--out")
    assert main(["record", "flat_floor", "--out", str(out)]) == 2


def test_write_baseline_is_checked_before_the_suite_runs(a_file, tmp_path, capsys, monkeypatch):
    monkeypatch.setattr("fogsim.run.suite.run_jobs", no_work)
    args = ["suite", "--quick", "--out", str(tmp_path / "o"), "--workers", "1"]
    assert main([*args, "--write-baseline", str(a_file / "b.json")]) == 2
    assert f"--write-baseline {a_file / 'b.json'}: {a_file} is a file" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("code", "message"),
    [
        (errno.EROFS, "Read-only file system (EROFS)"),
        (errno.EACCES, "Permission denied (EACCES)"),
        (errno.ENOSPC, "No space left on device (ENOSPC)"),
    ],
)
def test_an_unwritable_folder_is_found_by_writing_there(code, message, tmp_path, monkeypatch):
    """Root may write anywhere but on a read-only file system: the check writes, it does not
    ask for permissions (a real read-only mount: test_read_only_and_full_disks_for_real)."""

    def refuse(target):
        raise OSError(code, os.strerror(code))

    monkeypatch.setattr("fogsim.run.output_paths.make_temporary_folder", refuse)
    expected = f": cannot write in {tmp_path}: {message}"
    with pytest.raises(OutputError, match="^--out .*" + re.escape(expected)):
        check_output_path(tmp_path / "new" / "out", "folder", "--out")


def test_a_full_disk_is_found_before_the_run(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr("fogsim.sim.simulation.Simulation", no_work)
    full = SimpleNamespace(f_bavail=10, f_frsize=4096, f_files=100, f_favail=50)
    monkeypatch.setattr("fogsim.run.output_paths.os.statvfs", lambda path: full)
    assert run(tmp_path / "out") == 2
    assert "only 0.0 MiB free on the disk of" in capsys.readouterr().err
    no_inode = SimpleNamespace(f_bavail=2**30, f_frsize=4096, f_files=100, f_favail=0)
    monkeypatch.setattr("fogsim.run.output_paths.os.statvfs", lambda path: no_inode)
    assert run(tmp_path / "out") == 2
    assert "has no free inode" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_a_folder_of_other_files_is_refused_and_left_alone(tmp_path, capsys):
    out = tmp_path / "mine"
    (out / "sub").mkdir(parents=True)
    (out / "report.json").write_text("{}")
    (out / "sub" / "notes.txt").write_text("keep me")
    assert run(out) == 2
    assert f"holds {out / 'sub' / 'notes.txt'}, which no run wrote" in capsys.readouterr().err
    assert (out / "sub" / "notes.txt").read_text() == "keep me"
    # A recording in the folder a run would replace is someone's data too.
    (out / "sub" / "notes.txt").unlink()
    (out / "rec.npz").write_bytes(b"frames")
    assert foreign_file(out) == "rec.npz"


def test_a_result_without_manifest_is_an_earlier_result(tmp_path, fake_simulation):
    """Folders written before manifests existed (only result files) are replaced whole."""
    out = tmp_path / "old"
    (out / "seed_1").mkdir(parents=True)
    for name in ("report.json", "fog_map.png", "seed_1/report.json", "seed_1/maps.npz"):
        (out / name).write_text("old")
    assert foreign_file(out) is None
    assert run(out, "--no-pictures") == 0
    assert sorted(p.name for p in out.iterdir()) == [
        "frames.csv",
        MANIFEST_NAME,
        "maps.npz",
        "report.json",
    ]


def test_a_result_with_a_file_beside_its_manifest_is_refused(tmp_path, fake_simulation, capsys):
    out = tmp_path / "out"
    assert run(out, "--no-pictures") == 0
    (out / "fog_map.png").write_bytes(b"another run's picture")
    assert run(out, "--no-pictures") == 2
    assert f"holds {out / 'fog_map.png'}, which no run wrote" in capsys.readouterr().err
    (out / "fog_map.png").unlink()
    (out / MANIFEST_NAME).write_text("{")
    assert run(out, "--no-pictures") == 2
    assert "holds a broken manifest.json" in capsys.readouterr().err


# --- A run's results belong to that run


def test_a_run_writes_its_folder_whole_with_a_manifest_last(tmp_path, fake_simulation):
    out = tmp_path / "out"
    assert run(out, "--seed", "7") == 0
    manifest = read_manifest(out)
    assert (manifest.format, manifest.version, manifest.kind) == ("fogsim-manifest", 1, "run")
    assert (manifest.scenario, manifest.seed, manifest.seeds) == ("flat_floor", 7, None)
    assert len(manifest.run_id) == 32 and int(manifest.run_id, 16) >= 0
    names = [entry.path for entry in manifest.files]
    pictures = load_report(out / "report.json").pictures
    assert names == sorted(["frames.csv", "maps.npz", "report.json", *pictures])
    assert_complete(out)
    assert temporaries(tmp_path) == []
    # The manifest is the folder's last file.
    latest = max(out.iterdir(), key=lambda p: p.stat().st_mtime_ns)
    assert latest.name == MANIFEST_NAME


def test_an_older_result_is_replaced_whole_never_mixed(tmp_path, fake_simulation):
    out = tmp_path / "out"
    assert run(out) == 0
    assert (out / "fog_map.png").is_file()
    first = assert_complete(out)
    assert run(out, "--no-pictures") == 0
    second = assert_complete(out)
    assert second != first
    assert sorted(p.name for p in out.iterdir()) == [
        "frames.csv",
        MANIFEST_NAME,
        "maps.npz",
        "report.json",
    ]
    assert temporaries(tmp_path) == []


@pytest.mark.parametrize(
    ("failure", "code", "message"),
    [
        (
            OSError(errno.ENOSPC, os.strerror(errno.ENOSPC)),
            2,
            "No space left on device (ENOSPC); "
            "nothing was written (an earlier result there is unchanged)",
        ),
        (KeyboardInterrupt(), 130, "fogsim: interrupted; nothing of this run was written"),
        (RuntimeError("a bug"), None, ""),
    ],
    ids=["disk_full", "ctrl_c", "bug"],
)
def test_a_failing_run_leaves_the_older_result_and_nothing_else(
    failure, code, message, tmp_path, fake_simulation, monkeypatch, capsys
):
    out = tmp_path / "out"
    assert run(out, "--no-pictures") == 0
    before = assert_complete(out)

    def fail(result, scenario, folder):
        (Path(folder) / "fog_map.png").write_bytes(b"half a picture")
        raise failure

    monkeypatch.setattr("fogsim.run.runner.write_pictures", fail)
    if code is None:  # not an input error: a traceback is right
        with pytest.raises(type(failure)):
            run_scenario(load_scenario("flat_floor"), out)
    else:
        assert run(out) == code
        err = capsys.readouterr().err
        assert err.startswith("fogsim") and err.endswith(f"{message}\n") and err.count("\n") == 1
    assert assert_complete(out) == before
    assert temporaries(tmp_path) == []


def test_seeds_folder_is_replaced_whole(tmp_path, fake_simulation):
    out = tmp_path / "out"
    args = ["run", "flat_floor", "--no-pictures", "--workers", "1", "--out", str(out)]
    assert main([*args, "--seeds", "1-3"]) == 0
    manifest = read_manifest(out)
    assert (manifest.kind, manifest.scenario, manifest.seeds) == ("seeds", "flat_floor", "1-3")
    assert "seed_3/report.json" in {entry.path for entry in manifest.files}
    assert read_manifest(out / "seed_2").seed == 2
    assert_complete(out)
    assert main([*args, "--seeds", "1"]) == 0
    assert sorted(p.name for p in out.iterdir()) == [
        MANIFEST_NAME,
        "seed_1",
        "summary.json",
        "summary.md",
    ]
    assert_complete(out)
    assert_complete(out / "seed_1")


def test_two_runs_into_one_folder_the_later_commit_wins_whole(tmp_path):
    out = tmp_path / "out"
    first, second = RunFolder(out), RunFolder(out)
    with first, second:
        for folder, name in ((first, "a"), (second, "b")):
            (folder.path / f"{name}.txt").write_text(name)
        second.commit("run")
        first.commit("run")
    assert sorted(p.name for p in out.iterdir()) == ["a.txt", MANIFEST_NAME]
    assert assert_complete(out) == first.run_id
    # Many at once: every commit takes its turn; the last one's folder is there whole.
    errors = []

    def commit(index):
        try:
            with RunFolder(out) as folder:
                for part in range(3):
                    (folder.path / f"{index}_{part}.txt").write_text(str(index))
                folder.commit("run")
        except Exception as exc:  # collected: a thread's exception would be lost
            errors.append(exc)

    threads = [threading.Thread(target=commit, args=(i,)) for i in range(8)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert errors == []
    assert_complete(out)
    assert len({p.read_text() for p in out.glob("*.txt")}) == 1
    assert temporaries(tmp_path) == []


def test_a_file_that_comes_during_the_run_stops_the_commit(tmp_path):
    out = tmp_path / "out"
    with pytest.raises(OutputError) as caught, RunFolder(out) as folder:
        (folder.path / "report.json").write_text("{}")
        out.mkdir()
        (out / "notes.txt").write_text("written while the run ran")
        folder.commit("run")
    message = str(caught.value)
    assert message.startswith(f"output folder {out}: holds {out / 'notes.txt'}, which no run")
    assert message.endswith("; nothing was written (an earlier result there is unchanged)")
    assert message.count("output folder") == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]
    assert [p.name for p in out.iterdir()] == ["notes.txt"]


# --- Temporaries of killed runs are removed by the next run; a live run's never


def dead_pid() -> int:
    process = subprocess.Popen(["true"])
    process.wait()
    return process.pid


def test_stale_temporaries_are_removed_and_live_ones_kept(tmp_path, fake_simulation):
    out = tmp_path / "out"
    live = temporary_prefix(out)  # this process: alive
    dead = live.replace(f"-{os.getpid()}-", f"-{dead_pid()}-")
    other_host = dead.replace(".fogsim-", ".fogsim-otherhost")
    for prefix in (live, dead, other_host):
        (tmp_path / f"{prefix}abc.tmp").mkdir()
        (tmp_path / f"{prefix}abc.tmp" / "report.json").write_text("half")
        (tmp_path / f"{prefix}def.tmp").write_text("half")
        (tmp_path / f"{prefix}ghi.old").mkdir()
    (tmp_path / ".out.tmp").write_text("not ours")
    assert run(out, "--no-pictures") == 0
    left = sorted(p.name for p in tmp_path.iterdir())
    kept = [f"{p}{rest}" for p in (live, other_host) for rest in ("abc.tmp", "def.tmp", "ghi.old")]
    assert left == sorted([".out.tmp", "out", *kept])


def test_a_recording_is_written_whole_and_cleans_killed_ones(tmp_path, fake_simulation, capsys):
    path = tmp_path / "rec.npz"
    stale = tmp_path / f"{temporary_prefix(path).replace(str(os.getpid()), str(dead_pid()))}x.tmp"
    stale.write_bytes(b"half a recording")
    assert main(["record", "flat_floor", "--out", str(path), "--quiet"]) == 0
    assert f"recorded {FRAMES} frames of flat_floor" in capsys.readouterr().out
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rec.npz"]


# --- Paths from data stay inside their folder


@pytest.mark.parametrize("name", ["../x", "../../x", "a/../../x", "/tmp/x", "..", ".", ""])
def test_a_hostile_name_cannot_leave_its_folder(name, tmp_path):
    with pytest.raises(OutputError, match=r"^scenario name .* a name must stay inside its folder"):
        child_path(tmp_path / "runs", name, "scenario name")


def test_a_link_out_of_the_folder_is_refused(tmp_path):
    (tmp_path / "runs").mkdir()
    (tmp_path / "runs" / "stage").symlink_to(tmp_path / "elsewhere")
    with pytest.raises(OutputError, match="outside"):
        child_path(tmp_path / "runs", "stage", "scenario name")
    assert child_path(tmp_path / "runs", "flat_floor", "x") == tmp_path / "runs" / "flat_floor"


def test_a_hostile_scenario_name_writes_nothing_outside(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr("fogsim.sim.simulation.Simulation", no_work)
    monkeypatch.chdir(tmp_path)
    assert main(["run", "flat_floor", "--set", "name=../../escaped"]) == 2
    # Refused where the name enters (the scenario's own check); child_path is the second line.
    err = capsys.readouterr().err
    assert "name: must be a safe file name" in err and "'../../escaped'" in err
    assert list(tmp_path.iterdir()) == []


def test_a_hostile_name_in_the_suite_fails_its_scenario_only(tmp_path, fake_simulation, capsys):
    folder = tmp_path / "scenarios"
    folder.mkdir()
    text = (ROOT / "scenarios" / "flat_floor.toml").read_text()
    for stem, name in (("good", "good"), ("bad", "../escaped")):
        (folder / f"{stem}.toml").write_text(text.replace('"flat_floor"', json.dumps(name)))
    out = tmp_path / "deep" / "out"
    assert main(["suite", str(folder), "--out", str(out), "--workers", "1"]) == 1
    err = capsys.readouterr().err
    assert "FAILED bad: " in err and "escaped" in err
    assert sorted(p.name for p in out.iterdir()) == [
        "good",
        MANIFEST_NAME,
        "summary.json",
        "summary.md",
    ]
    assert sorted(p.name for p in (tmp_path / "deep").iterdir()) == ["out"]
    assert_complete(out)


# --- For real: a read-only and a full file system (a private mount namespace, as root)


def _can_mount() -> bool:
    if os.geteuid() != 0 or shutil.which("unshare") is None:
        return False
    probe = subprocess.run(
        ["unshare", "-m", "sh", "-c", "mount -t tmpfs -o size=64k tmpfs /mnt"],
        capture_output=True,
    )
    return probe.returncode == 0


@pytest.mark.skipif(not _can_mount(), reason="needs root and unshare/mount (private namespace)")
def test_read_only_and_full_disks_for_real(tmp_path):
    disk = tmp_path / "disk"
    disk.mkdir()
    python = (
        "import sys; import fogsim.run.output_paths as p; p.MIN_FREE_BYTES = int(sys.argv[1]); "
        "from fogsim.cli import main; sys.exit(main(sys.argv[2:]))"
    )
    fogsim = f"{sys.executable} -c '{python}' >/dev/null"
    run = f"run --replay {{rec}} --quiet --no-pictures --out {disk}/out"
    script = f"""
        set -u
        mount -t tmpfs -o size=100k tmpfs {disk}
        {fogsim} 0 {run}; echo "old=$?"
        {fogsim} 0 {run.replace("--no-pictures", "")}; echo "full=$?"
        ls -A {disk}; echo "--"
        {fogsim} 104857600 {run}; echo "min_free=$?"
        mount -o remount,ro {disk}
        {fogsim} 0 {run}; echo "read_only=$?"
    """
    rec = tmp_path / "rec.npz"
    save_recording(rec, make_frames(FRAMES), scenario=load_scenario("flat_floor"))
    result = subprocess.run(
        ["unshare", "-m", "sh", "-c", script.replace("{rec}", str(rec))],
        capture_output=True,
        text=True,
        env={**os.environ, "PYTHONPATH": f"{ROOT}:{ROOT / 'tests'}"},
        timeout=120,
    )
    out, err = result.stdout, result.stderr
    assert "old=0" in out, err
    assert "full=2" in out and "read_only=2" in out and "min_free=2" in out, out + err
    assert out.split("--")[0].split() == ["old=0", "full=2", "out"]  # old result, no temporary
    lines = err.strip().splitlines()
    assert "No space left on device (ENOSPC); nothing was written" in lines[0]
    assert f"--out {disk}/out: only " in lines[1] and "a run needs at least 100 MiB" in lines[1]
    assert f"cannot write in {disk}: Read-only file system (EROFS)" in lines[2]
    assert "Traceback" not in err
