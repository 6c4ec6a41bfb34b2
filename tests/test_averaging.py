"""The Kagami-style averaging baseline: running means by hand, labels, no forgetting."""

import numpy as np
import pytest

from mapper import AveragingMap, CellType, MapperParams

P = MapperParams()
ORIGIN = np.array([0.0, 0.0, 0.55])


def test_running_mean_by_hand():
    m = AveragingMap(P)
    # cell (60, 50): x 0.40..0.44, y 0..0.04
    m.update([[0.41, 0.01, 0.10], [0.43, 0.03, 0.20]], [np.nan, np.nan], ORIGIN)
    m.update([[0.42, 0.02, 0.30]], [0.30], ORIGIN)
    types, heights = m.fog()
    assert heights[60, 50] == pytest.approx(0.20)  # (0.1 + 0.2 + 0.3) / 3
    assert types[60, 50] == CellType.OBSTACLE  # 1 of 3 points floor-labelled
    assert m.floor()[60, 50] == pytest.approx(0.30)  # mean h of the floor points only
    assert types[0, 0] == CellType.UNKNOWN and np.isnan(heights[0, 0])
    assert np.isnan(m.floor()[0, 0])


def test_floor_label_by_majority():
    m = AveragingMap(P)
    pts = [[0.41, 0.01, 0.05]] * 3
    m.update(pts, [0.05, 0.05, np.nan], ORIGIN)
    assert m.fog()[0][60, 50] == CellType.FLOOR
    m.update(pts[:1], [np.nan], ORIGIN)  # 2 of 4: no majority
    assert m.fog()[0][60, 50] == CellType.OBSTACLE


def test_never_forgets_unobserved_cells():
    m = AveragingMap(P)
    m.update([[0.41, 0.01, 0.07]], [0.07], ORIGIN)
    for _ in range(50):  # other cells observed, rays through (60, 50) change nothing
        m.update([[1.0, 0.01, 0.0]], [0.0], ORIGIN)
    assert m.floor()[60, 50] == pytest.approx(0.07)


def test_update_counts_and_bad_input():
    m = AveragingMap(P)
    r = m.update([[0.41, 0.01, 0.0], [np.nan, 0, 0], [9.0, 0, 0]], [0.0, np.nan, 0.0], ORIGIN)
    assert (r.points_used, r.points_dropped_nonfinite, r.points_dropped_outside) == (1, 1, 1)
    assert r.floor_points_used == 1
    assert r.affected_area.slices == (slice(60, 61), slice(50, 51))
    empty = m.update(np.empty((0, 3)), np.empty(0), ORIGIN)
    assert empty.affected_area is None
    with pytest.raises(ValueError, match=r"floor_heights must have shape"):
        m.update(np.zeros((2, 3)), np.zeros(3), ORIGIN)


def test_recenter_keeps_world_content():
    m = AveragingMap(P)
    m.update([[0.41, 0.01, 0.07]], [0.07], ORIGIN)
    assert m.recenter(0.4, 0.0) == (10, 0)
    ix, iy = m.geometry.cell_of([[0.41, 0.01]])[0][0]
    assert (ix, iy) == (50, 50)
    assert m.floor()[50, 50] == pytest.approx(0.07)
    assert np.isnan(m.floor()[90:]).all()
