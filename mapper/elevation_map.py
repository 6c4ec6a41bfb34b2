"""An elevation map in the style of ANYbotics' elevation_mapping (Fankhauser et al.).

Built from the published equations (P. Fankhauser, M. Bloesch, C. Gehring, M. Hutter,
R. Siegwart, "Robot-Centric Elevation Mapping with Uncertainty Estimates", CLAWAR 2014;
P. Fankhauser, M. Bloesch, M. Hutter, "Probabilistic Terrain Mapping for Mobile Robots with
Uncertain Localization", RA-L 2018) and the defaults of the ``elevation_mapping`` package:

* **Sensor noise** (the structured-light model of Nguyen et al. 2012 that elevation_mapping's
  ``StructuredLightSensorProcessor`` uses): a point at range ``d`` has a standard deviation
  ``σ_n = a + b·(d − c)²`` along the ray and ``σ_l = lateral_factor·d`` across it; its height
  variance is that covariance projected onto z: ``σ_p² = σ_n²·u_z² + σ_l²·(1 − u_z²)`` with
  ``u`` the unit ray direction. (The package projects with the camera's optical axis and uses the
  depth, not the range; the map is handed only the camera centre, so the ray stands in for the
  axis — at most 30° apart in the testbed's 47° × 39° camera.) There is no robot-pose
  covariance here: every map of the comparison gets the same corrected points.
* **Fusion** per cell, a one-dimensional Kalman update of height ``h`` and variance ``σ²``:
  ``h ← (σ²·p + σ_p²·h) / (σ² + σ_p²)``, ``σ² ← σ²·σ_p² / (σ² + σ_p²)``; an empty cell takes
  ``(p, σ_p²)``.
* **Mahalanobis gating** keeping the higher surface: a point with ``|p − h| / σ`` above the
  threshold is not fused. Within the frame that last wrote the cell a higher point replaces
  ``(h, σ²)`` and a lower one is ignored; from a later frame it only adds the multi-height noise
  to ``σ²`` (so a lower surface is fused once the variance has grown enough). Variances stay in
  ``[min_variance_m2, max_variance_m2]``.
* **Visibility clean-up**: before a frame is fused, every ray from the camera to a point of the
  frame removes the cells it crosses (the point's own cell excepted) whose stored height lies
  above the ray by more than the gate ``threshold·√(σ² + σ_p²)``: a surface there would have
  blocked the ray, so it is gone (a removed box). elevation_mapping runs it at 1 Hz to save time;
  here it runs every frame.

It has no floor/obstacle labels: ``fog()`` labels its heights with
:func:`mapper.backends.label_by_step`. Points outside the grid's x, y or z range are dropped, as
in every map of the comparison.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray

from mapper.backends import ScrollingGrid, StepRuleParams, frame_cells, label_by_step
from mapper.grid import UpdateResult, validate_frame
from mapper.params import MapperParams
from mapper.validation import check_field


@dataclass(frozen=True)
class ElevationMapParams:
    """Noise model and fusion of :class:`ElevationMap` (defaults: elevation_mapping's).

    Attributes:
        normal_a_m: ``a`` of ``σ_n = a + b·(d − c)²`` [m]: 0.000611 (Nguyen et al. 2012, the
            package's structured-light default).
        normal_b_per_m: ``b`` [1/m]: 0.003587 (same source).
        normal_c_m: ``c`` [m]: 0.3515 (same source).
        lateral_factor: ``σ_l = lateral_factor·d``: 0.01576 (same source).
        mahalanobis_threshold: Gate on ``|p − h| / σ``: 2.5 (package default).
        multi_height_noise_m2: Variance added by a gated point of a later frame [m²]: 9e-7
            (package default).
        min_variance_m2: Smallest cell variance [m²]: 9e-6, σ = 3 mm (package default).
        max_variance_m2: Largest cell variance [m²]: 9e-4, σ = 3 cm (package default).
    """

    normal_a_m: float = 0.000611
    normal_b_per_m: float = 0.003587
    normal_c_m: float = 0.3515
    lateral_factor: float = 0.01576
    mahalanobis_threshold: float = 2.5
    multi_height_noise_m2: float = 9e-7
    min_variance_m2: float = 9e-6
    max_variance_m2: float = 9e-4

    def __post_init__(self) -> None:
        for name in ("normal_a_m", "normal_b_per_m", "normal_c_m", "lateral_factor"):
            check_field(
                "ElevationMapParams",
                name,
                getattr(self, name),
                float,
                "a finite float >= 0",
                lambda v: math.isfinite(v) and v >= 0,
            )
        for name in ("mahalanobis_threshold", "multi_height_noise_m2", "min_variance_m2"):
            check_field(
                "ElevationMapParams",
                name,
                getattr(self, name),
                float,
                "a finite float > 0",
                lambda v: math.isfinite(v) and v > 0,
            )
        check_field(
            "ElevationMapParams",
            "max_variance_m2",
            self.max_variance_m2,
            float,
            f"a finite float >= min_variance_m2 ({self.min_variance_m2!r})",
            lambda v: math.isfinite(v) and v >= self.min_variance_m2,
        )


def point_height_variance_m2(
    points: NDArray[np.float64], sensor_origin: NDArray[np.float64], params: ElevationMapParams
) -> NDArray[np.float64]:
    """(N,) height variance [m²] of each point from the sensor model (see the module)."""
    ray = points - sensor_origin
    range_m = np.linalg.norm(ray, axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        uz2 = np.where(range_m > 0, (ray[:, 2] / range_m) ** 2, 1.0)
    sigma_n = params.normal_a_m + params.normal_b_per_m * (range_m - params.normal_c_m) ** 2
    sigma_l = params.lateral_factor * range_m
    return sigma_n**2 * uz2 + sigma_l**2 * (1.0 - uz2)


@numba.njit(cache=True, no_cfunc_wrapper=True)
def _visibility_cleanup(
    points, point_var, origin, origin_x, origin_y, cell, height, variance, gate
):
    """Mark cells whose height lies above a ray of the frame by more than the gate.

    Rays are walked cell by cell in x, y (Amanatides–Woo in 2-D) from the camera's cell to the
    point's cell (that one excepted); the ray's lowest z within a cell is at its entry or exit.
    Returns the (nx, ny) mark (the caller removes the cells, so no ray sees another's removal).
    """
    nx, ny = height.shape
    remove = np.zeros((nx, ny), dtype=np.bool_)
    sx = (origin[0] - origin_x) / cell
    sy = (origin[1] - origin_y) / cell
    sz = origin[2]
    for i in range(points.shape[0]):
        px = (points[i, 0] - origin_x) / cell
        py = (points[i, 1] - origin_y) / cell
        pz = points[i, 2]
        if not (np.isfinite(px) and np.isfinite(py) and np.isfinite(pz)):
            continue
        dx = px - sx
        dy = py - sy
        dz = pz - sz
        ix = int(np.floor(sx))
        iy = int(np.floor(sy))
        end_x = int(np.floor(px))
        end_y = int(np.floor(py))
        step_x = 1 if dx > 0 else -1
        step_y = 1 if dy > 0 else -1
        t_dx = abs(1.0 / dx) if dx != 0 else np.inf
        t_dy = abs(1.0 / dy) if dy != 0 else np.inf
        t_x = ((ix + 1 - sx) if dx > 0 else (sx - ix)) * t_dx if dx != 0 else np.inf
        t_y = ((iy + 1 - sy) if dy > 0 else (sy - iy)) * t_dy if dy != 0 else np.inf
        t_in = 0.0
        for _ in range(abs(end_x - ix) + abs(end_y - iy)):
            t_out = min(t_x, t_y, 1.0)
            if 0 <= ix < nx and 0 <= iy < ny and np.isfinite(height[ix, iy]):
                z_low = sz + dz * (t_in if dz > 0 else t_out)
                limit = gate * np.sqrt(variance[ix, iy] + point_var[i])
                if height[ix, iy] - z_low > limit:
                    remove[ix, iy] = True
            t_in = t_out
            if t_x < t_y:
                ix += step_x
                t_x += t_dx
            else:
                iy += step_y
                t_y += t_dy
    return remove


@numba.njit(cache=True, no_cfunc_wrapper=True)
def _fuse(
    ix, iy, heights, point_var, height, variance, stamp, frame, gate, noise, min_var, max_var
):
    """Fuse the frame's points, in order, into their cells (module: fusion and gating).

    Args:
        ix: (M,) x index of each point inside the grid.
        iy: (M,) y index.
        heights: (M,) its z [m].
        point_var: (M,) its height variance [m²].
        height: (nx, ny) cell heights [m], updated.
        variance: (nx, ny) cell variances [m²], updated.
        stamp: (nx, ny) frame that last wrote each cell, updated.
        frame: This frame's number.
        gate: Mahalanobis threshold.
        noise: Multi-height noise [m²].
        min_var: Smallest variance [m²].
        max_var: Largest variance [m²].
    """
    for i in range(ix.shape[0]):
        x = ix[i]
        y = iy[i]
        p = heights[i]
        var_p = min(max(point_var[i], min_var), max_var)
        h = height[x, y]
        var = variance[x, y]
        if not np.isfinite(h):
            height[x, y] = p
            variance[x, y] = var_p
            stamp[x, y] = frame
        elif abs(p - h) > gate * np.sqrt(var):
            if stamp[x, y] != frame:
                variance[x, y] = min(var + noise, max_var)
            elif p > h:
                height[x, y] = p
                variance[x, y] = var_p
        else:
            height[x, y] = (var * p + var_p * h) / (var + var_p)
            variance[x, y] = min(max(var * var_p / (var + var_p), min_var), max_var)
            stamp[x, y] = frame


class ElevationMap(ScrollingGrid):
    """Height and variance per cell, Kalman-fused, gated and cleaned by rays (see the module).

    Args:
        params: Noise model and fusion.
        grid: Only the grid geometry fields are used (the FOG's grid, so cells coincide).
        rule: The labelling rule of ``fog()``.
        center_xy_m: World (x, y) [m] that lies in the central cell initially.
    """

    def __init__(
        self,
        params: ElevationMapParams | None = None,
        grid: MapperParams | None = None,
        rule: StepRuleParams | None = None,
        center_xy_m: ArrayLike = (0.0, 0.0),
    ) -> None:
        self.params = params if params is not None else ElevationMapParams()
        self.grid = grid if grid is not None else MapperParams()
        self.rule = rule if rule is not None else StepRuleParams()
        super().__init__(self.grid, center_xy_m)
        self._height = self._layer(np.nan)
        self._variance = self._layer(np.nan)
        self._stamp = self._layer(-1, np.int64)
        self._frames = 0

    def update(
        self, points: ArrayLike, floor_heights: ArrayLike, sensor_origin: ArrayLike
    ) -> UpdateResult:
        """Clean up along the frame's rays, then fuse its points (``floor_heights`` unused).

        ``cells_updated`` of the result counts the cells the clean-up removed.
        """
        pts, _, origin = validate_frame(points, floor_heights, sensor_origin)
        p = self.params
        g = self._geometry
        ox, oy = g.origin_xy_m
        point_var = point_height_variance_m2(pts, origin, p)
        remove = _visibility_cleanup(
            pts,
            point_var,
            origin,
            ox,
            oy,
            g.cell_m,
            self._height,
            self._variance,
            p.mahalanobis_threshold,
        )
        self._height[remove] = np.nan
        self._variance[remove] = np.nan
        self._stamp[remove] = -1
        cells = frame_cells(pts, g)
        _fuse(
            cells.ix,
            cells.iy,
            pts[cells.inside, 2],
            point_var[cells.inside],
            self._height,
            self._variance,
            self._stamp,
            self._frames,
            p.mahalanobis_threshold,
            p.multi_height_noise_m2,
            p.min_variance_m2,
            p.max_variance_m2,
        )
        self._frames += 1
        return cells.result(int(remove.sum()))

    def heights(self) -> NDArray[np.float64]:
        """(nx, ny) fused height per cell [m], NaN where none."""
        return self._height.copy()

    def variance(self) -> NDArray[np.float64]:
        """(nx, ny) height variance per cell [m²], NaN where none."""
        return self._variance.copy()

    def fog(self) -> tuple[NDArray[np.int8], NDArray[np.float64]]:
        """(labels by :func:`~mapper.backends.label_by_step`, heights [m] NaN = none)."""
        heights = self.heights()
        return label_by_step(heights, self.rule), heights
