"""The ``stereo`` mode's sensor: left and right images rendered and matched by OpenCV.

As QRIO's stereo hardware did (it matched at 176 × 144 for 88 × 72 output), the left and right
grey images are rendered at ``scale`` × the output resolution, matched with OpenCV's
StereoSGBM, turned into depth along the *left* camera's optical axis and median-pooled
``scale`` × ``scale`` down to the output size. The cameras' intrinsics at the render
resolution must be written into the model first (:mod:`fogsim.sim.camera.intrinsics`).
"""

from __future__ import annotations

import weakref

import cv2
import mujoco
import numpy as np
from numpy.typing import NDArray

from fogsim.sim.camera.depth import VISIBLE_GEOMGROUPS, scene_option
from mapper.intrinsics import PinholeIntrinsics

STEREO_RENDER_SCALE = 2
"""Render resolution / output resolution of the stereo mode: QRIO matched at 176 × 144 for its
88 × 72 output."""


class StereoMatcher:
    """Depth from rendered left/right images matched by OpenCV's StereoSGBM (``stereo`` mode).

    Args:
        model: The compiled model (left/right intrinsics at the render resolution in it).
        intrinsics: Intrinsics of the output depth image.
        baseline_m: Distance between the left and right cameras [m].
        scale: Render resolution / output resolution.
        num_disparities: SGBM disparity search range [px at the render resolution]; 32 px
            reaches down to ``f·b/32`` (about 0.4 m for a 7 cm baseline at 176 × 144).
        block_size: SGBM matching block side [px]; its smoothness penalties are OpenCV's
            recommended ``P1 = 8·block²``, ``P2 = 32·block²`` (one grey channel).
        geomgroups: Geom groups that are visible.
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        intrinsics: PinholeIntrinsics,
        baseline_m: float,
        scale: int = STEREO_RENDER_SCALE,
        num_disparities: int = 32,
        block_size: int = 5,
        geomgroups: tuple[int, ...] = VISIBLE_GEOMGROUPS,
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
        self._option = scene_option(geomgroups)
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
