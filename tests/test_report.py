"""report.json: the DESIGN.md "Results" keys, the typed round trip, strict loading, Table I text."""

import dataclasses
import json

import numpy as np
import pytest
from msgspec import UNSET
from report_factory import event, make_report, row
from test_pipeline import NAMES, make_frames, provider_removed_at

from fogsim.config import load_scenario
from fogsim.errors import ReportError
from fogsim.eval.report import Report, build_report, format_table1, load_report, write_report
from fogsim.run.runner import run_frames

RESULTS_KEYS = [
    "format",
    "version",
    "scenario",
    "seed",
    "source",
    "table1",
    "cells",
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
    assert r["format"] == "fogsim-report" and r["version"] == 1
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
    assert list(r["cells"]) == ["fog", "obstacles", "averaging"]
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
    assert list(r["params"]) == ["mapper", "segmentation", "elevation", "pipeline"]
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
    _rewrite(path, lambda d: (d["cells"]["fog"].update(seen=3), d.update(version=2)))
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
    assert "remove flat_box: footprint cleared after FOG" in text
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
        "remove box: footprint cleared after FOG 4 / averaging None frames",
    ]
