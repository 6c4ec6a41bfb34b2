"""Suite: regression metrics, tolerance rules, baseline check, and the quick subset end to end."""

import json

import pytest
from report_factory import event, make_report, row

from fogsim.cli import main
from fogsim.paths import SCENARIOS_DIR
from fogsim.run.suite import (
    NEVER_FRAMES,
    check_against_baseline,
    report_metrics,
    rule_for,
    summary_markdown,
    update_baseline,
)

REPORT = make_report(
    [row("ground", -0.4), row("sill", 2.5), row("far", None)],
    accuracy=0.981,
    within_one_cell=1.0,
    events=[event("box", 4), event("slider", None, intermediate_final=1)],
    frame_ms_median=6.0,
)


def test_report_metrics_flatten_the_report():
    assert report_metrics(REPORT) == {
        "table1.ground.abs_error_mm": 0.4,
        "table1.sill.abs_error_mm": 2.5,
        "cells.accuracy": 0.981,
        "cells.obstacle_within_one_cell": 1.0,
        "events.box.fog_frames": 4.0,
        "events.slider.fog_frames": NEVER_FRAMES,
        "events.slider.intermediate": 1.0,
        "timing.frame_ms_median": 6.0,
    }


def test_rules_allow_the_tolerance_and_flag_beyond_it():
    table = rule_for("table1.sill.abs_error_mm")
    assert table.worse_by(3.4, 2.5) < 0  # 0.9 mm worse: within 1 mm
    assert table.worse_by(3.6, 2.5) == pytest.approx(0.1)
    accuracy = rule_for("cells.accuracy")
    assert accuracy.worse_by(0.975, 0.981) < 0 and accuracy.worse_by(0.97, 0.981) > 0
    assert accuracy.worse_by(0.999, 0.981) < 0  # better is never a failure
    timing = rule_for("timing.frame_ms_median")
    assert timing.worse_by(16.9, 6.0) < 0 and timing.worse_by(17.1, 6.0) > 0  # 2x + 5 ms
    with pytest.raises(Exception, match="no tolerance rule"):
        rule_for("bogus")


def summary_with(metrics, quick=False, error=None):
    return {
        "quick": quick,
        "workers": 1,
        "wall_s": 1.0,
        "scenarios": {"stage": {"metrics": metrics, "frames": 5, "wall_s": 1.0, "error": error}},
    }


def test_check_names_each_worse_metric():
    base = update_baseline(None, summary_with(report_metrics(REPORT)))
    worse = dict(report_metrics(REPORT))
    worse["table1.sill.abs_error_mm"] = 4.0
    worse["events.box.fog_frames"] = NEVER_FRAMES
    del worse["cells.accuracy"]
    problems = check_against_baseline(summary_with(worse), base)
    assert len(problems) == 3
    assert any(
        p.startswith("stage: table1.sill.abs_error_mm got worse: 4 vs baseline 2.5")
        for p in problems
    )
    assert any("events.box.fog_frames got worse" in p for p in problems)
    assert any(p == "stage: cells.accuracy missing (baseline 0.981)" for p in problems)
    assert check_against_baseline(summary_with(report_metrics(REPORT)), base) == []
    failed = check_against_baseline(summary_with({}, error="boom"), base)
    assert failed == ["stage: run failed: boom"]
    # A quick run is compared with the quick section only.
    assert "no 'quick_scenarios'" in check_against_baseline(summary_with({}, quick=True), base)[0]
    both = update_baseline(base, summary_with({"cells.accuracy": 0.5}, quick=True))
    assert both["scenarios"] == base["scenarios"]
    assert both["quick_scenarios"]["stage"]["metrics"] == {"cells.accuracy": 0.5}


def test_summary_markdown_lists_scenarios_and_problems():
    text = summary_markdown(summary_with(report_metrics(REPORT)), ["stage: x got worse"])
    assert "| stage | 5 | 1.0 | ok |" in text
    assert "| events.slider.fog_frames | never |" in text
    assert "- stage: x got worse" in text


@pytest.mark.slow
def test_quick_suite_passes_check_against_committed_baseline(tmp_path, capsys):
    baseline = SCENARIOS_DIR / "baseline.json"
    assert json.loads(baseline.read_text())["quick_scenarios"], "baseline lacks a quick section"
    code = main(
        ["suite", "--quick", "--out", str(tmp_path), "--workers", "2", "--check", str(baseline)]
    )
    out = capsys.readouterr()
    assert code == 0, out.err
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert set(summary["scenarios"]) == {"flat_floor", "box_removal"}
    assert (tmp_path / "box_removal" / "report.json").is_file()
    assert (tmp_path / "box_removal" / "fig5_comparison.png").is_file()
    # The same run checked against a baseline that is better than possible fails loudly.
    strict = json.loads(baseline.read_text())
    strict["quick_scenarios"]["flat_floor"]["metrics"]["cells.accuracy"] = 1.5
    (tmp_path / "strict.json").write_text(json.dumps(strict))
    from fogsim.run.suite import check_against_baseline as check

    problems = check(summary, strict)
    assert problems and "flat_floor: cells.accuracy got worse" in problems[0]
