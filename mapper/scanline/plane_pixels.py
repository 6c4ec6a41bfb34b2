"""Each plane's fit and geometry from its labelled pixels (image frame in, camera frame out).

The pixels of a plane are its grown segments' (`mapper.scanline.planes`) and those filled in
beside them (`mapper.scanline.regions.fill_pixels`):

- `plane_fits`: each label's inverse-depth plane ``1/d = A·x + B·y + C`` (x, y normalised image
  coordinates; the plane table of `mapper.scanline.planes`) and its pixel count;
- `plane_refits`: the same on the pixels clear of outliers and of the sensor's range limit;
- `renumber_planes`: the planes kept, renumbered in creation order;
- `plane_moments`: each plane's centroid [m], covariance eigenvalues [m²] and footprint area
  [m²] in the camera frame.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from mapper.scanline.planes import _N_SUMS, _solve_plane

#: How far [sigma] inside the sensor's range limit a pixel's predicted inverse depth must lie for
#: `plane_refits` to count it: a pixel that far inside is lost to the cut with probability 0.13 %,
#: which moves the mean of those kept by 0.004 sigma.
RANGE_MARGIN_SIGMAS = 3.0


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy", inline="always")
def _accumulate_run(sums, p, inv_depth, x, yv, r, c, labels, keep, width):
    """Add a run's pixel moments to ``sums[p, :10]``; returns the column after the run.

    The run: the pixels labelled ``p`` from column c of row r on, those with ``keep[r, c]``
    counted. Summed in registers, starting from and going back to the plane's sums: the same
    additions in the same order as pixel by pixel into the array, without a store and a reload
    per sum and pixel. Inlined in numba IR: a call per run would take and drop a reference to
    each array argument (atomic NRT operations).
    """
    s0, s1, s2, s3, s4 = sums[p, 0], sums[p, 1], sums[p, 2], sums[p, 3], sums[p, 4]
    s5, s6, s7, s8, s9 = sums[p, 5], sums[p, 6], sums[p, 7], sums[p, 8], sums[p, 9]
    while c < width and labels[r, c] == p:
        if keep[r, c]:
            xv = x[c]
            z = inv_depth[r, c]
            s0 += 1.0
            s1 += xv
            s2 += yv
            s3 += xv * xv
            s4 += xv * yv
            s5 += yv * yv
            s6 += z
            s7 += xv * z
            s8 += yv * z
            s9 += z * z
        c += 1
    sums[p, 0], sums[p, 1], sums[p, 2], sums[p, 3], sums[p, 4] = s0, s1, s2, s3, s4
    sums[p, 5], sums[p, 6], sums[p, 7], sums[p, 8], sums[p, 9] = s5, s6, s7, s8, s9
    return c


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def plane_fits(inv_depth, x, y, labels, n_planes):
    """Inverse-depth plane (A, B, C) per label ``1/d = A·x + B·y + C`` and pixel counts.

    Returns:
        (P, 13) plane table (A, B, C, residual variance [1/m²], inverse normal matrix) and
        (P,) int64 pixel counts. Degenerate planes have NaN parameters.
    """
    height, width = labels.shape
    sums = np.zeros((n_planes, _N_SUMS))
    keep = labels >= 0
    for r in range(height):
        c = 0
        while c < width:
            p = labels[r, c]
            if p >= 0:
                c = _accumulate_run(sums, p, inv_depth, x, y[r], r, c, labels, keep, width)
            else:
                c += 1
    planes = np.full((n_planes, 13), np.nan)
    counts = np.zeros(n_planes, np.int64)
    for p in range(n_planes):
        counts[p] = int(sums[p, 0])
        _solve_plane(sums[p], planes[p])
    return planes, counts


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def plane_refits(inv_depth, x, y, labels, planes, factor, min_noise_m, min_inv_depth):
    """Refit each plane of `plane_fits` on its pixels clear of outliers and of the range limit.

    ``sigma`` of a pixel of plane ``p``: ``max(s_p, min_noise_m/d²)`` in inverse depth, ``s_p``
    the first fit's RMS residual (``planes[p, 3]`` is its square), the floor the depth-noise
    floor at its depth d (exact data has ``s_p ≈ 0``). A pixel counts if

    - its residual is at most ``factor·sigma`` (``factor`` 0: no outlier test): a few
      outlier pixels (a stereo matcher's edge fattening) no longer pull the normal;
    - its inverse depth predicted by the first fit lies ``RANGE_MARGIN_SIGMAS·sigma`` above
      ``min_inv_depth`` (1/the sensor's range limit; 0: none). A sensor cuts at its range on
      the *measured* depth, so near the limit only the pixels measured too near are there:
      the plane's far side reads near and its normal leans back (synthetic ground, 0.85 m,
      30° down, the stage's depth-mode errors, 4 m cut: the tilt 0.18 mrad off, camera height
      0.2 mm; without the cut 0.02 mrad). Whether a pixel that far inside was measured does
      not depend on its noise, so the pixels kept are unbiased.

    The labels and counts stay; only the parameters change. A plane whose pixels left are
    degenerate keeps its first fit; one that lost none gets it back bit for bit (same sums
    in the same order).

    Returns:
        (P, 13) plane table as `plane_fits`'s, refitted.
    """
    height, width = labels.shape
    n_planes = planes.shape[0]
    sums = np.zeros((n_planes, _N_SUMS))
    # The pixels counted, then their sums run by run (`_accumulate_run`).
    counted = np.zeros((height, width), np.bool_)
    for r in range(height):
        for c in range(width):
            p = labels[r, c]
            if p < 0 or math.isnan(planes[p, 0]):
                continue
            z = inv_depth[r, c]
            predicted = planes[p, 0] * x[c] + planes[p, 1] * y[r] + planes[p, 2]
            s_p = math.sqrt(planes[p, 3])
            floor = min_noise_m * predicted * predicted
            if predicted - RANGE_MARGIN_SIGMAS * max(s_p, floor) < min_inv_depth:
                continue
            if factor > 0.0 and abs(z - predicted) > factor * max(s_p, min_noise_m * z * z):
                continue
            counted[r, c] = True
    for r in range(height):
        c = 0
        while c < width:
            p = labels[r, c]
            if p >= 0:
                c = _accumulate_run(sums, p, inv_depth, x, y[r], r, c, labels, counted, width)
            else:
                c += 1
    refits = planes.copy()
    for p in range(n_planes):
        if not _solve_plane(sums[p], refits[p]):
            for k in range(planes.shape[1]):  # element-wise, as in plane_moments
                refits[p, k] = planes[p, k]
        # The residual variance stays the first fit's: the trimmed one underestimates the noise.
        refits[p, 3] = planes[p, 3]
    return refits


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def plane_moments(rays_camera, depth, pixel_index, ids, normals_camera, n_planes, fx, fy):
    """Per-plane geometry of labelled points.

    The points are the pixels' rays times their depths, taken here pixel by pixel (the same
    products as ``rays_camera[pixel_index] * depth.flat[pixel_index][:, None]``, without the
    (N, 3) array and its two gathers).

    Args:
        rays_camera: (H·W, 3) camera-frame rays with unit z, row-major.
        depth: (H, W) depths [m].
        pixel_index: (N,) the points' pixels, indices into the flattened image.
        ids: (N,) plane id per point (-1: none).
        normals_camera: (P, 3) unit plane normals in the camera frame.
        n_planes: P.
        fx: focal length along x [px].
        fy: focal length along y [px].

    Returns:
        centroids (P, 3) camera frame [m], covariance eigenvalues (P, 3) ascending [m²],
        footprint areas (P,) [m²] (pixel footprints on the plane, incidence capped at cos 0.1).
    """
    sums = np.zeros((n_planes, _N_SUMS + 3))
    areas = np.zeros(n_planes)
    depth_flat = depth.ravel()
    n_points = ids.shape[0]
    i = 0
    while i < n_points:
        p = ids[i]
        if p < 0:
            i += 1
            continue
        # A run of points of one plane is summed in registers, starting from and going back
        # to its sums: the same additions in the same order as point by point into the array.
        n, s1, s2, s3 = sums[p, 0], sums[p, 1], sums[p, 2], sums[p, 3]
        s4, s5, s6, s7, s8, s9 = (
            sums[p, 4],
            sums[p, 5],
            sums[p, 6],
            sums[p, 7],
            sums[p, 8],
            sums[p, 9],
        )
        ref_x, ref_y, ref_z = sums[p, 10], sums[p, 11], sums[p, 12]
        area = areas[p]
        n0, n1, n2 = normals_camera[p, 0], normals_camera[p, 1], normals_camera[p, 2]
        while i < n_points and ids[i] == p:
            pixel = pixel_index[i]
            i += 1
            d = depth_flat[pixel]
            cx = rays_camera[pixel, 0] * d
            cy = rays_camera[pixel, 1] * d
            cz = rays_camera[pixel, 2] * d
            if n == 0.0:  # the plane's first point: the reference the moments are taken about
                ref_x = cx
                ref_y = cy
                ref_z = cz
            px = cx - ref_x
            py = cy - ref_y
            pz = cz - ref_z
            n += 1.0
            s1 += px
            s2 += py
            s3 += pz
            s4 += px * px
            s5 += px * py
            s6 += px * pz
            s7 += py * py
            s8 += py * pz
            s9 += pz * pz
            rng = math.sqrt(cx * cx + cy * cy + cz * cz)
            cos_inc = abs(cx * n0 + cy * n1 + cz * n2) / rng
            # Solid angle of a pixel (depth²/(fx·fy)·cos³ of the off-axis angle) times range² …
            area += cz * cz * cz / (rng * fx * fy * max(cos_inc, 0.1))
        sums[p, 0], sums[p, 1], sums[p, 2], sums[p, 3] = n, s1, s2, s3
        sums[p, 4], sums[p, 5], sums[p, 6], sums[p, 7], sums[p, 8], sums[p, 9] = (
            s4,
            s5,
            s6,
            s7,
            s8,
            s9,
        )
        sums[p, 10], sums[p, 11], sums[p, 12] = ref_x, ref_y, ref_z
        areas[p] = area
    centroids = np.zeros((n_planes, 3))
    eigen = np.zeros((n_planes, 3))
    cov = np.empty((3, 3))
    for p in range(n_planes):
        row = sums[p]
        n = row[0]
        if n == 0.0:
            continue
        mx = row[1] / n
        my = row[2] / n
        mz = row[3] / n
        centroids[p, 0] = mx + row[10]
        centroids[p, 1] = my + row[11]
        centroids[p, 2] = mz + row[12]
        cov[0, 0] = row[4] / n - mx * mx
        cov[0, 1] = cov[1, 0] = row[5] / n - mx * my
        cov[0, 2] = cov[2, 0] = row[6] / n - mx * mz
        cov[1, 1] = row[7] / n - my * my
        cov[1, 2] = cov[2, 1] = row[8] / n - my * mz
        cov[2, 2] = row[9] / n - mz * mz
        values = np.linalg.eigvalsh(cov)
        for k in range(3):  # element-wise: a row assignment compiles a shape check (~1.5 s)
            eigen[p, k] = values[k]
    return centroids, eigen, areas


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def renumber_planes(labels, grown_labels, pixel_index, keep):
    """Planes kept renumbered in creation order, in one pass over the image.

    Args:
        labels: (H, W) plane of each pixel after the fill (-1 none, -2 no measurement).
        grown_labels: (H, W) the same before the fill (the grown segments only).
        pixel_index: (N,) the valid pixels' indices into the flattened image.
        keep: (P,) bool, the planes kept.

    Returns:
        (H, W) ``labels`` renumbered (a dissolved plane's pixels -1), (H, W) ``grown_labels``
        renumbered, (N,) the valid pixels' renumbered labels and (N,) grown labels, and the
        (K,) pixels of each kept plane (its valid pixels' labels).
    """
    n_planes = keep.shape[0]
    new_id = np.full(n_planes, -1, dtype=np.int64)
    n_kept = 0
    for p in range(n_planes):
        if keep[p]:
            new_id[p] = n_kept
            n_kept += 1
    height, width = labels.shape
    renumbered = np.empty((height, width), dtype=np.int64)
    grown = np.empty((height, width), dtype=np.int64)
    for r in range(height):
        for c in range(width):
            label = labels[r, c]
            renumbered[r, c] = new_id[label] if label >= 0 else label
            label = grown_labels[r, c]
            grown[r, c] = new_id[label] if label >= 0 else label
    n = pixel_index.shape[0]
    plane_ids = np.empty(n, dtype=np.int64)
    grown_ids = np.empty(n, dtype=np.int64)
    counts = np.zeros(n_kept, dtype=np.int64)
    for i in range(n):
        r = pixel_index[i] // width
        c = pixel_index[i] - r * width
        plane_ids[i] = renumbered[r, c]
        grown_ids[i] = grown[r, c]
        if plane_ids[i] >= 0:
            counts[plane_ids[i]] += 1
    return renumbered, grown, plane_ids, grown_ids, counts
