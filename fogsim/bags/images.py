"""Depth images and camera intrinsics from ``sensor_msgs/Image`` and ``sensor_msgs/CameraInfo``.

ROS depth encodings (REP 118): ``32FC1`` is depth along the optical axis in metres (NaN, ±inf
and 0 = no measurement), ``16UC1`` in millimetres (0 = no measurement). Rows may be padded
(``step`` ≥ width × bytes per pixel) and either byte order (``is_bigendian``). ``CameraInfo``'s
``K`` (row-major 3×3) holds fx, fy, cx, cy with pixel centres at integer coordinates — the
mapper's convention; the depth image must already be rectified (no distortion left).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from fogsim.bags.topics import BagError
from mapper.errors import MapperError
from mapper.intrinsics import PinholeIntrinsics

DEPTH_ENCODINGS = {"32FC1": ("f4", 1.0), "16UC1": ("u2", 1e-3)}
"""Encoding → (numpy element type, metres per unit)."""


def _field(message: Any, name: str) -> Any:
    """A CameraInfo field by its ROS 2 name (``k``) or its ROS 1 name (``K``)."""
    return getattr(message, name) if hasattr(message, name) else getattr(message, name.upper())


def depth_m_from_image(message: Any, where: str) -> NDArray[np.float32]:
    """(height, width) float32 depth [m] of a ``sensor_msgs/Image``, NaN = no measurement.

    Args:
        message: The deserialised image.
        where: Names the message in errors (topic and stamp).

    Raises:
        BagError: An encoding other than :data:`DEPTH_ENCODINGS`, or a ``step`` or data length
            that does not fit the image's size.
    """
    encoding = str(message.encoding)
    if encoding not in DEPTH_ENCODINGS:
        raise BagError(
            f"{where}: encoding {encoding!r} is not a depth encoding; allowed: 32FC1 (metres), "
            "16UC1 (millimetres)"
        )
    kind, metres_per_unit = DEPTH_ENCODINGS[encoding]
    dtype = np.dtype(kind).newbyteorder(">" if message.is_bigendian else "<")
    height, width, step = int(message.height), int(message.width), int(message.step)
    data = np.asarray(message.data, dtype=np.uint8)
    row_bytes = width * dtype.itemsize
    if height < 1 or width < 1 or step < row_bytes or data.size < step * height:
        raise BagError(
            f"{where}: a {width}×{height} {encoding} image needs step >= {row_bytes} bytes and "
            f"step × height bytes of data, got step {step} and {data.size} bytes"
        )
    rows = data[: step * height].reshape(height, step)[:, :row_bytes]
    values = np.ascontiguousarray(rows).view(dtype).reshape(height, width)
    depth = values.astype(np.float64) * metres_per_unit
    depth[~(np.isfinite(depth) & (depth > 0.0))] = np.nan
    return depth.astype(np.float32)


def intrinsics_from_camera_info(message: Any, where: str) -> PinholeIntrinsics:
    """The pinhole intrinsics of a ``sensor_msgs/CameraInfo``.

    Raises:
        BagError: Distortion coefficients that are not all 0 (the image is not rectified),
            or a ``K`` the mapper refuses (naming the value).
    """
    distortion = np.asarray(_field(message, "d"), dtype=np.float64)
    if np.any(distortion != 0.0):
        raise BagError(
            f"{where}: distortion coefficients {distortion.tolist()} are not all 0; the mapper "
            "needs a rectified depth image (record the driver's image_rect topic)"
        )
    k = np.asarray(_field(message, "k"), dtype=np.float64).reshape(3, 3)
    try:
        return PinholeIntrinsics(
            int(message.width),
            int(message.height),
            float(k[0, 0]),
            float(k[1, 1]),
            float(k[0, 2]),
            float(k[1, 2]),
        )
    except MapperError as exc:
        raise BagError(f"{where}: {exc}") from exc
