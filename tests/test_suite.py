"""Suite: regression metrics, tolerance rules, baseline check, and the quick subset end to end."""

import dataclasses

import pytest
from report_factory import event, make_report, row

from fogsim.cli import main
from fogsim.errors import ReportError
from fogsim.eval.report.io import load_json, load_report
from fogsim.paths import SCENARIOS_DIR
from fogsim.run.baseline import (
    NEVER_FRAMES,
    Baseline,
    BaselineEntry,
    load_baseline,
    report_metrics,
    rule_for,
    write_baseline,
)
from fogsim.run.suite import (
    ScenarioRun,
    SuiteSummary,
    check_against_baseline,
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
    run = ScenarioRun(metrics, 5, 1.0, None if error else "stage/report.json", error)
    return SuiteSummary("fogsim-suite", 1, quick, 1, 1.0, {"stage": run})


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
    assert both.scenarios == base.scenarios
    assert both.quick_scenarios == {"stage": BaselineEntry({"cells.accuracy": 0.5})}


def test_baseline_round_trip_keeps_the_committed_file_byte_for_byte(tmp_path):
    committed = SCENARIOS_DIR / "baseline.json"
    baseline = load_baseline(committed)
    assert set(baseline.section(quick=True)) == {"flat_floor", "box_removal"}
    path = write_baseline(tmp_path / "baseline.json", baseline)
    assert path.read_bytes() == committed.read_bytes()


def test_a_new_baseline_has_only_the_section_that_was_run(tmp_path):
    base = update_baseline(None, summary_with({"cells.accuracy": 0.9}))
    assert base == Baseline(scenarios={"stage": BaselineEntry({"cells.accuracy": 0.9})})
    path = write_baseline(tmp_path / "baseline.json", base)
    assert path.read_text() == (
        "{\n"
        '  "format": "fogsim-baseline",\n'
        '  "scenarios": {\n'
        '    "stage": {\n'
        '      "metrics": {\n'
        '        "cells.accuracy": 0.9\n'
        "      }\n"
        "    }\n"
        "  },\n"
        '  "version": 1\n'
        "}\n"
    )
    assert load_baseline(path) == base
    path.write_text(path.read_text().replace('"scenarios"', '"scenario"'))
    with pytest.raises(ReportError, match=r"does not know: `\$.scenario`"):
        load_baseline(path)


def test_summary_markdown_lists_scenarios_and_problems():
    text = summary_markdown(summary_with(report_metrics(REPORT)), ["stage: x got worse"])
    assert "| stage | 5 | 1.0 | ok |" in text
    assert "| events.slider.fog_frames | never |" in text
    assert "- stage: x got worse" in text


@pytest.mark.slow
def test_quick_suite_passes_check_against_committed_baseline(tmp_path, capsys):
    baseline = SCENARIOS_DIR / "baseline.json"
    assert load_baseline(baseline).section(quick=True), "baseline lacks a quick section"
    code = main(
        ["suite", "--quick", "--out", str(tmp_path), "--workers", "2", "--check", str(baseline)]
    )
    out = capsys.readouterr()
    assert code == 0, out.err
    summary = load_json(tmp_path / "summary.json", SuiteSummary, "suite summary")
    assert set(summary.scenarios) == {"flat_floor", "box_removal"}
    assert load_report(tmp_path / "box_removal" / "report.json").timing.frames == 80
    assert (tmp_path / "box_removal" / "fig5_comparison.png").is_file()
    # The same run checked against a baseline that is better than possible fails loudly.
    committed = load_baseline(baseline)
    flat = committed.quick_scenarios["flat_floor"]
    strict = dataclasses.replace(
        committed,
        quick_scenarios={
            **committed.quick_scenarios,
            "flat_floor": BaselineEntry({**flat.metrics, "cells.accuracy": 1.5}),
        },
    )
    problems = check_against_baseline(summary, strict)
    assert problems and "flat_floor: cells.accuracy got worse" in problems[0]
