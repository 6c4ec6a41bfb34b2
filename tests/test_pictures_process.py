"""Fig. 3 drawn by a forked process: the same file as drawn here, its errors raised here."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from test_maps import hand_built_maps, run_result

from fogsim.errors import FogsimError, OutputError
from fogsim.eval.maps import archive_maps
from fogsim.viz import pictures
from fogsim.viz.pictures import draw_fig3, write_pictures


def test_fig3_drawn_beside_is_the_file_drawn_here_byte_for_byte(tmp_path):
    archive, truth = hand_built_maps()
    result = run_result(archive, truth)
    (tmp_path / "run").mkdir()
    paths = write_pictures(result, None, tmp_path / "run")
    assert [p.name for p in paths] == ["fog_map.png", "fig3_panels.png", "difference.png"]
    here = draw_fig3(result, archive_maps(archive, truth), "run", tmp_path / "here.png")
    assert (tmp_path / "run" / "fig3_panels.png").read_bytes() == here.read_bytes()


def test_an_error_drawing_beside_is_raised_here_with_the_childs_traceback(tmp_path, monkeypatch):
    def full_disk(*args):
        raise OutputError("no space left for fig3_panels.png")

    monkeypatch.setattr(pictures, "draw_fig3", full_disk)  # the fork inherits it
    archive, truth = hand_built_maps()
    with pytest.raises(OutputError, match="no space left") as raised:
        write_pictures(run_result(archive, truth), None, tmp_path)
    (note,) = raised.value.__notes__
    assert note.startswith("in the picture process:") and "full_disk" in note
    assert (tmp_path / "fog_map.png").exists()  # this process drew its pictures meanwhile


def test_a_picture_process_that_dies_is_an_error_naming_its_exit_status(tmp_path, monkeypatch):
    monkeypatch.setattr(pictures, "draw_fig3", lambda *args: os._exit(4))
    archive, truth = hand_built_maps()
    with pytest.raises(FogsimError, match=r"ended without a word \(exit status 4\)"):
        write_pictures(run_result(archive, truth), None, tmp_path)


def test_a_runs_pictures_are_drawn_by_the_process_forked_for_them(tmp_path, monkeypatch):
    from test_pipeline import make_frames

    from fogsim.config import load_scenario
    from fogsim.data.recording import load_recording, save_recording
    from fogsim.run.runner import run_scenario

    def pictures_elsewhere(result, scenario, folder):
        path = Path(folder) / "fog_map.png"
        path.write_text(f"{os.getpid()} {result.frames} {scenario.name}")
        return [path]

    monkeypatch.setattr("fogsim.run.runner.write_pictures", pictures_elsewhere)
    scenario = load_scenario("flat_floor")
    save_recording(tmp_path / "rec.npz", make_frames(6), scenario=scenario)
    report = run_scenario(scenario, tmp_path / "out", replay=load_recording(tmp_path / "rec.npz"))
    pid, frames, name = (tmp_path / "out" / "fog_map.png").read_text().split()
    assert int(pid) != os.getpid() and (int(frames), name) == (6, "flat_floor")
    assert report.pictures == ("fog_map.png",) and report.timing.pictures_s >= 0.0
