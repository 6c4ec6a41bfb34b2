"""The head camera: intrinsics, exact depth, stereo errors, stereo matching, one mode of them.

* :mod:`~fogsim.sim.camera.intrinsics` — pinhole intrinsics, written into the MuJoCo model;
* :mod:`~fogsim.sim.camera.depth` — exact depth by OpenGL or by ray casting;
* :mod:`~fogsim.sim.camera.error_model` — the stereo error model of the ``depth`` mode;
* :mod:`~fogsim.sim.camera.stereo` — left/right images matched by OpenCV (``stereo`` mode);
* :mod:`~fogsim.sim.camera.head` — :class:`HeadCamera`, the mode a scenario asks for;
* :mod:`~fogsim.sim.camera.noise_model` — the segmentation's sensor model for each mode.

Depth is metres along the optical axis (OpenCV camera z), float32, NaN = no measurement.
"""

from fogsim.lazy import lazy_getattr

_EXPORTS = {
    "DEPTH_BACKENDS": "fogsim.sim.camera.backends",
    "HeadCamera": "fogsim.sim.camera.head",
    "RaycastDepth": "fogsim.sim.camera.depth",
    "RendererDepth": "fogsim.sim.camera.depth",
    "StereoErrorModel": "fogsim.sim.camera.error_model",
    "StereoMatcher": "fogsim.sim.camera.stereo",
    "camera_intrinsics": "fogsim.sim.camera.intrinsics",
    "segmentation_noise_fields": "fogsim.sim.camera.noise_model",
    "set_model_intrinsics": "fogsim.sim.camera.intrinsics",
}
"""The package's names and their modules, imported on first use: the segmentation's
noise model (:mod:`~fogsim.sim.camera.noise_model`, a replay's) needs neither MuJoCo nor OpenGL."""

__all__ = sorted(_EXPORTS)

__getattr__ = lazy_getattr(__name__, _EXPORTS)
