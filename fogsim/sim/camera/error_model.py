"""The ``depth`` mode's sensor: exact depth through the errors of a stereo depth camera.

In order: edge fattening (within ``edge_fattening_px`` of a depth edge the background takes the
foreground's depth, as a matching window straddling the edge does), occlusion (pixels the right
camera cannot see, beside the left of a nearer surface, lose their measurement, as SGBM's
left-right check withdraws them), then disparity ``d = f·b/z`` plus Gaussian noise (white, or
smoothed over ``disparity_noise_correlation_px`` as a matcher's window smooths it), quantised to
a step, back to ``z``; depths outside ``range_m`` and a random fraction of pixels (``dropout``)
are lost. The depth error thus grows with the square of the distance, as a stereo camera's does
(``σ_z = z²·σ_d/(f·b)``). ``bench/stereo_stats.py`` measures these figures for the stereo head
on the stage.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
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
        disparity_noise_correlation_px: Std [px] of the Gaussian kernel that smooths the noise
            field (0 = white noise); neighbours' errors then correlate by
            ``Σ k_i·k_(i+1) / Σ k_i²`` of the sampled kernel ``k`` (0.445 for 0.6 px; about
            ``exp(−1/(4·σ²))`` for wide kernels). The std stays ``disparity_noise_px``.
        disparity_step_px: Disparity quantisation step [px] (0 = none).
        dropout: Fraction of pixels randomly without a measurement.
        range_m: (min, max) depth kept [m].
        edge_fattening_px: How far [px] the nearer side of a depth edge spreads over the
            farther one (0 = none).
        occlusion: True: pixels hidden from a right camera ``baseline_m`` to the right lose
            their measurement.

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
    disparity_noise_correlation_px: float
    edge_fattening_px: int
    occlusion: bool

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
        if not 0.0 <= self.disparity_noise_correlation_px <= 5.0:
            raise CameraError(
                "disparity_noise_correlation_px must be in [0, 5] px, got "
                f"{self.disparity_noise_correlation_px}"
            )
        if not 0 <= self.edge_fattening_px <= 8:
            raise CameraError(
                f"edge_fattening_px must be an integer in [0, 8] px, got {self.edge_fattening_px}"
            )

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
            disparity_noise_correlation_px=config.disparity_noise_correlation_px,
            edge_fattening_px=config.edge_fattening_px,
            occlusion=config.occlusion,
        )

    def depth_sigma_m(self, depth_m: float) -> float:
        """Std of the depth error at ``depth_m`` from disparity noise alone [m] (z²σ/(f b))."""
        return depth_m**2 * self.disparity_noise_px / (self.focal_px * self.baseline_m)

    def equivalent_noise_px(self) -> float:
        """Std of the disparity error [px]: the noise and the quantisation's ``step/sqrt(12)``."""
        return float(np.hypot(self.disparity_noise_px, self.disparity_step_px / np.sqrt(12.0)))

    def mean_variance_factor(self) -> float:
        """How much the errors' correlation inflates the variance of a long row mean (≥ 1).

        A field smoothed by a normalised kernel ``k`` (:meth:`noise_px`) has row correlations
        summing to ``(Σk)²/Σk² = 1/Σk²`` (2.0 for 0.6 px); the quantisation error is white.
        The factor is the two parts' variance-weighted mean (1 for white noise).
        """
        noise_var = self.disparity_noise_px**2
        step_var = self.disparity_step_px**2 / 12.0
        if noise_var + step_var == 0.0:
            return 1.0
        sigma = self.disparity_noise_correlation_px
        factor = 1.0
        if sigma > 0.0:
            kernel = cv2.getGaussianKernel(2 * int(np.ceil(3.0 * sigma)) + 1, sigma, cv2.CV_64F)
            factor = 1.0 / float(np.sum(kernel**2))
        return (noise_var * factor + step_var) / (noise_var + step_var)

    def fattened(self, depth_m: NDArray[np.floating]) -> NDArray[np.float64]:
        """Depth with each depth edge's nearer side spread ``edge_fattening_px`` over the farther.

        A pixel takes the nearest depth within ``edge_fattening_px`` (a square window) only where
        that is more than 5 % nearer — an edge, not the slope of a surface seen at a slant.
        """
        depth = depth_m.astype(np.float64)
        if self.edge_fattening_px == 0:
            return depth
        side = 2 * self.edge_fattening_px + 1
        finite = np.nan_to_num(depth, nan=np.inf)
        nearest = cv2.erode(
            finite, np.ones((side, side), np.uint8), borderType=cv2.BORDER_REPLICATE
        )
        return np.where(nearest < 0.95 * finite, nearest, depth)

    def occluded(self, depth_m: NDArray[np.float64]) -> NDArray[np.bool_]:
        """Pixels of the (left) camera a right camera ``baseline_m`` to the right cannot see.

        Pixel ``u`` of a row with disparity ``d`` appears at ``u − d`` in the right image; a
        pixel further right whose surface is nearer appears at or left of it (by half a pixel)
        and hides it.
        """
        width = depth_m.shape[1]
        disparity = self.focal_px * self.baseline_m / depth_m
        right_position = np.where(
            np.isfinite(disparity), np.arange(width)[None, :] - disparity, np.inf
        )
        leftmost_further_right = np.minimum.accumulate(right_position[:, ::-1], axis=1)[:, ::-1]
        hidden = np.zeros(depth_m.shape, dtype=bool)
        hidden[:, :-1] = leftmost_further_right[:, 1:] < right_position[:, :-1] - 0.5
        return hidden

    def noise_px(self, shape: tuple[int, ...], rng: np.random.Generator) -> NDArray[np.float64]:
        """A disparity noise field [px]: std ``disparity_noise_px``, smoothed if asked.

        White noise filtered with a normalised Gaussian kernel of std ``σ`` keeps a std of
        ``|k|₂`` (the kernel's root sum of squares); dividing by it restores the std.
        """
        white = rng.standard_normal(shape)
        sigma = self.disparity_noise_correlation_px
        if sigma == 0.0:
            return self.disparity_noise_px * white
        size = 2 * int(np.ceil(3.0 * sigma)) + 1
        kernel = cv2.getGaussianKernel(size, sigma, cv2.CV_64F)
        smooth = cv2.sepFilter2D(white, cv2.CV_64F, kernel, kernel, borderType=cv2.BORDER_REFLECT)
        return self.disparity_noise_px / float(np.sum(kernel**2)) * smooth

    def apply(self, depth_m: NDArray[np.floating], rng: np.random.Generator) -> NDArray[np.float32]:
        """Noisy depth (float32, NaN = none) from exact depth; draws from ``rng``."""
        fb = self.focal_px * self.baseline_m
        exact = self.fattened(depth_m)
        hidden = self.occluded(exact) if self.occlusion else np.zeros(exact.shape, dtype=bool)
        disparity = fb / exact
        disparity = disparity + self.noise_px(depth_m.shape, rng)
        if self.disparity_step_px > 0.0:
            disparity = np.round(disparity / self.disparity_step_px) * self.disparity_step_px
        with np.errstate(divide="ignore", invalid="ignore"):
            depth = np.where(disparity > 0.0, fb / disparity, np.nan)
        lost = (
            hidden
            | ~(depth >= self.range_m[0])
            | ~(depth <= self.range_m[1])
            | (rng.random(depth_m.shape) < self.dropout)
        )
        depth[lost] = np.nan
        return depth.astype(np.float32)
