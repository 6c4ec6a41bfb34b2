"""bench/unsafe_kinds.py: unsafe cells counted by kind on a hand-made map."""

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "bench"))
unsafe_kinds = pytest.importorskip("unsafe_kinds")

from mapper.grid import CellType  # noqa: E402

FL, OB, UN = int(CellType.FLOOR), int(CellType.OBSTACLE), int(CellType.UNKNOWN)
NAN = np.nan


def test_each_unsafe_cell_is_counted_once_by_its_kind():
    # Rows along x. The truth: ground (0) at x = 0, riser cells (obstacle, top 60 mm) at x = 1,
    # a tread (60 mm) at x = 2 and, at its end, an obstacle cell (top 60 mm) with nothing
    # stepping around it (a tie: counted a side edge).
    truth = np.array([[FL, FL, FL], [OB, OB, OB], [FL, FL, OB]])
    truth_floor = np.array([[0.0, 0.0, 0.0], [NAN, NAN, NAN], [0.06, 0.06, NAN]])
    truth_top = np.array([[NAN, NAN, NAN], [0.06, 0.06, 0.06], [NAN, NAN, 0.06]])
    types = np.array([[FL, FL, FL], [FL, FL, UN], [FL, FL, FL]])
    heights = np.array(
        [
            [0.0, 0.03, -0.025],  # right, 30 mm high (off_hi), 25 mm low (off_lo)
            [0.055, 0.001, NAN],  # risers at the tread's height (hi), the ground's (lo); unknown
            [0.06, 0.06, 0.059],  # right, right, the tie cell at its top's height (hi)
        ]
    )
    maps = {
        "fog_types": types,
        "fog_heights_m": heights,
        "truth_labels": truth,
        "truth_floor_m": truth_floor,
        "truth_obstacle_top_m": truth_top,
        "visited": np.ones((3, 3), dtype=bool),
    }
    counts = unsafe_kinds.kinds(maps)
    # (1, 0) and (1, 1): the truth steps 60 mm across x (ground before, tread after) and not
    # across y — risers; (2, 2): no step either way — a tie, a side edge; (1, 2) is unknown.
    assert counts == {"off_hi": 1, "off_lo": 1, "riser_hi": 1, "riser_lo": 1, "side_hi": 1}
    maps["visited"] = np.zeros((3, 3), dtype=bool)
    assert unsafe_kinds.kinds(maps) == {}
