"""Synthetic depth images of boxes, steps and rough tops on a flat floor, for tests and benches.

Rendering is exact ray casting in numpy (no MuJoCo): every pixel ray of an OpenCV pinhole camera
(x right, y down, z forward) is intersected with the ground plane ``z = ground_z_m`` and with
every box (slab method in the box's own yawed frame); the nearest hit wins. A box with a rough
top carries a smooth random height field on its top face; the hit on it is found by marching along
the ray through the bump layer and bisecting the first crossing (exact to far below 0.1 mm;
rays entering through a side face ignore bumps reaching above the top edge). World frame: z up.

Typical use::

    intr = PinholeIntrinsics.from_fov(88, 72, 47.0, 39.0)
    cam = look_down_camera((0.0, 0.0, 0.9), pitch_down_deg=30.0)
    boxes = staircase(x_start_m=1.2, steps_m=(0.031, 0.061, 0.094), platform_m=0.122)
    scene = render_scene(intr, cam, boxes)          # depth, hit box, true points
    depth = add_depth_noise(scene.depth_m, 0.01, np.random.default_rng(0))
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from mapper.intrinsics import PinholeIntrinsics

GROUND = -1
"""`Rendering.box_index` value of pixels that see the ground."""
NOTHING = -2
"""`Rendering.box_index` value of pixels that see nothing (NaN depth)."""


@dataclass(frozen=True)
class Box:
    """A box standing in the world (yaw about z only).

    Attributes:
        center_xy_m: (x, y) of the footprint centre [m].
        size_m: (x, y, z) extent in the box frame [m].
        yaw_deg: rotation about the world z axis [deg].
        base_z_m: z of the bottom face [m] (0: standing on the ground).
        rough_amplitude_m: 0 for a flat top; else the peak amplitude of the top's bumps [m].
        rough_wavelength_m: spatial wavelength of the bumps [m].
        rough_seed: seed of the bumps' random phases and directions (or heights).
        rough_grid_m: 0 for the smooth bumps above; else the top is a height field like
            fogsim's rough tops (`fogsim.sim.scene.rough_elevation`): heights drawn uniformly
            within ±``rough_amplitude_m`` on a grid this far apart [m], bilinear between.
    """

    center_xy_m: tuple[float, float]
    size_m: tuple[float, float, float]
    yaw_deg: float = 0.0
    base_z_m: float = 0.0
    rough_amplitude_m: float = 0.0
    rough_wavelength_m: float = 0.12
    rough_seed: int = 0
    rough_grid_m: float = 0.0

    @property
    def top_z_m(self) -> float:
        """z of the (mean) top face [m]."""
        return self.base_z_m + self.size_m[2]

    def top_bumps_m(self, x_local: NDArray, y_local: NDArray) -> NDArray[np.float64]:
        """Height of the rough top above the flat top at box-frame (x, y) [m]; 0 if flat."""
        if self.rough_amplitude_m == 0.0:
            return np.zeros(np.broadcast(x_local, y_local).shape)
        if self.rough_grid_m > 0.0:
            return self._grid_bumps_m(x_local, y_local)
        rng = np.random.default_rng(self.rough_seed)
        angles = rng.uniform(0.0, np.pi, 3)
        phases = rng.uniform(0.0, 2.0 * np.pi, 3)
        k = 2.0 * np.pi / self.rough_wavelength_m
        total = np.zeros(np.broadcast(x_local, y_local).shape)
        for angle, phase in zip(angles, phases, strict=True):
            total += np.sin(k * (np.cos(angle) * x_local + np.sin(angle) * y_local) + phase)
        return self.rough_amplitude_m * total / 3.0

    def _grid_bumps_m(self, x_local: NDArray, y_local: NDArray) -> NDArray[np.float64]:
        """The height-field bumps (``rough_grid_m`` > 0), bilinear in the grid's cells [m]."""
        step = self.rough_grid_m
        nx = math.ceil(self.size_m[0] / step) + 1
        ny = math.ceil(self.size_m[1] / step) + 1
        rng = np.random.default_rng(self.rough_seed)
        heights = rng.uniform(-self.rough_amplitude_m, self.rough_amplitude_m, (nx, ny))
        u = np.clip((np.asarray(x_local) + 0.5 * self.size_m[0]) / step, 0.0, nx - 1.0)
        v = np.clip((np.asarray(y_local) + 0.5 * self.size_m[1]) / step, 0.0, ny - 1.0)
        i = np.minimum(np.floor(u).astype(np.int64), nx - 2)
        j = np.minimum(np.floor(v).astype(np.int64), ny - 2)
        a, b = u - i, v - j
        return (
            (1 - a) * (1 - b) * heights[i, j]
            + a * (1 - b) * heights[i + 1, j]
            + (1 - a) * b * heights[i, j + 1]
            + a * b * heights[i + 1, j + 1]
        )


@dataclass(frozen=True)
class Rendering:
    """What one synthetic camera sees.

    Attributes:
        depth_m: (H, W) depth along the optical axis [m], NaN where nothing is hit.
        box_index: (H, W) index into the box list, `GROUND` or `NOTHING`.
        on_top: (H, W) True where the hit is on a box's top face (or the ground).
        points_world: (H, W, 3) true hit points [m], NaN where nothing is hit.
    """

    depth_m: NDArray[np.float64]
    box_index: NDArray[np.int64]
    on_top: NDArray[np.bool_]
    points_world: NDArray[np.float64]

    def true_floor_height_m(self, boxes: Sequence[Box], ground_z_m: float = 0.0) -> NDArray:
        """(H, W) true height of the flat horizontal surface each pixel sees, NaN otherwise.

        Pixels on box sides and on rough tops are NaN.
        """
        heights = np.full(self.depth_m.shape, np.nan)
        heights[self.box_index == GROUND] = ground_z_m
        for i, box in enumerate(boxes):
            if box.rough_amplitude_m == 0.0:
                heights[(self.box_index == i) & self.on_top] = box.top_z_m
        return heights


def look_down_camera(
    position_m: Sequence[float],
    pitch_down_deg: float,
    yaw_deg: float = 0.0,
    roll_deg: float = 0.0,
) -> NDArray[np.float64]:
    """4×4 camera-to-world transform of an OpenCV camera looking along +x, tilted down.

    Args:
        position_m: camera centre (x, y, z) in the world [m].
        pitch_down_deg: angle of the optical axis below the horizon [deg].
        yaw_deg: heading of the optical axis about world z [deg] (0: along +x).
        roll_deg: rotation about the optical axis [deg].

    Returns:
        The 4×4 homogeneous transform mapping camera-frame points to world points.
    """
    # Level camera looking along +x: camera x -> -world y, camera y -> -world z, z -> world x.
    level = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
    rotation = _rot_z(math.radians(yaw_deg)) @ _rot_y(math.radians(pitch_down_deg)) @ level
    rotation = rotation @ _rot_z(math.radians(roll_deg))  # roll about the optical (z) axis
    transform = np.eye(4)
    transform[:3, :3] = rotation
    transform[:3, 3] = np.asarray(position_m, dtype=np.float64)
    return transform


def staircase(
    x_start_m: float = 1.2,
    steps_m: Sequence[float] = (0.031, 0.061, 0.094),
    platform_m: float = 0.122,
    tread_m: float = 0.2,
    platform_depth_m: float = 0.6,
    width_m: float = 0.8,
    center_y_m: float = 0.0,
) -> list[Box]:
    """Boxes of a straight staircase climbing along +x to a platform (the paper's Table I).

    Args:
        x_start_m: x of the first riser [m].
        steps_m: top heights of the steps [m], increasing.
        platform_m: top height of the platform [m].
        tread_m: depth of each step along x [m].
        platform_depth_m: depth of the platform along x [m].
        width_m: width along y [m].
        center_y_m: y of the staircase centre line [m].

    Returns:
        One `Box` per step and one for the platform, all standing on the ground.
    """
    boxes = []
    x = x_start_m
    for height in steps_m:
        boxes.append(Box((x + tread_m / 2, center_y_m), (tread_m, width_m, height)))
        x += tread_m
    boxes.append(
        Box((x + platform_depth_m / 2, center_y_m), (platform_depth_m, width_m, platform_m))
    )
    return boxes


def render_scene(
    intrinsics: PinholeIntrinsics,
    transform_camera_to_world: NDArray[np.float64],
    boxes: Sequence[Box] = (),
    *,
    ground_z_m: float = 0.0,
    max_range_m: float = 10.0,
) -> Rendering:
    """Ray-cast the ground plane and the boxes.

    Args:
        intrinsics: pinhole intrinsics of the camera.
        transform_camera_to_world: 4×4 camera pose (OpenCV optical frame) in the world.
        boxes: boxes in the scene.
        ground_z_m: height of the infinite ground plane [m].
        max_range_m: hits farther than this along the ray [m] count as no measurement.

    Returns:
        The `Rendering` (depth, which box each pixel sees, true points).
    """
    transform = np.asarray(transform_camera_to_world, dtype=np.float64)
    rays_camera = intrinsics.ray_directions_camera()  # unit z: t along the ray is depth [m]
    rays = rays_camera @ transform[:3, :3].T
    origin = transform[:3, 3]
    shape = rays.shape[:2]
    best_t = np.full(shape, np.inf)
    box_index = np.full(shape, NOTHING, dtype=np.int64)
    on_top = np.zeros(shape, dtype=bool)

    with np.errstate(divide="ignore", invalid="ignore"):
        t_ground = (ground_z_m - origin[2]) / rays[..., 2]
    hit = (rays[..., 2] < 0.0) & (t_ground > 0.0)
    best_t[hit] = t_ground[hit]
    box_index[hit] = GROUND
    on_top[hit] = True

    for i, box in enumerate(boxes):
        t_hit, top = _intersect_box(origin, rays, box)
        closer = t_hit < best_t
        best_t[closer] = t_hit[closer]
        box_index[closer] = i
        on_top[closer] = top[closer]

    far = np.isfinite(best_t) & (best_t * np.linalg.norm(rays, axis=-1) > max_range_m)
    best_t[far] = np.inf
    box_index[far] = NOTHING
    depth = np.where(np.isfinite(best_t), best_t, np.nan)
    points = origin + rays * depth[..., None]
    return Rendering(depth, box_index, on_top, points)


def render_boxes(
    intrinsics: PinholeIntrinsics,
    transform_camera_to_world: NDArray[np.float64],
    boxes: Sequence[Box] = (),
    *,
    ground_z_m: float = 0.0,
    max_range_m: float = 10.0,
) -> NDArray[np.float64]:
    """Depth image [m] (NaN = no hit) of boxes on a ground plane; see `render_scene`."""
    return render_scene(
        intrinsics,
        transform_camera_to_world,
        boxes,
        ground_z_m=ground_z_m,
        max_range_m=max_range_m,
    ).depth_m


def add_depth_noise(
    depth_m: NDArray[np.floating],
    relative_sigma: float,
    rng: np.random.Generator,
    quadratic_sigma_per_m: float = 0.0,
) -> NDArray[np.float64]:
    """Depth with Gaussian noise of std ``relative_sigma·d + quadratic_sigma_per_m·d²`` [m]."""
    depth = np.asarray(depth_m, dtype=np.float64)
    sigma = relative_sigma * depth + quadratic_sigma_per_m * depth**2
    noise = rng.standard_normal(depth.shape)
    return depth + np.where(np.isfinite(depth), sigma * noise, 0.0)


def add_stereo_noise(
    depth_m: NDArray[np.floating],
    focal_baseline_px_m: float,
    disparity_noise_px: float,
    correlation_px: float,
    rng: np.random.Generator,
) -> NDArray[np.float64]:
    """Depth through a stereo camera's disparity noise: ``d = f·b/z`` plus correlated noise.

    The noise field is white Gaussian noise smoothed by a normalised Gaussian kernel of std
    ``correlation_px`` (as a matcher's window smooths it) and rescaled to the std
    ``disparity_noise_px``; the depth error then grows with z² (``σ_z = z²·σ_d/(f·b)``).
    """
    depth = np.asarray(depth_m, dtype=np.float64)
    noise = rng.standard_normal(depth.shape)
    if correlation_px > 0.0:
        half = math.ceil(3.0 * correlation_px)
        kernel = np.exp(-0.5 * (np.arange(-half, half + 1) / correlation_px) ** 2)
        kernel /= kernel.sum()
        for axis in (0, 1):
            padded = np.pad(
                noise, [(half, half) if a == axis else (0, 0) for a in (0, 1)], "reflect"
            )
            noise = np.apply_along_axis(np.convolve, axis, padded, kernel, mode="valid")
        noise /= np.sum(kernel**2)  # a 2D kernel's root sum of squares: |k|₂² per axis
    disparity = focal_baseline_px_m / depth + disparity_noise_px * noise
    return np.where(disparity > 0.0, focal_baseline_px_m / disparity, np.nan)


def _intersect_box(
    origin: NDArray[np.float64], rays: NDArray[np.float64], box: Box
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Ray parameter t of the first hit on a box (inf if none) and whether it is on the top."""
    yaw = math.radians(box.yaw_deg)
    to_local = _rot_z(-yaw)
    center = np.array([box.center_xy_m[0], box.center_xy_m[1], box.base_z_m + box.size_m[2] / 2])
    o = to_local @ (origin - center)
    r = rays @ to_local.T
    half = np.asarray(box.size_m, dtype=np.float64) / 2.0
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / r
        t1 = (-half - o) * inv
        t2 = (half - o) * inv
    t_lo = np.where(np.isnan(t1), -np.inf, np.minimum(t1, t2))
    t_hi = np.where(np.isnan(t1), np.inf, np.maximum(t1, t2))
    # A ray parallel to a slab and outside it never hits.
    outside = (r == 0.0) & (np.abs(o) > half)
    t_near = t_lo.max(axis=-1)
    t_far = t_hi.min(axis=-1)
    entry_axis = t_lo.argmax(axis=-1)
    hit = (t_near <= t_far) & (t_near > 0.0) & ~outside.any(axis=-1)
    t_hit = np.where(hit, t_near, np.inf)
    top = hit & (entry_axis == 2) & (r[..., 2] < 0.0)
    if box.rough_amplitude_m > 0.0 and top.any():
        t_hit = t_hit.copy()
        t_hit[top] = _march_rough_top(o, r[top], half[2], box)
    return t_hit, top


def _march_rough_top(
    origin_local: NDArray[np.float64], rays_local: NDArray[np.float64], half_z: float, box: Box
) -> NDArray[np.float64]:
    """First crossing of rays (box frame, r_z < 0) with the bumpy top: march, then bisect."""
    amplitude = box.rough_amplitude_m
    r_z = rays_local[:, 2]
    t_start = (half_z + amplitude - origin_local[2]) / r_z
    t_stop = (half_z - amplitude - origin_local[2]) / r_z

    def above(t: NDArray[np.float64]) -> NDArray[np.bool_]:
        x = origin_local[0] + t * rays_local[:, 0]
        y = origin_local[1] + t * rays_local[:, 1]
        z = origin_local[2] + t * r_z
        return z > half_z + box.top_bumps_m(x, y)

    steps = 200
    t_lo = t_start.copy()
    t_hi = t_stop.copy()
    found = np.zeros(t_start.shape, dtype=bool)
    for k in range(1, steps + 1):
        t = t_start + (t_stop - t_start) * k / steps
        first = ~found & ~above(t)
        t_hi[first] = t[first]
        t_lo[first] = (t_start + (t_stop - t_start) * (k - 1) / steps)[first]
        found |= first
    for _ in range(40):
        mid = 0.5 * (t_lo + t_hi)
        is_above = above(mid)
        t_lo = np.where(is_above, mid, t_lo)
        t_hi = np.where(is_above, t_hi, mid)
    return 0.5 * (t_lo + t_hi)


def _rot_z(angle_rad: float) -> NDArray[np.float64]:
    c, s = math.cos(angle_rad), math.sin(angle_rad)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _rot_y(angle_rad: float) -> NDArray[np.float64]:
    c, s = math.cos(angle_rad), math.sin(angle_rad)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


@dataclass(frozen=True)
class FloorLabelQuality:
    """How well per-pixel plane and floor labels match a `Rendering`'s ground truth.

    Attributes:
        floor_pixels: pixels that truly see a flat horizontal surface (ground or flat top).
        right_plane_fraction: share of those labelled floor with a plane whose majority
            surface is the pixel's own surface.
        median_height_error_m: median |label − true height| over true floor pixels labelled
            floor [m].
        max_height_error_m: the largest such error [m].
        false_floor_pixels: pixels labelled floor that see no flat surface (sides, rough).
        worst_merge_share: over planes, the largest share of a plane's floor-surface pixels
            that belong to its second surface, if that has at least 5 pixels (0: no plane
            spans two surfaces).
    """

    floor_pixels: int
    right_plane_fraction: float
    median_height_error_m: float
    max_height_error_m: float
    false_floor_pixels: int
    worst_merge_share: float


def floor_label_quality(
    rendering: Rendering,
    boxes: Sequence[Box],
    plane_image: NDArray[np.integer],
    floor_height_image: NDArray[np.floating],
    ground_z_m: float = 0.0,
    measured: NDArray[np.bool_] | None = None,
) -> FloorLabelQuality:
    """Score (H, W) plane ids (-1 none) and floor heights (NaN = not floor) against the truth.

    Only pixels in ``measured`` count (default: every pixel that sees something), so that
    pixels dropped from the depth image before segmentation are not counted as misses.
    """
    true_height = rendering.true_floor_height_m(boxes, ground_z_m)
    surface = np.where(rendering.box_index == GROUND, 0, rendering.box_index + 1)
    surface = np.where(np.isfinite(true_height), surface, -1)
    if measured is not None:
        surface = np.where(measured, surface, -1)
    on_floor = surface >= 0
    labelled = np.isfinite(floor_height_image)
    planes = np.where(plane_image >= 0, plane_image, -1)
    n_planes = int(planes.max(initial=-1)) + 1
    n_surfaces = len(boxes) + 1
    table = np.zeros((max(n_planes, 1), n_surfaces), dtype=np.int64)
    both = on_floor & (planes >= 0)
    np.add.at(table, (planes[both], surface[both]), 1)
    majority = table.argmax(axis=1)
    right = on_floor & labelled & (planes >= 0)
    right &= majority[np.maximum(planes, 0)] == surface
    errors = np.abs(floor_height_image - true_height)[on_floor & labelled]
    sorted_counts = np.sort(table, axis=1)
    totals = np.maximum(table.sum(axis=1), 1)
    if n_surfaces > 1:  # a second surface counts from 5 pixels on (not a stray edge pixel)
        second = np.where(sorted_counts[:, -2] >= 5, sorted_counts[:, -2], 0) / totals
    else:
        second = np.zeros(len(table))
    return FloorLabelQuality(
        floor_pixels=int(on_floor.sum()),
        right_plane_fraction=float(right.sum() / max(on_floor.sum(), 1)),
        median_height_error_m=float(np.median(errors)) if errors.size else float("nan"),
        max_height_error_m=float(errors.max()) if errors.size else float("nan"),
        false_floor_pixels=int((labelled & ~on_floor & np.isfinite(rendering.depth_m)).sum()),
        worst_merge_share=float(second.max()) if n_planes else 0.0,
    )
