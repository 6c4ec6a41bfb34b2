"""Ground truth of a scene at one instant: support heights and labelled grids.

:class:`SceneTruth` is the world at one time, the objects placed where the event timeline
(:mod:`fogsim.world.timeline`) puts them; :meth:`SceneTruth.rasterize` turns it into the
:class:`GroundTruthGrid` a map is scored against.

Rasterisation rule (per cell, evaluated at the cell centre; "covers" = the point lies in the
object's footprint, edges included):
    * The *support* at a point is the top of the highest object resting there (an object rests
      when its base is at most 1 mm above the support beneath it — on the ground, or stacked on
      another object), or the ground (0 m).
    * FLOOR if the support is the ground or a walkable object: ``floor_m`` is its height,
      ``surface_id`` its index in ``surface_names`` (``ground`` first, then every walkable object
      of the scenario in file order, present or not, so ids are stable over time).
    * OBSTACLE if the support is a non-walkable object, or if any hanging object (base above the
      support, like a table top or a curtain) covers the point: ``obstacle_top_m`` is the highest
      such top (rough tops: the nominal top, the highest bump), ``floor_m`` NaN, ``surface_id`` -1.
    * ``interior``: the whole cell lies on one surface — 5 × 5 samples over the cell square
      (edges included, inset by 1e-4 cell) all give the centre's label and surface/object.
      Cells along an edge or a step are left out (the Table I convention of DESIGN.md).
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
from mapper.grid import CellType

GROUND = "ground"
RESTING_TOLERANCE_M = 1e-3  # an object rests on the support below if its base is this close
_INTERIOR_SAMPLES = 5


TruthLabel = CellType  # truth labels are the mapper's cell types (UNKNOWN unused)


@dataclass(frozen=True)
class GroundTruthGrid:
    """Ground truth on a grid of cells (see the module docstring for the rules).

    Attributes:
        floor_m: (nx, ny) true floor height [m], NaN where not floor.
        obstacle_top_m: (nx, ny) obstacle top [m], NaN where no obstacle.
        labels: (nx, ny) int8, ``TruthLabel`` (= ``mapper.CellType``) FLOOR=1 / OBSTACLE=2.
        surface_id: (nx, ny) int index into ``surface_names``, -1 for obstacle cells.
        interior: (nx, ny) bool, the whole cell lies on one surface.
        surface_names: ``ground`` and every walkable object of the scenario.
        surface_heights_m: true top height of each surface [m].
        cell_m: Cell side [m].
    """

    floor_m: NDArray[np.float64]
    obstacle_top_m: NDArray[np.float64]
    labels: NDArray[np.int8]
    surface_id: NDArray[np.int32]
    interior: NDArray[np.bool_]
    surface_names: tuple[str, ...]
    surface_heights_m: Mapping[str, float]
    cell_m: float

    def surface_mask(self, name: str, interior_only: bool = True) -> NDArray[np.bool_]:
        """Cells of one surface (optionally only its interior cells)."""
        if name not in self.surface_names:
            raise FogsimError(
                f"no surface named {name!r}; surfaces: {', '.join(self.surface_names)}"
            )
        mask = self.surface_id == self.surface_names.index(name)
        return mask & self.interior if interior_only else mask


@dataclass(frozen=True)
class _PointLabels:
    """Ground truth at M points (the rules of the module docstring).

    Attributes:
        floor_m: (M,) floor height [m], NaN where not floor.
        obstacle_top_m: (M,) obstacle top [m], NaN where no obstacle.
        labels: (M,) int8 ``TruthLabel``.
        surface_id: (M,) int32 index into ``surface_names``, -1 for obstacles.
        owner_key: (M,) int64, one key per surface or object a point lies on (the interior test).
    """

    floor_m: NDArray[np.float64]
    obstacle_top_m: NDArray[np.float64]
    labels: NDArray[np.int8]
    surface_id: NDArray[np.int32]
    owner_key: NDArray[np.int64]


@dataclass(frozen=True)
class SceneTruth:
    """The state of the world at one time.

    Attributes:
        time_s: Simulation time [s].
        objects: The objects present at that time (removed ones are absent).
        surface_names: ``ground`` and every walkable object of the scenario (stable ids).
        surface_heights_m: True top of every walkable surface [m] (ground 0).
    """

    time_s: float
    objects: tuple[ObjectState, ...]
    surface_names: tuple[str, ...]
    surface_heights_m: Mapping[str, float] = field(default_factory=dict)

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
        )

    def object_state(self, name: str) -> ObjectState | None:
        """The named object's state, None if it is not in the scene (removed)."""
        return next((o for o in self.objects if o.name == name), None)

    # ------------------------------------------------------------------ point queries

    def _classify(
        self, xy: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], NDArray[np.int32], NDArray[np.float64], NDArray[np.int32]]:
        """Per point (M, 2): support height, support owner, hanging top, hanging owner.

        Owner: -1 ground, else object index in ``self.objects``; hanging owner -1 = none.
        """
        m = xy.shape[0]
        support = np.zeros(m)
        owner = np.full(m, -1, dtype=np.int32)
        order = sorted(range(len(self.objects)), key=lambda k: self.objects[k].base_m)
        inside = [self.objects[k].contains(xy) for k in range(len(self.objects))]
        for k in order:
            obj = self.objects[k]
            rests = inside[k] & (obj.base_m <= support + RESTING_TOLERANCE_M)
            higher = rests & (obj.top_m > support)
            support = np.where(higher, obj.top_m, support)
            owner = np.where(higher, k, owner)
        hanging_top = np.full(m, np.nan)
        hanging_owner = np.full(m, -1, dtype=np.int32)
        for k, obj in enumerate(self.objects):
            hangs = inside[k] & (obj.base_m > support + RESTING_TOLERANCE_M)
            higher = hangs & ~(hanging_top >= obj.top_m)
            hanging_top = np.where(higher, obj.top_m, hanging_top)
            hanging_owner = np.where(higher, k, hanging_owner)
        return support, owner, hanging_top, hanging_owner

    def support_height_m(self, xy: ArrayLike) -> NDArray[np.float64]:
        """Height [m] of the highest surface one can stand on at world points (..., 2).

        The top of the highest resting object (walkable or not), 0 on the ground; hanging
        objects are no support.
        """
        p = np.asarray(xy, dtype=np.float64)
        support, *_ = self._classify(p.reshape(-1, 2))
        return support.reshape(p.shape[:-1])

    def _labels_of(self, xy: NDArray[np.float64]) -> _PointLabels:
        support, owner, hanging_top, hanging_owner = self._classify(xy)
        walkable = np.array([o.walkable for o in self.objects] + [True], dtype=bool)
        tops = np.array([o.top_m for o in self.objects] + [0.0])
        surface_of_object = np.array(
            [
                self.surface_names.index(o.name) if o.name in self.surface_names else -1
                for o in self.objects
            ]
            + [0],
            dtype=np.int32,
        )  # index -1 (ground) picks the appended last entry
        support_is_floor = walkable[owner]
        hanging = hanging_owner >= 0
        obstacle = ~support_is_floor | hanging
        obstacle_top = np.where(
            hanging, np.fmax(hanging_top, np.where(support_is_floor, np.nan, support)), np.nan
        )
        obstacle_top = np.where(~support_is_floor & ~hanging, tops[owner], obstacle_top)
        surface_id = np.where(obstacle, -1, surface_of_object[owner]).astype(np.int32)
        # One key per distinct surface/object a sample can lie on, for the interior test.
        owner_key = np.where(hanging, 10_000 + hanging_owner, owner).astype(np.int64)
        return _PointLabels(
            floor_m=np.where(obstacle, np.nan, support),
            obstacle_top_m=obstacle_top,
            labels=np.where(obstacle, TruthLabel.OBSTACLE, TruthLabel.FLOOR).astype(np.int8),
            surface_id=surface_id,
            owner_key=owner_key,
        )

    def rasterize(self, cell_centers_xy: ArrayLike, cell_m: float) -> GroundTruthGrid:
        """Ground truth on a grid of axis-aligned square cells.

        Args:
            cell_centers_xy: (nx, ny, 2) world x, y of the cell centres [m].
            cell_m: Cell side [m].

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
        at_center = self._labels_of(flat)
        # Only cells an object's outline passes near can straddle two surfaces: sample those.
        reach = 0.5 * math.sqrt(2.0) * cell_m
        near_edge = np.zeros(flat.shape[0], dtype=bool)
        for obj in self.objects:
            near_edge |= obj.contains(flat, reach) & ~obj.contains(flat, -reach)
        half = 0.5 * cell_m * (1.0 - 1e-4)
        offsets = np.linspace(-half, half, _INTERIOR_SAMPLES)
        ox, oy = np.meshgrid(offsets, offsets, indexing="ij")
        candidates = flat[near_edge]
        samples = candidates[:, None, :] + np.stack([ox.ravel(), oy.ravel()], axis=-1)[None]
        keys = self._labels_of(samples.reshape(-1, 2)).owner_key
        interior = np.ones(flat.shape[0], dtype=bool)
        interior[near_edge] = np.all(
            keys.reshape(candidates.shape[0], _INTERIOR_SAMPLES**2)
            == at_center.owner_key[near_edge, None],
            axis=1,
        )

        def grid(a: NDArray[Any]) -> NDArray[Any]:
            return a.reshape(nx, ny)

        return GroundTruthGrid(
            floor_m=grid(at_center.floor_m),
            obstacle_top_m=grid(at_center.obstacle_top_m),
            labels=grid(at_center.labels),
            surface_id=grid(at_center.surface_id),
            interior=grid(interior),
            surface_names=self.surface_names,
            surface_heights_m=dict(self.surface_heights_m),
            cell_m=float(cell_m),
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
                }
                for o in self.objects
            ],
            "surface_names": list(self.surface_names),
            "surface_heights_m": dict(self.surface_heights_m),
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> SceneTruth:
        """Inverse of :meth:`to_dict`."""
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
                )
                for o in data["objects"]
            )
            return cls(
                time_s=float(data["time_s"]),
                objects=objects,
                surface_names=tuple(str(n) for n in data["surface_names"]),
                surface_heights_m={str(k): float(v) for k, v in data["surface_heights_m"].items()},
            )
        except (KeyError, TypeError, IndexError, ValueError) as exc:
            raise FogsimError(f"invalid SceneTruth dict: {exc!r}") from exc
