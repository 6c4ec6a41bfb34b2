"""Exact depth images of a MuJoCo camera, by OpenGL rendering or by ray casting.

Depth is metres along the optical axis (OpenCV camera z), float32, NaN = no measurement.

What ``mujoco.Renderer``'s depth returns (probed on MuJoCo 3.17, see tests/test_camera.py):
the linearised z-buffer, i.e. distance along the optical axis in metres — not along the ray —
between ``znear·extent`` and ``zfar·extent``; pixels that hit nothing (or lie beyond the far
plane) read exactly the far distance. We turn those into NaN. A small model extent makes the far
plane short (0.4 m extent → 20 m): that explained an early probe reading "20.0". The camera's
intrinsics must be written into the model first (:mod:`fogsim.sim.camera.intrinsics`).

Ray casting (``mujoco.mj_multiRay``, no OpenGL) shoots one ray per pixel centre with unit
optical-z direction, so its hit distance *is* the depth along the axis. Both agree to
micrometres. The ray caster ignores the body the camera is mounted on: a camera inside its
head mesh sees through it in OpenGL (back faces are culled) and must do so when ray casting.
"""

from __future__ import annotations

import weakref

import mujoco
import numpy as np
from numpy.typing import NDArray

from fogsim.geometry import MJ_FROM_CV
from fogsim.sim.camera.culling import FrustumCulling
from mapper.intrinsics import PinholeIntrinsics

VISIBLE_GEOMGROUPS = (0, 1, 2)
"""Geom groups a camera sees by default: MuJoCo's default visible groups (the scene's
objects, the floor and the robot's meshes are in them)."""


def scene_option(geomgroups: tuple[int, ...]) -> mujoco.MjvOption:
    """Visualisation options that show exactly the geom groups ``geomgroups``."""
    option = mujoco.MjvOption()
    option.geomgroup[:] = 0
    for group in geomgroups:
        option.geomgroup[group] = 1
    return option


class RendererDepth:
    """Depth images by OpenGL (``mujoco.Renderer``; EGL when headless).

    Geoms wholly outside the camera's view are left out of each render
    (:class:`~fogsim.sim.camera.culling.FrustumCulling`: the same images, fewer triangles).

    Args:
        model: The compiled model (camera intrinsics already written into it).
        intrinsics: Intrinsics of the images (their size is the renderer's).
        geomgroups: Geom groups that are visible.
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        intrinsics: PinholeIntrinsics,
        geomgroups: tuple[int, ...] = VISIBLE_GEOMGROUPS,
    ) -> None:
        self.intrinsics = intrinsics
        self._renderer = mujoco.Renderer(model, intrinsics.height, intrinsics.width)
        # Free the GL context when collected or at exit, before EGL itself is torn down.
        self._finalizer = weakref.finalize(self, self._renderer.close)
        self._renderer.enable_depth_rendering()
        self._option = scene_option(geomgroups)
        self._culling = FrustumCulling(model, intrinsics, geomgroups)
        self._far_m = float(model.vis.map.zfar * model.stat.extent)

    def render(self, data: mujoco.MjData, camera_id: int) -> NDArray[np.float32]:
        """(H, W) depth along the optical axis [m] from camera ``camera_id``; NaN = none."""
        with self._culling.hidden(data, camera_id):
            self._renderer.update_scene(data, camera=camera_id, scene_option=self._option)
        depth = self._renderer.render().astype(np.float32, copy=True)
        depth[depth >= np.float32(self._far_m * (1.0 - 1e-5))] = np.nan
        return depth

    def close(self) -> None:
        """Free the OpenGL context (idempotent)."""
        self._finalizer()


class RaycastDepth:
    """Depth images by ray casting (``mujoco.mj_multiRay``; no OpenGL at all).

    Args:
        model: The compiled model.
        intrinsics: Intrinsics of the images.
        geomgroups: Geom groups the rays hit.
        cutoff_m: Longest ray [m]; None = the depth buffer's far plane, as the renderer sees.
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        intrinsics: PinholeIntrinsics,
        geomgroups: tuple[int, ...] = VISIBLE_GEOMGROUPS,
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
