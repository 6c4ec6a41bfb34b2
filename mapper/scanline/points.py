"""The level stage's points in the tilt-corrected robot frame [m].

`level_geometry`: every pixel's ray, point and height noise [m] in the frame the level regions
are grown in (`mapper.scanline.levels`: heights are the points' z). `floor_points`: the valid
pixels' points, those on a floor moved along their rays onto its height (and those in no region
onto the ground height when they lie on it), with each one's floor height.
"""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def level_geometry(depth, unit_rays, rotation, origin, typical, min_noise_m):
    """Pixel rays, points and height noise in a rotated frame, for the horizontal model.

    Args:
        depth: (H, W) depths [m], NaN = none.
        unit_rays: (H·W, 3) camera-frame rays with unit z, row-major.
        rotation: 3×3 rotation from the camera frame to the frame.
        origin: (3,) camera centre in the frame [m].
        typical: (H, W) typical depth noise at each pixel's depth [m].
        min_noise_m: lower bound of the height noise [m].

    Returns:
        rays (H, W, 3) in the frame (unit optical-axis component), points (H, W, 3) [m] and
        sigma_z (H, W) [m] = max(typical·|ray_z|, min_noise_m) (depth noise lies along the
        ray); points and sigma_z NaN where there is no depth.
    """
    height, width = depth.shape
    rays = np.empty((height, width, 3))
    points = np.empty((height, width, 3))
    sigma_z = np.empty((height, width))
    for r in range(height):
        for c in range(width):
            i = r * width + c
            for k in range(3):
                rays[r, c, k] = (
                    rotation[k, 0] * unit_rays[i, 0]
                    + rotation[k, 1] * unit_rays[i, 1]
                    + rotation[k, 2] * unit_rays[i, 2]
                )
            d = depth[r, c]
            if d == d:
                for k in range(3):
                    points[r, c, k] = origin[k] + d * rays[r, c, k]
                sigma_z[r, c] = max(typical[r, c] * abs(rays[r, c, 2]), min_noise_m)
            else:
                for k in range(3):
                    points[r, c, k] = np.nan
                sigma_z[r, c] = np.nan
    return rays, points, sigma_z


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def floor_points(
    pixel_index,
    floor_labels,
    floor_of_region,
    ground_m,
    rays,
    depth,
    typical,
    origin,
    relabel_factor,
    snap_factor,
):
    """Corrected points and floor heights of the valid pixels (see `segment_depth`).

    A pixel in no level region (label -1; not even one that failed the floor tests: it has a
    height of its own) whose depth lies within ``relabel_factor`` sigma (``typical``) of where
    its ray meets the ground height ``ground_m`` becomes a ground point (ground_m NaN or factor
    0: none). A floor point whose ray meets its height going down within ``snap_factor`` sigma
    of its depth is moved there along the ray; one that does not loses its floor label (factor
    0: points stay, labels too). A pixel labelled -3 (a floor region's occluding border,
    `mapper.floor_borders.BORDER_LABEL`) is no floor and no ground point.

    ``pixel_index`` (N,) are the valid pixels' indices into the flattened image in ascending
    order (``np.flatnonzero``).

    Returns:
        (N, 3) points [m], (N,) floor heights [m] (NaN: not floor) and (N,) the pixels' floor
        regions (``np.take(floor_labels, pixel_index)``, read on the way).
    """
    n = pixel_index.shape[0]
    width = depth.shape[1]
    points = np.empty((n, 3))
    heights = np.full(n, np.nan)
    regions = np.empty(n, floor_labels.dtype)
    r = 0
    for i in range(n):
        # pixel_index ascends (row-major order): the row follows by steps, no division.
        while pixel_index[i] >= (r + 1) * width:
            r += 1
        c = pixel_index[i] - r * width
        d = depth[r, c]
        ray_z = rays[r, c, 2]
        tol = typical[r, c]
        f = floor_labels[r, c]
        regions[i] = f
        h = floor_of_region[f] if f >= 0 else np.nan
        if (
            f == -1
            and relabel_factor > 0.0
            and ground_m == ground_m
            and ray_z < 0.0
            and abs(d - (ground_m - origin[2]) / ray_z) <= relabel_factor * tol
        ):
            h = ground_m
        if h == h and snap_factor > 0.0:
            d_on = (h - origin[2]) / ray_z if ray_z < 0.0 else np.inf
            if abs(d - d_on) <= snap_factor * tol:
                d = d_on
            else:
                h = np.nan
        heights[i] = h
        for k in range(3):
            points[i, k] = origin[k] + d * rays[r, c, k]
    return points, heights, regions
