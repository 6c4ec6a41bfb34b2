"""Scoring against hand-built ground truth: Table I, cell confusion, archive, event clearing."""

import numpy as np
import pytest
from archive_factory import store
from msgspec import UNSET

from fogsim.config import Event
from fogsim.errors import FogsimError
from fogsim.eval.archive import WorldArchive
from fogsim.eval.events import EventTracker
from fogsim.eval.metrics import cell_scores, score_archive, table1_rows
from fogsim.eval.report.schema import (
    ClassScores,
    ConfusionRow,
    EventFrames,
    MaxFinal,
    ObstacleObjectScore,
)
from fogsim.world.truth import ObjectState, SceneTruth
from mapper.grid import CellType

CELL = 0.04


def centers(nx=30, ny=30, x0=0.0, y0=0.0):
    ix, iy = np.meshgrid(np.arange(nx), np.arange(ny), indexing="ij")
    return np.stack([x0 + (ix + 0.5) * CELL, y0 + (iy + 0.5) * CELL], axis=-1)


STEP = ObjectState("step", (0.5, 0.5), (0.4, 0.4, 0.031), 0.0, 0.0, True)
POST = ObjectState("post", (0.9, 0.9), (0.16, 0.16, 0.2), 0.0, 0.0, False, "rough", 0.05)


def truth(objects=(STEP, POST), time_s=0.0):
    return SceneTruth(time_s, tuple(objects), ("ground", "step"), {"ground": 0.0, "step": 0.031})


def test_table1_medians_over_interior_cells_with_border_cells_left_out():
    grid = truth().rasterize(centers(), CELL)
    heights = np.where(grid.labels == CellType.FLOOR, grid.floor_m + 0.002, np.nan)
    step = grid.surface_id == 1
    heights[step & ~grid.interior] = 0.5  # garbage on border cells must not count
    heights[grid.surface_id == 0] = 0.001
    rows = {r.name: r for r in table1_rows(grid, heights, np.isfinite(heights))}
    # Box spans x, y in [0.3, 0.7]; cells lie fully inside from 0.32 to 0.68: 9 x 9 cells.
    assert rows["step"].cells == 81
    assert rows["step"].surface_cells == 81
    assert rows["step"].ground_truth_mm == pytest.approx(31.0)
    assert rows["step"].estimated_mm == pytest.approx(33.0, abs=1e-6)
    assert rows["step"].error_mm == pytest.approx(2.0, abs=1e-6)
    assert rows["ground"].estimated_mm == pytest.approx(1.0, abs=1e-6)


def test_table1_row_without_estimate_is_null():
    grid = truth().rasterize(centers(), CELL)
    rows = table1_rows(grid, np.full(grid.labels.shape, np.nan), np.ones(grid.labels.shape, bool))
    assert all(r.estimated_mm is None and r.error_mm is None for r in rows)
    assert all(r.cells == 0 for r in rows)


def test_cell_scores_confusion_accuracy_and_obstacle_height():
    grid = truth().rasterize(centers(), CELL)
    types = grid.labels.copy()
    # Obstacle tops 20 mm high: the post (0.20 m) and the step's risers (0.031 m).
    heights = np.where(grid.labels == CellType.FLOOR, grid.floor_m, grid.obstacle_top_m + 0.02)
    floor_cells = np.argwhere(grid.labels == CellType.FLOOR)
    for ix, iy in floor_cells[:5]:
        types[ix, iy] = CellType.OBSTACLE  # 5 wrong
    for ix, iy in floor_cells[5:15]:
        types[ix, iy] = CellType.UNKNOWN  # 10 unseen
    region = np.ones(types.shape, dtype=bool)
    in_view = np.zeros(types.shape, dtype=bool)
    in_view[:10] = True  # rows x < 0.4: 300 cells, of them the first 5 + 10 floor cells
    s = cell_scores(grid, types, heights, region, in_view, cell_z_m=0.04)
    n_obstacle = int((grid.labels == CellType.OBSTACLE).sum())
    # The rough post spans [0.82, 0.98]: 5 x 5 cells; the step's edges (0.3, 0.7) cross the
    # cells centred there, which hold its risers: a ring of 4 x 10 cells.
    assert n_obstacle == 25 + 40
    assert s.region == 900
    assert s.in_view == 300 and s.in_view_seen == 290
    assert s.seen == 890
    assert s.correct == 885
    assert s.accuracy == pytest.approx(885 / 890, abs=1e-5)
    assert s.confusion.floor == ConfusionRow(unknown=10, floor=820, obstacle=5)
    assert s.confusion.obstacle == ConfusionRow(unknown=0, floor=0, obstacle=65)
    assert s.classes.floor == ClassScores(825, 820, 820, round(820 / 825, 5), 1.0)
    assert s.classes.obstacle == ClassScores(65, 70, 65, 1.0, round(65 / 70, 5))
    assert s.obstacle_height.cells == 65
    assert s.obstacle_height.median_abs_error_mm == pytest.approx(20.0)
    assert s.obstacle_height.within_one_cell_fraction == 1.0
    assert s.floor_height.max_abs_error_mm == pytest.approx(0.0)


def test_world_archive_keeps_last_value_on_a_world_lattice():
    archive = WorldArchive(CELL)
    first = centers(10, 10)
    seen_first = np.zeros((10, 10), dtype=bool)
    seen_first[7, 2] = True
    ceiling = np.full((10, 10), 0.3)
    store(
        archive,
        first,
        np.full((10, 10), 1),
        np.full((10, 10), 0.01),
        np.zeros((10, 10)),
        ceiling_m=ceiling,
        in_view=seen_first,
    )
    moved = centers(10, 10, x0=5 * CELL, y0=-3 * CELL)  # scrolled by (5, -3) whole cells
    store(
        archive,
        moved,
        np.full((10, 10), 2),
        np.full((10, 10), 0.2),
        np.ones((10, 10)),
        in_view=np.zeros((10, 10), dtype=bool),
    )
    assert archive.visited.shape == (15, 13)
    assert archive.visited.sum() == 100 + 100 - 5 * 7
    xy = archive.cell_centers_xy()
    np.testing.assert_allclose(xy[0, 0], [0.5 * CELL, -2.5 * CELL], atol=1e-12)
    # A cell only in the first grid keeps the first values; overlap takes the second.
    only_first = np.argwhere(np.all(np.isclose(xy, [0.5 * CELL, 5.5 * CELL]), axis=-1))[0]
    overlap = np.argwhere(np.all(np.isclose(xy, [7.5 * CELL, 2.5 * CELL]), axis=-1))[0]
    assert archive.fog_types[tuple(only_first)] == 1
    assert archive.fog_heights_m[tuple(overlap)] == pytest.approx(0.2)
    assert archive.baseline_heights_m[tuple(overlap)] == pytest.approx(1.0)
    assert archive.floor_m[tuple(only_first)] == pytest.approx(0.01)
    assert np.isnan(archive.floor_m[tuple(overlap)])  # the second grid's cells are obstacle
    assert archive.obstacle_m[tuple(overlap)] == pytest.approx(0.2)
    assert archive.ceiling_m[tuple(only_first)] == pytest.approx(0.3)
    assert np.isnan(archive.ceiling_m[tuple(overlap)])
    # In view is kept: the cell seen in the first frame stays seen when a later frame misses it.
    assert archive.in_view.sum() == 1 and archive.in_view[tuple(overlap)]
    assert not archive.is_empty()


def test_score_archive_perfect_map_scores_exactly():
    c = centers()
    grid = truth().rasterize(c, CELL)
    heights = np.where(grid.labels == CellType.FLOOR, grid.floor_m, grid.obstacle_top_m)
    archive = store(WorldArchive(CELL), c, grid.labels, heights)
    scores = score_archive(archive, truth(), grid, cell_z_m=0.04)
    for row in scores.table1.fog + scores.table1.averaging:
        assert row.error_mm == pytest.approx(0.0, abs=1e-9)
    assert scores.cells.fog.accuracy == 1.0
    assert scores.cells.fog.classes.floor.recall == scores.cells.fog.classes.floor.precision == 1
    assert scores.cells.fog.classes.obstacle.recall == 1.0
    assert scores.cells.averaging.seen == 900
    assert scores.safety.unsafe_cells == 0 and scores.safety.positions_xy_m == ()
    assert scores.safety.floor_height_error_mm.max == 0.0
    # The step's four edges lie on cell boundaries: a perfect map puts them exactly there.
    assert {
        (e.edge, e.cells, e.median_error_mm, e.max_abs_error_mm) for e in scores.step_edges
    } == {
        ("x_min", 8, 0.0, 0.0),
        ("x_max", 8, 0.0, 0.0),
        ("y_min", 8, 0.0, 0.0),
        ("y_max", 8, 0.0, 0.0),
    }
    assert scores.unseen_objects == ()
    assert scores.ceiling is None  # nothing hangs
    (post,) = scores.cells.obstacles
    # Post spans [0.82, 0.98]; centres at least half a cell inside: 0.86, 0.90, 0.94.
    assert post == ObstacleObjectScore(
        name="post",
        cells=9,
        seen=9,
        obstacle_fraction=1.0,
        top_mm=200.0,
        median_top_error_mm=0.0,
    )


def _fog_of(grid):
    heights = np.where(grid.labels == CellType.FLOOR, grid.floor_m, grid.obstacle_top_m)
    return grid.labels.copy(), heights


def test_event_tracker_counts_frames_until_footprint_cleared_fog_vs_never_for_baseline():
    box = ObjectState("box", (0.6, 0.6), (0.3, 0.3, 0.05), 0.0, 0.0, True)
    with_box = SceneTruth(0.0, (box,), ("ground", "box"), {"ground": 0.0, "box": 0.05})
    without = SceneTruth(1.0, (), ("ground", "box"), {"ground": 0.0, "box": 0.05})

    def provider(t):
        return with_box if t < 1.0 else without

    c = centers()
    tracker = EventTracker([Event(at=1.0, remove="box")], provider)
    old_types, old_heights = _fog_of(with_box.rasterize(c, CELL))
    new_types, new_heights = _fog_of(without.rasterize(c, CELL))
    for i in range(30):
        t = i * 0.1
        if i < 14:  # the FOG shows the box until frame 14 (4 frames after the event at 10)
            types, heights = old_types, old_heights
        else:
            types, heights = new_types, new_heights
        # Baseline keeps the box's height on its near half forever.
        base = new_heights.copy()
        near = old_heights > 0.04
        near[: int(0.6 / CELL), :] &= True
        near[int(0.6 / CELL) :, :] = False
        base[near] = 0.05
        tracker.update(i, t, c, CELL, types, heights, base)
    (result,) = tracker.results()
    assert result.start_frame == 10
    assert result.footprint_cells == int((old_heights > 0.04).sum()) > 0
    assert result.cleared_frames == EventFrames(fog=4, averaging=None)
    assert result.floor_again_frames == EventFrames(fog=4, averaging=None)
    assert result.intermediate_floor_cells is UNSET  # only moves count intermediate cells


def test_event_tracker_counts_intermediate_floor_cells_of_a_moved_box():
    box = ObjectState("box", (0.3, 0.6), (0.2, 0.2, 0.06), 0.0, 0.0, True)
    moved = ObjectState("box", (0.9, 0.6), (0.2, 0.2, 0.06), 0.0, 0.0, True)
    names, heights_m = ("ground", "box"), {"ground": 0.0, "box": 0.06}
    before = SceneTruth(0.0, (box,), names, heights_m)
    after = SceneTruth(2.0, (moved,), names, heights_m)

    def provider(t):
        return before if t < 1.0 else after

    c = centers()
    tracker = EventTracker([Event(at=1.0, move="box", to=(0.9, 0.6), speed=1.0)], provider)
    types, heights = _fog_of(after.rasterize(c, CELL))
    smeared = heights.copy()
    smeared[12, 15] = 0.03  # ground cell between old and new place, half box height
    smeared[13, 15] = 0.03
    tracker.update(0, 0.0, c, CELL, types, heights, heights)
    tracker.update(1, 1.0, c, CELL, types, heights, smeared)
    tracker.update(2, 2.0, c, CELL, types, heights, heights)
    (result,) = tracker.results()
    assert result.kind == "move"
    # The maps never showed the box at its old place: no event figure (not seen).
    assert not result.seen.fog and result.cleared_frames == EventFrames(None, None)
    assert result.intermediate_floor_cells.fog == MaxFinal(max=0, final=0)
    assert result.intermediate_floor_cells.averaging == MaxFinal(max=2, final=0)


def test_an_empty_archive_has_no_cells():
    with pytest.raises(FogsimError, match="archive is empty"):
        WorldArchive(CELL).cell_centers_xy()
    assert WorldArchive(CELL).is_empty()
    unlabelled = store(WorldArchive(CELL), centers(3, 3), np.zeros((3, 3)), np.full((3, 3), np.nan))
    assert unlabelled.is_empty()
