"""Score mapper outputs against the scene's ground truth (Table I, cell labels, events).

All maps here are 2-D arrays over cells in x, y (index ``[ix, iy]``), heights in metres in the
world frame (z up, ground at 0), NaN = no value. Labels use ``mapper.CellType`` values
(UNKNOWN=0, FLOOR=1, OBSTACLE=2). Truth comes as a ``GroundTruthGrid`` rasterised on the same
cells (``floor_m``, ``obstacle_top_m``, ``labels``, ``surface_id``, ``surface_names``,
``interior``).

The mapper's grids follow the robot and scroll by whole cells, so a run is scored on a
:class:`WorldArchive`: a world-fixed lattice of the mapper's cells that keeps, for every cell
that was ever inside the map, the last FOG and averaging-baseline value it had there.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mapper import CellType

TruthProvider = Callable[[float], Any]
"""Ground truth of the world at a time [s]: returns a ``SceneTruth`` (with ``rasterize``)."""


def _mm(value_m: float) -> float | None:
    """Metres → millimetres rounded to 0.01 mm; None for NaN (JSON null)."""
    value = float(value_m)
    return None if not np.isfinite(value) else round(value * 1000.0, 2)


def _surface_true_height_m(truth: Any, index: int, name: str) -> float:
    """True top height [m] of a walkable surface: ``surface_heights_m`` or the cells' median."""
    for holder in (truth, getattr(truth, "scene", None)):
        heights = getattr(holder, "surface_heights_m", None)
        if isinstance(heights, Mapping) and name in heights:
            return float(heights[name])
    values = truth.floor_m[(truth.surface_id == index) & np.isfinite(truth.floor_m)]
    return float(np.median(values)) if values.size else float("nan")


def table1_rows(truth: Any, heights_m: NDArray[np.floating], use: NDArray[np.bool_]) -> list[dict]:
    """Table I of the paper: estimated vs true height of every walkable surface and the ground.

    Args:
        truth: ``GroundTruthGrid`` on the cells of ``heights_m``.
        heights_m: (nx, ny) estimated floor height per cell [m], NaN = none.
        use: (nx, ny) cells whose estimate counts (e.g. FOG cells labelled FLOOR).

    Returns:
        One row per surface in ``truth.surface_names``: ``name``, ``ground_truth_mm``,
        ``estimated_mm`` (median over the surface's interior cells — border cells left out — that
        have an estimate), ``error_mm`` (estimated − truth), ``cells`` (how many were used),
        ``surface_cells`` (interior cells of the surface in the scored area). Estimates are
        null when no cell was used.
    """
    heights = np.asarray(heights_m, dtype=np.float64)
    usable = np.asarray(use, dtype=bool) & np.isfinite(heights)
    rows = []
    for index, name in enumerate(truth.surface_names):
        surface = np.asarray(truth.interior, dtype=bool) & (truth.surface_id == index)
        cells = surface & usable
        true_m = _surface_true_height_m(truth, index, name)
        estimate_m = float(np.median(heights[cells])) if cells.any() else float("nan")
        rows.append(
            {
                "name": str(name),
                "ground_truth_mm": _mm(true_m),
                "estimated_mm": _mm(estimate_m),
                "error_mm": _mm(estimate_m - true_m),
                "cells": int(cells.sum()),
                "surface_cells": int(surface.sum()),
            }
        )
    return rows


def cell_scores(
    truth: Any,
    fog_types: NDArray[np.integer],
    fog_heights_m: NDArray[np.floating],
    region: NDArray[np.bool_],
    cell_z_m: float,
) -> dict:
    """Cell labelling and height errors of a FOG against the truth.

    Args:
        truth: ``GroundTruthGrid`` on the same cells.
        fog_types: (nx, ny) CellType values.
        fog_heights_m: (nx, ny) FOG height [m] (floor height or coarse obstacle top), NaN = none.
        region: (nx, ny) cells to score (the cells that were ever inside the map).
        cell_z_m: Vertical cell size [m] of the 3-D grid ("within one cell" of an obstacle top).

    Returns:
        Dict with ``region`` (cells scored), ``seen`` (region cells the FOG labels floor or
        obstacle), ``correct`` (seen cells labelled as the truth), ``accuracy`` (correct / seen),
        the same over interior cells only (``interior_seen``, ``interior_accuracy``),
        ``confusion`` (truth label → FOG label → count, over the whole region, unknown
        included), ``obstacle_height`` (FOG obstacle cells over true obstacles: absolute error
        stats [mm] and the fraction within one cell) and ``floor_height`` (FOG floor cells over
        true floor: absolute error stats [mm]).
    """
    types = np.asarray(fog_types)
    heights = np.asarray(fog_heights_m, dtype=np.float64)
    region = np.asarray(region, dtype=bool)
    labels = np.asarray(truth.labels)
    interior = np.asarray(truth.interior, dtype=bool)
    known = region & (types != CellType.UNKNOWN)
    right = known & (types == labels)
    inner = known & interior

    confusion = {
        CellType(t).name.lower(): {
            CellType(e).name.lower(): int((region & (labels == t) & (types == e)).sum())
            for e in CellType
        }
        for t in (CellType.FLOOR, CellType.OBSTACLE)
    }

    both_obstacle = known & (labels == CellType.OBSTACLE) & (types == CellType.OBSTACLE)
    obstacle_error = np.abs(heights[both_obstacle] - truth.obstacle_top_m[both_obstacle])
    obstacle_error = obstacle_error[np.isfinite(obstacle_error)]
    obstacle = error_stats_mm(obstacle_error)
    obstacle["within_one_cell_fraction"] = _fraction(
        int((obstacle_error <= cell_z_m + 1e-9).sum()), int(obstacle_error.size)
    )
    return {
        "region": int(region.sum()),
        "seen": int(known.sum()),
        "correct": int(right.sum()),
        "accuracy": _fraction(int(right.sum()), int(known.sum())),
        "interior_seen": int(inner.sum()),
        "interior_accuracy": _fraction(int((inner & right).sum()), int(inner.sum())),
        "confusion": confusion,
        "obstacle_height": obstacle,
        "floor_height": floor_height_errors(truth, heights, known & (types == CellType.FLOOR)),
    }


def _fraction(num: int, den: int) -> float | None:
    return None if den == 0 else round(num / den, 5)


def error_stats_mm(abs_errors_m: NDArray[np.floating]) -> dict:
    """Statistics of absolute errors [m] in millimetres.

    Returns:
        ``cells``, ``median_abs_error_mm``, ``p95_abs_error_mm``, ``max_abs_error_mm`` (null
        when there are no finite errors).
    """
    e = np.asarray(abs_errors_m, dtype=np.float64)
    e = e[np.isfinite(e)]
    if not e.size:
        return {
            "cells": 0,
            "median_abs_error_mm": None,
            "p95_abs_error_mm": None,
            "max_abs_error_mm": None,
        }
    return {
        "cells": int(e.size),
        "median_abs_error_mm": _mm(np.median(e)),
        "p95_abs_error_mm": _mm(np.percentile(e, 95)),
        "max_abs_error_mm": _mm(e.max()),
    }


def floor_height_errors(
    truth: Any, heights_m: NDArray[np.floating], use: NDArray[np.bool_]
) -> dict:
    """Absolute floor-height error stats over ``use`` cells that are true floor."""
    cells = np.asarray(use, dtype=bool) & (np.asarray(truth.labels) == CellType.FLOOR)
    return error_stats_mm(np.abs(np.asarray(heights_m)[cells] - truth.floor_m[cells]))


class WorldArchive:
    """World-fixed lattice of the mapper's cells: the last FOG / baseline value of each cell.

    The lattice is anchored at the first grid's cell centres; the mapper scrolls by whole cells,
    so every later grid lies on it. Storage grows as the robot walks (bounding box of all grids).
    """

    def __init__(self, cell_m: float) -> None:
        self.cell_m = float(cell_m)
        self._anchor_xy: NDArray[np.float64] | None = None
        self._lo = np.zeros(2, dtype=np.int64)  # lattice index of array cell [0, 0]
        self.fog_types = np.zeros((0, 0), dtype=np.int8)
        self.fog_heights_m = np.zeros((0, 0))
        self.baseline_heights_m = np.zeros((0, 0))
        self.visited = np.zeros((0, 0), dtype=bool)

    def lattice_index(self, points_xy: NDArray[np.floating]) -> NDArray[np.int64]:
        """Lattice index (…, 2) of world points (…, 2) [m] (nearest cell centre)."""
        assert self._anchor_xy is not None
        return np.rint((np.asarray(points_xy) - self._anchor_xy) / self.cell_m).astype(np.int64)

    def _grow(self, lo: NDArray[np.int64], hi: NDArray[np.int64]) -> None:
        new_lo = np.minimum(self._lo, lo) if self.visited.size else lo
        old_hi = self._lo + np.array(self.visited.shape)
        new_hi = np.maximum(old_hi, hi) if self.visited.size else hi
        if (
            self.visited.size
            and np.array_equal(new_lo, self._lo)
            and np.array_equal(new_hi, old_hi)
        ):
            return
        shape = tuple(int(v) for v in new_hi - new_lo)
        before = self._lo - new_lo
        arrays = []
        for old, fill in (
            (self.fog_types, CellType.UNKNOWN),
            (self.fog_heights_m, np.nan),
            (self.baseline_heights_m, np.nan),
            (self.visited, False),
        ):
            grown = np.full(shape, fill, dtype=old.dtype)
            if old.size:
                grown[
                    before[0] : before[0] + old.shape[0], before[1] : before[1] + old.shape[1]
                ] = old
            arrays.append(grown)
        self.fog_types, self.fog_heights_m, self.baseline_heights_m, self.visited = arrays
        self._lo = new_lo

    def store(
        self,
        cell_centers_xy: NDArray[np.floating],
        fog_types: NDArray[np.integer],
        fog_heights_m: NDArray[np.floating],
        baseline_heights_m: NDArray[np.floating],
    ) -> None:
        """Copy the current maps (nx, ny) with their cell centres (nx, ny, 2) into the archive."""
        centers = np.asarray(cell_centers_xy, dtype=np.float64)
        if self._anchor_xy is None:
            self._anchor_xy = centers[0, 0].copy()
        corner = self.lattice_index(centers[0, 0])
        nx, ny = centers.shape[:2]
        self._grow(corner, corner + np.array([nx, ny]))
        ox, oy = (int(v) for v in corner - self._lo)
        sl = (slice(ox, ox + nx), slice(oy, oy + ny))
        self.fog_types[sl] = fog_types
        self.fog_heights_m[sl] = fog_heights_m
        self.baseline_heights_m[sl] = baseline_heights_m
        self.visited[sl] = True

    def cell_centers_xy(self) -> NDArray[np.float64]:
        """(nx, ny, 2) world centres [m] of the archive's cells."""
        assert self._anchor_xy is not None
        ix = np.arange(self.visited.shape[0]) + self._lo[0]
        iy = np.arange(self.visited.shape[1]) + self._lo[1]
        gx, gy = np.meshgrid(ix, iy, indexing="ij")
        return self._anchor_xy + self.cell_m * np.stack([gx, gy], axis=-1)


def obstacle_objects(
    truth: Any,
    centers: NDArray[np.float64],
    fog_types: NDArray[np.integer],
    fog_heights_m: NDArray[np.floating],
    region: NDArray[np.bool_],
    cell_m: float,
) -> list[dict]:
    """Per obstacle object (not walkable, or hanging): how much of it the FOG marks obstacle.

    Args:
        truth: ``SceneTruth`` (its ``objects``).
        centers: (nx, ny, 2) cell centres [m].
        fog_types: (nx, ny) CellType values.
        fog_heights_m: (nx, ny) FOG heights [m].
        region: (nx, ny) cells to look at.
        cell_m: Cell side [m].

    Returns:
        One dict per object: ``name``, ``cells`` (cells whose centre lies inside its footprint,
        0.5 cell in from the edge), ``seen`` (of those, labelled floor or obstacle),
        ``obstacle_fraction`` (of the seen ones, labelled obstacle; null if none seen),
        ``top_mm`` (true top), ``median_top_error_mm`` (FOG obstacle height − true top).
    """
    rows = []
    for obj in getattr(truth, "objects", ()):
        if obj.walkable and obj.base_m <= 1e-3:
            continue
        inside = obj.contains(centers, -0.5 * cell_m)
        cells = inside & region
        types = np.asarray(fog_types)[cells]
        seen = types != CellType.UNKNOWN
        obstacle = types == CellType.OBSTACLE
        errors = np.asarray(fog_heights_m)[cells][obstacle] - obj.top_m
        rows.append(
            {
                "name": obj.name,
                "cells": int(cells.sum()),
                "seen": int(seen.sum()),
                "obstacle_fraction": _fraction(int(obstacle.sum()), int(seen.sum())),
                "top_mm": _mm(obj.top_m),
                "median_top_error_mm": _mm(np.median(errors)) if errors.size else None,
            }
        )
    return rows


def score_archive(archive: WorldArchive, truth: Any, cell_z_m: float) -> dict:
    """Table I (FOG and averaging baseline) and cell scores of an archive against a truth.

    Args:
        archive: The run's archive.
        truth: ``SceneTruth`` of the world state to score against (``rasterize`` is called on the
            archive's cells).
        cell_z_m: Vertical cell size of the 3-D grid [m].

    Returns:
        ``{"table1": {"fog": rows, "averaging": rows}, "cells": {"fog": cell_scores(...),
        "obstacles": obstacle_objects(...), "averaging": {"seen", "floor_height"}}}`` (the
        baseline has no cell labels).
    """
    centers = archive.cell_centers_xy()
    grid = truth.rasterize(centers, archive.cell_m)
    visited = archive.visited
    fog_rows = table1_rows(
        grid, archive.fog_heights_m, visited & (archive.fog_types == CellType.FLOOR)
    )
    avg_rows = table1_rows(grid, archive.baseline_heights_m, visited)
    return {
        "table1": {"fog": fog_rows, "averaging": avg_rows},
        "cells": {
            "fog": cell_scores(grid, archive.fog_types, archive.fog_heights_m, visited, cell_z_m),
            "obstacles": obstacle_objects(
                truth, centers, archive.fog_types, archive.fog_heights_m, visited, archive.cell_m
            ),
            "averaging": {
                "seen": int((visited & np.isfinite(archive.baseline_heights_m)).sum()),
                "floor_height": floor_height_errors(grid, archive.baseline_heights_m, visited),
            },
        },
    }


def _event_get(event: Any, key: str) -> Any:
    if isinstance(event, Mapping):
        return event.get(key)
    return getattr(event, key, None)


@dataclass
class _EventState:
    """Bookkeeping of one remove/move event."""

    name: str
    kind: str  # "remove" | "move"
    at_s: float
    start_frame: int | None = None
    footprint_xy: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 2)))
    footprint_floor_m: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    footprint_old_m: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    region_xy: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 2)))
    region_floor_m: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    top_m: float = float("nan")
    cleared: dict[str, int | None] = field(default_factory=lambda: {"fog": None, "averaging": None})
    floor_again: dict[str, int | None] = field(
        default_factory=lambda: {"fog": None, "averaging": None}
    )
    intermediate_max: dict[str, int] = field(default_factory=lambda: {"fog": 0, "averaging": 0})
    intermediate_final: dict[str, int] = field(default_factory=lambda: {"fog": 0, "averaging": 0})
    footprint_cells: int = 0


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
    """

    def __init__(
        self,
        events: Sequence[Any],
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
        self.states: list[_EventState] = []
        for event in events:
            at = float(_event_get(event, "at"))
            kind, target = _event_get(event, "kind"), _event_get(event, "target")
            if kind is None:  # the TOML spelling: {"remove": name} or {"move": name, ...}
                kind = "remove" if _event_get(event, "remove") else "move"
                target = _event_get(event, kind)
            if kind in ("remove", "move") and target:
                self.states.append(_EventState(str(target), str(kind), at))

    @property
    def active(self) -> bool:
        """True while some event still needs per-frame maps."""
        return bool(self.states)

    def _start(
        self, state: _EventState, frame_index: int, centers: NDArray[np.float64], cell_m: float
    ) -> None:
        before = self.truth_provider(max(0.0, state.at_s - 1e-6)).rasterize(centers, cell_m)
        after = self.truth_provider(self.end_time_s).rasterize(centers, cell_m)
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
        state.footprint_xy = centers[footprint]
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
                state.region_xy = centers[region]
                state.region_floor_m = after.floor_m[region]

    def update(
        self,
        frame_index: int,
        time_s: float,
        centers: NDArray[np.float64],
        cell_m: float,
        maps: Mapping[str, tuple[NDArray[Any] | None, NDArray[np.floating]]],
    ) -> None:
        """Check one frame's maps.

        Args:
            frame_index: Frame number.
            time_s: Frame time [s].
            centers: (nx, ny, 2) current grid cell centres [m].
            cell_m: Cell size [m].
            maps: ``{"fog": (types, heights_m), "averaging": (None, heights_m)}``; types None
                means every finite height is a floor observation.
        """
        origin = centers[0, 0]
        shape = centers.shape[:2]
        for state in self.states:
            if state.start_frame is None:
                if time_s + 1e-9 < state.at_s:
                    continue
                self._start(state, frame_index, centers, cell_m)
            elapsed = frame_index - state.start_frame
            for key, (types, heights) in maps.items():
                idx, inside = _indices(state.footprint_xy, origin, cell_m, shape)
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
                    if state.cleared[key] is None and not shows_old.any():
                        state.cleared[key] = elapsed
                    if state.floor_again[key] is None and (is_floor.mean() >= self.floor_fraction):
                        state.floor_again[key] = elapsed
                if state.kind == "move" and state.region_xy.size:
                    ridx, rin = _indices(state.region_xy, origin, cell_m, shape)
                    h = heights[ridx[rin, 0], ridx[rin, 1]]
                    floor = state.region_floor_m[rin]
                    mid = np.isfinite(h) & (h > floor + self.tolerance_m)
                    mid &= h < state.top_m - self.tolerance_m
                    if types is not None:
                        mid &= types[ridx[rin, 0], ridx[rin, 1]] == CellType.FLOOR
                    count = int(mid.sum())
                    state.intermediate_final[key] = count
                    state.intermediate_max[key] = max(state.intermediate_max[key], count)

    def results(self) -> list[dict]:
        """One dict per event.

        Keys: ``object``, ``kind``, ``at_s``, ``start_frame`` (first frame at or after the
        event), ``footprint_cells``, ``old_top_mm``, ``fog_frames`` / ``averaging_frames`` (frames
        from ``start_frame`` until the old footprint is cleared; null = never),
        ``fog_frames_to_floor`` / ``averaging_frames_to_floor`` (until ``floor_fraction`` of it is
        floor at the true height; null = never) and, for moves, ``intermediate_floor_cells``
        (``{"fog"|"averaging": {"max", "final"}}``).
        """
        out = []
        for s in self.states:
            row: dict[str, Any] = {
                "object": s.name,
                "kind": s.kind,
                "at_s": s.at_s,
                "start_frame": s.start_frame,
                "footprint_cells": s.footprint_cells,
                "old_top_mm": _mm(s.top_m),
            }
            for key in ("fog", "averaging"):
                row[f"{key}_frames"] = s.cleared[key]
            for key in ("fog", "averaging"):
                row[f"{key}_frames_to_floor"] = s.floor_again[key]
            if s.kind == "move":
                row["intermediate_floor_cells"] = {
                    key: {"max": s.intermediate_max[key], "final": s.intermediate_final[key]}
                    for key in s.intermediate_max
                }
            out.append(row)
        return out


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
