"""The FOG as a ``grid_map_msgs/msg/GridMap`` (ROS 2), in grid_map's conventions.

Our grid (:class:`mapper.grid.GridGeometry`) stores a layer as an array ``[ix, iy]``: ``ix``
grows along world +x from the grid's corner of lowest x and y, ``iy`` along +y; cell
``(ix, iy)``'s centre is ``origin + (ix + ½, iy + ½)·cell_m``. grid_map (``grid_map_core``)
stores a layer as an Eigen matrix of ``rows = nx`` × ``cols = ny`` whose index (0, 0) is the
cell of **largest** x and y: the row grows along −x, the column along −y, so

    row = nx − 1 − ix,    column = ny − 1 − iy,    i.e.  matrix = layer[::-1, ::-1].

The message carries:

* ``header``: the frame's stamp and ``frame_id`` (the world of the believed poses: odometry);
* ``info``: ``resolution`` = ``cell_m``, ``length_x`` = ``nx·cell_m``, ``length_y`` =
  ``ny·cell_m``, ``pose`` = the grid's centre ``origin + (nx, ny)·cell_m / 2`` at z = 0 with
  no rotation (grid_map's cell (r, c) lies at ``centre + (length / 2 − resolution / 2) −
  resolution·(r, c)``);
* ``layers`` :data:`LAYERS` and ``basic_layers`` (``fog_height``: a cell is valid where the FOG
  has a height, i.e. floor or obstacle);
* ``data``: one ``std_msgs/Float32MultiArray`` per layer, column-major as Eigen's default:
  ``layout.dim[0]`` = (``"column_index"``, ny, nx·ny), ``layout.dim[1]`` = (``"row_index"``, nx,
  nx), ``data[c·nx + r]`` = matrix(r, c); NaN = no value (grid_map's invalid cell);
* ``outer_start_index`` = ``inner_start_index`` = 0: grid_map keeps a circular buffer whose
  start indices say where the unwrapped index (0, 0) lies; our grids scroll by copying
  (``recenter``), so the buffer is never wrapped.

Layers: ``fog_height`` (FOG height [m]: floor height of a floor cell, coarse obstacle top of an
obstacle cell), ``fog_type`` (0 unknown, 1 floor, 2 obstacle: :class:`mapper.grid.CellType`),
``floor`` (the fine 2.5-D floor map [m]), ``obstacle`` (eq. 10's obstacle heights [m]),
``ceiling`` (the ceiling map [m]). ``grid_map_msgs`` is not in rosbags' type stores: its two
message definitions are registered from their ``.msg`` text (:func:`register_grid_map_types`).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import NDArray
from rosbags.typesys import get_types_from_msg
from rosbags.typesys.store import Typestore

from mapper.grid import GridGeometry

GRID_MAP_TYPE = "grid_map_msgs/msg/GridMap"
GRID_MAP_INFO_TYPE = "grid_map_msgs/msg/GridMapInfo"
GRID_MAP_MSG = """\
std_msgs/Header header
grid_map_msgs/GridMapInfo info
string[] layers
string[] basic_layers
std_msgs/Float32MultiArray[] data
uint16 outer_start_index
uint16 inner_start_index
"""
"""``grid_map_msgs/msg/GridMap.msg`` of grid_map's ROS 2 branches (comments left out)."""
GRID_MAP_INFO_MSG = """\
float64 resolution
float64 length_x
float64 length_y
geometry_msgs/Pose pose
"""
"""``grid_map_msgs/msg/GridMapInfo.msg`` of grid_map's ROS 2 branches."""

LAYERS = ("fog_height", "fog_type", "floor", "obstacle", "ceiling")
BASIC_LAYERS = ("fog_height",)


def register_grid_map_types(typestore: Typestore) -> None:
    """Add ``grid_map_msgs/msg/GridMap`` and ``GridMapInfo`` to a ROS 2 type store."""
    types = get_types_from_msg(GRID_MAP_INFO_MSG, GRID_MAP_INFO_TYPE)
    types.update(get_types_from_msg(GRID_MAP_MSG, GRID_MAP_TYPE))
    typestore.register(types)


def grid_map_index(ix: int, iy: int, nx: int, ny: int) -> tuple[int, int]:
    """grid_map's (row, column) of our cell ``(ix, iy)`` in an ``nx`` × ``ny`` grid."""
    return nx - 1 - ix, ny - 1 - iy


def grid_map_data(layer_xy: NDArray[np.floating]) -> NDArray[np.float32]:
    """A layer ``[ix, iy]`` as grid_map's column-major float32 data (``data[c·nx + r]``)."""
    matrix = np.asarray(layer_xy, dtype=np.float32)[::-1, ::-1]  # (row, column)
    return np.ascontiguousarray(matrix.ravel(order="F"))


def grid_map_center_xy(geometry: GridGeometry) -> tuple[float, float]:
    """World (x, y) of the grid's centre [m]: grid_map's map position."""
    ox, oy = geometry.origin_xy_m
    return (ox + 0.5 * geometry.nx * geometry.cell_m, oy + 0.5 * geometry.ny * geometry.cell_m)


def stamp(typestore: Typestore, stamp_ns: int) -> Any:
    """A ``builtin_interfaces/msg/Time`` of ``stamp_ns``."""
    sec, nanosec = divmod(int(stamp_ns), 1_000_000_000)
    return typestore.types["builtin_interfaces/msg/Time"](sec=sec, nanosec=nanosec)


def pose_message(
    typestore: Typestore, position_m: tuple[float, float, float], yaw_rad: float
) -> Any:
    """A ``geometry_msgs/msg/Pose`` at ``position_m`` turned by ``yaw_rad`` about z."""
    types = typestore.types
    half = 0.5 * float(yaw_rad)
    return types["geometry_msgs/msg/Pose"](
        position=types["geometry_msgs/msg/Point"](*(float(v) for v in position_m)),
        orientation=types["geometry_msgs/msg/Quaternion"](
            x=0.0, y=0.0, z=float(np.sin(half)), w=float(np.cos(half))
        ),
    )


def grid_map_message(
    typestore: Typestore,
    geometry: GridGeometry,
    layers: Mapping[str, NDArray[np.floating]],
    stamp_ns: int,
    frame_id: str,
) -> Any:
    """The ``grid_map_msgs/msg/GridMap`` of the layers (see the module doc).

    Args:
        typestore: A ROS 2 type store with the grid_map types registered.
        geometry: Where the grid lies.
        layers: :data:`LAYERS` name → (nx, ny) array ``[ix, iy]`` (NaN = none).
        stamp_ns: The frame's time [ns].
        frame_id: The world frame's name.
    """
    types = typestore.types
    nx, ny = geometry.nx, geometry.ny
    dimension = types["std_msgs/msg/MultiArrayDimension"]
    layout = types["std_msgs/msg/MultiArrayLayout"](
        dim=[dimension("column_index", ny, nx * ny), dimension("row_index", nx, nx)],
        data_offset=0,
    )
    array = types["std_msgs/msg/Float32MultiArray"]
    return types[GRID_MAP_TYPE](
        header=types["std_msgs/msg/Header"](stamp=stamp(typestore, stamp_ns), frame_id=frame_id),
        info=types[GRID_MAP_INFO_TYPE](
            resolution=float(geometry.cell_m),
            length_x=nx * geometry.cell_m,
            length_y=ny * geometry.cell_m,
            pose=pose_message(typestore, (*grid_map_center_xy(geometry), 0.0), 0.0),
        ),
        layers=list(LAYERS),
        basic_layers=list(BASIC_LAYERS),
        data=[array(layout=layout, data=grid_map_data(layers[name])) for name in LAYERS],
        outer_start_index=0,
        inner_start_index=0,
    )
