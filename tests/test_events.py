"""Event figures with known answers: each object's own footprint, cleared and floor-again frames.

Maps are built by hand from the scene's geometry (support heights), so the figures depend only on
the tracker: which cells belong to which event and when each map forgets the object.
"""

from __future__ import annotations

import numpy as np
from msgspec import UNSET

from fogsim.config import Event, scenario_from_toml
from fogsim.eval.events import EventTracker
from fogsim.eval.report.schema import EventFrames, EventSeen, MaxFinal
from fogsim.world.timeline import ObjectState
from fogsim.world.truth import SceneTruth
from mapper import CellType

CELL = 0.04


def lattice(x0: float, nx: int, y0: float, ny: int) -> np.ndarray:
    """(nx, ny, 2) cell centres [m] from (x0, y0) on, CELL apart."""
    gx, gy = np.meshgrid(x0 + CELL * np.arange(nx), y0 + CELL * np.arange(ny), indexing="ij")
    return np.stack([gx, gy], axis=-1)


def maps_of(world: SceneTruth, centers: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A perfect FOG of a world: floor at the support height, obstacle where a non-walkable
    object stands."""
    heights = world.support_height_m(centers)
    types = np.full(heights.shape, CellType.FLOOR, dtype=np.int8)
    for obj in world.objects:
        if not obj.walkable:
            types[obj.contains(centers)] = CellType.OBSTACLE
    return types, heights


# Two removals and a slider, 10 frames per second. box_a (25 cells) goes at 1 s, box_b at 2 s;
# the slider leaves at 1 s from right of box_a along y = 0.425 to x = -0.195 (5 s at 0.2 m/s)
# and passes over box_a's top row of cells (y = 0.38).
SCENE = """
name = "two_removals_and_a_slider"
description = "test scene"
seed = 1
frame_rate_hz = 10.0

[robot]
model = "icub"
start = [0.0, 0.0, 0.0]

[[objects]]
name = "box_a"
center = [0.3, 0.3]
size = [0.2, 0.2, 0.05]
walkable = true

[[objects]]
name = "box_b"
center = [0.3, 0.74]
size = [0.2, 0.2, 0.08]
walkable = true

[[objects]]
name = "slider"
center = [0.805, 0.425]
size = [0.1, 0.1, 0.1]

[[route]]
wait = 7.0

[[events]]
at = 1.0
remove = "box_a"

[[events]]
at = 1.0
move = "slider"
to = [-0.195, 0.425]
speed = 0.2

[[events]]
at = 2.0
remove = "box_b"
"""


def test_each_object_has_its_own_footprint_and_known_frame_counts():
    scenario = scenario_from_toml(SCENE)
    centers = lattice(-0.38, 40, 0.02, 30)

    def world_at(t: float) -> SceneTruth:
        return SceneTruth.from_scenario(scenario, t)

    start = world_at(0.0)
    box_a = start.object_state("box_a").contains(centers)
    box_b = start.object_state("box_b").contains(centers)
    a_kept = box_a & (centers[..., 1] < 0.36)  # box_a less the row the slider passes over
    assert box_a.sum() == 25 and a_kept.sum() == 20 and box_b.sum() == 25

    # The old rule (cells higher in the world before box_a's removal than in the world at the
    # end) takes box_b and the slider's start for box_a's footprint too: 56 cells, of which
    # box_b's 25 show until frame 24.
    end = world_at(6.9)
    before = world_at(1.0 - 1e-6)
    old_rule = before.support_height_m(centers) > end.support_height_m(centers) + 0.02
    assert old_rule.sum() == 25 + 25 + 6 and (old_rule & box_b).sum() == 25

    tracker = EventTracker(scenario.events, world_at)
    for i in range(70):
        t = i / 10
        types, heights = maps_of(world_at(t), centers)
        if 10 <= i <= 12:  # the FOG shows box_a 3 frames after its removal ...
            heights[a_kept] = 0.05
        elif 13 <= i <= 15:  # ... then nothing for 3 frames, then the floor (frame 16 on)
            heights[a_kept] = np.nan
            types[a_kept] = CellType.UNKNOWN
        if 20 <= i <= 24:  # box_b 5 frames after its removal
            heights[box_b] = 0.08
        averaging = heights.copy()
        if i >= 10:  # the averaging keeps box_a's left two columns (8 of 20 cells) for ever
            averaging[a_kept & (centers[..., 0] < 0.3)] = 0.05
        if i < 20:  # and never saw box_b
            averaging[box_b] = np.nan
        tracker.update(i, t, centers, CELL, types, heights, averaging)

    a, slider, b = tracker.results()
    assert (a.object, a.kind, a.start_frame) == ("box_a", "remove", 10)
    assert (a.footprint_cells, a.excluded_cells, a.old_top_mm) == (20, 5, 50.0)
    assert a.seen == EventSeen(fog=True, averaging=True)
    assert a.cleared_frames == EventFrames(fog=3, averaging=None)  # None: never
    assert a.floor_again_frames == EventFrames(fog=6, averaging=None)
    assert a.intermediate_floor_cells is UNSET
    assert a.text() == (
        "remove box_a (20 cells): cleared FOG 3 / averaging never; "
        "floor again FOG 6 / averaging never (frames after the event)"
    )

    assert (b.object, b.start_frame, b.footprint_cells, b.excluded_cells) == ("box_b", 20, 25, 0)
    assert b.seen == EventSeen(fog=True, averaging=False)
    assert b.cleared_frames == EventFrames(fog=5, averaging=None)  # None: not seen
    assert b.floor_again_frames == EventFrames(fog=5, averaging=None)
    assert "cleared FOG 5 / averaging not seen; floor again FOG 5 / averaging not seen" in b.text()

    # The slider's footprint: the 27 × 3 cells it slid over less the 2 × 3 it ends on and the
    # column beside them (within one cell). It stands on its footprint until it arrives at 6 s
    # (frame 60); the maps follow it at once.
    assert (slider.object, slider.kind, slider.start_frame) == ("slider", "move", 10)
    assert (slider.footprint_cells, slider.excluded_cells) == (72, 0)
    assert slider.seen == EventSeen(fog=True, averaging=True)
    assert slider.cleared_frames == EventFrames(fog=50, averaging=50)
    assert slider.floor_again_frames == EventFrames(fog=50, averaging=50)
    assert slider.intermediate_floor_cells.fog == MaxFinal(max=0, final=0)


def test_a_moved_box_sweeps_the_cells_between_its_places_and_smears_count():
    box = ObjectState("box", (0.3, 0.6), (0.2, 0.18, 0.06), 0.0, 0.0, True)
    moved = ObjectState("box", (0.9, 0.6), (0.2, 0.18, 0.06), 0.0, 0.0, True)
    names, heights_m = ("ground", "box"), {"ground": 0.0, "box": 0.06}
    worlds = [SceneTruth(t, (b,), names, heights_m) for t, b in ((0.0, box), (1.0, moved))]

    def world_at(t: float) -> SceneTruth:  # the box jumps at 1 s: no frame sees it between
        return worlds[0] if t < 1.0 else worlds[1]

    centers = lattice(0.02, 30, 0.02, 30)
    tracker = EventTracker([Event(at=1.0, move="box", to=(0.9, 0.6), speed=1.0)], world_at)
    types, heights = maps_of(worlds[1], centers)
    smeared = heights.copy()
    smeared[12, 15] = smeared[13, 15] = 0.03  # between the places (x 0.50, 0.54), half height
    tracker.update(0, 0.0, centers, CELL, *maps_of(worlds[0], centers), heights)
    tracker.update(1, 1.0, centers, CELL, types, heights, smeared)
    tracker.update(2, 2.0, centers, CELL, types, heights, heights)
    (result,) = tracker.results()
    # 20 × 4 cells from x 0.22 to 0.98 (rows 0.54–0.66), less the 5 × 4 it ends on and the
    # column beside them (x 0.78, within one cell).
    assert (result.kind, result.footprint_cells, result.excluded_cells) == ("move", 56, 0)
    assert result.seen == EventSeen(fog=True, averaging=False)  # the baseline had only floor
    assert result.cleared_frames == EventFrames(fog=0, averaging=None)
    assert result.intermediate_floor_cells.fog == MaxFinal(max=0, final=0)
    assert result.intermediate_floor_cells.averaging == MaxFinal(max=2, final=0)


def test_what_the_object_stood_on_stays_and_what_covers_it_does_not():
    platform = ObjectState("platform", (0.6, 0.6), (1.0, 1.0, 0.1), 0.0, 0.0, True)
    box = ObjectState("box", (0.6, 0.6), (0.18, 0.18, 0.05), 0.0, 0.1, True)  # on the platform
    table = ObjectState("table", (0.745, 0.6), (0.2, 0.6, 0.02), 0.0, 0.4, True)  # above it
    names = ("ground", "platform", "box", "table")
    with_box = SceneTruth(0.0, (platform, box, table), names)
    without = SceneTruth(1.0, (platform, table), names)

    def world_at(t: float) -> SceneTruth:
        return with_box if t < 1.0 else without

    centers = lattice(0.02, 30, 0.02, 30)
    tracker = EventTracker([Event(at=1.0, remove="box")], world_at)
    for i, t in enumerate((0.0, 1.0, 2.0)):
        types, heights = maps_of(world_at(t), centers)
        tracker.update(i, t, centers, CELL, types, heights, heights)
    (result,) = tracker.results()
    # The box covers x, y in [0.51, 0.69]: 4 × 4 cells. The table (x from 0.645) overlaps the
    # cells centred at x 0.66: one column left out; three stay, on the platform's floor.
    assert (result.footprint_cells, result.excluded_cells) == (12, 4)
    assert result.old_top_mm == 150.0
    assert result.cleared_frames == EventFrames(fog=0, averaging=0)
    assert result.floor_again_frames == EventFrames(fog=0, averaging=0)


def test_an_event_after_the_last_frame_has_no_start_and_no_figure():
    box = ObjectState("box", (0.3, 0.3), (0.2, 0.2, 0.05), 0.0, 0.0, True)
    world = SceneTruth(0.0, (box,), ("ground", "box"))
    centers = lattice(0.02, 20, 0.02, 20)
    tracker = EventTracker([Event(at=5.0, remove="box")], lambda t: world)
    tracker.update(0, 0.0, centers, CELL, *maps_of(world, centers), world.support_height_m(centers))
    (result,) = tracker.results()
    assert result.start_frame is None and result.footprint_cells == 25
    assert result.seen == EventSeen(fog=True, averaging=True)
    assert result.cleared_frames == EventFrames(None, None)
    assert result.text() == "remove box (25 cells): the run ended before the event"


def test_floor_again_counts_the_cells_the_map_knows_when_it_knows_half_the_place():
    box = ObjectState("box", (0.3, 0.3), (0.2, 0.2, 0.06), 0.0, 0.0, True)
    names = ("ground", "box")
    with_box, without = SceneTruth(0.0, (box,), names), SceneTruth(1.0, (), names)

    def world_at(t: float) -> SceneTruth:
        return with_box if t < 1.0 else without

    centers = lattice(0.02, 30, 0.02, 30)
    footprint = (np.abs(centers[..., 0] - 0.3) < 0.1) & (np.abs(centers[..., 1] - 0.3) < 0.1)
    tracker = EventTracker([Event(at=1.0, remove="box")], world_at)
    tracker.update(
        0, 0.0, centers, CELL, *maps_of(with_box, centers), maps_of(with_box, centers)[1]
    )
    types, heights = maps_of(without, centers)
    # Frame 1: the map knows one cell of the place (floor), the rest erased: not floor again.
    one_known = types.copy()
    one_known[footprint] = CellType.UNKNOWN
    first = np.argwhere(footprint)[0]
    one_known[tuple(first)] = CellType.FLOOR
    tracker.update(1, 1.0, centers, CELL, one_known, heights, heights)
    # Frame 2: it knows 60 % of the place, all floor: floor again (the rest is unknown).
    some_known = types.copy()
    cells = np.argwhere(footprint)
    for i, j in cells[int(0.6 * len(cells)) :]:
        some_known[i, j] = CellType.UNKNOWN
    tracker.update(2, 2.0, centers, CELL, some_known, heights, heights)
    (result,) = tracker.results()
    assert result.footprint_cells == len(cells) == 25
    assert result.cleared_frames.fog == 0  # unknown cells never show the object
    assert result.floor_again_frames.fog == 1
