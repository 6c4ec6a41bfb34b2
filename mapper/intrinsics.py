"""Pinhole camera intrinsics in OpenCV's convention (x right, y down, z forward)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from mapper.errors import InvalidInputError, InvalidParameterError


@dataclass(frozen=True)
class PinholeIntrinsics:
    """Pinhole intrinsics of a depth camera.

    Attributes:
        width: Image width [px].
        height: Image height [px].
        fx: Focal length along x [px].
        fy: Focal length along y [px].
        cx: Principal point x [px], pixel centres at integer coordinates.
        cy: Principal point y [px].
    """

    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float

    def __post_init__(self) -> None:
        if self.width <= 0 or self.height <= 0:
            raise InvalidParameterError(
                f"image size must be positive, got width={self.width}, height={self.height}"
            )
        if not (self.fx > 0 and self.fy > 0):
            raise InvalidParameterError(
                f"focal lengths must be > 0 px, got fx={self.fx}, fy={self.fy}"
            )

    @classmethod
    def from_fov(
        cls, width: int, height: int, hfov_deg: float, vfov_deg: float
    ) -> PinholeIntrinsics:
        """Intrinsics of a centred pinhole camera with the given full fields of view [deg]."""
        for name, fov in (("hfov_deg", hfov_deg), ("vfov_deg", vfov_deg)):
            if not 0.0 < fov < 180.0:
                raise InvalidParameterError(f"{name} must be in (0, 180) degrees, got {fov}")
        fx = 0.5 * width / math.tan(math.radians(hfov_deg) / 2.0)
        fy = 0.5 * height / math.tan(math.radians(vfov_deg) / 2.0)
        return cls(width, height, fx, fy, (width - 1) / 2.0, (height - 1) / 2.0)

    @property
    def shape(self) -> tuple[int, int]:
        """Image shape as (height, width)."""
        return (self.height, self.width)

    @property
    def hfov_deg(self) -> float:
        """Full horizontal field of view [deg]."""
        return math.degrees(2.0 * math.atan(0.5 * self.width / self.fx))

    @property
    def vfov_deg(self) -> float:
        """Full vertical field of view [deg]."""
        return math.degrees(2.0 * math.atan(0.5 * self.height / self.fy))

    @property
    def matrix(self) -> NDArray[np.float64]:
        """The 3×3 camera matrix K."""
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    def ray_directions_camera(self) -> NDArray[np.float64]:
        """Per-pixel ray directions with unit z, shape (height, width, 3), camera frame."""
        u = (np.arange(self.width) - self.cx) / self.fx
        v = (np.arange(self.height) - self.cy) / self.fy
        uu, vv = np.meshgrid(u, v)
        return np.stack([uu, vv, np.ones_like(uu)], axis=-1)

    def depth_to_points_camera(self, depth_m: NDArray[np.floating]) -> NDArray[np.float64]:
        """Back-project a depth image (metres along z, NaN or 0 = none) to (height, width, 3).

        Pixels without a measurement give NaN points.
        """
        depth = np.asarray(depth_m, dtype=np.float64)
        if depth.shape != self.shape:
            raise InvalidInputError(
                f"depth image must have shape (height, width) = {self.shape}, got {depth.shape}"
            )
        depth = np.where(depth > 0.0, depth, np.nan)
        return self.ray_directions_camera() * depth[..., None]
