"""The fogsim command line: list, run (replay, no MuJoCo), record, errors with exit codes."""

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from test_pipeline import make_frames, provider_removed_at

from fogsim.cli import main
from fogsim.config import find_scenario_files, load_scenario
from fogsim.data.recording import load_recording, save_recording
from fogsim.eval.frame_log import read_frame_log
from fogsim.paths import SCENARIOS_DIR


@pytest.fixture(scope="module")
def removal_recording(tmp_path_factory):
    frames = make_frames(60, box_until_frame=50)
    truths = [provider_removed_at(4.0)(f.time_s) for f in frames]
    path = tmp_path_factory.mktemp("rec") / "box_removal.npz"
    return save_recording(path, frames, scenario=load_scenario("box_removal"), truths=truths)


SIMULATION_MODULES = ("mujoco", "dm_control", "pinocchio", "coal", "OpenGL")
"""What only a simulation needs: MuJoCo, its MJCF tools, the robot's kinematics, OpenGL."""

OTHER_COMMAND_MODULES = (
    "fogsim.run.seeds",
    "fogsim.run.suite",
    "fogsim.run.baseline",
    "fogsim.tune.executors",
    "fogsim.tune.segment_cache",
    "fogsim.tune.suite",
)
"""What only other commands or options need: ``run --seeds``, ``suite``, ``run --strict``
(the baselines' rules), ``tune``."""


def test_a_replay_imports_nothing_of_the_simulation(removal_recording, tmp_path):
    """``run --replay`` maps a recording without MuJoCo and without the other commands' modules:
    none of them is imported (a new process); ``--strict`` imports what it needs and works."""
    out = str(tmp_path / "run")
    strict_out = str(tmp_path / "strict")
    watched = SIMULATION_MODULES + OTHER_COMMAND_MODULES
    code = (
        "import sys\n"
        "from fogsim.cli import main\n"
        f"args = ['run', '--replay', {str(removal_recording)!r}, '--out', {out!r}, "
        "'--quiet', '--no-pictures']\n"
        "assert main(args) == 0\n"
        f"imported = [m for m in {watched!r} if m in sys.modules]\n"
        f"code = main(args[:4] + [{strict_out!r}, '--quiet', '--no-pictures', '--strict'])\n"
        "print('@', ' '.join(imported), '@', code, '@', 'fogsim.run.baseline' in sys.modules)\n"
    )
    env = dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parent.parent))
    done = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True
    )
    assert (tmp_path / "run" / "report.json").is_file()
    imported, strict_code, baseline = done.stdout.splitlines()[-1].split("@")[1:]
    assert imported.strip() == "", f"a replay imported {imported}"
    # The recording's map is good (the box is cleared): --strict passes, after reading the rules.
    assert strict_code.strip() == "0"
    assert baseline.strip() == "True"
    assert (tmp_path / "strict" / "report.json").is_file()


def test_list_names_every_scenario(capsys):
    assert main(["list"]) == 0
    out = capsys.readouterr().out
    for name in ("stage", "box_removal", "moving_box", "simulated_world"):
        assert name in out


def test_run_replay_writes_report_pictures_video_and_prints_table1(
    removal_recording, tmp_path, capsys
):
    out = tmp_path / "run"
    code = main(
        [
            "run",
            "--replay",
            str(removal_recording),
            "--out",
            str(out),
            "--quiet",
            "--video",
            "--set",
            "mapper.p_occ=0.8",
        ]
    )
    assert code == 0, capsys.readouterr().err
    text = capsys.readouterr().out
    assert "ground" in text and "remove flat_box (" in text and "cleared FOG " in text
    report = json.loads((out / "report.json").read_text())
    assert report["source"] == "replay" and report["scenario"] == "box_removal"
    assert report["params"]["mapper"]["p_occ"] == 0.8
    (event,) = report["events"]
    assert event["seen"] == {"fog": True, "averaging": True}
    assert event["cleared_frames"]["fog"] <= 25
    assert event["cleared_frames"]["averaging"] is None
    pictures = ["fog_map.png", "fig3_panels.png", "difference.png", "fig5_comparison.png"]
    for name in [*pictures, "run.mp4", "maps.npz"]:
        assert (out / name).stat().st_size > 1000, name
    assert report["pictures"] == pictures


def test_replay_is_deterministic(removal_recording, tmp_path):
    for name in ("a", "b"):
        assert (
            main(
                [
                    "run",
                    "--replay",
                    str(removal_recording),
                    "--out",
                    str(tmp_path / name),
                    "--quiet",
                    "--no-pictures",
                ]
            )
            == 0
        )
    a, b = (json.loads((tmp_path / n / "report.json").read_text()) for n in ("a", "b"))
    assert a["table1"] == b["table1"] and a["cells"] == b["cells"] and a["events"] == b["events"]
    # Every frame's row, the same bytes (no timing in it), one per frame, as the report counts.
    a_log, b_log = (tmp_path / n / "frames.csv" for n in ("a", "b"))
    assert a_log.read_bytes() == b_log.read_bytes()
    log = read_frame_log(tmp_path / "a" / "frames.csv")
    assert log.frame.tolist() == list(range(60))
    timing = a["timing"]
    assert len(log) == timing["frames"]
    assert int(log.withdrawn.sum()) == timing["withdrawn_frames"]
    assert int(log.z_matched.sum()) == timing["z_matched_frames"]
    magnitudes = np.abs(log.pose.residual_heading_deg)
    assert a["pose_error"]["residual_heading_deg"]["median"] == round(
        float(np.median(magnitudes[np.isfinite(magnitudes)])), 4
    )


def test_bad_input_exits_2_with_a_clear_message(removal_recording, tmp_path, capsys):
    assert main(["run", "no_such_scenario", "--out", str(tmp_path)]) == 2
    assert "no_such_scenario" in capsys.readouterr().err
    assert main(["run", "--replay", str(tmp_path / "missing.npz")]) == 2
    assert "recording file not found" in capsys.readouterr().err
    assert (
        main(
            [
                "run",
                "--replay",
                str(removal_recording),
                "--quiet",
                "--no-pictures",
                "--out",
                str(tmp_path / "x"),
                "--set",
                "mapper.p_occ=2",
            ]
        )
        == 2
    )
    assert "p_occ" in capsys.readouterr().err
    assert main(["run"]) == 2
    assert "needs a SCENARIO" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["run", "stage", "--camera-mode", "lidar"])


def test_real_data_recording_runs_unscored(tmp_path, capsys):
    path = save_recording(tmp_path / "real.npz", make_frames(4))
    assert load_recording(path).scenario is None
    assert main(["run", "--replay", str(path), "--out", str(tmp_path / "o"), "--quiet"]) == 0
    assert "no ground truth" in capsys.readouterr().out
    report = json.loads((tmp_path / "o" / "report.json").read_text())
    assert report["table1"] is None and report["scenario"] is None
    assert np.isfinite(report["timing"]["update_ms"]["median"])


DEEP = "x = " + "[" * 5000 + "]" * 5000 + "\n"
"""TOML nested deeper than Python's recursion limit."""


@pytest.mark.parametrize(
    ("content", "problem"),
    [
        (b'name = "broken\n', "not valid TOML"),
        (b'name = "typed"\nseed = "five"\n', "seed"),
        (b"\xff\xfe\x00\x01\x02binary", "UTF-8"),
        ('name = "café"\n'.encode("latin-1"), "UTF-8"),
        (DEEP.encode(), "nested"),
    ],
    ids=["broken", "wrong_type", "binary", "latin1", "deep"],
)
def test_list_marks_a_bad_file_and_lists_the_others(
    content, problem, tmp_path, monkeypatch, capsys
):
    folder = tmp_path / "scenarios"
    folder.mkdir()
    (folder / "flat_floor.toml").write_bytes((SCENARIOS_DIR / "flat_floor.toml").read_bytes())
    (folder / "bad.toml").write_bytes(content)
    (folder / "zz_folder.toml").mkdir()  # a folder named like a scenario file
    monkeypatch.setattr("fogsim.cli.find_scenario_files", lambda: find_scenario_files(folder))
    assert main(["list"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 3
    assert lines[0].startswith("bad ") and "(invalid: " in lines[0] and problem in lines[0]
    assert lines[1].startswith("flat_floor ") and "a few steps forward" in lines[1]
    assert lines[2].startswith("zz_folder ") and "(invalid: " in lines[2]


def test_a_replay_keeps_the_recording_s_camera_whichever_scenario_is_named(tmp_path, capsys):
    """A stereo recording replayed as ``run box_removal --replay`` segments with stereo noise.

    ``box_removal.toml`` is a depth-mode scenario; its depth noise model on stereo frames
    withdrew half of the stage's frames. ``--camera-mode`` contradicting the recording is refused.
    """
    stereo = load_scenario("box_removal").with_overrides(["camera.mode=stereo"])
    path = save_recording(tmp_path / "stereo.npz", make_frames(4), scenario=stereo)
    out = tmp_path / "o"
    args = ["run", "box_removal", "--replay", str(path), "--quiet", "--no-pictures"]
    assert main([*args, "--out", str(out)]) == 0
    segmentation = json.loads((out / "report.json").read_text())["params"]["segmentation"]
    depth_scenario = load_scenario("box_removal")
    assert depth_scenario.camera.mode == "depth"
    assert segmentation["floor_edge_margin_px"] == 1  # the stereo head's noise model
    assert segmentation["disparity_noise_px"] > 0
    capsys.readouterr()
    assert main([*args, "--out", str(tmp_path / "x"), "--camera-mode", "depth"]) == 2
    err = capsys.readouterr().err
    assert "'stereo'" in err and "--camera-mode" in err and "Traceback" not in err
    assert not (tmp_path / "x").exists()
