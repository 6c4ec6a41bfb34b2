"""Accuracy targets (`fogsim.run.targets`): the file, the check, the command line."""

import fnmatch
import math

import pytest
from test_seeds import fake_runs, seed_run

from fogsim.cli import main
from fogsim.errors import TargetsError
from fogsim.paths import SCENARIOS_DIR
from fogsim.run.baseline import load_baseline
from fogsim.run.seeds import figure_stats
from fogsim.run.targets import (
    Target,
    Targets,
    check_targets,
    load_targets,
    missed_summary,
    scenario_counts,
)

SHIPPED = SCENARIOS_DIR / "targets" / "issue11_depth.toml"

HEAD = 'format = "fogsim-targets"\nversion = 1\n'


def _file(tmp_path, text, name="targets.toml"):
    path = tmp_path / name
    path.write_text(HEAD + text)
    return path


# --- The file


def test_a_targets_file_is_read_with_its_defaults(tmp_path):
    path = _file(
        tmp_path,
        '[[target]]\nfigure = "table1.*.abs_error_mm"\nworst = 1.5\nmean = 0.7\n'
        '[[target]]\nfigure = "safety.unsafe_cells"\nworst = 0\nscenarios = ["stage"]\n'
        'why = "none on the stage"\n',
    )
    targets = load_targets(path)
    first, second = targets.target
    assert first == Target("table1.*.abs_error_mm", worst=1.5, mean=0.7)
    assert first.scenarios == ("*",) and first.why == ""
    assert first.bounds() == [("worst", 1.5), ("mean", 0.7)]
    assert second.bounds() == [("worst", 0.0)]
    assert second.applies_to("stage") and not second.applies_to("stage_down")


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (
            '[[target]]\nfigure = "cells.floor_recall"\nwurst = 0.9\n',
            "target[0].wurst: unknown key; allowed: figure, worst, mean, scenarios, why",
        ),
        ('[[target]]\nfigure = "cells.floor_recall"\n', "bounds nothing; give worst = ..."),
        (
            '[[target]]\nfigure = "timing.frame_ms_median"\nworst = 5\n',
            "timing figures cannot be targets (speed is measured in bench/",
        ),
        (
            '[[target]]\nfigure = "tabel1.*.abs_error_mm"\nworst = 1\n',
            "no figure group 'tabel1'; groups: table1, cells, safety, step_edges, events, "
            "pose_error",
        ),
        ('[[target]]\nfigure = "cells.floor_recall"\nworst = nan\n', "worst must be a finite"),
        ('[[target]]\nfigure = "cells.floor_recall"\nworst = "high"\n', "target[0].worst"),
        (
            '[[target]]\nfigure = "cells.floor_recall"\nworst = 1\nscenarios = []\n',
            "scenarios is empty",
        ),
        ("[[target]\n", "is not valid TOML"),
    ],
)
def test_a_broken_targets_file_names_what_is_wrong(tmp_path, text, message):
    path = _file(tmp_path, text)
    with pytest.raises(TargetsError) as info:
        load_targets(path)
    assert message in str(info.value)
    assert str(path) in str(info.value)


def test_a_missing_or_foreign_targets_file_is_refused(tmp_path):
    with pytest.raises(TargetsError, match="cannot read targets"):
        load_targets(tmp_path / "none.toml")
    path = tmp_path / "baseline.toml"
    path.write_text('format = "fogsim-baseline"\nversion = 1\ntarget = []\n')
    with pytest.raises(TargetsError, match="format"):
        load_targets(path)


# --- The check


def _figures():
    """stage: sill errors 1, 2, 4 mm and recalls 0.8, 0.3, 0.6 (seed 2 lacks the sill)."""
    stage = figure_stats(
        [
            seed_run(1, {"table1.sill.abs_error_mm": 1.0, "cells.obstacle_recall": 0.8}),
            seed_run(2, {"cells.obstacle_recall": 0.3}),
            seed_run(3, {"table1.sill.abs_error_mm": 4.0, "cells.obstacle_recall": 0.6}),
            seed_run(4, {"table1.sill.abs_error_mm": 2.0, "cells.obstacle_recall": 0.9}),
        ]
    )
    room = figure_stats([seed_run(1, {"table1.sill.abs_error_mm": 0.5})])
    return {"stage": stage, "stage_down": room, "room": room}


def _targets(*targets):
    return Targets("fogsim-targets", 1, tuple(targets))


def test_each_bound_follows_its_figures_direction_and_missed_come_first():
    results = check_targets(
        {"stage": _figures()["stage"]},
        {},
        _targets(
            Target("table1.*.abs_error_mm", worst=3.0, mean=2.5, why="rows"),
            Target("cells.obstacle_recall", worst=0.25, mean=0.7),
        ),
    )
    by_key = {(r.figure, r.statistic): r for r in results}
    worst = by_key["table1.sill.abs_error_mm", "worst"]
    assert (worst.value, worst.worst_seed, worst.met, worst.missing_seeds) == (4.0, 3, False, (2,))
    assert worst.line() == (
        "stage: table1.sill.abs_error_mm worst 4 (seed 3) > 3, no value on seeds 2 — rows"
    )
    mean = by_key["table1.sill.abs_error_mm", "mean"]
    assert math.isclose(mean.value, 7.0 / 3.0, rel_tol=1e-6) and mean.met  # 2.33 <= 2.5
    recall_worst = by_key["cells.obstacle_recall", "worst"]
    assert (recall_worst.value, recall_worst.met) == (0.3, True)  # higher is better: >= 0.25
    recall_mean = by_key["cells.obstacle_recall", "mean"]
    assert (recall_mean.value, recall_mean.met) == (0.65, False)  # 0.65 < 0.7
    assert recall_mean.line() == "stage: cells.obstacle_recall mean 0.65 < 0.7"
    assert [r.met for r in results] == [False, False, True, True]


def test_scenario_patterns_failed_scenarios_and_targets_that_match_nothing():
    figures = _figures()
    results = check_targets(
        figures,
        {"stage_down": ["seed 2: failed: RuntimeError: boom"]},
        _targets(
            Target("table1.sill.abs_error_mm", worst=1.0, scenarios=("stage*",)),
            Target("table1.*.coverage", worst=0.5),
        ),
    )
    assert [(r.scenario, r.figure, r.met) for r in results] == [
        ("stage", "table1.sill.abs_error_mm", False),
        ("stage_down", None, False),
        ("stage_down", None, False),
        ("(every scenario)", None, False),
    ]  # room is not a stage*: not checked by the first
    assert results[1].line() == (
        "stage_down: table1.sill.abs_error_mm: failed: seed 2: failed: RuntimeError: boom"
    )
    assert results[3].line() == (
        "(every scenario): target 'table1.*.coverage' (scenarios *) matched no figure"
    )
    met = check_targets(figures, {}, _targets(Target("table1.*", worst=5.0)))
    assert len(met) == 3 and all(r.met for r in met)
    # A target for a scenario the suite does not have (the stage's, in the held-out suite).
    assert check_targets(figures, {}, _targets(Target("cells.*", worst=0, scenarios=("x",)))) == []


# --- The command line


def test_suite_targets_print_what_is_missed_and_fail_the_suite(
    two_scenarios, tmp_path, monkeypatch, capsys
):
    fake_runs(monkeypatch)  # seed n: a sill error of n mm
    strict = _file(tmp_path, '[[target]]\nfigure = "table1.*.abs_error_mm"\nworst = 2.5\n')
    suite = ["suite", str(two_scenarios), "--seeds", "1-3", "--workers", "1"]
    assert main([*suite, "--out", str(tmp_path / "a"), "--targets", str(strict)]) == 1
    out = capsys.readouterr()
    for name in ("alpha", "beta"):
        assert f"MISSED {name}: table1.sill.abs_error_mm worst 3 (seed 3) > 2.5" in out.err
    assert "MISSED per scenario: alpha 1 of 1 missed; beta 1 of 1 missed" in out.err
    assert "0 failed; no baseline given: nothing compared; 2 targets missed" in out.out
    text = (tmp_path / "a" / "summary.md").read_text()
    assert "## Targets\n\n0 of 2 checks met, 2 missed." in text
    assert "| alpha | 0 of 1 | 1 |\n| beta | 0 of 1 | 1 |" in text
    assert "| alpha | table1.sill.abs_error_mm | worst | 3 (seed 3) | ≤ 2.5 | **no** |" in text
    # The same runs checked again afterwards, against a bound they meet and one they miss.
    lenient = _file(
        tmp_path, '[[target]]\nfigure = "table1.*.abs_error_mm"\nworst = 3\n', "lenient.toml"
    )
    assert main(["targets", str(tmp_path / "a"), "--targets", str(lenient)]) == 0
    printed = capsys.readouterr().out
    assert "per scenario: every check met\n2 of 2 checks met, 0 missed" in printed
    assert main(["targets", str(tmp_path / "a"), "--targets", str(strict)]) == 1
    assert "MISSED beta: table1.sill.abs_error_mm worst 3" in capsys.readouterr().out


def test_a_bad_targets_file_stops_the_suite_before_its_runs(tmp_path, capsys):
    broken = _file(tmp_path, '[[target]]\nfigure = "timing.frame_ms_median"\nworst = 1\n')
    out = tmp_path / "o"
    assert main(["suite", "--quick", "--out", str(out), "--targets", str(broken)]) == 2
    assert "timing figures cannot be targets" in capsys.readouterr().err
    assert not out.exists()
    good = _file(tmp_path, '[[target]]\nfigure = "cells.*"\nworst = 0\n', "good.toml")
    assert main(["targets", str(tmp_path / "nothing"), "--targets", str(good)]) == 2
    assert "cannot read suite summary" in capsys.readouterr().err


def test_the_shipped_targets_name_figures_the_depth_suite_has():
    targets = load_targets(SHIPPED)
    depth = load_baseline(SCENARIOS_DIR / "baseline.json").sets["full seeds=1-8"]
    names = {name for entry in depth.values() for name in entry.figures}
    for target in targets.target:
        assert any(fnmatch.fnmatchcase(name, target.figure) for name in names), target.figure
        assert target.why
    stage_only = [t for t in targets.target if t.figure == "safety.unsafe_cells"]
    assert [t.scenarios for t in stage_only] == [("stage",)]


def test_run_over_seeds_checks_targets_and_targets_reads_its_summary(tmp_path, monkeypatch, capsys):
    fake_runs(monkeypatch)  # seed n: a sill error of n mm
    strict = _file(tmp_path, '[[target]]\nfigure = "table1.*.abs_error_mm"\nworst = 2.5\n')
    out = tmp_path / "seeds"
    run = ["run", "flat_floor", "--seeds", "1-3", "--workers", "1", "--out", str(out)]
    assert main([*run, "--targets", str(strict)]) == 1
    captured = capsys.readouterr()
    assert "MISSED flat_floor: table1.sill.abs_error_mm worst 3 (seed 3) > 2.5" in captured.err
    assert "targets: 0 of 1 checks met" in captured.out
    mean = _file(tmp_path, '[[target]]\nfigure = "table1.*.abs_error_mm"\nmean = 2\n', "m.toml")
    assert main(["targets", str(out), "--targets", str(mean)]) == 0  # (1 + 2 + 3) / 3 <= 2
    assert "1 of 1 checks met, 0 missed" in capsys.readouterr().out
    # One run has no seeds to bound: refused before it runs.
    one = tmp_path / "one"
    assert main(["run", "flat_floor", "--out", str(one), "--targets", str(strict)]) == 2
    assert "--targets bounds figures over seeds" in capsys.readouterr().err
    assert not one.exists()


def test_scenario_counts_put_the_most_missed_first():
    results = check_targets(
        _figures(),
        {},
        _targets(
            Target("table1.sill.abs_error_mm", worst=1.0, mean=1.0), Target("cells.*", worst=0.5)
        ),
    )
    # stage: worst 4 and mean 2.33 miss, recall 0.3 misses; stage_down and room: 0.5 <= 1 met
    assert scenario_counts(results) == [("stage", 0, 3), ("stage_down", 2, 2), ("room", 2, 2)]
    assert missed_summary(results) == "stage 3 of 3 missed"
