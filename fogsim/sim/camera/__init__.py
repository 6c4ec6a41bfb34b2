"""The head camera: intrinsics, exact depth, stereo errors, stereo matching, one mode of them.

* :mod:`~fogsim.sim.camera.intrinsics` — pinhole intrinsics, written into the MuJoCo model;
* :mod:`~fogsim.sim.camera.depth` — exact depth by OpenGL or by ray casting;
* :mod:`~fogsim.sim.camera.error_model` — the stereo error model of the ``depth`` mode;
* :mod:`~fogsim.sim.camera.stereo` — left/right images matched by OpenCV (``stereo`` mode);
* :mod:`~fogsim.sim.camera.head` — :class:`HeadCamera`, the mode a scenario asks for;
* :mod:`~fogsim.sim.camera.noise_model` — the segmentation's sensor model for each mode.

Depth is metres along the optical axis (OpenCV camera z), float32, NaN = no measurement.
"""

from fogsim.sim.camera.depth import DEPTH_BACKENDS, RaycastDepth, RendererDepth
from fogsim.sim.camera.error_model import StereoErrorModel
from fogsim.sim.camera.head import HeadCamera
from fogsim.sim.camera.intrinsics import camera_intrinsics, set_model_intrinsics
from fogsim.sim.camera.noise_model import segmentation_noise_fields
from fogsim.sim.camera.stereo import StereoMatcher

__all__ = [
    "DEPTH_BACKENDS",
    "HeadCamera",
    "RaycastDepth",
    "RendererDepth",
    "StereoErrorModel",
    "StereoMatcher",
    "camera_intrinsics",
    "segmentation_noise_fields",
    "set_model_intrinsics",
]
