"""Event scores: per removed or moved object, how many frames each map takes to forget it.

**Footprint.** An event's footprint is the object's own cells, on the world-fixed lattice of the
mapper's cells (a cell belongs to an object when its centre lies in the object's outline):

* the cells the object covers just before its event time ``at`` and, for a move, every cell it
  passes over from ``at`` on (the straight slide between consecutive frames included, so a fast
  object skips no cell) except the cells within one cell of where it stands at the last frame
  (a cell whose centre lies within ``cell_m`` of its outline: a map's edges are right to one
  cell; moving_box, seeds 1–8: the camera's pose error, 6–18 mm and 1–2° median, puts the
  box's face at its new place 1–3 cm into the row beside it on 5 seeds, which never cleared);
* minus the cells that another object covers at any frame time from ``at`` on — any part of
  the cell, the slide between frames included — and that rise above the floor the object left
  there: a neighbour that also moves or is removed, a box standing next to it, a table above
  it. What the object stood on (the ground, a platform) does not rise above that floor and
  stays, unless it moves or leaves later (then the floor changes: the cell is left out too);
* minus the cells where the object's top is less than two tolerances above that floor (it could
  not be told from the floor).

*The floor it left* is the support height of the world without the object at the start frame
(:meth:`SceneTruth.support_height_m`); before the event, "shows the object" is judged against
the support without it just before ``at``. The footprint needs the whole run ("at any time
after"), so :class:`EventTracker` records every frame and computes the footprint and the figures
at the end (:meth:`EventTracker.results`).

**Figures**, for each map, in frames from the event's start frame (the first frame at or after
``at``), over the footprint cells inside the map's grid at that frame. A frame without such a
cell, or while a moved object still stands on a footprint cell, counts as neither: for a move
both figures include the time the object takes to slide off its footprint.

* ``cleared_frames``: until no footprint cell shows the object — no FOG obstacle, and no height
  nearer the object's top than the floor (unknown cells are fine: the 3-D grid may erase a cell
  whose floor the camera cannot see).
* ``floor_again_frames``: until at least ``floor_fraction`` (90 %) of the cells the map knows
  are floor within ``tolerance_m`` (10 mm) of the floor the object left (FOG floor cells; for
  the averaging baseline every height is a floor observation). Unknown cells are left out, as
  for ``cleared_frames``: the camera may never see part of the place again (moving_box: 11–25
  of its 200 cells, outside the view, kept 5 of 8 seeds from ever reaching 90 %). The map must
  know at least :data:`MIN_KNOWN_FRACTION` of the footprint's cells in view, or a place the
  map has erased and knows one cell of would be floor again.
* ``seen``: whether the map showed the object (as above) on a cell of its footprint at ``at``
  in some frame before the event. A map that never saw the object gets no figure: both are
  None with ``seen`` false (None with ``seen`` true means never).
* moves only, ``intermediate_floor_cells``: per frame, footprint cells the object is not on that
  the map labels floor at a height more than ``tolerance_m`` above the floor and below the
  object's top by more than ``tolerance_m`` (the smear of a slid box); its largest and its last
  count.

Maps are 2-D arrays over the current grid's cells (index ``[ix, iy]``), heights in metres in the
world frame, NaN = none; labels are ``mapper.CellType`` values.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
from msgspec import UNSET
from numpy.typing import NDArray

from fogsim.config import Event
from fogsim.eval.report.schema import (
    EventFrames,
    EventResult,
    EventSeen,
    IntermediateFloorCells,
    MaxFinal,
)
from fogsim.eval.rounding import mm
from fogsim.world.timeline import ObjectState
from fogsim.world.truth import SceneTruth
from mapper import CellType

TruthProvider = Callable[[float], SceneTruth]
"""Ground truth of the world at a time [s] (``Simulation.truth_at``, ``Recording.truth_at``)."""

BEFORE_EVENT_S = 1e-6
"""The world "just before" an event is the world this long before ``at`` [s]."""

FLOOR_CHANGE_M = 1e-6
"""A support height that differs by more than this [m] has changed (float noise is far
below, the thinnest object far above)."""

MIN_KNOWN_FRACTION = 0.5
""""Floor again" needs the map to know (a label, a height) at least this share of the
footprint's cells in view: the ones it knows are then a sample of the place, not one cell left
after the 3-D grid erased the rest (moving_box: the map knows 175–189 of 200)."""


@dataclass(frozen=True)
class _Cells:
    """The lattice cells an event can concern.

    The object's outline at ``at`` and, for a move, the area it can slide over: the bounding box
    of both places, one cell of margin.

    Attributes:
        xy: (N, 2) world cell centres [m].
        floor_before_m: (N,) support height of the world without the object just before ``at``
            [m] (what a map shows there before the event, but for the object).
        top_m: The object's top [m] (the highest bump of a rough top).
        covered_at_event: (N,) the object covers the cell centre just before ``at``.
    """

    xy: NDArray[np.float64]
    floor_before_m: NDArray[np.float64]
    top_m: float
    covered_at_event: NDArray[np.bool_]


@dataclass(frozen=True)
class _MapView:
    """What one map shows at an event's cells in one frame; (N,) each, False off the grid.

    Attributes:
        shows_object: An obstacle, or a height nearer the object's top than the floor.
        floor_again: Floor within the tolerance of the floor the object left.
        intermediate: Floor between the floor and the top, more than the tolerance from both.
        known: The map has a label (FOG) or a height (averaging) there.
    """

    shows_object: NDArray[np.bool_]
    floor_again: NDArray[np.bool_]
    intermediate: NDArray[np.bool_]
    known: NDArray[np.bool_]


@dataclass(frozen=True)
class _FrameRecord:
    """One frame at or after the event.

    Attributes:
        elapsed: Frames since the start frame.
        inside: (N,) cells inside the map's grid.
        object_on: (N,) cells the object covers at this frame (moves).
        fog: What the FOG shows.
        averaging: What the averaging baseline shows.
    """

    elapsed: int
    inside: NDArray[np.bool_]
    object_on: NDArray[np.bool_]
    fog: _MapView
    averaging: _MapView


@dataclass
class _EventTrack:
    """Bookkeeping of one remove/move event (arrays over ``cells``, filled at the first frame).

    Attributes:
        event: The scenario's event.
        cells: The cells the event can concern (None before the first frame).
        seen_fog: (N,) the FOG showed the object there in a frame before the event.
        seen_averaging: (N,) the same for the averaging baseline.
        start_frame: First frame at or after ``at`` (None before).
        swept: (N,) cells the object covered at some frame time from ``at`` on (moves).
        covered_last: (N,) cells within one cell of the object at the latest frame.
        floor_m: (N,) the floor the object left: support height of the world without it at the
            start frame [m].
        others: (N,) cells another object covers from ``at`` on above that floor, or where
            that floor changes later.
        world: The world at the latest frame followed (``at`` minus a moment at first).
        frames: One record per frame from the start frame on.
    """

    event: Event
    cells: _Cells | None = None
    seen_fog: NDArray[np.bool_] = field(default_factory=lambda: np.zeros(0, dtype=bool))
    seen_averaging: NDArray[np.bool_] = field(default_factory=lambda: np.zeros(0, dtype=bool))
    start_frame: int | None = None
    swept: NDArray[np.bool_] = field(default_factory=lambda: np.zeros(0, dtype=bool))
    covered_last: NDArray[np.bool_] = field(default_factory=lambda: np.zeros(0, dtype=bool))
    floor_m: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    others: NDArray[np.bool_] = field(default_factory=lambda: np.zeros(0, dtype=bool))
    world: SceneTruth | None = None
    frames: list[_FrameRecord] = field(default_factory=list)


class EventTracker:
    """Measures, per removed or moved object, how fast each map forgets it (module docstring).

    Call :meth:`update` with every frame's maps from the first frame on (frames before an event
    tell whether a map saw the object), then :meth:`results`.

    Args:
        events: The scenario's events.
        truth_provider: Ground truth at a time [s].
        tolerance_m: Height tolerance of "floor again" and of the intermediate count [m] (the
            pipeline's ``event_tolerance_m``, 1 cm by default).
        floor_fraction: Share of the footprint that must be floor again (0.9: a few cells at
            the outline that keep an edge height do not hold the figure back).
    """

    def __init__(
        self,
        events: Sequence[Event],
        truth_provider: TruthProvider,
        *,
        tolerance_m: float = 0.01,
        floor_fraction: float = 0.9,
    ) -> None:
        self.truth_provider = truth_provider
        self.tolerance_m = float(tolerance_m)
        self.floor_fraction = float(floor_fraction)
        self._tracks = [_EventTrack(event) for event in events]
        self._anchor_xy: NDArray[np.float64] | None = None

    def update(
        self,
        frame_index: int,
        time_s: float,
        centers_xy: NDArray[np.float64],
        cell_m: float,
        fog_types: NDArray[np.integer],
        fog_heights_m: NDArray[np.floating],
        baseline_heights_m: NDArray[np.floating],
    ) -> None:
        """Record one frame's maps.

        Args:
            frame_index: Frame number.
            time_s: Frame time [s].
            centers_xy: (nx, ny, 2) current grid cell centres [m] (the mapper scrolls by whole
                cells, so they lie on the lattice of the first frame's centres).
            cell_m: Cell size [m].
            fog_types: (nx, ny) FOG CellType values.
            fog_heights_m: (nx, ny) FOG heights [m].
            baseline_heights_m: (nx, ny) averaging-baseline heights [m]; every finite one is a
                floor observation.
        """
        if self._anchor_xy is None:
            self._anchor_xy = np.array(centers_xy[0, 0], dtype=np.float64)
        for track in self._tracks:
            if track.cells is None:
                self._begin(track, cell_m)
            cells = track.cells
            assert cells is not None  # set by _begin
            idx, inside = _grid_indices(cells.xy, centers_xy[0, 0], cell_m, centers_xy.shape[:2])
            before = time_s + 1e-9 < track.event.at
            if not before:
                if track.start_frame is None:
                    track.start_frame = int(frame_index)
                self._follow_world(track, time_s, cell_m)
            floor_m = cells.floor_before_m if before else track.floor_m
            fog = self._view(cells.top_m, floor_m, idx, inside, fog_types, fog_heights_m)
            averaging = self._view(cells.top_m, floor_m, idx, inside, None, baseline_heights_m)
            if before:
                track.seen_fog |= fog.shows_object
                track.seen_averaging |= averaging.shows_object
                continue
            assert track.start_frame is not None  # set above
            elapsed = int(frame_index) - track.start_frame
            track.frames.append(_FrameRecord(elapsed, inside, track.covered_last, fog, averaging))

    def _begin(self, track: _EventTrack, cell_m: float) -> None:
        """The cells an event can concern and the world just before it."""
        assert self._anchor_xy is not None
        event = track.event
        world = self.truth_provider(max(0.0, event.at - BEFORE_EVENT_S))
        state = world.object_state(event.target)
        if state is None:
            xy = np.zeros((0, 2))
            top_m = math.nan
        else:
            corners = state.footprint_corners_xy()
            if event.to is not None:
                shift = np.asarray(event.to, dtype=np.float64) - np.asarray(state.center_xy)
                corners = np.concatenate([corners, corners + shift])
            lo = np.floor((corners.min(axis=0) - self._anchor_xy) / cell_m).astype(int) - 1
            hi = np.ceil((corners.max(axis=0) - self._anchor_xy) / cell_m).astype(int) + 1
            gx, gy = np.meshgrid(
                np.arange(lo[0], hi[0] + 1), np.arange(lo[1], hi[1] + 1), indexing="ij"
            )
            xy = self._anchor_xy + cell_m * np.stack([gx.ravel(), gy.ravel()], axis=-1)
            top_m = state.top_m
        without = _without(world, event.target)
        n = xy.shape[0]
        track.cells = _Cells(
            xy=xy,
            floor_before_m=without.support_height_m(xy),
            top_m=top_m,
            covered_at_event=state.contains(xy) if state is not None else np.zeros(0, bool),
        )
        for name in ("seen_fog", "seen_averaging", "swept", "covered_last", "others"):
            setattr(track, name, np.zeros(n, dtype=bool))
        track.floor_m = track.cells.floor_before_m  # until the start frame says otherwise
        track.world = world

    def _view(
        self,
        top_m: float,
        floor_m: NDArray[np.float64],
        idx: NDArray[np.int64],
        inside: NDArray[np.bool_],
        types: NDArray[np.integer] | None,
        heights_m: NDArray[np.floating],
    ) -> _MapView:
        """One map at an event's cells, given the object's top and the floor without it [m].

        ``types`` None: every finite height is a floor observation (the averaging baseline).
        """
        h = np.full(inside.shape, np.nan)
        h[inside] = heights_m[idx[inside, 0], idx[inside, 1]]
        known = np.isfinite(h)
        shows = known & (h > 0.5 * (floor_m + top_m))
        floor_again = known & (np.abs(h - floor_m) <= self.tolerance_m)
        intermediate = known & (h > floor_m + self.tolerance_m) & (h < top_m - self.tolerance_m)
        if types is not None:
            t = np.full(inside.shape, CellType.UNKNOWN, dtype=np.int8)
            t[inside] = types[idx[inside, 0], idx[inside, 1]]
            is_floor = t == CellType.FLOOR
            shows = (t == CellType.OBSTACLE) | (is_floor & shows)
            floor_again &= is_floor
            intermediate &= is_floor
            known = t != CellType.UNKNOWN
        return _MapView(shows, floor_again, intermediate, known)

    def _follow_world(self, track: _EventTrack, time_s: float, cell_m: float) -> None:
        """Add where the object and the others are (and slid) since the last followed frame."""
        now = self.truth_provider(time_s)
        before = track.world
        cells = track.cells
        assert before is not None and cells is not None
        first = track.start_frame is not None and not track.frames
        if not first and now.objects == before.objects:
            return  # nothing moved: the cells are already counted
        name = track.event.target
        floor_m = _without(now, name).support_height_m(cells.xy)
        if first:
            track.floor_m = floor_m
        track.others |= np.abs(floor_m - track.floor_m) > FLOOR_CHANGE_M
        for obj in now.objects:
            was = before.object_state(obj.name)
            if obj.name == name:
                track.swept |= _swept_by(was, obj, cells.xy, 0.0)
                continue
            margin_m = 0.5 * cell_m * (abs(math.cos(obj.yaw_rad)) + abs(math.sin(obj.yaw_rad)))
            rises = obj.top_m > track.floor_m + self.tolerance_m
            track.others |= _swept_by(was, obj, cells.xy, margin_m) & rises
        mine = now.object_state(name)
        track.covered_last = (
            mine.contains(cells.xy, cell_m) if mine is not None else np.zeros(len(cells.xy), bool)
        )
        track.world = now

    def results(self) -> tuple[EventResult, ...]:
        """One result per event, in the scenario's order."""
        return tuple(self._result(track) for track in self._tracks)

    def _result(self, track: _EventTrack) -> EventResult:
        event = track.event
        cells = track.cells
        if cells is None:  # no frame at all
            footprint = excluded = at_event = np.zeros(0, dtype=bool)
            top_m = math.nan
        else:
            rises = cells.top_m > track.floor_m + 2.0 * self.tolerance_m
            own = (cells.covered_at_event | track.swept) & ~track.covered_last & rises
            footprint = own & ~track.others
            excluded = own & track.others
            at_event = cells.covered_at_event & ~track.others & rises
            top_m = cells.top_m
        seen = EventSeen(
            fog=bool(np.any(track.seen_fog & at_event)),
            averaging=bool(np.any(track.seen_averaging & at_event)),
        )
        fog = _figures(track.frames, footprint, "fog", self.floor_fraction)
        averaging = _figures(track.frames, footprint, "averaging", self.floor_fraction)
        return EventResult(
            object=event.target,
            kind="remove" if event.remove is not None else "move",
            at_s=event.at,
            start_frame=track.start_frame,
            footprint_cells=int(footprint.sum()),
            excluded_cells=int(excluded.sum()),
            old_top_mm=mm(top_m) if footprint.any() else None,
            seen=seen,
            cleared_frames=EventFrames(
                fog=fog.cleared if seen.fog else None,
                averaging=averaging.cleared if seen.averaging else None,
            ),
            floor_again_frames=EventFrames(
                fog=fog.floor_again if seen.fog else None,
                averaging=averaging.floor_again if seen.averaging else None,
            ),
            intermediate_floor_cells=(
                IntermediateFloorCells(fog=fog.intermediate, averaging=averaging.intermediate)
                if event.kind == "move"
                else UNSET
            ),
        )


@dataclass(frozen=True)
class _Figures:
    """One map's figures of one event (frames from the start frame, None = never)."""

    cleared: int | None
    floor_again: int | None
    intermediate: MaxFinal


def _figures(
    frames: Sequence[_FrameRecord], footprint: NDArray[np.bool_], map_name: str, fraction: float
) -> _Figures:
    """``cleared``, ``floor again`` and the intermediate count of one map over the footprint."""
    cleared: int | None = None
    floor_again: int | None = None
    counts = [0]
    for record in frames:
        view: _MapView = getattr(record, map_name)
        cells = footprint & record.inside
        counts.append(int(np.count_nonzero(view.intermediate & cells & ~record.object_on)))
        if not cells.any() or (footprint & record.object_on).any():
            continue
        if cleared is None and not view.shows_object[cells].any():
            cleared = record.elapsed
        known = cells & view.known
        enough = np.count_nonzero(known) >= MIN_KNOWN_FRACTION * np.count_nonzero(cells)
        if floor_again is None and enough and view.floor_again[known].mean() >= fraction:
            floor_again = record.elapsed
    return _Figures(cleared, floor_again, MaxFinal(max=max(counts), final=counts[-1]))


def _without(world: SceneTruth, name: str) -> SceneTruth:
    """The world with the named object taken away."""
    return dataclasses.replace(world, objects=tuple(o for o in world.objects if o.name != name))


def _swept_by(
    was: ObjectState | None, now: ObjectState, xy: NDArray[np.float64], margin_m: float
) -> NDArray[np.bool_]:
    """Points (N, 2) [m] the object covers, grown by ``margin_m``, sliding from ``was`` to ``now``.

    Events slide objects in a straight line without turning them; without ``was``, or when the
    yaw changed, only ``now`` counts.

    In the object's frame the point ``p`` is covered at slide fraction ``s`` ∈ [0, 1] when
    ``|p - s·d| <= half size + margin`` on both axes (``d`` the slide); each axis allows an
    interval of ``s``, and the point is swept when the intervals and [0, 1] overlap.
    """
    if was is None or was.yaw_rad != now.yaw_rad:
        return now.contains(xy, margin_m)
    c, s = math.cos(now.yaw_rad), math.sin(now.yaw_rad)
    to_local = np.array([[c, -s], [s, c]])  # row vector @ this = rotation by -yaw
    p = (xy - np.asarray(was.center_xy)) @ to_local
    d = (np.asarray(now.center_xy) - np.asarray(was.center_xy)) @ to_local
    low = np.zeros(len(xy))
    high = np.ones(len(xy))
    for axis in range(2):
        half = 0.5 * now.size[axis] + margin_m
        if abs(d[axis]) < 1e-12:
            outside = np.abs(p[:, axis]) > half
            high = np.where(outside, -1.0, high)
            continue
        a = (p[:, axis] - half) / d[axis]
        b = (p[:, axis] + half) / d[axis]
        low = np.maximum(low, np.minimum(a, b))
        high = np.minimum(high, np.maximum(a, b))
    return low <= high


def _grid_indices(
    points_xy: NDArray[np.float64],
    origin_center_xy: NDArray[np.float64],
    cell_m: float,
    shape: tuple[int, ...],
) -> tuple[NDArray[np.int64], NDArray[np.bool_]]:
    """Grid indices (N, 2) of world cell centres and whether each lies inside the grid."""
    idx = np.rint((points_xy - origin_center_xy) / cell_m).astype(np.int64).reshape(-1, 2)
    inside = (idx[:, 0] >= 0) & (idx[:, 0] < shape[0]) & (idx[:, 1] >= 0) & (idx[:, 1] < shape[1])
    return idx, inside
