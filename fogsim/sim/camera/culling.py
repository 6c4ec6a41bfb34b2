"""Geoms a camera cannot see, left out of its scene: fewer triangles for OpenGL to transform.

The head camera sees the course ahead and below it; the iCub's chest, torso, arms and legs,
45 k of its 52 k mesh triangles, lie wholly outside its view in every frame of the stage
walk, and so does every triangle of the head mesh around the camera (6.6 k more), yet OpenGL
transforms every triangle it is given: on a CPU renderer (Mesa's llvmpipe, what EGL gives a
headless machine) most of an 88 × 72 depth render's time. Before MuJoCo builds the camera's
scene (``mjv_updateScene``), :class:`FrustumCulling` finds the mesh and box geoms whose
bounding box (MuJoCo's ``geom_aabb``, in the geom's frame) lies wholly on the outer side of
one plane of the camera's view, widened by a margin, or, for the meshes that move with the
camera, each of whose triangles does; :meth:`~FrustumCulling.hidden` moves them into a geom
group the renderer does not draw for that call, then back.

The images stay the same bit for bit: each triangle of a culled geom has all three vertices
outside one clipping plane, so OpenGL would have clipped it whole, leaving no fragment, and
every other triangle is drawn as before. What could show a geom outside the view, reflections and
shadows, the scenes have neither (``assets/mjcf/visual.xml``, ``materials.xml``); a model with
a geom of reflective material or a shadow-casting light is never culled
(:attr:`FrustumCulling.active`). tests/test_culling.py renders frames of a stage walk with and
without culling (depth, and the stereo mode's grey images) and compares them.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

import mujoco
import numpy as np
from numpy.typing import NDArray

from fogsim.geometry import MJ_FROM_CV
from mapper.intrinsics import PinholeIntrinsics

MARGIN_PX = 2.0
"""How far beyond the image's border the view is widened [px]: OpenGL clips at the border
itself (a triangle leaves fragments only at pixel centres inside it); the margin covers the
float32 arithmetic of its projection (a relative 1e-7, a thousandth of a pixel) many times."""
MARGIN_M = 0.01
"""How far beyond each plane of the widened view a box must lie to be culled [m]: the bounding
boxes are computed from the meshes' float32 vertices, which OpenGL transforms in float32
(micrometres at the scene's 20 m); a centimetre keeps every doubt on the side of drawing."""
CULLED_TYPES = (mujoco.mjtGeom.mjGEOM_MESH, mujoco.mjtGeom.mjGEOM_BOX)
"""Geom types culled: their rendered triangles lie within ``geom_aabb`` (a plane is drawn as a
large quad and a height field as its grid: always drawn)."""


class FrustumCulling:
    """The geoms wholly outside a camera's view, hidden while its scene is built.

    Args:
        model: The compiled model (its cameras' intrinsics already written into it).
        intrinsics: Intrinsics of the images rendered (their size, principal point, focal
            lengths): the view is the pyramid through the image's border.
        geomgroups: Geom groups the renderer draws; culled geoms go to the first group not
            among them.

    Attributes:
        active: Whether anything can be culled: False when every geom group is drawn (no group
            to hide in) or the model has a geom of reflective material or a shadow-casting
            light.
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        intrinsics: PinholeIntrinsics,
        geomgroups: tuple[int, ...],
    ) -> None:
        self._model = model
        free_groups = sorted(set(range(mujoco.mjNGROUP)) - set(geomgroups))
        shadows = model.vis.quality.shadowsize > 0 and bool(np.any(model.light_castshadow))
        materials = model.geom_matid[model.geom_matid >= 0]
        reflections = bool(np.any(model.mat_reflectance[materials] > 0))
        self.active = bool(free_groups) and not shadows and not reflections
        self._hidden_group = free_groups[0] if free_groups else -1
        culled = np.isin(model.geom_type, CULLED_TYPES) & self.active
        self._geoms = np.flatnonzero(culled)
        boxes = model.geom_aabb.reshape(-1, 6)[self._geoms]
        self._centres_geom = boxes[:, :3]
        self._half_sizes = boxes[:, 3:]
        self._normals_camera = _view_planes(intrinsics)
        self._on_camera_body: dict[int, NDArray[np.intp]] = {}

    def outside(self, data: mujoco.MjData, camera_id: int) -> NDArray[np.intp]:
        """Ids of the geoms wholly outside the widened view of camera ``camera_id`` now.

        A geom is outside when its bounding box lies beyond one of the view's planes by more
        than :data:`MARGIN_M` (its centre's signed distance below minus its extent along the
        plane's normal, ``Σ |n·axis_k| · half_size_k``), or, for a mesh on the camera's own
        body (the head's, around the camera), when each of its triangles does
        (:meth:`_unseen_on_camera_body`).
        """
        if self._geoms.size == 0:
            return self._geoms
        if camera_id not in self._on_camera_body:
            self._on_camera_body[camera_id] = self._unseen_on_camera_body(data, camera_id)
        rotation_cv = data.cam_xmat[camera_id].reshape(3, 3) @ MJ_FROM_CV
        rotations = data.geom_xmat[self._geoms].reshape(-1, 3, 3)
        centres_world = data.geom_xpos[self._geoms] + np.einsum(
            "gij,gj->gi", rotations, self._centres_geom
        )
        centres_camera = (centres_world - data.cam_xpos[camera_id]) @ rotation_cv
        axes_camera = np.einsum("ji,gjk->gik", rotation_cv, rotations)
        distances = centres_camera @ self._normals_camera.T
        extents = np.einsum(
            "gpk,gk->gp",
            np.abs(np.einsum("pi,gik->gpk", self._normals_camera, axes_camera)),
            self._half_sizes,
        )
        boxes_outside = self._geoms[np.any(distances < -extents - MARGIN_M, axis=1)]
        return np.union1d(boxes_outside, self._on_camera_body[camera_id])

    def _unseen_on_camera_body(self, data: mujoco.MjData, camera_id: int) -> NDArray[np.intp]:
        """Meshes on the camera's body whose every triangle lies wholly beyond a plane of its view.

        Beyond by more than :data:`MARGIN_M`, each triangle beyond one of the widened view's
        planes (not necessarily the same for all). Such a mesh never shows (OpenGL clips each
        of its triangles whole), and it moves with the camera, so the answer holds for every
        pose: it is computed once, from the vertices in the camera's frame now. The camera
        sits inside its head mesh, whose bounding box therefore always meets the view.
        """
        body = self._model.cam_bodyid[camera_id]
        rotation_cv = data.cam_xmat[camera_id].reshape(3, 3) @ MJ_FROM_CV
        unseen = []
        for geom in self._geoms[self._model.geom_bodyid[self._geoms] == body]:
            if self._model.geom_type[geom] != mujoco.mjtGeom.mjGEOM_MESH:
                continue
            mesh = self._model.geom_dataid[geom]
            first = self._model.mesh_vertadr[mesh]
            vertices = self._model.mesh_vert[first : first + self._model.mesh_vertnum[mesh]]
            faces = self._model.mesh_face[
                self._model.mesh_faceadr[mesh] : self._model.mesh_faceadr[mesh]
                + self._model.mesh_facenum[mesh]
            ]
            vertices_world = vertices @ data.geom_xmat[geom].reshape(3, 3).T + data.geom_xpos[geom]
            vertices_camera = (vertices_world - data.cam_xpos[camera_id]) @ rotation_cv
            beyond = vertices_camera @ self._normals_camera.T < -MARGIN_M  # (V, planes)
            if np.all(np.any(np.all(beyond[faces], axis=1), axis=1)):
                unseen.append(geom)
        return np.array(unseen, dtype=np.intp)

    @contextmanager
    def hidden(self, data: mujoco.MjData, camera_id: int) -> Iterator[None]:
        """Within: the geoms :meth:`outside` the view are in a group the renderer skips."""
        geoms = self.outside(data, camera_id)
        groups = self._model.geom_group
        saved = groups[geoms].copy()
        groups[geoms] = self._hidden_group
        try:
            yield
        finally:
            groups[geoms] = saved


def _view_planes(intrinsics: PinholeIntrinsics) -> NDArray[np.float64]:
    """Unit inward normals (5, 3), OpenCV camera frame, of the planes bounding the widened view.

    Left, right, top, bottom through the image's border widened by :data:`MARGIN_PX` (pixel u
    covers u − ½ .. u + ½), and the plane through the camera's centre facing forward (what is
    behind the camera is behind OpenGL's near plane too). All pass through the centre: a point
    x is inside when ``n · x >= 0`` for every normal n.
    """
    k = intrinsics
    left = (-0.5 - MARGIN_PX - k.cx) / k.fx
    right = (k.width - 0.5 + MARGIN_PX - k.cx) / k.fx
    top = (-0.5 - MARGIN_PX - k.cy) / k.fy
    bottom = (k.height - 0.5 + MARGIN_PX - k.cy) / k.fy
    normals = np.array(
        [
            [1.0, 0.0, -left],
            [-1.0, 0.0, right],
            [0.0, 1.0, -top],
            [0.0, -1.0, bottom],
            [0.0, 0.0, 1.0],
        ]
    )
    return normals / np.linalg.norm(normals, axis=1, keepdims=True)
