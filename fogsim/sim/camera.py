"""The head camera: depth by OpenGL rendering or ray casting, a stereo error model, stereo.

Depth is metres along the optical axis (OpenCV camera z), float32, NaN = no measurement.

What ``mujoco.Renderer``'s depth returns (probed on MuJoCo 3.17, see tests/test_camera.py):
the linearised z-buffer, i.e. distance along the optical axis in metres — not along the ray —
between ``znear·extent`` and ``zfar·extent``; pixels that hit nothing (or lie beyond the far
plane) read exactly the far distance. We turn those into NaN. A small model extent makes the far
plane short (0.4 m extent → 20 m): that explained an early probe reading "20.0". The camera's
intrinsics are written into the model (``cam_resolution``, ``cam_sensorsize``,
``cam_intrinsic``) so the renderer uses exactly ``PinholeIntrinsics.from_fov(...)``, fx ≠ fy
allowed; ray casting (``mujoco.mj_multiRay``, no OpenGL) shoots one ray per pixel centre with
unit optical-z direction, so its hit distance *is* the depth along the axis. Both agree to
micrometres. The ray caster ignores the body the camera is mounted on: a camera inside its
head mesh sees through it in OpenGL (back faces are culled) and must do so when ray casting.

Modes:
    ``ideal``: exact depth.
    ``depth``: exact depth through a stereo error model: disparity d = f·b/z, plus Gaussian
        noise, quantised to a step, back to z; depths outside ``range_m`` and a random fraction
        of pixels (``dropout``) are lost.
    ``stereo``: left and right grey images rendered at twice the resolution (as QRIO's stereo
        hardware worked at 176 × 144), matched with OpenCV's StereoSGBM, disparity → depth in
        the *left* camera, then 2 × 2 median-pooled to the output size.
"""

from __future__ import annotations

import math
import weakref
from dataclasses import dataclass

import cv2
import mujoco
import numpy as np
from numpy.typing import NDArray

from fogsim.config.scenario import CameraConfig
from fogsim.errors import FogsimError
from fogsim.geometry import MJ_FROM_CV
from mapper.intrinsics import PinholeIntrinsics

DEPTH_BACKENDS = ("renderer", "raycast")
_PIXEL_PITCH_M = 1e-5  # notional sensor pixel size: only the ratio focal/pitch matters


def camera_intrinsics(config: CameraConfig, scale: int = 1) -> PinholeIntrinsics:
    """Pinhole intrinsics of the head camera from the scenario (optionally ``scale``×)."""
    return PinholeIntrinsics.from_fov(
        config.width * scale, config.height * scale, config.fov_deg[0], config.fov_deg[1]
    )


def set_model_intrinsics(
    model: mujoco.MjModel, camera_id: int, intrinsics: PinholeIntrinsics
) -> None:
    """Make MuJoCo render camera ``camera_id`` with exactly these (centred) intrinsics."""
    if not (
        math.isclose(intrinsics.cx, (intrinsics.width - 1) / 2.0)
        and math.isclose(intrinsics.cy, (intrinsics.height - 1) / 2.0)
    ):
        raise FogsimError("only centred principal points can be rendered")
    model.cam_resolution[camera_id] = (intrinsics.width, intrinsics.height)
    model.cam_sensorsize[camera_id] = (
        intrinsics.width * _PIXEL_PITCH_M,
        intrinsics.height * _PIXEL_PITCH_M,
    )
    model.cam_intrinsic[camera_id] = (
        intrinsics.fx * _PIXEL_PITCH_M,
        intrinsics.fy * _PIXEL_PITCH_M,
        0.0,
        0.0,
    )
    model.cam_fovy[camera_id] = intrinsics.vfov_deg


def _scene_option(geomgroups: tuple[int, ...]) -> mujoco.MjvOption:
    option = mujoco.MjvOption()
    option.geomgroup[:] = 0
    for group in geomgroups:
        option.geomgroup[group] = 1
    return option


class RendererDepth:
    """Depth images by OpenGL (``mujoco.Renderer``; EGL when headless)."""

    def __init__(
        self,
        model: mujoco.MjModel,
        intrinsics: PinholeIntrinsics,
        geomgroups: tuple[int, ...] = (0, 1, 2),
    ) -> None:
        self.intrinsics = intrinsics
        self._renderer = mujoco.Renderer(model, intrinsics.height, intrinsics.width)
        # Free the GL context when collected or at exit, before EGL itself is torn down.
        self._finalizer = weakref.finalize(self, self._renderer.close)
        self._renderer.enable_depth_rendering()
        self._option = _scene_option(geomgroups)
        self._far_m = float(model.vis.map.zfar * model.stat.extent)

    def render(self, data: mujoco.MjData, camera_id: int) -> NDArray[np.float32]:
        """(H, W) depth along the optical axis [m] from camera ``camera_id``; NaN = none."""
        self._renderer.update_scene(data, camera=camera_id, scene_option=self._option)
        depth = self._renderer.render().astype(np.float32, copy=True)
        depth[depth >= np.float32(self._far_m * (1.0 - 1e-5))] = np.nan
        return depth

    def close(self) -> None:
        """Free the OpenGL context (idempotent)."""
        self._finalizer()


class RaycastDepth:
    """Depth images by ray casting (``mujoco.mj_multiRay``; no OpenGL at all)."""

    def __init__(
        self,
        model: mujoco.MjModel,
        intrinsics: PinholeIntrinsics,
        geomgroups: tuple[int, ...] = (0, 1, 2),
        cutoff_m: float | None = None,
    ) -> None:
        self.intrinsics = intrinsics
        self._model = model
        # Unit optical-z directions: the hit distance is the depth along the axis.
        self._directions_camera = intrinsics.ray_directions_camera().reshape(-1, 3)
        self._geomgroup = np.zeros(6, dtype=np.uint8)
        self._geomgroup[list(geomgroups)] = 1
        n = self._directions_camera.shape[0]
        self._geomid = np.empty(n, dtype=np.int32)
        self._dist = np.empty(n, dtype=np.float64)
        self._cutoff_m = float(cutoff_m or model.vis.map.zfar * model.stat.extent)

    def render(self, data: mujoco.MjData, camera_id: int) -> NDArray[np.float32]:
        """(H, W) depth along the optical axis [m] from camera ``camera_id``; NaN = none."""
        rotation_cv = data.cam_xmat[camera_id].reshape(3, 3) @ MJ_FROM_CV
        directions_world = self._directions_camera @ rotation_cv.T
        mujoco.mj_multiRay(
            self._model,
            data,
            data.cam_xpos[camera_id].copy(),
            np.ascontiguousarray(directions_world).ravel(),
            self._geomgroup,
            1,
            int(self._model.cam_bodyid[camera_id]),  # never the camera's own mount
            self._geomid,
            self._dist,
            None,
            self._dist.size,
            self._cutoff_m,
        )
        depth = self._dist.astype(np.float32)
        depth[self._geomid < 0] = np.nan
        return depth.reshape(self.intrinsics.shape)

    def close(self) -> None:
        """Nothing to free (kept for symmetry with :class:`RendererDepth`)."""


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
    """

    focal_px: float
    baseline_m: float
    disparity_noise_px: float = 0.05
    disparity_step_px: float = 0.0625
    dropout: float = 0.01
    range_m: tuple[float, float] = (0.15, 4.0)

    def __post_init__(self) -> None:
        if not (self.focal_px > 0 and self.baseline_m > 0):
            raise FogsimError(
                f"focal_px and baseline_m must be > 0, got {self.focal_px}, {self.baseline_m}"
            )
        if self.disparity_noise_px < 0 or self.disparity_step_px < 0:
            raise FogsimError("disparity noise and step must be >= 0 px")
        if not 0.0 <= self.dropout < 1.0:
            raise FogsimError(f"dropout must be in [0, 1), got {self.dropout}")
        if not 0.0 < self.range_m[0] < self.range_m[1]:
            raise FogsimError(f"range_m must be (min, max) with 0 < min < max, got {self.range_m}")

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


class StereoMatcher:
    """Depth from rendered left/right images matched by OpenCV's StereoSGBM (``stereo`` mode).

    Images are rendered at ``scale`` × the output resolution, matched, converted to depth in
    the left camera and median-pooled ``scale`` × ``scale`` down to the output size.
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        intrinsics: PinholeIntrinsics,
        baseline_m: float,
        scale: int = 2,
        num_disparities: int = 32,
        block_size: int = 5,
        geomgroups: tuple[int, ...] = (0, 1, 2),
    ) -> None:
        self.intrinsics = intrinsics
        self.scale = scale
        self.intrinsics_render = PinholeIntrinsics.from_fov(
            intrinsics.width * scale,
            intrinsics.height * scale,
            intrinsics.hfov_deg,
            intrinsics.vfov_deg,
        )
        self.baseline_m = baseline_m
        self._renderer = mujoco.Renderer(
            model, self.intrinsics_render.height, self.intrinsics_render.width
        )
        self._finalizer = weakref.finalize(self, self._renderer.close)
        self._option = _scene_option(geomgroups)
        self._matcher = cv2.StereoSGBM_create(
            minDisparity=0,
            numDisparities=num_disparities,
            blockSize=block_size,
            P1=8 * block_size**2,
            P2=32 * block_size**2,
            disp12MaxDiff=1,
            uniquenessRatio=10,
            speckleWindowSize=50,
            speckleRange=2,
            mode=cv2.STEREO_SGBM_MODE_SGBM,
        )

    def grey_image(self, data: mujoco.MjData, camera_id: int) -> NDArray[np.uint8]:
        """Rendered grey image (render resolution) of one camera."""
        self._renderer.update_scene(data, camera=camera_id, scene_option=self._option)
        return cv2.cvtColor(self._renderer.render(), cv2.COLOR_RGB2GRAY)

    def depth(
        self, data: mujoco.MjData, left_camera_id: int, right_camera_id: int
    ) -> NDArray[np.float32]:
        """(H, W) depth [m] along the left camera's optical axis; NaN where unmatched."""
        left = self.grey_image(data, left_camera_id)
        right = self.grey_image(data, right_camera_id)
        disparity = self._matcher.compute(left, right).astype(np.float32) / 16.0
        with np.errstate(divide="ignore"):
            depth = np.where(
                disparity > 0.5,
                np.float32(self.intrinsics_render.fx * self.baseline_m) / disparity,
                np.float32(np.nan),
            )
        h, w = self.intrinsics.shape
        blocks = depth.reshape(h, self.scale, w, self.scale).transpose(0, 2, 1, 3)
        blocks = blocks.reshape(h, w, self.scale * self.scale)
        valid = np.sum(np.isfinite(blocks), axis=-1)
        with np.errstate(all="ignore"):
            pooled = np.sort(blocks, axis=-1)  # NaN sort last
            index = np.maximum(valid - 1, 0) // 2
            out = np.take_along_axis(pooled, index[..., None], axis=-1)[..., 0]
        out[valid == 0] = np.nan
        return out.astype(np.float32)

    def close(self) -> None:
        """Free the OpenGL context (idempotent)."""
        self._finalizer()


class HeadCamera:
    """The robot's depth sensor in one of the modes ``ideal``, ``depth``, ``stereo``.

    Args:
        model: The scene's MuJoCo model (camera intrinsics are written into it).
        camera_ids: MuJoCo ids of ``head_camera``, ``head_camera_left``, ``head_camera_right``.
        config: The scenario's camera table.
        backend: ``renderer`` (OpenGL) or ``raycast`` (no OpenGL; not for ``stereo``).
        baseline_m: Stereo baseline of the left/right pair (``stereo`` mode) [m].
        geomgroups: Geom groups that are visible.

    Attributes:
        intrinsics: Intrinsics of the output depth image.
        depth_camera: Which camera the depth image belongs to (``head_camera``, or
            ``head_camera_left`` in ``stereo`` mode).
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        camera_ids: dict[str, int],
        config: CameraConfig,
        backend: str = "renderer",
        baseline_m: float | None = None,
        geomgroups: tuple[int, ...] = (0, 1, 2),
    ) -> None:
        if backend not in DEPTH_BACKENDS:
            raise FogsimError(
                f"depth_backend must be one of {', '.join(DEPTH_BACKENDS)}, got {backend!r}"
            )
        if config.mode == "stereo" and backend != "renderer":
            raise FogsimError("camera mode 'stereo' needs images: use depth_backend='renderer'")
        self.config = config
        self.mode = config.mode
        self.intrinsics = camera_intrinsics(config)
        for camera_id in camera_ids.values():
            set_model_intrinsics(model, camera_id, self.intrinsics)
        self._camera_ids = camera_ids
        self.depth_camera = "head_camera_left" if self.mode == "stereo" else "head_camera"
        self._depth: RendererDepth | RaycastDepth | None = None
        self._stereo: StereoMatcher | None = None
        if self.mode == "stereo":
            for name in ("head_camera_left", "head_camera_right"):
                set_model_intrinsics(model, camera_ids[name], camera_intrinsics(config, 2))
            self._stereo = StereoMatcher(
                model, self.intrinsics, baseline_m or config.baseline_m, geomgroups=geomgroups
            )
        elif backend == "renderer":
            self._depth = RendererDepth(model, self.intrinsics, geomgroups)
        else:
            self._depth = RaycastDepth(model, self.intrinsics, geomgroups)
        self.noise = StereoErrorModel.from_config(config, self.intrinsics.fx)

    def exact_depth(self, data: mujoco.MjData) -> NDArray[np.float32]:
        """Exact depth of ``head_camera`` (not in ``stereo`` mode)."""
        if self._depth is None:
            raise FogsimError("exact depth is not rendered in 'stereo' mode")
        return self._depth.render(data, self._camera_ids["head_camera"])

    def capture(self, data: mujoco.MjData, rng: np.random.Generator) -> NDArray[np.float32]:
        """One depth image of the current scene state (call the scene's ``forward`` first)."""
        if self._stereo is not None:
            return self._stereo.depth(
                data, self._camera_ids["head_camera_left"], self._camera_ids["head_camera_right"]
            )
        depth = self.exact_depth(data)
        if self.mode == "ideal":
            return depth
        return self.noise.apply(depth, rng)

    def close(self) -> None:
        """Free OpenGL contexts."""
        for part in (self._depth, self._stereo):
            if part is not None:
                part.close()
