"""`bench/bench_all.py`: every README benchmark in one run, written with the machine it ran on."""

import sys
from pathlib import Path

import pytest

BENCH = Path(__file__).resolve().parents[1] / "bench"
sys.path.insert(0, str(BENCH))
bench_all = pytest.importorskip("bench_all")


def test_every_step_names_an_existing_script_and_names_are_unique():
    names = [step.name for step in bench_all.STEPS]
    assert len(names) == len(set(names))
    for step in bench_all.STEPS:
        assert (BENCH / step.argv[0]).is_file()
        assert step.quick_argv[0] == step.argv[0]


def test_an_unknown_benchmark_name_exits_2_listing_the_valid_ones(capsys):
    with pytest.raises(SystemExit) as exit_info:
        bench_all.parse_args(["--only", "warp-drive"])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert "warp-drive" in err
    for step in bench_all.STEPS:
        assert step.name in err


def test_a_step_runs_in_a_child_and_a_failure_keeps_its_stderr(tmp_path):
    env = {"PATH": "/usr/bin:/bin", "PYTHONPATH": str(BENCH.parent)}
    ok = bench_all.Step("table", "help", ("seeds_table.py", "--help"), ("seeds_table.py", "--help"))
    recordings = {bench_all.RECORDING: tmp_path / "rec.npz"}
    result = bench_all.run_step(ok, recordings, quick=False, env=env)
    assert result.returncode == 0
    assert result.command == "python bench/seeds_table.py --help"
    assert "usage" in result.output
    bad = bench_all.Step("bad", "x", ("seeds_table.py", "--no-such-flag"), ("seeds_table.py",))
    result = bench_all.run_step(bad, recordings, quick=False, env=env)
    assert result.returncode == 2
    assert "--- stderr (tail) ---" in result.output
    assert "seeds_table.py: error" in result.output


def test_the_file_gives_machine_command_wall_time_load_and_output():
    step = bench_all.Step("robot", "pinocchio per frame", ("bench_robot.py",), ("bench_robot.py",))
    result = bench_all.StepResult(
        step, "python bench/bench_robot.py", 12.4, (1.0, 2.0, 3.0), (1.5, 2.0, 3.0), 0, "FK 25 µs"
    )
    failed = bench_all.StepResult(
        step, "python bench/bench_robot.py", 1.0, (0, 0, 0), (0, 0, 0), 1, ""
    )
    text = bench_all.render([result, failed], ["- CPU: test"], quick=False)
    assert text.splitlines()[:3] == [
        "# Benchmarks: one run of `python bench/bench_all.py`",
        "",
        "- CPU: test",
    ]
    assert (
        "pinocchio per frame. `python bench/bench_robot.py`: 12 s wall, load (1/5/15 min) "
        "before / after 1.0/2.0/3.0 / 1.5/2.0/3.0." in text
    )
    assert "```\nFK 25 µs\n```" in text
    assert "## robot — **failed (exit 1)**" in text
    assert "smoke test" not in text
    assert "smoke test" in bench_all.render([result], [], quick=True)


def test_the_recordings_are_named_in_the_commands_and_made_with_their_camera(tmp_path):
    # The segmentation times the stage's frames through both heads; a command names each file
    # by its placeholder's name, and the stereo one is recorded with the stereo camera.
    segmentation = next(step for step in bench_all.STEPS if step.name == "segmentation")
    assert bench_all.RECORDING in segmentation.argv
    assert bench_all.STEREO_RECORDING in segmentation.argv
    assert "camera.mode=stereo" in bench_all.RECORD_ARGUMENTS[bench_all.STEREO_RECORDING]
    env = {"PATH": "/usr/bin:/bin", "PYTHONPATH": str(BENCH.parent)}
    argv = ("seeds_table.py", "--help", bench_all.STEREO_RECORDING, bench_all.RECORDING)
    step = bench_all.Step("table", "help", argv, argv)
    recordings = {
        bench_all.RECORDING: tmp_path / "rec.npz",
        bench_all.STEREO_RECORDING: tmp_path / "stereo.npz",
    }
    result = bench_all.run_step(step, recordings, quick=False, env=env)
    assert result.returncode == 0
    assert result.command == "python bench/seeds_table.py --help STEREO_REC REC"
