"""`bench/replay_ab.py`'s comparison of two variants' replays, on hand-made run folders."""

import json
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "bench"))
replay_ab = pytest.importorskip("replay_ab")


def _run_folder(folder, scenario, seed, unsafe, rows, heights):
    """A ``fogsim run`` output folder with the fields the comparison reads."""
    folder.mkdir(parents=True)
    report = {
        "scenario": scenario,
        "seed": seed,
        "safety": {"unsafe_cells": unsafe},
        "table1": {"fog": [{"name": name, "error_mm": error} for name, error in rows.items()]},
    }
    (folder / "report.json").write_text(json.dumps(report))
    np.savez(folder / "maps.npz", fog_heights_m=np.asarray(heights), fog_types=np.array([1, 2]))
    return folder


def test_two_variants_are_compared_per_scenario_worst_first(tmp_path):
    heights = [0.0, np.nan]
    runs = [
        # stairs, seeds 1 and 2: unsafe 4 → 2 and 6 → 10; step_1 better by 1 mm, worse by 0.6.
        ("stairs", 1, 4, 2, {"step_1": -2.0, "ground": 0.1}, {"step_1": -1.0, "ground": 0.3}),
        ("stairs", 2, 6, 10, {"step_1": 1.0, "ground": None}, {"step_1": 1.6, "ground": 0.2}),
        # room, seed 1: 1 → 1, rows within 0.5 mm (not counted), the same maps.
        ("room", 1, 1, 1, {"sill": 0.4}, {"sill": -0.8}),
    ]
    pairs = []
    for scenario, seed, unsafe_a, unsafe_b, rows_a, rows_b in runs:
        name = f"{scenario}_s{seed}"
        folder_a = _run_folder(tmp_path / "a" / name, scenario, seed, unsafe_a, rows_a, heights)
        shifted = heights if scenario == "room" else [1e-12, np.nan]
        folder_b = _run_folder(tmp_path / "b" / name, scenario, seed, unsafe_b, rows_b, shifted)
        pairs.append(
            (
                replay_ab.read_report(folder_a),
                replay_ab.read_report(folder_b),
                replay_ab.same_maps(folder_a, folder_b),
            )
        )
    assert [identical for *_, identical in pairs] == [False, False, True]
    lines = replay_ab.compare(pairs)
    assert (
        lines[2]
        == "| `stairs` | 5.00 (6) → 6.00 (10) | step_1 2.00 (seed 1) → step_1 1.60 (seed 2) |"
    )
    assert lines[3] == "| `room` | 1.00 (1) → 1.00 (1) | sill 0.40 (seed 1) → sill 0.80 (seed 1) |"
    assert lines[-1] == (
        "in all 6.00 → 7.00 unsafe cells; Table I rows 0.5 mm or more better / worse: 1 / 1; "
        "the same maps bit for bit: 1 of 3 recordings"
    )


def test_maps_differing_in_an_array_s_keys_are_not_the_same(tmp_path):
    a = _run_folder(tmp_path / "a", "stage", 1, 0, {}, [0.5])
    b = tmp_path / "b"
    b.mkdir()
    (b / "report.json").write_text((a / "report.json").read_text())
    np.savez(b / "maps.npz", fog_heights_m=np.array([0.5]))  # fog_types missing
    assert not replay_ab.same_maps(a, b)
    assert replay_ab.same_maps(a, a)
