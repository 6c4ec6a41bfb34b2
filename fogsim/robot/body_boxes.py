"""Boxes bounding each geometry of the robot, fixed to its joint frame (for the self-filter)."""

from dataclasses import dataclass

import coal
import numpy as np
import pinocchio as pin
from numpy.typing import NDArray

from fogsim.errors import RobotModelError
from fogsim.robot.meshes import mesh_vertices_m


@dataclass(frozen=True)
class BodyBox:
    """A box bounding one geometry of the robot, fixed to a pinocchio joint frame.

    Attributes:
        joint_id: Pinocchio joint the geometry moves with.
        name: Geometry name.
        transform_box_to_joint: 4×4 box centre and axes in the joint frame.
        half_extents_m: (3,) half sizes along the box axes [m].
    """

    joint_id: int
    name: str
    transform_box_to_joint: NDArray[np.float64]
    half_extents_m: NDArray[np.float64]


def body_boxes(geometry_model: pin.GeometryModel, fix_y_up: bool) -> tuple[BodyBox, ...]:
    """One box per geometry object, axis-aligned in its joint frame.

    Args:
        geometry_model: The geometries MuJoCo renders (visual or collision model).
        fix_y_up: Rotate mesh vertices Y_UP → Z_UP, as the MJCF does.
    """
    return tuple(_geometry_box(g, fix_y_up) for g in geometry_model.geometryObjects)


def _geometry_box(geometry_object: pin.GeometryObject, fix_y_up: bool) -> BodyBox:
    """Axis-aligned (in the joint frame) box around one geometry object."""
    geometry = geometry_object.geometry
    if isinstance(geometry, coal.BVHModelBase):
        vertices = mesh_vertices_m(geometry_object, fix_y_up)
    else:
        if isinstance(geometry, coal.Box):
            half = np.asarray(geometry.halfSide, dtype=float)
        elif isinstance(geometry, coal.Cylinder | coal.Capsule):
            extra = geometry.radius if isinstance(geometry, coal.Capsule) else 0.0
            half = np.array([geometry.radius, geometry.radius, geometry.halfLength + extra])
        elif isinstance(geometry, coal.Sphere):
            half = np.full(3, geometry.radius)
        else:
            raise RobotModelError(
                f"unsupported geometry {type(geometry).__name__} in {geometry_object.name}"
            )
        signs = np.array(np.meshgrid([-1, 1], [-1, 1], [-1, 1])).reshape(3, -1).T
        vertices = signs * half
    placement = geometry_object.placement
    in_joint = vertices @ placement.rotation.T + placement.translation
    low, high = in_joint.min(axis=0), in_joint.max(axis=0)
    transform = np.eye(4)
    transform[:3, 3] = 0.5 * (low + high)
    return BodyBox(
        int(geometry_object.parentJoint), geometry_object.name, transform, 0.5 * (high - low)
    )
