"""Ground truth of a scene at one instant, by the paper's definitions, on a grid of cells.

:class:`SceneTruth` is the world at one time, the objects placed where the event timeline
(:mod:`fogsim.world.timeline`) puts them; :meth:`SceneTruth.rasterize` turns it into the
:class:`GroundTruthGrid` a map is scored against, given :class:`TruthParams` (the robot's foot
and the mapper grid's top).

Definitions (DESIGN.md "Ground truth"; heights in world metres, z up, the ground at 0). Every
object is a box; one whose bottom is at or above ``TruthParams.grid_top_m`` (within
:data:`SAME_HEIGHT_M`) is not there for the truth (the mapper never sees it). At a point
("over" = the point lies in the object's footprint, edges included):

* The *support* is the top of the highest object resting there (its base at most
  :data:`SAME_HEIGHT_M` above the support beneath it: on the ground, or stacked), else the
  ground: where a foot stands. A hanging object (base above the support: a table top, a
  curtain, a bar) is no support.
* The *highest thing* is the object with the highest top over the point, resting or hanging,
  else the ground. Nothing lies above it, so it is what a map's highest surface should show.
* FLOOR when the highest thing is the ground, or a flat top (``surface = "flat"``) with room
  for a foot (:meth:`TruthParams.has_room_for_foot` of the object's x, y size) at or below the
  grid top — walkable or not, resting or hanging: a flat box top or a table top is floor at its
  height (a planner decides whether the step is too high). OBSTACLE otherwise: a rough top, a
  top narrower than a foot (a post), a top above the grid, anything hanging over a floor that is
  no floor itself (a thin curtain, a bar, a curtain reaching above the grid).
* The *ceiling* is the bottom of the lowest hanging object over the support, NaN where there is
  none: under a table its base — the table top is floor, the ceiling below it, and ``ceiling −
  support`` is the clearance to crawl under.

A cell (an axis-aligned square) has its centre's truth when no object outline crosses it. When
one may (the cell lies within half a cell diagonal of an outline), 5 × 5 samples over the cell
(edges inset by 1e-4 cell) decide:

* FLOOR only if every sample is floor at the centre's height (within :data:`SAME_HEIGHT_M`).
  A cell over a step edge holds a riser's face; a cell partly on a box or partly under a
  hanging thing holds an obstacle: both are OBSTACLE. An edge lying exactly on a cell boundary
  crosses neither cell.
* ``obstacle_top_m`` and ``object_id`` of an OBSTACLE cell: the highest top over the samples
  and its object; ``ceiling_m``: the lowest ceiling over the samples.
* ``interior``: every sample has the centre's highest thing — the whole cell lies on one
  surface; Table I leaves the other cells out (DESIGN.md).

Terrains (objects with a ``heightfield``): their top at a point is the height field's surface
there (:meth:`ObjectState.top_at_m`), a support and a highest thing like any top. "Horizontal and
planar" has to allow the terrain's measurement noise and 8-bit steps, so a cell whose centre lies
on a terrain is FLOOR when every sample is floor and the samples' tops span at most
:data:`TERRAIN_STEP_M` (the FOG's own δ: a rise within δ of the floor is floor in eq. 11, one
above it an obstacle), at the centre's height; OBSTACLE where the terrain rises more within the
cell (a step's edge, a slope steeper than δ per cell, a rail) or above the grid top. Every cell
over a terrain is sampled, as its outline and its steps may cross any cell.

Objects thinner than the sample spacing (a quarter cell) can fall between the samples.
``walkable`` only chooses the Table I rows (``surface_names``); it never changes a label.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fogsim.config import Scenario
from fogsim.errors import FogsimError
from fogsim.world.timeline import ObjectState, object_center_at
from fogsim.world.truth_params import TruthParams
from mapper.grid import CellType
from mapper.params import MapperParams

__all__ = [
    "GROUND",
    "SAME_HEIGHT_M",
    "GroundTruthGrid",
    "SceneTruth",
    "TruthLabel",
    "TruthParams",
]

GROUND = "ground"
SAME_HEIGHT_M = 1e-3
"""Two heights this close are one level [m]: an object whose base is this close to the support
beneath it rests on it, a cell whose samples' tops are this close holds no step, a bottom or a
top this close to the grid top is at it. Far above the rounding of scenario heights, far below
any step the mapper resolves (its layers are 40 mm)."""
TERRAIN_STEP_M = MapperParams().delta_m
"""Largest rise within a cell of a terrain that is still floor [m]: the default FOG's δ (eq. 11),
0.05 m (see the module docstring)."""
_INTERIOR_SAMPLES = 5
_DEFAULT_PARAMS = TruthParams()

TruthLabel = CellType  # truth labels are the mapper's cell types (UNKNOWN unused)


@dataclass(frozen=True)
class GroundTruthGrid:
    """Ground truth on a grid of cells (see the module docstring for the rules).

    Attributes:
        floor_m: (nx, ny) true floor height [m], NaN where not floor.
        obstacle_top_m: (nx, ny) top of the highest thing over an obstacle cell [m] (rough
            tops: the highest bump), NaN where the cell is floor.
        labels: (nx, ny) int8, ``TruthLabel`` (= ``mapper.CellType``) FLOOR=1 / OBSTACLE=2.
        surface_id: (nx, ny) int32 index into ``surface_names`` of a floor cell's surface; -1
            for obstacle cells and for floors that are no Table I row (a flat top of an object
            that is not ``walkable``).
        interior: (nx, ny) bool, the whole cell lies on one surface.
        surface_names: ``ground`` and every walkable object of the scenario (Table I rows).
        surface_heights_m: True top height of each surface [m].
        cell_m: Cell side [m].
        ceiling_m: (nx, ny) bottom of the lowest object hanging over the support (the surface
            one stands on) [m], NaN where there is none.
        object_id: (nx, ny) int32 index into ``object_names`` of the object whose top or body
            is the highest thing over the cell, -1 for the ground.
        object_names: Every object of the scenario, in file order (removed ones included).
    """

    floor_m: NDArray[np.float64]
    obstacle_top_m: NDArray[np.float64]
    labels: NDArray[np.int8]
    surface_id: NDArray[np.int32]
    interior: NDArray[np.bool_]
    surface_names: tuple[str, ...]
    surface_heights_m: Mapping[str, float]
    cell_m: float
    ceiling_m: NDArray[np.float64]
    object_id: NDArray[np.int32]
    object_names: tuple[str, ...]

    def surface_mask(self, name: str, interior_only: bool = True) -> NDArray[np.bool_]:
        """Cells of one surface (optionally only its interior cells)."""
        if name not in self.surface_names:
            raise FogsimError(
                f"no surface named {name!r}; surfaces: {', '.join(self.surface_names)}"
            )
        mask = self.surface_id == self.surface_names.index(name)
        return mask & self.interior if interior_only else mask


@dataclass(frozen=True)
class _PointTruth:
    """The truth at M points (the rules of the module docstring).

    Attributes:
        top_m: (M,) top of the highest thing over the point [m] (0 on the ground).
        owner: (M,) int64 index into ``SceneTruth.objects`` of the highest thing, -1 ground.
        floor: (M,) bool, the highest thing is a floor.
        ceiling_m: (M,) bottom of the lowest object hanging over the support [m], NaN if none.
    """

    top_m: NDArray[np.float64]
    owner: NDArray[np.int64]
    floor: NDArray[np.bool_]
    ceiling_m: NDArray[np.float64]


def _lowest(values: NDArray[np.float64], axis: int) -> NDArray[np.float64]:
    """Minimum along ``axis`` ignoring NaN; NaN where every value is NaN."""
    low = np.where(np.isnan(values), np.inf, values).min(axis=axis, initial=np.inf)
    return np.where(np.isinf(low), np.nan, low)


@dataclass(frozen=True)
class SceneTruth:
    """The state of the world at one time.

    Attributes:
        time_s: Simulation time [s].
        objects: The objects present at that time (removed ones are absent).
        surface_names: ``ground`` and every walkable object of the scenario (stable ids).
        surface_heights_m: True top of every walkable surface [m] (ground 0).
        object_names: Every object of the scenario in file order, present or not, so that
            ``GroundTruthGrid.object_id`` is stable over time. Default (empty): the names of
            ``objects``, right for a world without removed objects (hand-built truths);
            :meth:`from_scenario` always gives every scenario object.

    Raises:
        FogsimError: An object whose name is not in ``object_names``.
    """

    time_s: float
    objects: tuple[ObjectState, ...]
    surface_names: tuple[str, ...]
    surface_heights_m: Mapping[str, float] = field(default_factory=dict)
    object_names: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if not self.object_names:
            object.__setattr__(self, "object_names", tuple(o.name for o in self.objects))
        missing = [o.name for o in self.objects if o.name not in self.object_names]
        if missing:
            raise FogsimError(
                f"SceneTruth objects {missing} are not in object_names "
                f"({', '.join(self.object_names)})"
            )

    @classmethod
    def from_scenario(cls, scenario: Scenario, time_s: float) -> SceneTruth:
        """The scenario's world at ``time_s`` with its events applied."""
        states = []
        for obj in scenario.objects:
            center = object_center_at(scenario, obj.name, time_s)
            if center is not None:
                states.append(ObjectState.from_object(obj, center))
        walkable = [o for o in scenario.objects if o.walkable]
        heights = {GROUND: 0.0, **{o.name: o.top_m for o in walkable}}
        return cls(
            time_s=float(time_s),
            objects=tuple(states),
            surface_names=(GROUND, *(o.name for o in walkable)),
            surface_heights_m=heights,
            object_names=tuple(o.name for o in scenario.objects),
        )

    def object_state(self, name: str) -> ObjectState | None:
        """The named object's state, None if it is not in the scene (removed)."""
        return next((o for o in self.objects if o.name == name), None)

    # ------------------------------------------------------------------ point queries

    def _inside(self, xy: NDArray[np.float64]) -> NDArray[np.bool_]:
        """(objects, M) whether each world point (M, 2) lies in each object's footprint."""
        if not self.objects:
            return np.zeros((0, xy.shape[0]), dtype=bool)
        return np.stack([obj.contains(xy) for obj in self.objects])

    def _tops(self, xy: NDArray[np.float64]) -> NDArray[np.float64]:
        """(objects, M) each object's top at world points (M, 2) [m] (terrains vary)."""
        if not self.objects:
            return np.zeros((0, xy.shape[0]))
        return np.stack([obj.top_at_m(xy) for obj in self.objects])

    def _support(self, inside: NDArray[np.bool_], tops: NDArray[np.float64]) -> NDArray[np.float64]:
        """(M,) support height [m] at points, given :meth:`_inside` and :meth:`_tops` of them."""
        support = np.zeros(inside.shape[1])
        for k in sorted(range(len(self.objects)), key=lambda k: self.objects[k].base_m):
            rests = inside[k] & (self.objects[k].base_m <= support + SAME_HEIGHT_M)
            support = np.where(rests & (tops[k] > support), tops[k], support)
        return support

    def support_height_m(self, xy: ArrayLike) -> NDArray[np.float64]:
        """Height [m] of the highest surface one can stand on at world points (..., 2).

        The top of the highest resting object (walkable or not, whatever its size or height),
        0 on the ground; hanging objects are no support.
        """
        p = np.asarray(xy, dtype=np.float64)
        flat = p.reshape(-1, 2)
        return self._support(self._inside(flat), self._tops(flat)).reshape(p.shape[:-1])

    def _point_truth(self, xy: NDArray[np.float64], params: TruthParams) -> _PointTruth:
        """The truth at world points (M, 2) (rules of the module docstring)."""
        inside = self._inside(xy)
        tops = self._tops(xy)
        support = self._support(inside, tops)
        bases = np.array([o.base_m for o in self.objects])
        counted = inside & (bases < params.grid_top_m - SAME_HEIGHT_M)[:, None]
        # Row 0 is the ground; row k + 1 object k (-inf where it is not over the point).
        heights = np.vstack([np.zeros((1, xy.shape[0])), np.where(counted, tops, -np.inf)])
        row = np.argmax(heights, axis=0)
        flat_with_room = np.array(
            [True]
            + [
                o.surface == "flat" and params.has_room_for_foot(o.size[0], o.size[1])
                for o in self.objects
            ]
        )
        top_m = np.take_along_axis(heights, row[None], axis=0)[0]
        hangs = counted & (bases[:, None] > support + SAME_HEIGHT_M)
        return _PointTruth(
            top_m=top_m,
            owner=row - 1,
            floor=flat_with_room[row] & (top_m <= params.grid_top_m + SAME_HEIGHT_M),
            ceiling_m=_lowest(np.where(hangs, bases[:, None], np.nan), axis=0),
        )

    def _near_outline(self, xy: NDArray[np.float64], cell_m: float) -> NDArray[np.bool_]:
        """(M,) whether the axis-aligned cell centred at each point needs sampling.

        It does where an object's outline may cross it, or over a terrain (whose steps may).
        """
        reach = 0.5 * math.sqrt(2.0) * cell_m
        near = np.zeros(xy.shape[0], dtype=bool)
        for obj in self.objects:
            reached = obj.contains(xy, reach)
            near |= reached if obj.heightfield is not None else reached & ~obj.contains(xy, -reach)
        return near

    def rasterize(
        self, cell_centers_xy: ArrayLike, cell_m: float, *, params: TruthParams = _DEFAULT_PARAMS
    ) -> GroundTruthGrid:
        """Ground truth on a grid of axis-aligned square cells.

        Args:
            cell_centers_xy: (nx, ny, 2) world x, y of the cell centres [m].
            cell_m: Cell side [m].
            params: The robot's foot and the mapper grid's top (default: iCub's foot, the
                default grid).

        Returns:
            The :class:`GroundTruthGrid` (rules in the module docstring).
        """
        centers = np.asarray(cell_centers_xy, dtype=np.float64)
        if centers.ndim != 3 or centers.shape[-1] != 2:
            raise FogsimError(f"cell_centers_xy must have shape (nx, ny, 2), got {centers.shape}")
        if not cell_m > 0:
            raise FogsimError(f"cell_m must be > 0 m, got {cell_m}")
        nx, ny = centers.shape[:2]
        flat = centers.reshape(-1, 2)
        center = self._point_truth(flat, params)
        cell_top, cell_owner = center.top_m.copy(), center.owner.copy()
        floor, ceiling = center.floor.copy(), center.ceiling_m.copy()
        interior = np.ones(flat.shape[0], dtype=bool)

        near = self._near_outline(flat, cell_m)
        half = 0.5 * cell_m * (1.0 - 1e-4)
        offsets = np.linspace(-half, half, _INTERIOR_SAMPLES)
        ox, oy = np.meshgrid(offsets, offsets, indexing="ij")
        samples_xy = flat[near][:, None, :] + np.stack([ox.ravel(), oy.ravel()], axis=-1)[None]
        sampled = self._point_truth(samples_xy.reshape(-1, 2), params)
        count = int(near.sum())

        def per_cell(values: NDArray[Any], at_center: NDArray[Any]) -> NDArray[Any]:
            """(cells near an outline, 1 + samples): the centre's value first."""
            return np.column_stack([at_center[near], values.reshape(count, _INTERIOR_SAMPLES**2)])

        tops = per_cell(sampled.top_m, center.top_m)
        highest = np.argmax(tops, axis=1)  # ties keep the centre
        cell_top[near] = np.take_along_axis(tops, highest[:, None], axis=1)[:, 0]
        owners = per_cell(sampled.owner, center.owner)
        cell_owner[near] = np.take_along_axis(owners, highest[:, None], axis=1)[:, 0]
        ceiling[near] = _lowest(per_cell(sampled.ceiling_m, center.ceiling_m), axis=1)
        on_terrain = np.array([o.heightfield is not None for o in self.objects] + [False])
        level = np.where(
            on_terrain[owners[:, 0]][:, None],
            np.ptp(tops, axis=1, keepdims=True) <= TERRAIN_STEP_M,
            np.abs(tops - tops[:, :1]) <= SAME_HEIGHT_M,
        )
        floor[near] &= np.all(per_cell(sampled.floor, center.floor) & level, axis=1)
        interior[near] = np.all(owners == owners[:, :1], axis=1)

        # Index -1 (the ground) picks the appended last entry.
        object_ids = np.array(
            [self.object_names.index(o.name) for o in self.objects] + [-1], dtype=np.int32
        )
        surface_ids = np.array(
            [
                self.surface_names.index(o.name) if o.name in self.surface_names else -1
                for o in self.objects
            ]
            + [self.surface_names.index(GROUND) if GROUND in self.surface_names else -1],
            dtype=np.int32,
        )

        def grid(a: NDArray[Any]) -> NDArray[Any]:
            return a.reshape(nx, ny)

        return GroundTruthGrid(
            floor_m=grid(np.where(floor, center.top_m, np.nan)),
            obstacle_top_m=grid(np.where(floor, np.nan, cell_top)),
            labels=grid(np.where(floor, TruthLabel.FLOOR, TruthLabel.OBSTACLE).astype(np.int8)),
            surface_id=grid(np.where(floor, surface_ids[center.owner], -1).astype(np.int32)),
            interior=grid(interior),
            surface_names=self.surface_names,
            surface_heights_m=dict(self.surface_heights_m),
            cell_m=float(cell_m),
            ceiling_m=grid(ceiling),
            object_id=grid(object_ids[np.where(floor, center.owner, cell_owner)]),
            object_names=self.object_names,
        )

    # ------------------------------------------------------------------ (de)serialisation

    def to_dict(self) -> dict[str, Any]:
        """JSON-able dict (for recordings); :meth:`from_dict` restores an equal value."""
        return {
            "time_s": self.time_s,
            "objects": [
                {
                    "name": o.name,
                    "center_xy": list(o.center_xy),
                    "size": list(o.size),
                    "yaw_rad": o.yaw_rad,
                    "base_m": o.base_m,
                    "walkable": o.walkable,
                    "surface": o.surface,
                    "roughness_m": o.roughness_m,
                    **(
                        {}
                        if o.heightfield is None
                        else {
                            "heightfield": o.heightfield,
                            "cell_m": o.cell_m,
                            "max_height_m": o.max_height_m,
                        }
                    ),
                }
                for o in self.objects
            ],
            "surface_names": list(self.surface_names),
            "surface_heights_m": dict(self.surface_heights_m),
            "object_names": list(self.object_names),
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> SceneTruth:
        """Inverse of :meth:`to_dict`.

        Raises:
            FogsimError: A key is missing or malformed (truths recorded before
                ``object_names`` existed lack it: record them again).
        """
        try:
            objects = tuple(
                ObjectState(
                    name=str(o["name"]),
                    center_xy=(float(o["center_xy"][0]), float(o["center_xy"][1])),
                    size=(float(o["size"][0]), float(o["size"][1]), float(o["size"][2])),
                    yaw_rad=float(o["yaw_rad"]),
                    base_m=float(o["base_m"]),
                    walkable=bool(o["walkable"]),
                    surface=str(o.get("surface", "flat")),
                    roughness_m=float(o.get("roughness_m", 0.0)),
                    heightfield=None if o.get("heightfield") is None else str(o["heightfield"]),
                    cell_m=float(o.get("cell_m", 0.0)),
                    max_height_m=float(o.get("max_height_m", 0.0)),
                )
                for o in data["objects"]
            )
            return cls(
                time_s=float(data["time_s"]),
                objects=objects,
                surface_names=tuple(str(n) for n in data["surface_names"]),
                surface_heights_m={str(k): float(v) for k, v in data["surface_heights_m"].items()},
                object_names=tuple(str(n) for n in data["object_names"]),
            )
        except (KeyError, TypeError, IndexError, ValueError) as exc:
            raise FogsimError(f"invalid SceneTruth dict: {exc!r}") from exc
