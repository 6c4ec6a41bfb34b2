"""`bench/unsafe_causes.py`: a traced unsafe cell's points sorted by what put them there."""

from __future__ import annotations

import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "bench"))

import unsafe_causes

LEVELS = {"ground": 0.0, "step_2": 70.0, "step_3": 95.0}


def _frame(points):
    """A traced frame of (floor_mm, true_hit, meas_xy) points."""
    return {
        "floor_mm": [p[0] for p in points],
        "true_hit": [p[1] for p in points],
        "meas_xyz": [[p[2][0], p[2][1], 0.0] for p in points],
    }


def test_points_are_right_pose_depth_or_relabelled():
    """A step_3 cell (95 mm) at (3.62, 1.1): a point at 95 is right; one at 70 of step_2 that
    the true pose puts at x = 3.58 (another cell) was moved by the pose, one the true pose puts
    in the cell by the depth; a point at 70 whose true hit is step_3 was relabelled (3 of them:
    the cell's cause)."""
    entry = {
        "xy": [3.62, 1.1],
        "truth": "step_3",
        "truth_floor_mm": 95.0,
        "fog_mm": 71.0,
        "frames": [
            _frame([(95.0, "step_3", (3.62, 1.1)), (70.0, "step_2", (3.58, 1.1))]),
            _frame([(70.0, "step_2", (3.63, 1.11))] + [(70.0, "step_3", (3.60, 1.1))] * 3),
        ],
    }
    cause, kinds = unsafe_causes.classify(entry, LEVELS)
    assert cause == "relabelled"
    assert dict(kinds) == {"right": 1, "pose": 1, "depth": 1, "relabelled": 3}


def test_every_floor_point_of_an_obstacle_cell_is_wrong():
    """A cell the truth calls an obstacle (NaN floor): its points at the sill's own height that
    the true pose puts elsewhere count as pose, and the cause is marked ``O:``."""
    entry = {
        "xy": [2.70, 0.1],
        "truth": "sill",
        "truth_floor_mm": math.nan,
        "fog_mm": 45.0,
        "frames": [_frame([(45.0, "sill", (2.75, 0.1))] * 2)],
    }
    cause, kinds = unsafe_causes.classify(entry, {"ground": 0.0, "sill": 45.0})
    assert cause == "O:pose"
    assert dict(kinds) == {"pose": 2}
