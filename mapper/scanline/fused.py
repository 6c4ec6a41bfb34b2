"""Each stage of the segmentation's scan-line grouping in one kernel call.

`plane_labels`: the planes stage of `mapper.segmentation.segment_depth` (noise, row segments,
planes grown and reassigned, their fits, pixels filled; image frame). `level_regions`: the floor
stage of `mapper.segmentation.floor_regions` (level regions grown, filled, measured and judged;
tilt-corrected robot frame). Each calls its stage's kernels in turn with the same arguments: one
dispatch and no intermediate arrays handed to Python, the same results bit for bit.
"""

from __future__ import annotations

import numba
import numpy as np

from mapper.scanline.floors import floor_segment_fit, floor_statistics, floor_verdict, foreign_rim
from mapper.scanline.levels import grow_floors, horizontal_sums, level_heights, split_level
from mapper.scanline.noise import local_noise_depth_m
from mapper.scanline.plane_pixels import plane_fits
from mapper.scanline.planes import grow_planes, reassign_segments, segment_sums
from mapper.scanline.regions import (
    _INVERSE_DEPTH_MODEL,
    _LEVEL_MODEL,
    fill_pixels,
    region_depth,
    region_interior,
    segment_labels,
)
from mapper.scanline.rows import propagate_breaks, split_rows
from mapper.scanline.steps import (
    CONFIDENCE_SIGMAS,
    MIN_STEP_M,
    SPLIT_BINS,
    SPLIT_DIRECTIONS,
    cut_segments,
    split_stepped_levels,
)


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def level_regions(
    z,
    sigma_z,
    points,
    rays,
    depth,
    seg_rows,
    seg_starts,
    seg_stops,
    origin_z,
    fx,
    fy,
    step_factor,
    min_segment_pixels,
    correlation,
    grow_factor,
    chi_factor,
    height_tolerance_m,
    seed_min_pixels,
    fill_factor,
    tolerance_floor_m,
    fill_passes,
    edge_margin_px,
    height_margin_px,
    snap_factor,
    min_plane_pixels,
    min_extent_m,
    max_slope,
    max_rms_ratio,
    max_segment_chi2,
    roughness_m,
    roughness_min_extent_m,
    step_split_t,
):
    """The floor stage of `mapper.segmentation.floor_regions` in one call (its kernels in turn).

    `split_level`, `horizontal_sums`, `grow_floors`, `segment_labels`, `level_heights`,
    `fill_pixels` (grown heights, no pixel fill without regions or passes),
    `split_stepped_levels` (with ``step_split_t`` > 0; the levels taken again), `region_interior`
    (edge margin), `region_depth` (height margin), `foreign_rim` (with ``snap_factor`` > 0),
    `floor_statistics`, `floor_segment_fit` and `floor_verdict`, with the same arguments: one
    dispatch and no intermediate arrays handed to Python (the same results bit for bit).

    Args:
        z: (H, W) C-contiguous heights of the pixels in the tilt-corrected frame [m].
        sigma_z: (H, W) their noise along z [m].
        points: (H, W, 3) the pixels' points in that frame [m] (NaN: no depth).
        rays: (H, W, 3) pixel rays in that frame with unit optical-axis component.
        depth: (H, W) measured depths [m], NaN = none.
        seg_rows: (S,) row of each row segment (`split_rows`, `propagate_breaks`).
        seg_starts: (S,) first column of each segment.
        seg_stops: (S,) column after the last of each segment.
        origin_z: z of the camera centre in that frame [m].
        fx: focal length along x [px] (pixel footprints).
        fy: focal length along y [px].
        step_factor: ``edge_sigma_factor`` (`split_level`).
        min_segment_pixels: shorter level pieces are no segments.
        correlation: ``noise_correlation_factor``.
        grow_factor: ``grow_sigma_factor`` (`grow_floors`).
        chi_factor: ``rms_sigma_factor`` (`grow_floors`).
        height_tolerance_m: ``floor_height_tolerance_m`` [m].
        seed_min_pixels: minimum length of each seed segment.
        fill_factor: ``fill_sigma_factor`` (`fill_pixels`).
        tolerance_floor_m: constant added to every tolerance [m].
        fill_passes: how many pixels deep leftover pixels may join a region.
        edge_margin_px: ``floor_edge_margin_px`` (`region_interior`).
        height_margin_px: ``floor_height_margin_px``.
        snap_factor: ``floor_snap_sigma_factor`` (`foreign_rim`; 0: no rim left out).
        min_plane_pixels: a floor's least pixels (`floor_verdict`).
        min_extent_m: ``min_plane_extent_m`` [m] (also `floor_segment_fit`'s prior extent).
        max_slope: tangent of ``floor_max_normal_angle_deg``.
        max_rms_ratio: ``floor_max_rms_ratio`` (0: no test).
        max_segment_chi2: ``floor_max_segment_chi2`` (0: no test).
        roughness_m: ``floor_roughness_m`` [m] (`floor_statistics`).
        roughness_min_extent_m: ``floor_roughness_min_extent_m`` [m].
        step_split_t: ``floor_step_split_t`` (`split_stepped_levels`; 0: no split).

    Returns:
        (H, W) floor region of each pixel (-1 none, -2 no measurement); per region (F,)
        pixel counts, heights [m], RMS ratios, (F, 2) extents [m], areas [m²] and is-floor.
    """
    level_rows, level_starts, level_stops = split_level(
        z, sigma_z, seg_rows, seg_starts, seg_stops, step_factor, min_segment_pixels, correlation
    )
    sums = horizontal_sums(points, sigma_z, level_rows, level_starts, level_stops, correlation)
    height, width = depth.shape
    floor_of_segment = grow_floors(
        level_rows,
        level_starts,
        level_stops,
        sums,
        height,
        grow_factor,
        chi_factor,
        height_tolerance_m,
        seed_min_pixels,
        correlation,
    )
    n_floors = np.int64(0)  # not a literal 0: one signature of the callees
    for i in range(floor_of_segment.shape[0]):
        n_floors = max(n_floors, floor_of_segment[i] + 1)
    measured = np.empty((height, width), np.bool_)
    for r in range(height):
        for c in range(width):
            measured[r, c] = np.isfinite(depth[r, c])
    grown = segment_labels(measured, level_rows, level_starts, level_stops, floor_of_segment)
    labels = grown
    grown_heights = level_heights(floor_of_segment, sums, n_floors)
    if n_floors > 0 and fill_passes > 0:
        labels = grown.copy()
        level_model = np.zeros((n_floors, 3))
        for f in range(n_floors):
            level_model[f, 2] = grown_heights[f]
        fill_pixels(
            z,
            np.zeros(width),
            np.zeros(height),
            labels,
            sigma_z,
            level_model,
            fill_factor,
            tolerance_floor_m,
            fill_passes,
            _LEVEL_MODEL,
        )
    if n_floors > 0 and step_split_t > 0.0:
        if fill_passes == 0:
            labels = grown.copy()  # not an alias: each is relabelled once
        split_floors = split_stepped_levels(
            labels,
            grown,
            points,
            sigma_z,
            n_floors,
            SPLIT_BINS,
            SPLIT_DIRECTIONS,
            step_split_t,
            MIN_STEP_M,
            min_plane_pixels,
            correlation,
            CONFIDENCE_SIGMAS,
        )
        if split_floors > n_floors:
            n_floors = split_floors
            level_rows, level_starts, level_stops, floor_of_segment = cut_segments(
                grown, level_rows, level_starts, level_stops, floor_of_segment
            )
            sums = horizontal_sums(
                points, sigma_z, level_rows, level_starts, level_stops, correlation
            )
            grown_heights = level_heights(floor_of_segment, sums, n_floors)
    interior = region_interior(labels, edge_margin_px)
    # The height comes from the pixels deepest inside, up to the margin; the rim a neighbouring
    # surface may have lent a region is its border ring (the margin's first pixel).
    height_depth = region_depth(labels, height_margin_px)
    if n_floors > 0 and snap_factor > 0.0:
        ring_inside = height_depth >= min(height_margin_px, 1)
        rim = foreign_rim(labels, ring_inside, z, sigma_z, grown_heights, snap_factor)
        interior = interior & ~rim
    counts, heights, rms, extents, areas, slope = floor_statistics(
        labels,
        grown,
        interior,
        height_depth,
        height_margin_px,
        points,
        sigma_z,
        depth,
        rays,
        origin_z,
        fx,
        fy,
        n_floors,
        tolerance_floor_m,
        roughness_m,
        roughness_min_extent_m,
    )
    chi2, n_segments = floor_segment_fit(
        sums, floor_of_segment, n_floors, height_tolerance_m, min_extent_m
    )
    is_floor = floor_verdict(
        counts,
        n_segments,
        extents,
        slope,
        rms,
        chi2,
        min_plane_pixels,
        min_extent_m,
        max_slope,
        max_rms_ratio,
        max_segment_chi2,
    )
    return labels, counts, heights, rms, extents, areas, is_floor


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def plane_labels(
    inv_depth,
    valid,
    cx,
    cy,
    fx,
    fy,
    noise_window,
    min_noise_m,
    noise_cap_factor,
    model_inv_sigma,
    split_factor,
    split_rms_factor,
    edge_window,
    edge_factor,
    tolerance_floor_m,
    min_segment_pixels,
    correlation,
    break_passes,
    break_factor,
    break_reach,
    grow_factor,
    rms_factor,
    seed_min_pixels,
    reassign_passes,
    fill_factor,
    fill_passes,
):
    """The planes stage of `mapper.segmentation.segment_depth` in one call (its kernels in turn).

    The columns' and rows' normalised image coordinates ``(i − c)/f``, `local_noise_depth_m`,
    `split_rows`, up to ``break_passes`` rounds of `propagate_breaks` (until a round splits
    nothing), `segment_sums`, `grow_planes`, `reassign_segments`, `segment_labels`,
    `plane_fits` and `fill_pixels` (with planes and passes), with the same arguments: one
    dispatch and no intermediate arrays handed to Python (the same results bit for bit).

    Args:
        inv_depth: (H, W) inverse depth [1/m] (NaN: none).
        valid: (H, W) bool, the measured pixels.
        cx: principal point column [px].
        cy: principal point row [px].
        fx: focal length along x [px].
        fy: focal length along y [px].
        noise_window: ``noise_window_px``.
        min_noise_m: ``min_noise_m`` [m].
        noise_cap_factor: ``noise_cap_factor``.
        model_inv_sigma: the stereo model's inverse-depth std [1/m] (0: none).
        split_factor: ``split_sigma_factor``.
        split_rms_factor: ``split_rms_sigma_factor``.
        edge_window: ``edge_window_px``.
        edge_factor: ``edge_sigma_factor``.
        tolerance_floor_m: ``tolerance_floor_m`` [m].
        min_segment_pixels: ``min_segment_pixels``.
        correlation: ``noise_correlation_factor``.
        break_passes: ``break_passes``.
        break_factor: ``break_sigma_factor``.
        break_reach: ``break_reach_px``.
        grow_factor: ``grow_sigma_factor``.
        rms_factor: ``rms_sigma_factor``.
        seed_min_pixels: ``seed_min_pixels``.
        reassign_passes: ``reassign_passes``.
        fill_factor: ``fill_sigma_factor``.
        fill_passes: ``fill_passes``.

    Returns:
        (W,) x and (H,) y of the columns and rows, (H, W) typical noise [m] (the range
        profile's, or the sensor model's), (H, W) local noise [m] (`local_noise_depth_m`),
        the (S,) rows, starts and stops of the row segments, (H, W) plane of each
        pixel after the fill and (H, W) before it (-1 none, -2 no measurement), the (P, 13)
        plane fits and (P,) their pixels (before the fill).
    """
    height, width = inv_depth.shape
    x = np.empty(width)
    for c in range(width):
        x[c] = (c - cx) / fx
    y = np.empty(height)
    for r in range(height):
        y[r] = (r - cy) / fy
    sigma, typical_sigma = local_noise_depth_m(
        inv_depth, noise_window, min_noise_m, noise_cap_factor, model_inv_sigma
    )
    seg_rows, seg_starts, seg_stops, seg_table = split_rows(
        inv_depth,
        x,
        sigma,
        split_factor,
        split_rms_factor,
        edge_window,
        edge_factor,
        tolerance_floor_m,
        min_segment_pixels,
        correlation,
    )
    # Rows to test in the next round of `propagate_breaks`: every row first, then those
    # next to (or in) a row that split (the others would split nothing again).
    check_rows = np.ones(height, np.bool_)
    for _ in range(break_passes):
        n_before = seg_rows.shape[0]
        seg_rows, seg_starts, seg_stops, seg_table, split_in = propagate_breaks(
            inv_depth,
            x,
            sigma,
            seg_rows,
            seg_starts,
            seg_stops,
            seg_table,
            check_rows,
            edge_window,
            break_factor,
            tolerance_floor_m,
            min_segment_pixels,
            break_reach,
            correlation,
        )
        if seg_rows.shape[0] == n_before:
            break
        for r in range(height):
            check_rows[r] = (
                split_in[r] or (r > 0 and split_in[r - 1]) or (r + 1 < height and split_in[r + 1])
            )
    seg_sums = segment_sums(inv_depth, x, y, seg_rows, seg_starts, seg_stops)
    plane_of_segment = grow_planes(
        inv_depth,
        x,
        y,
        seg_rows,
        seg_starts,
        seg_stops,
        seg_table,
        seg_sums,
        grow_factor,
        rms_factor,
        tolerance_floor_m,
        seed_min_pixels,
    )
    reassign_segments(
        inv_depth,
        x,
        y,
        seg_rows,
        seg_starts,
        seg_stops,
        seg_table,
        seg_sums,
        plane_of_segment,
        grow_factor,
        rms_factor,
        tolerance_floor_m,
        reassign_passes,
    )
    labels = segment_labels(valid, seg_rows, seg_starts, seg_stops, plane_of_segment)
    n_planes = np.int64(0)  # not a literal 0: one signature of the callees
    for i in range(plane_of_segment.shape[0]):
        n_planes = max(n_planes, plane_of_segment[i] + 1)
    plane_table, counts = plane_fits(inv_depth, x, y, labels, n_planes)
    grown_labels = labels.copy()
    if n_planes > 0 and fill_passes > 0:
        fill_pixels(
            inv_depth,
            x,
            y,
            labels,
            sigma,
            plane_table,
            fill_factor,
            tolerance_floor_m,
            fill_passes,
            _INVERSE_DEPTH_MODEL,
        )
    return (
        x,
        y,
        typical_sigma,
        sigma,
        seg_rows,
        seg_starts,
        seg_stops,
        labels,
        grown_labels,
        plane_table,
        counts,
    )
