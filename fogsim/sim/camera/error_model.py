"""The ``depth`` mode's sensor: exact depth through the errors of a stereo depth camera.

Disparity ``d = f·b/z``, plus Gaussian noise, quantised to a step, back to ``z``; depths outside
``range_m`` and a random fraction of pixels (``dropout``) are lost. The depth error thus grows
with the square of the distance, as a stereo camera's does (``σ_z = z²·σ_d/(f·b)``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from fogsim.config import CameraConfig
from fogsim.errors import CameraError


@dataclass(frozen=True)
class StereoErrorModel:
    """Errors of a stereo depth sensor applied to exact depth (the ``depth`` mode).

    Attributes:
        focal_px: Focal length the disparities are measured with [px].
        baseline_m: Stereo baseline [m].
        disparity_noise_px: Std of the Gaussian disparity noise [px].
        disparity_step_px: Disparity quantisation step [px] (0 = none).
        dropout: Fraction of pixels randomly without a measurement.
        range_m: (min, max) depth kept [m].

    No defaults: the scenario's camera table holds them (:meth:`from_config`).

    Raises:
        CameraError: A value is out of range (the message names it and what is allowed).
    """

    focal_px: float
    baseline_m: float
    disparity_noise_px: float
    disparity_step_px: float
    dropout: float
    range_m: tuple[float, float]

    def __post_init__(self) -> None:
        if not (self.focal_px > 0 and self.baseline_m > 0):
            raise CameraError(
                f"focal_px and baseline_m must be > 0, got {self.focal_px}, {self.baseline_m}"
            )
        if self.disparity_noise_px < 0 or self.disparity_step_px < 0:
            raise CameraError(
                f"disparity_noise_px and disparity_step_px must be >= 0 px, got "
                f"{self.disparity_noise_px}, {self.disparity_step_px}"
            )
        if not 0.0 <= self.dropout < 1.0:
            raise CameraError(f"dropout must be in [0, 1), got {self.dropout}")
        if not 0.0 < self.range_m[0] < self.range_m[1]:
            raise CameraError(f"range_m must be (min, max) with 0 < min < max, got {self.range_m}")

    @classmethod
    def from_config(cls, config: CameraConfig, focal_px: float) -> StereoErrorModel:
        """The error model of a scenario's camera table."""
        return cls(
            focal_px=focal_px,
            baseline_m=config.baseline_m,
            disparity_noise_px=config.disparity_noise_px,
            disparity_step_px=config.disparity_step_px,
            dropout=config.dropout,
            range_m=config.range_m,
        )

    def depth_sigma_m(self, depth_m: float) -> float:
        """Std of the depth error at ``depth_m`` from disparity noise alone [m] (z²σ/(f b))."""
        return depth_m**2 * self.disparity_noise_px / (self.focal_px * self.baseline_m)

    def apply(self, depth_m: NDArray[np.floating], rng: np.random.Generator) -> NDArray[np.float32]:
        """Noisy depth (float32, NaN = none) from exact depth; draws from ``rng``."""
        fb = self.focal_px * self.baseline_m
        disparity = fb / depth_m.astype(np.float64)
        disparity += rng.normal(0.0, self.disparity_noise_px, size=depth_m.shape)
        if self.disparity_step_px > 0.0:
            disparity = np.round(disparity / self.disparity_step_px) * self.disparity_step_px
        with np.errstate(divide="ignore", invalid="ignore"):
            depth = np.where(disparity > 0.0, fb / disparity, np.nan)
        lost = (
            ~(depth >= self.range_m[0])
            | ~(depth <= self.range_m[1])
            | (rng.random(depth_m.shape) < self.dropout)
        )
        depth[lost] = np.nan
        return depth.astype(np.float32)
