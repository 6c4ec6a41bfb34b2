"""Each level region measured, and which are floors (tilt-corrected robot frame; heights [m]).

The regions are those grown by `mapper.scanline.levels`, filled (`mapper.scanline.regions`):

- `floor_statistics`: per region its pixels, height (a level fit in inverse depth,
  `_level_height`), RMS height residual in sigma units, footprint widths [m] and area [m²] and
  slope; the RMS and slope from its interior pixels (a stereo matcher's window blends a
  region's border with the neighbouring surface);
- `floor_segment_fit`: how well a plane fits each region's segment mean heights (reduced χ²);
- `foreign_rim`: a region's border pixels that belong to a neighbouring surface;
- `region_noise_ratio`: each region's local noise over the typical (the roughness test);
- `floor_verdict`: the regions that are floors.
"""

from __future__ import annotations

import math

import numba
import numpy as np


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def floor_segment_fit(seg_hsums, floor_of_segment, n_floors, tolerance_m, prior_extent_m):
    """Plane fits of every floor's segment mean heights (see `grow_floors`).

    Each floor's segments' mean heights are fitted by ``z = h + a·x + b·y`` (weights: their
    inverse squared standard errors, x and y the segments' weighted centroids relative to the
    floor's). The slopes have a prior of zero worth a floor ``prior_extent_m`` wide in every
    direction, so a floor a few rows deep does not get its slope across from noise.

    Returns:
        (F,) reduced chi² of the segment means about the plane, with ``tolerance_m`` added to
        every standard error (0 with fewer than 4 segments), and (F,) int64 segment counts.
    """
    n_seg = floor_of_segment.shape[0]
    w_sum = np.zeros(n_floors)
    x_sum = np.zeros(n_floors)
    y_sum = np.zeros(n_floors)
    n_segments = np.zeros(n_floors, np.int64)
    for i in range(n_seg):
        f = floor_of_segment[i]
        if f < 0:
            continue
        w = seg_hsums[i, 0]
        w_sum[f] += w
        x_sum[f] += seg_hsums[i, 4]
        y_sum[f] += seg_hsums[i, 5]
        n_segments[f] += 1
    # Normal equations of (h, a, b): sums of w·[1, x, y]ᵀ[1, x, y] and w·m·[1, x, y].
    normal = np.zeros((n_floors, 6))  # 11, 1x, 1y, xx, xy, yy
    right = np.zeros((n_floors, 3))
    for i in range(n_seg):
        f = floor_of_segment[i]
        if f < 0:
            continue
        w = seg_hsums[i, 0]
        m = seg_hsums[i, 1] / w
        x = seg_hsums[i, 4] / w - x_sum[f] / w_sum[f]
        y = seg_hsums[i, 5] / w - y_sum[f] / w_sum[f]
        normal[f, 0] += w
        normal[f, 1] += w * x
        normal[f, 2] += w * y
        normal[f, 3] += w * x * x
        normal[f, 4] += w * x * y
        normal[f, 5] += w * y * y
        right[f, 0] += w * m
        right[f, 1] += w * m * x
        right[f, 2] += w * m * y
    coefficients = np.zeros((n_floors, 3))
    for f in range(n_floors):
        s00 = normal[f, 0]
        s01 = normal[f, 1]
        s02 = normal[f, 2]
        s11 = normal[f, 3]
        s12 = normal[f, 4]
        s22 = normal[f, 5]
        ridge = s00 * prior_extent_m * prior_extent_m / 12.0
        s11 += ridge
        s22 += ridge
        c00 = s11 * s22 - s12 * s12
        c01 = s02 * s12 - s01 * s22
        c02 = s01 * s12 - s02 * s11
        det = s00 * c00 + s01 * c01 + s02 * c02
        if not det > 0.0:
            coefficients[f, 0] = right[f, 0] / s00
            continue
        c11 = s00 * s22 - s02 * s02
        c12 = s01 * s02 - s00 * s12
        c22 = s00 * s11 - s01 * s01
        r0 = right[f, 0]
        r1 = right[f, 1]
        r2 = right[f, 2]
        coefficients[f, 0] = (c00 * r0 + c01 * r1 + c02 * r2) / det
        coefficients[f, 1] = (c01 * r0 + c11 * r1 + c12 * r2) / det
        coefficients[f, 2] = (c02 * r0 + c12 * r1 + c22 * r2) / det
    chi2 = np.zeros(n_floors)
    for i in range(n_seg):
        f = floor_of_segment[i]
        if f < 0:
            continue
        w = seg_hsums[i, 0]
        x = seg_hsums[i, 4] / w - x_sum[f] / w_sum[f]
        y = seg_hsums[i, 5] / w - y_sum[f] / w_sum[f]
        residual = seg_hsums[i, 1] / w - (
            coefficients[f, 0] + coefficients[f, 1] * x + coefficients[f, 2] * y
        )
        chi2[f] += residual * residual / (1.0 / w + tolerance_m * tolerance_m)
    for f in range(n_floors):
        chi2[f] = chi2[f] / (n_segments[f] - 3) if n_segments[f] >= 4 else 0.0
    return chi2, n_segments


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def foreign_rim(labels, inside, z, sigma_z, level_heights, factor):
    """(H, W) bool: the floor regions' rim pixels of a neighbouring surface.

    Labelled pixels outside ``inside`` farther from their region's level than
    ``factor`` times their noise along z (`segmentation._foreign_rim`, in one pass).

    Args:
        labels: (H, W) floor region of each pixel (-1 none, -2 no measurement).
        inside: (H, W) bool, the pixels within their region's border ring (`region_depth`
            >= 1; every labelled pixel when ``floor_height_margin_px`` is 0).
        z: (H, W) the pixels' heights [m].
        sigma_z: (H, W) their noise along z [m].
        level_heights: (F,) each region's level [m].
        factor: the tolerance in sigma.
    """
    height, width = labels.shape
    out = np.zeros((height, width), np.bool_)
    for r in range(height):
        for c in range(width):
            f = labels[r, c]
            if f >= 0 and not inside[r, c]:
                out[r, c] = abs(z[r, c] - level_heights[f]) > factor * sigma_z[r, c]
    return out


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def floor_statistics(
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
    tolerance_m,
    roughness_m,
    roughness_min_extent_m,
):
    """Per-floor pixel statistics of the level regions.

    RMS and slope come from a region's *interior* pixels (`region_interior`) when it has any,
    else from all of them: a stereo matcher's window blends the pixels at a region's border
    with the neighbouring surface (a sill's far row reads 10-25 mm low, a tread's rows next to
    its riser too), which would count as roughness. The height comes from the grown pixels at
    least ``height_margin_px`` inside the region (``height_depth``, `region_depth`); a region
    with none (a narrow tread seen from afar) takes its deepest pixels, and only one without
    any pixel inside its border takes all: besides the blending, a region's border is where
    the growing selects one-sidedly (see `SegmentationParams.floor_height_margin_px`).

    Args:
        labels: (H, W) floor of each pixel after the fill (-1 none, -2 invalid).
        grown: (H, W) floor of each pixel before the fill (its segments').
        interior: (H, W) bool, the pixel is in its region's interior (`region_interior`).
        height_depth: (H, W) int, how deep inside its region each pixel lies, capped at
            ``height_margin_px`` (`region_depth` of ``labels``).
        height_margin_px: ``floor_height_margin_px``: the depth the height is taken from.
        points: (H, W, 3) points in the tilt-corrected robot frame [m].
        sigma_z: (H, W) their noise along z [m].
        depth: (H, W) measured depths [m].
        rays: (H, W, 3) rays in that frame with unit optical-axis component.
        origin_z: z of the camera centre [m].
        fx: focal length along x [px].
        fy: focal length along y [px].
        n_floors: F.
        tolerance_m: added to sigma_z for the RMS (exact data) [m].
        roughness_m: the surface's allowed unevenness, added to sigma_z (with
            ``tolerance_m``, in quadrature) for the RMS of regions whose minor extent is at
            least ``roughness_min_extent_m`` [m] (`SegmentationParams.floor_roughness_m`).
        roughness_min_extent_m: ``floor_roughness_min_extent_m`` [m].

    Returns:
        pixel counts (F,) int64, heights (F,) [m] (the grown pixels' level fit in inverse
        depth, `_level_height`), RMS height residual over all pixels (about the level fit of
        the same pixels) in units of sqrt(sigma_z² + tolerance_m²) (+ roughness_m², see
        above), squared residuals clipped at 9 (F,),
        footprint widths (F, 2) minor first [m] (sqrt(12)·std of the points moved onto the
        height along their rays) and footprint areas (F,) [m²] (pixel footprints on a
        horizontal plane, incidence capped at cos 0.1) and slopes (F,) ``|(a, b)|`` of the
        weighted fit ``z = h + a·x + b·y`` over the points moved onto the height (their x, y
        carry no depth noise).
    """
    height, width = labels.shape
    # Normal equations of the level model in inverse depth, q = ray_z·u with u = 1/(h − origin_z)
    # (see `_level_height`): Σw·ray_z², Σw·ray_z·q over the grown pixels: all of them, the
    # interior ones; and over those at each depth inside the region (0 .. height_margin_px).
    normal_sums = np.zeros((n_floors, 2, 2))
    depth_sums = np.zeros((n_floors, height_margin_px + 1, 2))
    has_interior = np.zeros(n_floors, np.bool_)
    for r in range(height):
        for c in range(width):
            f = labels[r, c]
            if f >= 0 and interior[r, c]:
                has_interior[f] = True
            f = grown[r, c]
            if f >= 0:
                ray_z = rays[r, c, 2]
                d = depth[r, c]
                # 1/σ² of the inverse depth: depth noise σ_z/|ray_z| along the ray, over d².
                w = (d * d * ray_z / sigma_z[r, c]) ** 2
                term_0 = w * ray_z * ray_z
                term_1 = w * ray_z / d
                normal_sums[f, 0, 0] += term_0  # all grown pixels
                normal_sums[f, 0, 1] += term_1
                if interior[r, c]:
                    normal_sums[f, 1, 0] += term_0
                    normal_sums[f, 1, 1] += term_1
                k = height_depth[r, c]
                if k > 0:
                    depth_sums[f, k, 0] += term_0
                    depth_sums[f, k, 1] += term_1
    heights = np.zeros(n_floors)
    rms_heights = np.zeros(n_floors)  # the reference of the RMS: its own pixels' level
    for f in range(n_floors):
        # The deepest pixels up to the margin (a level's sums hold the pixels at that depth).
        k = height_margin_px
        while k > 0 and not depth_sums[f, k, 0] > 0.0:
            k -= 1
        if k > 0:
            heights[f] = _level_height(depth_sums[f, k, 0], depth_sums[f, k, 1], origin_z)
        else:
            heights[f] = _level_height(normal_sums[f, 0, 0], normal_sums[f, 0, 1], origin_z)
        k = 1 if normal_sums[f, 1, 0] > 0.0 else 0
        rms_heights[f] = _level_height(normal_sums[f, k, 0], normal_sums[f, k, 1], origin_z)
    used = np.zeros(n_floors, np.int64)
    counts = np.zeros(n_floors, np.int64)
    square = np.zeros(n_floors)
    rough_square = np.zeros(n_floors)  # the same against the noise with the unevenness
    rough_variance = tolerance_m**2 + roughness_m**2
    rough = roughness_m > 0.0  # the second sum only when the allowance is on
    moments = np.zeros((n_floors, 5))  # x, y, xx, xy, yy of the points on the height
    fit = np.zeros((n_floors, 9))  # weighted sums for the slope: 1 x y xx xy yy z xz yz
    areas = np.zeros(n_floors)
    # A run of pixels of one region along a row is summed in registers, starting from and
    # going back to the region's sums: the same additions in the same order as summing each
    # pixel into the arrays, without a store and a reload per sum and pixel.
    for r in range(height):
        c = 0
        while c < width:
            f = labels[r, c]
            if f < 0:
                c += 1
                continue
            n_f = counts[f]
            used_f = used[f]
            square_f = square[f]
            rough_square_f = rough_square[f]
            m0, m1, m2, m3, m4 = (
                moments[f, 0],
                moments[f, 1],
                moments[f, 2],
                moments[f, 3],
                moments[f, 4],
            )
            f0, f1, f2, f3, f4 = fit[f, 0], fit[f, 1], fit[f, 2], fit[f, 3], fit[f, 4]
            f5, f6, f7, f8 = fit[f, 5], fit[f, 6], fit[f, 7], fit[f, 8]
            area_f = areas[f]
            no_interior = not has_interior[f]
            height_f = heights[f]
            rms_height_f = rms_heights[f]
            while c < width and labels[r, c] == f:
                n_f += 1
                sigma = sigma_z[r, c]
                residual = points[r, c, 2] - rms_height_f
                counted = interior[r, c] or no_interior
                if counted:
                    used_f += 1
                    # Clipped at 3 sigma: a row of riser pixels joined to a tread is no roughness.
                    square_f += min(residual * residual / (sigma * sigma + tolerance_m**2), 9.0)
                    if rough:
                        rough_square_f += min(
                            residual * residual / (sigma * sigma + rough_variance), 9.0
                        )
                ray_z = rays[r, c, 2]
                d = depth[r, c]
                d_on = (height_f - origin_z) / ray_z if ray_z != 0.0 else -1.0
                if not d_on > 0.0:
                    d_on = d
                x = points[r, c, 0] + (d_on - d) * rays[r, c, 0]
                y = points[r, c, 1] + (d_on - d) * rays[r, c, 1]
                m0 += x
                m1 += y
                m2 += x * x
                m3 += x * y
                m4 += y * y
                # Weighted fit z = h + a·x + b·y over (x, y) on the height: free of the depth
                # noise, which moves a point along its ray in z and x, y together.
                w = 1.0 / (sigma * sigma) if counted else 0.0
                dz = residual
                f0 += w
                f1 += w * x
                f2 += w * y
                f3 += w * x * x
                f4 += w * x * y
                f5 += w * y * y
                f6 += w * dz
                f7 += w * x * dz
                f8 += w * y * dz
                norm = math.sqrt(rays[r, c, 0] ** 2 + rays[r, c, 1] ** 2 + ray_z * ray_z)
                area_f += d * d / (fx * fy * max(abs(ray_z), 0.1 * norm))
                c += 1
            counts[f] = n_f
            used[f] = used_f
            square[f] = square_f
            rough_square[f] = rough_square_f
            moments[f, 0], moments[f, 1], moments[f, 2], moments[f, 3], moments[f, 4] = (
                m0,
                m1,
                m2,
                m3,
                m4,
            )
            fit[f, 0], fit[f, 1], fit[f, 2], fit[f, 3], fit[f, 4] = f0, f1, f2, f3, f4
            fit[f, 5], fit[f, 6], fit[f, 7], fit[f, 8] = f5, f6, f7, f8
            areas[f] = area_f
    rms = np.zeros(n_floors)
    extents = np.zeros((n_floors, 2))
    slope = np.zeros(n_floors)
    for f in range(n_floors):
        n = counts[f]
        if n == 0:
            continue
        rms[f] = math.sqrt(square[f] / used[f])
        slope[f] = _fit_slope(fit[f])
        mx = moments[f, 0] / n
        my = moments[f, 1] / n
        cxx = moments[f, 2] / n - mx * mx
        cxy = moments[f, 3] / n - mx * my
        cyy = moments[f, 4] / n - my * my
        half = 0.5 * (cxx + cyy)
        root = math.sqrt(0.25 * (cxx - cyy) ** 2 + cxy * cxy)
        extents[f, 0] = math.sqrt(12.0 * max(half - root, 0.0))
        extents[f, 1] = math.sqrt(12.0 * max(half + root, 0.0))
        if rough and extents[f, 0] >= roughness_min_extent_m:
            rms[f] = math.sqrt(rough_square[f] / used[f])
    return counts, heights, rms, extents, areas, slope


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _level_height(sum_ray_z2, sum_ray_z_q, origin_z):
    """Height [m] of a level surface from its pixels' normal equations in inverse depth.

    A pixel's ray (unit optical-axis component, z component ``ray_z``) meets the plane
    ``z = h`` at depth ``(h − origin_z)/ray_z``: its inverse depth ``q = ray_z·u`` is linear in
    ``u = 1/(h − origin_z)``. A stereo camera's noise is additive and unbiased in inverse depth
    (disparity), so the weighted least squares ``u = Σw·ray_z·q / Σw·ray_z²`` is unbiased,
    and ``h = origin_z + 1/u`` only by the square of u's standard error relative to u (a
    region of n pixels: about σ_q²/(n·q²)). A weighted mean of the points' z is not: their
    depth ``1/q`` is biased by ``d·(σ_q/q)²``, and weights ``1/σ_z²`` from the measured depths
    (σ_z ∝ d²) favour the points measured too near — on a ground 1-2.5 m away under the depth
    mode's noise 0.3 mm too high, which the ground shift passed to every other surface.

    Args:
        sum_ray_z2: Σw·ray_z² of the pixels (w: 1/σ² of their inverse depth).
        sum_ray_z_q: Σw·ray_z·q.
        origin_z: z of the camera centre [m].

    Returns:
        The height [m]; NaN without pixels (or with rays parallel to the plane only).
    """
    if not sum_ray_z2 > 0.0 or sum_ray_z_q == 0.0:
        return np.nan
    return origin_z + sum_ray_z2 / sum_ray_z_q


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _fit_slope(sums):
    """|(a, b)| of the weighted least squares ``z = h + a·x + b·y`` from sums (0 if singular)."""
    s0, sx, sy, sxx, sxy, syy, sz, sxz, syz = (
        sums[0],
        sums[1],
        sums[2],
        sums[3],
        sums[4],
        sums[5],
        sums[6],
        sums[7],
        sums[8],
    )
    # Centre x and y: the slope needs only the 2×2 system of the centred sums.
    cxx = sxx - sx * sx / s0
    cxy = sxy - sx * sy / s0
    cyy = syy - sy * sy / s0
    cxz = sxz - sx * sz / s0
    cyz = syz - sy * sz / s0
    det = cxx * cyy - cxy * cxy
    if not det > 1e-12 * max(cxx * cyy, 1e-300):
        return 0.0
    a = (cyy * cxz - cxy * cyz) / det
    b = (cxx * cyz - cxy * cxz) / det
    return math.hypot(a, b)


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def region_noise_ratio(labels, sigma, typical, n_regions):
    """(F,) mean of ``sigma / typical`` over each region's pixels (0 for a region without any).

    `mapper.segmentation.segment_depth`'s roughness test of the floors
    (`SegmentationParams.floor_max_noise_ratio`): ``sigma`` is the local noise estimate
    (`local_noise_depth_m`, from second differences of inverse depth in a box reaching
    ``noise_window_px`` columns and a row beyond the pixel, so also over pixels the region left
    out), ``typical`` the sensor model's (or the image's) noise at the same depth.

    Args:
        labels: (H, W) region of each pixel (-1 none, -2 no measurement).
        sigma: (H, W) local depth noise [m] (NaN: none).
        typical: (H, W) typical depth noise at the pixel's depth [m] (NaN: none).
        n_regions: F.
    """
    height, width = labels.shape
    total = np.zeros(n_regions)
    count = np.zeros(n_regions)
    for r in range(height):
        for c in range(width):
            f = labels[r, c]
            if f < 0:
                continue
            ratio = sigma[r, c] / typical[r, c]
            if ratio == ratio:  # not NaN
                total[f] += ratio
                count[f] += 1.0
    out = np.zeros(n_regions)
    for f in range(n_regions):
        if count[f] > 0.0:
            out[f] = total[f] / count[f]
    return out


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def floor_verdict(
    counts,
    n_segments,
    extents,
    slope,
    rms_ratio,
    chi2,
    min_pixels,
    min_extent_m,
    max_slope,
    max_rms_ratio,
    max_segment_chi2,
):
    """(F,) bool: the level regions that are floors (`mapper.segmentation.floor_regions`).

    At least ``min_pixels`` pixels in 3 or more segments, a minor extent of ``min_extent_m``,
    a slope of at most ``max_slope`` (tan), an RMS ratio of at most ``max_rms_ratio`` (0: no
    test) and a segment χ² of at most ``max_segment_chi2·min(1 + 3·sqrt(2/dof), 2.5)``,
    dof = max(segments − 3, 1) (0: no test).
    """
    n = counts.shape[0]
    is_floor = np.empty(n, dtype=np.bool_)
    for f in range(n):
        dof = max(n_segments[f] - 3, 1)
        is_floor[f] = (
            counts[f] >= min_pixels
            and n_segments[f] >= 3
            and extents[f, 0] >= min_extent_m
            and slope[f] <= max_slope
            and (max_rms_ratio == 0.0 or rms_ratio[f] <= max_rms_ratio)
            and (
                max_segment_chi2 == 0.0
                or chi2[f] <= max_segment_chi2 * min(1.0 + 3.0 * math.sqrt(2.0 / dof), 2.5)
            )
        )
    return is_floor
