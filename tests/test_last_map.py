"""The last-measurement map: the highest point of the latest frame that hit a cell, nothing else."""

import numpy as np

from mapper import CellType, MapperParams
from mapper.last_map import LastMeasurementMap

ORIGIN = np.array([0.0, 0.0, 1.0])


def frame(emap, points):
    pts = np.array(points, dtype=float)
    return emap.update(pts, np.full(len(pts), np.nan), ORIGIN)


def test_a_frame_leaves_its_highest_point_per_cell_and_replaces_older_frames():
    m = LastMeasurementMap()
    result = frame(m, [[0.02, 0.02, 0.10], [0.03, 0.01, 0.25], [0.06, 0.02, 0.05]])
    assert (result.points_used, result.cells_updated) == (3, 2)
    h = m.heights()
    assert h[50, 50] == 0.25 and h[51, 50] == 0.05
    frame(m, [[0.02, 0.02, 0.01]])  # a later, lower frame replaces the cell
    h = m.heights()
    assert h[50, 50] == 0.01 and h[51, 50] == 0.05  # the cell it missed keeps its height
    assert np.isfinite(h).sum() == 2


def test_points_outside_the_grid_are_dropped_and_fog_uses_the_rule():
    m = LastMeasurementMap(MapperParams(nx=20, ny=20))
    result = frame(m, [[0.02, 0.02, 0.0], [0.06, 0.02, 0.0], [5.0, 0.0, 0.0], [0.0, 0.0, 9.0]])
    assert (result.points_used, result.points_dropped_outside) == (2, 2)
    types, _ = m.fog()
    assert types[10, 10] == CellType.FLOOR and types[11, 10] == CellType.FLOOR
    frame(m, [[0.10, 0.02, 0.2]])  # a 20 cm top beside them: the window spans 0.2 m > 0.05 m
    types, _ = m.fog()
    assert types[12, 10] == CellType.OBSTACLE and types[11, 10] == CellType.OBSTACLE
    assert types[10, 10] == CellType.FLOOR  # two cells away: outside the 3-cell window
    assert (types == CellType.UNKNOWN).sum() == 20 * 20 - 3


def test_recenter_scrolls_and_empties_the_entering_cells():
    m = LastMeasurementMap(MapperParams(nx=10, ny=10))
    frame(m, [[0.02, 0.02, 0.1]])
    assert m.recenter(0.02, 0.10) == (0, 2)
    assert m.heights()[5, 3] == 0.1 and np.isfinite(m.heights()).sum() == 1
    assert m.recenter(5.0, 0.0) == (125, -2)
    assert np.isnan(m.heights()).all()
