"""``--ray ADDRESS`` of compare, run --seeds and suite: the same tables as the local run, bit for
bit, on a local one-CPU Ray instance; a bad or unreachable address is a named error (exit 2)."""

import dataclasses
import json
import os
import socket
from pathlib import Path

import numpy as np
import pytest
from test_compare import TRUTH, make_frames

from fogsim.cli import main
from fogsim.compare.command import run_compare
from fogsim.config import load_scenario
from fogsim.data.recording import Recording, save_recording
from fogsim.run.ray_cluster import RayCluster
from fogsim.run.seeds import SeedRun, run_jobs, seed_jobs

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="module")
def ray_instance():
    """A private one-CPU Ray instance; its workers import this tree's fogsim (PYTHONPATH)."""
    ray = pytest.importorskip("ray", reason="ray is not installed (optional extra 'ray')")
    saved = os.environ.get("PYTHONPATH")
    os.environ["PYTHONPATH"] = os.pathsep.join(p for p in (str(ROOT), saved) if p)
    try:
        ray.init(num_cpus=1, include_dashboard=False, log_to_driver=False)
        yield ray
    finally:
        ray.shutdown()
        if saved is None:
            del os.environ["PYTHONPATH"]
        else:
            os.environ["PYTHONPATH"] = saved


def test_compare_over_ray_gives_the_local_tables_bit_for_bit(ray_instance, tmp_path, monkeypatch):
    recordings = [
        str(
            save_recording(
                tmp_path / f"rec{n}.npz", make_frames(n), scenario=None, truths=[TRUTH] * n
            )
        )
        for n in (3, 4)
    ]
    maps = ("fog", "elevation", "last")
    run_compare(recordings, maps, tmp_path / "local", pictures=False)
    put = []
    original_put = RayCluster.put
    monkeypatch.setattr(
        RayCluster, "put", lambda self, value: put.append(value) or original_put(self, value)
    )
    run_compare(recordings, maps, tmp_path / "ray", pictures=False, ray_address="auto")
    for name in ("compare.json", "compare.md"):
        assert (tmp_path / "ray" / name).read_bytes() == (tmp_path / "local" / name).read_bytes()
    groups = json.loads((tmp_path / "ray" / "compare.json").read_text())["groups"]
    assert list(groups) == ["rec3", "rec4"]  # the jobs' order, whatever order they finished in
    # each recording went to the object store once, loaded (the nodes need no file)
    assert [type(value) for value in put] == [Recording, Recording]
    assert [len(value.frames) for value in put] == [3, 4]


def test_seeds_over_ray_write_what_local_processes_write(ray_instance, tmp_path):
    def jobs(folder):
        return seed_jobs(
            load_scenario("flat_floor"),
            [2],
            folder,
            max_frames=3,
            pictures=False,
            depth_backend="raycast",
        )

    local = run_jobs(jobs(tmp_path / "local"), 1)
    on_ray = run_jobs(jobs(tmp_path / "ray"), 1, ray_address="auto")
    assert [_without_times(r) for r in on_ray] == [_without_times(r) for r in local]
    assert on_ray[0].error is None and on_ray[0].frames == 3
    files = {p.relative_to(tmp_path / "local") for p in (tmp_path / "local").rglob("*")}
    assert files == {p.relative_to(tmp_path / "ray") for p in (tmp_path / "ray").rglob("*")}
    assert Path("seed_2/report.json") in files and Path("seed_2/maps.npz") in files
    with (
        np.load(tmp_path / "local" / "seed_2" / "maps.npz") as here,
        np.load(tmp_path / "ray" / "seed_2" / "maps.npz") as there,
    ):
        assert sorted(here) == sorted(there)
        for key in here:
            np.testing.assert_array_equal(here[key], there[key], err_msg=key)


def _without_times(run: SeedRun) -> SeedRun:
    """The run's entry without its wall time and its ``timing.*`` figures."""
    metrics = {k: v for k, v in run.metrics.items() if not k.startswith("timing.")}
    return dataclasses.replace(run, wall_s=0.0, metrics=metrics)


def closed_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def commands(tmp_path):
    recording = save_recording(
        tmp_path / "rec.npz", make_frames(2), scenario=None, truths=[TRUTH] * 2
    )
    out = str(tmp_path / "out")
    return {
        "compare": ["compare", str(recording), "--out", out],
        "run --seeds": ["run", "flat_floor", "--seeds", "1-2", "--out", out, "--no-pictures"],
        "suite": ["suite", "--out", out, "--quick"],
    }


@pytest.mark.parametrize("command", ["compare", "run --seeds", "suite"])
def test_a_bad_ray_address_exits_2_naming_it_before_any_work(tmp_path, capsys, command):
    argv = commands(tmp_path)[command]
    assert main([*argv, "--ray", "head:99999"]) == 2
    err = capsys.readouterr().err
    assert "--ray 'head:99999': must be auto, local or HOST:PORT with a port in 1..65535" in err
    address = f"127.0.0.1:{closed_port()}"
    assert main([*argv, "--ray", address]) == 2
    err = capsys.readouterr().err
    assert f"--ray {address}: cannot reach a Ray head there" in err
    assert "Traceback" not in err
    assert not (tmp_path / "out").exists()


def test_ray_and_workers_are_refused_together(tmp_path, capsys):
    both = ["--workers", "2", "--ray", "auto", "--out", str(tmp_path / "out")]
    for argv in (["run", "flat_floor", "--seeds", "1", *both], ["suite", "--quick", *both]):
        assert main(argv) == 2
        assert "give --workers N (local processes) or --ray ADDRESS" in capsys.readouterr().err
    assert main(["run", "flat_floor", "--ray", "auto", "--out", str(tmp_path / "o")]) == 2
    assert "give --seeds SPEC too" in capsys.readouterr().err
