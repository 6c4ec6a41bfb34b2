"""Event scores: per removed or moved object, how many frames each map takes to forget it.

Maps are 2-D arrays over the current grid's cells (index ``[ix, iy]``), heights in metres in
the world frame, NaN = none; labels are ``mapper.CellType`` values.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from msgspec import UNSET
from numpy.typing import NDArray

from fogsim.config import Event
from fogsim.eval.report.schema import EventResult, IntermediateFloorCells, MaxFinal
from fogsim.eval.rounding import mm
from fogsim.world.truth import SceneTruth
from mapper import CellType

TruthProvider = Callable[[float], SceneTruth]
"""Ground truth of the world at a time [s] (``Simulation.truth_at``, ``Recording.truth_at``)."""

EventKind = Literal["remove", "move"]


@dataclass
class _MapProgress:
    """What one map has shown of an event so far (frame counts from the event's start frame)."""

    cleared: int | None = None
    floor_again: int | None = None
    intermediate_max: int = 0
    intermediate_final: int = 0

    def intermediate(self) -> MaxFinal:
        return MaxFinal(max=self.intermediate_max, final=self.intermediate_final)


def _empty_xy() -> NDArray[np.float64]:
    return np.zeros((0, 2))


def _empty() -> NDArray[np.float64]:
    return np.zeros(0)


@dataclass
class _EventState:
    """Bookkeeping of one remove/move event; world points [m], heights [m]."""

    name: str
    kind: EventKind
    at_s: float
    start_frame: int | None = None
    footprint_xy: NDArray[np.float64] = field(default_factory=_empty_xy)
    footprint_floor_m: NDArray[np.float64] = field(default_factory=_empty)
    footprint_old_m: NDArray[np.float64] = field(default_factory=_empty)
    region_xy: NDArray[np.float64] = field(default_factory=_empty_xy)
    region_floor_m: NDArray[np.float64] = field(default_factory=_empty)
    top_m: float = float("nan")
    footprint_cells: int = 0
    fog: _MapProgress = field(default_factory=_MapProgress)
    averaging: _MapProgress = field(default_factory=_MapProgress)


class EventTracker:
    """Measures, per removed or moved object, how fast each map forgets its old footprint.

    At the first frame at or after an event's time, the truth just before the event and at the
    end of the run are rasterised on the current grid; the object's *old footprint* is the cells
    that are floor at the end but had a different label or height before. From then on, every
    frame checks both maps over the footprint cells still inside the grid:

    * *cleared*: no cell shows the old object any more — no FOG obstacle, and no height closer
      to the old top than to the true floor (unknown cells are fine: the 3-D grid may erase a
      cell whose floor the camera cannot see);
    * *floor again*: at least ``floor_fraction`` of the cells are floor within ``tolerance_m`` of
      the true floor height.

    For moved objects it also counts *intermediate* floor cells in the swept area (bounding box
    of old and new footprint, cells that are floor at the end): floor heights more than
    ``tolerance_m`` above the true floor and below the old top by more than ``tolerance_m``.

    Args:
        events: The scenario's events.
        truth_provider: Ground truth at a time [s].
        end_time_s: Time of the run's last frame [s] (the world the footprint is checked for).
        tolerance_m: Height tolerance of "floor again" [m] (the pipeline's
            ``event_tolerance_m``, 1 cm by default).
        floor_fraction: Share of the footprint that must be floor again (0.9).
    """

    def __init__(
        self,
        events: Sequence[Event],
        truth_provider: TruthProvider,
        end_time_s: float,
        *,
        tolerance_m: float = 0.01,
        floor_fraction: float = 0.9,
    ) -> None:
        self.truth_provider = truth_provider
        self.end_time_s = float(end_time_s)
        self.tolerance_m = float(tolerance_m)
        self.floor_fraction = float(floor_fraction)
        self.states: list[_EventState] = [
            _EventState(event.target, "remove" if event.remove is not None else "move", event.at)
            for event in events
        ]

    def _start(
        self,
        state: _EventState,
        frame_index: int,
        centers_xy: NDArray[np.float64],
        cell_m: float,
    ) -> None:
        before = self.truth_provider(max(0.0, state.at_s - 1e-6)).rasterize(centers_xy, cell_m)
        after = self.truth_provider(self.end_time_s).rasterize(centers_xy, cell_m)
        old_top = np.where(
            np.isfinite(before.obstacle_top_m), before.obstacle_top_m, before.floor_m
        )
        after_floor = after.labels == CellType.FLOOR
        changed = (before.labels != after.labels) | (
            np.abs(np.nan_to_num(before.floor_m, nan=-1e3) - np.nan_to_num(after.floor_m, nan=-1e3))
            > 1e-3
        )
        footprint = after_floor & changed & (old_top > after.floor_m + 2 * self.tolerance_m)
        state.start_frame = frame_index
        state.footprint_xy = centers_xy[footprint]
        state.footprint_floor_m = after.floor_m[footprint]
        state.footprint_old_m = old_top[footprint]
        state.footprint_cells = int(footprint.sum())
        state.top_m = float(np.max(old_top[footprint])) if footprint.any() else float("nan")
        if state.kind == "move":
            # Swept area: bounding box of the old footprint and the new object's cells.
            new_object = (after.labels != before.labels) & ~after_floor
            new_object |= (after.floor_m > before.floor_m + 2 * self.tolerance_m) & after_floor
            both = footprint | new_object
            if both.any():
                ix, iy = np.nonzero(both)
                box = np.zeros_like(both)
                box[ix.min() : ix.max() + 1, iy.min() : iy.max() + 1] = True
                region = box & after_floor & np.isfinite(after.floor_m)
                state.region_xy = centers_xy[region]
                state.region_floor_m = after.floor_m[region]

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
        """Check one frame's maps.

        Args:
            frame_index: Frame number.
            time_s: Frame time [s].
            centers_xy: (nx, ny, 2) current grid cell centres [m].
            cell_m: Cell size [m].
            fog_types: (nx, ny) FOG CellType values.
            fog_heights_m: (nx, ny) FOG heights [m].
            baseline_heights_m: (nx, ny) averaging-baseline heights [m]; every finite one is a
                floor observation.
        """
        origin = centers_xy[0, 0]
        shape = centers_xy.shape[:2]
        for state in self.states:
            if state.start_frame is None:
                if time_s + 1e-9 < state.at_s:
                    continue
                self._start(state, int(frame_index), centers_xy, cell_m)
            elapsed = int(frame_index) - state.start_frame
            self._check(state, state.fog, elapsed, origin, cell_m, shape, fog_types, fog_heights_m)
            self._check(
                state, state.averaging, elapsed, origin, cell_m, shape, None, baseline_heights_m
            )

    def _check(
        self,
        state: _EventState,
        progress: _MapProgress,
        elapsed: int,
        origin_xy: NDArray[np.float64],
        cell_m: float,
        shape: tuple[int, int],
        types: NDArray[np.integer] | None,
        heights: NDArray[np.floating],
    ) -> None:
        """One map at one frame; ``types`` None: every finite height is a floor observation."""
        idx, inside = _indices(state.footprint_xy, origin_xy, cell_m, shape)
        if inside.any():
            h = heights[idx[inside, 0], idx[inside, 1]]
            floor = state.footprint_floor_m[inside]
            middle = 0.5 * (floor + state.footprint_old_m[inside])
            shows_old = np.isfinite(h) & (h > middle)
            is_floor = np.isfinite(h) & (np.abs(h - floor) <= self.tolerance_m)
            if types is not None:
                t = types[idx[inside, 0], idx[inside, 1]]
                shows_old = (t == CellType.OBSTACLE) | ((t == CellType.FLOOR) & shows_old)
                is_floor &= t == CellType.FLOOR
            if progress.cleared is None and not shows_old.any():
                progress.cleared = elapsed
            if progress.floor_again is None and (is_floor.mean() >= self.floor_fraction):
                progress.floor_again = elapsed
        if state.kind == "move" and state.region_xy.size:
            ridx, rin = _indices(state.region_xy, origin_xy, cell_m, shape)
            h = heights[ridx[rin, 0], ridx[rin, 1]]
            floor = state.region_floor_m[rin]
            mid = np.isfinite(h) & (h > floor + self.tolerance_m)
            mid &= h < state.top_m - self.tolerance_m
            if types is not None:
                mid &= types[ridx[rin, 0], ridx[rin, 1]] == CellType.FLOOR
            count = int(mid.sum())
            progress.intermediate_final = count
            progress.intermediate_max = max(progress.intermediate_max, count)

    def results(self) -> tuple[EventResult, ...]:
        """One result per event, in the scenario's order."""
        return tuple(
            EventResult(
                object=s.name,
                kind=s.kind,
                at_s=s.at_s,
                start_frame=s.start_frame,
                footprint_cells=s.footprint_cells,
                old_top_mm=mm(s.top_m),
                fog_frames=s.fog.cleared,
                averaging_frames=s.averaging.cleared,
                fog_frames_to_floor=s.fog.floor_again,
                averaging_frames_to_floor=s.averaging.floor_again,
                intermediate_floor_cells=(
                    IntermediateFloorCells(
                        fog=s.fog.intermediate(), averaging=s.averaging.intermediate()
                    )
                    if s.kind == "move"
                    else UNSET
                ),
            )
            for s in self.states
        )


def _indices(
    points_xy: NDArray[np.float64],
    origin_center_xy: NDArray[np.float64],
    cell_m: float,
    shape: tuple[int, int],
) -> tuple[NDArray[np.int64], NDArray[np.bool_]]:
    """Grid indices (N, 2) of world cell centres and whether each lies inside the grid."""
    idx = np.rint((points_xy - origin_center_xy) / cell_m).astype(np.int64).reshape(-1, 2)
    inside = (idx[:, 0] >= 0) & (idx[:, 0] < shape[0]) & (idx[:, 1] >= 0) & (idx[:, 1] < shape[1])
    return idx, inside
