"""A depth image's row segments, as `segment_depth` computes them before growing planes.

Shared by the tests of the planes stage's kernels (`scanline.grow_planes` and what follows it),
which start from the same calls: valid depth, local noise, row segments and their sums.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from mapper import scanline
from mapper.intrinsics import PinholeIntrinsics
from mapper.segmentation import SegmentationParams


class RowSegments(NamedTuple):
    """A frame's pixels and row segments (image frame; depths [m], inverse depths [1/m])."""

    valid: NDArray[np.bool_]
    depth: NDArray[np.float64]
    inv_depth: NDArray[np.float64]
    pixel_index: NDArray[np.int64]
    x: NDArray[np.float64]
    """(W,) normalised image x of the columns."""
    y: NDArray[np.float64]
    """(H,) normalised image y of the rows."""
    sigma: NDArray[np.float64]
    rows: NDArray[np.int64]
    starts: NDArray[np.int64]
    stops: NDArray[np.int64]
    table: NDArray[np.float64]
    sums: NDArray[np.float64]

    def grow_planes_args(self, params: SegmentationParams) -> tuple:
        """`scanline.grow_planes`' arguments, in its order."""
        return (
            self.inv_depth,
            self.x,
            self.y,
            self.rows,
            self.starts,
            self.stops,
            self.table,
            self.sums,
            params.grow_sigma_factor,
            params.rms_sigma_factor,
            params.tolerance_floor_m,
            params.seed_min_pixels,
        )


def row_segments(
    depth_m: NDArray[np.float64], intrinsics: PinholeIntrinsics, params: SegmentationParams
) -> RowSegments:
    """`segment_depth`'s calls from the depth image [m] to the row segments' moment sums."""
    p = params
    valid, depth, inv_depth, pixel_index = scanline.valid_depth(
        depth_m, p.min_depth_m, p.max_depth_m
    )
    x = (np.arange(intrinsics.width) - intrinsics.cx) / intrinsics.fx
    y = (np.arange(intrinsics.height) - intrinsics.cy) / intrinsics.fy
    sigma, _ = scanline.local_noise_depth_m(
        inv_depth, p.noise_window_px, p.min_noise_m, p.noise_cap_factor, 0.0
    )
    rows, starts, stops, table = scanline.split_rows(
        inv_depth,
        x,
        sigma,
        p.split_sigma_factor,
        p.split_rms_sigma_factor,
        p.edge_window_px,
        p.edge_sigma_factor,
        p.tolerance_floor_m,
        p.min_segment_pixels,
        p.noise_correlation_factor,
    )
    sums = scanline.segment_sums(inv_depth, x, y, rows, starts, stops)
    return RowSegments(
        valid, depth, inv_depth, pixel_index, x, y, sigma, rows, starts, stops, table, sums
    )
