"""report.json: the DESIGN.md "Results" keys, JSON-safe values, atomic write, Table I text."""

import json

import numpy as np
import pytest
from test_pipeline import NAMES, make_frames, provider_removed_at

from fogsim.config.scenario import load_scenario
from fogsim.eval.report import build_report, format_table1, load_report, write_report
from fogsim.run.runner import run_frames


@pytest.fixture(scope="module")
def removal_report():
    scenario = load_scenario("box_removal")
    frames = make_frames(60, box_until_frame=50)
    result = run_frames(frames, provider_removed_at(4.0), scenario)
    return build_report(result, scenario, wall_s=1.5, duration_s=60 / 12.5)


def test_report_has_every_results_key(removal_report):
    r = removal_report
    for key in (
        "table1",
        "cells",
        "events",
        "timing",
        "pose_error",
        "params",
        "scenario",
        "seed",
        "versions",
    ):
        assert key in r, key
    assert r["scenario"] == "box_removal" and r["seed"] == 2
    for table in ("fog", "averaging"):
        assert {row["name"] for row in r["table1"][table]} == set(NAMES)
        for row in r["table1"][table]:
            assert set(row) >= {"name", "ground_truth_mm", "estimated_mm", "error_mm", "cells"}
    assert set(r["cells"]["fog"]) >= {"seen", "correct", "accuracy", "confusion", "obstacle_height"}
    (event,) = r["events"]
    assert event["object"] == "flat_box" and "fog_frames" in event and "averaging_frames" in event
    assert r["timing"]["frames"] == 60 and r["timing"]["wall_s"] == 1.5
    assert r["timing"]["realtime_factor"] == pytest.approx(4.8 / 1.5, abs=1e-3)
    assert set(r["timing"]["update_ms"]) == {"median", "p99", "max"}
    assert r["pose_error"]["camera_in_world"]["translation_mm"]["max"] == pytest.approx(0.0)
    assert set(r["params"]) == {"mapper", "segmentation", "elevation", "pipeline"}
    assert r["versions"]["numpy"] == np.__version__


def test_write_report_is_strict_json_with_null_for_nan(tmp_path, removal_report):
    report = dict(removal_report, extra=float("nan"), arr=np.array([1.0, np.inf]))
    path = write_report(tmp_path / "out" / "report.json", report)
    text = path.read_text()
    assert "NaN" not in text and "Infinity" not in text
    loaded = load_report(path)
    assert loaded["extra"] is None and loaded["arr"] == [1.0, None]
    assert json.loads(text)["table1"] == removal_report["table1"]
    assert list(tmp_path.joinpath("out").iterdir()) == [path]  # no temp files left


def test_format_table1_lists_rows_accuracy_and_events(removal_report):
    text = format_table1(removal_report)
    assert "ground" in text and "flat_box" in text
    assert "cells labelled right" in text
    assert "remove flat_box: footprint cleared after FOG" in text
    assert format_table1({"table1": None}) == "Table I: no ground truth (nothing to score)."
