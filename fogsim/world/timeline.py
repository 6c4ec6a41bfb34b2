"""Where each scenario object is at a time: the world's event timeline.

The world is the scenario's: z up, the ground is the plane z = 0, every object a box (possibly
yawed, possibly hanging). Events move or remove objects over time: :func:`object_center_at`
gives an object's footprint centre at any instant, :class:`ObjectState` its whole placement.
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
    """

    name: str
    center_xy: tuple[float, float]
    size: tuple[float, float, float]
    yaw_rad: float
    base_m: float
    walkable: bool
    surface: str = "flat"
    roughness_m: float = 0.0

    @property
    def top_m(self) -> float:
        """Height of the top face (the highest bump of a rough top) [m]."""
        return self.base_m + self.size[2]

    def contains(self, xy: ArrayLike, margin_m: float = 1e-9) -> NDArray[np.bool_]:
        """Whether world points (..., 2) lie in the footprint (edges included, + margin)."""
        p = np.asarray(xy, dtype=np.float64)
        c, s = math.cos(self.yaw_rad), math.sin(self.yaw_rad)
        dx = p[..., 0] - self.center_xy[0]
        dy = p[..., 1] - self.center_xy[1]
        local_x = c * dx + s * dy
        local_y = -s * dx + c * dy
        return (np.abs(local_x) <= 0.5 * self.size[0] + margin_m) & (
            np.abs(local_y) <= 0.5 * self.size[1] + margin_m
        )

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
