"""Floor pixels on the near side of an occluding edge: not floor (beyond Gutmann et al.).

A stereo matcher's window blends the pixels on either side of an edge; where a nearer surface
occludes a farther one (a raised surface's side or far edge against the ground behind it), the
nearer surface's disparity spreads over the farther one's first pixels ("foreground
fattening", about one output pixel for fogsim's stereo head: its 5 render px window is 2.5
output pixels). Those pixels join the nearer surface's floor region at its height, a pixel past
its true edge — 1.4 cm at 1.5 m, 2.3 cm at 2.5 m — and put its floor a cell past its side edges,
where no ray refutes it (the ground there is hidden or out of view). On the shipped stereo
suite (seeds 1–8) that was most of `stairs`' and `talos_course`'s unsafe cells: the row of
ground beside the staircase's side edge at the treads' and the platform's heights, with 40
frame votes, 100–650 rays ending there and 0–10 passing (`stairs` seed 1), carried there by
the fattening and by the heading's error (which this does not touch).

:func:`occluding_border` takes those pixels out of their floor: a pixel of a floor region with a
pixel of another label (another region, or none) within ``px`` pixels along its row or column
that is farther by more than ``jump`` in inverse depth. They keep their points (the occupancy
grid still gets their hits) but lose the floor label, and, unlike a pixel in no region, are
never made ground points: :data:`BORDER_LABEL`. A riser seen from below (a crease: the surfaces
meet) and the near edge of a surface (the ground before it is nearer) keep their pixels.
`mapper.segmentation.segment_depth` applies it with
``SegmentationParams.floor_occluding_border_px`` (off by default; the measurements are there)
and marks the same pixels as the heading's structure with ``structure_border_px`` (the stereo
head's default). A numba kernel (the stereo head's warm-up group, `fogsim.run.warmup`).
"""

from __future__ import annotations

import numba
import numpy as np
from numpy.typing import NDArray

BORDER_LABEL = -3
"""The label of a floor region's occluding border pixel (`occluding_border`): no region, and
never made a ground point (`mapper.scanline.points.floor_points`; ``-1`` is "no region",
``-2`` "no measurement" in `SegmentationResult.labels_image`)."""


def occluding_border(
    labels: NDArray[np.integer],
    inv_depth: NDArray[np.floating],
    floor_level_m: NDArray[np.floating],
    px: int,
    jump: float,
    rows_only: bool = False,
) -> NDArray[np.integer]:
    """``labels`` with the floor regions' occluding border pixels set to :data:`BORDER_LABEL`.

    Args:
        labels: (H, W) pixel labels: a region's index, negative for none.
        inv_depth: (H, W) inverse depth [1/m], NaN where there is no measurement.
        floor_level_m: (R,) each region's floor height [m], NaN for a region that is no floor.
        px: How far a farther pixel of another label may lie [px], along the row or column.
        jump: How much farther it must be, in inverse depth [1/m].
        rows_only: Look along the row only: the borders beside a surface's side edges, not
            those before its far edge (a column's farther pixel).

    Returns:
        (H, W) labels (a new array; ``labels`` unchanged).
    """
    labels = np.asarray(labels)
    marked = _marked_borders(
        np.ascontiguousarray(labels, dtype=np.int64),
        np.ascontiguousarray(inv_depth, dtype=np.float64),
        np.isfinite(np.asarray(floor_level_m, dtype=np.float64)),
        px,
        jump,
        bool(rows_only),
    )
    return marked.astype(labels.dtype, copy=False)


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _marked_borders(labels, inv_depth, floor_region, px, jump, rows_only):
    """A copy of ``labels`` with :data:`BORDER_LABEL` on the floors' occluding border pixels.

    Marked: a pixel of a region whose ``floor_region`` is set with a pixel of another label up to
    ``px`` pixels along its row or column (``rows_only``: its row) whose inverse depth is lower
    by more than ``jump`` (NaN on either side: no edge). One pass over the pixels, the same
    comparisons as the numpy form it replaced (four shifted array compares a step):
    `occluding_border` 73 → 29 µs a frame on `stairs` stereo seed 1's (every 4th, the wall
    median of 3 passes over the 56 calls).
    """
    height, width = labels.shape
    marked = labels.copy()
    for r in range(height):
        for c in range(width):
            label = labels[r, c]
            if label < 0 or not floor_region[label]:
                continue
            here = inv_depth[r, c]
            found = False
            for step in range(1, px + 1):
                for n, (rr, cc) in enumerate(
                    ((r, c + step), (r, c - step), (r + step, c), (r - step, c))
                ):
                    # The compare is false when either is NaN (no measurement): no edge.
                    if (
                        (n < 2 or not rows_only)
                        and 0 <= rr < height
                        and 0 <= cc < width
                        and labels[rr, cc] != label
                        and here - inv_depth[rr, cc] > jump
                    ):
                        found = True
                if found:
                    marked[r, c] = BORDER_LABEL
                    break
    return marked
