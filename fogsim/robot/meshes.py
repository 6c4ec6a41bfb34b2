"""Vertices and faces of the meshes pinocchio loaded (coal BVH models), in the geometry's frame."""

import numpy as np
import pinocchio as pin
from numpy.typing import NDArray

_Y_UP_TO_Z_UP = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
"""+90° about x: turns a mesh stored Y_UP into Z_UP (see `MeshQuirks.fix_y_up_meshes`)."""


def mesh_vertices_m(geometry_object: pin.GeometryObject, fix_y_up: bool) -> NDArray[np.float64]:
    """(N, 3) vertices [m] of a mesh geometry, Y_UP fixed if asked, then scaled by its meshScale."""
    vertices = np.asarray(geometry_object.geometry.vertices(), dtype=np.float64)
    if fix_y_up:
        vertices = vertices @ _Y_UP_TO_Z_UP.T
    return vertices * np.asarray(geometry_object.meshScale, dtype=float)


def mesh_faces(geometry_object: pin.GeometryObject) -> NDArray[np.int32]:
    """(M, 3) vertex indices of a mesh geometry's triangles."""
    geometry = geometry_object.geometry
    faces = np.empty((geometry.num_tris, 3), dtype=np.int32)
    for i in range(geometry.num_tris):
        tri = geometry.tri_indices(i)
        faces[i] = (tri[0], tri[1], tri[2])
    return faces
