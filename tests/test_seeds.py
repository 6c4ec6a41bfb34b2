"""Seeds: specs, mean and worst over seeds, the seeds runner, --strict."""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import pytest
from report_factory import GOOD, make_report, row, safety_with
from report_factory import event as factory_event

import fogsim.run.seeds as seeds_module
from fogsim.cli import main
from fogsim.errors import FogsimError
from fogsim.eval.report.io import load_json, load_report
from fogsim.eval.report.schema import (
    ClassScores,
    EventFrames,
    EventResult,
    EventSeen,
    Report,
    StepEdge,
)
from fogsim.run.baseline import NEVER_FRAMES
from fogsim.run.seed_spec import format_seeds, parse_seeds
from fogsim.run.seeds import (
    FigureStats,
    SeedRun,
    SeedsSummary,
    SeedValue,
    figure_stats,
    figures_markdown,
    worst_lines,
)

# --- Hand-made reports with the figures the seeds runner reads (report_factory fills the rest)


def classes(recall: float | None, precision: float | None) -> ClassScores:
    return ClassScores(10, 10, 9, recall, precision)


def event(name: str, cleared: int | None, floor_again: int | None, seen=True) -> EventResult:
    """A remove event with the FOG's two figures (the averaging baseline never)."""
    return dataclasses.replace(
        factory_event(name, cleared),
        seen=EventSeen(fog=seen, averaging=seen),
        cleared_frames=EventFrames(fog=cleared, averaging=None),
        floor_again_frames=EventFrames(fog=floor_again, averaging=None),
    )


def contract_report(
    rows=(),
    *,
    floor=(None, None),
    obstacle=(None, None),
    unsafe: int | None = None,
    edges: Sequence[StepEdge] = (),
    events: Sequence[EventResult] = (),
    poor: Sequence[str] = (),
    frame_ms_median: float | None = None,
    seed: int = 0,
) -> Report:
    """report_factory's report with these figures (quality poor when reasons are given)."""
    report = make_report(
        rows,
        frame_ms_median=frame_ms_median,
        floor=classes(*floor),
        obstacle=classes(*obstacle),
        safety=safety_with(unsafe or 0),
        step_edges=edges,
        events=events,
        quality=dataclasses.replace(GOOD, poor=bool(poor), reasons=tuple(poor)),
    )
    return dataclasses.replace(report, seed=seed)


# --- Seed specs


@pytest.mark.parametrize(
    ("spec", "seeds"),
    [
        ("1-8", (1, 2, 3, 4, 5, 6, 7, 8)),
        ("1,3,5", (1, 3, 5)),
        ("2", (2,)),
        ("9, 1-3", (1, 2, 3, 9)),
        ("0-0", (0,)),
        ("4294967295", (4294967295,)),
    ],
)
def test_seed_specs_give_sorted_seeds_and_format_back(spec, seeds):
    assert parse_seeds(spec) == seeds
    assert parse_seeds(format_seeds(seeds)) == seeds


def test_format_seeds_writes_runs_as_ranges():
    assert format_seeds((1, 2, 3, 4, 5, 6, 7, 8)) == "1-8"
    assert format_seeds((1, 3, 5)) == "1,3,5"
    assert format_seeds((1, 2, 4, 6, 7)) == "1-2,4,6-7"
    assert format_seeds((2,)) == "2"


@pytest.mark.parametrize(
    ("spec", "problem"),
    [
        ("", "'' is not a seed or a range"),
        ("a", "'a' is not a seed or a range"),
        ("1-", "'1-' is not a seed or a range"),
        ("-1", "'-1' is not a seed or a range"),
        ("1.5", "'1.5' is not a seed or a range"),
        ("1,,2", "'' is not a seed or a range"),
        ("8-1", "range '8-1' ends before it starts"),
        ("1-3,3", "seed 3 is given twice"),
        ("4294967296", "seed 4294967296 is above 4294967295"),
    ],
)
def test_bad_seed_specs_name_the_argument_and_what_is_allowed(spec, problem):
    with pytest.raises(FogsimError) as info:
        parse_seeds(spec)
    message = str(info.value)
    assert message.startswith(f"--seeds {spec!r}: {problem}; allowed: a range 1-8, a list 1,3,5")


# --- Mean and worst over seeds


def seed_run(seed: int, metrics: dict[str, float], error=None, poor=()) -> SeedRun:
    report = None if error else f"seed_{seed}/report.json"
    return SeedRun(seed, {} if error else metrics, 5, 1.0, report, tuple(poor), error)


RUNS = [
    seed_run(1, {"table1.sill.abs_error_mm": 1.0, "cells.obstacle_recall": 0.8}),
    seed_run(2, {"table1.sill.abs_error_mm": 4.0, "cells.obstacle_recall": 0.3}),
    seed_run(
        3,
        {
            "table1.sill.abs_error_mm": 2.5,
            "cells.obstacle_recall": 0.3,
            "events.box.cleared_frames": NEVER_FRAMES,
        },
    ),
    seed_run(4, {"events.box.cleared_frames": 12.0}, poor=["map empty"]),
    seed_run(5, {"table1.sill.abs_error_mm": 99.0}, error="RuntimeError: boom"),
]


def test_figure_stats_know_their_direction():
    stats = figure_stats(RUNS)
    assert list(stats) == [
        "cells.obstacle_recall",
        "events.box.cleared_frames",
        "table1.sill.abs_error_mm",
    ]
    # Lower is better: the worst is the largest error; the failed seed 5 is left out.
    sill = stats["table1.sill.abs_error_mm"]
    assert sill == FigureStats(
        direction="lower",
        mean=2.5,
        worst=4.0,
        worst_seed=2,
        values=(SeedValue(2, 4.0), SeedValue(3, 2.5), SeedValue(1, 1.0)),
        missing=(4,),
    )
    # Higher is better: the worst is the smallest recall; a tie goes to the lower seed.
    recall = stats["cells.obstacle_recall"]
    assert (recall.direction, recall.worst, recall.worst_seed) == ("higher", 0.3, 2)
    assert recall.mean == pytest.approx(1.4 / 3) and recall.mean == round(1.4 / 3, 6)
    assert [v.seed for v in recall.values] == [2, 3, 1]
    # A poor run's figures count; "never" is the worst and counts as 10⁶ in the mean.
    cleared = stats["events.box.cleared_frames"]
    assert (cleared.worst, cleared.worst_seed, cleared.mean) == (NEVER_FRAMES, 3, 500006.0)
    assert cleared.missing == (1, 2)


def test_worst_lines_give_one_line_per_group_in_group_order():
    lines = worst_lines(figure_stats(RUNS))
    assert lines == [
        "table1     worst: sill 4 (seed 2, mean 2.5)",
        "cells      worst: obstacle_recall 0.3 (seed 2, mean 0.4667)",
        "events     worst: box.cleared_frames never (seed 3, mean never on 1 of 2)",
    ]


def test_figures_markdown_puts_the_worst_first():
    text = "\n".join(figures_markdown(figure_stats(RUNS)))
    assert "| figure | better | worst | seed | mean | seeds, worst first |" in text
    assert "| sill | lower | 4 | 2 | 2.5 | 4 (2), 2.5 (3), 1 (1); none on 4 |" in text
    assert (
        "| obstacle_recall | higher | 0.3 | 2 | 0.4667 | 0.3 (2), 0.3 (3), 0.8 (1); none on 4 |"
        in text
    )
    assert text.index("### table1") < text.index("### cells") < text.index("### events")
    one = figures_markdown(figure_stats([RUNS[0]]))
    assert "| sill | lower | 1 |" in one


# --- fogsim run --seeds / --strict through the command line (runs replaced by hand-made reports)


def fake_runs(monkeypatch, poor_seeds=(), failing_seeds=()):
    """Replace the runner of the seeds module: seed n reports a sill error of n mm."""

    def run_scenario(scenario, out_dir, **options):
        if scenario.seed in failing_seeds:
            raise RuntimeError(f"seed {scenario.seed} broke")
        reasons = ("withdrawn 30 % of frames",) if scenario.seed in poor_seeds else ()
        return contract_report(
            [row("sill", float(scenario.seed))],
            floor=((100 - scenario.seed) / 100, 0.99),
            poor=reasons,
            seed=scenario.seed,
        )

    monkeypatch.setattr("fogsim.run.seeds.run_scenario", run_scenario)


def test_run_seeds_summary_and_console(monkeypatch, tmp_path, capsys):
    fake_runs(monkeypatch)
    code = main(["run", "flat_floor", "--seeds", "1-3,7", "--workers", "1", "--out", str(tmp_path)])
    out = capsys.readouterr().out
    assert code == 0
    summary = load_json(tmp_path / "summary.json", SeedsSummary, "seeds summary")
    assert (summary.scenario, summary.seeds, summary.workers) == ("flat_floor", "1-3,7", 1)
    assert [r.seed for r in summary.runs] == [1, 2, 3, 7]
    assert summary.runs[3].report == "seed_7/report.json"
    sill = summary.figures["table1.sill.abs_error_mm"]
    assert (sill.mean, sill.worst, sill.worst_seed) == (3.25, 7.0, 7)
    floor = summary.figures["cells.floor_recall"]
    assert (floor.worst, floor.worst_seed) == (0.93, 7)
    assert "table1     worst: sill 7 (seed 7, mean 3.25)" in out
    assert "cells      worst: floor_precision 0.99 (seed 1, mean 0.99), floor_recall 0.93" in out
    assert summary.ray_address is None
    markdown = (tmp_path / "summary.md").read_text()
    assert "# fogsim run flat_floor, seeds 1-3,7" in markdown
    assert "4 seeds, 1 workers, " in markdown


def test_seeds_on_ray_say_so_instead_of_the_unused_workers(monkeypatch, tmp_path):
    fake_runs(monkeypatch)
    asked = []
    run_locally = seeds_module.run_jobs

    def run_jobs_here(jobs, workers, ray_address=None):  # the cluster stood in for by this process
        asked.append(ray_address)
        return run_locally(jobs, 1)

    monkeypatch.setattr(seeds_module, "check_ray_address", lambda address: None)
    monkeypatch.setattr(seeds_module, "run_jobs", run_jobs_here)
    args = ["run", "flat_floor", "--seeds", "1-2", "--ray", "auto", "--out", str(tmp_path)]
    assert main(args) == 0
    assert asked == ["auto"]
    summary = load_json(tmp_path / "summary.json", SeedsSummary, "seeds summary")
    assert summary.ray_address == "auto"
    assert "2 seeds, on Ray at auto, " in (tmp_path / "summary.md").read_text()


def test_strict_exits_3_naming_the_poor_seeds(monkeypatch, tmp_path, capsys):
    fake_runs(monkeypatch, poor_seeds=(2,))
    args = ["run", "flat_floor", "--seeds", "1-3", "--workers", "1", "--out", str(tmp_path)]
    assert main(args) == 0  # not strict: a poor run is reported, not fatal
    lines = capsys.readouterr().out.splitlines()
    assert lines[1].startswith("seed 2: 5 frames, ")
    assert lines[1].endswith(" s, poor: withdrawn 30 % of frames")
    assert main([*args, "--strict"]) == 3
    err = capsys.readouterr().err
    assert "fogsim: --strict: seed 2: poor map: withdrawn 30 % of frames" in err
    assert "seed 1" not in err


def test_a_failing_seed_exits_1_and_the_others_are_summarised(monkeypatch, tmp_path, capsys):
    fake_runs(monkeypatch, failing_seeds=(2,))
    args = ["run", "flat_floor", "--seeds", "1-3", "--workers", "1", "--out", str(tmp_path)]
    assert main([*args, "--strict"]) == 1
    assert "FAILED seed 2: RuntimeError: seed 2 broke" in capsys.readouterr().err
    summary = load_json(tmp_path / "summary.json", SeedsSummary, "seeds summary")
    assert summary.figures["table1.sill.abs_error_mm"].values == (
        SeedValue(3, 3.0),
        SeedValue(1, 1.0),
    )


def test_single_run_strict_exit_codes(monkeypatch, tmp_path, capsys):
    reports = {"good": contract_report(), "poor": contract_report(poor=["map is empty"])}
    for name, report in reports.items():
        monkeypatch.setattr("fogsim.cli.run_scenario", lambda *a, report=report, **k: report)
        args = ["run", "flat_floor", "--out", str(tmp_path / name), "--quiet"]
        assert main(args) == 0
        assert main([*args, "--strict"]) == (3 if name == "poor" else 0)
    err = capsys.readouterr().err
    assert err.count("fogsim: --strict: flat_floor: poor map: map is empty") == 1


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--seeds", "1-x"], "--seeds '1-x': '1-x' is not a seed or a range; allowed: a range"),
        (["--seeds", "3-1"], "--seeds '3-1': range '3-1' ends before it starts"),
        (["--seeds", "1-2", "--seed", "4"], "either --seed N or --seeds SPEC"),
        (["--workers", "2"], "--workers sets the processes of --seeds"),
        (["--seeds", "1-2", "--workers", "0"], "--workers must be >= 1, got 0"),
        (["--seeds", "1", "--set", "mapper.p_occ=2"], "p_occ"),
    ],
)
def test_bad_seeds_arguments_exit_2(args, message, monkeypatch, tmp_path, capsys):
    fake_runs(monkeypatch)
    assert main(["run", "flat_floor", "--out", str(tmp_path), *args]) == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "summary.json").exists()


def test_seeds_need_a_scenario_not_a_recording(tmp_path, capsys):
    assert main(["run", "--seeds", "1-2", "--replay", str(tmp_path / "r.npz")]) == 2
    assert "a recording (--replay) has fixed frames" in capsys.readouterr().err
    assert main(["run", "--seeds", "1-2"]) == 2
    assert "run --seeds needs a SCENARIO" in capsys.readouterr().err


# --- The real thing: a seed run in the parallel runner is `fogsim run SCENARIO --seed n`


def _without_times(report: Report) -> Report:
    """The report with its timing (ms, wall) and version fields blanked."""
    timing = report.timing
    blank = dataclasses.replace(
        timing,
        update_ms=None,
        segmentation_ms=None,
        frame_ms=None,
        wall_s=0.0,
        realtime_factor=None,
        pictures_s=0.0,
    )
    return dataclasses.replace(report, timing=blank, versions={})


@pytest.mark.slow
def test_parallel_seeds_equal_single_runs_bit_for_bit(tmp_path, capsys):
    assert main(["run", "flat_floor", "--seeds", "2,3", "--out", str(tmp_path / "s")]) == 0
    assert (
        main(["run", "flat_floor", "--seed", "3", "--quiet", "--out", str(tmp_path / "one")]) == 0
    )
    summary = load_json(tmp_path / "s" / "summary.json", SeedsSummary, "seeds summary")
    assert [(r.seed, r.status()) for r in summary.runs] == [(2, "ok"), (3, "ok")]
    reports = {n: load_report(tmp_path / "s" / f"seed_{n}" / "report.json") for n in (2, 3)}
    single = load_report(tmp_path / "one" / "report.json")
    assert reports[3].seed == 3 and reports[2].seed == 2
    assert _without_times(reports[3]) == _without_times(single)
    # The seed matters: seed 2 gives other results than seed 3.
    assert dataclasses.replace(_without_times(reports[2]), seed=3) != _without_times(single)
    for name in single.pictures:
        assert (tmp_path / "s" / "seed_2" / name).stat().st_size > 1000, name
    assert summary.runs[1].metrics["table1.ground.abs_error_mm"] == abs(
        single.table1.fog[0].error_mm
    )
