"""Pinhole camera intrinsics in OpenCV's convention (x right, y down, z forward)."""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from mapper.errors import InvalidInputError, InvalidParameterError
from mapper.limits import MAX_IMAGE_PIXELS, MAX_IMAGE_SIDE_PX
from mapper.validation import check_field, real_array


@dataclass(frozen=True)
class PinholeIntrinsics:
    """Pinhole intrinsics of a depth camera, checked on construction.

    Attributes:
        width: Image width [px], an integer in [1, `mapper.limits.MAX_IMAGE_SIDE_PX`]; with
            ``height``, at most `mapper.limits.MAX_IMAGE_PIXELS` pixels.
        height: Image height [px], likewise.
        fx: Focal length along x [px], finite and > 0.
        fy: Focal length along y [px], finite and > 0.
        cx: Principal point x [px], finite; pixel centres at integer coordinates.
        cy: Principal point y [px], finite.

    Raises:
        InvalidParameterError: a field of the wrong type or out of range (NaN, inf, a
            non-positive focal length), naming the field and the value.
    """

    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float

    def __post_init__(self) -> None:
        for name in ("width", "height"):
            check_field(
                "PinholeIntrinsics",
                name,
                getattr(self, name),
                int,
                f"an integer in [1, {MAX_IMAGE_SIDE_PX}] px (mapper.limits.MAX_IMAGE_SIDE_PX)",
                lambda v: 1 <= v <= MAX_IMAGE_SIDE_PX,
            )
        if self.width * self.height > MAX_IMAGE_PIXELS:
            raise InvalidParameterError(
                f"PinholeIntrinsics.width*height must be at most {MAX_IMAGE_PIXELS} pixels "
                f"(mapper.limits.MAX_IMAGE_PIXELS), got {self.width}×{self.height}"
            )
        for name in ("fx", "fy"):
            check_field(
                "PinholeIntrinsics",
                name,
                getattr(self, name),
                float,
                "a finite float > 0 [px]",
                lambda v: math.isfinite(v) and v > 0,
            )
        for name in ("cx", "cy"):
            check_field(
                "PinholeIntrinsics",
                name,
                getattr(self, name),
                float,
                "a finite float [px]",
                math.isfinite,
            )

    @classmethod
    def from_fov(
        cls, width: int, height: int, hfov_deg: float, vfov_deg: float
    ) -> PinholeIntrinsics:
        """Intrinsics of a centred pinhole camera with the given full fields of view [deg]."""
        for name, fov in (("hfov_deg", hfov_deg), ("vfov_deg", vfov_deg)):
            check_field(
                "PinholeIntrinsics.from_fov",
                name,
                fov,
                float,
                "in (0, 180) degrees",
                lambda v: 0.0 < v < 180.0,
            )
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
        """Per-pixel ray directions with unit z, shape (height, width, 3), camera frame.

        Read-only and made once per camera: every frame back-projects through them.
        """
        return _ray_directions_camera(self)

    def depth_to_points_camera(self, depth_m: NDArray[np.floating]) -> NDArray[np.float64]:
        """Back-project a depth image (metres along z, NaN or 0 = none) to (height, width, 3).

        Pixels without a measurement give NaN points.
        """
        depth = real_array(depth_m, "depth_m")
        if depth.shape != self.shape:
            raise InvalidInputError(
                f"depth image must have shape (height, width) = {self.shape}, got {depth.shape}"
            )
        depth = np.where(depth > 0.0, depth, np.nan)
        # ``rays * depth[..., None]`` bit for bit, multiplied per coordinate plane: a broadcast
        # over the last axis of 3 loops 3 elements at a time (twice as slow on 88×72 frames).
        points = np.empty((*self.shape, 3))
        np.multiply(_ray_planes_camera(self), depth, out=points.transpose(2, 0, 1))
        return points


@functools.lru_cache(maxsize=8)
def _ray_planes_camera(intrinsics: PinholeIntrinsics) -> NDArray[np.float64]:
    """(3, height, width) ray directions with unit z, one plane per coordinate (read-only)."""
    planes = np.ascontiguousarray(_ray_directions_camera(intrinsics).transpose(2, 0, 1))
    planes.flags.writeable = False
    return planes


@functools.lru_cache(maxsize=8)
def _ray_directions_camera(intrinsics: PinholeIntrinsics) -> NDArray[np.float64]:
    """:meth:`PinholeIntrinsics.ray_directions_camera`, computed (read-only, cached)."""
    u = (np.arange(intrinsics.width) - intrinsics.cx) / intrinsics.fx
    v = (np.arange(intrinsics.height) - intrinsics.cy) / intrinsics.fy
    uu, vv = np.meshgrid(u, v)
    rays = np.stack([uu, vv, np.ones_like(uu)], axis=-1)
    rays.flags.writeable = False
    return rays
