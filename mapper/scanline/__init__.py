"""Numba kernels of scan-line grouping (after Jiang & Bunke) on a depth image.

`mapper.segmentation` calls them, each stage mostly through one fused kernel. The stages, one
module each (frames and units in each module's doc):

1. `noise`: the measured pixels (`valid_depth`) and the local depth noise (`local_noise_depth_m`).
2. `rows`: every image row cut into straight segments in inverse depth (`split_rows`,
   `propagate_breaks`).
3. `planes`: planes grown over the row segments in the image's inverse-depth model
   (`segment_sums`, `grow_planes`, `reassign_segments`); `plane_pixels`: each plane's fit and
   geometry from its pixels (`plane_fits`, `plane_refits`, `plane_moments`, `renumber_planes`).
4. `levels`: level regions grown over the row segments in the horizontal model ``z = h``
   (`split_level`, `horizontal_sums`, `grow_floors`, `level_heights`); `floors`: each one
   measured and judged (`floor_statistics`, `floor_segment_fit`, `floor_verdict`, ...);
   `points`: the points in the tilt-corrected frame, and those on floors moved onto them
   (`level_geometry`, `floor_points`).
   `steps`: a level region that is two levels joined over a step its rows could not see, split
   (`split_stepped_levels`, `cut_segments`; ``floor_step_split_t``, off by default).
5. `fused`: each stage's kernels in one call (`plane_labels`, `level_regions`).

`regions` holds what the planes and the level regions share: which row segments touch, the
label image (`segment_labels`), its pixel fill (`fill_pixels`: leftover pixels next to a plane
or a level floor join it if they lie on it within tolerance) and a region's interior
(`region_interior`, `region_depth`).

The kernels compile with numba's ``error_model="numpy"``: no branch before every division to
raise ZeroDivisionError (a float division by zero gives inf or NaN, as in numpy); the same
results otherwise, bit for bit, and 5-20 % faster. Helpers take arrays with a row index, not a
row's view: a view made per call (an array struct and its reference count) cost more than the
arithmetic of the per-segment and per-pixel helpers. Constant arguments of kernels called with
both a constant and a variable are numpy scalars (``np.int64(0)``, ``np.bool_(True)``): numba
compiles a kernel once per argument type, and a literal (0, True) is a type of its own.

numba's cache (``cache=True``) checks a kernel's own source file only: a kernel calling one of
another module (the fused kernels, `mapper.tilt_kernels`) would keep the code it was cached with
when only the callee's file changed. `mapper.kernel_cache` stamps every mapper kernel with all
the package's kernel modules instead, so an edit here recompiles them all on the next run.
"""

from __future__ import annotations

from mapper.scanline.floors import (
    floor_segment_fit,
    floor_statistics,
    floor_verdict,
    foreign_rim,
    region_noise_ratio,
)
from mapper.scanline.fused import level_regions, plane_labels
from mapper.scanline.levels import grow_floors, horizontal_sums, level_heights, split_level
from mapper.scanline.noise import local_noise_depth_m, valid_depth
from mapper.scanline.plane_pixels import (
    RANGE_MARGIN_SIGMAS,
    plane_fits,
    plane_moments,
    plane_refits,
    renumber_planes,
)
from mapper.scanline.planes import grow_planes, reassign_segments, segment_sums
from mapper.scanline.points import floor_points, level_geometry
from mapper.scanline.regions import fill_pixels, region_depth, region_interior, segment_labels
from mapper.scanline.rows import propagate_breaks, split_rows

__all__ = [
    "RANGE_MARGIN_SIGMAS",
    "fill_pixels",
    "floor_points",
    "floor_segment_fit",
    "floor_statistics",
    "floor_verdict",
    "foreign_rim",
    "grow_floors",
    "grow_planes",
    "horizontal_sums",
    "level_geometry",
    "level_heights",
    "level_regions",
    "local_noise_depth_m",
    "plane_fits",
    "plane_labels",
    "plane_moments",
    "plane_refits",
    "propagate_breaks",
    "reassign_segments",
    "region_depth",
    "region_interior",
    "region_noise_ratio",
    "renumber_planes",
    "segment_labels",
    "segment_sums",
    "split_level",
    "split_rows",
    "valid_depth",
]
