"""The head camera's pinhole intrinsics, from the scenario and written into a MuJoCo model.

MuJoCo renders a camera with the intrinsics in its model (``cam_resolution``,
``cam_sensorsize``, ``cam_intrinsic``): writing :func:`camera_intrinsics` there makes the
renderer use exactly ``PinholeIntrinsics.from_fov(...)``, fx ≠ fy allowed. A principal point
left or right of the image centre renders too (the stereo mode's images extend to the left):
MuJoCo's principal offset is the centre minus ``cx``, in sensor metres (checked against ray
casting in tests/test_camera.py); a vertical offset is refused.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from fogsim.config import CameraConfig
from fogsim.errors import CameraError
from mapper.intrinsics import PinholeIntrinsics

if TYPE_CHECKING:  # a replay's noise model uses camera_intrinsics without MuJoCo
    import mujoco

PIXEL_PITCH_M = 1e-5
"""Notional sensor pixel size [m]: MuJoCo wants a sensor size and a focal length in metres, and
only their ratio (the focal length in pixels) matters."""


def camera_intrinsics(config: CameraConfig, scale: int = 1) -> PinholeIntrinsics:
    """Pinhole intrinsics of the head camera from the scenario (optionally ``scale``×).

    Args:
        config: The scenario's camera table (``width``, ``height`` [px], ``fov_deg``).
        scale: Resolution factor (the stereo mode renders at 2×); the field of view is kept.
    """
    return PinholeIntrinsics.from_fov(
        config.width * scale, config.height * scale, config.fov_deg[0], config.fov_deg[1]
    )


def set_model_intrinsics(
    model: mujoco.MjModel, camera_id: int, intrinsics: PinholeIntrinsics
) -> None:
    """Make MuJoCo render camera ``camera_id`` with exactly these intrinsics.

    Raises:
        CameraError: The principal point is not at the image's vertical centre (only horizontal
            offsets are supported).
    """
    centre_x, centre_y = (intrinsics.width - 1) / 2.0, (intrinsics.height - 1) / 2.0
    if not math.isclose(intrinsics.cy, centre_y):
        raise CameraError(
            f"only principal points at the vertical centre can be rendered: got "
            f"cy={intrinsics.cy} for a {intrinsics.width}x{intrinsics.height} image, allowed "
            f"cy={centre_y}"
        )
    model.cam_resolution[camera_id] = (intrinsics.width, intrinsics.height)
    model.cam_sensorsize[camera_id] = (
        intrinsics.width * PIXEL_PITCH_M,
        intrinsics.height * PIXEL_PITCH_M,
    )
    model.cam_intrinsic[camera_id] = (
        intrinsics.fx * PIXEL_PITCH_M,
        intrinsics.fy * PIXEL_PITCH_M,
        (centre_x - intrinsics.cx) * PIXEL_PITCH_M,
        0.0,
    )
    model.cam_fovy[camera_id] = intrinsics.vfov_deg
