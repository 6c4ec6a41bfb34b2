"""Where each scenario object is at a time: the world's event timeline.

The world is the scenario's: z up, the ground is the plane z = 0, every object a box (possibly
yawed, possibly hanging) or a terrain whose top is a height field. Events move or remove objects
over time: :func:`object_center_at` gives an object's footprint centre at any instant,
:class:`ObjectState` its whole placement.
The scene places its mocap bodies from this timeline; :mod:`fogsim.world.truth` derives the
ground truth from it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fogsim.config import Scenario, SceneObject
from fogsim.config.schema import read_heightfield
from fogsim.errors import FogsimError


@dataclass(frozen=True)
class ObjectState:
    """Where one box is at one instant.

    Attributes:
        name: The scenario object's name.
        center_xy: (x, y) footprint centre in the world [m].
        size: (x, y, z) extent [m].
        yaw_rad: Rotation about world z [rad].
        base_m: z of the bottom face [m].
        walkable: Its top is a floor.
        surface: ``flat`` or ``rough``.
        roughness_m: Bump height of a rough top [m].
        heightfield: A terrain's elevation image (path inside ``assets/``), None for a box.
        cell_m: A terrain's sample spacing [m] (0 for a box).
        max_height_m: A terrain's height of the value 255 [m] (0 for a box).
    """

    name: str
    center_xy: tuple[float, float]
    size: tuple[float, float, float]
    yaw_rad: float
    base_m: float
    walkable: bool
    surface: str = "flat"
    roughness_m: float = 0.0
    heightfield: str | None = None
    cell_m: float = 0.0
    max_height_m: float = 0.0

    @property
    def top_m(self) -> float:
        """Height of the top face (the highest bump of a rough top) [m]."""
        return self.base_m + self.size[2]

    def contains(self, xy: ArrayLike, margin_m: float = 1e-9) -> NDArray[np.bool_]:
        """Whether world points (..., 2) lie in the footprint (edges included, + margin)."""
        local_x, local_y = self._local_xy(xy)
        return (np.abs(local_x) <= 0.5 * self.size[0] + margin_m) & (
            np.abs(local_y) <= 0.5 * self.size[1] + margin_m
        )

    def _local_xy(self, xy: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """World points (..., 2) in the object's frame: (x, y) [m] from the footprint centre."""
        p = np.asarray(xy, dtype=np.float64)
        c, s = math.cos(self.yaw_rad), math.sin(self.yaw_rad)
        dx = p[..., 0] - self.center_xy[0]
        dy = p[..., 1] - self.center_xy[1]
        return c * dx + s * dy, -s * dx + c * dy

    def heights_m(self) -> NDArray[np.float64]:
        """A terrain's sample heights (rows, columns) [m]; row 0 at +y, column 0 at -x."""
        if self.heightfield is None:
            raise FogsimError(f"object {self.name!r} is a box, not a heightfield")
        return read_heightfield(self.heightfield) * (self.max_height_m / 255.0)

    def top_at_m(self, xy: ArrayLike) -> NDArray[np.float64]:
        """Height [m] of the top at world points (..., 2) in the footprint.

        A box's top face; a terrain's surface interpolated bilinearly between the four samples
        around the point (points off the terrain are clamped onto its edge). MuJoCo splits each
        cell into two triangles instead: the two agree at the samples and differ inside a cell
        by at most half the cell's height span.
        """
        if self.heightfield is None:
            return np.full(np.shape(xy)[:-1], self.top_m)
        heights = self.heights_m()
        rows, columns = heights.shape
        local_x, local_y = self._local_xy(xy)
        along = np.clip((local_x + 0.5 * self.size[0]) / self.cell_m, 0.0, columns - 1.0)
        down = np.clip((0.5 * self.size[1] - local_y) / self.cell_m, 0.0, rows - 1.0)
        row = np.minimum(np.floor(down).astype(np.intp), rows - 2)
        column = np.minimum(np.floor(along).astype(np.intp), columns - 2)
        fr, fc = down - row, along - column
        near_row = heights[row, column] * (1 - fc) + heights[row, column + 1] * fc
        far_row = heights[row + 1, column] * (1 - fc) + heights[row + 1, column + 1] * fc
        return self.base_m + near_row * (1 - fr) + far_row * fr

    def footprint_corners_xy(self) -> NDArray[np.float64]:
        """(4, 2) world corners of the footprint, counter-clockwise."""
        hx, hy = 0.5 * self.size[0], 0.5 * self.size[1]
        local = np.array([[hx, hy], [-hx, hy], [-hx, -hy], [hx, -hy]])
        c, s = math.cos(self.yaw_rad), math.sin(self.yaw_rad)
        return local @ np.array([[c, s], [-s, c]]) + np.asarray(self.center_xy)

    @classmethod
    def from_object(cls, obj: SceneObject, center_xy: Sequence[float]) -> ObjectState:
        """The state of a scenario object placed at ``center_xy``."""
        return cls(
            name=obj.name,
            center_xy=(float(center_xy[0]), float(center_xy[1])),
            size=obj.size,
            yaw_rad=math.radians(obj.yaw_deg),
            base_m=obj.base,
            walkable=obj.walkable,
            surface=obj.surface,
            roughness_m=obj.roughness_m if obj.surface == "rough" else 0.0,
            heightfield=obj.heightfield,
            cell_m=obj.cell_m or 0.0,
            max_height_m=obj.max_height_m or 0.0,
        )


def object_center_at(scenario: Scenario, name: str, time_s: float) -> tuple[float, float] | None:
    """Footprint centre (x, y) [m] of a scenario object at ``time_s``; None once removed.

    Events of the object apply in time order: ``remove`` takes it away at ``at``; ``move``
    slides it in a straight line from where it is at ``at`` towards ``to`` at ``speed`` until
    it arrives or the object's next event starts.
    """
    obj = scenario.object(name)
    center = np.array(obj.center, dtype=np.float64)
    events = sorted((e for e in scenario.events if e.target == name), key=lambda e: e.at)
    for i, event in enumerate(events):
        if time_s < event.at:
            break
        if event.kind == "remove":
            return None
        next_at = events[i + 1].at if i + 1 < len(events) else math.inf
        travel_s = min(time_s, next_at) - event.at
        to = np.array(event.to, dtype=np.float64)
        distance = float(np.linalg.norm(to - center))
        step = min(distance, (event.speed or 0.0) * travel_s)
        if distance > 0.0:
            center = center + (to - center) * (step / distance)
    return (float(center[0]), float(center[1]))


def moving_objects(scenario: Scenario) -> tuple[str, ...]:
    """Names of the objects some event moves or removes (mocap bodies in the scene)."""
    return tuple(dict.fromkeys(e.target for e in scenario.events))
