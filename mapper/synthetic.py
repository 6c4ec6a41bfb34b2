"""Analytic labelled point frames of boxes on a ground plane, for tests and benchmarks.

No rendering: every pixel ray of a pinhole camera is intersected exactly with the ground
(z = 0) and with axis-aligned boxes; the result is what an ideal segmentation would hand the
mapper — world points and, for points on the ground or on a walkable box top, the height of
that horizontal plane (NaN otherwise).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mapper.intrinsics import PinholeIntrinsics
from mapper.validation import real_array


@dataclass(frozen=True)
class Box:
    """An axis-aligned box in the world [m].

    Attributes:
        center_xy: (x, y) of the footprint centre.
        size_xyz: Extent along x, y, z.
        base_m: z of the bottom face (> 0: hanging, like a table top).
        walkable: Whether its top face is a floor (gets a floor height).
    """

    center_xy: tuple[float, float]
    size_xyz: tuple[float, float, float]
    base_m: float = 0.0
    walkable: bool = True

    @property
    def top_m(self) -> float:
        """World z of the top face [m]."""
        return self.base_m + self.size_xyz[2]

    @property
    def lower(self) -> NDArray[np.float64]:
        """(3,) lowest corner [m]."""
        cx, cy = self.center_xy
        sx, sy, _ = self.size_xyz
        return np.array([cx - sx / 2, cy - sy / 2, self.base_m])

    @property
    def upper(self) -> NDArray[np.float64]:
        """(3,) highest corner [m]."""
        cx, cy = self.center_xy
        sx, sy, _ = self.size_xyz
        return np.array([cx + sx / 2, cy + sy / 2, self.top_m])


def camera_rays_world(
    intrinsics: PinholeIntrinsics, yaw_deg: float, pitch_down_deg: float
) -> NDArray[np.float64]:
    """(H·W, 3) unit ray directions in the world of a camera with zero roll."""
    yaw, pitch = math.radians(yaw_deg), math.radians(pitch_down_deg)
    forward = np.array(
        [math.cos(pitch) * math.cos(yaw), math.cos(pitch) * math.sin(yaw), -math.sin(pitch)]
    )
    right = np.array([math.sin(yaw), -math.cos(yaw), 0.0])
    down = np.cross(forward, right)
    rotation_camera_to_world = np.stack([right, down, forward], axis=1)
    d = intrinsics.ray_directions_camera().reshape(-1, 3) @ rotation_camera_to_world.T
    return d / np.linalg.norm(d, axis=1, keepdims=True)


def cast_frame(
    camera_position: ArrayLike,
    rays_world: NDArray[np.float64],
    boxes: tuple[Box, ...] | list[Box] = (),
    *,
    max_range_m: float = np.inf,
    noise_z_m: float = 0.0,
    rng: np.random.Generator | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Points and floor heights seen along ``rays_world`` from ``camera_position``.

    Args:
        camera_position: (3,) world position [m].
        rays_world: (N, 3) unit directions.
        boxes: Boxes in the scene (the ground z = 0 is always there).
        max_range_m: Rays longer than this give NaN points.
        noise_z_m: Half-width [m] of uniform noise added to every point's z (not to ``h``).
        rng: Random generator for the noise (required when ``noise_z_m > 0``).

    Returns:
        (points (N, 3) world [m], NaN rows for no hit; floor_heights (N,) [m], NaN = not floor).
    """
    origin = real_array(camera_position, "camera_position")
    d = real_array(rays_world, "rays_world")
    n = d.shape[0]
    with np.errstate(divide="ignore", invalid="ignore"):
        t_best = np.where(d[:, 2] < 0, -origin[2] / d[:, 2], np.inf)
        h_best = np.zeros(n)
        for box in boxes:
            inv = 1.0 / d
            ta = (box.lower - origin) * inv
            tb = (box.upper - origin) * inv
            t_near = np.nanmax(np.minimum(ta, tb), axis=1)
            t_far = np.nanmin(np.maximum(ta, tb), axis=1)
            hit = (t_near <= t_far) & (t_near > 0) & (t_near < t_best)
            z_hit = origin[2] + t_near * d[:, 2]
            on_top = np.abs(z_hit - box.top_m) < 1e-9
            t_best = np.where(hit, t_near, t_best)
            h_box = box.top_m if box.walkable else np.nan
            h_best = np.where(hit, np.where(on_top, h_box, np.nan), h_best)
    valid = np.isfinite(t_best) & (t_best <= max_range_m)
    points = origin + t_best[:, None] * d
    points[~valid] = np.nan
    h_best[~valid] = np.nan
    if noise_z_m > 0:
        if rng is None:
            raise ValueError("cast_frame: rng is required when noise_z_m > 0")
        points[:, 2] += rng.uniform(-noise_z_m, noise_z_m, n)
    return points, h_best
