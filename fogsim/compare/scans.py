"""Height scans: a map sampled at a robot-centred pattern, against the truth's scan.

A legged-robot policy trained in simulation sees the terrain as heights at a fixed pattern of
points around the robot (the common one: a 1.6 m × 1.0 m grid at 0.1 m, 17 × 11 points, x along
the robot's heading). Here the pattern is placed with the robot's *true* pose, each map's height
is read at the cell under each point (no value: not covered), and the truth's scan is the height
of the highest surface one can stand on there (:meth:`SceneTruth.support_height_m`): the
perfect scan a policy was trained on. The errors are what the policy meets on the real map.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from fogsim.errors import FogsimError
from mapper.grid import GridGeometry


@dataclass(frozen=True)
class HeightScanParams:
    """The scan pattern and how often it is taken.

    Attributes:
        length_m: Extent along the robot's heading [m]: 1.6 (the common RL pattern).
        width_m: Extent across it [m]: 1.0.
        spacing_m: Distance between points [m]: 0.1.
        every_frames: Take a scan every this many frames: 1 (every frame).
    """

    length_m: float = 1.6
    width_m: float = 1.0
    spacing_m: float = 0.1
    every_frames: int = 1

    def __post_init__(self) -> None:
        for name in ("length_m", "width_m", "spacing_m"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise FogsimError(f"HeightScanParams.{name} must be a number [m], got {value!r}")
            if not (math.isfinite(value) and value >= 0) or (name == "spacing_m" and value <= 0):
                raise FogsimError(
                    f"HeightScanParams.{name} must be finite and "
                    f"{'> 0' if name == 'spacing_m' else '>= 0'} [m], got {value!r}"
                )
        if isinstance(self.every_frames, bool) or not isinstance(self.every_frames, int):
            raise FogsimError(
                f"HeightScanParams.every_frames must be an integer >= 1, got {self.every_frames!r}"
            )
        if self.every_frames < 1:
            raise FogsimError(
                f"HeightScanParams.every_frames must be an integer >= 1, got {self.every_frames!r}"
            )


def scan_pattern_robot(params: HeightScanParams) -> NDArray[np.float64]:
    """(K, 2) pattern points in the robot frame [m], x along the heading, centred on the robot.

    Points every ``spacing_m`` from ``-length/2`` to ``+length/2`` (and likewise across),
    both ends included: 17 × 11 points for the default.
    """
    nx = math.floor(params.length_m / params.spacing_m + 1e-9) + 1
    ny = math.floor(params.width_m / params.spacing_m + 1e-9) + 1
    x = (np.arange(nx) - 0.5 * (nx - 1)) * params.spacing_m
    y = (np.arange(ny) - 0.5 * (ny - 1)) * params.spacing_m
    gx, gy = np.meshgrid(x, y, indexing="ij")
    return np.stack([gx.ravel(), gy.ravel()], axis=1)


def scan_points_world(
    pattern_robot: NDArray[np.float64], robot_pose: NDArray[np.float64]
) -> NDArray[np.float64]:
    """(K, 2) world points [m] of the pattern at a robot pose (x, y, z, yaw [rad])."""
    x, y, _, yaw = (float(v) for v in robot_pose)
    c, s = math.cos(yaw), math.sin(yaw)
    rotation = np.array([[c, -s], [s, c]])
    return pattern_robot @ rotation.T + np.array([x, y])


def sample_heights(
    heights_m: NDArray[np.floating], geometry: GridGeometry, points_xy: NDArray[np.float64]
) -> NDArray[np.float64]:
    """(K,) a map's height [m] at the cell under each point; NaN outside the grid or unknown."""
    index, inside = geometry.cell_of(points_xy)
    values = np.full(points_xy.shape[0], np.nan)
    heights = np.asarray(heights_m, dtype=np.float64)
    values[inside] = heights[index[inside, 0], index[inside, 1]]
    return values
