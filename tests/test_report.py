"""report.json: the DESIGN.md "Results" keys, the typed round trip, strict loading, Table I text."""

import dataclasses
import json

import numpy as np
import pytest
from msgspec import UNSET
from report_factory import GOOD, class_scores, event, make_report, row, safety_with, step_edge
from test_pipeline import NAMES, make_frames, provider_removed_at

from fogsim.config import load_scenario
from fogsim.errors import ReportError
from fogsim.eval.report import (
    Report,
    build_report,
    format_table1,
    format_warnings,
    load_report,
    write_report,
)
from fogsim.eval.report.schema import CeilingScores, MedianMax, MedianP95Max, PoseErrorStats
from fogsim.run.runner import run_frames

RESULTS_KEYS = [
    "format",
    "version",
    "scenario",
    "seed",
    "source",
    "quality",
    "table1",
    "cells",
    "safety",
    "step_edges",
    "unseen_objects",
    "ceiling",
    "events",
    "timing",
    "pose_error",
    "params",
    "versions",
]


@pytest.fixture(scope="module")
def removal_report():
    scenario = load_scenario("box_removal")
    frames = make_frames(60, box_until_frame=50)
    result = run_frames(frames, provider_removed_at(4.0), scenario)
    return build_report(result, scenario, wall_s=1.5, duration_s=60 / 12.5)


@pytest.fixture
def written(tmp_path, removal_report):
    """The removal report written, and its JSON read back untyped."""
    path = write_report(tmp_path / "out" / "report.json", removal_report)
    return path, json.loads(path.read_text())


def test_report_has_every_results_key_in_order(written):
    _, r = written
    assert list(r) == RESULTS_KEYS
    assert r["format"] == "fogsim-report" and r["version"] == 2
    assert r["scenario"] == "box_removal" and r["seed"] == 2 and r["source"] == "simulation"
    for table in ("fog", "averaging"):
        assert [row["name"] for row in r["table1"][table]] == list(NAMES)
        for row_ in r["table1"][table]:
            assert list(row_) == [
                "name",
                "ground_truth_mm",
                "estimated_mm",
                "error_mm",
                "cells",
                "surface_cells",
            ]
    assert list(r["quality"]) == [
        "withdrawn_fraction",
        "frames_without_ground_plane",
        "map_empty",
        "floor_right_fraction",
        "poor",
        "reasons",
    ]
    assert r["quality"]["poor"] is False and r["quality"]["reasons"] == []
    assert r["quality"]["frames_without_ground_plane"] == 0  # the ground is in every frame
    assert list(r["cells"]) == ["fog", "obstacles", "averaging"]
    fog = r["cells"]["fog"]
    assert list(fog)[:4] == ["region", "in_view", "seen", "in_view_seen"]
    assert 0 < fog["in_view_seen"] <= fog["in_view"] <= fog["region"]
    assert list(fog["classes"]) == ["floor", "obstacle"]
    assert list(fog["classes"]["floor"]) == [
        "truth_seen",
        "labelled",
        "true_positive",
        "recall",
        "precision",
    ]
    assert list(r["safety"]) == [
        "unsafe_cells",
        "floor_on_obstacle",
        "floor_height_off",
        "height_tolerance_mm",
        "positions_xy_m",
        "floor_height_error_mm",
    ]
    assert list(r["safety"]["floor_height_error_mm"]) == ["p50", "p90", "p95", "p99", "max"]
    assert r["unseen_objects"] == [] and r["ceiling"] is None  # the box is gone, nothing hangs
    assert list(r["cells"]["fog"]["confusion"]["floor"]) == ["unknown", "floor", "obstacle"]
    assert list(r["cells"]["fog"]["obstacle_height"])[-1] == "within_one_cell_fraction"
    (ev,) = r["events"]
    assert ev["object"] == "flat_box" and ev["kind"] == "remove"
    assert "intermediate_floor_cells" not in ev  # moves only
    timing = r["timing"]
    assert list(timing) == [
        "frames",
        "withdrawn_frames",
        "z_matched_frames",
        "update_ms",
        "segmentation_ms",
        "frame_ms",
        "wall_s",
        "realtime_factor",
    ]
    assert timing["frames"] == 60 and timing["wall_s"] == 1.5
    assert timing["realtime_factor"] == pytest.approx(4.8 / 1.5, abs=1e-3)
    assert list(timing["update_ms"]) == ["median", "p99", "max"]
    assert r["pose_error"]["frames"] == 60
    assert r["pose_error"]["camera_in_world"]["translation_mm"]["max"] == pytest.approx(0.0)
    assert list(r["params"]) == [
        "mapper",
        "segmentation",
        "elevation",
        "pipeline",
        "heading",
        "reference",
    ]
    assert r["params"]["mapper"]["max_range_m"] is None  # infinite range is written as null
    assert r["versions"]["numpy"] == np.__version__


def test_write_then_load_gives_the_same_report(written, removal_report):
    path, _ = written
    loaded = load_report(path)
    assert isinstance(loaded, Report)
    assert loaded == removal_report
    assert loaded.pictures is UNSET and loaded.timing.pictures_s is UNSET
    assert list(path.parent.iterdir()) == [path]  # no temp files left


def test_round_trip_of_a_hand_made_report_with_every_optional_key(tmp_path):
    report = make_report(
        [row("ground", -0.4), row("sill", None)],
        region=500,
        seen=400,
        correct=390,
        accuracy=0.975,
        events=[event("box", 4), event("slider", None, intermediate_final=1)],
        frame_ms_median=6.0,
    )
    report = dataclasses.replace(
        report,
        pictures=("fog_map.png", "fig3_panels.png"),
        video="run.mp4",
        timing=dataclasses.replace(report.timing, pictures_s=0.25),
    )
    path = write_report(tmp_path / "report.json", report)
    raw = json.loads(path.read_text())
    assert list(raw)[-2:] == ["pictures", "video"] and raw["video"] == "run.mp4"
    assert list(raw["timing"])[-1] == "pictures_s"
    assert raw["events"][1]["intermediate_floor_cells"]["fog"] == {"max": 3, "final": 1}
    assert load_report(path) == report


def test_nan_and_infinity_are_written_as_null(tmp_path, removal_report):
    timing = dataclasses.replace(removal_report.timing, realtime_factor=float("nan"))
    path = write_report(
        tmp_path / "report.json", dataclasses.replace(removal_report, timing=timing)
    )
    text = path.read_text()
    assert "NaN" not in text and "Infinity" not in text
    assert json.loads(text)["timing"]["realtime_factor"] is None
    assert load_report(path).timing.realtime_factor is None


def _rewrite(path, edit):
    data = json.loads(path.read_text())
    edit(data)
    path.write_text(json.dumps(data, indent=2))
    return path


def test_a_missing_key_fails_loading_naming_it(written):
    path, _ = written
    _rewrite(path, lambda d: d["timing"].pop("frames"))
    with pytest.raises(ReportError, match=r"missing required field `frames` - at `\$.timing`"):
        load_report(path)


def test_a_renamed_key_fails_loading_naming_it(written):
    path, _ = written
    _rewrite(path, lambda d: d.update(table_1=d.pop("table1")))
    with pytest.raises(ReportError, match="missing required field `table1`"):
        load_report(path)


def test_a_renamed_optional_key_fails_loading_naming_it(written):
    path, _ = written
    _rewrite(path, lambda d: d.update(picture=["fog_map.png"]))
    with pytest.raises(ReportError, match=r"does not know: `\$.picture`"):
        load_report(path)
    _rewrite(path, lambda d: (d.pop("picture"), d["events"][0].update(fog_frame=3)))
    with pytest.raises(ReportError, match=r"does not know: `\$.events\[0\].fog_frame`"):
        load_report(path)


def test_a_wrong_type_or_version_fails_loading_naming_the_key(written):
    path, _ = written
    _rewrite(path, lambda d: d["cells"]["fog"].update(seen="many"))
    with pytest.raises(ReportError, match=r"Expected `int`, got `str` - at `\$.cells.fog.seen`"):
        load_report(path)
    _rewrite(path, lambda d: (d["cells"]["fog"].update(seen=3), d.update(version=1)))
    with pytest.raises(ReportError, match=r"at `\$.version`"):
        load_report(path)


def test_missing_or_broken_file_is_a_report_error(tmp_path):
    with pytest.raises(ReportError, match="cannot read report"):
        load_report(tmp_path / "none.json")
    (tmp_path / "bad.json").write_text("{")
    with pytest.raises(ReportError, match="is not valid JSON"):
        load_report(tmp_path / "bad.json")


def test_format_table1_lists_rows_accuracy_and_events(removal_report):
    text = format_table1(removal_report)
    assert "ground" in text and "flat_box" in text
    assert "cells labelled right" in text
    assert (
        f"remove flat_box ({removal_report.events[0].footprint_cells} cells): cleared FOG" in text
    )
    unscored = dataclasses.replace(removal_report, table1=None, cells=None, events=())
    assert format_table1(unscored) == "Table I: no ground truth (nothing to score)."


def test_format_table1_of_a_hand_made_report():
    report = make_report(
        [row("ground", -0.4), row("sill", None)],
        seen=400,
        accuracy=0.975,
        events=[event("box", 4)],
    )
    assert format_table1(report).splitlines() == [
        "floor             truth mm    FOG mm     err  cells    avg mm     err",
        "ground                 0.0      -0.4    -0.4     10         -       -",
        "sill                   0.0         -       -      0         -       -",
        "cells labelled right: 97.5 % of 400 seen",
        "floor: recall -, precision -; obstacle: recall -, precision -",
        "unsafe cells: 0 (0 floor on obstacle, 0 floor off > 20 mm); "
        "floor height error p50 - / p95 - / max - mm",
        "remove box (20 cells): cleared FOG 4 / averaging never; "
        "floor again FOG 4 / averaging never (frames after the event)",
    ]


def test_format_table1_shows_the_new_figures_compactly():
    report = make_report(
        [row("ground", 1.0)],
        seen=400,
        accuracy=0.9,
        floor=class_scores(380, 390, 370),
        obstacle=class_scores(20, 10, 8),
        safety=safety_with(7, on_obstacle=2),
        step_edges=[
            step_edge("sill", "x_min", -80.0, 120.0, 0.0, 160.0),
            step_edge("sill", "x_max", 4.0, 40.0),  # a report from before the band figures
            step_edge("step_1", "x_min", None, None, None, None),
        ],
        unseen_objects=["box_left_2", "box_right_2"],
        ceiling=CeilingScores(12, 20.0, 60.0),
        pose_error=PoseErrorStats(
            frames=5,
            residual_heading_deg=MedianMax(1.5, 3.0),
            map_heading_deg=MedianMax(1.25, 2.5),
            world_heading_deg=MedianMax(1.3, 2.6),
            residual_tilt_deg=MedianP95Max(0.13, 1.17, 3.16),
        ),
    )
    assert format_table1(report).splitlines()[2:] == [
        "cells labelled right: 90.0 % of 400 seen",
        "floor: recall 97.4 %, precision 94.9 %; obstacle: recall 40.0 %, precision 80.0 %",
        "unsafe cells: 7 (2 floor on obstacle, 5 floor off > 20 mm); "
        "floor height error p50 1.0 / p95 3.0 / max 40.0 mm",
        "step edges, median / max |error| mm (+ = toward the higher side),"
        " [nearest edge the map allows, undecided band] mm:",
        "  sill: x_min -80.0 / 120.0 [0.0, 160.0]  x_max 4.0 / 40.0",
        "  step_1: x_min - / - [-, -]",
        "camera left by the corrections (as mapped; every frame in frames.csv): "
        "tilt median 0.13 / p95 1.17 / max 3.16°, heading median 1.25 / max 2.50°",
        "never seen: box_left_2, box_right_2",
        "ceiling: 12 cells, |error| median 20.0 / max 60.0 mm",
    ]


POOR = dataclasses.replace(
    GOOD,
    withdrawn_fraction=0.74679,
    map_empty=True,
    poor=True,
    reasons=("581 of 778 frames (74.7 %) were withdrawn", "the map is empty"),
)


def test_a_poor_run_prints_a_warning_line_per_reason(removal_report):
    report = make_report([row("ground", 1.0)], quality=POOR)
    lines = format_table1(report).splitlines()
    assert lines[-2:] == [
        "WARNING: poor run: 581 of 778 frames (74.7 %) were withdrawn",
        "WARNING: poor run: the map is empty",
    ]
    assert format_warnings(report) == lines[-2:]
    unscored = dataclasses.replace(report, table1=None, cells=None, safety=None, events=())
    assert format_table1(unscored).splitlines() == [
        "Table I: no ground truth (nothing to score).",
        *lines[-2:],
    ]
    assert format_warnings(removal_report) == []


def test_a_poor_quality_block_round_trips(tmp_path):
    report = make_report([row("ground", 1.0)], quality=POOR)
    assert load_report(write_report(tmp_path / "report.json", report)) == report
