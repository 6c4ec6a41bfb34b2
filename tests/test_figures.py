"""The truth-based figures on hand-built archives and truths, with known answers.

Per-class recall and precision, unsafe cells, step-edge position errors, objects never seen,
ceiling errors, and the quality gate.
"""

import math

import numpy as np
from archive_factory import CELL, FLOOR, OBSTACLE, UNKNOWN, centers, store, truth_grid

from fogsim.eval.archive import WorldArchive
from fogsim.eval.metrics import (
    MAX_UNSAFE_POSITIONS,
    ceiling_scores,
    cell_scores,
    safety_scores,
    score_archive,
    step_edges,
    unseen_objects,
)
from fogsim.eval.report.quality import assess_quality
from fogsim.eval.report.schema import CeilingScores, ClassScores, Percentiles, StepEdge
from fogsim.eval.rounding import mm, rounded
from fogsim.world.truth import ObjectState, SceneTruth

# ----------------------------------------------------------------------------- classes


def test_recall_and_precision_per_class_over_the_seen_cells():
    labels = np.full((4, 5), FLOOR)
    labels[0] = OBSTACLE
    types = np.array(
        [
            [OBSTACLE, OBSTACLE, FLOOR, UNKNOWN, OBSTACLE],  # true obstacles
            [FLOOR, FLOOR, FLOOR, FLOOR, FLOOR],
            [FLOOR, FLOOR, OBSTACLE, UNKNOWN, UNKNOWN],
            [FLOOR, FLOOR, FLOOR, OBSTACLE, FLOOR],
        ]
    )
    grid = truth_grid(labels, np.zeros((4, 5)), np.full((4, 5), 0.2))
    in_view = np.zeros((4, 5), dtype=bool)
    in_view[:2] = True
    s = cell_scores(grid, types, np.zeros((4, 5)), np.ones((4, 5), bool), in_view, 0.04)
    # Seen true floor: 5 + 3 + 5 = 13, of them FOG floor 11; FOG floor on the obstacle row: 1.
    assert s.classes.floor == ClassScores(13, 12, 11, round(11 / 13, 5), round(11 / 12, 5))
    # Seen true obstacles: 4, FOG obstacle on 3 of them and on 2 floor cells.
    assert s.classes.obstacle == ClassScores(4, 5, 3, 0.75, 0.6)
    assert (s.in_view, s.in_view_seen) == (10, 9)


def test_a_class_never_seen_or_never_labelled_has_no_recall_or_precision():
    labels = np.full((2, 2), FLOOR)
    grid = truth_grid(labels, np.zeros((2, 2)))
    s = cell_scores(grid, labels, np.zeros((2, 2)), np.ones((2, 2), bool), np.ones((2, 2), bool), 1)
    assert s.classes.obstacle == ClassScores(0, 0, 0, None, None)
    assert s.classes.floor.recall == 1.0


# ----------------------------------------------------------------------------- safety


def test_unsafe_cells_counts_positions_worst_first_and_height_percentiles():
    labels = np.array([[FLOOR] * 4, [OBSTACLE, OBSTACLE, FLOOR, FLOOR]])
    true_floor = np.array([[0.0, 0.0, 0.1, 0.0], [0.0, 0.0, 0.0, 0.0]])
    grid = truth_grid(labels, true_floor, np.full((2, 4), 0.2))
    types = np.array([[FLOOR] * 4, [FLOOR, OBSTACLE, OBSTACLE, UNKNOWN]])
    heights = np.array([[0.005, 0.03, 0.121, 0.02], [0.0, 0.24, 0.04, np.nan]])
    s = safety_scores(grid, centers(2, 4), types, heights, np.ones((2, 4), bool))
    assert (s.unsafe_cells, s.floor_on_obstacle, s.floor_height_off) == (3, 1, 2)
    assert s.height_tolerance_mm == 20.0  # exactly 20 mm off (cell [0, 3]) is still safe
    # Floor on a 0.2 m obstacle (200 mm), then 30 mm and 21 mm off.
    assert s.positions_xy_m == ((0.06, 0.02), (0.02, 0.06), (0.02, 0.1))
    # |errors| of FOG floor on true floor: 5, 30, 21, 20 mm (numpy's linear percentiles).
    assert s.floor_height_error_mm == Percentiles(20.5, 27.3, 28.65, 29.73, 30.0)


def test_unsafe_positions_are_capped_worst_first():
    labels = np.full((20, 15), OBSTACLE)
    tops = np.arange(300, dtype=np.float64).reshape(20, 15) * 1e-3
    grid = truth_grid(labels, np.zeros((20, 15)), tops)
    types = np.full((20, 15), FLOOR)
    s = safety_scores(grid, centers(20, 15), types, np.zeros((20, 15)), np.ones((20, 15), bool))
    assert s.unsafe_cells == s.floor_on_obstacle == 300
    assert len(s.positions_xy_m) == MAX_UNSAFE_POSITIONS == 200
    assert s.positions_xy_m[0] == (19.5 * CELL, 14.5 * CELL)  # the highest top, 0.299 m
    assert s.floor_height_error_mm == Percentiles(None, None, None, None, None)


# ----------------------------------------------------------------------------- step edges

# A 50 mm step, x in [0.6, 1.0], y in [0.2, 1.0], and a 100 mm platform right behind it,
# x in [1.0, 1.4]: every edge lies on a cell boundary of the 4 cm grid over [0, 1.6] x [0, 1.2].
STEP = ObjectState("step", (0.8, 0.6), (0.4, 0.8, 0.05), 0.0, 0.0, True)
PLATFORM = ObjectState("platform", (1.2, 0.6), (0.4, 0.8, 0.1), 0.0, 0.0, True)
NX, NY = 40, 30


def across(c, x_lo, x_hi):
    """Cells with centres in x_lo < x < x_hi along the treads' width, 0.2 < y < 1.0."""
    return (c[..., 0] > x_lo) & (c[..., 0] < x_hi) & (c[..., 1] > 0.2) & (c[..., 1] < 1.0)


def stairs(*objects):
    names = ("ground", *(o.name for o in objects))
    return SceneTruth(0.0, objects, names, {"ground": 0.0, **{o.name: o.top_m for o in objects}})


def perfect_map(truth):
    """FOG floor at the true support height everywhere."""
    c = centers(NX, NY)
    return c, np.full((NX, NY), FLOOR), truth.support_height_m(c)


def edges_of(truth, types, heights):
    c = centers(NX, NY)
    grid = truth.rasterize(c, CELL)
    rows = step_edges(truth, grid, c, types, heights, np.ones((NX, NY), bool))
    return {(row.surface, row.edge): row for row in rows}


def test_a_perfect_map_puts_every_step_edge_in_place():
    truth = stairs(STEP, PLATFORM)
    _, types, heights = perfect_map(truth)
    rows = edges_of(truth, types, heights)
    assert len(rows) == 8
    for (surface, edge), row in rows.items():
        along = 20 if edge.startswith("x") else 10  # cells along the edge: 0.8 m or 0.4 m
        assert row == StepEdge(surface, edge, along - 2, 0.0, 0.0, 0.0, 0.0)  # ends left out


def test_a_riser_mapped_two_cells_toward_the_robot_is_minus_80_mm():
    truth = stairs(STEP, PLATFORM)
    c, types, heights = perfect_map(truth)
    # The map's step begins 2 cells (80 mm) early, toward a robot coming from x = 0.
    heights[across(c, 0.52, 0.6)] = 0.05
    rows = edges_of(truth, types, heights)
    # A floor carried over the edge counts in full: the nearest edge the map allows is as far.
    assert rows["step", "x_min"] == StepEdge("step", "x_min", 18, -80.0, 80.0, -80.0, 0.0)
    assert rows["step", "y_min"] == StepEdge("step", "y_min", 8, 0.0, 0.0, 0.0, 0.0)  # ends
    assert rows["platform", "x_min"].median_error_mm == 0.0


def test_an_obstacle_band_in_front_of_a_riser_puts_the_edge_in_its_middle():
    truth = stairs(STEP, PLATFORM)
    c, types, heights = perfect_map(truth)
    band = across(c, 0.52, 0.6)
    types[band] = OBSTACLE  # the riser, seen 2 cells toward the robot; the tread in place
    heights[band] = 0.06
    row = edges_of(truth, types, heights)["step", "x_min"]
    assert row.median_error_mm == -40.0
    # The band may hold the edge anywhere: the true edge (its far side) fits, 2 cells wide.
    assert (row.median_nearest_error_mm, row.median_gap_mm) == (0.0, 80.0)


def test_a_shadow_behind_a_platform_edge_is_a_gap_not_a_misplaced_edge():
    truth = stairs(STEP, PLATFORM)
    c, types, heights = perfect_map(truth)
    # Nothing seen within 3 cells beyond the platform's far side (x = 1.4): the ground there is
    # unknown, the platform's floor reaches its edge.
    types[(c[..., 0] > 1.4) & (c[..., 0] < 1.52)] = UNKNOWN
    row = edges_of(truth, types, heights)["platform", "x_max"]
    assert row == StepEdge("platform", "x_max", 18, -60.0, 60.0, 0.0, 120.0)
    # The platform's floor carried one cell past it, then 2 cells unknown: the map's floor
    # contradicts the edge by a cell, whatever the band holds.
    types[(c[..., 0] > 1.4) & (c[..., 0] < 1.44) & (c[..., 1] > 0.2) & (c[..., 1] < 1.0)] = FLOOR
    heights[(c[..., 0] > 1.4) & (c[..., 0] < 1.44)] = 0.1
    row = edges_of(truth, types, heights)["platform", "x_max"]
    assert (row.median_error_mm, row.median_nearest_error_mm, row.median_gap_mm) == (
        -80.0,
        -40.0,
        80.0,
    )


def test_sign_is_toward_the_higher_side_from_either_surface():
    truth = stairs(STEP, PLATFORM)
    c, types, heights = perfect_map(truth)
    # The step's 50 mm floor runs one cell into the platform (toward the higher side).
    heights[across(c, 1.0, 1.04)] = 0.05
    rows = edges_of(truth, types, heights)
    assert rows["step", "x_max"].median_error_mm == 40.0
    assert rows["platform", "x_min"].median_error_mm == 40.0
    assert rows["step", "x_max"].median_nearest_error_mm == 40.0
    assert rows["platform", "x_min"].median_gap_mm == 0.0


def test_edges_without_a_seen_cell_or_without_a_step_are_not_listed():
    truth = stairs(STEP, PLATFORM)
    c, types, heights = perfect_map(truth)
    types[c[..., 0] > 1.2] = UNKNOWN
    rows = edges_of(truth, types, heights)
    assert ("platform", "x_max") not in rows  # nothing seen within 0.2 m of x = 1.4
    # Along the platform's y edges, only the slots at x < 1.2 (4 of 8) are seen.
    assert rows["platform", "y_min"] == StepEdge("platform", "y_min", 4, 0.0, 0.0, 0.0, 0.0)
    # Two surfaces of one height side by side: their shared edge is no step.
    twin = ObjectState("twin", (1.2, 0.6), (0.4, 0.8, 0.05), 0.0, 0.0, True)
    flat = stairs(STEP, twin)
    _, types, heights = perfect_map(flat)
    rows = edges_of(flat, types, heights)
    assert ("step", "x_max") not in rows and ("twin", "x_min") not in rows
    assert ("step", "x_min") in rows and ("twin", "x_max") in rows


def test_an_edge_in_view_whose_step_the_map_misses_has_no_error():
    truth = stairs(STEP)
    _, types, heights = perfect_map(truth)
    heights[:] = 0.0  # the map never shows the step
    assert edges_of(truth, types, heights)["step", "x_min"] == StepEdge(
        "step", "x_min", 0, None, None, None, None
    )


def test_edges_are_named_in_the_objects_own_frame():
    # The same footprint as STEP, turned 90 degrees: its local y_max edge is the world's x_min.
    turned = ObjectState("step", (0.8, 0.6), (0.8, 0.4, 0.05), math.pi / 2, 0.0, True)
    truth = stairs(turned)
    c, types, heights = perfect_map(truth)
    heights[across(c, 0.52, 0.6)] = 0.05
    rows = edges_of(truth, types, heights)
    assert rows["step", "y_max"] == StepEdge("step", "y_max", 18, -80.0, 80.0, -80.0, 0.0)
    assert rows["step", "x_min"].median_error_mm == 0.0


# ----------------------------------------------------------------------------- objects, ceiling


def test_unseen_objects_are_the_present_ones_without_a_seen_cell():
    names = ("a", "b", "c", "removed")
    objects = tuple(
        ObjectState(name, (0.1 + 0.2 * i, 0.1), (0.1, 0.1, 0.1), 0.0, 0.0, False)
        for i, name in enumerate(names[:3])
    )
    truth = SceneTruth(0.0, objects, ("ground",), {"ground": 0.0}, object_names=names)
    object_id = np.array([[-1, 0, 0, 1, -1]])  # "c" covers no cell, "removed" is gone
    grid = truth_grid(
        np.full((1, 5), FLOOR), np.zeros((1, 5)), object_id=object_id, object_names=names
    )
    seen = np.array([[True, False, True, False, True]])  # a seen once, b never
    assert unseen_objects(truth, grid, seen) == ("b", "c")


def test_ceiling_errors_where_the_truth_has_a_ceiling():
    true_ceiling = np.array([[0.2, 0.2, 0.2, np.nan]])
    grid = truth_grid(np.full((1, 4), OBSTACLE), np.zeros((1, 4)), ceiling_m=true_ceiling)
    mapped = np.array([[0.18, 0.26, np.nan, 0.3]])
    region = np.ones((1, 4), dtype=bool)
    assert ceiling_scores(grid, mapped, region) == CeilingScores(2, 40.0, 60.0)
    assert ceiling_scores(grid, np.full((1, 4), np.nan), region) == CeilingScores(0, None, None)
    no_ceiling = truth_grid(np.full((1, 4), FLOOR), np.zeros((1, 4)))
    assert ceiling_scores(no_ceiling, mapped, region) is None


# ----------------------------------------------------------------------------- quality


def half_wrong_floor_scores():
    """Scores of a map whose floor is right on 4 of 10 seen floor cells (6 are 50 mm off)."""
    c = centers(1, 10)
    heights = np.where(np.arange(10) < 4, 0.0, 0.05)[None, :]
    archive = store(WorldArchive(CELL), c, np.full((1, 10), FLOOR), heights)
    grid = truth_grid(np.full((1, 10), FLOOR), np.zeros((1, 10)))
    truth = SceneTruth(0.0, (), ("ground",), {"ground": 0.0})
    return score_archive(archive, truth, grid, 0.04)


def quality(**changes):
    """The quality of a 100-frame run without ground truth, z matching off, with ``changes``."""
    counts = dict(
        frames=100,
        withdrawn=0,
        frames_without_ground_plane=0,
        z_match=False,
        map_empty=False,
        scores=None,
    )
    return assess_quality(**{**counts, **changes})


def test_a_good_run_passes_the_quality_gate():
    q = quality(withdrawn=20, frames_without_ground_plane=50)
    assert (q.withdrawn_fraction, q.frames_without_ground_plane) == (0.2, 50)
    assert not q.poor and q.reasons == () and q.floor_right_fraction is None
    # With z matching, frames without a ground plane are matched or withdrawn: no limit.
    assert not quality(frames_without_ground_plane=90, z_match=True).poor


def test_each_crossed_limit_is_a_reason():
    scores = half_wrong_floor_scores()
    assert scores.safety.floor_height_off == 6
    q = quality(
        frames=778, withdrawn=581, frames_without_ground_plane=400, map_empty=True, scores=scores
    )
    assert q.poor and q.floor_right_fraction == 0.4
    assert q.reasons == (
        "581 of 778 frames (74.7 %) were withdrawn by the z-match rule (limit 20 %)",
        "400 of 778 frames (51.4 %) had no ground plane and z matching is off (limit 50 %)",
        "the map is empty: the FOG labelled no cell floor or obstacle",
        "only 40.0 % of the seen floor is floor within 20 mm of the truth (limit 50 %)",
    )


def test_report_numbers_are_rounded_and_never_a_negative_zero():
    assert mm(0.0123456) == 12.35 and mm(float("nan")) is None
    assert math.copysign(1.0, mm(-1e-9)) == 1.0  # -0.000001 mm rounds to 0.0, not -0.0
    assert math.copysign(1.0, rounded(-1e-9, 5)) == 1.0
    assert rounded(float("inf"), 2) is None
