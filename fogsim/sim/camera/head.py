"""The robot's head camera: one depth image per frame in the mode the scenario asks for.

Modes:
    ``ideal``: exact depth (:mod:`fogsim.sim.camera.depth`).
    ``depth``: exact depth through the stereo error model (:mod:`fogsim.sim.camera.error_model`).
    ``stereo``: left and right images matched with OpenCV (:mod:`fogsim.sim.camera.stereo`);
        the depth image belongs to ``head_camera_left``.

In every mode :meth:`HeadCamera.exact_depth` gives the exact depth of the camera the depth image
belongs to, pixel for pixel: the truth to measure a mode's errors against.
"""

from __future__ import annotations

import mujoco
import numpy as np
from numpy.typing import NDArray

from fogsim.config import CameraConfig
from fogsim.errors import CameraError
from fogsim.sim.camera.backends import DEPTH_BACKENDS
from fogsim.sim.camera.depth import VISIBLE_GEOMGROUPS, RaycastDepth, RendererDepth
from fogsim.sim.camera.error_model import StereoErrorModel
from fogsim.sim.camera.intrinsics import camera_intrinsics, set_model_intrinsics
from fogsim.sim.camera.stereo import (
    DISPARITY_RANGE_PX,
    RIGHT_MARGIN_PX,
    STEREO_RENDER_SCALE,
    StereoMatcher,
    extended,
    render_intrinsics,
)


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
        config: The scenario's camera table.
        mode: ``ideal``, ``depth`` or ``stereo``.
        intrinsics: Intrinsics of the output depth image.
        depth_camera: Which camera the depth image belongs to (``head_camera``, or
            ``head_camera_left`` in ``stereo`` mode).
        noise: The stereo error model of the ``depth`` mode.
        baseline_m: Stereo baseline of the left/right pair [m] (``baseline_m``, else the
            scenario's).

    Raises:
        CameraError: An unknown backend, or ``stereo`` mode without the renderer.
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        camera_ids: dict[str, int],
        config: CameraConfig,
        backend: str = "renderer",
        baseline_m: float | None = None,
        geomgroups: tuple[int, ...] = VISIBLE_GEOMGROUPS,
    ) -> None:
        if backend not in DEPTH_BACKENDS:
            raise CameraError(
                f"depth_backend must be one of {', '.join(DEPTH_BACKENDS)}, got {backend!r}"
            )
        if config.mode == "stereo" and backend != "renderer":
            raise CameraError(
                f"camera mode 'stereo' needs images: depth_backend {backend!r} is not allowed, "
                "use 'renderer'"
            )
        self.config = config
        self.mode = config.mode
        self.intrinsics = camera_intrinsics(config)
        for camera_id in camera_ids.values():
            set_model_intrinsics(model, camera_id, self.intrinsics)
        self._camera_ids = camera_ids
        self.baseline_m = baseline_m or config.baseline_m
        self.depth_camera = "head_camera_left" if self.mode == "stereo" else "head_camera"
        self._stereo: StereoMatcher | None = None
        self._margins_px = (0, 0)
        if self.mode == "stereo":
            for name in ("head_camera_left", "head_camera_right"):
                set_model_intrinsics(model, camera_ids[name], render_intrinsics(self.intrinsics))
            self._stereo = StereoMatcher(
                model, self.intrinsics, self.baseline_m, geomgroups=geomgroups
            )
            # The left camera renders an extended field: its exact depth is the part between
            # the margins of a likewise extended output-resolution image.
            self._margins_px = (
                DISPARITY_RANGE_PX // STEREO_RENDER_SCALE,
                RIGHT_MARGIN_PX // STEREO_RENDER_SCALE,
            )
        exact_intrinsics = extended(self.intrinsics, *self._margins_px)
        self._depth: RendererDepth | RaycastDepth
        if backend == "renderer":
            self._depth = RendererDepth(model, exact_intrinsics, geomgroups)
        else:
            self._depth = RaycastDepth(model, exact_intrinsics, geomgroups)
        self.noise = StereoErrorModel.from_config(config, self.intrinsics.fx)

    def exact_depth(self, data: mujoco.MjData) -> NDArray[np.float32]:
        """Exact depth of the camera the depth images belong to (:attr:`depth_camera`)."""
        depth = self._depth.render(data, self._camera_ids[self.depth_camera])
        left, right = self._margins_px
        return depth[:, left : depth.shape[1] - right]

    def capture(self, data: mujoco.MjData, rng: np.random.Generator) -> NDArray[np.float32]:
        """One depth image of the current scene state (call the scene's ``forward`` first).

        In the ``stereo`` and ``depth`` modes depths outside the camera's ``range_m`` are NaN:
        beyond it a stereo head's depth is too noisy to use (at 8 m one tenth of a pixel of
        disparity is 0.9 m), and both modes keep the same range.
        """
        if self._stereo is not None:
            depth = self._stereo.depth(
                data,
                self._camera_ids["head_camera_left"],
                self._camera_ids["head_camera_right"],
                rng,
            )
            low, high = self.config.range_m
            depth[~((depth >= low) & (depth <= high))] = np.nan
            return depth
        depth = self.exact_depth(data)
        if self.mode == "ideal":
            return depth
        return self.noise.apply(depth, rng)

    def close(self) -> None:
        """Free OpenGL contexts."""
        for part in (self._depth, self._stereo):
            if part is not None:
                part.close()
